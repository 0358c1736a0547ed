//! `sweep work-precision`: what accuracy costs in time — `e_h` against CPU time over step ×
//! backend × solver tolerance.

use crate::scene_loader::load_scene;
use crate::stdout::outln;
use anyhow::Context;
use std::path::PathBuf;
use sweeping::backends::{make_projector, BackendChoice};
use sweeping::prelude::*;
use sweeping::study::work_precision::{work_precision, SolverSetting, WorkPrecisionSettings};
use sweeping::study::BoxError;

/// Arguments of `sweep work-precision`.
#[derive(clap::Args)]
pub struct WorkPrecisionArgs {
    /// The scene file.
    pub scene: PathBuf,
    /// Step of the reference run.
    #[arg(long, default_value_t = 0.01)]
    pub h_min: f64,
    /// Steps to try (comma-separated).
    #[arg(long, value_delimiter = ',', default_values_t = [0.02, 0.05, 0.1, 0.2])]
    pub hs: Vec<f64>,
    /// Solvers to try, `backend` or `backend@tolerance` (comma-separated). Default: every
    /// compiled backend at its defaults, and OSQP at 1e-3 and 1e-5 when compiled.
    #[arg(long, value_delimiter = ',')]
    pub solvers: Option<Vec<SolverSetting>>,
    /// The reference run's solver (default: the first compiled of clarabel, osqp,
    /// reference).
    #[arg(long)]
    pub reference_solver: Option<SolverSetting>,
    /// Horizon T (default: the scene's).
    #[arg(long)]
    pub t_end: Option<f64>,
    /// Comparison times.
    #[arg(long, default_value_t = 10)]
    pub samples: usize,
    /// Output folder (default `out/work-precision-<scene>`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run one setting after another instead of in parallel.
    #[arg(long)]
    pub serial: bool,
}

/// The compiled backends a study compares by default, the native one (the default backend) first.
fn compiled() -> Vec<BackendChoice> {
    [
        BackendChoice::Native,
        BackendChoice::Clarabel,
        BackendChoice::Osqp,
        BackendChoice::Reference,
    ]
    .into_iter()
    .filter(|b| make_projector(*b).is_ok())
    .collect()
}

/// Entry point of `sweep work-precision`.
pub fn main(args: WorkPrecisionArgs) -> anyhow::Result<()> {
    let first = load_scene(&args.scene, Some(args.h_min), args.t_end)?;
    let t_end = args.t_end.unwrap_or(first.settings.t_end);
    let backends = compiled();
    // By default the reference is an independent solver, not the native backend it measures.
    let independent = backends
        .iter()
        .find(|b| **b != BackendChoice::Native)
        .map(|&backend| SolverSetting {
            backend,
            tolerance: None,
        });
    let Some(reference) = args.reference_solver.or(independent) else {
        anyhow::bail!(
            "work-precision: no backend for the reference run (Clarabel, OSQP and the \
             reference backend are not compiled in); name one with --reference-solver"
        );
    };
    let solvers = args.solvers.clone().unwrap_or_else(|| {
        let mut v: Vec<SolverSetting> = backends
            .iter()
            .filter(|b| **b != BackendChoice::Reference || backends.len() == 1)
            .map(|&backend| SolverSetting {
                backend,
                tolerance: None,
            })
            .collect();
        if backends.contains(&BackendChoice::Osqp) {
            for tol in [1e-3, 1e-5] {
                v.push(SolverSetting {
                    backend: BackendChoice::Osqp,
                    tolerance: Some(tol),
                });
            }
        }
        v
    });
    let settings = WorkPrecisionSettings {
        h_min: args.h_min,
        reference,
        hs: args.hs.clone(),
        solvers,
        t_end,
        samples: args.samples,
        parallel: !args.serial,
    };
    let scene = args.scene.clone();
    let make_problem = || -> Result<Problem, BoxError> {
        Ok(load_scene(&scene, Some(args.h_min), Some(t_end))?.problem)
    };
    let stem = scene
        .file_stem()
        .unwrap_or_default()
        .to_string_lossy()
        .to_string();
    let report = work_precision(
        &format!("{stem} (T = {t_end})"),
        &make_problem,
        &first.settings,
        &settings,
    )?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("work-precision-{stem}")));
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    report.write_csv(&out.join("work_precision.csv"))?;
    report.plot(&out.join("work_precision.svg"))?;
    std::fs::write(
        out.join("work_precision.json"),
        serde_json::to_string_pretty(&report)?,
    )?;
    outln!("{}", report.summary());
    outln!(
        "wrote {}/work_precision.csv, work_precision.svg, work_precision.json",
        out.display()
    );
    Ok(())
}
