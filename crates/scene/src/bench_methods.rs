//! Table 1 per method (`shscale bench --methods …`): the three deforming sequences rendered with
//! every method of the vocabulary on the CPU sequence path ([`crate::sequence`]), each row with
//! its frame time, FPS, per-stage medians and each frame's error against the band-limited truth
//! of the same pose (`ray_traced` at the scene's `truth_res`, computed once per frame and shared
//! by the methods, outside the times).
//!
//! A method is given as a *variant*: `name[:key=value,…]` with `parts=P` (sub-volumes, sphere
//! sets), `s=S` (the sampling radius, in bounding radii), `clearance=D` (per-direction radii,
//! `radial = "clearance"` with δ = D) or `combine=C` (how a sphere set combines its spheres,
//! `sphere_combine`) — e.g. `sphere_set:parts=16`, `extrapolated:s=1.2`,
//! `sphere_set:parts=16,combine=union`.

use crate::error::Error;
use crate::method::Method;
use crate::scene::Scene;
use crate::sequence::{cached_path, flat, render_sequence_with, Reference};
use crate::settings::RenderSettings;
use serde::Serialize;
use shscale_field::bsv::RadialRule;
use shscale_gpu::timing::median;

/// The variants `--methods` runs when given `default`: the papers' method and full field, the
/// extrapolation's inflation and clearance radii, sub-volumes, sphere sets at two sizes by the chain
/// and at the larger by the exact union of their caps.
pub const DEFAULT_VARIANTS: &str = "extrapolated,full_field,extrapolated:s=1.2,extrapolated:clearance=0.1,sub_volumes:parts=2,sphere_set:parts=4,sphere_set:parts=16,sphere_set:parts=16,combine=union";

/// The most variants one bench takes.
pub const MAX_VARIANTS: usize = 16;

/// One method with the scene keys it changes.
#[derive(Clone, Debug, PartialEq)]
pub struct Variant {
    /// As given (`sphere_set:parts=16`).
    pub label: String,
    pub method: Method,
    pub parts: Option<usize>,
    pub sampling_radius: Option<f64>,
    pub clearance: Option<f64>,
    /// `combine=`: the sphere set's combination.
    pub sphere_combine: Option<crate::combine::Combine>,
}

impl Variant {
    /// Parse `name[:key=value,…]`; every error names the variant and the key.
    pub fn parse(text: &str) -> Result<Self, String> {
        let text = text.trim();
        let (name, keys) = text.split_once(':').unwrap_or((text, ""));
        let method = Method::parse(name).map_err(|e| format!("{text:?}: {e}"))?;
        if method == Method::FullFrequency {
            return Err(format!(
                "{text:?}: full_frequency is a reference, not a method timed per frame"
            ));
        }
        let mut v = Variant {
            label: text.to_string(),
            method,
            parts: None,
            sampling_radius: None,
            clearance: None,
            sphere_combine: None,
        };
        let mut seen: Vec<&str> = Vec::new();
        for kv in keys.split(',').filter(|k| !k.trim().is_empty()) {
            let (k, val) = kv
                .split_once('=')
                .ok_or_else(|| format!("{text:?}: {kv:?} is not key=value"))?;
            // A key given twice would label the row with both values and use one.
            if seen.contains(&k.trim()) {
                return Err(format!("{text:?}: {} is given twice", k.trim()));
            }
            seen.push(k.trim());
            v.set(text, (name, k, val))?;
        }
        Ok(v)
    }

    /// Set the key `k` of `name`'s variant (`text` as given) to `val`, checked against the
    /// method and the key's range; every error names the variant and the key.
    fn set(&mut self, text: &str, (name, k, val): (&str, &str, &str)) -> Result<(), String> {
        let method = self.method;
        if k.trim() == "combine" {
            self.sphere_combine = Some(parse_combine(text, name, method, val)?);
            return Ok(());
        }
        let num: f64 = val
            .trim()
            .parse()
            .map_err(|_| format!("{text:?}: {k}={val:?} is not a number"))?;
        let allowed = match k.trim() {
            "parts" => matches!(method, Method::SubVolumes | Method::SphereSet),
            "s" => matches!(
                method,
                Method::Extrapolated | Method::SubVolumes | Method::FullField
            ),
            "clearance" => method == Method::Extrapolated,
            other => {
                return Err(format!(
                    "{text:?}: unknown key {other:?} (parts, s, clearance, combine)"
                ))
            }
        };
        if !allowed {
            return Err(format!("{text:?}: {name} does not read {}", k.trim()));
        }
        match k.trim() {
            "parts" => {
                let max = shscale_geometry::partition::MAX_PARTS;
                if num.fract() != 0.0 || !(1.0..=max as f64).contains(&num) {
                    return Err(format!(
                        "{text:?}: parts={val} is not a whole number in 1..={max}"
                    ));
                }
                self.parts = Some(num as usize);
            }
            "s" => {
                if !(1.0..=10.0).contains(&num) {
                    return Err(format!(
                        "{text:?}: s={val} is outside [1, 10] bounding radii"
                    ));
                }
                self.sampling_radius = Some(num);
            }
            _ => {
                if !(0.0..=10.0).contains(&num) {
                    return Err(format!(
                        "{text:?}: clearance={val} is outside [0, 10] bounding radii"
                    ));
                }
                self.clearance = Some(num);
            }
        }
        Ok(())
    }

    /// A comma-separated list (`default` = [`DEFAULT_VARIANTS`]), at most [`MAX_VARIANTS`].
    pub fn parse_list(text: &str) -> Result<Vec<Self>, String> {
        let text = if text.trim() == "default" {
            DEFAULT_VARIANTS
        } else {
            text
        };
        // Commas separate variants and a variant's keys: a key continues the variant before it.
        let mut items: Vec<String> = Vec::new();
        for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            match items.last_mut() {
                Some(last) if part.contains('=') && !part.contains(':') => {
                    last.push(',');
                    last.push_str(part);
                }
                _ => items.push(part.to_string()),
            }
        }
        if items.is_empty() || items.len() > MAX_VARIANTS {
            return Err(format!(
                "{} variants: give 1 to {MAX_VARIANTS}",
                items.len()
            ));
        }
        items.iter().map(|i| Self::parse(i)).collect()
    }

    /// The render settings `rs` with this variant's method and keys; sub-volumes and sphere sets
    /// without `parts` take 4, as `render --parts` does by default.
    pub fn apply(&self, rs: &RenderSettings) -> RenderSettings {
        let mut s = rs.with(self.method);
        if let Some(p) = self.parts {
            s.parts = p;
        } else if matches!(self.method, Method::SubVolumes | Method::SphereSet) {
            s.parts = 4;
        }
        if let Some(r) = self.sampling_radius {
            s.sampling_radius = r;
        }
        if let Some(d) = self.clearance {
            s.radial = RadialRule::Clearance { delta: d };
        }
        if let Some(c) = self.sphere_combine {
            s.sphere_combine = c;
        }
        s
    }
}

/// A variant's `combine=` value: a sphere set's combination by name.
fn parse_combine(
    text: &str,
    name: &str,
    method: Method,
    val: &str,
) -> Result<crate::combine::Combine, String> {
    if method != Method::SphereSet {
        return Err(format!("{text:?}: {name} does not read combine"));
    }
    crate::combine::Combine::from_name(val.trim()).ok_or_else(|| {
        format!(
            "{text:?}: combine={val:?} is not one of {}",
            crate::combine::Combine::NAMES.join(", ")
        )
    })
}

fn as_map<S: serde::Serializer>(v: &[(String, f64)], s: S) -> Result<S::Ok, S::Error> {
    s.collect_map(v.iter().map(|(k, x)| (k, x)))
}

/// One row: a scene with one variant on the CPU sequence path.
#[derive(Clone, Debug, Serialize)]
pub struct MethodRow {
    pub scene: String,
    pub method: String,
    /// `cached` (the CPU real-time path), `per-frame` (every frame rendered from its pose) or
    /// `gpu` (the GPU sequence path).
    pub path: String,
    pub device: String,
    pub frames: usize,
    pub warmup: usize,
    /// Median of each stage over the measured frames (ms), in execution order (an object in
    /// JSON).
    #[serde(serialize_with = "as_map")]
    pub stages_ms: Vec<(String, f64)>,
    pub frame_ms: f64,
    pub fps: f64,
    /// `shade_rmse_rel` against the band-limited truth of each measured frame's pose: mean and
    /// largest (absent without `--errors`).
    pub error_mean: Option<f64>,
    pub error_max: Option<f64>,
}

/// The band-limited truth of every pose of a sequence (pixels, flat) and the unshadowed image.
pub struct Truths {
    frames: Vec<Vec<f64>>,
    reference: Reference,
}

impl Truths {
    /// `ray_traced` at `t = f / total` for `f` in `from..total` (with the settings `rs`).
    pub fn new(
        scene: &Scene,
        rs: &RenderSettings,
        from: usize,
        total: usize,
    ) -> Result<Self, Error> {
        let reference = Reference::new(scene, rs, Method::RayTraced)?;
        let frames = (from..total)
            .map(|f| {
                Ok(flat(
                    &reference
                        .image(scene, Some(f as f64 / total as f64))?
                        .pixels,
                ))
            })
            .collect::<Result<_, Error>>()?;
        Ok(Truths { frames, reference })
    }
}

/// Each measured frame's `shade_rmse_rel` against its pose's truth, as the frames arrive.
struct Scores<'a> {
    truths: Option<&'a Truths>,
    warmup: usize,
    errors: Vec<f64>,
    failed: Option<usize>,
}

impl<'a> Scores<'a> {
    fn new(truths: Option<&'a Truths>, warmup: usize) -> Self {
        Scores {
            truths,
            warmup,
            errors: Vec::new(),
            failed: None,
        }
    }

    /// Score frame `frame` (warm-up frames and runs without truths are not scored).
    fn add(&mut self, frame: usize, px: &[[f32; 3]]) {
        let Some(t) = self.truths.filter(|_| frame >= self.warmup) else {
            return;
        };
        match t.reference.error(px, &t.frames[frame - self.warmup]) {
            Some(e) => self.errors.push(e),
            None => self.failed = Some(frame),
        }
    }

    /// The errors, or the frame whose unshadowed image was black.
    fn finish(self, name: &str) -> Result<Vec<f64>, Error> {
        match self.failed {
            Some(f) => Err(Error::config(format!(
                "--scene {name}: frame {f}: the unshadowed image is black"
            ))),
            None => Ok(self.errors),
        }
    }
}

/// A row from the measured frames' stage times (seconds, the same stages in every frame) and
/// errors: each stage's median, the median frame (the sum of its stages).
fn row_of(
    (name, variant): (&str, &Variant),
    (path, device): (&str, String),
    (frames, warmup): (usize, usize),
    stages: &[Vec<(String, f64)>],
    errors: &[f64],
) -> MethodRow {
    let stages_ms = (stages[0].iter().enumerate())
        .map(|(i, (n, _))| {
            let v: Vec<f64> = stages.iter().map(|f| f[i].1).collect();
            (n.clone(), 1e3 * median(&v))
        })
        .collect();
    let totals: Vec<f64> = stages.iter().map(|f| f.iter().map(|s| s.1).sum()).collect();
    let frame_ms = 1e3 * median(&totals);
    MethodRow {
        scene: name.to_string(),
        method: variant.label.clone(),
        path: path.into(),
        device,
        frames,
        warmup,
        stages_ms,
        frame_ms,
        fps: 1e3 / frame_ms,
        error_mean: (!errors.is_empty()).then(|| errors.iter().sum::<f64>() / errors.len() as f64),
        error_max: (!errors.is_empty()).then(|| errors.iter().copied().fold(0.0, f64::max)),
    }
}

/// `variant` on `scene` (named `name`) over `warmup + frames` frames, scored against `truths`
/// (of the measured frames) when given.
pub fn bench_method(
    name: &str,
    (scene, rs): (&Scene, &RenderSettings),
    variant: &Variant,
    frames: usize,
    warmup: usize,
    truths: Option<&Truths>,
) -> Result<MethodRow, Error> {
    let frames = frames.max(1);
    let s = variant.apply(rs);
    let mut scores = Scores::new(truths, warmup);
    let (_, seq) = render_sequence_with(scene, &s, warmup + frames, None, &mut |f, px| {
        scores.add(f.frame, px)
    })?;
    let errors = scores.finish(name)?;
    let stages: Vec<Vec<(String, f64)>> = (seq.iter().skip(warmup))
        .map(|f| f.stages.clone())
        .collect();
    let path = if cached_path(&s) {
        "cached"
    } else {
        "per-frame"
    };
    let device = format!(
        "cpu ({} threads, kernels {}): {}",
        rayon::current_num_threads(),
        shscale_sh::simd::level().name(),
        shscale_sh::cpu::cpu().summary()
    );
    Ok(row_of(
        (name, variant),
        (path, device),
        (frames, warmup),
        &stages,
        &errors,
    ))
}

/// The GPU Table 1 sequence's stage times per measured frame (seconds), posed on the host or
/// (`device_pose`) on the device: there `deform` and `bvh_update` are the device's pose and
/// refit, the latter with any host rebuild.
fn gpu_extrapolated_stages(
    (scene, s): (&Scene, &RenderSettings),
    (total, warmup): (usize, usize),
    device_pose: bool,
    ctx: &shscale_gpu::GpuContext,
) -> Result<Vec<Vec<(String, f64)>>, Error> {
    use crate::gpu_path::{render_sequence_gpu_with, GpuFrames};
    let mode = if device_pose {
        GpuFrames::DevicePose
    } else {
        GpuFrames::Sequential
    };
    let run = render_sequence_gpu_with(scene, s, total, ctx, mode)?;
    Ok((run.frames.iter().skip(warmup))
        .map(|f| {
            let g = &f.gpu;
            crate::sequence::named_stages(&[
                ("deform", f.deform_seconds + g.deform_seconds),
                ("bvh_update", g.bvh_seconds + g.refit_seconds),
                ("upload", g.upload_seconds),
                ("bsv_sampling", g.sampling_seconds),
                ("sh_conversion", g.projection_seconds),
                ("shading", g.shading_seconds),
            ])
        })
        .collect())
}

/// `variant` on `scene` over `warmup + frames` frames on the GPU, where the method has a GPU
/// form ([`crate::gpu_methods::gpu_form`]) — the papers' extrapolation from one sampling sphere
/// (the GPU Table 1 sequence; no per-frame image, so no error), every other form scored against
/// `truths` like the CPU rows; `None` for methods without one. With `device_pose` the frames
/// are posed on the device (path `gpu-device`), and methods that pose on the host
/// ([`crate::gpu_methods::poses_on_device`]) give `None`.
pub fn bench_method_gpu(
    name: &str,
    (scene, rs): (&Scene, &RenderSettings),
    variant: &Variant,
    (frames, warmup): (usize, usize),
    (truths, device_pose): (Option<&Truths>, bool),
    ctx: &shscale_gpu::GpuContext,
) -> Result<Option<MethodRow>, Error> {
    let frames = frames.max(1);
    let total = warmup + frames;
    let s = variant.apply(rs);
    use crate::gpu_methods::{gpu_form, poses_on_device, render_gpu_frames_posed, GpuForm};
    let form = match gpu_form(scene, &s)? {
        Some(f) if !device_pose || poses_on_device(&s, f) => f,
        _ => return Ok(None),
    };
    let (stages, errors): (Vec<Vec<(String, f64)>>, Vec<f64>) = match form {
        GpuForm::Sequence => (
            gpu_extrapolated_stages((scene, &s), (total, warmup), device_pose, ctx)?,
            Vec::new(),
        ),
        form => {
            let (mut stages, mut scores) = (Vec::new(), Scores::new(truths, warmup));
            render_gpu_frames_posed(scene, &s, form, total, ctx, device_pose, &mut |f, px| {
                if f.frame >= warmup {
                    stages.push(f.stages.clone());
                }
                scores.add(f.frame, px);
            })?;
            (stages, scores.finish(name)?)
        }
    };
    let path = if device_pose { "gpu-device" } else { "gpu" };
    Ok(Some(row_of(
        (name, variant),
        (path, ctx.describe()),
        (frames, warmup),
        &stages,
        &errors,
    )))
}

/// The rows as Markdown.
pub fn to_markdown(rows: &[MethodRow]) -> String {
    let mut s = String::from(
        "| scene | method | path | frame (ms) | FPS | stages (ms, medians) | error vs band-limited truth: mean (max) |\n|---|---|---|---:|---:|---|---|\n",
    );
    for r in rows {
        let stages: Vec<String> = r
            .stages_ms
            .iter()
            .map(|(n, v)| format!("{n} {v:.3}"))
            .collect();
        let err = match (r.error_mean, r.error_max) {
            (Some(m), Some(x)) => format!("{m:.4} ({x:.4})"),
            _ => "—".into(),
        };
        s.push_str(&format!(
            "| {} | {} | {} | {:.3} | {:.1} | {} | {} |\n",
            r.scene,
            r.method,
            r.path,
            r.frame_ms,
            r.fps,
            stages.join(", "),
            err
        ));
    }
    s
}

/// The rows as CSV (stages as `name=ms;…`).
pub fn to_csv(rows: &[MethodRow]) -> String {
    let mut s = String::from(
        "scene,method,path,device,frames,warmup,frame_ms,fps,error_mean,error_max,stages_ms\n",
    );
    let opt = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:.6}"));
    for r in rows {
        let stages: Vec<String> = r
            .stages_ms
            .iter()
            .map(|(n, v)| format!("{n}={v:.6}"))
            .collect();
        s.push_str(&format!(
            "{},\"{}\",{},\"{}\",{},{},{:.6},{:.3},{},{},{}\n",
            r.scene,
            r.method,
            r.path,
            r.device.replace('"', "\"\""),
            r.frames,
            r.warmup,
            r.frame_ms,
            r.fps,
            opt(r.error_mean),
            opt(r.error_max),
            stages.join(";")
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variants_parse_and_refuse_what_a_method_does_not_read() {
        let v = Variant::parse_list("default").unwrap();
        assert_eq!(v.len(), 8);
        assert_eq!(v[6].parts, Some(16));
        let union = Some(crate::combine::Combine::Union);
        assert_eq!((v[7].parts, v[7].sphere_combine), (Some(16), union));
        assert_eq!(v[2].sampling_radius, Some(1.2));
        assert_eq!(v[3].clearance, Some(0.1));
        let two = Variant::parse_list("sphere_set:parts=8,s=1.1 , extrapolated").unwrap_err();
        assert!(two.contains("sphere_set") && two.contains("s"), "{two}");
        let ok = Variant::parse_list("sub_volumes:parts=3,s=1.1,ray_traced").unwrap();
        assert_eq!((ok[0].parts, ok[0].sampling_radius), (Some(3), Some(1.1)));
        assert_eq!(ok[1].method, Method::RayTraced);
        let u = Variant::parse_list("sphere_set:parts=16,combine=union").unwrap();
        let union = Some(crate::combine::Combine::Union);
        assert_eq!((u[0].parts, u[0].sphere_combine), (Some(16), union));
        for (bad, needle) in [
            ("sphere_set:parts=4,parts=9", "parts is given twice"),
            (
                "sphere_set:combine=union,combine=product",
                "combine is given twice",
            ),
            ("sphere_set:parts=0", "parts=0"),
            ("sphere_set:parts=2.5", "parts=2.5"),
            ("extrapolated:s=0.5", "s=0.5"),
            ("extrapolated:clearance=-1", "clearance=-1"),
            ("extrapolated:radius=2", "radius"),
            ("full_frequency", "reference"),
            ("nope", "nope"),
            ("extrapolated:s", "key=value"),
            ("sphere_set:combine=sum", "combine=\"sum\""),
            ("extrapolated:combine=union", "does not read combine"),
            ("", "0 variants"),
        ] {
            let e = Variant::parse_list(bad).unwrap_err();
            assert!(e.contains(needle), "{bad}: {e}");
        }
        let many = vec!["extrapolated"; MAX_VARIANTS + 1].join(",");
        assert!(Variant::parse_list(&many).is_err());
    }
}
