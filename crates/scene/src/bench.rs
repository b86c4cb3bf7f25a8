//! The papers' Table 1 reproduced: per-stage times and frames per second of the deforming
//! sequences (flying bird ~1.1k vertices, egg ~0.5k, bending sponge ~8.4k, each over a 160×160
//! receiver plane; N = 4, 12×20 base-sphere samples × 32² rays as in the TR), CPU path and GPU
//! path side by side. One timing procedure (docs/ARCHITECTURE.md (habit 10)):
//! warm-up frames are run and dropped, then every stage's median over the measured frames;
//! the device is synchronised before each clock read (GPU stages by timestamp queries where the
//! adapter has them).
//!
//! Stages: *BSV sampling* (ray casting at every base-sphere sample), *SH conversion* (projection
//! of those rays to SH), *shadowing* (every receiver), plus the host's deformation and BVH update
//! (and, for the GPU, the upload). The CPU path casts and projects in one loop per ray, so its SH
//! conversion is inside its BSV sampling column (reported empty, not zero).

use crate::error::Error;
use crate::gpu_path::{render_sequence_gpu_with, GpuFrames};
use crate::render::render_sequence;
use crate::scene::Scene;
use crate::settings::RenderSettings;
use serde::{Deserialize, Serialize};
use shscale_gpu::timing::median;
use shscale_gpu::GpuContext;
use std::path::Path;

/// The bench scenes, embedded (the files in `configs/bench/` are the same text).
pub(crate) const SCENES: &[(&str, &str)] = &[
    ("bird", include_str!("../../../configs/bench/bird.toml")),
    ("egg", include_str!("../../../configs/bench/egg.toml")),
    ("sponge", include_str!("../../../configs/bench/sponge.toml")),
];

/// A bench scene by name, with the render settings of its file.
pub fn scene(name: &str) -> Result<(Scene, RenderSettings), Error> {
    let (_, text) = SCENES.iter().find(|(n, _)| *n == name).ok_or_else(|| {
        Error::config(format!(
            "--scene {name:?}: not one of bird, egg, sponge, all"
        ))
    })?;
    Scene::parse(&format!("configs/bench/{name}.toml"), text, Path::new("."))
}

/// Which sequence path a row measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BenchPath {
    Cpu,
    Gpu,
    /// The GPU sequence with the host's half of frame i + 1 overlapping the device's frame i.
    #[serde(rename = "gpu-pipelined")]
    GpuPipelined,
    /// The GPU sequence posed and refitted on the device.
    #[serde(rename = "gpu-device")]
    GpuDevice,
    /// Posed and refitted on the device, two frames in flight.
    #[serde(rename = "gpu-device-pipelined")]
    GpuDevicePipelined,
}

shscale_names::names!(BenchPath {
    Cpu = "cpu",
    Gpu = "gpu",
    GpuPipelined = "gpu-pipelined",
    GpuDevice = "gpu-device",
    GpuDevicePipelined = "gpu-device-pipelined",
});

impl BenchPath {
    /// `cpu`, `gpu`, `gpu-pipelined`, `gpu-device` or `gpu-device-pipelined`.
    pub fn parse(s: &str) -> Result<Self, String> {
        Self::from_name(s).ok_or_else(|| {
            format!("{s:?} is not cpu, gpu, gpu-pipelined, gpu-device or gpu-device-pipelined")
        })
    }

    /// How a GPU path runs its frames (`None` for the CPU).
    pub fn frames(self) -> Option<GpuFrames> {
        match self {
            Self::Cpu => None,
            Self::Gpu => Some(GpuFrames::Sequential),
            Self::GpuPipelined => Some(GpuFrames::Pipelined),
            Self::GpuDevice => Some(GpuFrames::DevicePose),
            Self::GpuDevicePipelined => Some(GpuFrames::DeviceInFlight),
        }
    }
}

/// One path's per-stage medians of a scene: the `timing` kind's row as it is (its CSV
/// columns, in this order), and the measured part of [`BenchRow`].
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct FrameTimes {
    /// CPU: `cpu (N threads, kernels LEVEL): ` and the CPU ([`shscale_sh::cpu::Cpu::summary`]); GPU: the
    /// adapter's name, backend and driver.
    pub device: String,
    pub vertices: usize,
    pub triangles: usize,
    pub samples: usize,
    pub rays_per_sample: usize,
    pub receivers: usize,
    /// GPU stage times from timestamp queries (else wall clock).
    pub timestamps: bool,
    /// One-off setup (GPU: table, cache, buffers and pipelines).
    pub setup_ms: Option<f64>,
    pub deform_ms: f64,
    pub bvh_update_ms: f64,
    pub upload_ms: Option<f64>,
    pub bsv_sampling_ms: f64,
    /// `None` where it is inside `bsv_sampling_ms` (the CPU path).
    pub sh_conversion_ms: Option<f64>,
    pub shadowing_ms: f64,
    /// Median wall clock of a whole frame.
    pub frame_ms: f64,
    pub fps: f64,
}

/// One row of the table: one scene on one path, with how it was measured.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    pub scene: String,
    pub path: BenchPath,
    pub threads: usize,
    pub frames: usize,
    pub warmup: usize,
    #[serde(flatten)]
    pub times: FrameTimes,
}

/// Measure `scene` over `warmup + frames` frames: the CPU path always (unless `cpu` is false),
/// the GPU path when `gpu` is given — and each GPU path of `extra` as well (pipelined, posed on
/// the device).
pub fn bench_scene(
    name: &str,
    (frames, warmup): (usize, usize),
    cpu: bool,
    gpu: Option<&GpuContext>,
    extra: &[BenchPath],
) -> Result<Vec<BenchRow>, Error> {
    let (sc, rs) = scene(name)?;
    let frames = frames.max(1);
    let total = frames + warmup;
    let o = &sc.occluders[0];
    let mesh = o.placed()?;
    let threads = rayon::current_num_threads();
    let base = FrameTimes {
        vertices: mesh.positions.len(),
        triangles: mesh.triangles.len(),
        samples: rs.layout.directions().len(),
        rays_per_sample: rs.hemisphere_res * rs.hemisphere_res,
        receivers: sc.resolution[0] * sc.resolution[1],
        ..FrameTimes::default()
    };
    let row = |path, times| BenchRow {
        scene: name.to_string(),
        path,
        threads,
        frames,
        warmup,
        times,
    };
    let mut rows = Vec::new();
    if cpu {
        rows.push(row(
            BenchPath::Cpu,
            cpu_times((&sc, &rs), total, warmup, &base)?,
        ));
    }
    if let Some(ctx) = gpu {
        let more = extra.iter().copied();
        let paths = std::iter::once(BenchPath::Gpu)
            .chain(more.filter(|p| !matches!(p, BenchPath::Cpu | BenchPath::Gpu)));
        for path in paths {
            let mode = path.frames().expect("a GPU path");
            rows.push(row(
                path,
                gpu_times((&sc, &rs), (total, warmup), ctx, &base, mode)?,
            ));
        }
    }
    Ok(rows)
}

/// The median of `v` in milliseconds.
fn ms(v: Vec<f64>) -> f64 {
    1e3 * median(&v)
}

/// The CPU sequence's row: per-stage medians over the frames after `warmup`.
fn cpu_times(
    (sc, rs): (&Scene, &RenderSettings),
    total: usize,
    warmup: usize,
    base: &FrameTimes,
) -> Result<FrameTimes, Error> {
    let threads = rayon::current_num_threads();
    let (_, stats) = render_sequence(sc, rs, total)?;
    let st = &stats[warmup.min(stats.len() - 1)..];
    let frame: Vec<f64> = st
        .iter()
        .map(|s| {
            s.deform_seconds + s.bvh_update_seconds + s.bsv_sampling_seconds + s.shading_seconds
        })
        .collect();
    let frame_ms = ms(frame);
    Ok(FrameTimes {
        device: format!(
            "cpu ({threads} threads, kernels {}): {}",
            shscale_sh::simd::level().name(),
            shscale_sh::cpu::cpu().summary()
        ),
        deform_ms: ms(st.iter().map(|s| s.deform_seconds).collect()),
        bvh_update_ms: ms(st.iter().map(|s| s.bvh_update_seconds).collect()),
        bsv_sampling_ms: ms(st.iter().map(|s| s.bsv_sampling_seconds).collect()),
        shadowing_ms: ms(st.iter().map(|s| s.shading_seconds).collect()),
        frame_ms,
        fps: 1e3 / frame_ms,
        ..base.clone()
    })
}

/// The GPU sequence's row on `ctx` (its frames run as `mode` says): per-stage device times
/// (timestamps where available), the frame the median of
/// [`crate::gpu_path::GpuFrameStats::seconds`]. Posed on the device, `deform_ms` is the device's
/// pose and `bvh_update_ms` its refit plus any host rebuild.
fn gpu_times(
    (sc, rs): (&Scene, &RenderSettings),
    (total, warmup): (usize, usize),
    ctx: &GpuContext,
    base: &FrameTimes,
    mode: GpuFrames,
) -> Result<FrameTimes, Error> {
    let run = render_sequence_gpu_with(sc, rs, total, ctx, mode)?;
    let (stats, setup) = (&run.frames, run.setup_seconds);
    let st = &stats[warmup.min(stats.len() - 1)..];
    let frame_ms = ms(st.iter().map(|s| s.seconds()).collect());
    Ok(FrameTimes {
        device: ctx.describe(),
        timestamps: st[0].gpu.timestamps,
        setup_ms: Some(1e3 * setup),
        deform_ms: ms(st
            .iter()
            .map(|s| s.deform_seconds + s.gpu.deform_seconds)
            .collect()),
        bvh_update_ms: ms(st
            .iter()
            .map(|s| s.gpu.bvh_seconds + s.gpu.refit_seconds)
            .collect()),
        upload_ms: Some(ms(st.iter().map(|s| s.gpu.upload_seconds).collect())),
        bsv_sampling_ms: ms(st.iter().map(|s| s.gpu.sampling_seconds).collect()),
        sh_conversion_ms: Some(ms(st.iter().map(|s| s.gpu.projection_seconds).collect())),
        shadowing_ms: ms(st.iter().map(|s| s.gpu.shading_seconds).collect()),
        frame_ms,
        fps: 1e3 / frame_ms,
        ..base.clone()
    })
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or(String::new(), |x| format!("{x:.digits$}"))
}

/// The CSV columns of [`BenchRow`], in order.
pub const CSV_COLUMNS: &str = "scene,path,device,threads,vertices,triangles,samples,rays_per_sample,receivers,frames,warmup,timestamps,setup_ms,deform_ms,bvh_update_ms,upload_ms,bsv_sampling_ms,sh_conversion_ms,shadowing_ms,frame_ms,fps";

/// Rows as CSV (header first).
pub fn to_csv(rows: &[BenchRow]) -> String {
    let mut s = format!("{CSV_COLUMNS}\n");
    for r in rows {
        let device = format!("\"{}\"", r.times.device.replace('"', "\"\""));
        s.push_str(&format!(
            "{},{},{device},{},{},{},{},{},{},{},{},{},{},{:.6},{:.6},{},{:.6},{},{:.6},{:.6},{:.3}\n",
            r.scene,
            r.path.name(),
            r.threads,
            r.times.vertices,
            r.times.triangles,
            r.times.samples,
            r.times.rays_per_sample,
            r.times.receivers,
            r.frames,
            r.warmup,
            r.times.timestamps,
            opt(r.times.setup_ms, 6),
            r.times.deform_ms,
            r.times.bvh_update_ms,
            opt(r.times.upload_ms, 6),
            r.times.bsv_sampling_ms,
            opt(r.times.sh_conversion_ms, 6),
            r.times.shadowing_ms,
            r.times.frame_ms,
            r.times.fps
        ));
    }
    s
}

/// Rows as the Markdown Table 1 (times in ms, medians).
pub fn to_markdown(rows: &[BenchRow]) -> String {
    let mut s = String::from(
        "| scene | vertices | path | device | BSV sampling (ms) | SH conversion (ms) | shadowing (ms) | deform + BVH + upload (ms) | frame (ms) | FPS |\n|---|---:|---|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let host = r.times.deform_ms + r.times.bvh_update_ms + r.times.upload_ms.unwrap_or(0.0);
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.3} | {} | {:.3} | {:.3} | {:.3} | {:.1} |\n",
            r.scene,
            r.times.vertices,
            r.path.name(),
            r.times.device,
            r.times.bsv_sampling_ms,
            r.times
                .sh_conversion_ms
                .map_or("(in sampling)".to_string(), |v| format!("{v:.3}")),
            r.times.shadowing_ms,
            host,
            r.times.frame_ms,
            r.times.fps
        ));
    }
    s
}
