//! `shscale render`: a scene's receiver plane to EXR + PNG, with stage times.

use crate::args::{PartCombine, RenderArgs, SphereCombine, SphereFitArg, TextFormat};
use crate::flags;
use anyhow::{bail, Context};
use shscale_scene::method::Combine;
use shscale_scene::render::{render, Method, RenderOutput};
use shscale_scene::scene::Scene;
use shscale_scene::settings::RenderSettings;
use std::process::ExitCode;

/// The most frames `render --frames` renders.
const MAX_FRAMES: usize = 10_000;

pub fn run(a: RenderArgs) -> anyhow::Result<ExitCode> {
    check_args(&a)?;
    let (scene, rs) = scene_of(&a)?;
    let rays = check_limits(&a, (&scene, &rs))?;
    if let Some(frames) = a.frames {
        return sequence(&a, (&scene, &rs), frames);
    }
    let t0 = std::time::Instant::now();
    // Ray-traced methods can take minutes: a spinner with the estimate on a terminal, a line on
    // stderr every 10 s otherwise.
    let est = rays / shscale_runner::timing::CPU_RAYS_PER_SECOND;
    let ticker = Ticker::start(&a.method.to_string(), est);
    let img = render(&scene, &rs);
    ticker.stop();
    let img = img?;
    let total = t0.elapsed().as_secs_f64();
    // The reference first, so nothing is written when it fails; then the labelled figure, then
    // the EXR and its preview (the figure removed again if they fail).
    let (reference, truth) = match a.reference {
        None => (None, None),
        Some(r) => {
            let (m, rel, secs, truth) = reference_error((&scene, &rs), &img, r)?;
            (Some((m, rel, secs)), Some((r, truth)))
        }
    };
    let figure = if a.camera {
        None
    } else {
        // Named by --out, the path the user gave (the figure's own path is in the message).
        Some(
            write_figure(&a, &scene, &img, truth.as_ref())
                .with_context(|| format!("--out {}: its figure", a.out.display()))?,
        )
    };
    let png = match write_output(&a, &scene, &img).context("--out") {
        Ok(p) => p,
        Err(e) => {
            if let Some(f) = &figure {
                let _ = std::fs::remove_file(f);
            }
            return Err(e);
        }
    };
    // What the full-frequency truth lights with, and a truth's own error (RMS over pixels and
    // channels of its per-pixel estimate; only the truth methods have one).
    let truth_light = shscale_scene::frame::truth_light(&scene, rs.order)?;
    let truth_error_rms = (!img.error.is_empty()).then(|| {
        (img.error
            .iter()
            .flat_map(|p| p.map(|v| (v as f64) * (v as f64)))
            .sum::<f64>()
            / (3 * img.error.len()) as f64)
            .sqrt()
    });
    let done = Rendered {
        scene: &scene,
        img: &img,
        png: &png,
        figure: figure.as_deref(),
        total,
        reference,
        truth_light,
        truth_error_rms,
    };
    if a.format == TextFormat::Json {
        done.print_json(&a)?;
    } else {
        done.print_text(&a);
    }
    Ok(ExitCode::SUCCESS)
}

/// The scene file and its render settings with `--method` and the flags that set what the file
/// has no key for: the parts of sub-volumes and sphere sets, and how spheres and extrapolated
/// fields combine.
fn scene_of(a: &RenderArgs) -> anyhow::Result<(Scene, RenderSettings)> {
    let (scene, rs) = Scene::load(&a.scene)?;
    let mut rs = rs.with(a.method);
    if matches!(a.method, Method::SubVolumes | Method::SphereSet) {
        rs.parts = a.parts;
    }
    rs.sphere_combine = match a.sphere_combine {
        SphereCombine::Product => Combine::Product,
        SphereCombine::Union => Combine::Union,
        SphereCombine::Shexp => Combine::Shexp,
    };
    if a.part_combine == PartCombine::Shexp {
        rs.part_combine = Combine::Shexp;
    }
    if a.sphere_fit == SphereFitArg::Inscribed {
        rs.sphere_fit = shscale_scene::combine::SphereFit::Inscribed;
    }
    Ok((scene, rs))
}

/// `--out` (an `.exr` in an existing directory) and `--frames`.
fn check_args(a: &RenderArgs) -> anyhow::Result<()> {
    if a.out.extension().and_then(|e| e.to_str()) != Some("exr") {
        bail!("--out: {} must end in .exr", a.out.display());
    }
    if let Some(dir) = a.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            bail!("--out: directory {} does not exist", dir.display());
        }
    }
    if let Some(frames) = a.frames {
        flags::int("--frames", frames, 1, MAX_FRAMES)?;
    }
    flags::int(
        "--parts",
        a.parts,
        1,
        shscale_geometry::partition::MAX_PARTS,
    )?;
    if a.sphere_combine != SphereCombine::Product && a.method != Method::SphereSet {
        bail!(
            "--sphere-combine {}: only --method sphere_set combines spheres (this is {})",
            format!("{:?}", a.sphere_combine).to_lowercase(),
            a.method
        );
    }
    if a.sphere_fit != SphereFitArg::Area && a.method != Method::SphereSet {
        bail!(
            "--sphere-fit inscribed: only --method sphere_set fits spheres (this is {})",
            a.method
        );
    }
    if a.part_combine != PartCombine::Product {
        if !matches!(a.method, Method::Extrapolated | Method::SubVolumes) {
            bail!(
                "--part-combine shexp: only extrapolated fields (--method extrapolated or sub_volumes) combine in log space (this is {})",
                a.method
            );
        }
        if a.gpu {
            bail!("--part-combine shexp has no GPU form: drop --gpu");
        }
    }
    if let Some(r) = a.reference.filter(|r| !r.is_truth()) {
        bail!("--reference {r}: only the truths are references — ray_traced (band-limited) or full_frequency (full-frequency)");
    }
    Ok(())
}

/// The work limits: the method, the reference (and its unshadowed image), every frame. Returns
/// the estimated rays.
fn check_limits(a: &RenderArgs, (scene, rs): (&Scene, &RenderSettings)) -> anyhow::Result<f64> {
    let frames = a.frames.unwrap_or(1).max(1) as f64;
    if rs.method == Method::SphereSet
        && rs.sphere_fit == shscale_scene::combine::SphereFit::Inscribed
    {
        // A mesh with no inside is refused here, before any image (the run's `sphere_fit`).
        shscale_scene::frame::inscribed_seconds(scene, true)?;
    }
    let (mut rays, mut bytes) = shscale_scene::render::estimated_work(scene, rs);
    rays *= frames;
    if let Some(r) = a.reference {
        // The reference of every frame, and the unshadowed image once.
        let (r2, b2) = shscale_scene::render::estimated_work(scene, &rs.with(r));
        let (r3, _) = shscale_scene::render::estimated_work(scene, &rs.with(Method::RayTraced));
        rays += r2 * frames + r3;
        bytes = bytes.max(b2);
    }
    shscale_runner::limits::check_work(
        "render",
        rays,
        bytes,
        &format!(
            "{}×{} receivers, hemisphere_res {}, layout {}, {} occluder(s), {frames} frame(s)",
            scene.resolution[0],
            scene.resolution[1],
            rs.hemisphere_res,
            rs.layout.name(),
            scene.occluders.len()
        ),
        a.allow_large,
    )?;
    Ok(rays)
}

/// The receiver plane (or, with `--camera`, the camera's view of it) as EXR + PNG; the PNG.
fn write_output(
    a: &RenderArgs,
    scene: &Scene,
    img: &RenderOutput,
) -> Result<std::path::PathBuf, shscale_runner::Error> {
    if !a.camera {
        return write_image(&a.out, img);
    }
    let cam = scene
        .camera
        .unwrap_or_else(|| shscale_scene::scene::Camera::default_for(scene));
    let view = shscale_scene::camera::render_camera(scene, img, &cam)
        .map_err(shscale_runner::Error::from)?;
    Ok(shscale_present::image::write_exr_and_png(
        &a.out,
        cam.resolution[0],
        cam.resolution[1],
        &view,
        shscale_present::image::Png::Preview,
    )?)
}

/// The reference `r` rendered on the same scene and `img`'s error against it (relative to the
/// unshadowed irradiance: the scene without occluders, docs/conventions.md §6), with the
/// reference's render time.
fn reference_error(
    (scene, rs): (&Scene, &RenderSettings),
    img: &RenderOutput,
    r: Method,
) -> anyhow::Result<(Method, f64, f64, RenderOutput)> {
    let t = std::time::Instant::now();
    let reference = shscale_scene::sequence::Reference::new(scene, rs, r)?;
    let truth = reference.image(scene, None)?;
    let flat = shscale_scene::sequence::flat(&truth.pixels);
    let rel = (reference.error(&img.pixels, &flat))
        .context("shade_rmse_rel: the unshadowed image is black")?;
    Ok((r, rel, t.elapsed().as_secs_f64(), truth))
}

/// `<out stem>_figure.png` beside `--out`: the receiver plane's irradiance (luminance, the mean
/// of R, G, B) in false colour with a colour bar and axes in scene units; with `--reference`,
/// the reference beside it on the same scale and below them the difference (method −
/// reference) on a blue–white–red scale symmetric about 0.
fn write_figure(
    a: &RenderArgs,
    scene: &Scene,
    img: &RenderOutput,
    reference: Option<&(Method, RenderOutput)>,
) -> Result<std::path::PathBuf, shscale_runner::Error> {
    use shscale_present::figure::{ColourMap, Grid, Panel};
    let stem = a
        .out
        .file_stem()
        .map_or(String::new(), |s| s.to_string_lossy().to_string());
    let path = a.out.with_file_name(format!("{stem}_figure.png"));
    let lum = |o: &RenderOutput| -> Vec<f32> {
        o.pixels
            .iter()
            .map(|p| (p[0] + p[1] + p[2]) / 3.0)
            .collect()
    };
    let (w, h) = (img.width, img.height);
    let panel = |title: String, values: Vec<f32>| Panel {
        title,
        width: w,
        height: h,
        values,
    };
    let mut panels = vec![panel(a.method.to_string(), lum(img))];
    if let Some((r, t)) = reference {
        panels.push(panel(format!("{r} (reference)"), lum(t)));
    }
    let range = |vals: &[&Vec<f32>]| {
        vals.iter()
            .flat_map(|v| v.iter())
            .fold((f64::MAX, f64::MIN), |(lo, hi), &x| {
                (lo.min(x as f64), hi.max(x as f64))
            })
    };
    let c = scene.receiver_center;
    let [sx, sy] = scene.receiver_size;
    let x = (c.x - sx / 2.0, c.x + sx / 2.0, "x (scene units)");
    let y = (c.y + sy / 2.0, c.y - sy / 2.0, "y (scene units)");
    let px = (
        320u32,
        (320.0 * h as f64 / w.max(1) as f64).round().max(40.0) as u32,
    );
    let shown: Vec<&Vec<f32>> = panels.iter().map(|p| &p.values).collect();
    let first = Grid {
        title: "irradiance on the receiver plane",
        rows: vec![],
        x,
        y,
        colours: ColourMap::Heat,
        range: range(&shown),
        scale_label: "irradiance (mean of R, G, B)",
        panel_px: px,
    };
    let mut grids = vec![Grid {
        rows: vec![panels],
        ..first
    }];
    if let Some((r, t)) = reference {
        let d: Vec<f32> = lum(img).iter().zip(lum(t)).map(|(a, b)| a - b).collect();
        let title = format!("{} − {r}", a.method);
        let dr = range(&[&d]);
        grids.push(Grid {
            title: "difference from the reference",
            rows: vec![vec![panel(title, d)]],
            x,
            y,
            colours: ColourMap::Diverging,
            range: dr,
            scale_label: "irradiance difference",
            panel_px: px,
        });
    }
    shscale_present::figure::write_png_stack(&path, &grids)?;
    Ok(path)
}

/// What one render did, for printing.
struct Rendered<'a> {
    scene: &'a Scene,
    img: &'a RenderOutput,
    png: &'a std::path::Path,
    /// The labelled false-colour figure (not with --camera).
    figure: Option<&'a std::path::Path>,
    total: f64,
    reference: Option<(Method, f64, f64)>,
    truth_light: &'static str,
    truth_error_rms: Option<f64>,
}

impl Rendered<'_> {
    fn print_json(&self, a: &RenderArgs) -> anyhow::Result<()> {
        let img = self.img;
        let stages: serde_json::Map<String, serde_json::Value> = img
            .stages
            .iter()
            .map(|(k, v)| (k.to_string(), serde_json::json!(v * 1e3)))
            .collect();
        let files: Vec<String> = [a.out.display().to_string(), self.png.display().to_string()]
            .into_iter()
            .chain(self.figure.map(|f| f.display().to_string()))
            .collect();
        let out = serde_json::json!({
            "scene": a.scene.display().to_string(),
            "method": a.method.to_string(),
            "width": img.width,
            "height": img.height,
            "occluders": self.scene.occluders.len(),
            "threads": rayon::current_num_threads(),
            "stages_ms": stages,
            "total_ms": self.total * 1e3,
            "sh_products": img.products,
            "skipped_unoccluded": img.skipped,
            "full_frequency_light": self.truth_light,
            "truth_error_rms": self.truth_error_rms,
            "reference": self.reference.map(|(r, rel, secs)| serde_json::json!({
                "method": r.to_string(),
                "shade_rmse_rel": rel,
                "render_ms": secs * 1e3,
            })),
            "files": files,
        });
        crate::output::print_json(&out)
    }

    fn print_text(&self, a: &RenderArgs) {
        let img = self.img;
        println!(
            "rendered {} ({}×{} receivers, {} occluder(s), method {}, {} threads)",
            a.scene.display(),
            img.width,
            img.height,
            self.scene.occluders.len(),
            a.method,
            rayon::current_num_threads()
        );
        for (stage, s) in &img.stages {
            println!("  {stage:<18} {:>10.3} ms", s * 1e3);
        }
        println!("  {:<18} {:>10.3} ms", "total", self.total * 1e3);
        println!(
            "  SH products computed: {}, occluder evaluations skipped as unoccluded: {}",
            img.products, img.skipped
        );
        println!("  full-frequency truth lights with: {}", self.truth_light);
        if let Some(e) = self.truth_error_rms {
            println!("  the truth's own error (RMS of its per-pixel estimate): {e:.3e}");
        }
        if let Some((r, rel, secs)) = self.reference {
            println!(
                "shade_rmse_rel vs {}: {rel:.4e}  (reference rendered in {:.1} ms)",
                r,
                secs * 1e3
            );
        }
        match self.figure {
            Some(f) => println!(
                "wrote {}, {} and {} (false colour, with a colour bar)",
                a.out.display(),
                self.png.display(),
                f.display()
            ),
            None => println!("wrote {} and {}", a.out.display(), self.png.display()),
        }
    }
}

/// `render --frames --gpu`: the method's GPU sequence, or a refusal naming why it has none.
fn gpu_sequence_of(
    a: &RenderArgs,
    (scene, rs): (&Scene, &RenderSettings),
    frames: usize,
) -> anyhow::Result<ExitCode> {
    let method = rs.method;
    use shscale_scene::gpu_methods::{gpu_form, GpuForm};
    if a.reference.is_some() {
        bail!("--reference: not with --gpu (the GPU sequence keeps no per-frame images)");
    }
    let Some(form) = gpu_form(scene, rs)? else {
        bail!(
            "--gpu: the GPU sequence renders the papers' extrapolation (--method extrapolated, radial = \"uniform\" or \"clearance\", no clamp), the full field, sub-volumes, sphere sets and the band-limited ray-traced reference only; --method {method} with these keys runs on the CPU path (without --gpu)"
        );
    };
    if a.pipelined && form != GpuForm::Sequence {
        bail!(
            "--pipelined: the papers' extrapolation's GPU sequence only (--method extrapolated, radial = \"uniform\"); --method {method} with these keys runs its GPU frames one after another"
        );
    }
    if a.device_pose && !shscale_scene::gpu_methods::poses_on_device(rs, form) {
        bail!(
            "--device-pose: the papers' extrapolation (--method extrapolated, radial = \"uniform\") and sphere sets with sphere_fit = \"area\" only; --method {method} with these keys poses its GPU frames on the host"
        );
    }
    if form == GpuForm::Sequence {
        return gpu_sequence(a, (scene, rs), frames);
    }
    let ctx = required_gpu()?;
    let mut seq = Vec::with_capacity(frames);
    let img = shscale_scene::gpu_methods::render_gpu_frames_posed(
        scene,
        rs,
        form,
        frames,
        &ctx,
        a.device_pose,
        &mut |f, _| seq.push(f.clone()),
    )?;
    let what = if a.device_pose {
        format!("{} (posed and fitted on the device)", form.name())
    } else {
        form.name().to_string()
    };
    print_gpu_sequence(a, &what, &img, &seq, &ctx)
}

fn sequence(
    a: &RenderArgs,
    (scene, rs): (&Scene, &RenderSettings),
    frames: usize,
) -> anyhow::Result<ExitCode> {
    let method = rs.method;
    use shscale_scene::sequence::{cached_path, render_sequence_with};
    flags::int("--frames", frames, 1, MAX_FRAMES)?;
    if a.gpu {
        return gpu_sequence_of(a, (scene, rs), frames);
    }
    let bar = crate::output::Progress::new(frames, "frames");
    let (img, seq) = render_sequence_with(scene, rs, frames, a.reference, &mut |_, _| bar.inc())?;
    bar.finish();
    let png = write_image(&a.out, &img).context("--out")?;
    let n = seq.len() as f64;
    let mean = seq.iter().map(|f| f.seconds).sum::<f64>() / n;
    let errors: Vec<f64> = seq.iter().filter_map(|f| f.error).collect();
    let path = if cached_path(rs) {
        "cached: refit, one BSV per frame, receiver cache"
    } else {
        "every frame rendered from its posed mesh"
    };
    if a.format == TextFormat::Json {
        crate::output::print_json(&serde_json::json!({
            "scene": a.scene.display().to_string(),
            "method": method.to_string(),
            "path": path,
            "threads": rayon::current_num_threads(),
            "reference": a.reference.map(|r| r.to_string()),
            "frames": seq.iter().map(frame_json).collect::<Vec<_>>(),
            "mean_frame_seconds": mean,
            "out": a.out.display().to_string(),
            "png": png.display().to_string(),
        }))?;
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "sequence {} --method {method} ({path}; {}×{} receivers, {} occluder(s), {frames} frames, {} threads)",
        a.scene.display(),
        img.width,
        img.height,
        scene.occluders.len(),
        rayon::current_num_threads()
    );
    print_sequence_table(&seq, a.reference);
    println!("mean frame {:.3} ms ({:.1} FPS)", mean * 1e3, 1.0 / mean);
    if let (Some(r), false) = (a.reference, errors.is_empty()) {
        let m = errors.iter().sum::<f64>() / errors.len() as f64;
        let max = errors.iter().copied().fold(0.0, f64::max);
        println!(
            "shade_rmse_rel against {r}: mean {m:.4}, max {max:.4} over {} frames",
            errors.len()
        );
    }
    println!("wrote {} and {}", a.out.display(), png.display());
    Ok(ExitCode::SUCCESS)
}

/// One frame of a sequence in `--format json`: its index, time, seconds, stages (seconds by
/// name) and error against the reference (null without one).
fn frame_json(f: &shscale_scene::sequence::SequenceFrame) -> serde_json::Value {
    serde_json::json!({
        "frame": f.frame,
        "t": f.t,
        "seconds": f.seconds,
        "stages": f.stages.iter().map(|(k, v)| (k.clone(), serde_json::json!(v))).collect::<serde_json::Map<_, _>>(),
        "shade_rmse_rel": f.error,
    })
}

/// One line per frame: its stages (ms, the first frame's names as columns), the total and, with
/// a reference, the frame's error.
fn print_sequence_table(seq: &[shscale_scene::sequence::SequenceFrame], reference: Option<Method>) {
    let names: Vec<&str> = seq[0].stages.iter().map(|(n, _)| n.as_str()).collect();
    let mut head = format!("{:>5} {:>6}", "frame", "t");
    for n in &names {
        head.push_str(&format!(" {:>12}", format!("{n}_ms")));
    }
    head.push_str(&format!(" {:>10}", "frame_ms"));
    if reference.is_some() {
        head.push_str(&format!(" {:>14}", "shade_rmse_rel"));
    }
    println!("{head}");
    for f in seq {
        let mut line = format!("{:>5} {:>6.3}", f.frame, f.t);
        for n in &names {
            let v = f
                .stages
                .iter()
                .filter(|(k, _)| k == n)
                .map(|s| s.1)
                .sum::<f64>();
            line.push_str(&format!(" {:>12.3}", v * 1e3));
        }
        line.push_str(&format!(" {:>10.3}", f.seconds * 1e3));
        if let Some(e) = f.error {
            line.push_str(&format!(" {e:>14.4}"));
        }
        println!("{line}");
    }
}

/// The adapter, required (`--gpu`).
fn required_gpu() -> anyhow::Result<shscale_scene::gpu_path::GpuContext> {
    use shscale_runner::GpuMode;
    use shscale_scene::gpu_path::open_gpu;
    (open_gpu(GpuMode::Required).map_err(|e| anyhow::anyhow!("--gpu: {e}"))?).context("--gpu")
}

/// Write the last frame and print a GPU sequence's frames (`what` names it).
fn print_gpu_sequence(
    a: &RenderArgs,
    what: &str,
    img: &shscale_scene::render::RenderOutput,
    seq: &[shscale_scene::sequence::SequenceFrame],
    ctx: &shscale_scene::gpu_path::GpuContext,
) -> anyhow::Result<ExitCode> {
    let png = write_image(&a.out, img).context("--out")?;
    let mean = seq.iter().map(|f| f.seconds).sum::<f64>() / seq.len() as f64;
    if a.format == TextFormat::Json {
        crate::output::print_json(&serde_json::json!({
            "scene": a.scene.display().to_string(),
            "method": a.method.to_string(),
            "path": format!("gpu: {what}"),
            "adapter": ctx.describe(),
            "frames": seq.iter().map(frame_json).collect::<Vec<_>>(),
            "mean_frame_seconds": mean,
            "out": a.out.display().to_string(),
            "png": png.display().to_string(),
        }))?;
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "GPU {what} sequence {} ({}×{} receivers, {} frames, adapter {})",
        a.scene.display(),
        img.width,
        img.height,
        seq.len(),
        ctx.describe()
    );
    print_sequence_table(seq, None);
    println!("mean frame {:.3} ms ({:.1} FPS)", mean * 1e3, 1.0 / mean);
    println!("wrote {} and {}", a.out.display(), png.display());
    Ok(ExitCode::SUCCESS)
}

fn gpu_sequence(
    a: &RenderArgs,
    (scene, rs): (&Scene, &RenderSettings),
    frames: usize,
) -> anyhow::Result<ExitCode> {
    use shscale_runner::GpuMode;
    use shscale_scene::gpu_path::{open_gpu, render_sequence_gpu_with, GpuFrames};
    let ctx = open_gpu(GpuMode::Required)?.context("--gpu")?;
    let mode = match (a.pipelined, a.device_pose) {
        (true, true) => GpuFrames::DeviceInFlight,
        (true, false) => GpuFrames::Pipelined,
        (false, true) => GpuFrames::DevicePose,
        (false, false) => GpuFrames::Sequential,
    };
    let run = render_sequence_gpu_with(scene, rs, frames, &ctx, mode)?;
    let img = &run.image;
    let png = write_image(&a.out, img).context("--out")?;
    if a.format == TextFormat::Json {
        print_gpu_run_json(a, &ctx, &run, &png)?;
    } else {
        print_gpu_run_text(a, (&ctx, frames), &run, &png);
    }
    Ok(ExitCode::SUCCESS)
}

/// The papers' GPU sequence as JSON: the adapter, set-up, every frame's stages and the files.
fn print_gpu_run_json(
    a: &RenderArgs,
    ctx: &shscale_scene::gpu_path::GpuContext,
    run: &shscale_scene::gpu_path::GpuSequenceRun,
    png: &std::path::Path,
) -> anyhow::Result<()> {
    let (stats, setup) = (&run.frames, run.setup_seconds);
    let ms = |x: f64| serde_json::json!(x);
    crate::output::print_json(&serde_json::json!({
        "scene": a.scene.display().to_string(),
        "method": a.method.to_string(),
        "path": "gpu: the papers' sequence",
        "adapter": ctx.describe(),
        "setup_seconds": setup,
        "receiver_setup_seconds": run.receiver_setup_seconds,
        "stage_clock": if ctx.timestamps { "timestamps" } else { "wall" },
        "frames": stats.iter().map(|s| {
            let g = &s.gpu;
            serde_json::json!({
                "frame": s.frame,
                "seconds": s.seconds(),
                "stages": {
                    "deform": ms(s.deform_seconds + g.deform_seconds),
                    "bvh": ms(g.bvh_seconds + g.refit_seconds),
                    "upload": ms(g.upload_seconds),
                    "bsv": ms(g.sampling_seconds),
                    "sh": ms(g.projection_seconds),
                    "shade": ms(g.shading_seconds),
                },
                "stage_sum_seconds": s.stage_sum(),
            })
        }).collect::<Vec<_>>(),
        "mean_frame_seconds": stats.iter().map(|s| s.seconds()).sum::<f64>() / stats.len() as f64,
        "out": a.out.display().to_string(),
        "png": png.display().to_string(),
    }))?;
    Ok(())
}

/// The papers' GPU sequence as a table of every frame's stages, with the mean frame.
fn print_gpu_run_text(
    a: &RenderArgs,
    (ctx, frames): (&shscale_scene::gpu_path::GpuContext, usize),
    run: &shscale_scene::gpu_path::GpuSequenceRun,
    png: &std::path::Path,
) {
    let (img, stats, setup) = (&run.image, &run.frames, run.setup_seconds);
    println!(
        "GPU sequence {} ({}×{} receivers, {frames} frames, adapter {}, setup {:.1} ms of which GPU receiver setup {:.1} ms, stage clock: {})",
        a.scene.display(),
        img.width,
        img.height,
        ctx.describe(),
        setup * 1e3,
        run.receiver_setup_seconds * 1e3,
        if ctx.timestamps { "timestamps" } else { "wall" }
    );
    if a.device_pose {
        print_device_pose(a.pipelined, run);
    }
    println!(
        "{:>5} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}",
        "frame",
        "deform_ms",
        "bvh_ms",
        "upload_ms",
        "bsv_ms",
        "sh_ms",
        "shade_ms",
        "stages_ms",
        "frame_ms"
    );
    for s in stats {
        let g = &s.gpu;
        println!(
            "{:>5} {:>10.3} {:>10.3} {:>10.3} {:>10.3} {:>10.3} {:>10.3} {:>10.3} {:>10.3}",
            s.frame,
            (s.deform_seconds + g.deform_seconds) * 1e3,
            (g.bvh_seconds + g.refit_seconds) * 1e3,
            g.upload_seconds * 1e3,
            g.sampling_seconds * 1e3,
            g.projection_seconds * 1e3,
            g.shading_seconds * 1e3,
            s.stage_sum() * 1e3,
            s.seconds() * 1e3
        );
    }
    let n = stats.len() as f64;
    let mean = stats.iter().map(|s| s.seconds()).sum::<f64>() / n;
    let sum = stats.iter().map(|s| s.stage_sum()).sum::<f64>() / n;
    println!(
        "mean frame {:.3} ms ({:.1} FPS); its stages {:.3} ms one after another{}",
        mean * 1e3,
        1.0 / mean,
        sum * 1e3,
        if a.pipelined {
            format!(" — pipelined, {:.3} ms overlapped", (sum - mean) * 1e3)
        } else {
            String::new()
        }
    );
    println!("wrote {} and {}", a.out.display(), png.display());
}

/// `render --frames --gpu --device-pose`'s line on where the pose and trees were made.
fn print_device_pose(in_flight: bool, run: &shscale_scene::gpu_path::GpuSequenceRun) {
    let built = if in_flight {
        format!(
            "{} tree(s) built on a host thread in {:.3} ms off the frames' path; bvh_ms adds a swapped-in tree's upload",
            run.host_rebuilds,
            run.background_build_seconds * 1e3
        )
    } else {
        format!(
            "bvh_ms adds any host rebuild; {} frame(s) built on the host",
            run.host_rebuilds
        )
    };
    println!(
        "posed and refitted on the device{}: deform_ms and bvh_ms are device stages ({built})",
        if in_flight {
            ", two frames in flight"
        } else {
            ""
        },
    );
}

/// Liveness of a long render: a spinner with elapsed and estimated seconds on a terminal, a
/// line on stderr every [`crate::output::Progress::every`] otherwise; silent for short renders.
struct Ticker {
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    handle: Option<std::thread::JoinHandle<()>>,
}

impl Ticker {
    fn start(what: &str, estimate_s: f64) -> Self {
        use std::io::IsTerminal;
        let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let flag = stop.clone();
        let what = what.to_string();
        let handle = std::thread::spawn(move || {
            let t0 = std::time::Instant::now();
            let terminal = std::io::stderr().is_terminal();
            let spinner = terminal.then(indicatif::ProgressBar::new_spinner);
            let mut last = t0;
            while !flag.load(std::sync::atomic::Ordering::Relaxed) {
                std::thread::sleep(std::time::Duration::from_millis(200));
                let secs = t0.elapsed().as_secs_f64();
                let msg = format!(
                    "rendering {what}: {secs:.0} s elapsed of ≈ {estimate_s:.0} s estimated"
                );
                match &spinner {
                    Some(sp) if secs > 1.0 => {
                        sp.set_message(msg);
                        sp.tick();
                    }
                    None if last.elapsed() >= crate::output::Progress::every() => {
                        last = std::time::Instant::now();
                        eprintln!("progress: {msg}");
                    }
                    _ => {}
                }
            }
            if let Some(sp) = spinner {
                sp.finish_and_clear();
            }
        });
        Self {
            stop,
            handle: Some(handle),
        }
    }

    fn stop(mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// A rendered receiver plane as EXR + PNG preview, written as a unit; the PNG's path.
fn write_image(
    out: &std::path::Path,
    img: &shscale_scene::render::RenderOutput,
) -> Result<std::path::PathBuf, shscale_runner::Error> {
    Ok(shscale_present::image::write_exr_and_png(
        out,
        img.width,
        img.height,
        &img.pixels,
        shscale_present::image::Png::Preview,
    )?)
}
