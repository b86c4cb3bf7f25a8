//! Meshes bundled with the binary (assets/meshes, attribution in assets/SOURCES.md), addressable
//! by name.

use crate::error::GeometryError;

use crate::mesh::Mesh;

/// `(name, OBJ text)` of every bundled mesh.
pub const BUNDLED: &[(&str, &str)] = &[
    ("bunny", include_str!("../../../assets/meshes/bunny.obj")),
    ("duck", include_str!("../../../assets/meshes/duck.obj")),
    (
        "dragon_19k",
        include_str!("../../../assets/meshes/dragon_19k.obj"),
    ),
    ("knot", include_str!("../../../assets/meshes/knot.obj")),
    ("teapot", include_str!("../../../assets/meshes/teapot.obj")),
];

/// Names of the bundled meshes.
pub fn names() -> Vec<&'static str> {
    BUNDLED.iter().map(|(n, _)| *n).collect()
}

/// A bundled mesh by name.
pub fn load(name: &str) -> Result<Mesh, GeometryError> {
    let (_, text) = BUNDLED.iter().find(|(n, _)| *n == name).ok_or_else(|| {
        GeometryError::Unknown(format!(
            "no bundled mesh {name:?} (bundled: {})",
            names().join(", ")
        ))
    })?;
    Mesh::from_obj_bytes(name, text.as_bytes())
}

/// A mesh by bundled name or file path (a path if it contains a `/` or a `.` extension).
pub fn resolve(spec: &str) -> Result<Mesh, GeometryError> {
    if BUNDLED.iter().any(|(n, _)| *n == spec) {
        load(spec)
    } else {
        Mesh::load(std::path::Path::new(spec))
    }
}
