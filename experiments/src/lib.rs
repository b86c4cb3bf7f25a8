//! The papers' figures and tables, one module per figure, each answering one question
//! (docs/conventions.md §8):
//!
//! - [`sparsity`] — Fig. 2: where are the non-zeros of a scaling matrix, and is the pattern
//!   really independent of τ?
//! - [`m_elements`] — Fig. 3: how smoothly do elements of `M_k` vary with k, and how well does a
//!   40-entry table interpolate them?
//! - [`visibility_radii`] — Fig. 5: how does extrapolated visibility compare with the actual
//!   visibility at 0.5r, 0.7r, 0.9r, 1.3r and 2r?
//! - [`shadows`] — Fig. 7: how do shadows of the extrapolated field compare with a fully sampled
//!   shadow field (and with ray-traced truth)?
//! - [`timing`] — Table 1: per-stage times and FPS of the deforming sequences.
//!
//! A figure config (`configs/paper/*.toml`) names its `figure` kind and parameters; the raw file
//! is checked (unknown fields, wrong types are errors naming the file, line and field) before it
//! runs. [`regenerate`] runs every config of a folder into an output folder (`paper-figs/`) and
//! writes its index `README.md` with, per figure, the config, the paper's claim, our numbers and
//! the comparison — generated from the numbers, so the text never goes stale.

pub mod extremes;
pub mod m_elements;
pub mod midrange;
pub mod shadows;
pub mod sparsity;
pub mod srf;
pub mod timing;
pub mod visibility_radii;

use serde::Deserialize;
use shscale_lab::exp::{DynKind, Erased};
use shscale_lab::LabError;

static PROBE: Erased<shscale_lab::exp::probe::Probe> = Erased::new();
static MIDRANGE: Erased<midrange::MidRange> = Erased::new();

/// The experiment kinds of the runner (`experiment = "…"`), one line each. A new kind is one
/// file implementing `shscale_lab::exp::Kind` plus one line here.
pub fn registry() -> Vec<&'static dyn DynKind> {
    vec![&PROBE, &MIDRANGE]
}
use std::path::{Path, PathBuf};

/// What a figure produced: its files and its section of the index.
pub struct FigureOutput {
    pub files: Vec<PathBuf>,
    /// Markdown: our numbers and the comparison with the paper (without the heading).
    pub markdown: String,
}

/// A figure config as written: the `figure` key picks the kind, whose struct mirrors the file
/// (rejecting unknown fields).
#[derive(Debug)]
pub enum RawFigure {
    Sparsity(sparsity::Spec),
    MElements(m_elements::Spec),
    Visibility(visibility_radii::Spec),
    Shadows(shadows::Spec),
    Timing(timing::Spec),
    Srf(srf::Spec),
    Extremes(extremes::Spec),
}

/// `header()` of a figure spec (every spec carries `title` and `claim`; serde cannot flatten them
/// into a struct that rejects unknown fields, so each spec declares them and this implements the
/// accessor once).
macro_rules! impl_header {
    ($spec:ty) => {
        impl $spec {
            /// Title and claim.
            pub fn header(&self) -> $crate::Header {
                $crate::Header {
                    title: self.title.clone(),
                    claim: self.claim.clone(),
                }
            }
        }
    };
}
pub(crate) use impl_header;

/// Title and the paper's claim, common to every figure.
#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub struct Header {
    /// e.g. "Fig. 2 — …".
    pub title: String,
    /// The paper's claim, quoted or paraphrased with its section.
    pub claim: String,
}

/// The figure kinds, as spelled in `figure = "…"`.
pub const KINDS: &[&str] = &[
    "sparsity",
    "m_elements",
    "visibility",
    "shadows",
    "timing",
    "srf",
    "extremes",
];

/// Parse a figure config; errors name the file, the line and the field.
pub fn parse(file: &str, text: &str) -> Result<RawFigure, LabError> {
    let wrap = |e: toml::de::Error| shscale_lab::toml_error(file, text, &e);
    let table: toml::Table = toml::from_str(text).map_err(wrap)?;
    let line_of_figure = text
        .lines()
        .position(|l| {
            let t = l.trim_start();
            t.starts_with("figure") || t.starts_with("experiment")
        })
        .map_or(0, |i| i + 1);
    // Figures say `figure = …`; the same kinds run as experiments (`shscale run`) say
    // `experiment = …`.
    let kind = match table.get("figure").or_else(|| table.get("experiment")) {
        Some(toml::Value::String(k)) => k.as_str(),
        Some(other) => {
            return Err(LabError::Config(format!(
                "{file}:{line_of_figure}: figure: {other} is not a string"
            )))
        }
        None => {
            return Err(LabError::Config(format!(
                "{file}:0: figure: missing (one of {})",
                KINDS.join(", ")
            )))
        }
    };
    Ok(match kind {
        "sparsity" => RawFigure::Sparsity(toml::from_str(text).map_err(wrap)?),
        "m_elements" => RawFigure::MElements(toml::from_str(text).map_err(wrap)?),
        "visibility" => RawFigure::Visibility(toml::from_str(text).map_err(wrap)?),
        "shadows" => RawFigure::Shadows(toml::from_str(text).map_err(wrap)?),
        "timing" => RawFigure::Timing(toml::from_str(text).map_err(wrap)?),
        "srf" => RawFigure::Srf(toml::from_str(text).map_err(wrap)?),
        "extremes" => RawFigure::Extremes(toml::from_str(text).map_err(wrap)?),
        other => {
            return Err(LabError::Config(format!(
                "{file}:{line_of_figure}: figure: unknown kind {other:?} (one of {})",
                KINDS.join(", ")
            )))
        }
    })
}

/// Run one figure config into `out` (files named after the config's stem).
pub fn run_figure(
    path: &Path,
    out: &Path,
    gpu: Option<&shscale_gpu::GpuContext>,
) -> Result<(Header, FigureOutput), LabError> {
    let text = std::fs::read_to_string(path).map_err(|e| LabError::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    })?;
    let file = path.display().to_string();
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| "figure".into());
    let base = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(out).map_err(|e| LabError::Io {
        path: out.display().to_string(),
        reason: e.to_string(),
    })?;
    match parse(&file, &text)? {
        RawFigure::Sparsity(s) => Ok((s.header(), sparsity::run(&file, &s, out, &stem)?)),
        RawFigure::MElements(s) => Ok((s.header(), m_elements::run(&file, &s, out, &stem)?)),
        RawFigure::Visibility(s) => Ok((s.header(), visibility_radii::run(&file, &s, out, &stem)?)),
        RawFigure::Shadows(s) => Ok((s.header(), shadows::run(&file, &s, base, out, &stem)?)),
        RawFigure::Timing(s) => Ok((s.header(), timing::run(&file, &s, out, &stem, gpu)?)),
        RawFigure::Srf(s) => Ok((s.header(), srf::run(&file, &s, out, &stem)?)),
        RawFigure::Extremes(s) => Ok((s.header(), extremes::run(&file, &s, out, &stem)?)),
    }
}

/// Run every `*.toml` of `configs` (sorted) into `out`, then write `out/README.md`. `progress`
/// gets a line per figure. Returns the files written.
pub fn regenerate(
    configs: &Path,
    out: &Path,
    gpu: Option<&shscale_gpu::GpuContext>,
    mut progress: impl FnMut(&str),
) -> Result<Vec<PathBuf>, LabError> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(configs)
        .map_err(|e| LabError::Io {
            path: configs.display().to_string(),
            reason: e.to_string(),
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    paths.sort();
    if paths.is_empty() {
        return Err(LabError::Config(format!(
            "{}: no *.toml figure configs",
            configs.display()
        )));
    }
    let mut index = String::from(
        "# paper-figs/\n\nThe papers' figures, regenerated by `shscale figs` (from `configs/paper/*.toml`; do not edit\nthis file by hand — it is rewritten with the figures). Per figure: the config, the paper's\nclaim, our numbers and how they compare. Paper references: Wang et al., *Spherical Harmonics\nScaling* (\"SHS\"); Zhou et al., *Shadow Fields for Deformable Objects*, MSR-TR-2005-96 (\"TR\").\n\n",
    );
    let mut all = Vec::new();
    for p in &paths {
        let t = std::time::Instant::now();
        let (h, f) = run_figure(p, out, gpu)?;
        progress(&format!(
            "{} → {} file(s) in {:.1} s",
            p.display(),
            f.files.len(),
            t.elapsed().as_secs_f64()
        ));
        index.push_str(&format!("## {}\n\nConfig: `{}`\n\n", h.title, p.display()));
        index.push_str(&format!("**Paper.** {}\n\n", h.claim.trim()));
        index.push_str(f.markdown.trim_end());
        index.push_str("\n\nFiles: ");
        let names: Vec<String> = f
            .files
            .iter()
            .filter_map(|x| x.file_name().map(|n| format!("`{}`", n.to_string_lossy())))
            .collect();
        index.push_str(&names.join(", "));
        index.push_str("\n\n");
        if let Some(png) = f
            .files
            .iter()
            .find(|x| x.extension().is_some_and(|e| e == "png"))
        {
            index.push_str(&format!(
                "![{}]({})\n\n",
                h.title,
                png.file_name().unwrap_or_default().to_string_lossy()
            ));
        }
        all.extend(f.files);
    }
    let readme = out.join("README.md");
    shscale_lab::runner::write_atomic(&readme, &index)?;
    all.push(readme);
    Ok(all)
}

/// Run a study config (`experiment = "midrange" | "srf" | "extremes" | …`, any kind of
/// [`KINDS`]) the way `shscale run` does for sweeps: into `out_root/<kind>/<config stem>/`, with
/// `summary.md` (the claim, our numbers, the comparison) and `manifest.toml` (the config, the
/// machine, the date). Studies sweep their own lists in one go (seconds), so they are neither
/// sharded nor resumed: a rerun recomputes and atomically replaces every file.
pub fn run_study(
    path: &Path,
    out_root: &Path,
    gpu: Option<&shscale_gpu::GpuContext>,
) -> Result<(PathBuf, String), LabError> {
    let text = std::fs::read_to_string(path).map_err(|e| LabError::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    })?;
    let kind = match parse(&path.display().to_string(), &text)? {
        RawFigure::Sparsity(_) => "sparsity",
        RawFigure::MElements(_) => "m_elements",
        RawFigure::Visibility(_) => "visibility",
        RawFigure::Shadows(_) => "shadows",
        RawFigure::Timing(_) => "timing",
        RawFigure::Srf(_) => "srf",
        RawFigure::Extremes(_) => "extremes",
    };
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| kind.to_string());
    let out = out_root.join(kind).join(&stem);
    let (h, f) = run_figure(path, &out, gpu)?;
    let summary = format!(
        "# {}\n\nConfig: `{}`\n\n**Question / claim.** {}\n\n{}\n",
        h.title,
        path.display(),
        h.claim.trim(),
        f.markdown.trim_end()
    );
    write_text(&out, "summary.md", &summary)?;
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let manifest = format!(
        "# shscale study manifest\nconfig_file = {:?}\nexperiment = {kind:?}\nunix_time = {now}\nos = {:?}\narch = {:?}\nthreads = {}\nfiles = {:?}\n\n[config]\ntext = '''\n{}'''\n",
        path.display().to_string(),
        std::env::consts::OS,
        std::env::consts::ARCH,
        std::thread::available_parallelism().map_or(1, |n| n.get()),
        f.files
            .iter()
            .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().to_string()))
            .collect::<Vec<_>>(),
        text
    );
    write_text(&out, "manifest.toml", &manifest)?;
    Ok((out, summary))
}

/// Write `text` to `out/name` atomically and return the path.
pub(crate) fn write_text(out: &Path, name: &str, text: &str) -> Result<PathBuf, LabError> {
    let p = out.join(name);
    shscale_lab::runner::write_atomic(&p, text)?;
    Ok(p)
}
