//! One vocabulary for every command, the runner and the figures: what a mesh name means
//! (`sphere`, the procedural shapes, the bundled meshes, a file path) and the k range a set of
//! probe radii needs, the angular scaling τ and η by name. Resolved here only.

use crate::LabError;
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{bundled, shapes, AnalyticSphere, Mesh, MeshBvh, Occluder, Sphere};

/// The procedural shapes, by name.
pub const PROCEDURAL: &[&str] = &["bird", "egg", "sponge", "plane"];

/// Every name a mesh key accepts besides a file path, for messages.
pub fn mesh_names() -> String {
    format!(
        "\"sphere\" (analytic), the procedural {} or the bundled {}",
        PROCEDURAL.join(", "),
        bundled::names().join(", ")
    )
}

/// Whether `name` names a mesh: the analytic sphere, a procedural shape, a bundled mesh or an
/// existing file.
pub fn mesh_exists(name: &str) -> bool {
    name == "sphere"
        || PROCEDURAL.contains(&name)
        || bundled::names().contains(&name)
        || std::path::Path::new(name).is_file()
}

/// The mesh of a name as built or stored (not moved or scaled); not for `sphere`.
pub fn mesh(name: &str) -> Result<Mesh, LabError> {
    Ok(match name {
        "bird" => shapes::bird(),
        "egg" => shapes::egg(1.0, 0.5, 22, 24),
        "sponge" => shapes::box_block(glam::DVec3::new(1.0, 0.5, 0.3), 37),
        "plane" => shapes::plane(2.0, 2.0, 92, 92),
        "sphere" => {
            return Err(LabError::Config(
                "mesh \"sphere\" is the analytic sphere, not a triangle mesh".into(),
            ))
        }
        _ => bundled::resolve(name)?,
    })
}

/// An occluder by name in its own coordinates: the analytic unit sphere or a mesh behind a BVH.
pub fn occluder(name: &str) -> Result<Box<dyn Occluder>, LabError> {
    if name == "sphere" {
        return Ok(Box::new(AnalyticSphere::unit()));
    }
    Ok(Box::new(MeshBvh::build(
        &mesh(name)?,
        UpdateStrategy::Rebuild,
    )))
}

/// An occluder placed in the unit sphere (its minimal bounding sphere centred at the origin with
/// radius 1), as experiments use it (results are in units of r): the occluder, the closed-form
/// sphere when analytic, and the mesh otherwise.
pub struct UnitOccluder {
    pub occ: Box<dyn Occluder>,
    pub analytic: Option<Sphere>,
    pub mesh: Option<Mesh>,
}

/// See [`UnitOccluder`].
pub fn unit_occluder(name: &str) -> Result<UnitOccluder, LabError> {
    if name == "sphere" {
        let s = AnalyticSphere::unit();
        return Ok(UnitOccluder {
            occ: Box::new(s),
            analytic: Some(s.sphere),
            mesh: None,
        });
    }
    let m = crate::render::placed_mesh(name, glam::DVec3::ZERO, 1.0, false)?;
    Ok(UnitOccluder {
        occ: Box::new(MeshBvh::build(&m, UpdateStrategy::Rebuild)),
        analytic: None,
        mesh: Some(m),
    })
}

/// The k range a k-table needs for probe radii (× r) sampled at radius `s` (× r):
/// [`shscale_field::probe::k_range`], re-exported so every caller finds it here.
pub use shscale_field::probe::k_range;

/// The family of angular scaling functions named in a config (`tau = "cone" | "midrange"`): the
/// cone approximation with half-angle `alpha_deg` in (0, 90), or mid-range lighting (α unused).
/// Errors name the key at fault.
pub fn tau_family(
    tau: &str,
    alpha_deg: f64,
) -> Result<shscale_scaling::TauFamily, crate::exp::KeyError> {
    use crate::exp::KeyError;
    match tau {
        "cone" if !(alpha_deg > 0.0 && alpha_deg < 90.0) => Err(KeyError::new(
            "alpha_deg",
            format!("{alpha_deg} is outside (0, 90)"),
        )),
        "cone" => Ok(shscale_scaling::TauFamily::Cone {
            alpha: alpha_deg.to_radians(),
        }),
        "midrange" => Ok(shscale_scaling::TauFamily::MidRange),
        other => Err(KeyError::new(
            "tau",
            format!("{other:?} is not cone or midrange"),
        )),
    }
}

/// The angular scaling function τ of [`tau_family`] at k (k = d/r > 0 for the cone, k = d/R
/// in (−1, 1) for mid-range lighting). Errors name the key at fault.
pub fn scaling_tau(
    tau: &str,
    k: f64,
    alpha_deg: f64,
) -> Result<Box<dyn shscale_scaling::AngularScaling>, crate::exp::KeyError> {
    tau_family(tau, alpha_deg)?
        .at(k)
        .map_err(|e| crate::exp::KeyError::new("k", e.to_string()))
}

/// The largest hemisphere resolution of a single-point visibility query (`shscale visibility`,
/// Python `visibility`): 2·1024² rays per point.
pub const MAX_VISIBILITY_RES: usize = 1024;

/// Check query points against an occluder: each within
/// [`shscale_geometry::ray::MAX_QUERY_DISTANCE`] bounding radii (beyond it the ray tracer loses
/// its precision), and — for the `local` frame — not at the bounding-sphere centre, where the
/// frame is undefined. The error names the point by its index.
pub fn check_query_points(
    occ: &dyn Occluder,
    name: &str,
    points: &[glam::DVec3],
    local_frame: bool,
) -> Result<(), String> {
    let b = occ.bounding_sphere();
    for (i, p) in points.iter().enumerate() {
        let far = (*p - b.center).length() / b.radius;
        if far.is_nan() || far > shscale_geometry::ray::MAX_QUERY_DISTANCE {
            return Err(format!(
                "point {i} ({:e}, {:e}, {:e}) is {far:.3e} bounding radii from {name}, more than {:e}, the farthest a query keeps its precision",
                p.x,
                p.y,
                p.z,
                shscale_geometry::ray::MAX_QUERY_DISTANCE
            ));
        }
        if local_frame && (*p - b.center).length() == 0.0 {
            return Err(format!(
                "point {i}: the local frame is undefined at the bounding-sphere centre"
            ));
        }
    }
    Ok(())
}

/// `plain` or `energy`: the name of η in configs and CSV columns.
pub fn eta_name(eta: shscale_scaling::Eta) -> &'static str {
    match eta {
        shscale_scaling::Eta::Plain => "plain",
        shscale_scaling::Eta::Energy => "energy",
    }
}
