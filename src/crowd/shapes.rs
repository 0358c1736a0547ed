//! People against walls and obstacles: exact segments and disks, fixed or moving.

use super::verlet::{self, Anchor, ListPolicy, NeighbourSearch};
use super::Population;
use crate::constraint::{
    linearize, second_order, ConstraintFamily, ConstraintKernel, FamilyKind, LinearizedRow,
    SecondOrderData, Travel,
};
use num_dual::DualNum;
use serde::{Deserialize, Serialize};
use std::sync::{Arc, Mutex};

/// How a wall or obstacle moves: its displacement `o(t)` from where it was declared.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Motion {
    /// Does not move.
    Static,
    /// `o(t) = t·v`.
    Velocity([f64; 2]),
    /// Piecewise linear through `(tₖ, oₖ)` (times increasing), constant before the first and
    /// after the last waypoint.
    Path(Vec<(f64, [f64; 2])>),
}

impl Motion {
    /// Whether it moves at all.
    pub fn is_static(&self) -> bool {
        match self {
            Motion::Static => true,
            Motion::Velocity(v) => v[0] == 0.0 && v[1] == 0.0,
            Motion::Path(p) => p.windows(2).all(|w| w[0].1 == w[1].1),
        }
    }

    /// The length of the path in `(t0, t1)` and its largest speed there, when a waypoint lies
    /// strictly inside that interval; `None` otherwise (the motion is linear there, or static).
    pub fn travel_within(&self, t0: f64, t1: f64) -> Option<Travel> {
        let Motion::Path(p) = self else {
            return None;
        };
        // Waypoints are in time order: the first after t0, found by bisection, since the
        // stepper asks this of every person against the shape at every step.
        let next = p.partition_point(|&(t, _)| t <= t0);
        if !p.get(next).is_some_and(|&(t, _)| t < t1) {
            return None;
        }
        let mut travel = Travel {
            distance: 0.0,
            max_speed: 0.0,
        };
        for w in p.windows(2) {
            let ((ta, a), (tb, b)) = (w[0], w[1]);
            let overlap = tb.min(t1) - ta.max(t0);
            if overlap > 0.0 {
                let speed = (b[0] - a[0]).hypot(b[1] - a[1]) / (tb - ta);
                travel.distance += speed * overlap;
                travel.max_speed = travel.max_speed.max(speed);
            }
        }
        Some(travel)
    }

    /// Pushes onto `out` the times of the path's waypoints strictly inside `(t0, t1)`.
    pub fn waypoints_within(&self, t0: f64, t1: f64, out: &mut Vec<f64>) {
        if let Motion::Path(p) = self {
            let first = p.partition_point(|&(t, _)| t <= t0);
            out.extend(p[first..].iter().map(|&(t, _)| t).take_while(|&t| t < t1));
        }
    }

    /// `o(t)`, generic so that `∂ₜ` comes by autodiff.
    pub fn offset<D: DualNum<Primitive = f64> + Copy>(&self, t: D) -> [D; 2] {
        match self {
            Motion::Static => [D::from(0.0), D::from(0.0)],
            Motion::Velocity(v) => [t * v[0], t * v[1]],
            Motion::Path(p) => {
                let tr = t.re();
                if p.is_empty() {
                    return [D::from(0.0), D::from(0.0)];
                }
                if tr <= p[0].0 {
                    return [D::from(p[0].1[0]), D::from(p[0].1[1])];
                }
                for w in p.windows(2) {
                    let ((t0, o0), (t1, o1)) = (w[0], w[1]);
                    if tr <= t1 {
                        let s = (t - t0) * (1.0 / (t1 - t0));
                        return [s * (o1[0] - o0[0]) + o0[0], s * (o1[1] - o0[1]) + o0[1]];
                    }
                }
                let last = p[p.len() - 1].1;
                [D::from(last[0]), D::from(last[1])]
            }
        }
    }
}

/// A wall or obstacle shape, as declared at `t = 0`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Shape {
    /// The segment `[a, b]` (two-sided: a disk may be on either side).
    Segment {
        /// One end.
        a: [f64; 2],
        /// The other end.
        b: [f64; 2],
    },
    /// A disk obstacle.
    Disk {
        /// Centre.
        center: [f64; 2],
        /// Radius.
        radius: f64,
    },
}

/// The four sides of the rectangle `[x0, x1] × [y0, y1]` as fixed segments.
pub fn rectangle_walls(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<(Shape, Motion)> {
    [
        ([x0, y0], [x1, y0]),
        ([x1, y0], [x1, y1]),
        ([x1, y1], [x0, y1]),
        ([x0, y1], [x0, y0]),
    ]
    .into_iter()
    .map(|(a, b)| (Shape::Segment { a, b }, Motion::Static))
    .collect()
}

/// A shape, how it moves, and the radius of the person it is paired with.
#[derive(Debug, Clone, PartialEq)]
pub struct ShapeParams {
    /// The shape.
    pub shape: Shape,
    /// Its motion.
    pub motion: Motion,
    /// The person's radius.
    pub person_radius: f64,
}

/// `g(t, z) = dist(z, S(t)) − r` on a person's centre `z = (x, y)`: convex in `z` (distance to
/// a convex set), `|∇g| = 1`, and affine in `z` where the closest point of a segment is
/// interior.
#[derive(Debug, Clone, Copy, Default)]
pub struct PersonShapeKernel;

impl ConstraintKernel<2> for PersonShapeKernel {
    type Params = ShapeParams;

    fn value<D: DualNum<Primitive = f64> + Copy>(&self, p: &ShapeParams, t: D, z: [D; 2]) -> D {
        let o = p.motion.offset(t);
        match &p.shape {
            Shape::Disk { center, radius } => {
                let dx = z[0] - o[0] - center[0];
                let dy = z[1] - o[1] - center[1];
                (dx * dx + dy * dy).sqrt() - (*radius + p.person_radius)
            }
            Shape::Segment { a, b } => {
                // Work relative to the moving end a(t) = a + o(t).
                let px = z[0] - o[0] - a[0];
                let py = z[1] - o[1] - a[1];
                let ab = [b[0] - a[0], b[1] - a[1]];
                let len2 = ab[0] * ab[0] + ab[1] * ab[1];
                let s = (px * ab[0] + py * ab[1]) * (1.0 / len2);
                // The closest point: an end, or the interior point a + s(b − a). The branch is
                // taken on the real part; the derivative is that of the active piece, which is
                // the derivative of the distance (it is C¹ across the switch).
                let (cx, cy) = if s.re() <= 0.0 {
                    (D::from(0.0), D::from(0.0))
                } else if s.re() >= 1.0 {
                    (D::from(ab[0]), D::from(ab[1]))
                } else {
                    (s * ab[0], s * ab[1])
                };
                let dx = px - cx;
                let dy = py - cy;
                (dx * dx + dy * dy).sqrt() - p.person_radius
            }
        }
    }
}

/// Every present person against every shape: member `i·S + s` is person `i` against shape `s`.
///
/// Candidates are found by testing each person against each shape (`O(N·S)`, with `S` the
/// handful of walls and obstacles of a room), kept as a neighbour list that answers the next
/// steps' queries for as long as the displacements since prove it complete (a Verlet list);
/// members with `g > cutoff` are omitted and the stepper's culling proof covers them with the
/// drift bound `max_i |Δᵢ|` (`|∇g| = 1` on one person's two coordinates).
pub struct PersonShapes {
    name: String,
    population: Arc<Population>,
    shapes: Vec<(Shape, Motion)>,
    moving: bool,
    scratch: Mutex<ShapeScratch>,
}

impl PersonShapes {
    /// `name` (e.g. "walls"), the people, and the shapes with their motions.
    pub fn new(
        name: impl Into<String>,
        population: Arc<Population>,
        shapes: Vec<(Shape, Motion)>,
    ) -> Self {
        let moving = shapes.iter().any(|(_, m)| !m.is_static());
        Self {
            name: name.into(),
            population,
            shapes,
            moving,
            scratch: Mutex::new(ShapeScratch::default()),
        }
    }

    /// The shapes.
    pub fn shapes(&self) -> &[(Shape, Motion)] {
        &self.shapes
    }

    fn split(&self, index: usize) -> (usize, usize) {
        (index / self.shapes.len(), index % self.shapes.len())
    }

    fn params(&self, person: usize, shape: usize) -> ShapeParams {
        let (s, m) = &self.shapes[shape];
        ShapeParams {
            shape: s.clone(),
            motion: m.clone(),
            person_radius: self.population.radius(person),
        }
    }

    /// Each shape where it is at `t`, with its bounding box, into `placed`.
    fn place(&self, t: f64, placed: &mut Vec<Placed>) {
        placed.clear();
        placed.extend(self.shapes.iter().map(|(shape, motion)| {
            let o: [f64; 2] = motion.offset(t);
            let shape = match *shape {
                Shape::Segment { a, b } => Shape::Segment {
                    a: [a[0] + o[0], a[1] + o[1]],
                    b: [b[0] + o[0], b[1] + o[1]],
                },
                Shape::Disk { center, radius } => Shape::Disk {
                    center: [center[0] + o[0], center[1] + o[1]],
                    radius,
                },
            };
            let bbox = match shape {
                Shape::Segment { a, b } => [
                    a[0].min(b[0]),
                    a[1].min(b[1]),
                    a[0].max(b[0]),
                    a[1].max(b[1]),
                ],
                Shape::Disk { center, radius } => [
                    center[0] - radius,
                    center[1] - radius,
                    center[0] + radius,
                    center[1] + radius,
                ],
            };
            Placed {
                shape,
                offset: o,
                bbox,
            }
        }));
    }

    /// The plain search: every present person against every `placed` shape, person by person.
    fn plain_search(&self, placed: &[Placed], q: &[f64], cutoff: f64, out: &mut Vec<usize>) {
        for i in 0..self.population.len() {
            if self.population.is_present(q, i) {
                self.members_within(placed, q, i, cutoff, out);
            }
        }
    }

    /// Pushes the members of person `i` against each of the shapes `placed` that pass
    /// [`member_within`](Self::member_within), in the shapes' order.
    fn members_within(
        &self,
        placed: &[Placed],
        q: &[f64],
        i: usize,
        cutoff: f64,
        out: &mut Vec<usize>,
    ) {
        for (s, shape) in placed.iter().enumerate() {
            if self.member_within(shape, q, i, cutoff) {
                out.push(i * placed.len() + s);
            }
        }
    }

    /// Whether person `i` may have `g ≤ cutoff` against the `placed` shape: a person whose
    /// centre is farther than `r + cutoff` from the shape's box has `g > cutoff` and is
    /// rejected without evaluating `g`; otherwise `g` is evaluated in plain floating point
    /// (the kernel's formula) and kept up to a slack far above the kernel's other roundings
    /// (returning more is allowed).
    fn member_within(&self, placed: &Placed, q: &[f64], i: usize, cutoff: f64) -> bool {
        let p = [q[2 * i], q[2 * i + 1]];
        let slack = 1e-12 * (1.0 + p[0].abs() + p[1].abs() + cutoff.abs());
        let radius = self.population.radius(i);
        let reach = radius + cutoff + slack;
        let bbox = placed.bbox;
        let dx = (bbox[0] - p[0]).max(p[0] - bbox[2]).max(0.0);
        let dy = (bbox[1] - p[1]).max(p[1] - bbox[3]).max(0.0);
        if dx > reach || dy > reach {
            return false;
        }
        let g = match placed.shape {
            Shape::Segment { a, b } => super::segment_distance(p, a, b),
            Shape::Disk { center, radius } => {
                ((p[0] - center[0]).powi(2) + (p[1] - center[1]).powi(2)).sqrt() - radius
            }
        } - radius;
        g <= cutoff + slack
    }
}

/// A shape where it is at the time of a query: the shape moved by its offset, the offset, and
/// the moved shape's bounding box.
#[derive(Debug, Clone)]
struct Placed {
    shape: Shape,
    offset: [f64; 2],
    bbox: [f64; 4],
}

/// The shapes placed at the last query's time, and the neighbour list.
#[derive(Debug, Default)]
struct ShapeScratch {
    placed: Vec<Placed>,
    list: ShapeList,
}

/// A Verlet list of the members `(i, s)` with `g_is ≤ reach` at the anchor (people at the
/// anchor's positions, shapes at its time). `g_is = dist(qᵢ − o_s(t), S_s) − rᵢ` changes by at
/// most `|Δqᵢ| + |Δo_s|` (a distance is 1-Lipschitz), so the list holds every member with
/// `g_is ≤ c` at a query while `c + m₁ + max_s |Δo_s| ≤ reach`, `m₁` the largest displacement
/// of a present person since the anchor. The members are tested again at the query by the
/// plain search's own test, in the plain search's order (person by person), so the answer is
/// the plain search's, member for member.
#[derive(Debug, Default)]
struct ShapeList {
    anchor: Anchor,
    /// Each shape's offset at the anchor's time.
    offsets: Vec<[f64; 2]>,
    reach: f64,
    /// Members `(person, shape)`, person by person.
    members: Vec<(u32, u32)>,
    policy: ListPolicy,
}

impl NeighbourSearch for ShapeList {
    fn policy_and_anchor(&mut self) -> (&mut ListPolicy, &mut Anchor) {
        (&mut self.policy, &mut self.anchor)
    }
}

impl ShapeList {
    /// Pushes the members with `g ≤ cutoff` at `q` (shapes `placed` at the query's time) and
    /// returns `true`, from the list or from one built now; or returns `false` without pushing
    /// when the plain search should answer (see [`ListPolicy`]).
    fn answer(
        &mut self,
        fam: &PersonShapes,
        placed: &[Placed],
        q: &[f64],
        cutoff: f64,
        out: &mut Vec<usize>,
    ) -> bool {
        verlet::answer(
            self,
            |list| list.select(fam, placed, q, cutoff, out),
            |list| list.rebuild(fam, placed, q, cutoff),
        )
    }

    /// Pushes the members with `g ≤ cutoff` and returns `true`, or returns `false` without
    /// pushing when the list cannot be proven to hold them all.
    fn select(
        &mut self,
        fam: &PersonShapes,
        placed: &[Placed],
        q: &[f64],
        cutoff: f64,
        out: &mut Vec<usize>,
    ) -> bool {
        let pop = &fam.population;
        if self.offsets.len() != placed.len() {
            return false;
        }
        let Some(moved) = self.anchor.moved(pop, q) else {
            return false;
        };
        let shift = placed
            .iter()
            .zip(&self.offsets)
            .map(|(p, o)| (p.offset[0] - o[0]).hypot(p.offset[1] - o[1]))
            .fold(0.0, f64::max);
        let m1 = moved.largest[0];
        // The plain search keeps members up to `cutoff + slack` (its `slack`, at most the first
        // term), and distances are computed to a few ulps (the second).
        let margin = 2e-12 * (1.0 + moved.extent + cutoff.abs())
            + 1e-9 * (self.reach + pop.max_radius() + m1 + shift);
        // Written so that a NaN (a shape's offset that is not a number) fails it.
        let proven = cutoff.max(0.0) + m1 + shift + margin <= self.reach;
        if !proven {
            return false;
        }
        let present = self.anchor.present();
        let shapes = placed.len();
        for &(i, s) in &self.members {
            let (i, s) = (i as usize, s as usize);
            if present[i] && fam.member_within(&placed[s], q, i, cutoff) {
                out.push(i * shapes + s);
            }
        }
        true
    }

    /// Builds the list at `q` (shapes `placed` at its time) for cutoffs up to `cutoff + skin`.
    fn rebuild(&mut self, fam: &PersonShapes, placed: &[Placed], q: &[f64], cutoff: f64) {
        let pop = &fam.population;
        let cutoff = cutoff.max(0.0);
        let reach = cutoff + verlet::skin(pop, cutoff);
        self.members.clear();
        let mut listed = Vec::new();
        for i in 0..pop.len() {
            if !pop.is_present(q, i) {
                continue;
            }
            listed.push(i);
            for (s, shape) in placed.iter().enumerate() {
                if fam.member_within(shape, q, i, reach) {
                    self.members.push((i as u32, s as u32));
                }
            }
        }
        self.anchor.set(pop, q, listed);
        self.offsets.clear();
        self.offsets.extend(placed.iter().map(|p| p.offset));
        self.reach = reach;
        self.policy.built();
    }
}

impl ConstraintFamily for PersonShapes {
    fn name(&self) -> &str {
        &self.name
    }

    fn kind(&self) -> FamilyKind {
        FamilyKind::PersonShapes
    }

    fn count(&self) -> usize {
        self.population.len() * self.shapes.len()
    }

    fn is_time_dependent(&self) -> bool {
        self.moving
    }

    fn is_affine(&self) -> bool {
        false
    }

    /// `dist(z, S) − r` is smooth off the shape itself (`|∇g| = 1`, on the person's two
    /// coordinates): the margin is the smallest `rᵢ` (plus the obstacle's radius for disks).
    fn a0_margin(&self) -> Option<f64> {
        let r_min = self
            .population
            .radii()
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        self.shapes
            .iter()
            .map(|(s, _)| match s {
                Shape::Segment { .. } => r_min,
                Shape::Disk { radius, .. } => r_min + radius,
            })
            .reduce(f64::min)
            .filter(|v| v.is_finite())
    }

    /// The shape's path within `(t0, t1)`: `g` is a distance minus radii, 1-Lipschitz in the
    /// shape's position.
    fn travel_within(&self, index: usize, t0: f64, t1: f64) -> Option<Travel> {
        let (_, shape) = self.split(index);
        self.shapes[shape].1.travel_within(t0, t1)
    }

    fn waypoints_within(&self, t0: f64, t1: f64, out: &mut Vec<f64>) {
        for (_, motion) in &self.shapes {
            motion.waypoints_within(t0, t1, out);
        }
    }

    fn describe(&self, index: usize) -> String {
        let (i, s) = self.split(index);
        let what = match &self.shapes[s].0 {
            Shape::Segment { a, b } => {
                let n = crate::numbers::display_number;
                format!(
                    "segment ({}, {})–({}, {})",
                    n(a[0]),
                    n(a[1]),
                    n(b[0]),
                    n(b[1])
                )
            }
            Shape::Disk { center, radius } => {
                format!("disk of radius {radius} at ({}, {})", center[0], center[1])
            }
        };
        format!("person {i} against {} #{s} ({what})", self.name)
    }

    fn culls(&self) -> bool {
        true
    }

    fn candidates(&self, t: f64, q: &[f64], cutoff: f64, out: &mut Vec<usize>) {
        let mut scratch = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        let ShapeScratch { placed, list } = &mut *scratch;
        self.place(t, placed);
        let pop = &self.population;
        if cutoff.is_finite()
            && u32::try_from(pop.len()).is_ok()
            && list.answer(self, placed, q, cutoff, out)
        {
            return;
        }
        self.plain_search(placed, q, cutoff, out);
    }

    fn linearization_drift_bound(&self, _t: f64, q: &[f64], x: &[f64]) -> f64 {
        self.population.largest_displacement(q, x)
    }

    fn linearize(&self, index: usize, t: f64, q: &[f64], want_dt: bool, out: &mut LinearizedRow) {
        let (i, s) = self.split(index);
        let lin = linearize(
            &PersonShapeKernel,
            &self.params(i, s),
            t,
            [q[2 * i], q[2 * i + 1]],
            want_dt && self.moving,
        );
        out.value = lin.value;
        out.dt = if want_dt {
            Some(lin.dt.unwrap_or(0.0))
        } else {
            None
        };
        out.columns.clear();
        out.columns.extend_from_slice(&[2 * i, 2 * i + 1]);
        out.gradient.clear();
        out.gradient.extend_from_slice(&lin.gradient);
    }

    fn value(&self, index: usize, t: f64, q: &[f64], _: &mut LinearizedRow) -> f64 {
        let (i, s) = self.split(index);
        PersonShapeKernel.value(&self.params(i, s), t, [q[2 * i], q[2 * i + 1]])
    }

    fn second_order(&self, index: usize, t: f64, q: &[f64]) -> SecondOrderData {
        let (i, s) = self.split(index);
        let so = second_order(
            &PersonShapeKernel,
            &self.params(i, s),
            t,
            [q[2 * i], q[2 * i + 1]],
        );
        so.on_columns(vec![2 * i, 2 * i + 1])
    }

    fn min_dimension(&self) -> usize {
        2 * self.population.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn travel_within_counts_the_path_only_when_it_turns_inside_the_interval() {
        // 3 m right in 1 s, then 4 m up in 1 s, then still.
        let path = Motion::Path(vec![
            (1.0, [0.0, 0.0]),
            (2.0, [3.0, 0.0]),
            (3.0, [3.0, 4.0]),
        ]);
        // No waypoint strictly inside: linear there (or still), left to the derivatives.
        assert_eq!(path.travel_within(1.0, 2.0), None);
        assert_eq!(path.travel_within(0.0, 1.0), None);
        assert_eq!(path.travel_within(3.0, 9.0), None);
        assert_eq!(Motion::Velocity([1.0, 0.0]).travel_within(0.0, 5.0), None);
        assert_eq!(Motion::Static.travel_within(0.0, 5.0), None);
        // Half a second of each leg, around the turn at t = 2.
        let t = path.travel_within(1.5, 2.5).unwrap();
        assert!(
            (t.distance - 3.5).abs() < 1e-12 && t.max_speed == 4.0,
            "{t:?}"
        );
        // From before the start to after the end: the whole path, 7 m.
        let t = path.travel_within(0.0, 5.0).unwrap();
        assert!(
            (t.distance - 7.0).abs() < 1e-12 && t.max_speed == 4.0,
            "{t:?}"
        );
    }

    #[test]
    fn waypoints_within_lists_the_turns_strictly_inside_the_interval() {
        let path = Motion::Path(vec![
            (1.0, [0.0, 0.0]),
            (2.0, [3.0, 0.0]),
            (3.0, [3.0, 4.0]),
        ]);
        let within = |t0, t1| {
            let mut out = Vec::new();
            path.waypoints_within(t0, t1, &mut out);
            out
        };
        assert_eq!(within(0.0, 5.0), vec![1.0, 2.0, 3.0]);
        assert_eq!(within(1.0, 3.0), vec![2.0]);
        assert_eq!(within(1.5, 2.0), Vec::<f64>::new());
        let mut out = Vec::new();
        Motion::Velocity([1.0, 0.0]).waypoints_within(0.0, 5.0, &mut out);
        assert!(out.is_empty());
    }

    /// The plain search's answer: every present person against every placed shape.
    fn plain(fam: &PersonShapes, t: f64, q: &[f64], cutoff: f64) -> Vec<usize> {
        let mut placed = Vec::new();
        fam.place(t, &mut placed);
        let mut out = Vec::new();
        fam.plain_search(&placed, q, cutoff, &mut out);
        out
    }

    /// Lists built, and queries they answered.
    fn lists_used(fam: &PersonShapes) -> (usize, usize) {
        let policy = &fam.scratch.lock().unwrap().list.policy;
        (policy.builds(), policy.answered())
    }

    /// A room's walls, a pillar, a wall sliding at constant speed and one on a path, with a
    /// crowd walking in small random steps (now and then scattered afresh) while time runs:
    /// every answer is the plain search's, member for member and in its order; it holds every
    /// member with `g ≤ cutoff` (evaluated by the family's own `value`) and nothing beyond the
    /// slack; and lists are reused for most queries.
    #[test]
    fn the_walls_list_answers_as_the_plain_search_while_walls_move() {
        // Near the origin, and far from it (where rounding is 1e5 times coarser).
        for o in [0.0, 1e5 + 0.37] {
            walls_list_against_plain_search(o);
        }
    }

    fn walls_list_against_plain_search(o: f64) {
        let n = 100;
        let radii: Vec<f64> = (0..n).map(|i| 0.15 + 0.02 * (i % 5) as f64).collect();
        let pop = Arc::new(Population::new(radii));
        let mut shapes = rectangle_walls(o, o, o + 8.0, o + 8.0);
        shapes.push((
            Shape::Disk {
                center: [o + 4.0, o + 4.0],
                radius: 0.5,
            },
            Motion::Static,
        ));
        shapes.push((
            Shape::Segment {
                a: [o + 1.0, o + 2.0],
                b: [o + 3.0, o + 2.0],
            },
            Motion::Velocity([0.0, 0.5]),
        ));
        shapes.push((
            Shape::Segment {
                a: [o + 6.0, o + 1.0],
                b: [o + 6.0, o + 3.0],
            },
            Motion::Path(vec![
                (0.0, [0.0, 0.0]),
                (1.0, [-1.0, 0.5]),
                (2.0, [0.0, 0.0]),
            ]),
        ));
        let fam = PersonShapes::new("walls", Arc::clone(&pop), shapes);
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let mut q: Vec<f64> = (0..2 * n).map(|_| o + rng.gen_range(0.3..7.7)).collect();
        let queries = 300;
        for k in 0..queries {
            let t = 0.01 * k as f64;
            if k % 100 == 50 {
                q.iter_mut().for_each(|v| *v = o + rng.gen_range(0.3..7.7));
            } else {
                q.iter_mut().for_each(|v| *v += rng.gen_range(-0.01..0.01));
            }
            let cutoff = [0.0, 0.03, 0.1, 0.3][k % 4];
            let mut found = Vec::new();
            fam.candidates(t, &q, cutoff, &mut found);
            assert_eq!(found, plain(&fam, t, &q, cutoff), "origin {o}, query {k}");
            let mut scratch = LinearizedRow::default();
            for m in 0..fam.count() {
                let g = fam.value(m, t, &q, &mut scratch);
                let kept = found.contains(&m);
                assert!(
                    kept || g > cutoff,
                    "origin {o}, query {k}: member {m} at g = {g} missed"
                );
                // The plain search's slack grows with the coordinates (1e-12 relative).
                let slack = 1e-9 + 1e-11 * o;
                assert!(
                    !kept || g <= cutoff + slack,
                    "origin {o}, query {k}: member {m} at g = {g} kept"
                );
            }
        }
        let (builds, answered) = lists_used(&fam);
        assert!(
            (5..queries / 3).contains(&builds) && answered >= queries * 9 / 10,
            "origin {o}: {builds} lists answered {answered} of {queries} queries"
        );
    }

    /// People standing still while a wall slides towards them: only the wall's own movement
    /// invalidates the list, and every answer is still the plain search's.
    #[test]
    fn a_wall_moving_towards_people_standing_still_is_not_missed() {
        let pop = Arc::new(Population::new(vec![0.2; 3]));
        let wall = (
            Shape::Segment {
                a: [0.0, 0.0],
                b: [10.0, 0.0],
            },
            Motion::Velocity([0.0, 1.0]),
        );
        let fam = PersonShapes::new("walls", pop, vec![wall]);
        let q = [1.0, 3.0, 5.0, 3.5, 9.0, 6.0];
        let mut reached = 0;
        for k in 0..300 {
            let t = 0.01 * k as f64;
            let mut found = Vec::new();
            fam.candidates(t, &q, 0.05, &mut found);
            assert_eq!(found, plain(&fam, t, &q, 0.05), "t = {t}");
            reached = reached.max(found.len());
        }
        // The wall (at y = t) came within the cutoff of the nearest person (y = 3) from
        // t = 2.75 on, and of nobody else.
        assert_eq!(reached, 1);
        // Reach 0.25 (the cutoff and a skin of the largest radius), so a list lasts while the
        // wall moves 0.2: 20 queries of 0.01.
        let (builds, answered) = lists_used(&fam);
        assert!(
            (14..=16).contains(&builds) && answered == 300,
            "{builds} lists answered {answered} of 300 queries"
        );
    }

    /// The list answers exactly while `c + m₁ + shift + margin ≤ reach`, with the margin
    /// `2e-12 (1 + extent + |c|) + 1e-9 (reach + r_max + m₁ + shift)` (the plain search's
    /// slack, then rounding): a person far from the origin moved, and a far wall slid, so that
    /// the slack left is 1.1 and then 0.9 times that margin; the list is kept and then rebuilt.
    #[test]
    fn the_walls_list_holds_up_to_its_margin_and_no_further() {
        let (r, cutoff, x0, shift) = (10.0, 0.1, 1e4, 4.5);
        let reach = cutoff + r; // the skin is the largest radius here
        let wall = (
            Shape::Segment {
                a: [0.0, 1e3],
                b: [1.0, 1e3],
            },
            Motion::Velocity([shift, 0.0]),
        );
        for (fraction, rebuilt) in [(1.1, false), (0.9, true)] {
            let fam = PersonShapes::new(
                "walls",
                Arc::new(Population::new(vec![r])),
                vec![wall.clone()],
            );
            // At (x0/2, x0/2): `extent`, |x| + |y|, is x0.
            for _ in 0..crate::crowd::verlet::MIN_SERVED {
                let mut found = Vec::new();
                fam.candidates(0.0, &[0.5 * x0, 0.5 * x0], cutoff, &mut found);
                assert!(found.is_empty());
            }
            assert_eq!(lists_used(&fam).0, 1);
            let margin =
                |m1: f64| 2e-12 * (1.0 + (x0 - m1) + cutoff) + 1e-9 * (reach + r + m1 + shift);
            // Solve reach − cutoff − m₁ − shift = fraction · margin(m₁) for m₁ (about 5.5).
            let mut m1 = reach - cutoff - shift;
            for _ in 0..4 {
                m1 = reach - cutoff - shift - fraction * margin(m1);
            }
            let mut found = Vec::new();
            fam.candidates(1.0, &[0.5 * x0 - m1, 0.5 * x0], cutoff, &mut found);
            assert!(found.is_empty());
            assert_eq!(
                lists_used(&fam).0,
                1 + usize::from(rebuilt),
                "slack of {fraction} margins"
            );
        }
    }
}
