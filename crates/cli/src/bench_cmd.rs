//! `shscale bench`: the Table 1 reproduction (crates/lab/src/bench.rs) printed as Markdown, CSV
//! or JSON, with the machine in a header line; `shscale figs`: the papers' figures
//! (experiments/).

use crate::args::{BenchArgs, BenchFormat, BenchScene, FigsArgs};
use shscale_lab::bench::{bench_scene, to_csv, to_markdown};
use shscale_lab::gpu_path::{open_gpu, GpuMode};
use std::process::ExitCode;

pub fn run(a: BenchArgs) -> anyhow::Result<ExitCode> {
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
    shscale_lab::limits::check_work(
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
        shscale_lab::runner::write_atomic(path, &to_csv(&rows))?;
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
