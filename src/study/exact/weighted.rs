//! Exact cases beyond the Euclidean class: a projection in a mass metric, and an equality
//! constraint.

use super::{ExactCase, PointBehindMovingWall};
use crate::constraint::{ConstraintKernel, KernelFamily, Scalar};
use crate::problem::Problem;
use sweeping_api::Metric;

/// `g(t, q) = n·q − c₀ − v t` with params `(n, c₀, v)`: a wall of normal `n` moving at speed
/// `v` along it (in units of `|n|`).
#[derive(Debug, Clone, Copy, Default)]
pub struct ObliqueWallKernel;

impl ConstraintKernel<2> for ObliqueWallKernel {
    type Params = ([f64; 2], f64, f64);

    fn value<D: Scalar>(&self, p: &([f64; 2], f64, f64), t: D, z: [D; 2]) -> D {
        z[0] * p.0[0] + z[1] * p.0[1] - t * p.2 - p.1
    }

    fn is_affine(&self) -> bool {
        true
    }
}

/// A point of the plane with masses `m = (m₁, m₂)` (metric `W = diag(m)`) kept on the side
/// `n·q ≥ c₀ + v t` of a moving wall, driven by `f(t) = d + a cos(ωt) e`:
/// `q' + W⁻¹ N(Q(t), q) ∋ f(t)`.
///
/// Exact solution. The normal cone of the half-plane is spanned by `−n`, so
/// `q' = f + λ W⁻¹n` with `λ ≥ 0`, positive only on the wall: the reaction pushes along
/// `W⁻¹n`, not along `n` (a heavy coordinate moves less). Along `n`, `s = n·q` solves the
/// one-dimensional Skorokhod problem of [`PointBehindMovingWall`] with start `n·q₀`, drift
/// `n·d`, amplitude `a (n·e)`, barrier `c₀ + v t`, and `n·W⁻¹n · Λ(t) = max(0, sup φ)` for
/// `Λ = ∫λ`; so `q(t) = q₀ + ∫₀ᵗ f + Λ(t) W⁻¹n`, in closed form for every `t`.
///
/// The scheme in the metric `W` is the discrete Skorokhod map of the same one-dimensional
/// problem, pushed along the same `W⁻¹n`: first order, as the explicit prediction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassesAgainstMovingWall {
    /// The masses `m₁, m₂ > 0`.
    pub masses: [f64; 2],
    /// The wall's normal `n` (pointing into the allowed side).
    pub normal: [f64; 2],
    /// Start, `n·q₀ ≥ c₀`.
    pub q0: [f64; 2],
    /// The constant part `d` of `f`.
    pub drift: [f64; 2],
    /// The direction `e` of `f`'s oscillation (with `a (n·e) ≠ 0`).
    pub oscillation: [f64; 2],
    /// Amplitude `a`.
    pub a: f64,
    /// Angular frequency `ω > 0`.
    pub omega: f64,
    /// Wall at `t = 0`.
    pub c0: f64,
    /// Wall speed.
    pub v: f64,
    /// Horizon.
    pub t_end: f64,
}

impl Default for MassesAgainstMovingWall {
    /// Masses `(1, 4)`, wall `x₁ + x₂ ≥ t/2`, `q₀ = (¼, ¼)`, `f = (0.3 + cos 2t, −0.3)`,
    /// `T = 6`: along `n` the default [`PointBehindMovingWall`] (caught, pushed, released,
    /// caught again), with a tangential drift; pushed along `W⁻¹n = (1, ¼)`.
    fn default() -> Self {
        Self {
            masses: [1.0, 4.0],
            normal: [1.0, 1.0],
            q0: [0.25, 0.25],
            drift: [0.3, -0.3],
            oscillation: [1.0, 0.0],
            a: 1.0,
            omega: 2.0,
            c0: 0.0,
            v: 0.5,
            t_end: 6.0,
        }
    }
}

impl MassesAgainstMovingWall {
    fn dot(u: [f64; 2], w: [f64; 2]) -> f64 {
        u[0] * w[0] + u[1] * w[1]
    }

    /// The one-dimensional problem along `n`.
    fn along_normal(&self) -> PointBehindMovingWall {
        let n = self.normal;
        PointBehindMovingWall {
            x0: Self::dot(n, self.q0),
            c0: self.c0,
            v: self.v,
            b: Self::dot(n, self.drift),
            a: self.a * Self::dot(n, self.oscillation),
            omega: self.omega,
            t_end: self.t_end,
        }
    }

    /// `W⁻¹n`.
    fn push_direction(&self) -> [f64; 2] {
        [
            self.normal[0] / self.masses[0],
            self.normal[1] / self.masses[1],
        ]
    }
}

impl ExactCase for MassesAgainstMovingWall {
    fn name(&self) -> String {
        "masses-wall".into()
    }

    fn problem(&self) -> Problem {
        let (d, e, a, w) = (self.drift, self.oscillation, self.a, self.omega);
        let mut fam = KernelFamily::new("wall", ObliqueWallKernel);
        fam.push([0, 1], (self.normal, self.c0, self.v), "n·q ≥ c₀ + v t");
        Problem::new(
            self.q0.to_vec(),
            move |t: f64, _q: &[f64], f: &mut [f64]| {
                let c = a * (w * t).cos();
                f[0] = d[0] + c * e[0];
                f[1] = d[1] + c * e[1];
            },
        )
        .with_family(fam)
        .with_metric(Metric::Diagonal(self.masses.to_vec()))
    }

    fn exact(&self, t: f64) -> Vec<f64> {
        let line = self.along_normal();
        // κΛ(t): how far along n the wall has pushed, beyond the free motion.
        let pushed = line.exact(t)[0]
            - (line.x0 + line.b * t + line.a / line.omega * (line.omega * t).sin());
        let kappa = Self::dot(self.normal, self.push_direction());
        let s = (self.omega * t).sin() / self.omega * self.a;
        let u = self.push_direction();
        (0..2)
            .map(|i| {
                self.q0[i] + self.drift[i] * t + s * self.oscillation[i] + pushed / kappa * u[i]
            })
            .collect()
    }

    fn t_end(&self) -> f64 {
        self.t_end
    }
}

/// `h(t, q) = |q − c(t)| − R` with `c(t) = c₀ + v t`, params `(c₀, v, R)`: on a moving circle.
#[derive(Debug, Clone, Copy, Default)]
pub struct OnMovingCircleKernel;

impl ConstraintKernel<2> for OnMovingCircleKernel {
    type Params = ([f64; 2], [f64; 2], f64);

    fn value<D: Scalar>(&self, p: &([f64; 2], [f64; 2], f64), t: D, z: [D; 2]) -> D {
        let (c0, v, r) = *p;
        let dx = z[0] - t * v[0] - c0[0];
        let dy = z[1] - t * v[1] - c0[1];
        (dx * dx + dy * dy).sqrt() - r
    }
}

/// A point held on a circle of radius `R` whose centre moves at velocity `(v, 0)`, driven by
/// `f = (f₁, 0)` with `w = f₁ − v > 0`: `q' + N ∋ f` where `N` is the normal line of the
/// circle (an equality constraint; its multiplier has either sign).
///
/// Exact solution. With `q = c(t) + R(cos θ, sin θ)`, the velocity relative to the centre is
/// the tangential part of `f − c' = (w, 0)`: `R θ' = −w sin θ`, whence
/// `tan(θ/2) = tan(θ₀/2) e^{−w t/R}`: the point slides round to the circle's front (`θ → 0`).
/// The constraint is not affine: the scheme projects onto the tangent line at `q_k`, leaves
/// the circle by `O(h²)` per step (measured,
/// [`StepReport::max_equality_residual`](crate::stepper::StepReport::max_equality_residual))
/// and corrects it at the next step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointOnMovingCircle {
    /// Radius `R`.
    pub radius: f64,
    /// Speed `v` of the centre (along the first axis), from the origin.
    pub v: f64,
    /// The drive `f₁ > v`.
    pub f: f64,
    /// The start angle `θ₀ ∈ (0, π)`.
    pub theta0: f64,
    /// Horizon.
    pub t_end: f64,
}

impl Default for PointOnMovingCircle {
    /// `R = 1`, `v = ½`, `f₁ = 1`, `θ₀ = 2.5`, `T = 4`: from the back of the circle nearly to
    /// its front.
    fn default() -> Self {
        Self {
            radius: 1.0,
            v: 0.5,
            f: 1.0,
            theta0: 2.5,
            t_end: 4.0,
        }
    }
}

impl ExactCase for PointOnMovingCircle {
    fn name(&self) -> String {
        "on-circle".into()
    }

    fn problem(&self) -> Problem {
        let f1 = self.f;
        let mut fam = KernelFamily::new("circle", OnMovingCircleKernel);
        fam.push(
            [0, 1],
            ([0.0, 0.0], [self.v, 0.0], self.radius),
            "|q − c(t)| = R",
        );
        Problem::new(
            self.exact(0.0),
            move |_t: f64, _q: &[f64], f: &mut [f64]| {
                f[0] = f1;
                f[1] = 0.0;
            },
        )
        .with_equality(fam)
    }

    fn exact(&self, t: f64) -> Vec<f64> {
        let w = self.f - self.v;
        let theta = 2.0 * ((0.5 * self.theta0).tan() * (-w * t / self.radius).exp()).atan();
        vec![
            self.v * t + self.radius * theta.cos(),
            self.radius * theta.sin(),
        ]
    }

    fn t_end(&self) -> f64 {
        self.t_end
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::distance;

    /// `q' − f` is a non-negative multiple of `W⁻¹n`, positive only on the wall, and the
    /// point never crosses it (finite differences of the closed form).
    #[test]
    fn the_masses_solution_is_pushed_along_the_inverse_metric_normal() {
        let c = MassesAgainstMovingWall::default();
        let u = c.push_direction();
        let d = 1e-6;
        let mut on_wall = 0;
        for i in 1..600 {
            let t = i as f64 * 0.01 + 0.003;
            let q = c.exact(t);
            let gap = c.normal[0] * q[0] + c.normal[1] * q[1] - c.c0 - c.v * t;
            assert!(gap >= -1e-12, "t = {t}: gap {gap}");
            let (qp, qm) = (c.exact(t + d), c.exact(t - d));
            let vel = [(qp[0] - qm[0]) / (2.0 * d), (qp[1] - qm[1]) / (2.0 * d)];
            let cos = c.a * (c.omega * t).cos();
            let f = [
                c.drift[0] + cos * c.oscillation[0],
                c.drift[1] + cos * c.oscillation[1],
            ];
            let r = [vel[0] - f[0], vel[1] - f[1]];
            // r = λ W⁻¹n: parallel to u, λ ≥ 0, and zero off the wall.
            assert!(
                (r[0] * u[1] - r[1] * u[0]).abs() < 1e-5,
                "t = {t}: {r:?} not along {u:?}"
            );
            let lambda = (r[0] * u[0] + r[1] * u[1]) / (u[0] * u[0] + u[1] * u[1]);
            assert!(lambda >= -1e-5, "t = {t}: λ = {lambda}");
            if gap > 1e-4 {
                assert!(lambda.abs() < 1e-5, "t = {t}: pushed off the wall");
            } else if lambda > 1e-3 {
                on_wall += 1;
            }
        }
        assert!(on_wall > 50, "the wall pushes on {on_wall} samples only");
    }

    #[test]
    fn the_circle_solution_stays_on_the_circle_and_moves_with_the_tangential_drive() {
        let c = PointOnMovingCircle::default();
        let d = 1e-6;
        for i in 0..40 {
            let t = i as f64 * 0.1 + 0.01;
            let q = c.exact(t);
            let centre = [c.v * t, 0.0];
            assert!((distance(&q, &centre) - c.radius).abs() < 1e-12);
            let (qp, qm) = (c.exact(t + d), c.exact(t - d));
            let vel = [(qp[0] - qm[0]) / (2.0 * d), (qp[1] - qm[1]) / (2.0 * d)];
            // q' − f is normal to the circle: no tangential part.
            let n = [(q[0] - centre[0]) / c.radius, (q[1] - centre[1]) / c.radius];
            let r = [vel[0] - c.f, vel[1]];
            assert!((r[0] * n[1] - r[1] * n[0]).abs() < 1e-6, "t = {t}");
        }
    }
}
