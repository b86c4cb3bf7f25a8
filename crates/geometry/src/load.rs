//! Loading a mesh file: the extension chooses the reader (OBJ in [`crate::mesh`], PLY in
//! [`crate::ply`]).

use crate::error::GeometryError;
use crate::mesh::Mesh;
use std::path::Path;

impl Mesh {
    /// Load an OBJ (tobj, triangulated) or PLY file; the extension decides.
    pub fn load(path: &Path) -> Result<Self, GeometryError> {
        let name = path.display().to_string();
        // Only a regular file is read: a FIFO would block, a device never end.
        let meta = std::fs::metadata(path).map_err(|e| GeometryError::Io {
            file: name.clone(),
            reason: e.to_string(),
        })?;
        if !meta.is_file() {
            return Err(GeometryError::Io {
                file: name,
                reason:
                    "is not a regular file (a directory, FIFO or device); a mesh must be a file"
                        .into(),
            });
        }
        let bytes = std::fs::read(path).map_err(|e| GeometryError::Io {
            file: name.clone(),
            reason: e.to_string(),
        })?;
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("obj") => Self::from_obj_bytes(&name, &bytes),
            Some("ply") => crate::ply::parse_ply(&name, &bytes),
            _ => Err(GeometryError::Unknown(format!(
                "{name}: unsupported mesh format (expected .obj or .ply)"
            ))),
        }
    }
}
