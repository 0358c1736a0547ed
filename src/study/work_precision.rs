//! What accuracy costs in time: the error `e_h` of the paper's protocol against CPU time, over
//! step × backend × solver tolerance.
//!
//! Every setting is compared with one reference run (step `h_min`, the tightest solver), so
//! the error mixes the scheme's error (which shrinks with `h`) and the solver's (which
//! shrinks with its tolerance). A setting is *efficient* when no other setting is both
//! faster and more accurate ([`WorkPrecisionReport::pareto`]).

use super::{
    comparison_times, distances, map_runs, max_of, plot, run_sampled, ProblemFactory,
    ReferenceSummary, RunCost, StudyError,
};
use crate::backends::{BackendChoice, BackendError};
use crate::stepper::StepperSettings;
use serde::{Deserialize, Serialize};
use std::path::Path;
use sweeping_api::Projector;

/// A backend and, optionally, the tolerance it is asked for.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SolverSetting {
    /// The backend.
    pub backend: BackendChoice,
    /// Its tolerance; `None` keeps the backend's default (tight) settings.
    pub tolerance: Option<f64>,
}

impl SolverSetting {
    /// A name such as `osqp@1e-3` or `clarabel` (default tolerance).
    pub fn label(&self) -> String {
        match self.tolerance {
            Some(t) => format!("{}@{t:.0e}", self.backend),
            None => self.backend.to_string(),
        }
    }
}

/// The solver tolerances a setting may ask for, inclusive: tighter than the lower bound is
/// below rounding of `f64`, looser than the upper leaves answers that are not solutions.
pub const TOLERANCE_RANGE: (f64, f64) = (1e-14, 1e-1);

impl SolverSetting {
    /// Checks that the tolerance, if any, lies in [`TOLERANCE_RANGE`].
    ///
    /// # Errors
    /// A message naming the setting, its tolerance and the accepted range.
    pub fn validate(&self) -> Result<(), String> {
        let (lo, hi) = TOLERANCE_RANGE;
        match self.tolerance {
            Some(t) if !(t.is_finite() && (lo..=hi).contains(&t)) => Err(format!(
                "the tolerance {t:e} of solver setting `{}` is outside the accepted range \
                 [{lo:e}, {hi:e}]",
                self.label()
            )),
            _ => Ok(()),
        }
    }
}

impl std::str::FromStr for SolverSetting {
    type Err = String;
    /// `backend` or `backend@tolerance`, e.g. `osqp@1e-3`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (name, tol) = match s.split_once('@') {
            Some((n, t)) => (
                n,
                Some(
                    t.parse::<f64>()
                        .map_err(|e| format!("bad tolerance `{t}` in `{s}`: {e}"))?,
                ),
            ),
            None => (s, None),
        };
        if let Some(t) = tol {
            if !(t.is_finite() && t > 0.0) {
                return Err(format!("the tolerance in `{s}` must be positive"));
            }
        }
        let setting = Self {
            backend: name.parse().map_err(|e: BackendError| e.to_string())?,
            tolerance: tol,
        };
        setting.validate()?;
        Ok(setting)
    }
}

/// Builds the projector of a [`SolverSetting`] (see
/// [`make_projector_with`](crate::backends::make_projector_with)), its projections on the
/// calling thread: a run's CPU time is measured on its thread ([`thread_cpu_seconds`]), so
/// that time is then the whole of the run's work. (Runs go in parallel instead.)
///
/// [`thread_cpu_seconds`]: crate::study::thread_cpu_seconds
///
/// # Errors
/// When the backend is not compiled in, or a tolerance is asked of the cross-check.
pub fn projector_for(setting: &SolverSetting) -> Result<Box<dyn Projector>, BackendError> {
    crate::backends::make_projector_with(setting.backend, projector_options(setting))
}

/// What [`projector_for`] builds a setting's backend with: its tolerance, on one thread.
fn projector_options(setting: &SolverSetting) -> crate::backends::ProjectorOptions {
    crate::backends::ProjectorOptions {
        tolerance: setting.tolerance,
        threads: 1,
    }
}

/// Settings of a work–precision study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorkPrecisionSettings {
    /// Step of the reference run.
    pub h_min: f64,
    /// The solver of the reference run (the tightest available).
    pub reference: SolverSetting,
    /// Steps to try.
    pub hs: Vec<f64>,
    /// Solvers to try with each step.
    pub solvers: Vec<SolverSetting>,
    /// Horizon.
    pub t_end: f64,
    /// Comparison times.
    pub samples: usize,
    /// Run in parallel (rayon). CPU time is measured per thread either way.
    pub parallel: bool,
}

/// One setting's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorkPrecisionRow {
    /// Step.
    pub h: f64,
    /// Solver label ([`SolverSetting::label`]).
    pub solver: String,
    /// `e_h` against the reference (NaN when the run failed).
    pub error: f64,
    /// What the run cost ([`RunCost::failed`] when it failed; flattened into the row's JSON).
    #[serde(flatten)]
    pub cost: RunCost,
    /// Why the run failed, if it did.
    pub failure: Option<String>,
    /// The run's answers violate the constraints by more than the problem's own violation
    /// tolerance (a loose solver is judged at its tolerance, so its run can complete with
    /// them): such a row solves another problem and is never efficient.
    #[serde(default)]
    pub infeasible: bool,
}

/// The outcome of [`work_precision`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorkPrecisionReport {
    /// What was studied.
    pub label: String,
    /// The settings.
    pub settings: WorkPrecisionSettings,
    /// The reference run.
    pub reference: ReferenceSummary,
    /// One row per (h, solver), solvers varying fastest.
    pub rows: Vec<WorkPrecisionRow>,
}

/// Errors within this fraction of each other count as equal on the efficient front. Tight
/// solvers move `e_h` in its eighth or ninth digit by their own rounding and tolerance
/// (tight OSQP, whose answers violate rows by up to about `1e-9`, can come out "more
/// accurate" than the native backend by that alone, and so on the front at several times its
/// cost); a loose tolerance moves it by a percent.
pub const ERROR_TIE: f64 = 1e-6;

impl WorkPrecisionReport {
    /// Indices of the efficient rows — no other successful, feasible row is at least as fast
    /// and at least as accurate, and strictly better in one — sorted by CPU time. Errors
    /// within [`ERROR_TIE`] of each other (relative) are equally accurate. Rows flagged
    /// [`infeasible`](WorkPrecisionRow::infeasible) take no part.
    pub fn pareto(&self) -> Vec<usize> {
        let ok: Vec<usize> = (0..self.rows.len())
            .filter(|&i| {
                let r = &self.rows[i];
                r.failure.is_none() && !r.infeasible && r.error.is_finite()
            })
            .collect();
        let mut front: Vec<usize> = ok
            .iter()
            .copied()
            .filter(|&i| {
                let a = &self.rows[i];
                !ok.iter().any(|&j| {
                    let b = &self.rows[j];
                    let tie = ERROR_TIE * a.error.abs().max(b.error.abs());
                    j != i
                        && b.cost.cpu_seconds <= a.cost.cpu_seconds
                        && b.error <= a.error + tie
                        && (b.cost.cpu_seconds < a.cost.cpu_seconds || b.error < a.error - tie)
                })
            })
            .collect();
        front.sort_by(|&a, &b| {
            self.rows[a]
                .cost
                .cpu_seconds
                .total_cmp(&self.rows[b].cost.cpu_seconds)
        });
        front
    }

    /// The cheapest successful, feasible row with `error ≤ target`.
    pub fn cheapest_below(&self, target: f64) -> Option<&WorkPrecisionRow> {
        self.rows
            .iter()
            .filter(|r| r.failure.is_none() && !r.infeasible && r.error <= target)
            .min_by(|a, b| a.cost.cpu_seconds.total_cmp(&b.cost.cpu_seconds))
    }

    /// Writes the table. Columns: `h`, `solver`, `error`, `cpu_seconds`, `wall_seconds`,
    /// `steps`, `iterations`, `max_violation`, `pareto` (1 on the efficient front),
    /// `infeasible` (1 when the answers violate the constraints beyond the problem's
    /// tolerance), `failure` (empty, or the error message in double quotes).
    ///
    /// # Errors
    /// [`StudyError::Io`].
    pub fn write_csv(&self, path: &Path) -> Result<(), StudyError> {
        let front = self.pareto();
        let mut s = String::from(
            "h,solver,error,cpu_seconds,wall_seconds,steps,iterations,max_violation,pareto,infeasible,failure\n",
        );
        for (i, r) in self.rows.iter().enumerate() {
            s.push_str(&format!(
                "{},{},{:.9e},{:.6},{:.6},{},{},{:.3e},{},{},{}\n",
                r.h,
                r.solver,
                r.error,
                r.cost.cpu_seconds,
                r.cost.wall_seconds,
                r.cost.steps,
                r.cost.iterations,
                r.cost.max_violation,
                u8::from(front.contains(&i)),
                u8::from(r.infeasible),
                r.failure
                    .as_deref()
                    .map(|m| format!("\"{}\"", m.replace('"', "'")))
                    .unwrap_or_default()
            ));
        }
        super::write_file(path, &s)
    }

    /// Error against CPU time, log–log, one series per solver (SVG).
    ///
    /// # Errors
    /// [`StudyError::Plot`].
    pub fn plot(&self, path: &Path) -> Result<(), StudyError> {
        let mut labels: Vec<String> = Vec::new();
        for r in &self.rows {
            if !labels.contains(&r.solver) {
                labels.push(r.solver.clone());
            }
        }
        let series: Vec<plot::Series> = labels
            .iter()
            .map(|l| plot::Series {
                label: l.clone(),
                points: self
                    .rows
                    .iter()
                    .filter(|r| &r.solver == l && r.failure.is_none())
                    .map(|r| (r.cost.cpu_seconds, r.error))
                    .collect(),
                fit: None,
            })
            .collect();
        plot::log_log(
            path,
            &format!("Work–precision: {}", self.label),
            "CPU seconds",
            "e_h",
            &series,
            None,
        )
    }

    /// A table sorted by `h` then solver, with the efficient front marked, and the cheapest
    /// setting reaching each decade of error.
    pub fn summary(&self) -> String {
        let front = self.pareto();
        let mut s = format!(
            "{}\nreference: h = {}, {}: {} steps, {:.2} s CPU\n{:>8} {:>16} {:>12} {:>10} {:>8} {:>10}\n",
            self.label,
            self.reference.h,
            self.settings.reference.label(),
            self.reference.steps,
            self.reference.cpu_seconds,
            "h",
            "solver",
            "e_h",
            "cpu [s]",
            "steps",
            "efficient"
        );
        for (i, r) in self.rows.iter().enumerate() {
            match &r.failure {
                None => s.push_str(&format!(
                    "{:>8} {:>16} {:12.4e} {:10.3} {:>8} {:>10}\n",
                    r.h,
                    r.solver,
                    r.error,
                    r.cost.cpu_seconds,
                    r.cost.steps,
                    if front.contains(&i) {
                        "*".to_string()
                    } else if r.infeasible {
                        format!("infeasible (violation {:.1e})", r.cost.max_violation)
                    } else {
                        String::new()
                    }
                )),
                Some(m) => s.push_str(&format!("{:>8} {:>16} failed: {m}\n", r.h, r.solver)),
            }
        }
        s.push_str("efficient front (fastest first):\n");
        for &i in &front {
            let r = &self.rows[i];
            s.push_str(&format!(
                "  h = {:<7} {:<16} e_h = {:.3e} in {:.3} s\n",
                r.h, r.solver, r.error, r.cost.cpu_seconds
            ));
        }
        let finite: Vec<f64> = self
            .rows
            .iter()
            .filter(|r| r.failure.is_none() && !r.infeasible && r.error > 0.0)
            .map(|r| r.error)
            .collect();
        if let (Some(lo), Some(hi)) = (
            finite.iter().copied().reduce(f64::min),
            finite.iter().copied().reduce(f64::max),
        ) {
            let mut decade = 10f64.powf(hi.log10().ceil());
            while decade >= lo {
                if let Some(r) = self.cheapest_below(decade) {
                    s.push_str(&format!(
                        "cheapest with e_h ≤ {decade:.0e}: h = {}, {} ({:.3} s)\n",
                        r.h, r.solver, r.cost.cpu_seconds
                    ));
                }
                decade /= 10.0;
            }
        }
        s
    }
}

/// Runs the reference and every (h, solver) setting, and measures `e_h` and CPU time.
///
/// A setting whose run fails is recorded with its message (loose tolerances may fail on
/// jammed crowds); the study fails only when the reference does.
///
/// # Errors
/// [`StudyError::InvalidInput`] for bad settings; the reference run's error.
pub fn work_precision(
    label: &str,
    make_problem: &ProblemFactory<'_>,
    base: &StepperSettings,
    settings: &WorkPrecisionSettings,
) -> Result<WorkPrecisionReport, StudyError> {
    let t0 = make_problem()
        .map_err(|source| StudyError::Setup {
            h: settings.h_min,
            source,
        })?
        .t0();
    if settings.hs.is_empty() || settings.solvers.is_empty() {
        return Err(StudyError::InvalidInput(
            "a work–precision study needs at least one step and one solver".into(),
        ));
    }
    if let Some(h) = std::iter::once(&settings.h_min)
        .chain(&settings.hs)
        .find(|h| !(h.is_finite() && **h > 0.0))
    {
        return Err(StudyError::InvalidInput(format!(
            "step {h} must be positive"
        )));
    }
    if settings.t_end.is_nan() || settings.t_end <= t0 || settings.samples == 0 {
        return Err(StudyError::InvalidInput(format!(
            "need T > t₀ (T = {}, t₀ = {t0}) and at least one comparison time",
            settings.t_end
        )));
    }
    if let Some(m) = std::iter::once(&settings.reference)
        .chain(&settings.solvers)
        .find_map(|s| s.validate().err())
    {
        return Err(StudyError::InvalidInput(m));
    }
    let times = comparison_times(t0, settings.t_end, settings.samples);
    let mut jobs: Vec<(f64, SolverSetting)> = vec![(settings.h_min, settings.reference)];
    for &h in &settings.hs {
        for s in &settings.solvers {
            jobs.push((h, *s));
        }
    }
    let runs = map_runs(&jobs, settings.parallel, |(h, solver)| {
        let make_projector = || -> Result<Box<dyn Projector>, super::BoxError> {
            projector_for(solver).map_err(Into::into)
        };
        // A solver asked for a loose tolerance is judged at its own accuracy: the run-time
        // KKT and violation checks allow 10× its tolerance (osqp@1e-3 leaves overlaps of
        // ~1e-4 m, which the default 1e-6 would refuse).
        let judged = match solver.tolerance {
            Some(tol) => StepperSettings {
                kkt_tolerance: base.kkt_tolerance.max(10.0 * tol),
                violation_tolerance: base.violation_tolerance.max(10.0 * tol),
                ..base.clone()
            },
            None => base.clone(),
        };
        run_sampled(
            make_problem,
            &make_projector,
            &judged,
            *h,
            settings.t_end,
            &times,
            false,
        )
    });
    let mut runs = runs.into_iter();
    let reference = runs
        .next()
        .ok_or_else(|| StudyError::InvalidInput("no reference run".into()))??;
    let rows = jobs[1..]
        .iter()
        .zip(runs)
        .map(|((h, solver), run)| match run {
            Ok(run) => WorkPrecisionRow {
                h: *h,
                solver: solver.label(),
                error: max_of(&distances(&run.samples, &reference.samples)),
                cost: RunCost::of(&run),
                failure: None,
                infeasible: run.stats.max_violation > base.violation_tolerance,
            },
            Err(e) => WorkPrecisionRow {
                h: *h,
                solver: solver.label(),
                error: f64::NAN,
                cost: RunCost::failed(),
                failure: Some(e.to_string()),
                infeasible: false,
            },
        })
        .collect();
    Ok(WorkPrecisionReport {
        label: label.to_string(),
        settings: settings.clone(),
        reference: ReferenceSummary::of(settings.h_min, &reference),
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solver_settings_parse_with_and_without_tolerance() {
        let s: SolverSetting = "osqp@1e-3".parse().unwrap();
        assert_eq!(s.backend, BackendChoice::Osqp);
        assert!((s.tolerance.unwrap() - 1e-3).abs() < 1e-18);
        assert_eq!(s.label(), "osqp@1e-3");
        let r: SolverSetting = "reference".parse().unwrap();
        assert_eq!(r.tolerance, None);
        assert!("osqp@-1".parse::<SolverSetting>().is_err());
        assert!("nope".parse::<SolverSetting>().is_err());
    }

    /// A report of rows `(solver, error, CPU seconds)` at one step.
    fn report(rows: &[(&str, f64, f64)]) -> WorkPrecisionReport {
        let setting: SolverSetting = "reference".parse().unwrap();
        WorkPrecisionReport {
            label: "test".into(),
            settings: WorkPrecisionSettings {
                h_min: 0.01,
                reference: setting,
                hs: vec![0.02],
                solvers: vec![setting],
                t_end: 2.0,
                samples: 10,
                parallel: false,
            },
            reference: ReferenceSummary {
                h: 0.01,
                cpu_seconds: 1.0,
                steps: 200,
                iterations: 0,
            },
            rows: rows
                .iter()
                .map(|&(solver, error, cpu_seconds)| WorkPrecisionRow {
                    h: 0.02,
                    solver: solver.into(),
                    error,
                    cost: RunCost {
                        cpu_seconds,
                        wall_seconds: cpu_seconds,
                        steps: 100,
                        iterations: 0,
                        max_violation: 0.0,
                    },
                    failure: None,
                    infeasible: false,
                })
                .collect(),
        }
    }

    #[test]
    fn an_error_smaller_by_a_solvers_rounding_buys_no_place_on_the_front() {
        // Errors and times shaped like the paper's room at h = 0.02, T = 2: tight OSQP's error
        // a rounding below the native backend's, at three times its time.
        let tied = report(&[
            ("native", 5.157926859e-2, 0.0066),
            ("clarabel", 5.157926859e-2, 0.0563),
            ("osqp", 5.157926816e-2, 0.0214),
            ("osqp@1e-3", 5.243397037e-2, 0.0171),
        ]);
        assert_eq!(tied.pareto(), vec![0]);
        // A setting that is really more accurate stays on it, and so does an equal error
        // reached faster.
        let apart = report(&[
            ("native", 5.2e-2, 0.0066),
            ("osqp", 5.1e-2, 0.0214),
            ("clarabel", 5.2e-2, 0.0563),
        ]);
        assert_eq!(apart.pareto(), vec![0, 1]);
        // Equal errors and times: neither dominates the other.
        let twins = report(&[("native", 5.2e-2, 0.01), ("osqp", 5.2e-2, 0.01)]);
        assert_eq!(twins.pareto(), vec![0, 1]);
    }

    #[test]
    fn a_settings_projector_keeps_to_the_thread_its_cpu_time_is_measured_on() {
        // A native backend left to its default would solve large blocks on other threads,
        // whose CPU time the study does not see.
        for text in ["native", "native@1e-9", "osqp@1e-3", "clarabel"] {
            let setting: SolverSetting = text.parse().unwrap();
            let options = projector_options(&setting);
            assert_eq!(options.threads, 1, "{text}");
            assert_eq!(options.tolerance, setting.tolerance, "{text}");
        }
    }

    /// A tolerance far outside sense is refused with the range it must lie in, whether
    /// parsed or given in the settings.
    #[test]
    fn a_tolerance_outside_the_accepted_range_is_refused() {
        let err = "osqp@1e30".parse::<SolverSetting>().unwrap_err();
        assert!(
            err.contains("1e30") && err.contains("[1e-14, 1e-1]"),
            "{err}"
        );
        assert!("osqp@1e-20".parse::<SolverSetting>().is_err());
        assert!("osqp@1e-1".parse::<SolverSetting>().is_ok());
        let loose = SolverSetting {
            backend: BackendChoice::Reference,
            tolerance: Some(1e30),
        };
        let settings = WorkPrecisionSettings {
            solvers: vec![loose],
            ..report(&[]).settings
        };
        let make = || -> Result<crate::problem::Problem, super::super::BoxError> {
            Ok(crate::problem::Problem::new(
                vec![0.0],
                |_t: f64, _q: &[f64], f: &mut [f64]| f[0] = 1.0,
            ))
        };
        let err = work_precision("t", &make, &StepperSettings::default(), &settings).unwrap_err();
        assert!(
            matches!(&err, StudyError::InvalidInput(m) if m.contains("accepted range")),
            "{err}"
        );
    }

    /// A fast, accurate row whose answers overlap beyond the problem's tolerance is flagged
    /// and kept off the efficient front and the cheapest-per-decade list.
    #[test]
    fn an_infeasible_row_is_never_efficient() {
        let mut r = report(&[("native", 5.2e-2, 0.05), ("osqp@1e-3", 5.0e-2, 0.01)]);
        r.rows[1].infeasible = true;
        r.rows[1].cost.max_violation = 1.8e-3;
        assert_eq!(r.pareto(), vec![0]);
        assert_eq!(
            r.cheapest_below(1.0).map(|x| x.solver.as_str()),
            Some("native")
        );
        assert!(r.summary().contains("infeasible"), "{}", r.summary());
    }
}
