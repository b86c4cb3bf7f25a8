//! `shscale bench`: the Table 1 reproduction (crates/scene/src/bench.rs) printed as Markdown, CSV
//! or JSON, with the machine in a header line; `shscale figs`: the papers' figures
//! (experiments/).

use crate::args::{
    BenchArgs, BenchFormat, BenchKernel, BenchScene, FigsArgs, KernelCommon, Precision, TextFormat,
    Workload,
};
use crate::flags;
use shscale_runner::check::Ends;
use shscale_runner::GpuMode;
use shscale_scene::bench::{bench_scene, to_csv, to_markdown, BenchPath};
use shscale_scene::gpu_path::open_gpu;
use shscale_scene::kernels::{self, Protocol, RaySet};
use std::process::ExitCode;

/// `--frames` and `--warmup` within the timing kind's bounds; `--pipelined` only without
/// `--methods`.
fn check_frames(a: &BenchArgs) -> anyhow::Result<()> {
    let max = shscale_experiments::timing::MAX_FRAMES;
    flags::int("--frames", a.frames, 1, max)?;
    if a.warmup > max {
        anyhow::bail!("--warmup: {} is more than the limit {max}", a.warmup);
    }
    if a.methods.is_some() && a.pipelined {
        anyhow::bail!(
            "--pipelined: Table 1's papers' sequence only; drop it with --methods (each method's GPU frames run one after another)"
        );
    }
    Ok(())
}

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
    check_frames(&a)?;
    if let Some(list) = &a.methods {
        return bench_methods(&a, scenes, list, ctx.as_ref());
    }
    let extra = extra_paths(&a);
    let paths = usize::from(cpu) + usize::from(ctx.is_some()) * (1 + extra.len());
    check_table1_work(&a, scenes.len(), paths)?;
    let mut rows = Vec::new();
    let bar = crate::output::Progress::new(scenes.len(), "scenes");
    for s in scenes {
        bar.set_message(format!("{s} ({} + {} frames)", a.warmup, a.frames));
        rows.extend(bench_scene(
            s,
            (a.frames, a.warmup),
            cpu,
            ctx.as_ref(),
            &extra,
        )?);
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
                "Table 1 reproduction — medians of {} frames after {} warm-up; {} {}, {} rayon threads; CPU: {}",
                a.frames,
                a.warmup,
                std::env::consts::OS,
                std::env::consts::ARCH,
                rayon::current_num_threads(),
                shscale_sh::cpu::cpu().summary()
            );
            println!();
            print!("{}", to_markdown(&rows));
        }
        BenchFormat::Csv => print!("{}", to_csv(&rows)),
        BenchFormat::Json => println!("{}", serde_json::to_string_pretty(&rows)?),
    }
    Ok(ExitCode::SUCCESS)
}

/// The GPU paths asked for beside the sequential one: pipelined, posed on the device, and both
/// (posed on the device, frames in flight).
fn extra_paths(a: &BenchArgs) -> Vec<BenchPath> {
    [
        (a.pipelined, BenchPath::GpuPipelined),
        (a.device_pose, BenchPath::GpuDevice),
        (a.pipelined && a.device_pose, BenchPath::GpuDevicePipelined),
    ]
    .into_iter()
    .filter_map(|(set, p)| set.then_some(p))
    .collect()
}

/// Table 1's work within the limits (`--allow-large` lifts them): every bench frame traces 240
/// samples × 32² rays per path (configs/bench/).
fn check_table1_work(a: &BenchArgs, scenes: usize, paths: usize) -> anyhow::Result<()> {
    let rays = (scenes * paths) as f64 * (a.frames + a.warmup) as f64 * 240.0 * 1024.0;
    shscale_runner::limits::check_work(
        "bench",
        rays,
        0.0,
        &format!(
            "{scenes} scene(s) × {paths} path(s) × (--frames {} + --warmup {}) × 240 × 32² rays",
            a.frames, a.warmup
        ),
        a.allow_large,
    )?;
    Ok(())
}

/// `bench --methods`: Table 1 per method on the CPU sequence path (`shscale_scene::bench_methods`).
fn bench_methods(
    a: &BenchArgs,
    scenes: &[&str],
    list: &str,
    gpu: Option<&shscale_scene::gpu_path::GpuContext>,
) -> anyhow::Result<ExitCode> {
    use shscale_scene::bench_methods::{bench_method, bench_method_gpu, Truths, Variant};
    let variants = Variant::parse_list(list).map_err(|e| anyhow::anyhow!("--methods: {e}"))?;
    check_methods_work(a, scenes, &variants)?;
    let mut rows = Vec::new();
    let bar = crate::output::Progress::new(scenes.len() * variants.len(), "sequences");
    for s in scenes {
        let (scene, rs) = shscale_scene::bench::scene(s)?;
        let sc = (&scene, &rs);
        let truths = if a.errors {
            bar.set_message(format!("{s}: band-limited truths of {} frames", a.frames));
            Some(Truths::new(&scene, &rs, a.warmup, a.warmup + a.frames)?)
        } else {
            None
        };
        for v in &variants {
            bar.set_message(format!("{s} {}", v.label));
            rows.push(bench_method(s, sc, v, a.frames, a.warmup, truths.as_ref())?);
            if let Some(ctx) = gpu {
                let fw = (a.frames, a.warmup);
                rows.extend(bench_method_gpu(
                    s,
                    sc,
                    v,
                    fw,
                    (truths.as_ref(), false),
                    ctx,
                )?);
                if a.device_pose {
                    let posed = (truths.as_ref(), true);
                    rows.extend(bench_method_gpu(s, sc, v, fw, posed, ctx)?);
                }
            }
            bar.inc();
        }
    }
    bar.finish();
    print_method_rows(a, &rows)?;
    Ok(ExitCode::SUCCESS)
}

/// `bench --methods`' work within the limits (`--allow-large` lifts them): every variant's rays
/// per frame on every scene, and a truth per measured frame with `--errors`.
fn check_methods_work(
    a: &BenchArgs,
    scenes: &[&str],
    variants: &[shscale_scene::bench_methods::Variant],
) -> anyhow::Result<()> {
    use shscale_scene::render::estimated_work;
    let total = (a.frames + a.warmup) as f64;
    let mut rays = 0.0;
    for s in scenes {
        let (sc, rs) = shscale_scene::bench::scene(s)?;
        for v in variants {
            rays += estimated_work(&sc, &v.apply(&rs)).0 * total;
        }
        if a.errors {
            rays += estimated_work(&sc, &rs.with(shscale_scene::method::Method::RayTraced)).0
                * (a.frames + 1) as f64;
        }
    }
    shscale_runner::limits::check_work(
        "bench --methods",
        rays,
        0.0,
        &format!(
            "{} scene(s) × {} method(s) × (--frames {} + --warmup {}){}",
            scenes.len(),
            variants.len(),
            a.frames,
            a.warmup,
            if a.errors {
                ", and a truth per measured frame"
            } else {
                ""
            }
        ),
        a.allow_large,
    )?;
    Ok(())
}

/// `bench --methods`' rows: to `--csv`, then to stdout in `--format`.
fn print_method_rows(
    a: &BenchArgs,
    rows: &[shscale_scene::bench_methods::MethodRow],
) -> anyhow::Result<()> {
    use shscale_scene::bench_methods::{to_csv, to_markdown};
    if let Some(path) = &a.csv {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| anyhow::anyhow!("{}: {e}", dir.display()))?;
        }
        shscale_runner::write_atomic(path, &to_csv(rows))?;
    }
    match a.format {
        BenchFormat::Markdown => {
            println!(
                "Table 1 per method (CPU sequence path) — medians of {} frames after {} warm-up; {} rayon threads; CPU: {}",
                a.frames,
                a.warmup,
                rayon::current_num_threads(),
                shscale_sh::cpu::cpu().summary()
            );
            println!();
            print!("{}", to_markdown(rows));
        }
        BenchFormat::Csv => print!("{}", to_csv(rows)),
        BenchFormat::Json => println!("{}", serde_json::to_string_pretty(rows)?),
    }
    Ok(())
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
    flags::real("--min-time", c.min_time, 0.0, 600.0, Ends::OpenClosed)?;
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
    flags::int("--threads", t, 1, MAX_THREADS)
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
        BenchKernel::Runner(a) => bench_runner(&a)?,
        BenchKernel::Estimates(a) => bench_estimates(&a)?,
    }
    Ok(ExitCode::SUCCESS)
}

/// `bench runner`: the bookkeeping cost per run of sweeps of the do-nothing kind (and the merge
/// of the largest one's shards), or of one config against its runs' own work.
fn bench_runner(a: &crate::args::BenchRunnerArgs) -> anyhow::Result<()> {
    use shscale_runner::bench::{self, TALLY};
    let sizes = runner_sizes(a)?;
    flags::int("--shards", a.shards, 0, 100_000)?;
    let root = runner_root(a)?;
    struct Cleanup(Option<std::path::PathBuf>);
    impl Drop for Cleanup {
        fn drop(&mut self) {
            if let Some(d) = &self.0 {
                let _ = std::fs::remove_dir_all(d);
            }
        }
    }
    let _cleanup = Cleanup(a.out_dir.is_none().then(|| root.clone()));
    let json = a.format == crate::args::TextFormat::Json;
    let mut sweeps = Vec::new();
    if let Some(cfg) = &a.config {
        let text = shscale_files::input::read_regular_string(cfg)
            .map_err(|e| anyhow::anyhow!("--config: {e}"))?;
        let registry = shscale_experiments::registry();
        let file = cfg.display().to_string();
        let out = root.join("config");
        sweeps.push(bench::sweep(&text, &file, &registry, &out, a.allow_large)?);
    }
    for &n in &sizes {
        sweeps.push(bench::sweep(
            &bench::tally_config(n),
            &format!("--runs {n}"),
            &[&TALLY],
            &root.join(n.to_string()),
            a.allow_large,
        )?);
        if !json {
            eprintln!("{} runs done", n);
        }
    }
    let hashing = match sizes.iter().max() {
        Some(&n) => Some(runner_hashing(&root, n)?),
        None => None,
    };
    let merge = match sizes.iter().max() {
        Some(&n) if a.shards > 0 => Some(bench::merge_shards(
            &root
                .join(n.to_string())
                .join("tally")
                .join(format!("tally-{n}")),
            a.shards,
        )?),
        _ => None,
    };
    if json {
        crate::output::print_json(&serde_json::json!({
            "threads": rayon::current_num_threads(),
            "cpu": kernels::CpuRow::this(),
            "sweeps": sweeps,
            "merge": merge,
            "hashing": hashing.as_ref().map(|(name, h)| serde_json::json!({"mesh": name, "cost": h})),
        }))?;
        return Ok(());
    }
    print_runner_table(a.config.is_some(), &sweeps, merge.as_ref());
    if let Some((name, h)) = &hashing {
        println!();
        println!(
            "inputs by content: the largest bundled mesh ({name}, {:.2} MB) hashed cold {:.2} ms as a file, {:.2} ms embedded; a cached lookup {:.2} µs; a plan of {} runs reading it {:.3} s against {:.3} s without ({} read)",
            h.bytes as f64 / 1e6,
            h.cold_file_s * 1e3,
            h.cold_embedded_s * 1e3,
            h.cached_per_call_s * 1e6,
            h.runs,
            h.plan_with_input_s,
            h.plan_without_s,
            h.reads_in_plan
        );
    }
    Ok(())
}

/// `bench runner`'s folder: `--out-dir` (which must be an empty folder or absent) or a fresh
/// one in the temporary directory.
fn runner_root(a: &crate::args::BenchRunnerArgs) -> anyhow::Result<std::path::PathBuf> {
    let root = a.out_dir.clone().unwrap_or_else(|| {
        std::env::temp_dir().join(format!("shscale-bench-runner-{}", std::process::id()))
    });
    if root.exists() && !root.is_dir() {
        anyhow::bail!(
            "--out-dir {}: exists and is not a folder; the bench needs an empty folder",
            root.display()
        );
    }
    if root.exists() && std::fs::read_dir(&root)?.next().is_some() {
        anyhow::bail!(
            "--out-dir {}: not empty; the bench needs an empty folder",
            root.display()
        );
    }
    Ok(root)
}

/// Inputs by content: the largest bundled mesh hashed cold (as a file and embedded), a cached
/// lookup, and a plan of `n` runs with every run reading it (in `root/hashing`).
fn runner_hashing(
    root: &std::path::Path,
    n: usize,
) -> anyhow::Result<(&'static str, shscale_runner::bench::HashCost)> {
    let (name, text) = (shscale_geometry::bundled::BUNDLED.iter())
        .max_by_key(|(_, t)| t.len())
        .copied()
        .unwrap_or(("none", ""));
    let d = root.join("hashing");
    std::fs::create_dir_all(&d)?;
    Ok((
        name,
        shscale_runner::bench::hash_cost(&d, text.as_bytes(), n)?,
    ))
}

/// The most runs of one `bench runner` sweep, and the most sweeps (`--runs` entries).
const MAX_BENCH_RUNS: usize = 100_000;
const MAX_BENCH_SWEEPS: usize = 8;

/// The plan sizes of `bench runner` (`--runs`: at most `MAX_BENCH_SWEEPS` whole numbers, each
/// in 1..=`MAX_BENCH_RUNS`); none with `--config`.
fn runner_sizes(a: &crate::args::BenchRunnerArgs) -> anyhow::Result<Vec<usize>> {
    if a.config.is_some() {
        return Ok(Vec::new());
    }
    let list = crate::args::parse_list("runs", &a.runs)?;
    if list.len() > MAX_BENCH_SWEEPS {
        anyhow::bail!(
            "--runs: {} sizes; give at most {MAX_BENCH_SWEEPS}",
            list.len()
        );
    }
    list.into_iter()
        .map(|v| {
            let n = v as usize;
            if v.fract() != 0.0 || v < 1.0 {
                anyhow::bail!("--runs: {v} is not a whole number ≥ 1");
            }
            flags::int("--runs", n, 1, MAX_BENCH_RUNS)
        })
        .collect()
}

/// `bench runner`'s table: a line per sweep, then the merge of the shards.
fn print_runner_table(
    config: bool,
    sweeps: &[shscale_runner::bench::SweepCost],
    merge: Option<&shscale_runner::bench::MergeCost>,
) {
    println!(
        "runner bookkeeping — {}, {} rayon threads; seconds of wall time; CPU: {}",
        if config {
            "the config's sweep"
        } else {
            "a kind that does no work"
        },
        rayon::current_num_threads(),
        shscale_sh::cpu::cpu().summary()
    );
    println!();
    println!("| runs | plan | run | runs' work | report | total / work | overhead per run | resume (nothing to do) | runs.csv | report.html | peak RSS |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for s in sweeps {
        println!(
            "| {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {:.1} µs | {:.3} | {:.1} MB | {:.0} kB | {:.0} MB |",
            s.runs,
            s.plan_s,
            s.run_s,
            s.work_s,
            s.report_s,
            s.total_over_work,
            s.overhead_per_run_s * 1e6,
            s.resume_s,
            s.csv_bytes as f64 / 1e6,
            s.html_bytes as f64 / 1e3,
            s.peak_rss_bytes as f64 / 1e6,
        );
    }
    if let Some(m) = merge {
        println!();
        println!(
            "merge of {} shard files ({} rows): {:.3} s, then its report {:.3} s",
            m.shards, m.rows, m.merge_s, m.report_s
        );
    }
}

/// `bench estimates`: each config's `--dry-run` estimate against its measured wall time from
/// empty (plan, runs, report; not the process's start), one config after another in a fresh
/// temporary folder each. Configs whose estimate depends on files read at run time (the
/// `shadows` kind) are measured and listed without a ratio.
fn bench_estimates(a: &crate::args::BenchEstimatesArgs) -> anyhow::Result<()> {
    let registry = shscale_experiments::registry();
    let overrides = shscale_runner::config::Overrides::default();
    crate::flags::calibrate_estimates()?;
    let speed = shscale_runner::timing::machine_speed().unwrap_or(1.0);
    // Every config resolved before any runs: a bad one fails the bench at once.
    let mut plans = Vec::new();
    for c in &a.configs {
        let plan = shscale_runner::Plan::load(c, &overrides, &registry)?;
        plan.check_limits(a.allow_large)?;
        plans.push(plan);
    }
    let root = std::env::temp_dir().join(format!("shscale-bench-estimates-{}", std::process::id()));
    struct Cleanup(std::path::PathBuf);
    impl Drop for Cleanup {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
    let _cleanup = Cleanup(root.clone());
    let json = a.format == crate::args::TextFormat::Json;
    let mut rows = Vec::new();
    for (i, (c, plan)) in a.configs.iter().zip(&plans).enumerate() {
        let estimate = plan.estimate().seconds;
        let dir = root.join(i.to_string());
        let t0 = std::time::Instant::now();
        let s = shscale_runner::run_plan(plan, &dir, None, &|_| {})?;
        shscale_runner::report(plan.kind, &s.dir)?;
        let measured = t0.elapsed().as_secs_f64();
        let _ = std::fs::remove_dir_all(&dir);
        let ratio = (estimate.is_finite() && measured > 0.0).then(|| estimate / measured);
        // The development VM's seconds, as the model prints them without a speed.
        let vm = estimate * speed;
        if !json {
            eprintln!("{}: {measured:.2} s", c.display());
        }
        rows.push(serde_json::json!({
            "config": c.display().to_string(),
            "runs": plan.runs.len(),
            "estimate_s": estimate.is_finite().then_some(estimate),
            "measured_s": measured,
            "estimate_over_measured": ratio,
            "estimate_dev_vm_s": vm.is_finite().then_some(vm),
            "dev_vm_estimate_over_measured": (vm.is_finite() && measured > 0.0).then(|| vm / measured),
        }));
    }
    if json {
        crate::output::print_json(&serde_json::json!({
            "threads": rayon::current_num_threads(),
            "cpu": kernels::CpuRow::this(),
            "speed": speed,
            "configs": rows,
        }))?;
        return Ok(());
    }
    print_estimates(&rows, speed);
    Ok(())
}

/// `bench estimates`' text table.
fn print_estimates(rows: &[serde_json::Value], speed: f64) {
    println!(
        "`--dry-run` estimate against measured wall time, {} rayon threads; this machine's ray rate {speed:.2}× the development VM's ({}); CPU: {}",
        rayon::current_num_threads(),
        if std::env::var_os("SHSCALE_SPEED").is_some() { "SHSCALE_SPEED" } else { "measured" },
        shscale_sh::cpu::cpu().summary()
    );
    println!();
    println!("| config | runs | estimate (s) | measured (s) | estimate / measured | uncalibrated estimate / measured |");
    println!("|---|---:|---:|---:|---:|---:|");
    for r in rows {
        let f = |k: &str, p: usize| {
            r[k].as_f64()
                .map_or("not estimated".to_string(), |v| format!("{v:.p$}"))
        };
        println!(
            "| {} | {} | {} | {} | {} | {} |",
            r["config"].as_str().unwrap_or_default(),
            r["runs"],
            f("estimate_s", 2),
            f("measured_s", 2),
            f("estimate_over_measured", 2),
            f("dev_vm_estimate_over_measured", 2)
        );
    }
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
                flags::int("--count", a.count, 1, MAX_KERNEL_RAYS)?;
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
    ) + &format!("; CPU: {}", r.cpu.summary);
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
    flags::int(
        "--hemisphere-res",
        a.hemisphere_res,
        1,
        shscale_scene::vocab::MAX_VISIBILITY_RES,
    )?;
    // The orders a scene may shade with (docs/config-reference.md).
    flags::int("--order", a.order, 1, 16)?;
    let rays = layout.sample_count().unwrap_or(usize::MAX) as f64
        * (a.hemisphere_res * a.hemisphere_res) as f64;
    shscale_runner::limits::check_work(
        "bench bsv",
        rays,
        0.0,
        "layout samples × H²",
        a.common.allow_large,
    )?;
    if let Some(prefix) = &a.write_rays {
        if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
            if !dir.is_dir() {
                anyhow::bail!("--write-rays: directory {} does not exist", dir.display());
            }
        }
    }
    let mut r = kernels::bench_bsv(&m, &a.mesh, layout, a.hemisphere_res, a.order, t, level, p)?;
    if let Some(prefix) = &a.write_rays {
        r.written = Some(
            kernels::write_bsv_rays(&m, layout, a.hemisphere_res, a.order, prefix)
                .map_err(|e| anyhow::anyhow!("--write-rays: {e}"))?,
        );
    }
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
    ) + &format!("; CPU: {}", r.cpu.summary)
        + &r.written.as_ref().map_or(String::new(), |w| {
            format!(
                "\nwrote {} rays to {} ({}, {}), tnear {:e}, hit fraction {:.4}",
                w.count, w.rays, w.hits, w.mesh, w.tnear, w.hit_fraction
            )
        });
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
    ) + &format!("; CPU: {}", r.cpu.summary);
    print(a.common.format, &r, text)?;
    Ok(())
}
