//! A round arena: every person kept inside a circle, `|zᵢ − c| ≤ R − rᵢ`. Each person's
//! constraint `gᵢ = (R − rᵢ) − |zᵢ − c|` is concave ([`Curvature::Concave`]: the allowed set is
//! a disk, convex), so each step projects people onto the disk itself rather than onto its
//! tangent lines; with the pairs (the paper's class) the problem is mixed.

use super::Population;
use crate::constraint::{
    linearize, second_order, ConstraintFamily, ConstraintKernel, Curvature, FamilyKind,
    LinearizedRow, SecondOrderData,
};
use num_dual::DualNum;
use std::sync::Arc;

/// `g(z) = ρ − |z − c|` with params `(c, ρ)`: inside the circle of radius `ρ` about `c`.
/// Concave; smooth except at `c`, where `|∇g| = 1` fails (a person exactly at the centre is
/// never near the wall, and never a candidate).
#[derive(Debug, Clone, Copy, Default)]
pub struct InsideCircleKernel;

impl ConstraintKernel<2> for InsideCircleKernel {
    type Params = ([f64; 2], f64);

    fn value<D: DualNum<Primitive = f64> + Copy>(
        &self,
        (c, rho): &([f64; 2], f64),
        _t: D,
        z: [D; 2],
    ) -> D {
        let (dx, dy) = (z[0] - c[0], z[1] - c[1]);
        -(dx * dx + dy * dy).sqrt() + *rho
    }

    fn is_time_dependent(&self) -> bool {
        false
    }

    fn curvature(&self) -> Curvature {
        Curvature::Concave
    }
}

/// The round wall of an arena of centre `c` and radius `R`: person `i` (member `i`) stays
/// inside the circle of radius `R − rᵢ`. People who have left are dropped.
pub struct ArenaWall {
    population: Arc<Population>,
    center: [f64; 2],
    radius: f64,
}

impl ArenaWall {
    /// The wall of the arena `|z − center| ≤ radius` for `population`.
    pub fn new(population: Arc<Population>, center: [f64; 2], radius: f64) -> Self {
        Self {
            population,
            center,
            radius,
        }
    }

    /// The centre and the radius.
    pub fn circle(&self) -> ([f64; 2], f64) {
        (self.center, self.radius)
    }

    fn params(&self, i: usize) -> ([f64; 2], f64) {
        (self.center, self.radius - self.population.radius(i))
    }

    fn value_at(&self, i: usize, q: &[f64]) -> f64 {
        InsideCircleKernel.value(&self.params(i), 0.0, Population::position(q, i))
    }
}

impl ConstraintFamily for ArenaWall {
    fn name(&self) -> &str {
        "arena"
    }

    fn kind(&self) -> FamilyKind {
        FamilyKind::PersonShapes
    }

    fn count(&self) -> usize {
        self.population.len()
    }

    fn is_time_dependent(&self) -> bool {
        false
    }

    fn is_affine(&self) -> bool {
        false
    }

    fn curvature(&self) -> Curvature {
        Curvature::Concave
    }

    fn describe(&self, index: usize) -> String {
        format!(
            "person {index} against the arena wall (circle of radius {} at ({}, {}))",
            self.radius, self.center[0], self.center[1]
        )
    }

    /// The people within `cutoff` of the wall (a pass over everyone: one number each); who
    /// has not arrived yet is in no constraint, as who has left.
    fn candidates(&self, _t: f64, q: &[f64], cutoff: f64, out: &mut Vec<usize>) {
        let pop = &self.population;
        out.extend((0..pop.len()).filter(|&i| {
            !pop.has_departed(i) && pop.has_arrived(i) && self.value_at(i, q) <= cutoff
        }));
    }

    fn culls(&self) -> bool {
        true
    }

    /// `|∇gᵢ| = 1` on person `i`'s two coordinates: the largest displacement of anyone not
    /// seen leaving.
    fn linearization_drift_bound(&self, _t: f64, q: &[f64], x: &[f64]) -> f64 {
        self.population.largest_displacement(q, x)
    }

    fn linearize(&self, index: usize, t: f64, q: &[f64], want_dt: bool, out: &mut LinearizedRow) {
        let lin = linearize(
            &InsideCircleKernel,
            &self.params(index),
            t,
            Population::position(q, index),
            want_dt,
        );
        out.value = lin.value;
        out.dt = lin.dt;
        out.columns.clear();
        out.columns.extend_from_slice(&[2 * index, 2 * index + 1]);
        out.gradient.clear();
        out.gradient.extend_from_slice(&lin.gradient);
    }

    fn value(&self, index: usize, _t: f64, q: &[f64], _: &mut LinearizedRow) -> f64 {
        self.value_at(index, q)
    }

    fn second_order(&self, index: usize, t: f64, q: &[f64]) -> SecondOrderData {
        let so = second_order(
            &InsideCircleKernel,
            &self.params(index),
            t,
            Population::position(q, index),
        );
        so.on_columns(vec![2 * index, 2 * index + 1])
    }

    fn min_dimension(&self) -> usize {
        2 * self.population.len()
    }

    /// `g` is smooth except at the centre, at distance `R − rᵢ` from the boundary of its set:
    /// but the centre lies *inside* the set, so no margin around the set avoids it. A0 is
    /// then not derivable here.
    fn a0_margin(&self) -> Option<f64> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_person_is_kept_inside_the_circle_less_their_radius() {
        let pop = Population::new(vec![0.5, 0.25]).shared();
        let wall = ArenaWall::new(pop, [1.0, 0.0], 5.0);
        // Person 0 at distance 4 from the centre: 0.5 left; person 1 at 4.9: −0.15.
        let q = [5.0, 0.0, 1.0, 4.9];
        let mut row = LinearizedRow::default();
        assert!((wall.value(0, 0.0, &q, &mut row) - 0.5).abs() < 1e-15);
        assert!((wall.value(1, 0.0, &q, &mut row) + 0.15).abs() < 1e-15);
        let mut out = Vec::new();
        wall.candidates(0.0, &q, 0.0, &mut out);
        assert_eq!(out, vec![1]);
        out.clear();
        wall.candidates(0.0, &q, 0.5, &mut out);
        assert_eq!(out, vec![0, 1]);
        wall.linearize(1, 0.0, &q, false, &mut row);
        assert_eq!(row.columns, vec![2, 3]);
        assert!(row.gradient[0].abs() < 1e-15 && (row.gradient[1] + 1.0).abs() < 1e-15);
        // Concave: the Hessian −(I − n nᵀ)/|z − c| has eigenvalues 0 and −1/|z − c|.
        let so = wall.second_order(0, 0.0, &q);
        assert!((so.hessian[3] + 0.25).abs() < 1e-15 && so.hessian[0].abs() < 1e-15);
        assert_eq!(wall.curvature(), Curvature::Concave);
        // The drift bound is the largest displacement.
        let x = [5.0, 0.3, 1.4, 4.9];
        assert!((wall.linearization_drift_bound(0.0, &q, &x) - 0.4).abs() < 1e-15);
    }
}
