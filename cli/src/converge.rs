//! `sweep converge`: the paper's convergence experiment on a scene (error against `h` and the
//! fitted order), or the true error on the built-in exact solutions.

use crate::scene_loader::load_scene;
use crate::stdout::{errln, outln};
use anyhow::Context;
use std::path::{Path, PathBuf};
use sweeping::backends::{make_projector_with, BackendChoice, ProjectorOptions};
use sweeping::prelude::*;
use sweeping::study::exact::{self, ExactCase};
use sweeping::study::{converge, BoxError, ConvergenceReport, ConvergenceSettings, PAPER_HS};

/// Arguments of `sweep converge`.
#[derive(clap::Args)]
pub struct ConvergeArgs {
    /// The scene file.
    #[arg(required_unless_present = "exact")]
    pub scene: Option<PathBuf>,
    /// Instead of a scene: the true error on a built-in exact solution (`two-disks`,
    /// `moving-wall`, `around-disk`, `play`, `inside-disk`, `masses-wall`, `on-circle`, or
    /// `all`).
    #[arg(long, conflicts_with = "scene")]
    pub exact: Option<String>,
    /// Step of the reference run.
    #[arg(long, default_value_t = 0.01)]
    pub h_min: f64,
    /// Steps compared with the reference (comma-separated). Default: the paper's list
    /// (0.02, 0.025, 0.04, 0.05, 0.0625, 0.08, 0.1, 0.2, 0.5); for exact solutions
    /// 0.005, 0.01, 0.02, 0.04, 0.08, 0.16.
    #[arg(long, value_delimiter = ',')]
    pub hs: Option<Vec<f64>>,
    /// Horizon T (default: the scene's).
    #[arg(long)]
    pub t_end: Option<f64>,
    /// A short horizon also fitted (default 2 s when T > 2; 0 for none).
    #[arg(long)]
    pub short: Option<f64>,
    /// Comparison times per horizon.
    #[arg(long, default_value_t = 10)]
    pub samples: usize,
    /// Backend (default: the scene's; `reference` for exact solutions).
    #[arg(long)]
    pub backend: Option<BackendChoice>,
    /// Output folder (default `out/converge-<scene or case>`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run one step size after another instead of in parallel.
    #[arg(long)]
    pub serial: bool,
}

fn projector_factory(
    backend: BackendChoice,
) -> impl Fn() -> Result<Box<dyn Projector>, BoxError> + Sync {
    // On the run's own thread: its CPU time, measured there, is then all of its work.
    let options = ProjectorOptions {
        threads: 1,
        ..ProjectorOptions::default()
    };
    move || make_projector_with(backend, options).map_err(Into::into)
}

fn write_outputs(report: &ConvergenceReport, out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    report.write_csv(&out.join("convergence.csv"))?;
    report.write_times_csv(&out.join("convergence_times.csv"))?;
    report.plot(&out.join("convergence.svg"))?;
    let json = serde_json::to_string_pretty(report)?;
    std::fs::write(out.join("convergence.json"), json)
        .with_context(|| format!("writing {}", out.join("convergence.json").display()))?;
    outln!("{}", report.summary());
    let per_time = report.order_at_times();
    if !per_time.is_empty() && report.reference.is_some() {
        outln!("fitted order of |q_ref(tᵢ) − qⁿ(tᵢ)| at each comparison time:");
        for (t, fit) in per_time {
            match fit {
                Some(f) => outln!("  t = {t:>8.3}: {}", f.describe()),
                None => outln!("  t = {t:>8.3}: -"),
            }
        }
    }
    outln!(
        "wrote {}/convergence.csv, convergence_times.csv, convergence.svg, convergence.json",
        out.display()
    );
    Ok(())
}

fn run_exact(args: &ConvergeArgs, which: &str) -> anyhow::Result<()> {
    let cases: Vec<Box<dyn ExactCase>> = match which {
        "all" => exact::standard_cases(),
        "two-disks" => vec![Box::new(exact::TwoDisksOnALine::default())],
        "moving-wall" => vec![Box::new(exact::PointBehindMovingWall::default())],
        "around-disk" => vec![Box::new(exact::PointAroundDisk::default())],
        "play" => vec![Box::new(exact::PlayOperator::default())],
        "inside-disk" => vec![Box::new(exact::PointInsideMovingDisk::default())],
        "masses-wall" => vec![Box::new(exact::MassesAgainstMovingWall::default())],
        "on-circle" => vec![Box::new(exact::PointOnMovingCircle::default())],
        other => anyhow::bail!(
            "unknown exact case `{other}` (expected two-disks, moving-wall, around-disk, \
             play, inside-disk, masses-wall, on-circle or all)"
        ),
    };
    let hs = args
        .hs
        .clone()
        .unwrap_or_else(|| vec![0.005, 0.01, 0.02, 0.04, 0.08, 0.16]);
    let backend = args.backend.unwrap_or(BackendChoice::Reference);
    let factory = projector_factory(backend);
    for case in cases {
        let report = exact::true_error_study(
            case.as_ref(),
            &hs,
            args.samples,
            &factory,
            &StepperSettings::default(),
            !args.serial,
        )
        .with_context(|| format!("true-error study of `{}`", case.name()))?;
        let out = args
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from("out"))
            .join(format!("exact-{}", case.name()));
        write_outputs(&report, &out)?;
    }
    Ok(())
}

/// Entry point of `sweep converge`.
pub fn main(args: ConvergeArgs) -> anyhow::Result<()> {
    if let Some(which) = args.exact.clone() {
        return run_exact(&args, &which);
    }
    let Some(scene) = args.scene.clone() else {
        anyhow::bail!("give a scene file or --exact CASE");
    };
    let first = load_scene(&scene, Some(args.h_min), args.t_end)?;
    let t_end = args.t_end.unwrap_or(first.settings.t_end);
    let backend = args.backend.unwrap_or(first.backend);
    let base = first.settings.clone();
    let t0 = first.problem.t0();
    let t_short = match args.short {
        Some(s) if s <= 0.0 => None,
        Some(s) => Some(s),
        None => (t_end - t0 > 2.0).then_some(t0 + 2.0),
    };
    let settings = ConvergenceSettings {
        h_min: args.h_min,
        hs: args.hs.clone().unwrap_or_else(|| PAPER_HS.to_vec()),
        t_end,
        t_short,
        samples: args.samples,
        parallel: !args.serial,
    };
    // Each run loads its own copy of the scene (runs go in parallel).
    let make_problem = || -> Result<Problem, BoxError> {
        Ok(load_scene(&scene, Some(args.h_min), Some(t_end))?.problem)
    };
    let label = format!(
        "{} ({backend}, T = {t_end})",
        scene.file_stem().unwrap_or_default().to_string_lossy()
    );
    errln!(
        "{label}: reference h = {} and {} step sizes{}",
        settings.h_min,
        settings.hs.len(),
        if settings.parallel {
            ", in parallel"
        } else {
            ""
        }
    );
    let report = converge(
        &label,
        &make_problem,
        &projector_factory(backend),
        &base,
        &settings,
    )?;
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from("out").join(format!(
            "converge-{}",
            scene.file_stem().unwrap_or_default().to_string_lossy()
        ))
    });
    write_outputs(&report, &out)
}
