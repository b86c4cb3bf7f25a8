//! `shscale bench`: the Table 1 reproduction (crates/scene/src/bench.rs) printed as Markdown, CSV
//! or JSON, with the machine in a header line; `shscale figs`: the papers' figures
//! (experiments/).

use crate::args::{
    BenchArgs, BenchFormat, BenchKernel, BenchScene, FigsArgs, KernelCommon, Precision, TextFormat,
    Workload,
};
use shscale_runner::GpuMode;
use shscale_scene::bench::{bench_scene, to_csv, to_markdown};
use shscale_scene::gpu_path::open_gpu;
use shscale_scene::kernels::{self, Protocol, RaySet};
use std::process::ExitCode;

pub fn run(a: BenchArgs) -> anyhow::Result<ExitCode> {
    if let Some(k) = a.kernel {
        return kernel(k);
    }
    let mode = match (a.gpu, a.require_gpu) {
        (false, _) => GpuMode::Off,
        (true, false) => GpuMode::Auto,
        (true, true) => GpuMode::Required,
    };
    let ctx = open_gpu(mode)?;
    let cpu = !a.no_cpu || ctx.is_none();
    let scenes: &[&str] = match a.scene {
        BenchScene::Bird => &["bird"],
        BenchScene::Egg => &["egg"],
        BenchScene::Sponge => &["sponge"],
        BenchScene::All => &["bird", "egg", "sponge"],
    };
    // The same bounds as the timing kind's `frames` and `warmup`.
    let max = shscale_experiments::timing::MAX_FRAMES;
    if !(1..=max).contains(&a.frames) {
        anyhow::bail!("--frames: {} is outside 1..={max}", a.frames);
    }
    if a.warmup > max {
        anyhow::bail!("--warmup: {} is more than the limit {max}", a.warmup);
    }
    // Every bench frame traces 240 samples × 32² rays per path (configs/bench/).
    let paths = usize::from(cpu) + usize::from(ctx.is_some());
    let rays = (scenes.len() * paths) as f64 * (a.frames + a.warmup) as f64 * 240.0 * 1024.0;
    shscale_runner::limits::check_work(
        "bench",
        rays,
        0.0,
        &format!(
            "{} scene(s) × {paths} path(s) × (--frames {} + --warmup {}) × 240 × 32² rays",
            scenes.len(),
            a.frames,
            a.warmup
        ),
        a.allow_large,
    )?;
    let mut rows = Vec::new();
    let bar = crate::output::Progress::new(scenes.len(), "scenes");
    for s in scenes {
        bar.set_message(format!("{s} ({} + {} frames)", a.warmup, a.frames));
        rows.extend(bench_scene(s, a.frames, a.warmup, cpu, ctx.as_ref())?);
        bar.inc();
    }
    bar.finish();
    if let Some(path) = &a.csv {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| anyhow::anyhow!("{}: {e}", dir.display()))?;
        }
        shscale_runner::write_atomic(path, &to_csv(&rows))?;
    }
    match a.format {
        BenchFormat::Markdown => {
            println!(
                "Table 1 reproduction — medians of {} frames after {} warm-up; {} {}, {} rayon threads",
                a.frames,
                a.warmup,
                std::env::consts::OS,
                std::env::consts::ARCH,
                rayon::current_num_threads()
            );
            println!();
            print!("{}", to_markdown(&rows));
        }
        BenchFormat::Csv => print!("{}", to_csv(&rows)),
        BenchFormat::Json => println!("{}", serde_json::to_string_pretty(&rows)?),
    }
    Ok(ExitCode::SUCCESS)
}

pub fn figs(a: FigsArgs) -> anyhow::Result<ExitCode> {
    let mode = GpuMode::parse(&a.gpu).map_err(|e| anyhow::anyhow!("--gpu: {e}"))?;
    let count = std::fs::read_dir(&a.configs)
        .map(|d| {
            d.flatten()
                .filter(|e| e.path().extension().is_some_and(|x| x == "toml"))
                .count()
        })
        .unwrap_or(0);
    // The runs go to --runs, or to a fresh temporary folder removed afterwards (also on error).
    struct TempDir(std::path::PathBuf);
    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
    let (runs, _temp) = match &a.runs {
        Some(d) => (d.clone(), None),
        None => {
            let d = std::env::temp_dir().join(format!("shscale-figs-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&d);
            (d.clone(), Some(TempDir(d)))
        }
    };
    let bar = crate::output::Progress::new(count, "figures");
    let files = shscale_experiments::regenerate(&a.configs, &a.out, &runs, Some(mode), |l| {
        if l.starts_with("warning:") {
            eprintln!("{l}");
        } else if a.format != crate::args::TextFormat::Json {
            bar.println(l);
        }
        if !l.starts_with("warning:") {
            bar.inc();
        }
    })?;
    bar.finish();
    if a.format == crate::args::TextFormat::Json {
        crate::output::print_json(&serde_json::json!({
            "files": files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
            "index": a.out.join("README.md").display().to_string(),
        }))?;
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "wrote {} file(s); index {}",
        files.len(),
        a.out.join("README.md").display()
    );
    Ok(ExitCode::SUCCESS)
}

/// The most random rays (`--count`) and threads (`--threads`) a kernel benchmark accepts:
/// beyond these a run takes minutes or gigabytes (`--allow-large` does not lift them).
const MAX_KERNEL_RAYS: usize = 100_000_000;
const MAX_THREADS: usize = 1024;

fn protocol(c: &KernelCommon) -> anyhow::Result<Protocol> {
    if !(c.min_time.is_finite() && c.min_time > 0.0 && c.min_time <= 600.0) {
        anyhow::bail!("--min-time: {} is outside (0, 600] seconds", c.min_time);
    }
    if c.warmup > 100 {
        anyhow::bail!("--warmup: {} is more than the limit 100", c.warmup);
    }
    Ok(Protocol {
        warmup: c.warmup,
        min_reps: 5,
        min_time: c.min_time,
    })
}

fn threads(t: usize) -> anyhow::Result<usize> {
    if !(1..=MAX_THREADS).contains(&t) {
        anyhow::bail!("--threads: {t} is outside 1..={MAX_THREADS}");
    }
    Ok(t)
}

fn mesh(name: &str) -> anyhow::Result<shscale_geometry::Mesh> {
    shscale_scene::vocab::mesh(name).map_err(|e| anyhow::anyhow!("--mesh: {e}"))
}

fn print<T: serde::Serialize>(format: TextFormat, row: &T, text: String) -> anyhow::Result<()> {
    match format {
        TextFormat::Json => println!("{}", serde_json::to_string_pretty(row)?),
        TextFormat::Text => println!("{text}"),
    }
    Ok(())
}

fn kernel(k: BenchKernel) -> anyhow::Result<ExitCode> {
    let level = shscale_sh::simd::level();
    match k {
        BenchKernel::Rays(a) => bench_rays(&a, level)?,
        BenchKernel::Bsv(a) => bench_bsv(&a, level)?,
        BenchKernel::Sh(a) => bench_sh(&a, level)?,
    }
    Ok(ExitCode::SUCCESS)
}

/// `bench rays`: a ray set (a file, the BSV workload or random rays) through the BVH.
fn bench_rays(
    a: &crate::args::BenchRaysArgs,
    level: shscale_sh::simd::Level,
) -> anyhow::Result<()> {
    let p = protocol(&a.common)?;
    let t = threads(a.threads)?;
    let m = mesh(&a.mesh)?;
    let (set, workload) = match &a.rays {
        Some(f) => (
            RaySet::from_file(f, a.hits.as_deref()).map_err(|e| anyhow::anyhow!("--rays: {e}"))?,
            f.display().to_string(),
        ),
        None => match a.workload {
            Workload::Bsv => (RaySet::bsv(&m, 12, 20, 32), "bsv".to_string()),
            Workload::Random => {
                if !(1..=MAX_KERNEL_RAYS).contains(&a.count) {
                    anyhow::bail!("--count: {} is outside 1..={MAX_KERNEL_RAYS}", a.count);
                }
                (RaySet::random(&m, a.count, 20261122), "random".to_string())
            }
        },
    };
    let r = kernels::bench_rays(&m, &a.mesh, &workload, &set, t, level, p)?;
    let text = format!(
        "rays {} {} ({} triangles; tree of {} nodes, {:.1} of 8 slots used, {} packs of {:.2} triangles, depth {}): {} rays, {:.2} Mrays/s (median of {} in {:.3} s; min {:.3} ms, max {:.3} ms), {} thread(s), {}, hit fraction {:.4}{}",
        r.mesh,
        r.workload,
        r.triangles,
        r.tree.nodes,
        r.tree.slots_used,
        r.tree.packs,
        r.tree.pack_fill,
        r.tree.depth,
        r.rays,
        r.rays_per_second / 1e6,
        r.timing.reps,
        r.median_seconds,
        r.timing.min_seconds * 1e3,
        r.timing.max_seconds * 1e3,
        r.threads,
        r.simd,
        r.hits as f64 / r.rays as f64,
        r.mismatches.map_or(String::new(), |m| format!(", {m} disagreements with the file's answers"))
    );
    print(a.common.format, &r, text)?;
    Ok(())
}

/// `bench bsv`: one base-sphere visibility sampling of a mesh.
fn bench_bsv(a: &crate::args::BenchBsvArgs, level: shscale_sh::simd::Level) -> anyhow::Result<()> {
    let p = protocol(&a.common)?;
    let t = threads(a.threads)?;
    let m = mesh(&a.mesh)?;
    let layout = shscale_field::bsv::Layout::parse(&a.layout)
        .map_err(|e| anyhow::anyhow!("--layout: {e}"))?;
    if !(1..=shscale_scene::vocab::MAX_VISIBILITY_RES).contains(&a.hemisphere_res) {
        anyhow::bail!(
            "--hemisphere-res: {} is outside 1..={}",
            a.hemisphere_res,
            shscale_scene::vocab::MAX_VISIBILITY_RES
        );
    }
    // The orders a scene may shade with (docs/config-reference.md).
    if !(1..=16).contains(&a.order) {
        anyhow::bail!("--order: {} is outside 1..=16", a.order);
    }
    let rays = layout.sample_count().unwrap_or(usize::MAX) as f64
        * (a.hemisphere_res * a.hemisphere_res) as f64;
    shscale_runner::limits::check_work(
        "bench bsv",
        rays,
        0.0,
        "layout samples × H²",
        a.common.allow_large,
    )?;
    let r = kernels::bench_bsv(&m, &a.mesh, layout, a.hemisphere_res, a.order, t, level, p)?;
    let text = format!(
        "bsv {} {} ({} triangles): {} rays in {:.3} ms (median of {}; min {:.3}, max {:.3}), {:.2} Mrays/s, {} thread(s), {}",
        r.mesh,
        r.workload,
        r.triangles,
        r.rays,
        r.median_seconds * 1e3,
        r.timing.reps,
        r.timing.min_seconds * 1e3,
        r.timing.max_seconds * 1e3,
        r.rays_per_second / 1e6,
        r.threads,
        r.simd
    );
    print(a.common.format, &r, text)?;
    Ok(())
}

/// `bench sh`: the SH basis at `--points` directions.
fn bench_sh(a: &crate::args::BenchShArgs, level: shscale_sh::simd::Level) -> anyhow::Result<()> {
    let p = protocol(&a.common)?;
    shscale_sh::check_order(a.order).map_err(|e| anyhow::anyhow!("--order: {e}"))?;
    if a.points == 0 {
        anyhow::bail!("--points: 0; at least one direction is needed");
    }
    let f32 = a.precision == Precision::F32;
    let bytes = a.points as f64 * (a.order * a.order) as f64 * if f32 { 4.0 } else { 8.0 };
    shscale_runner::limits::check_work(
        "bench sh",
        0.0,
        bytes,
        "--points × N² values",
        a.common.allow_large,
    )?;
    let r = kernels::bench_sh(a.order, f32, a.points, level, p)?;
    let text = format!(
        "sh N={} {}: {:.2} ns/point over {} points (median of {} in {:.3} s), 1 thread, {}",
        r.order, r.precision, r.ns_per_point, r.points, r.timing.reps, r.median_seconds, r.simd
    );
    print(a.common.format, &r, text)?;
    Ok(())
}
