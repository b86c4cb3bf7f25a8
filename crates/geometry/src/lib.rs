//! Geometry for shadow fields: triangle meshes (OBJ/PLY, validated, bundled by name), procedural
//! shapes and deformers, minimal bounding spheres, and ray casting against meshes (BVH via obvhs)
//! or the analytic sphere. Knows nothing of SH, configs or files beyond mesh loading.

pub mod bsphere;
pub mod bundled;
pub mod deform;
pub mod error;
pub mod inscribed;
mod load;
pub mod mesh;
pub mod partition;
pub mod ply;
pub mod ray;
pub mod shapes;
pub mod wide;

pub use bsphere::{min_enclosing_sphere, Sphere};
pub use error::GeometryError;
pub use mesh::Mesh;
pub use ray::{AnalyticSphere, BruteForce, MeshBvh, Occluder, RAY_EPS};

pub use glam::DVec3;
