//! The `shscale` binary: glue between the command line and the numerical crates.
//!
//! Every failure prints one line `error: …` on stderr and exits with status 2; nothing panics on
//! user input.

mod args;
mod bench_cmd;
mod demo;
mod geometry_cmd;
mod matrix_cmd;
mod output;
mod probe_cmd;
mod render_cmd;
mod run_cmd;
mod sh_cmd;

use args::{Cli, Command};
use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                let _ = e.print();
                return ExitCode::SUCCESS;
            }
            if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                let _ = e.print();
                return ExitCode::from(2);
            }
            // One line: clap's first line, which names the argument and the problem.
            let text = e.render().to_string();
            let line = text
                .lines()
                .find(|l| !l.trim().is_empty())
                .unwrap_or("invalid arguments");
            eprintln!("{}", line.trim());
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
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
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            let msg = format!("{e:#}").replace('\n', " ");
            eprintln!("error: {msg}");
            ExitCode::from(2)
        }
    }
}
