//! Typed errors of the geometry crate; every variant names the file and the element.

use thiserror::Error;

/// Mesh loading and validation errors.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GeometryError {
    /// The file could not be read.
    #[error("{file}: cannot read: {reason}")]
    Io { file: String, reason: String },
    /// A parse error at a line (1-based) or element.
    #[error("{file}:{line}: {reason}")]
    Parse {
        file: String,
        line: usize,
        reason: String,
    },
    /// A semantic problem with an element (vertex or face index, 0-based).
    #[error("{file}: {element} {index}: {reason}")]
    Invalid {
        file: String,
        element: &'static str,
        index: usize,
        reason: String,
    },
    /// The mesh has no triangles or no vertices.
    #[error("{file}: empty mesh ({vertices} vertices, {triangles} triangles)")]
    Empty {
        file: String,
        vertices: usize,
        triangles: usize,
    },
    /// The mesh as a whole is outside the supported domain (its size).
    #[error("{file}: {reason}")]
    Domain { file: String, reason: String },
    /// An unknown bundled name or unsupported extension.
    #[error("{0}")]
    Unknown(String),
}
