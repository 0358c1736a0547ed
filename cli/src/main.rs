//! `sweep`: run, check and study sweeping processes and crowd scenes.
// One call into glibc (`heap`) needs `unsafe`; nothing else may use it.
#![deny(unsafe_code)]

use clap::{Parser, Subcommand};

mod batch;
mod bench;
mod check;
mod converge;
mod heap;
mod interrupt;
mod out_dir;
mod resume;
mod run;
mod scene_loader;
mod stdout;
use stdout::errln;
mod work_precision;

/// Perturbed sweeping processes and crowd motion by the Bernicot–Venel scheme.
#[derive(Parser)]
#[command(name = "sweep", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene and write its trajectory, summary, snapshots and animation.
    Run(run::RunArgs),
    /// Validate a scene without running it, and print the constants of assumptions A0–A5.
    Check(check::CheckArgs),
    /// The paper's convergence experiment on a scene: error against h and the fitted order.
    Converge(converge::ConvergeArgs),
    /// Error against CPU time over step × backend × solver tolerance.
    WorkPrecision(work_precision::WorkPrecisionArgs),
    /// Milliseconds per step, by stage, on synthetic crowds of growing size, per backend.
    Bench(bench::BenchArgs),
    /// Run a plan of many trials (scenes × overrides × seeds), one per core, into one
    /// results table; or write it as a Slurm job array.
    Batch(batch::BatchArgs),
}

fn main() {
    // Only speed depends on it: glibc's defaults stand when it is refused.
    let _ = heap::keep_freed_memory();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(a) => run::main(a),
        Command::Check(a) => check::main(a),
        Command::Converge(a) => converge::main(a),
        Command::WorkPrecision(a) => work_precision::main(a),
        Command::Bench(a) => bench::main(a),
        Command::Batch(a) => batch::main(a),
    };
    if let Err(e) = result {
        errln!("error: {e:#}");
        std::process::exit(1);
    }
    // The command's files are written; what it could not print is said here.
    if let Some(e) = stdout::finish() {
        errln!("error: could not write to standard output: {e}");
        std::process::exit(1);
    }
}
