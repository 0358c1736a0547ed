//! Journeys: a person follows a chain of waypoints, each with a velocity field of its own
//! (straight or geodesic), then a last field (towards the exits or a point). The stage each
//! person has reached is remembered, and only goes forward: a person who has reached a
//! waypoint heads for the next even if pushed back out of it.

use super::fast_marching::Target;
use super::velocity::VelocityField;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// One waypoint: where it is, and the field leading to it.
pub struct Stage {
    /// The waypoint.
    pub target: Target,
    /// The velocity field towards it.
    pub field: Box<dyn VelocityField>,
}

/// The stage each person has reached (`0`: heading for the first waypoint), latched forward.
#[derive(Debug, Default)]
pub struct JourneyProgress(Vec<AtomicUsize>);

impl JourneyProgress {
    /// Everybody of a population of `people` at the first stage.
    pub fn new(people: usize) -> Self {
        Self((0..people).map(|_| AtomicUsize::new(0)).collect())
    }

    /// The stage person `i` has reached.
    pub fn stage(&self, i: usize) -> usize {
        self.0[i].load(Ordering::Relaxed)
    }

    /// Everybody back at the first stage: the start of a new run.
    pub fn reset(&self) {
        for s in &self.0 {
            s.store(0, Ordering::Relaxed);
        }
    }
}

/// A chain of waypoints, then a last field.
///
/// ```
/// use std::sync::Arc;
/// use sweeping::crowd::fast_marching::Target;
/// use sweeping::crowd::journey::{Journey, JourneyProgress, Stage};
/// use sweeping::crowd::velocity::{TowardsPoint, VelocityField};
/// let progress = Arc::new(JourneyProgress::new(1));
/// let journey = Journey::new(
///     vec![Stage {
///         target: Target::Point { at: [0.0, 5.0], reach: 0.5 },
///         field: Box::new(TowardsPoint { point: [0.0, 5.0] }),
///     }],
///     Box::new(TowardsPoint { point: [5.0, 4.6] }),
///     progress.clone(),
/// );
/// // First up, to the waypoint; once within 0.5 of it, right, to the last point.
/// assert_eq!(journey.velocity_of(0, [0.0, 0.0], 1.0), [0.0, 1.0]);
/// assert_eq!(journey.velocity_of(0, [0.0, 4.6], 1.0), [1.0, 0.0]);
/// assert_eq!(progress.stage(0), 1);
/// // Pushed back out of the waypoint: still on to the last point.
/// let v = journey.velocity_of(0, [0.0, 3.0], 1.0);
/// assert!(v[0] > 0.0 && v[1] > 0.0);
/// ```
pub struct Journey {
    stages: Vec<Stage>,
    last: Box<dyn VelocityField>,
    progress: Arc<JourneyProgress>,
}

impl Journey {
    /// The waypoints in order, the field after the last, and where the stages are kept
    /// (one entry per person of the population).
    pub fn new(
        stages: Vec<Stage>,
        last: Box<dyn VelocityField>,
        progress: Arc<JourneyProgress>,
    ) -> Self {
        Self {
            stages,
            last,
            progress,
        }
    }

    /// The waypoints.
    pub fn stages(&self) -> &[Stage] {
        &self.stages
    }
}

impl VelocityField for Journey {
    /// Without a person: the first stage's field.
    fn velocity(&self, p: [f64; 2], speed: f64) -> [f64; 2] {
        match self.stages.first() {
            Some(s) => s.field.velocity(p, speed),
            None => self.last.velocity(p, speed),
        }
    }

    fn velocity_of(&self, person: usize, p: [f64; 2], speed: f64) -> [f64; 2] {
        let mut stage = self.progress.stage(person);
        while stage < self.stages.len() && self.stages[stage].target.is_reached(p) {
            stage += 1;
        }
        self.progress.0[person].store(stage, Ordering::Relaxed);
        match self.stages.get(stage) {
            Some(s) => s.field.velocity(p, speed),
            None => self.last.velocity(p, speed),
        }
    }

    fn describe(&self) -> String {
        let stages: Vec<String> = self.stages.iter().map(|s| s.field.describe()).collect();
        format!(
            "a journey: {}, then {}",
            stages.join(", then "),
            self.last.describe()
        )
    }
}
