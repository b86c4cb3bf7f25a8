//! One vocabulary for every command, the runner and the figures: what a mesh name means
//! (`sphere`, the procedural shapes, the bundled meshes, a file path) and the k range a set of
//! probe radii needs, the angular scaling τ and η by name. Resolved here only.

use crate::error::Error;
use glam::DVec3;
use shscale_field::Layout;
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::{bundled, shapes, AnalyticSphere, Mesh, MeshBvh, Occluder, Sphere};
use shscale_runner::check::Ends;
use shscale_runner::KeyError;
use shscale_scaling::{Interp, Spacing};

/// The procedural shapes, by name.
pub(crate) const PROCEDURAL: &[&str] = &["bird", "egg", "sponge", "plane"];

/// Every name a mesh key accepts besides a file path, for messages.
pub(crate) fn mesh_names() -> String {
    format!(
        "\"sphere\" (analytic), the procedural {} or the bundled {}",
        PROCEDURAL.join(", "),
        bundled::names().join(", ")
    )
}

/// Whether `name` names a mesh: the analytic sphere, a procedural shape, a bundled mesh or an
/// existing file.
pub(crate) fn mesh_exists(name: &str) -> bool {
    builtin_mesh(name) || std::path::Path::new(name).is_file()
}

/// Whether `name` is a built-in mesh (the analytic sphere, a procedural shape, a bundled mesh):
/// these names win over files of the same name in the working directory.
pub(crate) fn builtin_mesh(name: &str) -> bool {
    name == "sphere" || PROCEDURAL.contains(&name) || bundled::names().contains(&name)
}

/// What reading the mesh `name` reads ([`shscale_runner::Kind::inputs`], named by the
/// parameter `key`): nothing for the analytic sphere and the procedural shapes (made by the
/// code, which the numerical fingerprint covers), the embedded text of a bundled mesh, else the
/// file at `name` (relative to the working directory, as [`mesh`] opens it).
pub fn mesh_inputs(key: &str, name: &str) -> Vec<shscale_runner::inputs::Input> {
    use shscale_runner::inputs::Input;
    if name == "sphere" || PROCEDURAL.contains(&name) {
        return Vec::new();
    }
    if let Some((n, text)) = bundled::BUNDLED.iter().find(|(n, _)| *n == name) {
        return vec![Input::Embedded {
            key: key.into(),
            name: (*n).into(),
            bytes: text.as_bytes(),
        }];
    }
    vec![Input::File {
        key: key.into(),
        path: name.into(),
    }]
}

/// The mesh of a name as built or stored (not moved or scaled); not for `sphere`.
pub fn mesh(name: &str) -> Result<Mesh, Error> {
    Ok(match name {
        "bird" => shapes::bird(),
        "egg" => shapes::egg(1.0, 0.5, 22, 24),
        "sponge" => shapes::box_block(glam::DVec3::new(1.0, 0.5, 0.3), 37),
        "plane" => shapes::plane(2.0, 2.0, 92, 92),
        "sphere" => {
            return Err(Error::config(
                "mesh \"sphere\" is the analytic sphere, not a triangle mesh".into(),
            ))
        }
        _ => bundled::resolve(name)?,
    })
}

/// An occluder by name in its own coordinates: the analytic unit sphere or a mesh behind a BVH.
pub fn occluder(name: &str) -> Result<Box<dyn Occluder>, Error> {
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
pub fn unit_occluder(name: &str) -> Result<UnitOccluder, Error> {
    if name == "sphere" {
        let s = AnalyticSphere::unit();
        return Ok(UnitOccluder {
            occ: Box::new(s),
            analytic: Some(s.sphere),
            mesh: None,
        });
    }
    let m = crate::vocab::placed_mesh(name, glam::DVec3::ZERO, 1.0, false)?;
    Ok(UnitOccluder {
        occ: Box::new(MeshBvh::build(&m, UpdateStrategy::Rebuild)),
        analytic: None,
        mesh: Some(m),
    })
}

/// The k range a k-table needs for probe radii (× r) sampled at radius `s` (× r):
/// [`shscale_field::probe::k_range`], re-exported so every caller finds it here.
pub use shscale_field::probe::k_range;

/// A cone half-angle α in degrees, finite and in the open interval (0, 90) — a cone of 0° has no
/// inside and one of 90° no outside — checked once, where a key or flag is read: the one
/// statement of the bound in the code (configs, scene files, `demo` and `matrix` flags, the
/// extrapolation's keys). Holding one is the proof it was checked.
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd)]
pub struct AlphaDeg(f64);

impl AlphaDeg {
    /// The open interval of degrees.
    pub const RANGE: (f64, f64) = (0.0, 90.0);

    /// `deg` checked; the message states the range tested (`95 is outside (0, 90)`).
    pub fn new(deg: f64) -> Result<Self, String> {
        shscale_runner::check::real(deg, Self::RANGE.0, Self::RANGE.1, Ends::Open).map(Self)
    }

    /// [`AlphaDeg::new`] of the key `key` (its error names the key).
    pub fn of_key(key: &str, deg: f64) -> Result<Self, KeyError> {
        Self::new(deg).map_err(|m| KeyError::new(key, m))
    }

    pub fn degrees(self) -> f64 {
        self.0
    }

    pub fn radians(self) -> f64 {
        self.0.to_radians()
    }
}

/// The family of angular scaling functions named in a config (`tau = "cone" | "midrange"`): the
/// cone approximation with half-angle `alpha_deg` in (0, 90), or mid-range lighting (α unused).
/// Errors name the key at fault.
pub fn tau_family(tau: &str, alpha_deg: f64) -> Result<shscale_scaling::TauFamily, KeyError> {
    use shscale_runner::KeyError;
    match tau {
        "cone" => Ok(shscale_scaling::TauFamily::Cone {
            alpha: AlphaDeg::of_key("alpha_deg", alpha_deg)?.radians(),
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
) -> Result<Box<dyn shscale_scaling::AngularScaling>, KeyError> {
    tau_family(tau, alpha_deg)?
        .at(k)
        .map_err(|e| KeyError::new("k", e.to_string()))
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

/// A mesh by name — procedural (`bird`, `egg`, `sponge`, `plane`), bundled, or a path — rotated
/// to z-up (bundled/path meshes with `up_is_y`), scaled and moved so its minimal bounding sphere
/// is `(center, radius)`.
pub fn placed_mesh(mesh: &str, center: DVec3, radius: f64, up_is_y: bool) -> Result<Mesh, Error> {
    let mut m = self::mesh(mesh)?;
    if up_is_y && !PROCEDURAL.contains(&mesh) {
        for p in &mut m.positions {
            *p = DVec3::new(p.x, -p.z, p.y);
        }
    }
    m.fit_to(&Sphere { center, radius });
    Ok(m)
}

// The sampling bounds every base-sphere kind shares (probe, alpha_fit, budget, shadows, srf).

/// The most probe radii a run may have.
pub const MAX_RADII: usize = 64;

/// The largest SH order of a probe run.
pub const MAX_ORDER: usize = 16;

/// The largest hemisphere resolution H (H² rays per BSV sample).
pub const MAX_HEMISPHERE_RES: usize = 256;

/// The largest truth resolution T (4T² rays per probe).
pub const MAX_TRUTH_RES: usize = shscale_field::truth::MAX_TRUTH_RES;

/// The most tabulated k values.
pub const MAX_K_COUNT: usize = 10_000;

/// `"exp" | "uniform" | "chebyshev"`.
pub fn parse_spacing(s: &str) -> Result<Spacing, String> {
    match s {
        "exp" => Ok(Spacing::Exp),
        "uniform" => Ok(Spacing::Uniform),
        "chebyshev" => Ok(Spacing::Chebyshev),
        _ => Err(format!(
            "{s:?} is not one of \"exp\", \"uniform\", \"chebyshev\""
        )),
    }
}

/// `"linear" | "cubic"`.
pub fn parse_interp(s: &str) -> Result<Interp, String> {
    match s {
        "linear" => Ok(Interp::Linear),
        "cubic" => Ok(Interp::Cubic),
        _ => Err(format!("{s:?} is not one of \"linear\", \"cubic\"")),
    }
}

/// The checks of the keys every base-sphere study shares (`probe`, `alpha_fit`, `budget`):
/// `mesh` known, `order` in 1..=[`MAX_ORDER`], `alpha_deg` in (0, 90), `layout` parsed,
/// `hemisphere_res` in 1..=[`MAX_HEMISPHERE_RES`]; the error names the first bad key.
pub fn check_sampling_keys(
    mesh: &str,
    order: usize,
    alpha_deg: f64,
    layout: &str,
    hemisphere_res: usize,
) -> Result<(), KeyError> {
    if !builtin_mesh(mesh) {
        if let Err(e) = shscale_files::input::regular_file(std::path::Path::new(mesh)) {
            // Something is there, but not a file a mesh can be read from (a FIFO, a directory,
            // a symlink loop): say that, not "unknown".
            return Err(KeyError::new("mesh", e.to_string()));
        }
    }
    if !mesh_exists(mesh) {
        // A path is read relative to the working directory: say where that is.
        let resolved = std::path::absolute(mesh)
            .map(|p| format!(" (looked for {})", p.display()))
            .unwrap_or_default();
        return Err(KeyError::new(
            "mesh",
            format!(
                "{mesh:?} is neither {} nor an existing .obj/.ply file{resolved}",
                mesh_names()
            ),
        ));
    }
    KeyError::int("order", order, 1, MAX_ORDER)?;
    AlphaDeg::of_key("alpha_deg", alpha_deg)?;
    Layout::parse(layout).map_err(|e| KeyError::new("layout", e.to_string()))?;
    KeyError::int("hemisphere_res", hemisphere_res, 1, MAX_HEMISPHERE_RES)?;
    Ok(())
}

/// How visibility at a point is ray traced (`shscale visibility --quadrature`, the Python
/// `visibility`): the converged stratified truth (`4T²` rays, with its own error estimate) or
/// the method's Gauss–Legendre rings (`2H²` rays).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quadrature {
    Stratified,
    Gauss,
}

shscale_names::names!(Quadrature { Stratified = "stratified", Gauss = "gauss" });

impl Quadrature {
    /// `"stratified"` or `"gauss"`.
    pub fn parse(s: &str) -> Result<Self, String> {
        Self::from_name(s).ok_or_else(|| format!("{s:?} is not \"stratified\" or \"gauss\""))
    }
}

/// Ray-traced visibility at one point, projected to SH.
pub struct PointVisibility {
    pub coeffs: Vec<f64>,
    pub rays: usize,
    /// The stratified truth's own error estimate (absolute, and relative to the occlusion).
    pub error: Option<f64>,
    pub rel_error: Option<f64>,
}

/// The one visibility query of the CLI and the Python package, set up once for many points.
pub enum VisibilityQuery {
    Stratified(shscale_field::truth::TruthSampler),
    Gauss(shscale_field::VisibilitySampler),
}

impl VisibilityQuery {
    /// The query of `quadrature` at `order`: `hemisphere_res` H for Gauss, `truth_res` T and
    /// `seed` for the stratified truth (each checked by its sampler).
    pub fn new(
        quadrature: Quadrature,
        order: usize,
        hemisphere_res: usize,
        truth_res: usize,
        seed: u64,
    ) -> Result<Self, Error> {
        Ok(match quadrature {
            Quadrature::Gauss => Self::Gauss(shscale_field::VisibilitySampler::new(
                order,
                hemisphere_res,
            )?),
            Quadrature::Stratified => Self::Stratified(shscale_field::truth::TruthSampler::new(
                order, truth_res, seed,
            )?),
        })
    }

    /// The rays one point costs: `2H²` (Gauss, both hemispheres) or `4T²` (stratified truth).
    pub fn rays_per_point(&self) -> usize {
        match self {
            Self::Gauss(s) => 2 * s.rays_per_hemisphere(),
            Self::Stratified(ts) => ts.rays(),
        }
    }

    /// Visibility of `occ` at `p` over the full sphere, in `frame`.
    pub fn at(&self, occ: &dyn Occluder, p: DVec3, frame: shscale_field::Frame) -> PointVisibility {
        match self {
            Self::Gauss(s) => {
                let (coeffs, rays) = s.full_sphere(occ, p, frame);
                PointVisibility {
                    coeffs,
                    rays,
                    error: None,
                    rel_error: None,
                }
            }
            Self::Stratified(ts) => {
                let t = ts.sample_in(occ, p, frame);
                PointVisibility {
                    rel_error: t.rel_error(),
                    error: Some(t.error),
                    rays: t.rays,
                    coeffs: t.coeffs,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::AlphaDeg;

    /// The cone half-angle's domain at its edges: the open ends 0 and 90 refused with the range
    /// stated, the nearest doubles inside kept as they are, NaN and the infinities refused; a
    /// key's error names the key.
    #[test]
    fn a_cone_angle_is_checked_at_its_open_ends() {
        for bad in [
            0.0,
            90.0,
            -1e-300,
            90.0 + 1e-13,
            f64::NAN,
            f64::INFINITY,
            -f64::INFINITY,
        ] {
            let e = AlphaDeg::new(bad).unwrap_err();
            assert!(e.contains("(0, 90)"), "{bad}: {e}");
        }
        assert_eq!(AlphaDeg::new(95.0).unwrap_err(), "95 is outside (0, 90)");
        let lo = f64::MIN_POSITIVE;
        let hi = f64::from_bits(90f64.to_bits() - 1);
        for ok in [lo, 1e-9, 45.0, hi] {
            let a = AlphaDeg::new(ok).unwrap();
            assert_eq!(a.degrees(), ok);
            assert!(a.radians() > 0.0 && a.radians() < std::f64::consts::FRAC_PI_2);
        }
        let e = AlphaDeg::of_key("alpha_deg", 90.0).unwrap_err();
        assert_eq!(
            (e.key.as_str(), e.message.as_str()),
            ("alpha_deg", "90 is outside (0, 90)")
        );
    }
}
