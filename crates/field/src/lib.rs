//! Fields of visibility around an entity: visibility sampling at a point (full sphere or the
//! hemisphere facing the entity), base-sphere visibility (BSV) on layouts of the bounding sphere
//! with spherical-Delaunay interpolation, and ray-traced truth (band-limited SH and full-frequency
//! maps). Built on the SH core and the geometry crate's [`Occluder`]; knows nothing of configs,
//! files or GPUs. Conventions: docs/conventions.md §2 (frames), §4 (fields), §7 (on-surface samples).

pub mod alpha;
pub mod bsv;
pub mod delaunay;
pub mod error;
pub mod evaluator;
pub mod extrapolate;
pub mod frame;
pub mod metrics;
pub mod midrange;
pub mod probe;
pub mod radiance;
pub mod receivers;
pub mod selfshadow;
pub mod shading;
pub mod shexp;
pub mod shexp_ol;
pub mod sphereset;
pub mod srf;
pub mod subvolume;
pub mod truth;
pub mod union;
pub mod visibility;

pub use bsv::{Bsv, BsvSample, Layout};
pub use frame::LocalFrame;
pub use radiance::{Emitter, Radiant, SphereEmitter};
pub use shscale_geometry::Occluder;
pub use visibility::{Frame, VisibilitySampler};

pub use error::FieldError;
