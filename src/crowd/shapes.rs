//! People against walls and obstacles: exact segments and disks, fixed or moving.

use super::Population;
use crate::constraint::{
    linearize, second_order, ConstraintFamily, ConstraintKernel, FamilyKind, LinearizedRow,
    SecondOrderData,
};
use num_dual::DualNum;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

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
/// handful of walls and obstacles of a room); members with `g > cutoff` are omitted and the
/// stepper's culling proof covers them with the drift bound `max_i |Δᵢ|` (`|∇g| = 1` on one
/// person's two coordinates).
pub struct PersonShapes {
    name: String,
    population: Arc<Population>,
    shapes: Vec<(Shape, Motion)>,
    moving: bool,
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

    fn describe(&self, index: usize) -> String {
        let (i, s) = self.split(index);
        let what = match &self.shapes[s].0 {
            Shape::Segment { a, b } => {
                let n = crate::stepper::display_number;
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
        let s_count = self.shapes.len();
        // Each shape where it is at t, with its bounding box: a person whose centre is farther
        // than r + cutoff from the box has g > cutoff and is skipped without evaluating g.
        let placed: Vec<(Shape, [f64; 4])> = self
            .shapes
            .iter()
            .map(|(shape, motion)| {
                let o: [f64; 2] = motion.offset(t);
                let moved = match *shape {
                    Shape::Segment { a, b } => Shape::Segment {
                        a: [a[0] + o[0], a[1] + o[1]],
                        b: [b[0] + o[0], b[1] + o[1]],
                    },
                    Shape::Disk { center, radius } => Shape::Disk {
                        center: [center[0] + o[0], center[1] + o[1]],
                        radius,
                    },
                };
                let bbox = match moved {
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
                (moved, bbox)
            })
            .collect();
        for i in 0..self.population.len() {
            if !self.population.is_present(q, i) {
                continue;
            }
            let p = [q[2 * i], q[2 * i + 1]];
            // The kernel computes g with other roundings: a slack far above them keeps every
            // member with g ≤ cutoff (returning more is allowed).
            let slack = 1e-12 * (1.0 + p[0].abs() + p[1].abs() + cutoff.abs());
            let reach = self.population.radius(i) + cutoff + slack;
            for (s, (shape, bbox)) in placed.iter().enumerate() {
                let dx = (bbox[0] - p[0]).max(p[0] - bbox[2]).max(0.0);
                let dy = (bbox[1] - p[1]).max(p[1] - bbox[3]).max(0.0);
                if dx > reach || dy > reach {
                    continue;
                }
                // The kernel's value at t in plain floating point (the same formula).
                let g = match *shape {
                    Shape::Segment { a, b } => super::segment_distance(p, a, b),
                    Shape::Disk { center, radius } => {
                        ((p[0] - center[0]).powi(2) + (p[1] - center[1]).powi(2)).sqrt() - radius
                    }
                } - self.population.radius(i);
                if g <= cutoff + slack {
                    out.push(i * s_count + s);
                }
            }
        }
    }

    fn linearization_drift_bound(&self, _t: f64, q: &[f64], x: &[f64]) -> f64 {
        // The largest squared displacement, then one square root (monotone and correctly
        // rounded, so the same number as the largest root).
        (0..self.population.len())
            .filter(|&i| self.population.is_present(q, i))
            .map(|i| (x[2 * i] - q[2 * i]).powi(2) + (x[2 * i + 1] - q[2 * i + 1]).powi(2))
            .fold(0.0, f64::max)
            .sqrt()
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
        SecondOrderData {
            value: so.value,
            columns: vec![2 * i, 2 * i + 1],
            gradient: so.gradient.to_vec(),
            dt: so.dt,
            hessian: so.hessian.iter().flatten().copied().collect(),
            dt_gradient: so.dt_gradient.to_vec(),
        }
    }

    fn min_dimension(&self) -> usize {
        2 * self.population.len()
    }
}
