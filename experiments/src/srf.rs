//! Source radiance fields (SHS §3.1, TR §4.1 and Appendix A): when a light's radiance, sampled on
//! its bounding sphere, is extrapolated to other radii, which scaling matches ray-traced radiance —
//! the plain matrix or the energy-preserving one the papers prescribe?
//!
//! The papers' deformable light (two square panels joined at a hinge, `srf::hinged_light`),
//! both panels emitting 1. One run is one hinge angle and α; `srf::compare` gives, per probe
//! radius (one row each), the mean relative L2 error of each η variant against ray-traced radiance.

/// Rays per second of the SRF comparison, measured (see the note in the kind's `cost`).
const SRF_RAYS_PER_SECOND: f64 = 6.5e5;

use serde::{Deserialize, Serialize};
use shscale_field::{Emitter, Layout, Radiant, SphereEmitter};
use shscale_geometry::ray::UpdateStrategy;
use shscale_geometry::MeshBvh;
use shscale_present::plots::{write_both, Labels};
use shscale_runner::check::Ends;
use shscale_runner::records::Results;
use shscale_runner::{Cost, Ctx, KeyError, Kind, Typed};
use shscale_scene::vocab::{MAX_HEMISPHERE_RES, MAX_ORDER, MAX_RADII};
use shscale_scene::Error;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Parameters of one run (one light and α).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// `hinged` (the papers' deformable light) or `sphere` (a uniformly emitting sphere, whose
    /// radiance has a closed-form projection).
    pub emitter: String,
    pub order: usize,
    pub layout: String,
    pub hemisphere_res: usize,
    pub alpha_deg: f64,
    /// Angle between the two panels (degrees, in (0, 360)).
    pub hinge_deg: f64,
    /// Probe radii (× the bounding radius r, ≥ 1, distinct).
    #[serde(with = "shscale_runner::records::list")]
    pub radii: Vec<f64>,
    /// T of the radiance truth (4T² stratified rays per probe).
    pub truth_res: usize,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            emitter: "hinged".into(),
            order: 4,
            layout: "latlong:12x20".into(),
            hemisphere_res: 16,
            alpha_deg: 45.0,
            hinge_deg: 100.0,
            radii: vec![1.3, 2.0, 3.0],
            truth_res: 64,
        }
    }
}

/// One row per probe radius: the field crate's row as it is.
pub type Row = shscale_field::srf::SrfRow;

/// The light whose radiance field is extrapolated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmitterKind {
    /// The papers' two-panel light; truth ray-traced.
    Hinged,
    /// A unit sphere of radiance 1; truth closed form.
    Sphere,
}

shscale_names::names!(EmitterKind { Hinged = "hinged", Sphere = "sphere" });

impl EmitterKind {
    /// `hinged` or `sphere`.
    pub fn parse(s: &str) -> Result<Self, String> {
        Self::from_name(s).ok_or_else(|| format!("{s:?} is not `hinged` or `sphere`"))
    }
}

/// The kind `srf`.
pub struct Srf;

impl Kind for Srf {
    const NAME: &'static str = "srf";
    const QUESTION: &'static str = "TR §4.1, SHS §3.1: is a light's radiance, extrapolated from its bounding sphere, closer to ray-traced radiance with the energy-preserving scaling matrix (η = sin τ · τ′) than with the plain one?";
    type Params = Params;
    type Shared = ();
    type Row = Row;
    type Error = Error;
    type Spec = Typed<Params, (Layout, EmitterKind)>;

    fn describe() -> &'static [(&'static str, &'static str)] {
        &[
            ("emitter", "`hinged` (the papers' two-panel light; truth ray-traced) or `sphere` (a unit sphere of radiance 1; truth closed form)"),
            ("order", "SH order N, 1..=16"),
            ("layout", "base-sphere sample layout, at most 10⁶ samples"),
            ("hemisphere_res", "H: H² rays per BSV sample, 1..=256"),
            ("alpha_deg", "cone half-angle α, degrees, (0, 90)"),
            (
                "hinge_deg",
                "angle between the light's two panels, degrees, (0, 360) (the hinged emitter only)",
            ),
            (
                "radii",
                "probe radii in bounding radii, 1 to 64 distinct values in [1, 1e6]",
            ),
            (
                "truth_res",
                "T of the ray-traced radiance truth: 4T² stratified rays per probe, its own error reported, 1..=1024",
            ),
        ]
    }

    fn resolve(p: &Params) -> Result<Self::Spec, KeyError> {
        KeyError::int(
            "truth_res",
            p.truth_res,
            1,
            shscale_field::truth::MAX_TRUTH_RES,
        )?;
        KeyError::int("order", p.order, 1, MAX_ORDER)?;
        let emitter = EmitterKind::parse(&p.emitter).map_err(|m| KeyError::new("emitter", m))?;
        let layout =
            Layout::parse(&p.layout).map_err(|e| KeyError::new("layout", e.to_string()))?;
        KeyError::int("hemisphere_res", p.hemisphere_res, 1, MAX_HEMISPHERE_RES)?;
        shscale_scene::vocab::AlphaDeg::of_key("alpha_deg", p.alpha_deg)?;
        KeyError::real("hinge_deg", p.hinge_deg, 0.0, 360.0, Ends::Open)?;
        if p.radii.is_empty() || p.radii.len() > MAX_RADII {
            return Err(KeyError::new(
                "radii",
                format!("{} radii: give 1 to {MAX_RADII}", p.radii.len()),
            ));
        }
        for (i, r) in p.radii.iter().enumerate() {
            KeyError::real("radii", *r, 1.0, 1e6, Ends::Closed).map_err(|e| KeyError {
                message: format!("{} (× the bounding radius)", e.message),
                ..e
            })?;
            if p.radii[..i].contains(r) {
                return Err(KeyError::new("radii", format!("{r} appears twice")));
            }
        }
        Ok(Typed {
            params: p.clone(),
            typed: (layout, emitter),
        })
    }

    fn cost(p: &Self::Spec) -> (Cost, Cost) {
        let samples = p.typed.0.sample_count().unwrap_or(0) as f64;
        let h = p.hemisphere_res as f64;
        // The BSV on the bounding sphere plus the ray-traced truth at every radius.
        let rays = samples * h * h * (1.0 + p.radii.len() as f64);
        (
            Cost::default(),
            Cost {
                cached_once: None,
                rays,
                bytes: samples * (p.order * p.order) as f64 * 8.0 * 2.0,
                seconds: 0.0,
                // Untimed, at the effective rate of this kind (rays to the hinged emitter, its
                // radiance integrated per ray, the emitter's set-up): 2.2e6 rays in 3.4 s for
                // `configs/experiments/srf.toml` on the development VM.
                once_seconds: rays / SRF_RAYS_PER_SECOND,
                drivers: format!(
                    "layout {} × hemisphere_res {}² × (1 + {} radii)",
                    p.layout,
                    p.hemisphere_res,
                    p.radii.len()
                ),
            },
        )
    }

    fn rows_per_run(p: &Params) -> usize {
        p.radii.len()
    }

    fn shared(_: &Self::Spec, _: &Ctx) -> Result<(), Error> {
        Ok(())
    }

    fn run(p: &Self::Spec, _: &str, _: &(), _: &Ctx) -> Result<Vec<Row>, Error> {
        let (layout, emitter) = p.typed;
        let e: Box<dyn Radiant> = match emitter {
            EmitterKind::Sphere => Box::new(SphereEmitter {
                sphere: shscale_geometry::Sphere {
                    center: glam::DVec3::ZERO,
                    radius: 1.0,
                },
                radiance: 1.0,
            }),
            EmitterKind::Hinged => {
                let (mesh, rgb) = shscale_field::srf::hinged_light(1.0, p.hinge_deg.to_radians());
                let radiance: Vec<f64> = rgb.iter().map(|c| c[0] + c[1] + c[2]).collect();
                let bvh = MeshBvh::build(&mesh, UpdateStrategy::Rebuild);
                Box::new(Emitter::new(&mesh, bvh, radiance)?)
            }
        };
        let res = shscale_field::srf::compare(
            e.as_ref(),
            layout,
            p.order,
            p.hemisphere_res,
            p.alpha_deg.to_radians(),
            1.0,
            &p.radii,
            p.truth_res,
        )?;
        Ok(res)
    }

    fn summary_columns() -> &'static [&'static str] {
        &[
            "radius",
            "plain_rel_l2",
            "energy_rel_l2",
            "energy_r2_rel_l2",
            "better",
        ]
    }

    fn report(dir: &Path, t: &Results) -> Result<Vec<PathBuf>, Error> {
        Self::figure(dir, t, dir, "srf_error_vs_radius")
    }

    fn discussion(t: &Results) -> Result<String, Error> {
        if t.rows.is_empty() {
            return Ok(String::new());
        }
        let mut out = String::new();
        for emitter in t.distinct("emitter") {
            let rows: Vec<usize> = (0..t.rows.len())
                .filter(|&r| t.cell(r, "emitter") == emitter)
                .collect();
            out.push_str(&discussion_of(t, &rows, &emitter));
        }
        Ok(out)
    }

    fn figure(_: &Path, t: &Results, out: &Path, stem: &str) -> Result<Vec<PathBuf>, Error> {
        // Error against radius: one series per η and per combination of the varying parameters.
        let params = shscale_runner::Erased::<Srf>::new();
        let varying: Vec<String> = t
            .varying(&shscale_runner::DynKind::param_columns(&params))
            .into_iter()
            .filter(|c| c != "radii")
            .collect();
        let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for r in 0..t.rows.len() {
            let label = varying
                .iter()
                .map(|o| format!(", {} = {}", shscale_present::plots::words(o), t.cell(r, o)))
                .collect::<String>();
            for (name, col) in [
                ("plain η", "plain_rel_l2"),
                ("energy η", "energy_rel_l2"),
                ("energy η × (r/d)²", "energy_r2_rel_l2"),
            ] {
                series
                    .entry(format!("{name}{label}"))
                    .or_default()
                    .push((t.num(r, "radius"), t.num(r, col)));
            }
        }
        for v in series.values_mut() {
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        Ok(write_both(
            out,
            stem,
            &Labels {
                title: "light extrapolation error vs radius",
                x: "probe radius (× bounding radius r)",
                y: "mean relative L2 error vs ray-traced radiance (1)",
            },
            &series,
            false,
            &[],
        )?)
    }
}

/// The discussion of one emitter's rows.
fn discussion_of(t: &Results, rows: &[usize], emitter: &str) -> String {
    let total = rows.len();
    let count = |v: &str| rows.iter().filter(|&&r| t.cell(r, "better") == v).count();
    let (plain, energy, r2) = (count("plain"), count("energy"), count("energy_r2"));
    let verdict = if energy == total {
        "the energy-preserving matrix is the closest in every case — as the papers prescribe"
            .to_string()
    } else if plain == total {
        "the plain matrix is the closest in every case — contrary to the papers' prescription"
            .to_string()
    } else if r2 == total {
        "the energy-preserving result scaled by (r/d)² is the closest in every case".to_string()
    } else {
        format!("the plain matrix is closest in {plain}, the energy-preserving one in {energy} and the energy-preserving one scaled by (r/d)² in {r2} of {total} cases — none uniformly, contrary to the papers' unconditional prescription")
    };
    let lines: Vec<String> = rows
        .iter()
        .map(|&r| {
            format!(
                "| {} | {}° | {} | {:.4} | {:.4} | {:.4} | {} |",
                if EmitterKind::parse(emitter) == Ok(EmitterKind::Sphere) {
                    "—".to_string()
                } else {
                    format!("{}°", t.cell(r, "hinge_deg"))
                },
                t.cell(r, "alpha_deg"),
                t.cell(r, "radius"),
                t.num(r, "plain_rel_l2"),
                t.num(r, "energy_rel_l2"),
                t.num(r, "energy_r2_rel_l2"),
                t.cell(r, "better")
            )
        })
        .collect();
    let best: Vec<f64> = rows
        .iter()
        .map(|&r| {
            ["plain_rel_l2", "energy_rel_l2", "energy_r2_rel_l2"]
                .iter()
                .map(|c| t.num(r, c))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let (lo, hi) = best
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    let light = if EmitterKind::parse(emitter) == Ok(EmitterKind::Sphere) {
        "A unit sphere of uniform radiance 1 (an analytic emitter: from distance d it fills the cap asin(1/d), so the truth is the cap's closed-form projection, own error 0)"
    } else {
        "The hinged two-panel light (side 1, both panels radiance 1; truth: the converged stratified projection, its own error in the CSV's `truth_rel_err`)"
    };
    format!(
            "**Ours ({emitter} emitter).** {light}, BSV sampled on its bounding sphere; mean relative L2 \
error of the extrapolated radiance against the truth over the sample directions whose truth is lit.\n\n\
| hinge | α | radius | plain η | energy η | energy η × (r/d)² | closest |\n|---|---|---:|---:|---:|---:|---|\n{}\n\n**Comparison.** Across these cases {verdict}. The closest variant itself errs {lo:.2}–{hi:.2} (relative L2).\n\n",
            lines.join("\n")
        )
}
