//! Running a built scene: from its own start, or resumed from a state an earlier run reached
//! (checked against the scene first).

use super::{BuiltScene, ObstacleShape, ResumeError};
use crate::crowd::velocity::ExitSegment;
use crate::crowd::Population;

/// A state an earlier run of a scene reached, to resume the scene from
/// ([`BuiltScene::resume_at`]): what `sweep run --resume` reads from the last frame of a
/// run's `trajectory.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct ResumeState {
    /// The time of the state.
    pub t: f64,
    /// Every person's centre, `[x₀, y₀, x₁, y₁, …]`.
    pub q: Vec<f64>,
    /// Whether each person had left.
    pub departed: Vec<bool>,
}

impl BuiltScene {
    /// Makes the run start from `state`, a state an earlier run of this scene reached,
    /// instead of the scene's own start: the time, every person's position, who had left and
    /// who of a source had arrived (latched, as the earlier run had them: everybody in the
    /// room or gone; who is written absent at their place is still to come). The horizon
    /// stays the scene's (or the override's): a run resumed at `t` goes on to the same `T`.
    ///
    /// The state is checked against the scene, since the run trusts it from then on: the
    /// time lies in `[t₀, T)`; everybody marked present has a disk in the room (not wholly
    /// outside it, not inside a polygon obstacle) and, as a scene's start, overlaps nobody
    /// present, no wall and no obstacle (to `1e-9`); everybody marked gone left through an
    /// exit (wholly outside the room on an exit's outer side, or beyond an exit in line with
    /// it, where a non-convex room lies across the way out).
    ///
    /// # Errors
    /// A [`ResumeError`] saying what does not fit, and naming the person where one is at
    /// fault. The scene is left as it was.
    pub fn resume_at(&mut self, state: ResumeState) -> Result<(), ResumeError> {
        let n = self.population.len();
        if !self.journeys.is_empty() {
            return Err(ResumeError::Journeys);
        }
        if state.q.len() != 2 * n || state.departed.len() != n {
            return Err(ResumeError::PeopleCount {
                found: state.departed.len(),
                expected: n,
            });
        }
        if let Some(k) = state.q.iter().position(|v| !v.is_finite()) {
            return Err(ResumeError::NotFinite {
                person: k / 2,
                axis: ["x", "y"][k % 2],
                value: state.q[k],
            });
        }
        let start = self.problem.t0();
        if state.t.is_nan() || state.t < start {
            return Err(ResumeError::BeforeStart { t: state.t, start });
        }
        if state.t >= self.settings.t_end {
            return Err(ResumeError::NotBeforeHorizon {
                t: state.t,
                t_end: self.settings.t_end,
            });
        }
        let mut state = state;
        let places = self.problem.q0().to_vec();
        // Everybody of a source but who is still to come had arrived by then.
        let mut arrived: Vec<bool> = (0..n).map(|i| self.population.due(i).is_some()).collect();
        for (i, in_by_now) in arrived.iter_mut().enumerate() {
            let p = Population::position(&state.q, i);
            let r = self.population.radius(i);
            // Someone of a source written absent at their place, never having moved, has not
            // arrived yet: they are not gone, and come in when due and their place is free.
            if state.departed[i]
                && self.population.due(i).is_some()
                && p == Population::position(&places, i)
            {
                state.departed[i] = false;
                *in_by_now = false;
                continue;
            }
            if state.departed[i] {
                if let Some(what) = self.why_not_gone(p, r) {
                    return Err(ResumeError::GoneInside {
                        person: i,
                        t: state.t,
                        position: p,
                        what,
                    });
                }
            } else if let Some(what) = self.why_not_present(state.t, p, r) {
                return Err(ResumeError::PresentOutside {
                    person: i,
                    t: state.t,
                    position: p,
                    what,
                });
            }
        }
        let (t0, q0) = (start, self.problem.q0().to_vec());
        let t = state.t;
        self.problem.set_start(state.t, state.q);
        self.departed_at_start = state.departed;
        self.arrived_at_start = arrived;
        // Checked as a start is, with the departures latched (people who left are in no
        // constraint).
        self.latch_departures_at_start();
        let checked = self.problem.validate(1e-9);
        self.population.reset_departures();
        if let Err(source) = checked {
            self.problem.set_start(t0, q0);
            self.departed_at_start = vec![false; n];
            self.arrived_at_start = vec![false; n];
            return Err(ResumeError::Infeasible { t, source });
        }
        Ok(())
    }

    /// Why a person of radius `r` at `p` cannot be present at `t`, if they cannot: the model
    /// marks a person gone once their disk is wholly outside the room, and the constraints
    /// see a polygon obstacle's edges only, not a person wholly inside it.
    fn why_not_present(&self, t: f64, p: [f64; 2], r: f64) -> Option<String> {
        if let Some(room) = self.population.room() {
            if !(room.contains(p) || room.boundary_distance(p) < r) {
                return Some(format!(
                    "their disk (radius {r}) is wholly outside the room: who is there has left"
                ));
            }
        }
        self.geometry
            .obstacles
            .iter()
            .enumerate()
            .find_map(|(k, o)| {
                let ObstacleShape::Polygon(v) = &o.shape else {
                    return None;
                };
                let d: [f64; 2] = o.offset(t);
                let moved = v.iter().map(|a| [a[0] + d[0], a[1] + d[1]]).collect();
                crate::crowd::Room { vertices: moved }
                    .contains(p)
                    .then(|| format!("they are inside obstacle #{} there", k + 1))
            })
    }

    /// Why a person of radius `r` at `p` cannot have left, if they cannot: leaving is through
    /// an exit, after which they walk on along its outward normal. So they are on an exit's
    /// outer side, and either wholly outside the room or, in line with that exit and at
    /// least `r` beyond it, crossing another part of a non-convex room.
    fn why_not_gone(&self, p: [f64; 2], r: f64) -> Option<String> {
        let Some(room) = self.population.room() else {
            return Some("the scene has no room to leave".into());
        };
        let exits = &self.geometry.exits;
        if exits.is_empty() {
            return Some("the scene has no exit to leave by".into());
        }
        let wholly_out = !(room.contains(p) || room.boundary_distance(p) < r);
        // Rounding of the positions written, at the room's scale.
        let slack = 1e-9 * (1.0 + p[0].abs() + p[1].abs());
        let left_by = |e: &ExitSegment| {
            let rel = [p[0] - e.a[0], p[1] - e.a[1]];
            let beyond = rel[0] * e.outward[0] + rel[1] * e.outward[1];
            let len = (e.b[0] - e.a[0]).hypot(e.b[1] - e.a[1]);
            let along = (rel[0] * (e.b[0] - e.a[0]) + rel[1] * (e.b[1] - e.a[1])) / len;
            // A person slips past an exit's ends by up to their radius as they go through,
            // and moves a step further before the departure is seen.
            let in_line = (-2.0 * r..=len + 2.0 * r).contains(&along);
            beyond >= -slack && (wholly_out || (in_line && beyond >= r - slack))
        };
        if exits.iter().any(left_by) {
            return None;
        }
        Some(if wholly_out {
            "they are outside the room on no exit's outer side: they cannot have left through an exit".into()
        } else {
            format!("their disk (radius {r}) is not wholly outside the room, beyond no exit: who is there is present")
        })
    }

    /// Clears every departure, then latches those of [`BuiltScene::departed_at_start`]; clears
    /// every arrival, then latches those of [`BuiltScene::arrived_at_start`] (in a resumed
    /// state they may touch their neighbours, as people in a queue do, which would keep a
    /// newcomer out) and lets in who else is due by the start and finds their place free: the
    /// population as the run starts.
    fn latch_departures_at_start(&self) {
        self.population.reset_departures();
        for (i, _) in self
            .departed_at_start
            .iter()
            .enumerate()
            .filter(|(_, &d)| d)
        {
            self.population.set_departed(i);
        }
        self.population.reset_arrivals();
        for (i, _) in self.arrived_at_start.iter().enumerate().filter(|(_, &a)| a) {
            self.population.set_arrived(i, self.problem.t0());
        }
        self.population.admit(self.problem.t0(), self.problem.q0());
        for j in &self.journeys {
            j.reset();
        }
    }

    /// Runs the scene to its horizon (or until everybody has left, when the scene says
    /// `stop_when_empty`), calling the observers after each step.
    ///
    /// # Errors
    /// A [`RunFailure`](crate::stepper::RunFailure): the error and everything computed before
    /// it. The observers' `on_finish` is called in every case, so writers flush.
    pub fn run(
        &self,
        projector: &mut dyn sweeping_api::Projector,
        observers: &mut [&mut dyn crate::stepper::Observer],
    ) -> Result<crate::stepper::Run, Box<crate::stepper::RunFailure>> {
        use crate::stepper::{Run, RunFailure, RunStats, Stepper, Trajectory};
        // A new run from q₀: nobody has left yet, unless it resumes an earlier run; who is due
        // by the start and finds their place free comes in.
        self.latch_departures_at_start();
        let mut settings = self.settings.clone();
        settings.record_contacts |= self.output.contact_forces;
        let stepper = match Stepper::new(&self.problem, settings) {
            Ok(s) => s,
            Err(error) => {
                // The start is a state of the run all the same: written, and counted (a run
                // refused here reported everybody as gone and wrote no trajectory).
                let q0 = self.problem.q0().to_vec();
                for o in observers.iter_mut() {
                    let _ = o.on_start(self.problem.t0(), &q0);
                    let _ = o.on_finish(Some(&error));
                }
                return Err(Box::new(RunFailure {
                    error,
                    partial: Run {
                        trajectory: Trajectory {
                            times: vec![self.problem.t0()],
                            states: vec![q0.clone()],
                        },
                        stats: RunStats::default(),
                        q_final: q0,
                        t_final: self.problem.t0(),
                    },
                }));
            }
        };
        let stop_when_empty = self.stop_when_empty;
        let population = &self.population;
        // Arrivals come in between steps, before the observers see the step.
        stepper.run_until(projector, observers, |t, q| {
            population.admit(t, q);
            stop_when_empty && population.is_done(q)
        })
    }
}
