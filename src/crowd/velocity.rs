//! Desired velocities: the perturbation `f(q) = (U₁(q₁), …, U_N(q_N))` of the crowd model.
//!
//! A scene composes only the terms it declares: each [`VelocityField`] drives a list of
//! people, and [`DesiredVelocity`] evaluates each term on its people only. No geodesic field
//! is computed unless some people head for the exits.
//!
//! People whose centre is outside the room (they are going through a door, or have left) keep
//! walking straight on: their velocity is their speed times the outward normal of the nearest
//! exit. The dimension of `q` never changes (the convergence study compares configurations).

use super::fast_marching::DistanceField;
use super::population::segment_distance;
use super::Population;
use crate::problem::Perturbation;
use std::sync::Arc;

/// A desired velocity as a function of position, for a person of desired speed `speed`.
///
/// ```
/// use sweeping::crowd::velocity::{TowardsPoint, VelocityField};
/// let field = TowardsPoint { point: [3.0, 4.0] };
/// let v = field.velocity([0.0, 0.0], 2.0);
/// assert!((v[0] - 1.2).abs() < 1e-12 && (v[1] - 1.6).abs() < 1e-12);
/// ```
pub trait VelocityField: Send + Sync {
    /// The velocity at `p`.
    fn velocity(&self, p: [f64; 2], speed: f64) -> [f64; 2];
    /// The velocity of `person` at `p`: [`velocity`](Self::velocity), unless the field
    /// remembers something of each person (a journey, the waypoint they have reached).
    fn velocity_of(&self, person: usize, p: [f64; 2], speed: f64) -> [f64; 2] {
        let _ = person;
        self.velocity(p, speed)
    }
    /// A short description for reports ("towards the nearest exit (geodesic)").
    fn describe(&self) -> String;
}

/// The same velocity everywhere (the person's speed is not used).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantVelocity(pub [f64; 2]);

impl VelocityField for ConstantVelocity {
    fn velocity(&self, _p: [f64; 2], _speed: f64) -> [f64; 2] {
        self.0
    }
    fn describe(&self) -> String {
        format!("constant velocity ({}, {})", self.0[0], self.0[1])
    }
}

/// Straight towards a point at the person's speed, slowing down linearly within
/// [`TowardsPoint::ARRIVAL`] of it (so the field is continuous and vanishes at the point).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TowardsPoint {
    /// The target.
    pub point: [f64; 2],
}

impl TowardsPoint {
    /// Radius of the slow-down zone around the target: `0.1`.
    pub const ARRIVAL: f64 = 0.1;
}

impl VelocityField for TowardsPoint {
    fn velocity(&self, p: [f64; 2], speed: f64) -> [f64; 2] {
        let d = [self.point[0] - p[0], self.point[1] - p[1]];
        let n = (d[0] * d[0] + d[1] * d[1]).sqrt();
        let scale = speed / n.max(Self::ARRIVAL);
        [d[0] * scale, d[1] * scale]
    }
    fn describe(&self) -> String {
        format!("towards the point ({}, {})", self.point[0], self.point[1])
    }
}

/// Towards the nearest exit around the obstacles: speed times the descent direction of the
/// geodesic distance (see [`DistanceField::direction`]).
#[derive(Debug, Clone)]
pub struct TowardsExits {
    /// The distance field.
    pub field: Arc<DistanceField>,
    /// The exits the field leads to, by index from 0 (`None`: every exit), for reports.
    pub exits: Option<Vec<usize>>,
}

impl VelocityField for TowardsExits {
    fn velocity(&self, p: [f64; 2], speed: f64) -> [f64; 2] {
        let d = self.field.direction(p);
        [d[0] * speed, d[1] * speed]
    }
    fn describe(&self) -> String {
        let which = match &self.exits {
            None => "the nearest exit".to_string(),
            Some(e) if e.len() == 1 => format!("exit {}", e[0] + 1),
            Some(e) => {
                let numbers: Vec<String> = e.iter().map(|k| (k + 1).to_string()).collect();
                format!("the nearest of exits {}", numbers.join(", "))
            }
        };
        format!(
            "towards {which} (geodesic, fast marching on a {}×{} grid of cell {})",
            self.field.grid().nx,
            self.field.grid().ny,
            self.field.grid().cell
        )
    }
}

/// Towards a place inside the room (a waypoint) around the obstacles: speed times the descent
/// direction of the geodesic distance to it.
#[derive(Debug, Clone)]
pub struct TowardsTarget {
    /// The distance field to the target.
    pub field: Arc<DistanceField>,
    /// The target, for reports.
    pub target: super::fast_marching::Target,
}

impl VelocityField for TowardsTarget {
    /// Slowing down, near a point, as [`TowardsPoint`] does: a person who stops there does
    /// not oscillate about it.
    fn velocity(&self, p: [f64; 2], speed: f64) -> [f64; 2] {
        use super::fast_marching::Target;
        let d = self.field.direction(p);
        let slow = match self.target {
            Target::Point { .. } => (self.target.distance(p) / TowardsPoint::ARRIVAL).min(1.0),
            Target::Region(_) => 1.0,
        };
        [d[0] * speed * slow, d[1] * speed * slow]
    }
    fn describe(&self) -> String {
        use super::fast_marching::Target;
        let which = match self.target {
            Target::Point { at, reach } => format!("({}, {}) within {reach}", at[0], at[1]),
            Target::Region(r) => format!("the region {r:?}"),
        };
        format!("towards {which} (geodesic)")
    }
}

/// An exit segment and its outward unit normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExitSegment {
    /// One end.
    pub a: [f64; 2],
    /// The other end.
    pub b: [f64; 2],
    /// Unit normal pointing out of the room.
    pub outward: [f64; 2],
}

/// The crowd's desired velocity, composed of the terms a scene declares.
///
/// ```
/// use std::sync::Arc;
/// use sweeping::crowd::{Population, Room};
/// use sweeping::crowd::velocity::{ConstantVelocity, DesiredVelocity};
/// use sweeping::problem::Perturbation;
/// let pop = Population::new(vec![0.2, 0.2]).with_room(Room::rectangle(0.0, 0.0, 5.0, 5.0)).shared();
/// let f = DesiredVelocity::new(pop, vec![1.0, 1.0], Vec::new())
///     .with_term(Box::new(ConstantVelocity([0.5, 0.0])), vec![1]);
/// let mut v = [9.0; 4];
/// f.eval(0.0, &[1.0, 1.0, 2.0, 2.0], &mut v);
/// assert_eq!(v, [0.0, 0.0, 0.5, 0.0]); // person 0 has no term: it stands still
/// ```
pub struct DesiredVelocity {
    population: Arc<Population>,
    speeds: Vec<f64>,
    terms: Vec<(Box<dyn VelocityField>, Vec<usize>)>,
    exits: Vec<ExitSegment>,
    /// When each person starts walking (empty: everybody at once).
    starts: Vec<f64>,
}

impl DesiredVelocity {
    /// No term yet: everybody stands still. `speeds[i]` is person `i`'s desired speed, also
    /// used once the person is outside the room.
    pub fn new(population: Arc<Population>, speeds: Vec<f64>, exits: Vec<ExitSegment>) -> Self {
        Self {
            population,
            speeds,
            terms: Vec::new(),
            exits,
            starts: Vec::new(),
        }
    }

    /// Person `i` stands still (desired velocity zero) while `t < starts[i]`: a pre-movement
    /// (reaction) time. People pushed by others or by obstacles still move.
    ///
    /// # Panics
    /// When `starts` has not one entry per person.
    pub fn with_start_times(mut self, starts: Vec<f64>) -> Self {
        assert_eq!(starts.len(), self.speeds.len(), "one start time per person");
        self.starts = starts;
        self
    }

    /// Adds a term driving `people`.
    pub fn with_term(mut self, field: Box<dyn VelocityField>, people: Vec<usize>) -> Self {
        self.terms.push((field, people));
        self
    }

    /// The terms and who they drive.
    pub fn terms(&self) -> &[(Box<dyn VelocityField>, Vec<usize>)] {
        &self.terms
    }

    /// The outward normal of the exit nearest to `p`, if there is an exit.
    pub fn nearest_exit_normal(&self, p: [f64; 2]) -> Option<[f64; 2]> {
        self.exits
            .iter()
            .map(|e| (segment_distance(p, e.a, e.b), e.outward))
            .min_by(|x, y| x.0.total_cmp(&y.0))
            .map(|(_, n)| n)
    }
}

impl Perturbation for DesiredVelocity {
    fn eval(&self, t: f64, q: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|v| *v = 0.0);
        for (field, people) in &self.terms {
            for &i in people {
                if self.starts.get(i).is_some_and(|&start| t < start)
                    || !self.population.has_arrived(i)
                {
                    continue;
                }
                let p = Population::position(q, i);
                let speed = self.speeds[i];
                // Who has left keeps walking out, even where that path crosses the room again.
                let outside = self.population.has_departed(i) || self.population.outside_room(p);
                // The nearest exit is looked for only for who is outside: it costs a segment
                // distance per exit per person per step, and nobody else uses it.
                let v = match outside.then(|| self.nearest_exit_normal(p)).flatten() {
                    Some(n) => [n[0] * speed, n[1] * speed],
                    None => field.velocity_of(i, p, speed),
                };
                out[2 * i] = v[0];
                out[2 * i + 1] = v[1];
            }
        }
    }

    fn is_time_dependent(&self) -> bool {
        self.starts.iter().any(|&start| start > 0.0)
    }
}
