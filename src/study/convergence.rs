//! The paper's convergence experiment ([`converge`]): a reference run, one run per step size,
//! the errors at the comparison times and the fitted orders, as a report.

use super::fit::{fit_order_checked, round_off_floor, OrderFit, ROUNDING_FLOOR};
use super::plot;
use super::sampling::{comparison_times, distance, max_of, run_sampled, SampledRun};
use super::{map_runs, write_file, ProblemFactory, ProjectorFactory, StudyError};
use crate::stepper::{step_count, StepperSettings};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Settings of the convergence experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceSettings {
    /// Step of the reference run. The paper: `0.01`.
    pub h_min: f64,
    /// Steps compared with the reference (each `> h_min`). The paper: `0.02, 0.025, 0.04,
    /// 0.05, 0.0625, 0.08, 0.1, 0.2, 0.5`.
    pub hs: Vec<f64>,
    /// The horizon `T`.
    pub t_end: f64,
    /// A second, short horizon (`t₀ < T_short ≤ T`), or none.
    pub t_short: Option<f64>,
    /// Comparison times per horizon. The paper: 10.
    pub samples: usize,
    /// Run the step sizes in parallel (rayon). Default `true`.
    pub parallel: bool,
}

impl ConvergenceSettings {
    /// The paper's steps (`h_min = 0.01`, nine `h`), 10 comparison times, horizon `t_end`,
    /// short horizon 2 s when `t_end > 2`.
    pub fn paper(t_end: f64) -> Self {
        Self {
            h_min: 0.01,
            hs: PAPER_HS.to_vec(),
            t_end,
            t_short: (t_end > 2.0).then_some(2.0),
            samples: 10,
            parallel: true,
        }
    }

    fn validate(&self, t0: f64) -> Result<(), StudyError> {
        let bad = |m: String| Err(StudyError::InvalidInput(m));
        if !(self.h_min.is_finite() && self.h_min > 0.0) {
            return bad(format!("h_min = {} must be positive", self.h_min));
        }
        if self.hs.is_empty() {
            return bad("no step sizes to compare".into());
        }
        if let Some(h) = self
            .hs
            .iter()
            .find(|h| !(h.is_finite() && **h > self.h_min))
        {
            return bad(format!(
                "every compared h must exceed h_min = {}; got {h}",
                self.h_min
            ));
        }
        if !(self.t_end.is_finite() && self.t_end > t0) {
            return bad(format!("T = {} must exceed t₀ = {t0}", self.t_end));
        }
        if let Some(ts) = self.t_short {
            if !(ts > t0 && ts <= self.t_end) {
                return bad(format!(
                    "the short horizon {ts} must lie in (t₀, T] = ({t0}, {}]",
                    self.t_end
                ));
            }
        }
        if self.samples == 0 {
            return bad("at least one comparison time is needed".into());
        }
        // Two step sizes with one step count are one run twice: their errors fit a slope of 0.
        let span = self.t_end - t0;
        let mut counts: Vec<(usize, f64)> = Vec::new();
        for &h in std::iter::once(&self.h_min).chain(&self.hs) {
            let n = step_count(span, h);
            if let Some((_, other)) = counts.iter().find(|(m, _)| *m == n) {
                return bad(format!(
                    "h = {other} and h = {h} both take {n} step(s) over T − t₀ = {span}: their \
                     runs are the same run; give step sizes with different step counts"
                ));
            }
            counts.push((n, h));
        }
        Ok(())
    }
}

/// The paper's compared step sizes.
pub const PAPER_HS: [f64; 9] = [0.02, 0.025, 0.04, 0.05, 0.0625, 0.08, 0.1, 0.2, 0.5];

/// One step size of a convergence study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceRow {
    /// Time step.
    pub h: f64,
    /// `e_h` over the whole horizon.
    pub error: f64,
    /// `e_h` over the short horizon.
    pub error_short: Option<f64>,
    /// `|q_ref(tᵢ) − qⁿ(tᵢ)|` at each comparison time of the whole horizon.
    pub errors_at: Vec<f64>,
    /// `|q_ref(tᵢ) − qⁿ(tᵢ)|` at each comparison time of the short horizon.
    pub errors_at_short: Vec<f64>,
    /// For exact solutions: `sup_t |q(t) − qⁿ(t)|` (see [`super::exact::true_error_study`]).
    pub error_sup: Option<f64>,
    /// The error at or below which this row measures rounding ([`round_off_floor`]).
    #[serde(default)]
    pub round_off: f64,
    /// What the run cost (flattened into the row's JSON).
    #[serde(flatten)]
    pub cost: RunCost,
}

/// What one run of a study cost, and how far it strayed from the true constraints.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RunCost {
    /// CPU seconds of the run's thread (wall seconds where CPU time is unavailable).
    pub cpu_seconds: f64,
    /// Wall-clock seconds.
    pub wall_seconds: f64,
    /// Steps.
    pub steps: usize,
    /// Solver iterations, summed.
    pub iterations: u64,
    /// Largest violation of the true constraints after any step.
    pub max_violation: f64,
}

impl RunCost {
    /// The cost of `run`.
    pub fn of(run: &SampledRun) -> Self {
        Self {
            cpu_seconds: run.cpu_seconds,
            wall_seconds: run.wall_seconds,
            steps: run.stats.steps,
            iterations: run.stats.iterations,
            max_violation: run.stats.max_violation,
        }
    }

    /// A run that failed: no steps counted, times and violation unknown (NaN).
    pub fn failed() -> Self {
        Self {
            cpu_seconds: f64::NAN,
            wall_seconds: f64::NAN,
            steps: 0,
            iterations: 0,
            max_violation: f64::NAN,
        }
    }
}

/// The reference run's cost.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReferenceSummary {
    /// Its step (`h_min`), or 0 for an exact solution.
    pub h: f64,
    /// CPU seconds.
    pub cpu_seconds: f64,
    /// Steps.
    pub steps: usize,
    /// Solver iterations.
    pub iterations: u64,
}

/// The outcome of [`converge`] (or of [`super::exact::true_error_study`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceReport {
    /// What was studied.
    pub label: String,
    /// The settings.
    pub settings: ConvergenceSettings,
    /// Comparison times of the whole horizon.
    pub times: Vec<f64>,
    /// Comparison times of the short horizon.
    pub times_short: Vec<f64>,
    /// The reference run (absent for an exact solution).
    pub reference: Option<ReferenceSummary>,
    /// One row per compared `h`, in the order given.
    pub rows: Vec<ConvergenceRow>,
    /// Fitted order over the whole horizon.
    pub order: Option<OrderFit>,
    /// Fitted order over the short horizon.
    pub order_short: Option<OrderFit>,
    /// Fitted order of the sup-norm error (exact solutions).
    pub order_sup: Option<OrderFit>,
}

impl ConvergenceRow {
    /// The row of `run` whose distances at the comparison times of the whole horizon are
    /// `errors_at`: `e_h` is their max, the costs are the run's; the short horizon and the sup
    /// error are left empty for the caller to fill.
    pub(super) fn measured(run: &SampledRun, errors_at: Vec<f64>) -> Self {
        Self {
            h: run.h,
            error: max_of(&errors_at),
            error_short: None,
            errors_at,
            errors_at_short: Vec::new(),
            error_sup: None,
            round_off: run.round_off(run.stats.steps),
            cost: RunCost::of(run),
        }
    }
}

impl SampledRun {
    /// The round-off floor of a distance to this run from a run of `steps` steps: the larger
    /// step count and the largest coordinate of this run's samples ([`round_off_floor`]).
    fn round_off(&self, steps: usize) -> f64 {
        let scale = self
            .samples
            .iter()
            .flatten()
            .chain(self.trajectory.states.iter().flatten())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let dim = self.samples.first().map_or(0, Vec::len);
        round_off_floor(steps.max(self.stats.steps), dim, scale)
    }
}

impl ReferenceSummary {
    /// The cost of the reference `run`, made with step `h`.
    pub(super) fn of(h: f64, run: &SampledRun) -> Self {
        Self {
            h,
            cpu_seconds: run.cpu_seconds,
            steps: run.stats.steps,
            iterations: run.stats.iterations,
        }
    }
}

impl ConvergenceReport {
    pub(super) fn fit(&mut self) {
        let (hs, steps, floors) = self.fit_inputs();
        let es: Vec<f64> = self.rows.iter().map(|r| r.error).collect();
        self.order = fit_order_checked(&hs, &es, &steps, &floors);
        let short: Option<Vec<f64>> = self.rows.iter().map(|r| r.error_short).collect();
        self.order_short = short.and_then(|es| fit_order_checked(&hs, &es, &steps, &floors));
        let sup: Option<Vec<f64>> = self.rows.iter().map(|r| r.error_sup).collect();
        self.order_sup = sup.and_then(|es| fit_order_checked(&hs, &es, &steps, &floors));
    }

    /// Each row's `h`, step count and round-off floor, for [`fit_order_checked`].
    fn fit_inputs(&self) -> (Vec<f64>, Vec<usize>, Vec<f64>) {
        let hs = self.rows.iter().map(|r| r.h).collect();
        let steps = self.rows.iter().map(|r| r.cost.steps).collect();
        let floors = self
            .rows
            .iter()
            .map(|r| r.round_off.max(ROUNDING_FLOOR))
            .collect();
        (hs, steps, floors)
    }

    /// The fitted order of `e_h` at each comparison time `tᵢ` alone (not the max over
    /// `t ≤ tᵢ`): how the order changes along the run; `None` where it cannot be fitted.
    pub fn order_at_times(&self) -> Vec<(f64, Option<OrderFit>)> {
        let (hs, steps, floors) = self.fit_inputs();
        self.times
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let es: Vec<f64> = self.rows.iter().map(|r| r.errors_at[i]).collect();
                (t, fit_order_checked(&hs, &es, &steps, &floors))
            })
            .collect()
    }

    /// Writes the per-`h` table.
    ///
    /// Columns: `h`, `error` (`e_h`, whole horizon), `error_short` (short horizon, empty if
    /// none), `error_sup` (exact solutions only), `cpu_seconds`, `wall_seconds`, `steps`,
    /// `iterations`, `max_violation`. The fitted orders follow as comment lines starting with
    /// `#`.
    ///
    /// # Errors
    /// [`StudyError::Io`].
    pub fn write_csv(&self, path: &Path) -> Result<(), StudyError> {
        let mut s = String::from(
            "h,error,error_short,error_sup,cpu_seconds,wall_seconds,steps,iterations,max_violation\n",
        );
        let opt = |v: Option<f64>| v.map(|x| format!("{x:.9e}")).unwrap_or_default();
        for r in &self.rows {
            s.push_str(&format!(
                "{},{:.9e},{},{},{:.6},{:.6},{},{},{:.3e}\n",
                r.h,
                r.error,
                opt(r.error_short),
                opt(r.error_sup),
                r.cost.cpu_seconds,
                r.cost.wall_seconds,
                r.cost.steps,
                r.cost.iterations,
                r.cost.max_violation
            ));
        }
        for (name, fit) in [
            ("order", self.order),
            ("order_short", self.order_short),
            ("order_sup", self.order_sup),
        ] {
            if let Some(f) = fit {
                s.push_str(&format!(
                    "# {name} = {:.4} (C = {:.4e}, R² = {:.4}, {} points)\n",
                    f.order, f.constant, f.r_squared, f.points
                ));
                if let Some(c) = f.caveat {
                    s.push_str(&format!("# {name} is not an order: {c}\n"));
                }
            }
        }
        write_file(path, &s)
    }

    /// Writes the error at every comparison time, long format.
    ///
    /// Columns: `horizon` (`whole` or `short`), `h`, `t`, `error`
    /// (`|q_ref(t) − qⁿ(t)|`).
    ///
    /// # Errors
    /// [`StudyError::Io`].
    pub fn write_times_csv(&self, path: &Path) -> Result<(), StudyError> {
        let mut s = String::from("horizon,h,t,error\n");
        for r in &self.rows {
            for (t, e) in self.times.iter().zip(&r.errors_at) {
                s.push_str(&format!("whole,{},{t},{e:.9e}\n", r.h));
            }
            for (t, e) in self.times_short.iter().zip(&r.errors_at_short) {
                s.push_str(&format!("short,{},{t},{e:.9e}\n", r.h));
            }
        }
        write_file(path, &s)
    }

    /// Draws `e_h` against `h` in log–log coordinates (whole horizon, short horizon, sup
    /// norm where present), each with its fitted line, and a slope-½ reference line (SVG).
    ///
    /// # Errors
    /// [`StudyError::Plot`].
    pub fn plot(&self, path: &Path) -> Result<(), StudyError> {
        let mut series = Vec::new();
        let hs: Vec<f64> = self.rows.iter().map(|r| r.h).collect();
        let horizon = |t: f64| {
            format!("{t:.3}")
                .trim_end_matches('0')
                .trim_end_matches('.')
                .to_string()
        };
        series.push(plot::Series {
            label: format!("e_h, t ≤ {}", horizon(self.settings.t_end)),
            points: hs
                .iter()
                .zip(self.rows.iter().map(|r| r.error))
                .map(|(a, b)| (*a, b))
                .collect(),
            fit: self.order,
        });
        if let Some(ts) = self.settings.t_short {
            series.push(plot::Series {
                label: format!("e_h, t ≤ {}", horizon(ts)),
                points: hs
                    .iter()
                    .zip(&self.rows)
                    .filter_map(|(h, r)| r.error_short.map(|e| (*h, e)))
                    .collect(),
                fit: self.order_short,
            });
        }
        if self.rows.iter().all(|r| r.error_sup.is_some()) {
            series.push(plot::Series {
                label: "sup_t |q − qⁿ|".into(),
                points: hs
                    .iter()
                    .zip(&self.rows)
                    .filter_map(|(h, r)| r.error_sup.map(|e| (*h, e)))
                    .collect(),
                fit: self.order_sup,
            });
        }
        plot::log_log(
            path,
            &format!("Convergence: {}", self.label),
            "h",
            "error",
            &series,
            Some(0.5),
        )
    }

    /// A plain-text summary: one line per `h`, then the fitted orders.
    pub fn summary(&self) -> String {
        let mut s = format!("{}\n", self.label);
        if let Some(r) = &self.reference {
            s.push_str(&format!(
                "reference h = {}: {} steps, {:.2} s CPU, {} solver iterations\n",
                r.h, r.steps, r.cpu_seconds, r.iterations
            ));
        }
        s.push_str(&format!(
            "{:>8} {:>12} {:>12} {:>12} {:>9} {:>6}\n",
            "h", "e_h", "e_h short", "sup", "cpu [s]", "steps"
        ));
        let opt = |v: Option<f64>| {
            v.map(|x| format!("{x:12.4e}"))
                .unwrap_or(format!("{:>12}", "-"))
        };
        for r in &self.rows {
            s.push_str(&format!(
                "{:>8} {:12.4e} {} {} {:9.3} {:>6}\n",
                r.h,
                r.error,
                opt(r.error_short),
                opt(r.error_sup),
                r.cost.cpu_seconds,
                r.cost.steps
            ));
        }
        let line = |name: &str, f: Option<OrderFit>| match f {
            Some(f) => format!("{name}: {}\n", f.describe()),
            None => format!("{name}: not fitted (fewer than two positive errors)\n"),
        };
        s.push_str(&line(
            &format!("fitted order, t ≤ {}", self.settings.t_end),
            self.order,
        ));
        if let Some(ts) = self.settings.t_short {
            s.push_str(&line(&format!("fitted order, t ≤ {ts}"), self.order_short));
        }
        if self.rows.iter().all(|r| r.error_sup.is_some()) {
            s.push_str(&line("fitted order, sup norm", self.order_sup));
        }
        s
    }
}

/// The paper's convergence experiment: a reference run at `h_min` and one run per `h`, all
/// in parallel; `e_h` over the whole and the short horizon; fitted orders.
///
/// `base` supplies everything but `h`, `t_end` and `record_every`.
///
/// ```
/// use sweeping::prelude::*;
/// use sweeping::study::{converge, ConvergenceSettings};
/// use sweeping::api::conformance::ReferenceProjector;
///
/// struct Floor;
/// impl ConstraintKernel<1> for Floor {
///     type Params = ();
///     fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 1]) -> D { z[0] }
///     fn is_time_dependent(&self) -> bool { false }
/// }
/// // x' = −x − 1 above the floor x ≥ 0: explicit Euler until contact.
/// let make = || -> Result<Problem, sweeping::study::BoxError> {
///     Ok(Problem::new(vec![1.0], |_t: f64, q: &[f64], f: &mut [f64]| f[0] = -q[0] - 1.0)
///         .with_family(KernelFamily::single("floor", Floor, [0])))
/// };
/// let proj = || -> Result<Box<dyn Projector>, sweeping::study::BoxError> {
///     Ok(Box::new(ReferenceProjector::default()))
/// };
/// let settings = ConvergenceSettings {
///     h_min: 0.001, hs: vec![0.004, 0.01, 0.02], t_end: 0.5, t_short: None,
///     samples: 10, parallel: false,
/// };
/// let report = converge("floor", &make, &proj, &StepperSettings::default(), &settings).unwrap();
/// assert!(report.order.unwrap().order > 0.8);
/// ```
///
/// # Errors
/// [`StudyError::InvalidInput`] for bad settings; the first failing run's error otherwise.
pub fn converge(
    label: &str,
    make_problem: &ProblemFactory<'_>,
    make_projector: &ProjectorFactory<'_>,
    base: &StepperSettings,
    settings: &ConvergenceSettings,
) -> Result<ConvergenceReport, StudyError> {
    let t0 = make_problem()
        .map_err(|source| StudyError::Setup {
            h: settings.h_min,
            source,
        })?
        .t0();
    settings.validate(t0)?;
    let times = comparison_times(t0, settings.t_end, settings.samples);
    let times_short = settings
        .t_short
        .map(|ts| comparison_times(t0, ts, settings.samples))
        .unwrap_or_default();
    let mut all: Vec<f64> = times.iter().chain(&times_short).copied().collect();
    all.sort_by(f64::total_cmp);
    all.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * a.abs().max(1.0));

    // The reference first in the list: rayon starts it at once, and it is the longest.
    let steps: Vec<f64> = std::iter::once(settings.h_min)
        .chain(settings.hs.iter().copied())
        .collect();
    let runs = map_runs(&steps, settings.parallel, |&h| {
        run_sampled(
            make_problem,
            make_projector,
            base,
            h,
            settings.t_end,
            &all,
            false,
        )
    });
    let mut runs = runs.into_iter().collect::<Result<Vec<_>, _>>()?;
    let reference = runs.remove(0);
    let at = |run: &SampledRun, ts: &[f64]| -> Vec<f64> {
        ts.iter()
            .map(|t| {
                let i = all
                    .iter()
                    .position(|s| (s - t).abs() <= 1e-12 * t.abs().max(1.0))
                    .unwrap_or(0);
                distance(&reference.samples[i], &run.samples[i])
            })
            .collect()
    };
    let rows = runs
        .iter()
        .map(|run| {
            let errors_at_short = at(run, &times_short);
            ConvergenceRow {
                error_short: settings.t_short.map(|_| max_of(&errors_at_short)),
                errors_at_short,
                round_off: run
                    .round_off(reference.stats.steps)
                    .max(reference.round_off(run.stats.steps)),
                ..ConvergenceRow::measured(run, at(run, &times))
            }
        })
        .collect();
    let mut report = ConvergenceReport {
        label: label.to_string(),
        settings: settings.clone(),
        times,
        times_short,
        reference: Some(ReferenceSummary::of(settings.h_min, &reference)),
        rows,
        order: None,
        order_short: None,
        order_sup: None,
    };
    report.fit();
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::super::work_precision;
    use super::*;

    /// The rows' JSON keeps the cost columns of [`RunCost`] at the top level (flattened),
    /// and reads back equal.
    #[test]
    fn row_json_is_flat_and_round_trips() {
        let cost = RunCost {
            cpu_seconds: 1.5,
            wall_seconds: 2.5,
            steps: 7,
            iterations: 40,
            max_violation: 1e-9,
        };
        let row = ConvergenceRow {
            h: 0.1,
            error: 0.25,
            error_short: None,
            errors_at: vec![0.25],
            errors_at_short: Vec::new(),
            error_sup: Some(0.5),
            round_off: 1e-12,
            cost,
        };
        let json: serde_json::Value = serde_json::to_value(&row).unwrap();
        assert!(json.get("cost").is_none(), "{json}");
        assert_eq!(json["cpu_seconds"], 1.5);
        assert_eq!(json["steps"], 7);
        assert_eq!(json["max_violation"], 1e-9);
        let back: ConvergenceRow = serde_json::from_value(json).unwrap();
        assert_eq!(back, row);
        let wp = work_precision::WorkPrecisionRow {
            h: 0.1,
            solver: "clarabel".into(),
            error: 0.25,
            cost,
            failure: None,
            infeasible: false,
        };
        let json = serde_json::to_value(&wp).unwrap();
        assert_eq!(json["iterations"], 40);
        assert_eq!(json["wall_seconds"], 2.5);
        let back: work_precision::WorkPrecisionRow = serde_json::from_value(json).unwrap();
        assert_eq!(back, wp);
    }
}
