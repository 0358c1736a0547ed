//! `sweep check`: validate a scene, and measure the constants of assumptions A0–A5 on it.

use crate::stdout::{errln, out, outln};
use anyhow::{Context, Result};
use sweeping::assumptions::{estimate_problem, samples_from_trajectory, EstimateSettings};
use sweeping::backends::{make_projector, make_projector_with, ProjectorOptions};
use sweeping::output::{check_format, csv_interval_note, TrajectoryFormat};
use sweeping::scene::{BuiltScene, Overrides, Scene};
use sweeping::stepper::Stepper;

/// Arguments of `sweep check`.
#[derive(clap::Args)]
pub struct CheckArgs {
    /// The scene file.
    pub scene: std::path::PathBuf,
    /// Also sample the assumptions along the first SECONDS of a run of the scene (contacts
    /// form only once people move); 0 samples the initial configuration alone.
    #[arg(long, default_value_t = 2.0, value_name = "SECONDS")]
    pub sample_run: f64,
    /// Keep every this many steps of the sampling run as a sample.
    #[arg(long, default_value_t = 10)]
    pub sample_every: usize,
    /// ρ of assumption A5 (constraints with gᵢ ≤ ρ count as near-active).
    #[arg(long, default_value_t = EstimateSettings::default().rho)]
    pub rho: f64,
    /// Write the full report as JSON to this file.
    #[arg(long)]
    pub json: Option<std::path::PathBuf>,
    /// Only validate the scene; skip the assumption constants.
    #[arg(long)]
    pub no_constants: bool,
    /// Override a scene field, as `sweep run --set` does (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<sweeping::scene::SetOverride>,
}

/// Entry point of `sweep check`: parses and builds the scene (placing random people, solving
/// the geodesic field), prints what it contains and which effects are active, then the
/// constants of A0–A5 measured on the initial configuration and along a short run, with the
/// paper's derived constants and a verdict.
pub fn main(args: CheckArgs) -> Result<()> {
    // Validated before anything is built: NaN, negative or absurd horizons are refused.
    if !(args.sample_run.is_finite() && args.sample_run >= 0.0 && args.sample_run <= 1e6) {
        anyhow::bail!(
            "--sample-run {} must be a number of seconds in [0, 1e6]",
            args.sample_run
        );
    }
    let scene = Scene::from_file_with(&args.scene, &args.sets)?;
    let built = scene
        .build(&Overrides::default())
        .map_err(|e| crate::run::with_sets(e.into(), &args.sets))?;
    refuse_as_run_would(&args.scene, &built)?;
    out!("{}", built.describe());
    outln!("ok: {} is a valid scene", args.scene.display());
    if args.no_constants {
        return Ok(());
    }

    let mut samples = vec![(built.problem.t0(), built.problem.q0().to_vec())];
    let mut sampling_failure = None;
    let mut projector = make_projector(built.backend).map_err(anyhow::Error::msg)?;
    let horizon = args
        .sample_run
        .min(built.settings.t_end - built.problem.t0());
    if horizon > 0.0 {
        let mut settings = built.settings.clone();
        settings.t_end = built.problem.t0() + horizon;
        settings.record_every = args.sample_every.max(1);
        match Stepper::new(&built.problem, settings)?.run(projector.as_mut(), &mut []) {
            Ok(run) => samples = samples_from_trajectory(&run.trajectory),
            Err(failure) => {
                // What was computed before the failure is still worth measuring (the failure
                // is often an assumption failing), and the failure is part of the verdict.
                errln!("the sampling run failed: {failure}");
                samples = samples_from_trajectory(&failure.partial.trajectory);
                sampling_failure = Some(failure.to_string());
            }
        }
    }
    // The samples are measured one by one, each from its own configuration: departures
    // latched at the end of the sampling run must not hide people at earlier samples.
    built.population.reset_departures();
    let settings = EstimateSettings {
        rho: args.rho,
        ..Default::default()
    };
    let report = estimate_problem(&built.problem, &samples, &settings, projector.as_mut())
        .context("estimating the assumption constants")?;
    outln!();
    outln!(
        "assumptions A0–A5 measured on {} configuration(s) (t ≤ {}):",
        samples.len(),
        samples.last().map(|s| s.0).unwrap_or(0.0)
    );
    out!("{}", report.table());
    if let Some(path) = &args.json {
        std::fs::write(path, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("writing {}", path.display()))?;
        outln!("report written to {}", path.display());
    }
    if let Some(f) = sampling_failure {
        anyhow::bail!("verdict: the sampling run failed ({f}); constants above are from before it");
    }
    if report.failures.is_empty() {
        outln!("verdict: no assumption failed on these samples");
        Ok(())
    } else {
        // A failed assumption is a failed check: the exit status says so (scripts rely on it).
        anyhow::bail!(
            "verdict: {} assumption failure(s) on these samples (see above)",
            report.failures.len()
        )
    }
}

/// What `sweep run` refuses once the scene is built (a backend or a trajectory format this
/// build lacks, SQLite frames that are not a whole number of steps apart), refused here too,
/// and what it adjusts, told: a valid scene is one that runs as written.
fn refuse_as_run_would(path: &std::path::Path, built: &BuiltScene) -> Result<()> {
    let options = ProjectorOptions {
        threads: built.threads,
        ..ProjectorOptions::default()
    };
    make_projector_with(built.backend, options).map_err(anyhow::Error::msg)?;
    let (every, h) = (built.output.trajectory_every, built.settings.h);
    for &format in &built.output.formats {
        check_format(format, every, h)
            .with_context(|| format!("{} (--format {format})", path.display()))?;
    }
    for note in &built.output.notes {
        errln!("note: {note}");
    }
    if built.output.formats.contains(&TrajectoryFormat::Csv) {
        if let Some(note) = csv_interval_note(every, h) {
            errln!("note: {note}");
        }
    }
    Ok(())
}
