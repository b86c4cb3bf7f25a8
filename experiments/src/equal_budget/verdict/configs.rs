//! Rows grouped into configurations (equal in every parameter but the seeds), each with its
//! method's spec parsed once, and named in words.

use super::*;

/// The parameter columns of kind parameters `P`.
fn param_columns<P: Default + Serialize>() -> Vec<String> {
    shscale_runner::records::to_cells(&P::default())
        .map(|(h, _)| h)
        .unwrap_or_default()
}

/// The parameter columns that make a configuration of kind parameters `P`: all of them but
/// `grouping` (the columns a discussion is split by, and the seeds and receivers its rows
/// repeat over). Derived from `P`, so a new parameter is never merged away.
pub(crate) fn config_keys<P: Default + Serialize>(grouping: &[&str]) -> Vec<String> {
    (param_columns::<P>().into_iter())
        .filter(|h| !grouping.contains(&h.as_str()))
        .collect()
}

/// Every row's method, parsed once from its cells with `spec` (`None` where they no longer
/// parse): the kind's parameter columns are found once for the table, not once per row and use.
pub(crate) fn specs_of<P: Default + Serialize + DeserializeOwned>(
    t: &Results,
    spec: impl Fn(&P) -> Option<Spec>,
) -> Vec<Option<Spec>> {
    let headers = param_columns::<P>();
    (0..t.rows.len())
        .map(|r| {
            let cells: Vec<String> = headers.iter().map(|h| t.cell(r, h).to_string()).collect();
            let p: P = shscale_runner::records::from_cells(&headers, &cells).ok()?;
            spec(&p)
        })
        .collect()
}

/// Row `r`'s parameters, parsed from its cells (`None` where they no longer parse).
pub(crate) fn params_of<P: Default + Serialize + DeserializeOwned>(
    t: &Results,
    r: usize,
) -> Option<P> {
    let headers = param_columns::<P>();
    let cells: Vec<String> = headers.iter().map(|h| t.cell(r, h).to_string()).collect();
    shscale_runner::records::from_cells(&headers, &cells).ok()
}

/// A configuration: its rows (one per seed) and its method, parsed once.
#[derive(Clone)]
pub(crate) struct Config {
    pub rows: Vec<usize>,
    pub spec: Spec,
}

impl Config {
    /// Mean of `col` over the seeds, and its range.
    pub(super) fn mean(&self, t: &Results, col: &str) -> (f64, f64, f64) {
        let v: Vec<f64> = self.rows.iter().map(|&r| t.num(r, col)).collect();
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (m, lo, hi)
    }
    pub(super) fn first(&self) -> usize {
        self.rows[0]
    }
    pub(super) fn method(&self) -> Method {
        self.spec.method()
    }
}

/// Rows grouped by configuration (equal cells in `keys`), in the order of the table, each with
/// its spec (`spec_of`; rows whose parameters no longer parse are left out).
pub(crate) fn by_config(
    t: &Results,
    rows: &[usize],
    keys: &[String],
    spec_of: &dyn Fn(usize) -> Option<Spec>,
) -> Vec<Config> {
    let mut index: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    let mut out: Vec<Config> = Vec::new();
    for &r in rows {
        let key = keys
            .iter()
            .map(|k| t.cell(r, k))
            .collect::<Vec<_>>()
            .join(";");
        match index.get(&key) {
            Some(&i) => out[i].rows.push(r),
            None => {
                let Some(spec) = spec_of(r) else { continue };
                index.insert(key, out.len());
                out.push(Config {
                    rows: vec![r],
                    spec,
                });
            }
        }
    }
    out
}

/// A number as its CSV cell writes it (`3.0`, `0.05`): the discussion names parameters as the
/// rows spell them.
fn cell(x: f64) -> String {
    if x.fract() == 0.0 && x.abs() < 1e16 {
        format!("{x:.1}")
    } else {
        x.to_string()
    }
}

/// The papers' full field: uniform shells over [1, 8]·s, trilinear.
pub(super) fn is_papers_field(s: &Spec) -> bool {
    matches!(s, Spec::FullField(f) if f.spacing == ShellSpacing::Uniform
        && f.shell_max == 8.0
        && f.interp == FieldInterp::Trilinear)
}

/// The papers' extrapolation: one sphere, fixed α, no mitigation, on the bounding sphere.
pub(crate) fn is_papers_extrapolation(s: &Spec) -> bool {
    matches!(s, Spec::Extrapolated(e) if matches!(e.alpha, Alpha::Fixed(_))
        && e.plausibility == Plausibility::None
        && e.sampling_radius == 1.0
        && e.radial == RadialRule::Uniform)
}

/// Per-direction radii (any rule but the uniform one).
pub(super) fn is_radial(s: &Spec) -> bool {
    s.extrapolation()
        .is_some_and(|e| e.radial != RadialRule::Uniform)
}

/// The series a spec belongs to: its method and, where it is not the papers', its variant.
pub(crate) fn variant(s: &Spec) -> String {
    match s {
        Spec::FullField(_) if is_papers_field(s) => "full field (papers')".into(),
        Spec::FullField(f) => format!(
            "full field ({}, [1, {}]r, {})",
            f.spacing.name(),
            cell(f.shell_max),
            f.interp.name()
        ),
        Spec::RayTraced(RayTracedSpec { .. }) => "ray tracing".into(),
        Spec::SphereSet(SetSpec {
            parts,
            combine,
            internal_order,
            fit,
        }) => format!(
            "sphere set (S = {parts}{}{})",
            match fit {
                SphereFit::Area => "",
                SphereFit::Inscribed => ", inscribed",
            },
            match (combine, internal_order) {
                (Combine::Quadrature, _) => ", quadrature".to_string(),
                (Combine::Union, _) => ", union".to_string(),
                (Combine::Shexp, _) => ", SHEXP".to_string(),
                (_, 0) => String::new(),
                (_, m) => format!(", M = {m}"),
            }
        ),
        Spec::Extrapolated(e) => extrapolation_variant("extrapolation", None, e),
        Spec::SubVolumes(SubVolumeSpec {
            parts,
            ex,
            combine: Combine::Shexp,
        }) => extrapolation_variant("sub-volumes in log space", Some(*parts), ex),
        Spec::SubVolumes(SubVolumeSpec { parts, ex, .. }) => {
            extrapolation_variant("sub-volumes", Some(*parts), ex)
        }
    }
}

fn extrapolation_variant(base: &str, parts: Option<usize>, e: &Extrapolation) -> String {
    let mut v = Vec::new();
    if let Some(p) = parts {
        v.push(format!("P = {p}"));
    }
    if e.alpha == Alpha::Fit {
        v.push("α fit".to_string());
    }
    if e.plausibility == Plausibility::Clamp {
        v.push("clamp".into());
    }
    if e.sampling_radius != 1.0 {
        v.push(format!("s = {}", cell(e.sampling_radius)));
    }
    match e.radial {
        RadialRule::Clearance { delta } => v.push(format!("clearance δ = {}", cell(delta))),
        RadialRule::Occlusion { tau, t_max } => {
            v.push(format!("occlusion τ = {} to {}r", cell(tau), cell(t_max)))
        }
        RadialRule::Uniform => {}
    }
    if v.is_empty() {
        base.into()
    } else {
        format!("{base} ({})", v.join(", "))
    }
}

/// A configuration in words.
pub(crate) fn name(c: &Config) -> String {
    let s = &c.spec;
    match s {
        Spec::FullField(f) => format!(
            "{}, {} shells of `{}`, H = {}",
            variant(s),
            f.count,
            f.layout.name(),
            f.hemisphere_res
        ),
        Spec::RayTraced(RayTracedSpec { rt_res }) => format!("ray tracing, T = {rt_res}"),
        Spec::SphereSet(SetSpec { .. }) => variant(s),
        Spec::Extrapolated(e) | Spec::SubVolumes(SubVolumeSpec { ex: e, .. }) => format!(
            "{}, `{}`{}, H = {}{}",
            variant(s),
            e.layout.name(),
            if c.method() == Method::SubVolumes {
                " each"
            } else {
                ""
            },
            e.hemisphere_res,
            match e.alpha {
                Alpha::Fixed(a) => format!(", α = {}°", cell(a.degrees())),
                // α by distance: the variant says so.
                Alpha::Fit => String::new(),
            }
        ),
    }
}

/// The sampling (layout, H) of a spec that samples hemispheres.
pub(crate) fn sampling(s: &Spec) -> Option<(String, usize)> {
    match s {
        Spec::FullField(f) => Some((f.layout.name(), f.hemisphere_res)),
        _ => s
            .extrapolation()
            .map(|e| (e.layout.name(), e.hemisphere_res)),
    }
}
