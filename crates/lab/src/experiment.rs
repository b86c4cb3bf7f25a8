//! Experiment configs (TOML), raw → resolved plan (STYLE.md §5): fixed parameters at the top
//! level, sweep axes under `[sweep]`, expanded into a deterministic list of runs, each with a run
//! id hashed from its resolved parameters. Every error names the file, the line and the field.
//!
//! ```toml
//! experiment = "probe"        # the experiment kind (probe: extrapolated vs truth at radii)
//! name = "alpha_sweep"        # results/<experiment>/<name>/ (default: the file stem)
//! mesh = "bunny"              # bundled name, path, or "sphere"
//! order = 4
//! alpha_deg = 45
//! layout = "latlong:12x20"
//! hemisphere_res = 32
//! sampling_radius = 1.0
//! k_count = 40
//! k_spacing = "exp"           # exp | uniform | chebyshev
//! k_interp = "linear"         # linear | cubic (in ln k)
//! radii = [0.5, 0.7, 0.9, 1.3, 2.0]
//! gpu = "auto"                # also time GPU BSV sampling: auto | off | required
//! parallel_runs = true        # runs sharing a BSV run in parallel (false: one at a time)
//!
//! [sweep]                     # any of the scalar parameters above, as lists
//! alpha_deg = [15, 30, 45, 60, 75]
//! order = [2, 4, 8]
//! ```

use crate::LabError;
use serde::Deserialize;
use shscale_field::Layout;
use shscale_scaling::{Interp, Spacing};
use std::collections::BTreeMap;
use std::path::Path;

/// The file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawExperiment {
    pub experiment: String,
    pub name: Option<String>,
    pub mesh: Option<String>,
    pub order: Option<usize>,
    pub alpha_deg: Option<f64>,
    pub layout: Option<String>,
    pub hemisphere_res: Option<usize>,
    pub sampling_radius: Option<f64>,
    pub k_count: Option<usize>,
    pub k_spacing: Option<String>,
    pub k_interp: Option<String>,
    pub on_surface_eps: Option<f64>,
    pub radii: Option<Vec<f64>>,
    pub gpu: Option<String>,
    pub parallel_runs: Option<bool>,
    #[serde(default)]
    pub sweep: BTreeMap<String, toml::Value>,
}

/// One run's resolved parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeParams {
    pub mesh: String,
    pub order: usize,
    pub alpha_deg: f64,
    pub layout: Layout,
    pub hemisphere_res: usize,
    pub sampling_radius: f64,
    pub k_count: usize,
    pub k_spacing: Spacing,
    pub k_interp: Interp,
    pub on_surface_eps: f64,
    pub radii: Vec<f64>,
}

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

fn spacing_name(s: Spacing) -> &'static str {
    match s {
        Spacing::Exp => "exp",
        Spacing::Uniform => "uniform",
        Spacing::Chebyshev => "chebyshev",
    }
}

fn interp_name(i: Interp) -> &'static str {
    match i {
        Interp::Linear => "linear",
        Interp::Cubic => "cubic",
    }
}

impl ProbeParams {
    /// Canonical `key=value;…` form (fixed key order), the input of the run id. The k-table's
    /// spacing and interpolation appear only when they differ from the default (exp, linear), so
    /// run ids of configs that never set them are unchanged.
    pub fn canonical(&self) -> String {
        let mut table = String::new();
        if self.k_spacing != Spacing::Exp {
            table.push_str(&format!(";k_spacing={}", spacing_name(self.k_spacing)));
        }
        if self.k_interp != Interp::Linear {
            table.push_str(&format!(";k_interp={}", interp_name(self.k_interp)));
        }
        format!(
            "mesh={};order={};alpha_deg={};layout={};hemisphere_res={};sampling_radius={};k_count={}{table};on_surface_eps={};radii={:?}",
            self.mesh,
            self.order,
            self.alpha_deg,
            self.layout.name(),
            self.hemisphere_res,
            self.sampling_radius,
            self.k_count,
            self.on_surface_eps,
            self.radii
        )
    }

    /// The spacing's config spelling.
    pub fn k_spacing_name(&self) -> &'static str {
        spacing_name(self.k_spacing)
    }

    /// The interpolation's config spelling.
    pub fn k_interp_name(&self) -> &'static str {
        interp_name(self.k_interp)
    }

    /// Deterministic run id: FNV-1a (64 bit) of [`ProbeParams::canonical`], hex.
    pub fn run_id(&self) -> String {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in self.canonical().bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        format!("{h:016x}")
    }
}

/// A resolved experiment: its kind, name and the expanded runs.
#[derive(Clone, Debug)]
pub struct Plan {
    pub file: String,
    pub experiment: String,
    pub name: String,
    pub runs: Vec<ProbeParams>,
    /// The config text, recorded in the manifest.
    pub text: String,
    /// The sweep axes, in expansion order.
    pub swept: Vec<String>,
    /// `gpu = "auto" | "off" | "required"`: time GPU BSV sampling in every run where an adapter
    /// exists (not part of the run ids: it adds timing columns, never changes a metric).
    pub gpu: crate::gpu_path::GpuMode,
    /// Run the runs of a group in parallel (default true); `false` when per-run times must not
    /// share the cores with other runs.
    pub parallel_runs: bool,
}

/// Whether a run's mesh can be built: the analytic sphere, a procedural shape, a bundled name or
/// an existing file.
fn mesh_exists(mesh: &str) -> bool {
    matches!(mesh, "sphere" | "bird" | "egg" | "sponge" | "plane")
        || shscale_geometry::bundled::names().contains(&mesh)
        || Path::new(mesh).is_file()
}

fn line_of_key(text: &str, key: &str) -> usize {
    text.lines()
        .position(|l| {
            let t = l.trim_start();
            t.starts_with(&format!("{key} ")) || t.starts_with(&format!("{key}="))
        })
        .map_or(0, |i| i + 1)
}

impl Plan {
    /// Read and resolve a config file.
    pub fn load(path: &Path) -> Result<Self, LabError> {
        let text = std::fs::read_to_string(path).map_err(|e| LabError::Io {
            path: path.display().to_string(),
            reason: e.to_string(),
        })?;
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_else(|| "experiment".into());
        Self::parse(&path.display().to_string(), &stem, &text)
    }

    /// Resolve config text (`file` names it in errors; `stem` is the default name).
    pub fn parse(file: &str, stem: &str, text: &str) -> Result<Self, LabError> {
        let raw: RawExperiment =
            toml::from_str(text).map_err(|e| crate::toml_error(file, text, &e))?;
        let err = |key: &str, msg: String| {
            LabError::Config(format!("{file}:{}: {key}: {msg}", line_of_key(text, key)))
        };
        if raw.experiment != "probe" {
            return Err(err(
                "experiment",
                format!(
                    "{:?} is not a known experiment kind (sweeps: probe; studies: midrange, srf, extremes and the figure kinds)",
                    raw.experiment
                ),
            ));
        }
        let base = ProbeParams {
            mesh: raw.mesh.clone().unwrap_or_else(|| "sphere".into()),
            order: raw.order.unwrap_or(4),
            alpha_deg: raw.alpha_deg.unwrap_or(45.0),
            layout: Layout::parse(raw.layout.as_deref().unwrap_or("latlong:12x20"))
                .map_err(|e| err("layout", e.to_string()))?,
            hemisphere_res: raw.hemisphere_res.unwrap_or(32),
            sampling_radius: raw.sampling_radius.unwrap_or(1.0),
            k_count: raw.k_count.unwrap_or(40),
            k_spacing: parse_spacing(raw.k_spacing.as_deref().unwrap_or("exp"))
                .map_err(|e| err("k_spacing", e))?,
            k_interp: parse_interp(raw.k_interp.as_deref().unwrap_or("linear"))
                .map_err(|e| err("k_interp", e))?,
            on_surface_eps: raw.on_surface_eps.unwrap_or(1e-3),
            radii: raw
                .radii
                .clone()
                .unwrap_or_else(|| vec![0.5, 0.7, 0.9, 1.3, 2.0]),
        };
        // Expand the sweep: the cartesian product in key order (BTreeMap: alphabetical).
        let mut runs = vec![base];
        for (key, value) in &raw.sweep {
            let items = value
                .as_array()
                .ok_or_else(|| err(key, "a sweep axis must be a list".into()))?;
            if items.is_empty() {
                return Err(err(key, "a sweep axis must not be empty".into()));
            }
            let mut next = Vec::with_capacity(runs.len() * items.len());
            for run in &runs {
                for item in items {
                    let mut r = run.clone();
                    let num = || {
                        item.as_float()
                            .or_else(|| item.as_integer().map(|i| i as f64))
                    };
                    let bad = || err(key, format!("sweep value {item} has the wrong type"));
                    match key.as_str() {
                        "mesh" => r.mesh = item.as_str().ok_or_else(bad)?.to_string(),
                        "layout" => r.layout = Layout::parse(item.as_str().ok_or_else(bad)?).map_err(|e| err(key, e.to_string()))?,
                        "order" => r.order = item.as_integer().filter(|v| *v > 0).ok_or_else(bad)? as usize,
                        "hemisphere_res" => r.hemisphere_res = item.as_integer().filter(|v| *v > 0).ok_or_else(bad)? as usize,
                        "k_count" => r.k_count = item.as_integer().filter(|v| *v > 0).ok_or_else(bad)? as usize,
                        "k_spacing" => r.k_spacing = parse_spacing(item.as_str().ok_or_else(bad)?).map_err(|e| err(key, e))?,
                        "k_interp" => r.k_interp = parse_interp(item.as_str().ok_or_else(bad)?).map_err(|e| err(key, e))?,
                        "alpha_deg" => r.alpha_deg = num().ok_or_else(bad)?,
                        "sampling_radius" => r.sampling_radius = num().ok_or_else(bad)?,
                        "on_surface_eps" => r.on_surface_eps = num().ok_or_else(bad)?,
                        other => return Err(err(other, "is not a sweepable parameter (mesh, layout, order, hemisphere_res, k_count, k_spacing, k_interp, alpha_deg, sampling_radius, on_surface_eps)".into())),
                    }
                    next.push(r);
                }
            }
            runs = next;
        }
        for r in &runs {
            let key_err =
                |key: &str, msg: String| err(key, format!("{msg} (run {})", r.canonical()));
            if !mesh_exists(&r.mesh) {
                return Err(key_err(
                    "mesh",
                    format!(
                        "{:?} is neither \"sphere\", a procedural shape (bird, egg, sponge, plane), a bundled mesh ({}) nor an existing .obj/.ply file",
                        r.mesh,
                        shscale_geometry::bundled::names().join(", ")
                    ),
                ));
            }
            if !(1..=16).contains(&r.order) {
                return Err(key_err("order", format!("{} is outside 1..=16", r.order)));
            }
            if !(r.alpha_deg > 0.0 && r.alpha_deg < 90.0) {
                return Err(key_err(
                    "alpha_deg",
                    format!("{} is outside (0, 90)", r.alpha_deg),
                ));
            }
            if !(1..=256).contains(&r.hemisphere_res) {
                return Err(key_err(
                    "hemisphere_res",
                    format!("{} is outside 1..=256", r.hemisphere_res),
                ));
            }
            if !(r.sampling_radius.is_finite() && r.sampling_radius >= 1.0) {
                return Err(key_err(
                    "sampling_radius",
                    format!("{} must be ≥ 1", r.sampling_radius),
                ));
            }
            if r.k_count < 2 || (r.k_interp == Interp::Cubic && r.k_count < 4) {
                return Err(key_err(
                    "k_count",
                    format!("{} must be ≥ 2 (≥ 4 for cubic interpolation)", r.k_count),
                ));
            }
            if !(r.on_surface_eps.is_finite() && r.on_surface_eps >= 0.0) {
                return Err(key_err(
                    "on_surface_eps",
                    format!("{} must be ≥ 0", r.on_surface_eps),
                ));
            }
            if r.radii.is_empty() || r.radii.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
                return Err(key_err(
                    "radii",
                    format!("{:?} must be non-empty, finite and > 0", r.radii),
                ));
            }
        }
        let gpu = match raw.gpu.as_deref() {
            None => crate::gpu_path::GpuMode::Auto,
            Some(g) => crate::gpu_path::GpuMode::parse(g).map_err(|e| err("gpu", e))?,
        };
        let swept = raw.sweep.keys().cloned().collect();
        Ok(Self {
            file: file.into(),
            experiment: raw.experiment,
            name: raw.name.unwrap_or_else(|| stem.to_string()),
            runs,
            text: text.to_string(),
            swept,
            gpu,
            parallel_runs: raw.parallel_runs.unwrap_or(true),
        })
    }
}
