//! The `probe` kind (SHS Fig. 5 / TR Fig. 1): extrapolated vs ray-traced visibility at probe
//! radii along the probe directions (seeded, between the base-sphere samples, or on them), one row
//! per run and radius. Runs sharing mesh, order, layout, H, sampling radius, ε, probe directions,
//! truth resolution and seed, and radii share the BSV and the truth (computed once); α, the
//! k-table, the contact threshold and the plausibility mitigation vary per run.

use serde::{Deserialize, Serialize};
use shscale_field::extrapolate::Plausibility;
use shscale_field::probe::{
    probe_base_on, probe_with, sample_bsv, ProbeBase, ProbeDirs, ProbeSpec,
};
use shscale_field::Layout;
use shscale_runner::check::Ends;
use shscale_runner::records::{list, Results};
use shscale_runner::timing::{Timing, CPU_RAYS_PER_SECOND, TRUTH_RAYS_PER_SECOND};

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
pub fn parse_alpha_mode(s: &str) -> Result<bool, String> {
    match s {
        "fixed" => Ok(false),
        "fit" => Ok(true),
        _ => Err(format!("{s:?} is not one of \"fixed\", \"fit\"")),
    }
}

/// `"random" | "samples"` with the seed of `random`.
pub fn parse_probe_dirs(s: &str, seed: u64) -> Result<ProbeDirs, String> {
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

/// One row: a run at one probe radius (metric names of docs/conventions.md §6; the accuracy
/// columns are those of [`shscale_field::probe::ProbeRow`], documented there).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct ProbeRow {
    pub radius: f64,
    pub k: f64,
    pub k_node_offset: f64,
    pub alpha_used_deg: f64,
    /// The BSV's effective cap θ₀, degrees (what `alpha_mode = "fit"` uses).
    pub effective_cap_deg: f64,
    pub probes: usize,
    pub inside_count: usize,
    pub unoccluded_truth_count: usize,
    pub clamped_count: usize,
    pub vis_rel_l2_mean: Option<f64>,
    pub vis_rel_l2_max: Option<f64>,
    pub occ_rel_l2_mean: Option<f64>,
    pub occ_rel_l2_max: Option<f64>,
    /// Quantiles of `occ_rel_l2` over the probes with a truth (p5, p25, median, p75, p95;
    /// linear rule, `metrics::quantiles`).
    pub occ_rel_l2_p05: Option<f64>,
    pub occ_rel_l2_p25: Option<f64>,
    pub occ_rel_l2_p50: Option<f64>,
    pub occ_rel_l2_p75: Option<f64>,
    pub occ_rel_l2_p95: Option<f64>,
    pub truth_rel_err_mean: Option<f64>,
    pub truth_rel_err_max: Option<f64>,
    pub truth_limited_count: usize,
    pub occ_rel_l2_exact_k_mean: Option<f64>,
    pub occ_rel_l2_exact_dir_mean: Option<f64>,
    pub occ_rel_l2_model_mean: Option<f64>,
    pub band_limit_rel_mean: Option<f64>,
    pub implausible_count: usize,
    pub occ_solid_angle_min: Option<f64>,
    pub occ_solid_angle_max: Option<f64>,
    pub on_surface_count: usize,
    pub vis_rel_l2_on_surface_mean: Option<f64>,
    pub occ_rel_l2_on_surface_mean: Option<f64>,
    pub occ_rel_l2_on_surface_max: Option<f64>,
    pub contact_count: usize,
    pub occ_rel_l2_contact_mean: Option<f64>,
    pub occ_rel_l2_contact_max: Option<f64>,
    pub bsv_rays: usize,
    /// Rays per probe of the truth (0: closed form).
    pub truth_rays: usize,
    /// Median over the timing procedure; `*_spread` = (max − min) / median.
    pub bsv_sampling_seconds: f64,
    pub bsv_sampling_spread: f64,
    pub table_build_seconds: f64,
    pub table_build_spread: f64,
    pub extrapolation_seconds: f64,
    pub extrapolation_spread: f64,
    /// The truth at this radius, measured once (it is the reference, not a method under test).
    pub truth_seconds: f64,
    pub gpu_bsv_sampling_seconds: Option<f64>,
    pub gpu_sh_conversion_seconds: Option<f64>,
    pub gpu_device: String,
    /// `parts > 1`: the partition's time (k-means, the parts' meshes and BVHs), once per run.
    pub partition_seconds: Option<f64>,
}

/// What runs of a group share.
pub struct ProbeShared {
    occ: Box<dyn shscale_geometry::Occluder>,
    /// The mesh (none for the analytic sphere), for `parts > 1`.
    mesh: Option<shscale_geometry::Mesh>,
    base: ProbeBase,
    bsv_timing: Timing,
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
        let direct_rays = if p.probe_dirs == "samples" {
            0.0
        } else {
            samples * h2
        };
        let bsv_rays = samples * h2 + direct_rays;
        let rays = bsv_rays + truth_rays;
        let shared = Cost {
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
        let (bsv, bsv_timing) = ctx.timing.measure(|| sample_bsv(u.occ.as_ref(), spec))?;
        let base = probe_base_on(bsv, bsv_timing.median, u.occ.as_ref(), u.analytic, spec)?;
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
            bsv_timing,
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
            return sub_volume_rows(p, sh, ctx);
        }
        // The α- and K-dependent work, timed by the procedure: per repeat the table build and the
        // extrapolation at each radius.
        let mut results = Vec::new();
        for i in 0..ctx.timing.warmup + ctx.timing.repeats.max(1) {
            let r = probe_with(&sh.base, spec)?;
            if i >= ctx.timing.warmup {
                results.push(r);
            }
        }
        let table = Timing::of(
            &results
                .iter()
                .map(|r| r.table_build_seconds)
                .collect::<Vec<_>>(),
        );
        let res = results.pop().expect("one repeat at least");
        crate::probe_figure::visibility_figure(
            ctx.dir,
            run_id,
            p.order,
            sh.occ.as_ref(),
            &res.examples,
        )?;
        Ok(res
            .rows
            .iter()
            .enumerate()
            .map(|(ri, r)| {
                let mut ext: Vec<f64> = results
                    .iter()
                    .map(|x| x.rows[ri].extrapolation_seconds)
                    .collect();
                ext.push(r.extrapolation_seconds);
                row_of(r, &res, sh, &table, &Timing::of(&ext))
            })
            .collect())
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
        crate::probe_figure::probe_plots(dir, t, &varying)
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
        Ok(shscale_runner::image::copy_image(
            dir,
            &format!("visibility_truth_vs_extrapolated_{}", t.cell(r, "run_id")),
            out,
            stem,
        )?)
    }
}

/// One radius's row of a run: the field's row `r` of the last repeat `res`, with the shared
/// work's rays and times and the timed stages' medians and spreads.
fn row_of(
    r: &shscale_field::probe::ProbeRow,
    res: &shscale_field::probe::ProbeResult,
    sh: &ProbeShared,
    table: &Timing,
    ext: &Timing,
) -> ProbeRow {
    ProbeRow {
        radius: r.radius,
        k: r.k,
        k_node_offset: r.k_node_offset,
        alpha_used_deg: r.alpha_used_deg,
        effective_cap_deg: res.effective_cap_deg,
        probes: r.probes,
        inside_count: r.inside_count,
        unoccluded_truth_count: r.unoccluded_truth_count,
        clamped_count: r.clamped_count,
        vis_rel_l2_mean: r.vis_rel_l2_mean,
        vis_rel_l2_max: r.vis_rel_l2_max,
        occ_rel_l2_mean: r.occ_rel_l2_mean,
        occ_rel_l2_max: r.occ_rel_l2_max,
        occ_rel_l2_p05: r.occ_rel_l2_p05,
        occ_rel_l2_p25: r.occ_rel_l2_p25,
        occ_rel_l2_p50: r.occ_rel_l2_p50,
        occ_rel_l2_p75: r.occ_rel_l2_p75,
        occ_rel_l2_p95: r.occ_rel_l2_p95,
        truth_rel_err_mean: r.truth_rel_err_mean,
        truth_rel_err_max: r.truth_rel_err_max,
        truth_limited_count: r.truth_limited_count,
        occ_rel_l2_exact_k_mean: r.occ_rel_l2_exact_k_mean,
        occ_rel_l2_exact_dir_mean: r.occ_rel_l2_exact_dir_mean,
        occ_rel_l2_model_mean: r.occ_rel_l2_model_mean,
        band_limit_rel_mean: r.band_limit_rel_mean,
        implausible_count: r.implausible_count,
        occ_solid_angle_min: r.occ_solid_angle_min,
        occ_solid_angle_max: r.occ_solid_angle_max,
        on_surface_count: r.on_surface_count,
        vis_rel_l2_on_surface_mean: r.vis_rel_l2_on_surface_mean,
        occ_rel_l2_on_surface_mean: r.occ_rel_l2_on_surface_mean,
        occ_rel_l2_on_surface_max: r.occ_rel_l2_on_surface_max,
        contact_count: r.contact_count,
        occ_rel_l2_contact_mean: r.occ_rel_l2_contact_mean,
        occ_rel_l2_contact_max: r.occ_rel_l2_contact_max,
        bsv_rays: res.bsv_rays,
        truth_rays: res.truth_rays_per_probe,
        bsv_sampling_seconds: sh.bsv_timing.median,
        bsv_sampling_spread: sh.bsv_timing.spread(),
        table_build_seconds: table.median,
        table_build_spread: table.spread(),
        extrapolation_seconds: ext.median,
        extrapolation_spread: ext.spread(),
        truth_seconds: r.truth_seconds,
        gpu_bsv_sampling_seconds: sh.gpu.0,
        gpu_sh_conversion_seconds: sh.gpu.1,
        gpu_device: sh.gpu.2.clone(),
        partition_seconds: None,
    }
}

/// The rows of a run with `parts > 1`: the mesh partitioned once per run (timed on its own);
/// per repeat of the timing procedure (timed stage by stage, as the one-sphere rows are,
/// except that the evaluation covers every radius) every part's BSV (the run's layout, H and
/// sampling radius on the part's own sphere), its k-table (fixed α, or α by distance at the part's
/// effective cap; over the k its probes need, widened by `K_MARGIN`, at least 1e-3) and the
/// product of the parts near to far at every probe point ([`SubVolumeField`]); scored against
/// the group's truth at the same points, as the one-sphere rows are. The decomposition, the
/// on-surface and the contact columns belong to one sphere and stay empty.
fn sub_volume_rows(
    p: &Typed<ProbeParams, ProbeSpec>,
    sh: &ProbeShared,
    ctx: &Ctx,
) -> Result<Vec<ProbeRow>, Error> {
    use rayon::prelude::*;
    use shscale_field::metrics::{mean_max, occ_rel_l2, quantiles, vis_rel_l2};
    use shscale_scaling::{Eta, KTable, TauFamily};
    let spec = &p.typed;
    let mesh = (sh.mesh.as_ref()).ok_or_else(|| {
        Error::config("sub-volumes split a mesh; the analytic sphere has none".into())
    })?;
    let t0 = std::time::Instant::now();
    let labels = shscale_geometry::partition::kmeans_parts(mesh, p.parts)
        .map_err(|e| Error::config(e.to_string()))?;
    let bvhs: Vec<shscale_geometry::MeshBvh> =
        (shscale_geometry::partition::split(mesh, &labels, p.parts).iter())
            .map(|m| {
                shscale_geometry::MeshBvh::build(m, shscale_geometry::ray::UpdateStrategy::Rebuild)
            })
            .collect();
    let partition_seconds = t0.elapsed().as_secs_f64();
    let s = sh.base.bsv.sphere;
    let points: Vec<Vec<glam::DVec3>> = (spec.radii.iter())
        .map(|rho| {
            sh.base
                .dirs
                .iter()
                .map(|d| s.center + rho * s.radius * *d)
                .collect()
        })
        .collect();
    let gaunt =
        shscale_sh::GauntTensor::<f64>::new(p.order).map_err(|e| Error::config(e.to_string()))?;
    let nn = p.order * p.order;
    let (values, [sampling, table, eval]) = ctx.timing.measure_parts(|| -> Result<_, Error> {
        let t0 = std::time::Instant::now();
        let bsvs = (bvhs.iter())
            .map(|b| sample_bsv(b, spec))
            .collect::<Result<Vec<_>, _>>()?;
        let t1 = std::time::Instant::now();
        let tables = (bsvs.iter())
            .map(|b| {
                let (lo, hi) = shscale_field::probe::k_range_to(
                    b.sphere.center,
                    b.sampling_radius,
                    points.iter().flatten().copied(),
                    shscale_field::probe::K_MARGIN,
                );
                let lo = lo.max(1e-3);
                let family = if spec.alpha_fit {
                    TauFamily::ConeFit {
                        theta0: shscale_field::alpha::effective_cap_angle(b),
                    }
                } else {
                    TauFamily::Cone { alpha: spec.alpha }
                };
                KTable::build(
                    family,
                    Eta::Plain,
                    p.order,
                    spec.k_count,
                    lo,
                    hi.max(lo * 1.01),
                    spec.k_spacing,
                    spec.k_interp,
                )
                .map_err(|e| Error::config(e.to_string()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let t2 = std::time::Instant::now();
        let exs = (bsvs.iter().zip(&tables))
            .map(|(b, t)| {
                shscale_field::extrapolate::Extrapolator::new(b, t)
                    .with_plausibility(spec.plausibility)
            })
            .collect();
        let field = shscale_field::subvolume::SubVolumeField::new(exs, &gaunt);
        let values: Vec<Vec<Vec<f64>>> = (points.iter())
            .map(|ps| {
                ps.par_iter()
                    .map(|q| {
                        let mut out = vec![0.0; nn];
                        shscale_field::evaluator::VisibilityField::eval(&field, *q, &mut out);
                        out
                    })
                    .collect()
            })
            .collect();
        let rays: usize = bsvs.iter().map(|b| b.rays).sum();
        let secs = |a: std::time::Instant, b: std::time::Instant| (b - a).as_secs_f64();
        let t3 = std::time::Instant::now();
        Ok(((values, rays), [secs(t0, t1), secs(t1, t2), secs(t2, t3)]))
    })?;
    let (values, rays) = values;
    Ok((spec.radii.iter().enumerate())
        .map(|(ri, &rho)| {
            let truths = &sh.base.truth[ri];
            let pairs: Vec<(&Vec<f64>, &shscale_field::truth::Truth)> = (values[ri].iter())
                .zip(truths)
                .filter_map(|(v, t)| t.as_ref().map(|t| (v, t)))
                .collect();
            let occ: Vec<Option<f64>> = pairs
                .iter()
                .map(|(v, t)| occ_rel_l2(v, &t.coeffs))
                .collect();
            let (om, ox, _) = mean_max(occ.iter().copied());
            let (vm, vx, _) = mean_max(pairs.iter().map(|(v, t)| vis_rel_l2(v, &t.coeffs)));
            let q = quantiles(occ.iter().copied(), &[0.05, 0.25, 0.5, 0.75, 0.95]);
            ProbeRow {
                radius: rho,
                k: rho / spec.sampling_radius,
                alpha_used_deg: spec.alpha.to_degrees(),
                probes: truths.len(),
                inside_count: truths.iter().filter(|t| t.is_none()).count(),
                unoccluded_truth_count: occ.iter().filter(|o| o.is_none()).count(),
                vis_rel_l2_mean: vm,
                vis_rel_l2_max: vx,
                occ_rel_l2_mean: om,
                occ_rel_l2_max: ox,
                occ_rel_l2_p05: q[0],
                occ_rel_l2_p25: q[1],
                occ_rel_l2_p50: q[2],
                occ_rel_l2_p75: q[3],
                occ_rel_l2_p95: q[4],
                bsv_rays: rays,
                truth_rays: sh.base.truth_rays_per_probe,
                bsv_sampling_seconds: sampling.median,
                bsv_sampling_spread: sampling.spread(),
                table_build_seconds: table.median,
                table_build_spread: table.spread(),
                // Every radius at once (the one-sphere rows time each radius).
                extrapolation_seconds: eval.median,
                extrapolation_spread: eval.spread(),
                truth_seconds: sh.base.truth_seconds[ri],
                partition_seconds: Some(partition_seconds),
                ..ProbeRow::default()
            }
        })
        .collect())
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

/// A finite error to three decimals, `—` otherwise.
fn fmt3(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3}")
    } else {
        "—".into()
    }
}

/// The discussion's table of a single run: its setting, then per radius the mean errors.
fn single_run_table(t: &Results, rows: &[usize]) -> String {
    let r0 = rows[0];
    let mut out = format!(
        "**Ours.** Mesh `{}`, N = {}, α = {}°, BSV on `{}` × {}² rays, K = {} ({} k, {} interpolation). Mean errors over the \
probe directions per radius (`probe_dirs = {}`: seeded directions between the samples unless `samples`; docs/conventions.md §6; \
`occ_rel_l2` is relative to the occluded part; both compare coefficients with the converged truth projected to order N — its own \
error is in the CSV's `truth_rel_err_mean` — so they measure the extrapolation alone, not band-limiting). Image: one probe direction \
per radius (rows), actual full-frequency visibility (left, white = visible; lat-long, +z at the top) beside the extrapolated \
visibility (right).\n\n\
| radius (× r) | k | probes | vis_rel_l2 | occ_rel_l2 | inside the mesh |\n|---:|---:|---:|---:|---:|---:|\n",
        t.cell(r0, "mesh"),
        t.cell(r0, "order"),
        t.cell(r0, "alpha_deg"),
        t.cell(r0, "layout"),
        t.cell(r0, "hemisphere_res"),
        t.cell(r0, "k_count"),
        t.cell(r0, "k_spacing"),
        t.cell(r0, "k_interp"),
        t.cell(r0, "probe_dirs"),
    );
    for &r in rows {
        out.push_str(&format!(
            "| {} | {:.2} | {} | {} | {} | {} |\n",
            t.cell(r, "radius"),
            t.num(r, "k"),
            t.cell(r, "probes"),
            fmt3(t.num(r, "vis_rel_l2_mean")),
            fmt3(t.num(r, "occ_rel_l2_mean")),
            t.cell(r, "inside_count")
        ));
    }
    out
}

/// Where one run (`who`, its rows) follows the actual occlusion (occ_rel_l2 < [`FOLLOWS`]) and
/// where it departs from it, with its best and worst radius.
fn follows_sentence(t: &Results, who: &str, rows: &[usize]) -> String {
    let occ = |r: usize| t.num(r, "occ_rel_l2_mean");
    let finite: Vec<usize> = rows
        .iter()
        .copied()
        .filter(|&r| occ(r).is_finite())
        .collect();
    let list = |follows: bool| {
        let v: Vec<String> = (finite.iter())
            .filter(|&&r| (occ(r) < FOLLOWS) == follows)
            .map(|&r| format!("{}r", t.cell(r, "radius")))
            .collect();
        if v.is_empty() {
            "no radius".to_string()
        } else {
            v.join(", ")
        }
    };
    let best = finite
        .iter()
        .copied()
        .min_by(|&a, &b| occ(a).total_cmp(&occ(b)));
    let worst = finite
        .iter()
        .copied()
        .max_by(|&a, &b| occ(a).total_cmp(&occ(b)));
    match (best, worst) {
        (Some(b), Some(w)) => format!(
            "{who} follows the actual occlusion (occ_rel_l2 < {FOLLOWS}) at {} and departs from it at {}: best at {}r ({:.3}), worst at {}r \
({:.3}; above 1 is worse than predicting no occlusion).\n",
            list(true),
            list(false),
            t.cell(b, "radius"),
            occ(b),
            t.cell(w, "radius"),
            occ(w)
        ),
        _ => format!("{who}: no radius has a finite occ_rel_l2 (no occluded truth).\n"),
    }
}

/// The truth's own error against the method's: rows where the truth does not resolve the error
/// are flagged (docs/conventions.md §6).
fn truth_note(t: &Results) -> String {
    let limited: Vec<String> = (0..t.rows.len())
        .filter(|&r| t.num(r, "truth_limited_count") > 0.0)
        .map(|r| {
            format!(
                "run `{}` at {}r ({} probes)",
                t.cell(r, "run_id"),
                t.cell(r, "radius"),
                t.cell(r, "truth_limited_count")
            )
        })
        .collect();
    let worst = (0..t.rows.len())
        .map(|r| t.num(r, "truth_rel_err_mean"))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    if limited.is_empty() {
        format!(
            "\n**Truth.** The converged truth's own error (mean per row) is at most {worst:.4} of the occlusion, and no probe's \
occ_rel_l2 is within 3× of its truth's error.\n"
        )
    } else {
        format!(
            "\n**Truth-limited** (occ_rel_l2 within 3× of the truth's own error; raise `truth_res`): {}. The truth's mean \
error per row is at most {worst:.4} of the occlusion.\n",
            limited.join(", ")
        )
    }
}

/// occ_rel_l2 below which the discussion says the extrapolation follows the actual occlusion.
pub const FOLLOWS: f64 = 0.5;
