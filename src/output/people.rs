//! The people of a run: each one's radius, and when and where they left. The trajectory
//! writes nobody who has left, so this table is what says who left, and the radii with which
//! a run with random radii is checked and drawn from its outputs alone.

use crate::crowd::Population;
use crate::error::SweepError;
use crate::stepper::{Observer, ObserverError, StepReport};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The people table's file in the output directory: `id,radius,t_left,x_left,y_left`.
pub const PEOPLE_FILE: &str = "people.csv";

/// When and where a person was first seen wholly outside the room: the end of the first step
/// (or the start of a run) at which their disk was out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Departure {
    /// The time.
    pub t: f64,
    /// Their centre then.
    pub position: [f64; 2],
}

/// Who has left so far, updated at every state of a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct DepartureLog(Vec<Option<Departure>>);

impl DepartureLog {
    /// Nobody has left yet, or, for a resumed run, those the earlier run saw leave.
    pub(crate) fn new(people: usize, before: &[Option<Departure>]) -> Self {
        let mut log = vec![None; people];
        for (slot, d) in log.iter_mut().zip(before) {
            *slot = *d;
        }
        Self(log)
    }

    /// Records everybody seen out at `(t, q)` for the first time; returns their indices.
    pub(crate) fn update(&mut self, population: &Population, t: f64, q: &[f64]) -> Vec<usize> {
        let mut new = Vec::new();
        for (i, slot) in self.0.iter_mut().enumerate() {
            if slot.is_none() && population.has_arrived(i) && !population.is_present(q, i) {
                *slot = Some(Departure {
                    t,
                    position: Population::position(q, i),
                });
                new.push(i);
            }
        }
        new
    }

    pub(crate) fn get(&self, i: usize) -> Option<Departure> {
        self.0.get(i).copied().flatten()
    }

    pub(crate) fn all(&self) -> &[Option<Departure>] {
        &self.0
    }
}

/// Writes [`PEOPLE_FILE`]: one row per person, `id,radius,t_left,x_left,y_left`, the last
/// three empty for who has not left. Written at the start (so that a run that dies still has
/// the radii) and again at the end, with the departures.
pub struct PeopleWriter {
    path: PathBuf,
    population: Arc<Population>,
    log: DepartureLog,
}

impl PeopleWriter {
    /// A writer to `path` for the people of `population`.
    pub fn new(path: impl Into<PathBuf>, population: Arc<Population>) -> Self {
        let log = DepartureLog::new(population.len(), &[]);
        Self {
            path: path.into(),
            population,
            log,
        }
    }

    /// The departures an earlier run saw, for a run resumed from it: people who had left
    /// before its start keep the time and place they left at.
    #[must_use]
    pub fn with_departures_before(mut self, before: &[Option<Departure>]) -> Self {
        self.log = DepartureLog::new(self.population.len(), before);
        self
    }

    /// Where it writes.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Each person's departure so far.
    pub fn departures(&self) -> &[Option<Departure>] {
        self.log.all()
    }

    fn write(&self) -> Result<(), String> {
        use std::fmt::Write;
        let mut text = String::from("id,radius,t_left,x_left,y_left\n");
        for (i, r) in self.population.radii().iter().enumerate() {
            let _ = match self.log.get(i) {
                Some(d) => writeln!(text, "{i},{r},{},{},{}", d.t, d.position[0], d.position[1]),
                None => writeln!(text, "{i},{r},,,"),
            };
        }
        super::write_whole(&self.path, text).map_err(|e| format!("{}: {e}", self.path.display()))
    }
}

impl Observer for PeopleWriter {
    fn name(&self) -> &str {
        "people writer"
    }

    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        self.log.update(&self.population, t, q);
        Ok(self.write()?)
    }

    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        self.log.update(&self.population, report.t, q);
        Ok(())
    }

    fn on_finish(&mut self, _error: Option<&SweepError>) -> Result<(), ObserverError> {
        Ok(self.write()?)
    }
}
