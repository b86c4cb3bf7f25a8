//! Command-line schema (clap derive). Parsing of comma lists lives here; validation of values
//! against their mathematical domains lives in the numerical crates.

use clap::{Args, Parser, Subcommand, ValueEnum};
use shscale_scene::method::Method;

/// `--version`: the crate version, the git revision it was built from (`+dirty` when the
/// checkout had local changes at build time) and the numerical fingerprint its rows carry in
/// `code` (docs/provenance.md).
pub static VERSION: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| {
    format!(
        "{} (git {}, numerical code {})",
        env!("CARGO_PKG_VERSION"),
        shscale_runner::manifest::BUILD_REVISION,
        shscale_runner::manifest::CODE_FINGERPRINT
    )
});

#[derive(Parser, Debug)]
#[command(
    name = "shscale",
    version = VERSION.as_str(),
    about = "Spherical-harmonics scaling and shadow fields for deformable objects: an evaluation framework",
    after_help = "Examples:\n  shscale demo\n  shscale sh eval --order 4 --dir 0,0,1\n  shscale sh cap --order 4 --angle-deg 30\n  shscale sh rotate --order 2 --coeffs 1,0,1,0 --euler-zyz-deg 0,90,0\n  shscale matrix --order 4 --tau cone --alpha-deg 45 --k 2\n  shscale matrix --order 8 --tau cone --alpha-deg 45 --table 40 --k-range 0.1,10\n  shscale inspect bunny\n  shscale visibility --mesh sphere --point 0,0,2 --order 4\n  shscale probe --mesh bunny --order 4 --alpha-deg 45\n  shscale render --scene configs/scene_bunny.toml --method extrapolated --out results/bunny.exr\n  shscale run configs/probe_alpha_sweep.toml\n  shscale slurm configs/probe_alpha_sweep.toml --tasks 8 > sweep.sh"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Inspect the SH core: evaluate the basis, cap coefficients, rotate coefficients.
    /// Example: shscale sh eval --order 4 --dir 0,0,1
    #[command(subcommand)]
    Sh(ShCommand),
    /// Print a dense SH scaling matrix, or build a k-table and report its interpolation error.
    /// Example: shscale matrix --order 4 --tau cone --alpha-deg 45 --k 2 --format pretty
    Matrix(MatrixArgs),
    /// Built-in demonstration: scale caps with M_k and check them against the analytic caps.
    /// Example: shscale demo --order 8
    Demo(DemoArgs),
    /// Mesh counts, minimal bounding sphere, watertightness and validation findings.
    /// Example: shscale inspect bunny
    Inspect(InspectArgs),
    /// Ray-traced visibility (1 = unoccluded) at a point over the full sphere, projected to SH.
    /// Example: shscale visibility --mesh sphere --point 0,0,2 --order 4
    Visibility(VisibilityArgs),
    /// Extrapolated vs ray-traced visibility at the papers' probe radii (Fig. 5), with metrics.
    /// Example: shscale probe --mesh bunny --order 4 --alpha-deg 45
    Probe(ProbeArgs),
    /// Render a scene's receiver plane (irradiance) to EXR + PNG with one visibility method.
    /// Example: shscale render --scene configs/scene_sphere.toml --method extrapolated --out results/sphere.exr
    Render(RenderArgs),
    /// Run an experiment config (sweeps → runs.csv + manifest.toml; resumable, shardable).
    /// Example: shscale run configs/probe_alpha_sweep.toml
    Run(RunArgs),
    /// Merge shard outputs (runs*.csv) into <first dir>/runs.csv.
    /// Example: shscale merge results/probe/probe_alpha_sweep
    Merge(MergeArgs),
    /// Write a Slurm job-array script running CONFIG in N shards, then the merge.
    /// Example: shscale slurm configs/probe_alpha_sweep.toml --tasks 8 > sweep.sh
    Slurm(SlurmArgs),
    /// Table 1: per-stage times and FPS of the deforming sequences, CPU and GPU side by side.
    /// Example: shscale bench --gpu --scene all --frames 16 --format markdown
    Bench(BenchArgs),
    /// Regenerate the papers' figures (paper-figs/) from configs/paper/*.toml, with an index.
    /// Example: shscale figs
    Figs(FigsArgs),
    /// Regenerate summary.md, report.md, the self-contained report.html and the plots of a
    /// results directory. Example: shscale report results/probe/quickstart
    Report {
        /// A results directory (holding runs.csv and manifest.toml).
        dir: std::path::PathBuf,
    },
    /// Compare two results directories of one kind: metrics over the parameters both share and
    /// their differences (compare.md + plots). Example: shscale compare results/probe/a results/probe/b
    Compare {
        a: std::path::PathBuf,
        b: std::path::PathBuf,
        /// Where compare.md and the plots go [default: <A>/../compare_<A>_vs_<B>].
        #[arg(long)]
        out: Option<std::path::PathBuf>,
        /// `json`: the comparison's Markdown and files as one JSON object.
        #[arg(long, value_enum, default_value_t = TextFormat::Text)]
        format: TextFormat,
    },
    /// Re-plot any column of a results directory without rerunning: plot_<METRIC>_vs_<X>[_by_<FACET>][_series_<S>][_where_<K>-<V>].png/.svg (every selecting argument in the name: two plots of different rows never overwrite each other).
    /// Example: shscale plot results/probe/quickstart --metric occ_rel_l2_mean --x alpha_deg --facet radius --where sampling_radius=1.0
    Plot(PlotArgs),
    /// Print the config reference (runner keys, every kind's parameters, scene-file keys) as
    /// Markdown — the text of docs/config-reference.md. Example: shscale config-reference
    ConfigReference,
    /// Print a shell completion script: bash, zsh, fish, elvish or powershell.
    /// Example: shscale completions bash > ~/.local/share/bash-completion/completions/shscale
    Completions {
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
}

#[derive(Args, Debug)]
pub struct PlotArgs {
    pub dir: std::path::PathBuf,
    /// The y column.
    #[arg(long)]
    pub metric: String,
    /// The x column.
    #[arg(long)]
    pub x: String,
    /// One series per combination of these columns; repeatable [default: the other varying
    /// parameters, faceted by the probe radius (or the parameter with most values) when
    /// that would make more than 8 series].
    #[arg(long)]
    pub series: Vec<String>,
    /// One panel per value of this column (at most 16).
    #[arg(long)]
    pub facet: Option<String>,
    /// Keep only rows with COLUMN=VALUE (numbers compared as numbers); repeatable.
    #[arg(long = "where", value_name = "COLUMN=VALUE")]
    pub filters: Vec<String>,
    /// Logarithmic y axis (default: when the data span two decades).
    #[arg(long, conflicts_with = "linear_y")]
    pub log_y: bool,
    /// Linear y axis even when the data span decades.
    #[arg(long)]
    pub linear_y: bool,
    /// Logarithmic x axis (every x must be > 0).
    #[arg(long)]
    pub log_x: bool,
}

#[derive(Args, Debug)]
pub struct FigsArgs {
    /// Folder of figure configs.
    #[arg(long, default_value = "configs/paper")]
    pub configs: std::path::PathBuf,
    /// Output folder (created); its README.md is rewritten as the index.
    #[arg(long, default_value = "paper-figs")]
    pub out: std::path::PathBuf,
    /// GPU rows of Table 1: auto (when an adapter exists), off, required.
    #[arg(long, default_value = "auto")]
    pub gpu: String,
    /// Keep the figures' runs (runs.csv, manifest, per-run images) under this folder, resumed
    /// when already there. Default: a fresh temporary folder, removed afterwards, so every
    /// figure is recomputed by this binary.
    #[arg(long, value_name = "DIR")]
    pub runs: Option<std::path::PathBuf>,
    /// `json`: one JSON object (the files written and the index).
    #[arg(long, value_enum, default_value_t = TextFormat::Text)]
    pub format: TextFormat,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchScene {
    Bird,
    Egg,
    Sponge,
    All,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TextFormat {
    Text,
    Json,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchFormat {
    Markdown,
    Csv,
    Json,
}

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true)]
pub struct BenchArgs {
    /// One kernel timed the way the peers are (Embree, sphericart): rays, bsv or sh. Without
    /// one, the Table 1 reproduction below.
    #[command(subcommand)]
    pub kernel: Option<BenchKernel>,
    /// Also run the GPU path (without an adapter: a one-line notice, the CPU path goes on).
    #[arg(long)]
    pub gpu: bool,
    /// With --gpu: fail (exit 2) when no adapter exists instead of going on with the CPU.
    #[arg(long, requires = "gpu")]
    pub require_gpu: bool,
    /// With --gpu: a third row per scene, the GPU sequence pipelined (the host poses and refits
    /// frame i + 1 while the device runs frame i; timestamp queries needed): its frame is the
    /// period between completions, its stages as measured — their sum less the frame is the
    /// overlap.
    #[arg(long, requires = "gpu")]
    pub pipelined: bool,
    /// With --gpu: one more row per scene, the GPU sequence posed and refitted on the device
    /// (`gpu-device`: deform and refit are device stages, only the pose's uniform is uploaded;
    /// with --pipelined also `gpu-device-pipelined`, two such frames in flight);
    /// with --methods, a `gpu-device` row for each method the device poses (the papers'
    /// extrapolation, sphere sets with the area fit: posed and fitted on the device).
    #[arg(long, requires = "gpu")]
    pub device_pose: bool,
    /// Skip the CPU path (with --gpu).
    #[arg(long, requires = "gpu")]
    pub no_cpu: bool,
    /// The sequence(s): the flying bird, the morphing egg, the bending sponge (configs/bench/).
    #[arg(long, value_enum, default_value_t = BenchScene::All)]
    pub scene: BenchScene,
    /// Measured frames per scene and path (medians over them).
    #[arg(long, default_value_t = 16, value_parser = whole)]
    pub frames: usize,
    /// Warm-up frames, run and dropped before measuring.
    #[arg(long, default_value_t = 3, value_parser = whole)]
    pub warmup: usize,
    #[arg(long, value_enum, default_value_t = BenchFormat::Markdown)]
    pub format: BenchFormat,
    /// Also write the rows as CSV to this file (atomically).
    #[arg(long)]
    pub csv: Option<std::path::PathBuf>,
    /// Table 1 per method on the CPU sequence path: a comma-separated list of variants
    /// `name[:key=value,…]` (keys `parts`, `s` = sampling radius, `clearance` = δ of per-direction
    /// radii, `combine` = a sphere set's combination), or `default` (extrapolated, full_field,
    /// extrapolated:s=1.2, extrapolated:clearance=0.1, sub_volumes:parts=2, sphere_set:parts=4,
    /// sphere_set:parts=16, sphere_set:parts=16,combine=union). With --gpu, a GPU row too for
    /// each variant with a GPU form (the papers' extrapolation from one sampling sphere or
    /// clearance radii, sub-volumes, the full field, sphere sets by the chain, the union or SH
    /// exponentiation).
    #[arg(long)]
    pub methods: Option<String>,
    /// With --methods: score every measured frame against the band-limited truth of its pose
    /// (ray_traced at the scene's truth_res; once per frame, shared by the methods, not timed).
    #[arg(long, requires = "methods")]
    pub errors: bool,
    /// Run even when the estimated work exceeds 1e10 rays (docs/limits.md).
    #[arg(long)]
    pub allow_large: bool,
}

#[derive(Subcommand, Debug)]
pub enum BenchKernel {
    /// Occlusion throughput of the BVH on the BSV workload, random rays or a peers' ray file.
    /// Example: shscale bench rays --mesh bunny --workload random --threads 1 --format json
    Rays(BenchRaysArgs),
    /// The whole BSV sampling (rays and SH projection) of one mesh.
    /// Example: shscale bench bsv --mesh bunny --hemisphere-res 32 --order 4 --threads 2
    Bsv(BenchBsvArgs),
    /// All N² real SH at P random directions, one thread.
    /// Example: shscale bench sh --order 8 --precision f32 --format json
    Sh(BenchShArgs),
    /// The `--dry-run` time estimate against the measured wall time of each config, run from
    /// empty (a temporary folder) one after another.
    /// Example: shscale bench estimates configs/quickstart.toml configs/experiments/*.toml
    Estimates(BenchEstimatesArgs),
    /// The runner's own cost per run (plan, store, resume, report, merge) on a kind that does
    /// no work, or of a config of yours against its runs' own work.
    /// Example: shscale bench runner --runs 1000,10000 --shards 100
    Runner(BenchRunnerArgs),
}

#[derive(Args, Debug)]
pub struct BenchRunnerArgs {
    /// Sweep sizes of the do-nothing kind, comma-separated (each 1..=100000).
    #[arg(long, default_value = "1000,10000,100000")]
    pub runs: String,
    /// Merge the largest sweep's rows dealt into this many shard files (0: no merge).
    #[arg(long, default_value_t = 1000)]
    pub shards: usize,
    /// Instead, time this config (any kind): the whole sweep against its runs' own work.
    #[arg(long, conflicts_with_all = ["runs", "shards"])]
    pub config: Option<std::path::PathBuf>,
    /// Where the results go (default: a temporary folder, removed afterwards).
    #[arg(long)]
    pub out_dir: Option<std::path::PathBuf>,
    #[arg(long, value_enum, default_value_t = TextFormat::Text)]
    pub format: TextFormat,
    /// Run a `--config` plan beyond the limits (10^10 rays, 8 GiB per group), as `run` takes it.
    #[arg(long)]
    pub allow_large: bool,
}

#[derive(Args, Debug)]
pub struct BenchEstimatesArgs {
    /// Experiment configs (any kind); each is run whole, so pick what fits your time.
    #[arg(required = true)]
    pub configs: Vec<std::path::PathBuf>,
    #[arg(long, value_enum, default_value_t = TextFormat::Text)]
    pub format: TextFormat,
    /// Run configs beyond the limits (10^10 rays, 8 GiB per group), as `run` takes them: the
    /// limit's message advises this flag.
    #[arg(long)]
    pub allow_large: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Workload {
    /// 12×20 samples on the minimal bounding sphere × 32² rays toward the centre.
    Bsv,
    /// 10⁶ rays, origins uniform in the doubled bounding box, directions uniform.
    Random,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Precision {
    F32,
    F64,
}

/// Flags every kernel benchmark shares.
#[derive(Args, Debug)]
pub struct KernelCommon {
    /// `json`: one JSON object.
    #[arg(long, value_enum, default_value_t = TextFormat::Text)]
    pub format: TextFormat,
    /// Keep repeating until the timed calls add up to this many seconds (0 < S ≤ 600).
    #[arg(long, default_value_t = 1.0)]
    pub min_time: f64,
    /// Warm-up calls, run and dropped.
    #[arg(long, default_value_t = 2, value_parser = whole)]
    pub warmup: usize,
    /// Run even when one call's estimated work exceeds 1e10 rays or 8 GiB (docs/limits.md).
    #[arg(long)]
    pub allow_large: bool,
}

#[derive(Args, Debug)]
pub struct BenchRaysArgs {
    /// A mesh name or OBJ/PLY file (not the analytic sphere).
    #[arg(long, default_value = "bunny")]
    pub mesh: String,
    #[arg(long, value_enum, default_value_t = Workload::Bsv)]
    pub workload: Workload,
    /// Rays for the random workload.
    #[arg(long, default_value_t = 1_000_000, value_parser = whole)]
    pub count: usize,
    /// Trace the rays of a peers' file instead (`<mesh>_{A,B}.rays.f32`; t from 0).
    #[arg(long, conflicts_with_all = ["workload", "count"])]
    pub rays: Option<std::path::PathBuf>,
    /// With --rays: Embree's answers (`.hits.bits`), to count disagreements.
    #[arg(long, requires = "rays")]
    pub hits: Option<std::path::PathBuf>,
    /// Worker threads (1 = the calling thread's pool of one).
    #[arg(long, default_value_t = 1, value_parser = whole)]
    pub threads: usize,
    #[command(flatten)]
    pub common: KernelCommon,
}

#[derive(Args, Debug)]
pub struct BenchBsvArgs {
    /// A mesh name or OBJ/PLY file (not the analytic sphere).
    #[arg(long, default_value = "bunny")]
    pub mesh: String,
    /// Base-sphere layout: latlong:RxC, cube:N or fib:P.
    #[arg(long, default_value = "latlong:12x20")]
    pub layout: String,
    /// Hemisphere resolution H (H² rays per sample).
    #[arg(long, default_value_t = 32, value_parser = whole)]
    pub hemisphere_res: usize,
    /// SH order N.
    #[arg(long, default_value_t = 4, value_parser = whole)]
    pub order: usize,
    #[arg(long, default_value_t = 2, value_parser = whole)]
    pub threads: usize,
    /// Also write the sampling's exact rays for a peer: PREFIX.rays.f32 (origins then
    /// directions, f32, the peer kit's format), PREFIX.hits.bits (our answers) and PREFIX.obj (the
    /// mesh as traced); the rays' tmin is printed (Embree's tnear).
    #[arg(long, value_name = "PREFIX")]
    pub write_rays: Option<std::path::PathBuf>,
    #[command(flatten)]
    pub common: KernelCommon,
}

#[derive(Args, Debug)]
pub struct BenchShArgs {
    /// SH order N (l_max = N − 1).
    #[arg(long, default_value_t = 8, value_parser = whole)]
    pub order: usize,
    #[arg(long, value_enum, default_value_t = Precision::F64)]
    pub precision: Precision,
    /// Directions (the output holds points × N² values).
    #[arg(long, default_value_t = 1_000_000, value_parser = whole)]
    pub points: usize,
    #[command(flatten)]
    pub common: KernelCommon,
}

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Directories holding runs*.csv (shard files and/or runs.csv), all of one experiment kind.
    #[arg(required = true)]
    pub dirs: Vec<std::path::PathBuf>,
    /// Output directory (new; default <first DIR>/merged): runs.csv, manifest.toml, summary and
    /// plots. An existing runs.csv there is never overwritten, unless --replace.
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
    /// Replace an existing merged runs.csv and manifest.toml, atomically (what the merge job of
    /// a `shscale slurm` script does, so a resubmitted script can merge again).
    #[arg(long)]
    pub replace: bool,
    /// Merge inputs of several config versions or code revisions (refused without it).
    #[arg(long)]
    pub allow_mixed: bool,
    /// Merge although shard files or runs of the plan are missing (refused without it); the
    /// merged manifest.toml records what is missing.
    #[arg(long)]
    pub allow_partial: bool,
    /// `json`: one JSON object (the merged directory, files, rows, report files).
    #[arg(long, value_enum, default_value_t = TextFormat::Text)]
    pub format: TextFormat,
}

#[derive(Args, Debug)]
pub struct SlurmArgs {
    pub config: std::path::PathBuf,
    /// Number of array tasks (shards).
    #[arg(value_parser = whole, long)]
    pub tasks: usize,
    /// Path of the shscale binary on the cluster.
    #[arg(long, default_value = "shscale", allow_hyphen_values = true)]
    pub binary: String,
    #[arg(long, default_value = "results")]
    pub out_dir: std::path::PathBuf,
    /// Overrides passed to every shard, as for `shscale run`.
    #[command(flatten)]
    pub overrides: OverrideArgs,
    /// sbatch --time (e.g. 02:00:00).
    #[arg(long, allow_hyphen_values = true)]
    pub time: Option<String>,
    /// sbatch --mem (e.g. 8G).
    #[arg(long, allow_hyphen_values = true)]
    pub mem: Option<String>,
    /// sbatch --partition.
    #[arg(long, allow_hyphen_values = true)]
    pub partition: Option<String>,
    /// sbatch --cpus-per-task.
    #[arg(value_parser = whole, long)]
    pub cpus_per_task: Option<usize>,
    /// sbatch --account.
    #[arg(long, allow_hyphen_values = true)]
    pub account: Option<String>,
    /// At most this many array tasks at once (sbatch --array=0-N%K).
    #[arg(value_parser = whole, long)]
    pub array_parallel: Option<usize>,
    /// sbatch --dependency of the array job (e.g. afterok:12345); the merge always waits for
    /// the array.
    #[arg(long, allow_hyphen_values = true)]
    pub dependency: Option<String>,
}

/// Command-line overrides of an experiment config (Hydra style).
#[derive(Args, Debug, Default, Clone)]
pub struct OverrideArgs {
    /// Set a key (dotted for nested keys): `--set order=6`, `--set light.sun=2.5`, a list as
    /// `--set radii=1.3,2`; repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE", allow_hyphen_values = true)]
    pub set: Vec<String>,
    /// Add or replace a sweep axis: `--sweep alpha_deg=15,30,45`; repeatable.
    #[arg(
        long = "sweep",
        value_name = "KEY=V1,V2,...",
        allow_hyphen_values = true
    )]
    pub sweep: Vec<String>,
    /// The results name (letters, digits, '.', '_', '-'): <out-dir>/<experiment>/<NAME>/.
    #[arg(long)]
    pub name: Option<String>,
}

#[derive(Args, Debug)]
pub struct RunArgs {
    /// Experiment config (TOML; keys and overrides in experiments/README.md).
    pub config: Option<std::path::PathBuf>,
    /// Run only shard I of N (runs whose index ≡ I mod N), e.g. 0/4.
    #[arg(long, allow_hyphen_values = true)]
    pub shard: Option<String>,
    /// Root of the outputs: <out-dir>/<experiment>/<name>/.
    #[arg(long, default_value = "results")]
    pub out_dir: std::path::PathBuf,
    #[command(flatten)]
    pub overrides: OverrideArgs,
    /// Print the resolved plan (runs, shared groups, estimated rays, memory, time) and write
    /// nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// `json`: print one JSON object (the results directory, CSV, counts, files written)
    /// instead of the log and the summary.
    #[arg(long, value_enum, default_value_t = TextFormat::Text)]
    pub format: TextFormat,
    /// Run plans beyond the limits (10^10 rays, 8 GiB per group).
    #[arg(long)]
    pub allow_large: bool,
    /// Rows of this plan that are stale (computed by other numerical code, or from inputs whose
    /// content changed; docs/provenance.md): `rerun` sets them aside into runs.csv.stale and
    /// runs them again; `refuse` stops before any work, naming them.
    #[arg(long, value_enum, default_value_t = StaleArg::Rerun)]
    pub stale: StaleArg,
}

/// `--stale`: what `shscale run` does with stale rows of its plan.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum StaleArg {
    Rerun,
    Refuse,
}

/// A method of the one vocabulary (`shscale_scene::method`): its name, or the command line's
/// earlier spellings (`full-field`, `raytraced`, `raytraced-full`).
fn method_arg(s: &str) -> Result<Method, String> {
    Method::parse_cli(s)
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML; its keys: `shscale config-reference`, section "Scene files", or
    /// docs/config-reference.md).
    #[arg(long)]
    pub scene: std::path::PathBuf,
    /// The method: `extrapolated`, `full_field` (Zhou et al. 2005's field), `ray_traced`
    /// (band-limited truth), `full_frequency` (full-frequency truth), `sub_volumes` or
    /// `sphere_set` (the scene's occluders split into 4 parts); `full-field`, `raytraced` and
    /// `raytraced-full` are the earlier spellings.
    #[arg(long, value_parser = method_arg, default_value_t = Method::Extrapolated)]
    pub method: Method,
    /// Parts of every mesh occluder for `--method sub_volumes`, or its spheres for `sphere_set`,
    /// 1..=64 (k-means on triangle centroids).
    #[arg(long, value_parser = whole, default_value_t = 4)]
    pub parts: usize,
    /// How `--method sphere_set` combines its spheres: `product` (truncated SH products near to
    /// far), `union` (the exact union of the caps, no products) or `shexp` (SH exponentiation,
    /// Ren et al. 2006; orders up to 8); the last two on the CPU only.
    #[arg(long, value_enum, default_value_t = SphereCombine::Product)]
    pub sphere_combine: SphereCombine,
    /// Which spheres `--method sphere_set` takes: `area` (one per k-means part, refitted every
    /// frame) or `inscribed` (the greedy cover of each pose's interior by inscribed balls, nested
    /// in --parts: a one-off fit per pose, kept for the last 16 poses).
    #[arg(long, value_enum, default_value_t = SphereFitArg::Area)]
    pub sphere_fit: SphereFitArg,
    /// How extrapolated fields combine — `--method sub_volumes`'s parts, or a scene's several
    /// occluders under `extrapolated`: `product` (near to far) or `shexp` (scaling in log space:
    /// the base-sphere samples' logs scaled, summed, exponentiated once; orders up to 8, no
    /// plausibility clamp; CPU only).
    #[arg(long, value_enum, default_value_t = PartCombine::Product)]
    pub part_combine: PartCombine,
    /// Output EXR path; a PNG preview is written beside it.
    #[arg(long)]
    pub out: std::path::PathBuf,
    /// Animate the scene's deformers over this many frames (t = f/frames, any method) and print
    /// per-frame stage times (with --reference, each frame's error); the image is the last
    /// frame. The papers' extrapolation takes the cached real-time path; every other method
    /// renders each frame from its posed mesh.
    #[arg(value_parser = whole, long)]
    pub frames: Option<usize>,
    /// Also render this reference on the same scene and print `shade_rmse_rel` against it
    /// (docs/conventions.md §6; with --frames, per frame at the frame's pose): `ray_traced`
    /// (band-limited truth) or `full_frequency` (full-frequency truth).
    #[arg(long, value_parser = method_arg)]
    pub reference: Option<Method>,
    /// With --frames: render the sequence on the GPU (wgpu; one mesh occluder, N ≤ 8) and print
    /// the GPU stage times; the image is the GPU's last frame. Exit 2 without an adapter.
    #[arg(long, requires = "frames")]
    pub gpu: bool,
    /// With --gpu (the papers' extrapolation): pipelined frames — the host poses and refits frame
    /// i + 1 while the device runs frame i; each frame's stages are printed beside its period.
    #[arg(long, requires = "gpu")]
    pub pipelined: bool,
    /// With --gpu (the papers' extrapolation, or sphere sets with the area fit): pose every frame
    /// on the device and refit its BVH there or fit its spheres there (device stages; only the
    /// pose's uniform is uploaded). With --pipelined (the papers' extrapolation): two frames in
    /// flight, each waited for alone.
    #[arg(long, requires = "gpu")]
    pub device_pose: bool,
    /// Run even when the estimated work exceeds 1e10 rays or 8 GiB (docs/limits.md).
    #[arg(long)]
    pub allow_large: bool,
    /// Write a camera render instead of the receiver plane: the scene's `[camera]` (or a default
    /// view) ray-casts the occluders and the plane, the plane shaded with this method's irradiance.
    #[arg(long, conflicts_with = "frames")]
    pub camera: bool,
    /// How the stage times (and the reference's error) are printed; `json` for scripts.
    #[arg(long, value_enum, default_value_t = TextFormat::Text)]
    pub format: TextFormat,
}

#[derive(Args, Debug)]
pub struct ProbeArgs {
    /// A bundled mesh name, an .obj/.ply path, or `sphere` (analytic, closed-form truth).
    #[arg(long)]
    pub mesh: String,
    /// SH order N.
    #[arg(value_parser = whole, long)]
    pub order: usize,
    /// Cone half-angle α in degrees, inside (0, 90).
    #[arg(long)]
    pub alpha_deg: f64,
    /// Base-sphere layout: latlong:RxC, cube:N or fib:P.
    #[arg(long, default_value = "latlong:12x20")]
    pub layout: String,
    /// Rays per hemisphere H×H for the BSV.
    #[arg(value_parser = whole, long, default_value_t = 32)]
    pub hemisphere_res: usize,
    /// Resolution T of the converged ray-traced truth (4T² rays per probe, its own error reported).
    #[arg(value_parser = whole, long, default_value_t = shscale_field::truth::DEFAULT_TRUTH_RES)]
    pub truth_res: usize,
    /// Probe directions: random (seeded, between the samples) or samples (on them).
    #[arg(long, default_value = "random")]
    pub probe_dirs: String,
    /// Sampling sphere radius as a multiple of the bounding radius (≥ 1; > 1 mitigates on-surface samples).
    #[arg(long, default_value_t = 1.0)]
    pub sampling_radius: f64,
    /// Probe radii as multiples of the bounding radius, comma-separated [default: the papers'
    /// Fig. 5 radii, 0.5,0.7,0.9,1.3,2].
    #[arg(long)]
    pub radii: Option<String>,
    /// Number of tabulated k values (exponential spacing over the probed k range).
    #[arg(value_parser = whole, long, default_value_t = 40)]
    pub k_count: usize,
    /// On-surface threshold ε: a sample closer than ε·r to the surface is flagged.
    #[arg(long, default_value_t = 1e-3)]
    pub on_surface_eps: f64,
    #[arg(long, value_enum, default_value_t = Format::Json)]
    pub format: Format,
    /// Run even when the estimated work exceeds 1e10 rays or 8 GiB (docs/limits.md).
    #[arg(long)]
    pub allow_large: bool,
}

#[derive(Args, Debug)]
pub struct InspectArgs {
    /// A bundled mesh name (bunny, duck, dragon_19k, knot, teapot), an .obj/.ply path, or `sphere`.
    pub mesh: String,
    #[arg(long, value_enum, default_value_t = Format::Json)]
    pub format: Format,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SphereCombine {
    Product,
    Union,
    Shexp,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SphereFitArg {
    Area,
    Inscribed,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartCombine {
    Product,
    Shexp,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quadrature {
    Stratified,
    Gauss,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameArg {
    Entity,
    Local,
}

#[derive(Args, Debug)]
pub struct VisibilityArgs {
    /// A bundled mesh name, an .obj/.ply path, or `sphere` (the analytic unit sphere at the origin).
    #[arg(long)]
    pub mesh: String,
    /// The point X,Y,Z.
    #[arg(long, allow_hyphen_values = true)]
    pub point: String,
    /// SH order N.
    #[arg(value_parser = whole, long)]
    pub order: usize,
    /// Quadrature: `stratified` (the converged truth, 4T² rays, with its error estimate) or
    /// `gauss` (the method's Gauss–Legendre rings, 2H² rays, no error estimate).
    #[arg(long, value_enum, default_value_t = Quadrature::Stratified)]
    pub quadrature: Quadrature,
    /// Resolution T of the stratified quadrature (4T² rays).
    #[arg(value_parser = whole, long, default_value_t = shscale_field::truth::DEFAULT_TRUTH_RES)]
    pub truth_res: usize,
    /// Seed of the stratified quadrature's rotations and jitter.
    #[arg(long, default_value_t = shscale_field::truth::DEFAULT_TRUTH_SEED)]
    pub seed: u64,
    /// Rays per hemisphere H×H of the gauss quadrature (the full sphere uses 2H²).
    #[arg(value_parser = whole, long, default_value_t = 32)]
    pub hemisphere_res: usize,
    /// Frame of the coefficients: the mesh's own axes, or z toward the bounding-sphere centre.
    #[arg(long, value_enum, default_value_t = FrameArg::Entity)]
    pub frame: FrameArg,
    #[arg(long, value_enum, default_value_t = Format::Json)]
    pub format: Format,
}

/// Output formats of the inspection commands.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Json,
    Csv,
    Pretty,
}

#[derive(Subcommand, Debug)]
pub enum ShCommand {
    /// The N² basis values at a direction (normalised first).
    /// Example: shscale sh eval --order 3 --dir 1,1,0 --format csv
    Eval {
        /// SH order N (bands 0..N-1).
        #[arg(value_parser = whole, long)]
        order: usize,
        /// Direction X,Y,Z (any non-zero length).
        #[arg(long, allow_hyphen_values = true)]
        dir: String,
        #[arg(long, value_enum, default_value_t = Format::Json)]
        format: Format,
    },
    /// Analytic coefficients of the cap θ ≤ A about +z.
    /// Example: shscale sh cap --order 4 --angle-deg 30
    Cap {
        #[arg(value_parser = whole, long)]
        order: usize,
        /// Cap half-angle A in degrees, 0..=180.
        #[arg(long, allow_hyphen_values = true)]
        angle_deg: f64,
        #[arg(long, value_enum, default_value_t = Format::Json)]
        format: Format,
    },
    /// Coefficients of the function rotated by R = Rz(A)·Ry(B)·Rz(C): g(ω) = f(R⁻¹ω).
    /// Example: shscale sh rotate --order 2 --coeffs 1,0,1,0 --euler-zyz-deg 0,90,0
    Rotate {
        #[arg(value_parser = whole, long)]
        order: usize,
        /// N² coefficients c0,c1,… in index order l·l+l+m.
        #[arg(long, allow_hyphen_values = true)]
        coeffs: String,
        /// Euler angles A,B,C in degrees.
        #[arg(long, allow_hyphen_values = true)]
        euler_zyz_deg: String,
        #[arg(long, value_enum, default_value_t = Format::Json)]
        format: Format,
    },
}

/// Angular scaling families.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum TauArg {
    Cone,
    Midrange,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpacingArg {
    Exp,
    Uniform,
    Chebyshev,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum InterpArg {
    Linear,
    Cubic,
}

#[derive(Args, Debug)]
pub struct MatrixArgs {
    /// SH order N (1..=32 for this command).
    #[arg(value_parser = whole, long)]
    pub order: usize,
    /// Angular scaling family.
    #[arg(long, value_enum)]
    pub tau: TauArg,
    /// Cone half-angle α in degrees, strictly inside (0, 90). Required for --tau cone.
    #[arg(long, allow_hyphen_values = true)]
    pub alpha_deg: Option<f64>,
    /// Scale k: d/r > 0 for the cone, d/R in (-1, 1) for mid-range.
    #[arg(long, allow_hyphen_values = true)]
    pub k: Option<f64>,
    /// Energy-preserving η = sin τ · τ′ (radiance) instead of η = sin θ (visibility).
    #[arg(long)]
    pub energy: bool,
    /// Build a k-table with this many samples instead of printing one matrix.
    #[arg(value_parser = whole, long, value_name = "K_COUNT")]
    pub table: Option<usize>,
    /// Table range KMIN,KMAX.
    #[arg(long, allow_hyphen_values = true)]
    pub k_range: Option<String>,
    #[arg(long, value_enum, default_value_t = SpacingArg::Exp)]
    pub spacing: SpacingArg,
    #[arg(long, value_enum, default_value_t = InterpArg::Linear)]
    pub interp: InterpArg,
    #[arg(long, value_enum, default_value_t = Format::Json)]
    pub format: Format,
}

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Largest SH order of the convergence table.
    #[arg(value_parser = whole, long, default_value_t = 16)]
    pub order: usize,
    /// Cone half-angle α in degrees.
    #[arg(long, default_value_t = 45.0)]
    pub alpha_deg: f64,
    /// `json`: the tables and checks as one JSON object.
    #[arg(long, value_enum, default_value_t = TextFormat::Text)]
    pub format: TextFormat,
}

/// Small helpers on [`Format`].
pub trait FormatArgsExt {
    fn is_json(&self) -> bool;
}

impl FormatArgsExt for Format {
    fn is_json(&self) -> bool {
        *self == Format::Json
    }
}

/// Parse `a,b,c,…` into numbers; the error names the flag and the bad item.
pub fn parse_list(flag: &str, s: &str) -> anyhow::Result<Vec<f64>> {
    s.split(',')
        .enumerate()
        .map(|(i, t)| {
            t.trim().parse::<f64>().map_err(|_| {
                anyhow::anyhow!("--{flag}: item {} ({:?}) is not a number", i + 1, t.trim())
            })
        })
        .collect()
}

/// A whole number ≥ 0 (counts, orders, resolutions): negative values are read as values (the
/// parser allows negative numbers) and refused naming the flag and the value.
pub fn whole(s: &str) -> Result<usize, String> {
    let t = s.trim();
    t.parse::<usize>().map_err(|_| {
        if t.starts_with('-') {
            format!("{t} is negative: a whole number ≥ 0 is expected")
        } else {
            format!("{t:?} is not a whole number ≥ 0")
        }
    })
}
