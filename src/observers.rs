//! Ready-made observers: a trajectory writer for any problem, a callback adapter, and a
//! recorder of step reports.

use crate::error::SweepError;
use crate::stepper::{Observer, StepReport};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Writes `t,q0,q1,…` lines to a CSV file, every `every` steps and at the end; flushes on
/// finish, also after a failure, so a failed run keeps what it computed.
pub struct TrajectoryCsv {
    path: PathBuf,
    out: BufWriter<File>,
    every: usize,
    steps: usize,
    last_written: Option<usize>,
    last: Option<(f64, Vec<f64>)>,
}

impl TrajectoryCsv {
    /// Creates (truncates) the file.
    ///
    /// # Errors
    /// When the file cannot be created.
    pub fn create(path: impl AsRef<Path>, every: usize) -> std::io::Result<Self> {
        let path = path.as_ref().to_path_buf();
        let out = BufWriter::new(File::create(&path)?);
        Ok(Self {
            path,
            out,
            every: every.max(1),
            steps: 0,
            last_written: None,
            last: None,
        })
    }

    fn write(&mut self, t: f64, q: &[f64]) -> Result<(), String> {
        let mut line = format!("{t}");
        for v in q {
            line.push(',');
            line.push_str(&v.to_string());
        }
        writeln!(self.out, "{line}").map_err(|e| format!("{}: {e}", self.path.display()))
    }
}

impl Observer for TrajectoryCsv {
    fn name(&self) -> &str {
        "trajectory CSV writer"
    }

    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), String> {
        let header: Vec<String> = std::iter::once("t".to_string())
            .chain((0..q.len()).map(|i| format!("q{i}")))
            .collect();
        writeln!(self.out, "{}", header.join(","))
            .map_err(|e| format!("{}: {e}", self.path.display()))?;
        self.last_written = Some(0);
        self.write(t, q)
    }

    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), String> {
        self.steps += 1;
        if self.steps.is_multiple_of(self.every) {
            self.last_written = Some(self.steps);
            self.last = None;
            self.write(report.t, q)
        } else {
            self.last = Some((report.t, q.to_vec()));
            Ok(())
        }
    }

    fn on_finish(&mut self, _error: Option<&SweepError>) -> Result<(), String> {
        if let Some((t, q)) = self.last.take() {
            self.write(t, &q)?;
        }
        self.out
            .flush()
            .map_err(|e| format!("{}: {e}", self.path.display()))
    }
}

/// Turns a closure `FnMut(&StepReport, &[f64])` into an observer.
///
/// ```
/// use sweeping::observers::Callback;
/// let mut worst = 0.0f64;
/// let mut obs = Callback::new(|r: &sweeping::stepper::StepReport, _q: &[f64]| {
///     worst = worst.max(r.max_violation);
/// });
/// # let _ = &mut obs;
/// ```
pub struct Callback<F>(F);

impl<F: FnMut(&StepReport, &[f64])> Callback<F> {
    /// Wraps `f`.
    pub fn new(f: F) -> Self {
        Self(f)
    }
}

impl<F: FnMut(&StepReport, &[f64])> Observer for Callback<F> {
    fn name(&self) -> &str {
        "callback"
    }
    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), String> {
        (self.0)(report, q);
        Ok(())
    }
}

/// Keeps every step report.
#[derive(Debug, Default, Clone)]
pub struct ReportRecorder {
    /// The reports, in order.
    pub reports: Vec<StepReport>,
}

impl Observer for ReportRecorder {
    fn name(&self) -> &str {
        "report recorder"
    }
    fn on_step(&mut self, report: &StepReport, _q: &[f64]) -> Result<(), String> {
        self.reports.push(report.clone());
        Ok(())
    }
}
