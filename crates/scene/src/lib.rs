//! Scenes of shscale: scene files (TOML, raw → resolved, the camera inside, every error naming
//! the file, line and field), the one vocabulary of meshes, deformers, τ families and k ranges
//! with the sampling bounds every experiment kind shares, the frame set-up shared by the CPU and
//! GPU sequence paths, rendering a scene's receiver plane with any of the visibility evaluators
//! and through a camera, the GPU sequence path, the Table 1 bench and the kernel benches. Files
//! and configs are the runner's ([`shscale_runner`]); the numerical crates stay free of both.
//!
//! | module | what it owns | imports (inside the crate) |
//! |---|---|---|
//! | [`error`] | [`Error`] | — |
//! | [`vocab`] | meshes, placement, τ families, k ranges, sampling bounds | `error` |
//! | [`scene`] | scene files, lights, the camera | `vocab`, `error` |
//! | [`frame`] | one frame's set-up: lights, receivers, posed meshes, k-tables | `scene`, `vocab` |
//! | [`render`] | the CPU receiver-plane render and sequence | `frame`, `scene`, `vocab` |
//! | [`sequence`] | sequences with every method, per-frame errors | `render`, `scene` |
//! | [`camera`] | camera images of a render | `render`, `scene`, `vocab` |
//! | [`gpu_path`] | opening the GPU, the GPU sequence, GPU BSV timing | `frame`, `render`, `scene` |
//! | [`gpu_sets`] | sphere sets on the GPU sequence path | `frame`, `render`, `scene` |
//! | [`bench`] | Table 1: CPU and GPU sequences per stage | `gpu_path`, `render`, `scene` |
//! | [`bench_methods`] | Table 1 per method on the CPU, with per-frame errors | `sequence`, `render`, `scene` |
//! | [`kernels`] | `shscale bench rays|bsv|sh` against the peers | `error` |
//! | [`calibrate`] | this machine's ray rate, to scale `--dry-run`'s estimates | — |

pub mod bench;
pub mod bench_methods;
pub mod cached;
pub mod calibrate;
pub mod camera;
pub mod combine;
pub mod error;
pub mod frame;
pub mod gpu_field;
pub mod gpu_methods;
pub mod gpu_parts;
pub mod gpu_path;
pub mod gpu_radial;
pub mod gpu_sets;
pub mod gpu_truth;
pub mod kernels;
pub mod method;
pub mod render;
pub mod scene;
pub mod sequence;
pub mod settings;
pub mod vocab;

pub use error::Error;
