//! `sweep bench`: milliseconds per step, by stage, on synthetic crowds of growing size.

use crate::stdout::{out, outln};
use anyhow::{Context, Result};
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;
use sweeping::backends::{make_projector, make_projector_with, BackendChoice, ProjectorOptions};
use sweeping::crowd::synthetic::{Start, SyntheticCrowd};
use sweeping::stepper::{StageTimes, Stepper, StepperSettings};
use sweeping::study::peak_memory_bytes;

/// Arguments of `sweep bench`.
#[derive(clap::Args)]
pub struct BenchArgs {
    /// Crowd sizes.
    #[arg(long, value_delimiter = ',', default_value = "150,1000,5000")]
    pub n: Vec<usize>,
    /// Starts: `spread` (the paper's density, h = 0.01) and/or `jammed` (twice it, everybody
    /// walking to the centre, h = 0.1).
    #[arg(long, value_delimiter = ',', default_value = "spread,jammed")]
    pub start: Vec<Start>,
    /// Backends (default: every compiled one but `reference` and `cross`).
    #[arg(long, value_delimiter = ',')]
    pub backends: Vec<BackendChoice>,
    /// Steps per configuration.
    #[arg(long, default_value_t = 20)]
    pub steps: usize,
    /// Stop a configuration after this many seconds of stepping (at least one step is taken).
    #[arg(long, default_value_t = 60.0)]
    pub budget: f64,
    /// Seed of the placements.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Most threads a projection runs on (0: as many as the cores). The native backend uses
    /// more than one, and a cross-check with two or more runs its two backends at once.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Also write the table as CSV.
    #[arg(long)]
    pub csv: Option<PathBuf>,
}

/// One measured configuration.
struct Row {
    start: Start,
    n: usize,
    backend: String,
    steps: usize,
    times: StageTimes,
    rows: usize,
    active: usize,
    solves: usize,
    peak_mib: Option<f64>,
    failure: Option<String>,
}

fn default_backends() -> Vec<BackendChoice> {
    BackendChoice::ALL
        .iter()
        .copied()
        .filter(|b| {
            !matches!(
                b,
                BackendChoice::Reference | BackendChoice::Cross | BackendChoice::CrossNative
            )
        })
        .filter(|b| make_projector(*b).is_ok())
        .collect()
}

fn measure(crowd: SyntheticCrowd, backend: BackendChoice, args: &BenchArgs) -> Result<Row> {
    let h = match crowd.start {
        Start::Spread => 0.01,
        Start::Jammed => 0.1,
    };
    let problem = crowd
        .problem()
        .with_context(|| format!("building the {} crowd of {}", crowd.start, crowd.n))?;
    let mut projector = make_projector_with(
        backend,
        ProjectorOptions {
            threads: args.threads,
            ..ProjectorOptions::default()
        },
    )
    .map_err(anyhow::Error::msg)?;
    let settings = StepperSettings {
        h,
        t_end: args.steps as f64 * h,
        ..Default::default()
    };
    let mut stepper = Stepper::new(&problem, settings)?;
    let mut row = Row {
        start: crowd.start,
        n: crowd.n,
        backend: backend.to_string(),
        steps: 0,
        times: StageTimes::default(),
        rows: 0,
        active: 0,
        solves: 0,
        peak_mib: None,
        failure: None,
    };
    let began = Instant::now();
    while row.steps < args.steps && (row.steps == 0 || began.elapsed().as_secs_f64() < args.budget)
    {
        match stepper.step(projector.as_mut()) {
            Ok(r) => {
                row.steps += 1;
                row.times.add(&r.times);
                row.rows += r.rows;
                row.active += r.active;
                row.solves += r.solves;
            }
            Err(e) => {
                row.failure = Some(e.to_string());
                break;
            }
        }
    }
    row.peak_mib = peak_memory_bytes().map(|b| b as f64 / (1024.0 * 1024.0));
    Ok(row)
}

pub fn main(mut args: BenchArgs) -> Result<()> {
    if args.backends.is_empty() {
        args.backends = default_backends();
    }
    if args.steps == 0 {
        anyhow::bail!("--steps must be at least 1");
    }
    if args.n.contains(&0) {
        anyhow::bail!("--n: every crowd size must be at least 1, got {:?}", args.n);
    }
    if !(args.budget.is_finite() && args.budget > 0.0) {
        anyhow::bail!("--budget must be a positive number of seconds");
    }
    let header = format!(
        "{:<7} {:>7} {:<9} {:>5} {:>9} {:>9} {:>9} {:>10} {:>9} {:>9} {:>7} {:>6} {:>8}",
        "start",
        "N",
        "backend",
        "steps",
        "effects",
        "broad",
        "assembly",
        "projection",
        "check",
        "total",
        "rows",
        "active",
        "peak MiB"
    );
    outln!("ms per step (mean), by stage; rows and active constraints per step (mean)");
    outln!("{header}");
    // The CSV is created before the first measurement (a path that cannot be written fails
    // now, not after minutes of benching) and each row is written as it is measured, so an
    // interrupted or failed bench keeps the rows it finished.
    let mut csv = match &args.csv {
        Some(path) => {
            let mut file = std::io::BufWriter::new(
                std::fs::File::create(path)
                    .with_context(|| format!("--csv: creating {}", path.display()))?,
            );
            file.write_all(
                b"start,n,backend,steps,effects_ms,broad_phase_ms,assembly_ms,projection_ms,check_ms,total_ms,rows,active,solves,peak_mib,failure\n",
            )
            .and_then(|()| file.flush())
            .with_context(|| format!("--csv: writing {}", path.display()))?;
            Some((path, file))
        }
        None => None,
    };
    for &start in &args.start {
        for &n in &args.n {
            for &backend in &args.backends {
                let crowd = SyntheticCrowd {
                    n,
                    start,
                    seed: args.seed,
                };
                let row = measure(crowd, backend, &args)?;
                let k = row.steps.max(1) as f64;
                let t = &row.times;
                // effects, broad phase, assembly, projection, check, total: ms per step.
                let ms = [
                    t.effects,
                    t.broad_phase,
                    t.assembly,
                    t.projection,
                    t.check,
                    t.total(),
                ]
                .map(|v| 1e3 * v / k);
                let (rows, active) = (row.rows / row.steps.max(1), row.active / row.steps.max(1));
                let peak = row
                    .peak_mib
                    .map_or_else(|| "—".to_string(), |m| format!("{m:.0}"));
                let failure = row.failure.as_deref().unwrap_or("");
                out!(
                    "{:<7} {:>7} {:<9} {:>5}",
                    row.start.to_string(),
                    row.n,
                    row.backend,
                    row.steps
                );
                for (v, width) in ms.iter().zip([9, 9, 9, 10, 9, 9]) {
                    out!(" {v:>width$.3}");
                }
                out!(" {rows:>7} {active:>6} {peak:>8}");
                if !failure.is_empty() {
                    out!("  failed after {} steps: {failure}", row.steps);
                }
                outln!();
                std::io::stdout().flush().ok();
                if let Some((path, file)) = csv.as_mut() {
                    let ms: Vec<String> = ms.iter().map(f64::to_string).collect();
                    writeln!(
                        file,
                        "{},{},{},{},{},{rows},{active},{},{},{}",
                        row.start,
                        row.n,
                        row.backend,
                        row.steps,
                        ms.join(","),
                        row.solves,
                        row.peak_mib.map(|m| m.to_string()).unwrap_or_default(),
                        failure.replace([',', '\n'], ";")
                    )
                    .and_then(|()| file.flush())
                    .with_context(|| format!("--csv: writing {}", path.display()))?;
                }
            }
        }
    }
    outln!(
        "peak MiB is the process's resident peak so far (VmHWM), so it only grows down the table"
    );
    Ok(())
}
