//! The `shscale` binary: glue between the command line and the numerical crates.
//!
//! Every failure prints one line `error: …` on stderr and exits with status 2; nothing panics on
//! user input.

mod args;
mod bench_cmd;
mod demo;
mod flags;
mod geometry_cmd;
mod interrupt;
mod matrix_cmd;
mod output;
mod probe_cmd;
mod render_cmd;
mod run_cmd;
mod sh_cmd;

use args::{Cli, Command};
use std::process::ExitCode;

/// Mesa's software Vulkan device prints `XDG_RUNTIME_DIR is invalid or not set` on every adapter
/// request when the variable is unset; give it a private directory (mode 0700) first. Runs
/// before any thread exists, so setting the environment is sound.
fn quiet_mesa() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    let dir = std::env::temp_dir().join("shscale-xdg-runtime");
    if std::fs::create_dir_all(&dir).is_ok() {
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
        }
        // SAFETY (edition 2021: a safe fn): single-threaded at this point.
        std::env::set_var("XDG_RUNTIME_DIR", &dir);
    }
}

fn main() -> ExitCode {
    // A closed pipe (`shscale demo | head`) ends the process quietly, as it does any Unix
    // tool, instead of a panic in println!.
    #[cfg(unix)]
    // SAFETY: resetting a signal's disposition to the default before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    quiet_mesa();
    // A long inscribed fit (seconds to minutes) says how far it is, on every path to it.
    shscale_geometry::inscribed::set_progress(|line| eprintln!("progress: {line}"));
    // The kernels' instruction set is chosen from SHSCALE_SIMD once; a value the library would
    // silently read as `portable` is refused here.
    if let Err(e) = shscale_sh::simd::parse_setting(std::env::var("SHSCALE_SIMD").ok().as_deref()) {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    // Negative numbers are values (`--order -1`, `--radii -1`), refused by the flag's own check.
    fn negatives(c: clap::Command) -> clap::Command {
        c.allow_negative_numbers(true).mut_subcommands(negatives)
    }
    let parsed = negatives(<Cli as clap::CommandFactory>::command())
        .try_get_matches()
        .and_then(|m| <Cli as clap::FromArgMatches>::from_arg_matches(&m));
    let cli = match parsed {
        Ok(c) => c,
        Err(e) => return clap_failure(e),
    };
    let result = dispatch(cli.command);
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", terminal_safe(&format!("{e:#}")));
            ExitCode::from(2)
        }
    }
}

/// An error message as one terminal line: a newline as a space, every other control character
/// (ESC, BEL, CR — from a file name or a cell of a shared results directory) as its escape, so
/// none reaches the terminal raw.
fn terminal_safe(msg: &str) -> String {
    msg.chars()
        .map(|c| match c {
            '\n' => " ".to_string(),
            c if c.is_control() => c.escape_unicode().to_string(),
            c => c.to_string(),
        })
        .collect()
}

/// Help and version on stdout (exit 0); a missing subcommand's help (exit 2); any other
/// argument error as one line with all of clap's message (the arguments it names, its
/// suggestions), without the usage block and the pointer to --help (exit 2).
fn clap_failure(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
        let _ = e.print();
        return ExitCode::SUCCESS;
    }
    if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
        let _ = e.print();
        return ExitCode::from(2);
    }
    let text = e.render().to_string();
    let mut parts = Vec::new();
    for l in text.lines().map(str::trim) {
        if l.is_empty() || l.starts_with("For more information") {
            continue;
        }
        if l.starts_with("Usage:") {
            break;
        }
        parts.push(l);
    }
    let line = parts.join(" ");
    eprintln!(
        "{}",
        if line.is_empty() {
            "error: invalid arguments"
        } else {
            &line
        }
    );
    ExitCode::from(2)
}

/// Run one command.
fn dispatch(command: Command) -> anyhow::Result<ExitCode> {
    match command {
        Command::Sh(cmd) => sh_cmd::run(cmd),
        Command::Matrix(cmd) => matrix_cmd::run(cmd),
        Command::Demo(cmd) => demo::run(cmd),
        Command::Inspect(cmd) => geometry_cmd::inspect(cmd),
        Command::Visibility(cmd) => geometry_cmd::visibility(cmd),
        Command::Probe(cmd) => probe_cmd::run(cmd),
        Command::Render(cmd) => render_cmd::run(cmd),
        Command::Run(cmd) => run_cmd::run(cmd),
        Command::Merge(cmd) => run_cmd::merge(cmd),
        Command::Slurm(cmd) => run_cmd::slurm(cmd),
        Command::Bench(cmd) => bench_cmd::run(cmd),
        Command::Figs(cmd) => bench_cmd::figs(cmd),
        Command::Report { dir } => run_cmd::report(&dir),
        Command::Compare { a, b, out, format } => {
            run_cmd::compare(&a, &b, out.as_deref(), format == args::TextFormat::Json)
        }
        Command::Plot(a) => run_cmd::plot(a),
        Command::ConfigReference => {
            print!(
                "{}",
                shscale_runner::reference::markdown(
                    &shscale_experiments::registry(),
                    shscale_scene::scene::SCENE_KEYS,
                )
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Completions { shell } => {
            let mut cmd = <Cli as clap::CommandFactory>::command();
            clap_complete::generate(shell, &mut cmd, "shscale", &mut std::io::stdout());
            Ok(ExitCode::SUCCESS)
        }
    }
}
