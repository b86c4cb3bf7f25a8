//! The `probe` kind (SHS Fig. 5 / TR Fig. 1): extrapolated vs ray-traced visibility at probe
//! radii along the probe directions (seeded, between the base-sphere samples, or on them), one row
//! per run and radius. Runs sharing mesh, order, layout, H, sampling radius, ε, probe directions,
//! truth resolution and seed, and radii share the BSV and the truth (computed once); α, the
//! k-table, the contact threshold and the plausibility mitigation vary per run.
//!
//! | module | what it owns |
//! |---|---|
//! | `row` | the one row type (CSV, `shscale probe`, Python) |
//! | `driver` | the shared work and one repeat of a run, timed; the rows with their times |
//! | `subvolumes` | runs with `parts > 1` through the same assessment and timing procedure |
//! | `discussion` | the summary's text from the rows |
//! | `figure` | the pictures: Fig. 5 of a run, the plots of a results directory |

mod discussion;
pub mod driver;
pub mod figure;
pub mod row;
mod subvolumes;

pub use discussion::FOLLOWS;
use discussion::{follows_sentence, single_run_table, truth_note};
pub use row::ProbeRow;
use serde::{Deserialize, Serialize};
use shscale_field::extrapolate::Plausibility;
use shscale_field::probe::{ProbeDirs, ProbeSpec};
use shscale_field::Layout;
use shscale_runner::check::Ends;
use shscale_runner::records::{list, Results};
use shscale_runner::timing::{CPU_RAYS_PER_SECOND, TRUTH_RAYS_PER_SECOND};

/// The cost model's untimed work of a probe group beyond its rays: the mesh's load and BVH, the
/// GPU path's set-up and the group's bookkeeping (`shscale bench estimates`, docs/BENCHMARKS.md).
const GROUP_OVERHEAD_SECONDS: f64 = 0.3;

/// The cost model's price of one per-run visibility image (EXR + PNG, truth beside extrapolation)
/// at one probe radius.
const IMAGE_SECONDS: f64 = 0.02;
use shscale_runner::{Cost, Ctx, Device, GpuMode, KeyError, Kind, Typed};
use shscale_scaling::Interp;
use shscale_scene::vocab::{
    check_sampling_keys, parse_interp, parse_spacing, MAX_K_COUNT, MAX_RADII, MAX_TRUTH_RES,
};
use shscale_scene::Error;
use std::path::{Path, PathBuf};

/// Parameters of one probe run (config keys; every one can be swept).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProbeParams {
    /// `sphere`, a procedural shape, a bundled mesh or a path.
    pub mesh: String,
    pub order: usize,
    /// Cone half-angle α in degrees, in (0, 90).
    pub alpha_deg: f64,
    /// `fixed` (α = alpha_deg at every distance) or `fit` (α by distance, the cone-angle law).
    pub alpha_mode: String,
    /// `latlong:RxC`, `cube:N` or `fib:P` (at most 10⁶ samples).
    pub layout: String,
    pub hemisphere_res: usize,
    /// Sampling sphere radius as a multiple of the bounding radius, ≥ 1.
    pub sampling_radius: f64,
    pub k_count: usize,
    /// `exp | uniform | chebyshev`.
    pub k_spacing: String,
    /// `linear | cubic` (in ln k).
    pub k_interp: String,
    /// The k-table's range; empty: the probes' range widened by 1.25 each way.
    pub k_min: Option<f64>,
    pub k_max: Option<f64>,
    /// On-surface threshold ε (× r).
    pub on_surface_eps: f64,
    /// Contact threshold: occluded fraction of the facing hemisphere, [0, 1].
    pub contact_occlusion: f64,
    /// `random` (seeded, between the samples) or `samples` (on them).
    pub probe_dirs: String,
    pub probe_seed: u64,
    /// Truth resolution T (4T² rays per probe) and the truth's seed.
    pub truth_res: usize,
    pub truth_seed: u64,
    /// `none` or `clamp` (the plausibility mitigation).
    pub plausibility: String,
    /// Sub-volumes: the mesh split into this many parts (1 = one sphere, the papers').
    pub parts: usize,
    /// Probe radii (× r).
    #[serde(with = "list")]
    pub radii: Vec<f64>,
}

impl Default for ProbeParams {
    fn default() -> Self {
        Self {
            mesh: "sphere".into(),
            order: 4,
            alpha_deg: 45.0,
            alpha_mode: "fixed".into(),
            layout: "latlong:12x20".into(),
            hemisphere_res: 32,
            sampling_radius: 1.0,
            k_count: 40,
            k_spacing: "exp".into(),
            k_interp: "linear".into(),
            k_min: None,
            k_max: None,
            on_surface_eps: 1e-3,
            contact_occlusion: shscale_field::probe::DEFAULT_CONTACT_OCCLUSION,
            probe_dirs: "random".into(),
            probe_seed: 1,
            truth_res: shscale_field::truth::DEFAULT_TRUTH_RES,
            truth_seed: shscale_field::truth::DEFAULT_TRUTH_SEED,
            plausibility: "none".into(),
            parts: 1,
            radii: shscale_field::probe::DEFAULT_RADII.to_vec(),
        }
    }
}

/// `"fixed" | "fit"`: whether α is fitted by distance.
pub(crate) fn parse_alpha_mode(s: &str) -> Result<bool, String> {
    match s {
        "fixed" => Ok(false),
        "fit" => Ok(true),
        _ => Err(format!("{s:?} is not one of \"fixed\", \"fit\"")),
    }
}

/// `"random" | "samples"` with the seed of `random`.
pub(crate) fn parse_probe_dirs(s: &str, seed: u64) -> Result<ProbeDirs, String> {
    match s {
        "random" => Ok(ProbeDirs::Random { seed }),
        "samples" => Ok(ProbeDirs::Samples),
        _ => Err(format!("{s:?} is not one of \"random\", \"samples\"")),
    }
}

impl ProbeParams {
    /// Validate (the kind's bounds), check the estimated work against the limits unless
    /// `allow_large`, and give the field crate's spec: what `shscale probe` and the Python
    /// `probe` do before any work. A bad parameter comes back as a [`KeyError`] naming it (the
    /// key without an index: `radii`, not `radii[2]`); a plan over the limits as its message.
    pub fn checked_spec(&self, allow_large: bool) -> Result<ProbeSpec, KeyError> {
        let resolved = <Probe as Kind>::resolve(self)
            .map_err(|e| KeyError::new(e.key.split('[').next().unwrap_or(&e.key), e.message))?;
        let (shared, run) = <Probe as Kind>::cost(&resolved);
        shscale_runner::limits::check_work(
            "probe",
            shared.rays + run.rays,
            shared.bytes.max(run.bytes),
            &shared.drivers,
            allow_large,
        )
        .map_err(|e| KeyError::new("", e.to_string()))?;
        Ok(resolved.typed)
    }

    /// The field crate's spec, every enum-like value parsed (parameters already validated: the
    /// kind's [`Kind::resolve`] calls it once).
    pub fn spec(&self) -> Result<ProbeSpec, Error> {
        let c = |m: String| Error::config(m);
        Ok(ProbeSpec {
            order: self.order,
            alpha: self.alpha_deg.to_radians(),
            layout: Layout::parse(&self.layout)?,
            hemisphere_res: self.hemisphere_res,
            sampling_radius: self.sampling_radius,
            radii: self.radii.clone(),
            k_count: self.k_count,
            k_spacing: parse_spacing(&self.k_spacing).map_err(c)?,
            k_interp: parse_interp(&self.k_interp).map_err(c)?,
            k_min: self.k_min,
            k_max: self.k_max,
            on_surface_eps: self.on_surface_eps,
            contact_occlusion: self.contact_occlusion,
            probe_dirs: parse_probe_dirs(&self.probe_dirs, self.probe_seed).map_err(c)?,
            truth_res: self.truth_res,
            truth_seed: self.truth_seed,
            plausibility: Plausibility::parse(&self.plausibility).map_err(c)?,
            alpha_fit: parse_alpha_mode(&self.alpha_mode).map_err(c)?,
        })
    }
}

/// What runs of a group share.
pub struct ProbeShared {
    occ: Box<dyn shscale_geometry::Occluder>,
    /// The mesh (none for the analytic sphere), for `parts > 1`.
    mesh: Option<shscale_geometry::Mesh>,
    base: driver::Base,
    gpu: (Option<f64>, Option<f64>, String),
}

/// The kind.
pub struct Probe;

fn base_key(p: &ProbeParams) -> String {
    format!(
        "mesh={};order={};layout={};hemisphere_res={};sampling_radius={};on_surface_eps={};dirs={}/{};truth={}/{};radii={:?}",
        p.mesh, p.order, p.layout, p.hemisphere_res, p.sampling_radius, p.on_surface_eps,
        p.probe_dirs, p.probe_seed, p.truth_res, p.truth_seed, p.radii
    )
}

impl Kind for Probe {
    const NAME: &'static str = "probe";
    const QUESTION: &'static str = "How close is SH-scaling extrapolation of a base-sphere visibility field to ray-traced visibility at probe radii (occ_rel_l2 per radius, on-surface samples separately), and at what cost?";
    type Params = ProbeParams;
    type Shared = ProbeShared;
    type Row = ProbeRow;
    type Error = Error;
    type Spec = Typed<ProbeParams, ProbeSpec>;

    fn inputs(
        p: &Self::Params,
        _config_dir: &std::path::Path,
    ) -> Result<Vec<shscale_runner::inputs::Input>, KeyError> {
        crate::common::mesh_inputs(&p.mesh)
    }
    fn open_device(mode: GpuMode) -> Result<Option<Device>, Error> {
        shscale_scene::gpu_path::open_device(mode)
    }

    fn describe() -> &'static [(&'static str, &'static str)] {
        &[
            ("mesh", "the occluder: `sphere` (analytic, closed-form truth), a procedural shape (`bird`, `egg`, `sponge`, `plane`), a bundled mesh (`bunny`, `duck`, `dragon_19k`, `knot`, `teapot`) or an .obj/.ply path (relative to the working directory)"),
            ("order", "SH order N (N² coefficients), 1..=16"),
            ("alpha_deg", "cone half-angle α of the cone approximation τ, degrees, in (0, 90)"),
            ("alpha_mode", "`fixed` (α = alpha_deg at every distance) or `fit` (α by distance: the law exact for a centred sphere, at the BSV's effective cap; docs/math.md §7)"),
            ("layout", "base-sphere sample layout: `latlong:RxC`, `cube:N` or `fib:P`, at most 10⁶ samples"),
            ("hemisphere_res", "H: H² rays per BSV sample (and per probe direction for the decomposition), 1..=256; the truth has its own `truth_res`"),
            ("sampling_radius", "radius of the sampling sphere in bounding radii, [1, 1000]; > 1 mitigates the on-surface failure"),
            ("k_count", "entries K of the k-table, 2..=10000 (≥ 4 for cubic)"),
            ("k_spacing", "spacing of the tabulated k: `exp`, `uniform` or `chebyshev`"),
            ("k_interp", "interpolation between table entries: `linear` or `cubic` (in ln k)"),
            ("k_min", "smallest tabulated k (> 0); empty: the probes' smallest k ÷ 1.25, so no probe sits on an end node"),
            ("k_max", "largest tabulated k (> k_min); empty: the probes' largest k × 1.25"),
            ("on_surface_eps", "on-surface threshold ε in bounding radii, [0, 1): samples closer to the surface are reported separately"),
            ("contact_occlusion", "contact threshold, [0, 1]: probe directions whose BSV occludes at least this fraction of the facing hemisphere are reported separately (docs/conventions.md §7)"),
            ("probe_dirs", "`random` (as many seeded uniform directions as samples, between them: the BSV interpolation is measured) or `samples` (on the sample directions, the papers' design)"),
            ("probe_seed", "seed of the `random` probe directions"),
            ("truth_res", "resolution T of the converged truth (4T² rays per probe, stratified, its own error reported), 1..=1024, independent of hemisphere_res"),
            ("truth_seed", "seed of the truth's per-probe rotations and jitter"),
            ("plausibility", "`none` or `clamp`: visibility clamped to [0, 1] in the angular domain and 1 outside the bounding sphere's cone, re-projected (docs/conventions.md §6)"),
            ("parts", "sub-volumes: the mesh split into 1..=64 parts (k-means on triangle centroids, as `budget`'s `sub_volumes`), each sampled with the run's layout, H and sampling radius and extrapolated from its own sphere, multiplied near to far at every probe; 1 is the papers' one sphere. Above 1 the single-sphere decomposition and on-surface columns stay empty and the BSV columns sum the parts; meshes only"),
            ("radii", "probe radii in bounding radii: 1 to 64 distinct values in (0, 1e6]"),
        ]
    }

    fn resolve(p: &ProbeParams) -> Result<Self::Spec, KeyError> {
        check_sampling_keys(&p.mesh, p.order, p.alpha_deg, &p.layout, p.hemisphere_res)?;
        KeyError::real("sampling_radius", p.sampling_radius, 1.0, 1e3, Ends::Closed)?;
        let interp = parse_interp(&p.k_interp).map_err(|m| KeyError::new("k_interp", m))?;
        parse_spacing(&p.k_spacing).map_err(|m| KeyError::new("k_spacing", m))?;
        let min_k = if interp == Interp::Cubic { 4 } else { 2 };
        KeyError::int("k_count", p.k_count, min_k, MAX_K_COUNT).map_err(|e| KeyError {
            message: format!("{} (≥ 4 for cubic)", e.message),
            ..e
        })?;
        KeyError::real(
            "on_surface_eps",
            p.on_surface_eps,
            0.0,
            1.0,
            Ends::ClosedOpen,
        )?;
        for (key, k) in [("k_min", p.k_min), ("k_max", p.k_max)] {
            if let Some(k) = k {
                KeyError::real(key, k, 0.0, 1e6, Ends::OpenClosed)?;
            }
        }
        KeyError::real(
            "contact_occlusion",
            p.contact_occlusion,
            0.0,
            1.0,
            Ends::Closed,
        )?;
        parse_probe_dirs(&p.probe_dirs, p.probe_seed)
            .map_err(|m| KeyError::new("probe_dirs", m))?;
        Plausibility::parse(&p.plausibility).map_err(|m| KeyError::new("plausibility", m))?;
        parse_alpha_mode(&p.alpha_mode).map_err(|m| KeyError::new("alpha_mode", m))?;
        KeyError::int("truth_res", p.truth_res, 1, MAX_TRUTH_RES)?;
        KeyError::int("parts", p.parts, 1, shscale_geometry::partition::MAX_PARTS)?;
        if p.parts > 1 && p.mesh == "sphere" {
            return Err(KeyError::new(
                "parts",
                "sub-volumes split a mesh; the analytic sphere has none",
            ));
        }
        check_radii(&p.radii)?;
        let (a, b) =
            shscale_field::probe::table_range_of(p.k_min, p.k_max, &p.radii, p.sampling_radius);
        if a >= b {
            return Err(KeyError::new(
                if p.k_max.is_some() { "k_max" } else { "k_min" },
                format!("the table range [{a}, {b}] is empty: k_max must exceed k_min"),
            ));
        }
        let typed = p.spec().map_err(|e| KeyError::new("", e.to_string()))?;
        Ok(Typed {
            params: p.clone(),
            typed,
        })
    }

    fn group_key(p: &ProbeParams) -> String {
        base_key(p)
    }

    fn cost(p: &Self::Spec) -> (Cost, Cost) {
        let samples = Layout::parse(&p.layout)
            .ok()
            .and_then(|l| l.sample_count())
            .unwrap_or(0) as f64;
        let h2 = (p.hemisphere_res * p.hemisphere_res) as f64;
        let nn = (p.order * p.order) as f64;
        let radii = p.radii.len() as f64;
        let t4 = 4.0 * (p.truth_res * p.truth_res) as f64;
        // The truth at every probe and radius, and at each probe direction on the sampling
        // sphere (the decomposition's converged BSV); the BSV at the probe directions when they
        // are not the samples.
        let truth_rays = if p.mesh == "sphere" {
            0.0
        } else {
            (radii + 1.0) * samples * t4
        };
        let direct_rays = if p.typed.probe_dirs == ProbeDirs::Samples {
            0.0
        } else {
            samples * h2
        };
        let bsv_rays = samples * h2 + direct_rays;
        let rays = bsv_rays + truth_rays;
        let shared = Cost {
            cached_once: None,
            rays,
            bytes: (1.0 + radii) * samples * nn * 8.0 + 64e6,
            // The BSV is timed (warm-up + repeats); the truths and the BSV at the probe
            // directions are computed once, as are the mesh's load and the GPU path's set-up.
            seconds: samples * h2 / CPU_RAYS_PER_SECOND,
            once_seconds: truth_rays / TRUTH_RAYS_PER_SECOND
                + direct_rays / CPU_RAYS_PER_SECOND
                + GROUP_OVERHEAD_SECONDS,
            drivers: format!(
                "mesh {} with layout = {:?} ({samples} samples) × hemisphere_res = {} ({h2} rays per BSV sample), truth_res = {} ({t4} rays per truth probe) × ({} radii + 1) → {rays:.3e} rays",
                p.mesh,
                p.layout,
                p.hemisphere_res,
                p.truth_res,
                p.radii.len()
            ),
        };
        let table = p.k_count as f64 * nn * nn * 8.0;
        // Sub-volumes sample every part's BSV per repeat.
        let part_rays = if p.parts > 1 {
            p.parts as f64 * samples * h2
        } else {
            0.0
        };
        let run = Cost {
            cached_once: None,
            rays: part_rays,
            bytes: p.parts as f64 * table + radii * samples * nn * 8.0,
            // Table build ≈ 70 ns per k and element pair at N = 4 (2.7 ms for K = 40),
            // extrapolation ≈ 10 ns per probe and element; both timed.
            seconds: p.parts as f64
                * (p.k_count as f64 * nn * nn * 2.6e-7 + radii * samples * nn * 1e-8)
                + part_rays / CPU_RAYS_PER_SECOND,
            // The per-run images (truth and extrapolated visibility at every radius).
            once_seconds: radii * IMAGE_SECONDS,
            drivers: format!("k_count = {} × order² = {nn}", p.k_count),
        };
        (shared, run)
    }

    fn rows_per_run(p: &ProbeParams) -> usize {
        p.radii.len()
    }

    fn shared(p: &Self::Spec, ctx: &Ctx) -> Result<ProbeShared, Error> {
        let spec = &p.typed;
        let u = shscale_scene::vocab::unit_occluder(&p.mesh)?;
        let base = driver::base(u.occ.as_ref(), u.analytic, spec, ctx.timing)?;
        let gpu = match (shscale_scene::gpu_path::gpu_of(ctx), u.mesh.as_ref()) {
            (Some(g), Some(m)) if p.order <= shscale_gpu::MAX_GPU_ORDER => {
                let b = m.bounding_sphere();
                let sphere = shscale_geometry::Sphere {
                    center: b.center,
                    radius: b.radius * p.sampling_radius,
                };
                let t = shscale_scene::gpu_path::time_gpu_bsv(
                    g,
                    m,
                    spec.layout,
                    p.order,
                    p.hemisphere_res,
                    sphere,
                    ctx.timing.repeats.max(5),
                )?;
                (
                    Some(t.sampling_seconds),
                    Some(t.conversion_seconds),
                    t.device,
                )
            }
            _ => (None, None, String::new()),
        };
        Ok(ProbeShared {
            occ: u.occ,
            mesh: u.mesh,
            base,
            gpu,
        })
    }

    fn run(
        p: &Self::Spec,
        run_id: &str,
        sh: &ProbeShared,
        ctx: &Ctx,
    ) -> Result<Vec<ProbeRow>, Error> {
        let spec = &p.typed;
        if p.parts > 1 {
            return subvolumes::rows(spec, p.parts, sh.mesh.as_ref(), &sh.base, ctx);
        }
        // The α- and K-dependent work, timed by the procedure: per repeat the table build and the
        // extrapolation at each radius.
        let (once, t) = ctx
            .timing
            .measure_each(|| driver::once(&sh.base.base, spec))?;
        figure::visibility_figure(ctx.dir, run_id, p.order, sh.occ.as_ref(), &once.examples)?;
        let rows = driver::with_times(once.rows, &sh.base, &t[0], &t[1..]);
        Ok(with_gpu(rows, &sh.gpu))
    }

    fn time_columns() -> &'static [&'static str] {
        &[
            "bsv_sampling_seconds",
            "bsv_sampling_spread",
            "table_build_seconds",
            "table_build_spread",
            "extrapolation_seconds",
            "extrapolation_spread",
            "truth_seconds",
            "gpu_bsv_sampling_seconds",
            "gpu_sh_conversion_seconds",
            "partition_seconds",
        ]
    }

    fn best_of() -> Option<(&'static str, &'static str)> {
        Some(("radius", "occ_rel_l2_mean"))
    }

    fn summary_columns() -> &'static [&'static str] {
        &[
            "radius",
            "occ_rel_l2_mean",
            "occ_rel_l2_on_surface_mean",
            "table_build_seconds",
        ]
    }

    fn report(dir: &Path, t: &Results) -> Result<Vec<PathBuf>, Error> {
        let params = shscale_runner::Erased::<Probe>::new();
        let varying = t.varying(&shscale_runner::DynKind::param_columns(&params));
        figure::probe_plots(dir, t, &varying)
    }

    fn discussion(t: &Results) -> Result<String, Error> {
        // Per run: the radii where the extrapolation follows the actual occlusion.
        // Rows grouped by run, in order of first appearance (linear in the rows).
        let mut runs: Vec<(String, Vec<usize>)> = Vec::new();
        let mut slot = std::collections::HashMap::new();
        for r in 0..t.rows.len() {
            let id = t.cell(r, "run_id");
            let i = *slot.entry(id).or_insert_with(|| {
                runs.push((id.to_string(), Vec::new()));
                runs.len() - 1
            });
            runs[i].1.push(r);
        }
        let params = shscale_runner::Erased::<Probe>::new();
        let varying = t.varying(&shscale_runner::DynKind::param_columns(&params));
        let mut out = String::new();
        if let [(_, rows)] = runs.as_slice() {
            out.push_str(&single_run_table(t, rows));
            out.push_str("\n**Comparison.** ");
        }
        for (id, rows) in &runs {
            let who = if runs.len() == 1 {
                "The extrapolation".to_string()
            } else {
                format!(
                    "- Run `{id}` ({})",
                    varying
                        .iter()
                        .filter(|c| *c != "radii")
                        .map(|c| format!("{c} = {}", t.cell(rows[0], c)))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            };
            out.push_str(&follows_sentence(t, &who, rows));
        }
        if runs.len() > 1 {
            // The list ends before the notes (a blank line closes it in Markdown).
            out.push('\n');
        }
        out.push_str(&truth_note(t));
        Ok(out)
    }

    fn figure(dir: &Path, t: &Results, out: &Path, stem: &str) -> Result<Vec<PathBuf>, Error> {
        // The first run's visibility image, under the figure's name.
        let Some(r) = (0..t.rows.len()).next() else {
            return Ok(Vec::new());
        };
        Ok(shscale_present::image::copy_image(
            dir,
            &format!("visibility_truth_vs_extrapolated_{}", t.cell(r, "run_id")),
            out,
            stem,
        )?)
    }
}

/// Rows with the group's GPU timings of the BSV (empty without a device).
fn with_gpu(mut rows: Vec<ProbeRow>, gpu: &(Option<f64>, Option<f64>, String)) -> Vec<ProbeRow> {
    for r in &mut rows {
        r.gpu_bsv_sampling_seconds = gpu.0;
        r.gpu_sh_conversion_seconds = gpu.1;
        r.gpu_device = gpu.2.clone();
    }
    rows
}

/// 1 to [`MAX_RADII`] distinct probe radii, each in (0, 1e6].
fn check_radii(radii: &[f64]) -> Result<(), KeyError> {
    if radii.is_empty() || radii.len() > MAX_RADII {
        return Err(KeyError::new(
            "radii",
            format!("{} radii: give 1 to {MAX_RADII}", radii.len()),
        ));
    }
    for r in radii {
        KeyError::real("radii", *r, 0.0, 1e6, Ends::OpenClosed)?;
    }
    for (i, r) in radii.iter().enumerate() {
        if radii[..i].contains(r) {
            return Err(KeyError::new(
                &format!("radii[{i}]"),
                format!("radius {r} appears twice"),
            ));
        }
    }
    Ok(())
}
