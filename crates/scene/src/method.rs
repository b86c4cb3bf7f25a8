//! The methods' vocabulary: every way this project computes the visibility a receiver sees,
//! spelled one way ([`Method`]: the config's `method` cell, the CSV column, `render --method`,
//! Python), and the typed spec of each method a budget study compares ([`Spec`]), parsed once
//! from a kind's keys ([`Keys`]) with the keys each method reads, its rays and its memory in
//! one place (docs/methods.md).
//!
//! A key that the chosen method does not read must keep its default: given any other value it
//! is refused, naming the key and the method (Mitsuba's rule for unqueried properties), so it
//! never changes a run id without changing the run.

use crate::scene::Scene;
use shscale_field::bsv::{Layout, RadialRule};
use shscale_field::evaluator::{FieldInterp, ShellSpacing, Shells};
use shscale_field::extrapolate::Plausibility;
use shscale_runner::check::Ends;
use shscale_runner::KeyError;

/// A method of computing a receiver's visibility.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Method {
    /// SH-scaling extrapolation from one base-sphere visibility per occluder (the papers').
    Extrapolated,
    /// The fully sampled shadow field (Zhou et al. 2005): shells of samples, interpolated.
    FullField,
    /// Band-limited ray-traced visibility (the converged stratified truth at `4T²` rays per
    /// receiver), shaded through SH like the others.
    RayTraced,
    /// Full-frequency truth: direct quadrature of `∫ L Π V cos⁺` with exact ray-cast visibility.
    FullFrequency,
    /// Sub-volumes (TR §6, SHS §5 future work): every mesh occluder split into parts, each part
    /// extrapolated from its own bounding sphere, multiplied near to far.
    SubVolumes,
    /// Sphere sets (Ren et al. 2006's occluder model): one sphere fitted per part, closed-form
    /// caps; no rays.
    SphereSet,
}

shscale_names::names!(Method {
    Extrapolated = "extrapolated",
    FullField = "full_field",
    RayTraced = "ray_traced",
    FullFrequency = "full_frequency",
    SubVolumes = "sub_volumes",
    SphereSet = "sphere_set",
});

impl Method {
    /// Every method, in the order of the docs.
    pub const ALL: [Method; 6] = [
        Method::Extrapolated,
        Method::FullField,
        Method::RayTraced,
        Method::FullFrequency,
        Method::SubVolumes,
        Method::SphereSet,
    ];
    /// The methods a budget study compares (full-frequency truth is its reference, not a
    /// method under a budget).
    pub(crate) const BUDGETED: [Method; 5] = [
        Method::Extrapolated,
        Method::FullField,
        Method::RayTraced,
        Method::SubVolumes,
        Method::SphereSet,
    ];
    /// The command line's earlier spellings, still accepted by [`Method::parse_cli`].
    const CLI_ALIASES: [(&'static str, Method); 3] = [
        ("full-field", Method::FullField),
        ("raytraced", Method::RayTraced),
        ("raytraced-full", Method::FullFrequency),
    ];

    /// The method named `s` among `among`, or a message listing them.
    pub(crate) fn parse_among(s: &str, among: &[Method]) -> Result<Self, String> {
        among
            .iter()
            .copied()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                let names: Vec<String> = among.iter().map(|m| format!("{:?}", m.name())).collect();
                format!("{s:?} is not one of {}", names.join(", "))
            })
    }

    /// Any method by its name.
    pub fn parse(s: &str) -> Result<Self, String> {
        Self::parse_among(s, &Self::ALL)
    }

    /// A method as the command line takes it: its name, or an earlier spelling
    /// (`full-field`, `raytraced`, `raytraced-full`).
    pub fn parse_cli(s: &str) -> Result<Self, String> {
        (Self::CLI_ALIASES.iter())
            .find(|(a, _)| *a == s)
            .map(|(_, m)| *m)
            .map_or_else(|| Self::parse(s), Ok)
    }

    /// The references: ray-traced truths, band-limited and full-frequency.
    pub fn is_truth(self) -> bool {
        matches!(self, Method::RayTraced | Method::FullFrequency)
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How α of the extrapolation's k-table is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Alpha {
    /// One cone angle, degrees, in (0, 90).
    Fixed(f64),
    /// α by distance at the BSV's effective cap (the table is then built per frame).
    Fit,
}

pub use crate::combine::{Combine, SphereFit};

/// Rings of [`Combine::Union`], fixed before the study's runs from its convergence on random
/// sets (`cargo test --release -p shscale-field --test union -- --ignored --nocapture`,
/// docs/math.md "The union of the caps"): at 32 rings at most 2.1 % of the occlusion against
/// 2,048 rings for S = 2–64, N = 4 and 8, where the 64 × 128 quadrature errs 1.4–7.5 %.
pub const UNION_RINGS: usize = 32;

/// Gauss–Legendre nodes in cos θ of [`Combine::Quadrature`] (× twice as many φ).
pub const SPHERE_QUADRATURE_RES: usize = 64;

/// The extrapolation's parameters (one sphere, or each sub-volume's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extrapolation {
    pub layout: Layout,
    /// H: H² rays per base-sphere sample.
    pub hemisphere_res: usize,
    pub alpha: Alpha,
    pub plausibility: Plausibility,
    /// The sampling sphere in bounding radii, [1, 1000].
    pub sampling_radius: f64,
    pub radial: RadialRule,
    /// k-table entries; `None` where the scene's are used (`budget_plane`).
    pub k_count: Option<usize>,
}

/// The fully sampled field's parameters: shells over `[s, shell_max·s]·r`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldSpec {
    pub layout: Layout,
    pub hemisphere_res: usize,
    pub count: usize,
    pub shell_max: f64,
    pub spacing: ShellSpacing,
    pub interp: FieldInterp,
    /// The innermost shell in bounding radii.
    pub sampling_radius: f64,
}

impl FieldSpec {
    /// The shells, over `[s, shell_max·s]` bounding radii.
    pub fn shells(&self) -> Shells {
        Shells {
            count: self.count,
            rho_min: self.sampling_radius,
            rho_max: self.shell_max * self.sampling_radius,
            spacing: self.spacing,
            interp: self.interp,
        }
    }
}

/// One method with everything it reads, parsed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Spec {
    Extrapolated(Extrapolation),
    FullField(FieldSpec),
    RayTraced {
        rt_res: usize,
    },
    /// `combine`: [`Combine::Product`] (each part's scaled visibility multiplied near to far)
    /// or [`Combine::Shexp`] (each part's log-visibility scaled, summed, exponentiated once).
    SubVolumes {
        parts: usize,
        ex: Extrapolation,
        combine: Combine,
    },
    /// `internal_order`: the order M the caps are multiplied at before truncating to the run's
    /// N (0: N itself, the plain order-N chain); `fit`: which spheres.
    SphereSet {
        parts: usize,
        combine: Combine,
        internal_order: usize,
        fit: SphereFit,
    },
}

/// The highest internal order of a sphere set's products (a product at M = 16 does about
/// 1,150× the work of one at 4: docs/math.md, "Combining many spheres").
pub(crate) const MAX_SPHERE_ORDER: usize = 16;

/// The raw method keys of a kind's parameters (each kind fills the ones it has; a key it does
/// not offer is `None`, and the method uses the fixed value the kind documents).
#[derive(Clone, Copy, Debug)]
pub struct Keys<'a> {
    pub method: &'a str,
    pub parts: usize,
    pub layout: &'a str,
    pub hemisphere_res: usize,
    pub shells: usize,
    pub shell_max: f64,
    pub shell_spacing: &'a str,
    pub field_interp: &'a str,
    pub rt_res: usize,
    pub alpha_deg: f64,
    pub alpha_mode: Option<&'a str>,
    pub plausibility: &'a str,
    pub sampling_radius: f64,
    pub radial: &'a str,
    pub radial_delta: f64,
    pub radial_tau: Option<f64>,
    pub radial_max: Option<f64>,
    pub sphere_combine: Option<&'a str>,
    /// Which spheres a sphere set takes: `area` or `inscribed`.
    pub sphere_fit: Option<&'a str>,
    /// The internal order of a sphere set's products (0: the run's order).
    pub sphere_order: Option<usize>,
    /// How sub-volumes combine their parts: `product` or `shexp`.
    pub part_combine: Option<&'a str>,
    pub k_count: Option<usize>,
}

/// The most shells of a full field.
pub(crate) const MAX_SHELLS: usize = 64;

impl<'a> Keys<'a> {
    /// Every method key this kind offers with its value as a cell, for the unread-key rule (and
    /// the GPU forms' [`crate::gpu_methods::unhonoured`]).
    pub fn cells(&self) -> Vec<(&'static str, String)> {
        let mut v = vec![
            ("parts", self.parts.to_string()),
            ("layout", self.layout.to_string()),
            ("hemisphere_res", self.hemisphere_res.to_string()),
            ("shells", self.shells.to_string()),
            ("shell_max", self.shell_max.to_string()),
            ("shell_spacing", self.shell_spacing.to_string()),
            ("field_interp", self.field_interp.to_string()),
            ("rt_res", self.rt_res.to_string()),
            ("alpha_deg", self.alpha_deg.to_string()),
            ("plausibility", self.plausibility.to_string()),
            ("sampling_radius", self.sampling_radius.to_string()),
            ("radial", self.radial.to_string()),
            ("radial_delta", self.radial_delta.to_string()),
        ];
        let opt = [
            ("alpha_mode", self.alpha_mode.map(str::to_string)),
            ("radial_tau", self.radial_tau.map(|x| x.to_string())),
            ("radial_max", self.radial_max.map(|x| x.to_string())),
            ("sphere_combine", self.sphere_combine.map(str::to_string)),
            ("sphere_fit", self.sphere_fit.map(str::to_string)),
            ("sphere_order", self.sphere_order.map(|x| x.to_string())),
            ("part_combine", self.part_combine.map(str::to_string)),
            ("k_count", self.k_count.map(|x| x.to_string())),
        ];
        v.extend(opt.into_iter().filter_map(|(k, c)| Some((k, c?))));
        v
    }

    fn extrapolation(&self) -> Result<Extrapolation, KeyError> {
        let layout = layout(self.layout)?;
        let mode = self.alpha_mode.unwrap_or("fixed");
        let alpha = match AlphaMode::from_name(mode) {
            Some(AlphaMode::Fixed) => {
                KeyError::real("alpha_deg", self.alpha_deg, 0.0, 90.0, Ends::Open)?;
                Alpha::Fixed(self.alpha_deg)
            }
            Some(AlphaMode::Fit) => Alpha::Fit,
            None => {
                return Err(KeyError::new(
                    "alpha_mode",
                    shscale_names::one_of(mode, AlphaMode::NAMES),
                ))
            }
        };
        Ok(Extrapolation {
            layout,
            hemisphere_res: hemisphere_res(self.hemisphere_res)?,
            alpha,
            plausibility: Plausibility::parse(self.plausibility)
                .map_err(|m| KeyError::new("plausibility", m))?,
            sampling_radius: self.sampling_radius()?,
            radial: self.radial_rule()?,
            k_count: self
                .k_count
                .map(|k| KeyError::int("k_count", k, 2, crate::vocab::MAX_K_COUNT))
                .transpose()?,
        })
    }

    /// `uniform`, `clearance` (δ ∈ [0, 10]) or `occlusion` (τ ∈ [0, 1), ceiling ∈ [1, 10]),
    /// the last only where the kind offers `radial_tau` and `radial_max`.
    fn radial_rule(&self) -> Result<RadialRule, KeyError> {
        match (RadialName::from_name(self.radial), self.radial_tau.zip(self.radial_max)) {
            (Some(RadialName::Uniform), _) => Ok(RadialRule::Uniform),
            (Some(RadialName::Clearance), _) => Ok(RadialRule::Clearance {
                delta: KeyError::real("radial_delta", self.radial_delta, 0.0, 10.0, Ends::Closed)?,
            }),
            (Some(RadialName::Occlusion), Some((tau, t_max))) => Ok(RadialRule::Occlusion {
                tau: KeyError::real("radial_tau", tau, 0.0, 1.0, Ends::ClosedOpen)?,
                t_max: KeyError::real("radial_max", t_max, 1.0, 10.0, Ends::Closed)?,
            }),
            (Some(RadialName::Occlusion), None) => Err(KeyError::new(
                "radial",
                "\"occlusion\" is offered by `budget` only (its search rays are not in the plane's ray count); use \"uniform\" or \"clearance\"",
            )),
            (None, _) => Err(KeyError::new(
                "radial",
                shscale_names::one_of(self.radial, RadialName::NAMES),
            )),
        }
    }

    /// The sampling sphere (and innermost shell) in bounding radii, [1, 1000].
    fn sampling_radius(&self) -> Result<f64, KeyError> {
        KeyError::real(
            "sampling_radius",
            self.sampling_radius,
            1.0,
            1e3,
            Ends::Closed,
        )
    }

    fn field(&self) -> Result<FieldSpec, KeyError> {
        let f = FieldSpec {
            layout: layout(self.layout)?,
            hemisphere_res: hemisphere_res(self.hemisphere_res)?,
            count: KeyError::int("shells", self.shells, 2, MAX_SHELLS)?,
            shell_max: KeyError::real("shell_max", self.shell_max, 1.0, 1e3, Ends::OpenClosed)?,
            spacing: ShellSpacing::parse(self.shell_spacing)
                .map_err(|e| KeyError::new("shell_spacing", e.to_string()))?,
            interp: FieldInterp::parse(self.field_interp)
                .map_err(|e| KeyError::new("field_interp", e.to_string()))?,
            sampling_radius: self.sampling_radius()?,
        };
        (f.shells().check(f.layout)).map_err(|e| KeyError::new("field_interp", e.to_string()))?;
        Ok(f)
    }
}

fn layout(s: &str) -> Result<Layout, KeyError> {
    Layout::parse(s).map_err(|e| KeyError::new("layout", e.to_string()))
}

fn hemisphere_res(h: usize) -> Result<usize, KeyError> {
    KeyError::int("hemisphere_res", h, 1, crate::vocab::MAX_HEMISPHERE_RES)
}

impl Spec {
    /// Parse the method keys `k` once; `defaults` are the kind's defaults (the unread-key
    /// rule), `rt_res_max` the kind's largest `rt_res`. Errors name the key.
    pub fn parse(k: &Keys, defaults: &Keys, rt_res_max: usize) -> Result<Spec, KeyError> {
        let method = Method::parse_among(k.method, &Method::BUDGETED)
            .map_err(|m| KeyError::new("method", m))?;
        let parts = || KeyError::int("parts", k.parts, 1, shscale_geometry::partition::MAX_PARTS);
        let spec = match method {
            Method::Extrapolated => Spec::Extrapolated(k.extrapolation()?),
            Method::SubVolumes => Spec::SubVolumes {
                parts: parts()?,
                ex: k.extrapolation()?,
                combine: {
                    let s = k.part_combine.unwrap_or("product");
                    Combine::from_name(s)
                        .filter(|c| matches!(c, Combine::Product | Combine::Shexp))
                        .ok_or_else(|| {
                            KeyError::new(
                                "part_combine",
                                format!("{s:?} is not one of [\"product\", \"shexp\"]"),
                            )
                        })?
                },
            },
            Method::FullField => Spec::FullField(k.field()?),
            Method::RayTraced => Spec::RayTraced {
                rt_res: KeyError::int("rt_res", k.rt_res, 1, rt_res_max)?,
            },
            Method::SphereSet => Spec::SphereSet {
                parts: parts()?,
                combine: {
                    let s = k.sphere_combine.unwrap_or("product");
                    Combine::from_name(s).ok_or_else(|| {
                        KeyError::new(
                            "sphere_combine",
                            format!("{s:?} is not one of {:?}", Combine::NAMES),
                        )
                    })?
                },
                internal_order: match k.sphere_order.unwrap_or(0) {
                    0 => 0,
                    m => KeyError::int("sphere_order", m, 1, MAX_SPHERE_ORDER)?,
                },
                fit: {
                    let s = k.sphere_fit.unwrap_or("area");
                    SphereFit::from_name(s).ok_or_else(|| {
                        KeyError::new(
                            "sphere_fit",
                            format!("{s:?} is not one of {:?}", SphereFit::NAMES),
                        )
                    })?
                },
            },
            Method::FullFrequency => unreachable!("not among the budgeted methods"),
        };
        let cells = k.cells();
        // The keys it reads among those the kind offers, for the message.
        let reads: Vec<&str> = (spec.reads().into_iter())
            .filter(|r| cells.iter().any(|(c, _)| c == r))
            .collect();
        for ((key, v), (_, d)) in cells.iter().zip(defaults.cells()) {
            if *v != d && !reads.contains(key) {
                return Err(KeyError::new(
                    key,
                    format!(
                        "{v} is not read by method \"{method}\" (it reads {}); leave {key} at its default {d}",
                        reads.join(", ")
                    ),
                ));
            }
        }
        Ok(spec)
    }

    pub fn method(&self) -> Method {
        match self {
            Spec::Extrapolated(_) => Method::Extrapolated,
            Spec::FullField(_) => Method::FullField,
            Spec::RayTraced { .. } => Method::RayTraced,
            Spec::SubVolumes { .. } => Method::SubVolumes,
            Spec::SphereSet { .. } => Method::SphereSet,
        }
    }

    /// The extrapolation of `extrapolated` and of each sub-volume.
    pub fn extrapolation(&self) -> Option<&Extrapolation> {
        match self {
            Spec::Extrapolated(e) | Spec::SubVolumes { ex: e, .. } => Some(e),
            _ => None,
        }
    }

    /// The method keys this spec reads (the others must keep their defaults).
    pub fn reads(&self) -> Vec<&'static str> {
        let ex = |e: &Extrapolation| {
            let mut v = vec!["layout", "hemisphere_res", "alpha_mode"];
            if matches!(e.alpha, Alpha::Fixed(_)) {
                v.push("alpha_deg");
            }
            v.extend(["plausibility", "sampling_radius", "radial", "k_count"]);
            match e.radial {
                RadialRule::Uniform => {}
                RadialRule::Clearance { .. } => v.push("radial_delta"),
                RadialRule::Occlusion { .. } => v.extend(["radial_tau", "radial_max"]),
            }
            v
        };
        match self {
            Spec::Extrapolated(e) => ex(e),
            Spec::SubVolumes { ex: e, .. } => [vec!["parts", "part_combine"], ex(e)].concat(),
            Spec::FullField(_) => FULL_FIELD_KEYS.to_vec(),
            Spec::RayTraced { .. } => vec!["rt_res"],
            Spec::SphereSet {
                combine: Combine::Product,
                ..
            } => vec!["parts", "sphere_combine", "sphere_order", "sphere_fit"],
            Spec::SphereSet { .. } => vec!["parts", "sphere_combine", "sphere_fit"],
        }
    }

    /// The combinations' own domains at the run's order N, named by their keys: a sphere set's
    /// internal order at or above N (0: N itself), SH exponentiation — of sphere sets or of
    /// sub-volumes — at orders up to `shscale_field::shexp_ol::MAX_SHEXP_ORDER` (its exact
    /// exponential's eigenproblem is N² × N²), and sub-volumes in log space without the
    /// plausibility clamp (it bounds visibilities, not logs). Both budget kinds check it at plan
    /// time.
    pub fn check_order(&self, order: usize) -> Result<(), KeyError> {
        let max = shscale_field::shexp_ol::MAX_SHEXP_ORDER;
        let shexp = |key: &str| {
            KeyError::new(
                key,
                format!("\"shexp\" takes orders up to {max} (its exact exponential's eigenproblem is N² × N²), not {order}"),
            )
        };
        match *self {
            Spec::SphereSet {
                internal_order: m, ..
            } if m != 0 && m < order => Err(KeyError::new(
                "sphere_order",
                format!(
                    "{m} is below the order {order}: give 0 (that order) or an order from {order} to {MAX_SPHERE_ORDER}"
                ),
            )),
            Spec::SphereSet {
                combine: Combine::Shexp,
                ..
            } if order > max => Err(shexp("sphere_combine")),
            Spec::SubVolumes {
                combine: Combine::Shexp,
                ex,
                ..
            } => {
                if order > max {
                    Err(shexp("part_combine"))
                } else if ex.plausibility != Plausibility::None {
                    Err(KeyError::new(
                        "plausibility",
                        "the clamp bounds visibilities, not the logs `part_combine = \"shexp\"` extrapolates: leave it at \"none\"",
                    ))
                } else {
                    Ok(())
                }
            }
            _ => Ok(()),
        }
    }

    /// The scene rendered with this method: the method's parameters set on `scene` (the keys
    /// it does not read leave the scene as it is). `rt_res` must be below the scene's
    /// `truth_res` (checked by the kinds at plan time).
    pub fn apply(&self, scene: &mut Scene) {
        let ex = |s: &mut Scene, e: &Extrapolation| {
            s.layout = e.layout;
            s.hemisphere_res = e.hemisphere_res;
            if let Alpha::Fixed(deg) = e.alpha {
                s.alpha = deg.to_radians();
            }
            s.plausibility = e.plausibility;
            s.sampling_radius = e.sampling_radius;
            s.radial = e.radial;
            if let Some(k) = e.k_count {
                s.k_count = k;
            }
        };
        match self {
            Spec::Extrapolated(e) => ex(scene, e),
            Spec::SubVolumes {
                parts,
                ex: e,
                combine,
            } => {
                ex(scene, e);
                scene.parts = *parts;
                scene.part_combine = *combine;
            }
            Spec::FullField(f) => {
                scene.layout = f.layout;
                scene.hemisphere_res = f.hemisphere_res;
                scene.sampling_radius = f.sampling_radius;
                scene.full_field = Some(f.shells());
            }
            Spec::RayTraced { rt_res } => scene.truth_res = *rt_res,
            Spec::SphereSet {
                parts,
                internal_order,
                combine,
                fit,
            } => {
                scene.parts = *parts;
                scene.sphere_order = *internal_order;
                scene.sphere_combine = *combine;
                scene.sphere_fit = *fit;
            }
        }
    }
}

/// The keys the full field reads (its GPU form carries out every one of them).
pub(crate) const FULL_FIELD_KEYS: &[&str] = &[
    "layout",
    "hemisphere_res",
    "shells",
    "shell_max",
    "shell_spacing",
    "field_interp",
    "sampling_radius",
];

/// The names `alpha_mode` takes (the cone angle given, or fitted by distance).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum AlphaMode {
    Fixed,
    Fit,
}
shscale_names::names!(AlphaMode { Fixed = "fixed", Fit = "fit" });

/// The names `radial` takes ([`RadialRule`]'s variants, whose parameters are other keys).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RadialName {
    Uniform,
    Clearance,
    Occlusion,
}
shscale_names::names!(RadialName {
    Uniform = "uniform",
    Clearance = "clearance",
    Occlusion = "occlusion",
});
#[cfg(test)]
mod tests;
