//! Empty: the build-dependencies of this crate only pin host-side features (see Cargo.toml).
fn main() {}
