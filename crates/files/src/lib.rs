//! Files in and out, safely — the ground floor every writer and reader of the project stands on
//! (docs/ARCHITECTURE.md):
//!
//! | module | what |
//! |---|---|
//! | [`atomic`] | durable output: a temporary beside the target, `fsync`, rename, the folder's `fsync`; several files, or a folder, as a unit |
//! | [`input`] | regular-file input: FIFOs, directories and dangling links refused by name |
//! | [`table`] | a CSV table read back (results files): cells by column name, a missing column reported |
//!
//! Nothing numerical: it imports no crate of the project.

pub mod atomic;
pub mod error;
pub mod input;
pub mod table;

pub use atomic::{write_atomic, write_atomic_all, write_atomic_bytes, Staging};
pub use error::Error;
pub use table::Table;
