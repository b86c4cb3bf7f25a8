//! Table 1 (SHS Table 1, TR Table 1): how fast is a frame of a deforming entity — BSV sampling,
//! SH conversion, shadowing and FPS — on the CPU path and, where an adapter exists, the GPU path?
//!
//! One run is one bench sequence (`bird`, `egg`, `sponge`) on one path (`cpu` or `gpu`), measured
//! by the Table 1 bench (`shscale_scene::bench`): per-stage medians over `frames` frames after
//! `warmup` frames — the timing procedure of this kind, the frames being its repeats. A `gpu` run
//! without an adapter writes no row (it says so in the summary, and a later run with an adapter
//! fills it in). Time columns are only comparable when runs do not overlap: the configs of this
//! kind set `parallel_runs = false`.

use serde::{Deserialize, Serialize};
use shscale_runner::records::Results;
use shscale_runner::Typed;
use shscale_runner::{Cost, Ctx, Device, GpuMode, KeyError, Kind};
use shscale_scene::bench::{bench_scene, BenchPath, FrameTimes};
use shscale_scene::Error;
use std::path::{Path, PathBuf};

/// Parameters of one run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// `bird`, `egg` or `sponge`.
    pub scene: String,
    /// `cpu` or `gpu`.
    pub path: String,
    pub frames: usize,
    pub warmup: usize,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            scene: "bird".into(),
            path: "cpu".into(),
            frames: 16,
            warmup: 3,
        }
    }
}

/// One row per run (none for a `gpu` run without an adapter): the bench's per-stage medians as
/// they are.
pub type Row = FrameTimes;

/// The kind `timing`.
pub struct Timing;

/// The most frames (and warm-up frames) of a run.
pub const MAX_FRAMES: usize = 10_000;

impl Kind for Timing {
    const NAME: &'static str = "timing";
    const QUESTION: &'static str = "SHS / TR Table 1: how long do BSV sampling, SH conversion and shadowing of a deforming entity take per frame, and at what FPS, on the CPU and the GPU path?";
    type Params = Params;
    type Shared = ();
    type Row = Row;
    type Error = Error;
    type Spec = Typed<Params, BenchPath>;
    fn open_device(mode: GpuMode) -> Result<Option<Device>, Error> {
        shscale_scene::gpu_path::open_device(mode)
    }

    fn describe() -> &'static [(&'static str, &'static str)] {
        &[
            (
                "scene",
                "bench sequence: `bird` (flapping), `egg` (morphing) or `sponge` (bending)",
            ),
            (
                "path",
                "`cpu`, `gpu`, `gpu-pipelined` (the host's half of frame i + 1 overlapping the device's frame i; timestamp queries needed), `gpu-device` (the pose and the BVH refit on the device) or `gpu-device-pipelined` (posed on the device, two frames in flight; timestamp queries needed); a GPU run without an adapter writes no row",
            ),
            (
                "frames",
                "measured frames (their medians are the times), 1..=10000",
            ),
            ("warmup", "frames run and dropped before measuring, ≤ 10000"),
        ]
    }

    fn resolve(p: &Params) -> Result<Self::Spec, KeyError> {
        if !matches!(p.scene.as_str(), "bird" | "egg" | "sponge") {
            return Err(KeyError::new(
                "scene",
                format!("{:?} is not one of bird, egg, sponge", p.scene),
            ));
        }
        let path = BenchPath::parse(&p.path).map_err(|m| KeyError::new("path", m))?;
        KeyError::int("frames", p.frames, 1, MAX_FRAMES)?;
        if p.warmup > MAX_FRAMES {
            return Err(KeyError::new(
                "warmup",
                format!("{} is more than the limit {MAX_FRAMES}", p.warmup),
            ));
        }
        Ok(Typed {
            params: p.clone(),
            typed: path,
        })
    }

    fn cost(p: &Self::Spec) -> (Cost, Cost) {
        // Bench scenes: 240 samples × 32² rays per frame.
        let rays = (p.frames + p.warmup) as f64 * 240.0 * 1024.0;
        (
            Cost::default(),
            Cost {
                cached_once: None,
                rays,
                bytes: 256e6,
                // The kind times its own frames (not the runner's procedure), so all of it is
                // once; a frame costs about 3× its rays' tracing (the SH projection, the
                // extrapolation to the receivers and the GPU path where there is an adapter):
                // `configs/experiments/deformation.toml` 4.3 s in `shscale bench estimates` and
                // 8.1 s through `shscale run`, `configs/paper/table1_timing.toml` 7.7 and 11.3 s.
                seconds: 0.0,
                once_seconds: 3.0 * rays / shscale_runner::timing::CPU_RAYS_PER_SECOND,
                drivers: format!(
                    "(frames {} + warmup {}) × 240 × 32² rays",
                    p.frames, p.warmup
                ),
            },
        )
    }

    fn rows_per_run(_: &Params) -> usize {
        1
    }

    fn shared(_: &Self::Spec, _: &Ctx) -> Result<(), Error> {
        Ok(())
    }

    fn run(p: &Self::Spec, _: &str, _: &(), ctx: &Ctx) -> Result<Vec<Row>, Error> {
        let gpu = if p.typed != BenchPath::Cpu {
            match shscale_scene::gpu_path::gpu_of(ctx) {
                Some(g) => Some(g),
                None => return Ok(Vec::new()),
            }
        } else {
            None
        };
        let cpu = p.typed == BenchPath::Cpu;
        let rows = bench_scene(&p.scene, (p.frames, p.warmup), cpu, gpu, &[p.typed])?;
        Ok((rows.into_iter())
            .filter(|r| r.path == p.typed)
            .map(|r| r.times)
            .collect())
    }

    fn time_columns() -> &'static [&'static str] {
        &[
            "setup_ms",
            "deform_ms",
            "bvh_update_ms",
            "upload_ms",
            "bsv_sampling_ms",
            "sh_conversion_ms",
            "shadowing_ms",
            "frame_ms",
            "fps",
        ]
    }

    fn summary_columns() -> &'static [&'static str] {
        &[
            "device",
            "bsv_sampling_ms",
            "shadowing_ms",
            "frame_ms",
            "fps",
        ]
    }

    fn discussion(t: &Results) -> Result<String, Error> {
        if t.rows.is_empty() {
            return Ok(
                "No rows: no run has finished (a gpu run without an adapter writes none).".into(),
            );
        }
        let table = table(t);
        let fps = |path: &str| {
            (0..t.rows.len())
                .filter(|&r| t.cell(r, "path") == path)
                .map(|r| format!("{} {:.1}", t.cell(r, "scene"), t.num(r, "fps")))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let gpu: Vec<usize> = (0..t.rows.len())
            .filter(|&r| t.cell(r, "path") == "gpu")
            .collect();
        let device = gpu.first().map(|&r| t.cell(r, "device").to_string());
        Ok(format!(
            "**Ours.** Per-stage medians of {} frames after {} warm-up frames, {} rayon threads; GPU: {}.\n\n{table}\n\
**Comparison.** TR Table 1 (GeForce 6800-era GPU for sampling, CPU for shadowing): dragon 1151 vertices 11.0 / 5.0 / 37.7 ms, 21.3 FPS; egg 482 \
vertices 7.4 / 5.0 / 36.7 ms, 22.5 FPS; plane 8382 vertices 72.4 / 5.0 / 47.9 ms, 13.5 FPS (BSV sampling / SH conversion / shadowing). \
SHS Table 1: dragon 35.4, egg 14.2, sponge 13.4 FPS. Our CPU path: {}. {} Shadowing the receivers costs us well under a \
millisecond per frame (a cached three-term dot product per receiver, `crates/field/src/receivers.rs`) against the papers' ~37–48 ms, \
so our frame is dominated by BSV sampling — ray casting 240 × 32² rays, which the papers did by rasterisation on the GPU.",
            t.cell(0, "frames"),
            t.cell(0, "warmup"),
            t.cell(0, "threads"),
            device.clone().unwrap_or_else(|| "no adapter (CPU rows only)".into()),
            fps("cpu"),
            match device {
                None => "No GPU rows: no adapter was available.".to_string(),
                Some(d) => format!(
                    "Our GPU path on `{d}`: {}{}.",
                    fps("gpu"),
                    if d.contains("llvmpipe") {
                        " — lavapipe is a software device on the same CPU cores, a correctness device slower than the CPU path; a real GPU's rows (an NVIDIA H200) are in docs/BENCHMARKS.md"
                    } else {
                        ""
                    }
                ),
            },
        ))
    }

    fn figure(_: &Path, t: &Results, out: &Path, stem: &str) -> Result<Vec<PathBuf>, Error> {
        Ok(vec![crate::common::write_text(
            out,
            &format!("{stem}.md"),
            &table(t),
        )?])
    }
}

/// The table as Markdown.
fn table(t: &Results) -> String {
    let mut s = String::from(
        "| scene | vertices | path | device | BSV sampling (ms) | SH conversion (ms) | shadowing (ms) | deform + BVH + upload (ms) | frame (ms) | FPS |\n|---|---:|---|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in 0..t.rows.len() {
        let upload = t.num(r, "upload_ms");
        let host = t.num(r, "deform_ms")
            + t.num(r, "bvh_update_ms")
            + if upload.is_finite() { upload } else { 0.0 };
        let sh = t.num(r, "sh_conversion_ms");
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.3} | {} | {:.3} | {host:.3} | {:.3} | {:.1} |\n",
            t.cell(r, "scene"),
            t.cell(r, "vertices"),
            t.cell(r, "path"),
            t.cell(r, "device"),
            t.num(r, "bsv_sampling_ms"),
            if sh.is_finite() {
                format!("{sh:.3}")
            } else {
                "(in sampling)".into()
            },
            t.num(r, "shadowing_ms"),
            t.num(r, "frame_ms"),
            t.num(r, "fps"),
        ));
    }
    s
}
