//! No code. This crate asks for the union of the features that the workspace's build commands
//! turn on in shared dependencies, so that `cargo run`, `cargo test --workspace` and maturin
//! compile each dependency once, alike (see `Cargo.toml` and docs/building.md).
