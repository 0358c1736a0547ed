//! Exact cases of Moreau's class: sweeping by moving **convex** sets.
//!
//! * [`PlayOperator`] — the play operator of hysteresis: `q` kept in the interval
//!   `[u(t) − r, u(t) + r]` for the input `u(t) = A sin(ωt)`, no drift. Both walls are
//!   affine.
//! * [`PointInsideMovingDisk`] — a point kept inside a disk whose centre moves at constant
//!   velocity, pushed outward by a constant drift: the constraint `R − |z − c(t)| ≥ 0` is
//!   concave ([`Curvature::Concave`]), so each step projects onto the disk itself.

use super::ExactCase;
use crate::constraint::{ConstraintKernel, Curvature, KernelFamily};
use crate::problem::Problem;
use num_dual::DualNum;

/// One wall of the play operator's interval: `r + s·(z − A sin(ωt)) ≥ 0` with params
/// `(s, A, ω, r)`, `s = 1` for the lower wall `z ≥ u − r` and `s = −1` for the upper one.
#[derive(Debug, Clone, Copy, Default)]
pub struct PlayWallKernel;

impl ConstraintKernel<1> for PlayWallKernel {
    type Params = (f64, f64, f64, f64);

    fn value<D: DualNum<Primitive = f64> + Copy>(
        &self,
        &(s, a, w, r): &(f64, f64, f64, f64),
        t: D,
        z: [D; 1],
    ) -> D {
        (z[0] - (t * w).sin() * a) * s + r
    }

    fn is_affine(&self) -> bool {
        true
    }
}

/// The play operator: `q' + N([u(t) − r, u(t) + r], q) ∋ 0` with `u(t) = A sin(ωt)`,
/// `|q₀ − u(0)| ≤ r`.
///
/// Exact solution: on each interval where `u` is monotone (between the extrema
/// `ωt = π/2 + kπ`), `q(t) = max(q(s), u(t) − r)` where `u` increases and
/// `q(t) = min(q(s), u(t) + r)` where it decreases, `s` the start of the interval. `q` is at
/// rest until the wall behind it arrives, then moves with it: its velocity jumps from 0 to
/// `u'` at those times (the kinks).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlayOperator {
    /// Amplitude `A` of the input.
    pub amplitude: f64,
    /// Angular frequency `ω > 0` of the input.
    pub omega: f64,
    /// Half-width `r > 0` of the interval.
    pub radius: f64,
    /// Start `q₀`.
    pub q0: f64,
    /// Horizon.
    pub t_end: f64,
}

impl Default for PlayOperator {
    /// `u = sin 2t`, `r = 0.4`, `q₀ = 0`, `T = 6`: caught by the lower wall at
    /// `t = asin(0.4)/2`, left at each extremum of `u`, caught by the other wall once `u` has
    /// turned back by `2r = 0.8`: four kinks within the horizon.
    fn default() -> Self {
        Self {
            amplitude: 1.0,
            omega: 2.0,
            radius: 0.4,
            q0: 0.0,
            t_end: 6.0,
        }
    }
}

impl PlayOperator {
    fn input(&self, t: f64) -> f64 {
        self.amplitude * (self.omega * t).sin()
    }

    /// The ends of the monotone pieces of `u` up to `t`: `0`, the extrema before `t`, `t`.
    fn pieces(&self, t: f64) -> Vec<f64> {
        let mut ends = vec![0.0];
        let mut k = 0.0;
        loop {
            let e = (std::f64::consts::FRAC_PI_2 + k * std::f64::consts::PI) / self.omega;
            if e >= t {
                break;
            }
            ends.push(e);
            k += 1.0;
        }
        ends.push(t);
        ends
    }

    /// `q` at `t`, and the kinks before `t`: the times where a wall catches `q`.
    fn solve(&self, t: f64) -> (f64, Vec<f64>) {
        let mut q = self.q0;
        let mut kinks = Vec::new();
        let ends = self.pieces(t);
        for w in ends.windows(2) {
            let (s0, s1) = (w[0], w[1]);
            let rising = self.input(s1) >= self.input(s0);
            // The wall behind q: u − r when rising, u + r when falling; monotone on the piece.
            let wall = |s: f64| {
                if rising {
                    self.input(s) - self.radius
                } else {
                    self.input(s) + self.radius
                }
            };
            let behind = |s: f64| if rising { wall(s) - q } else { q - wall(s) };
            if behind(s1) > 0.0 {
                // Caught within the piece (or at its start): where `behind` crosses 0.
                if behind(s0) < 0.0 {
                    let (mut lo, mut hi) = (s0, s1);
                    for _ in 0..200 {
                        let mid = 0.5 * (lo + hi);
                        if behind(mid) < 0.0 {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    kinks.push(hi);
                }
                q = wall(s1);
            }
        }
        (q, kinks)
    }
}

impl ExactCase for PlayOperator {
    fn name(&self) -> String {
        "play".into()
    }

    fn problem(&self) -> Problem {
        let (a, w, r) = (self.amplitude, self.omega, self.radius);
        let mut walls = KernelFamily::new("interval", PlayWallKernel);
        walls.push([0], (1.0, a, w, r), "q ≥ u(t) − r");
        walls.push([0], (-1.0, a, w, r), "q ≤ u(t) + r");
        Problem::new(vec![self.q0], crate::problem::NoPerturbation).with_family(walls)
    }

    fn exact(&self, t: f64) -> Vec<f64> {
        vec![self.solve(t).0]
    }

    fn t_end(&self) -> f64 {
        self.t_end
    }

    fn kinks(&self) -> Vec<f64> {
        self.solve(self.t_end).1
    }
}

/// `g(t, z) = R − |z − c₀ − v t|` with params `(c₀, v, R)`: inside a disk moving at constant
/// velocity. Concave in `z`.
#[derive(Debug, Clone, Copy, Default)]
pub struct InsideMovingDiskKernel;

impl ConstraintKernel<2> for InsideMovingDiskKernel {
    type Params = ([f64; 2], [f64; 2], f64);

    fn value<D: DualNum<Primitive = f64> + Copy>(
        &self,
        (c, v, r): &([f64; 2], [f64; 2], f64),
        t: D,
        z: [D; 2],
    ) -> D {
        let dx = z[0] - t * v[0] - c[0];
        let dy = z[1] - t * v[1] - c[1];
        -(dx * dx + dy * dy).sqrt() + *r
    }

    fn curvature(&self) -> Curvature {
        Curvature::Concave
    }
}

/// A point kept inside the disk of radius `R` centred at `c(t) = c₀ + v t`, pushed by the
/// constant drift `f`: `z' + N(D(t), z) ∋ f`.
///
/// Derivation. In the disk's frame, `w = z − c(t)` is pushed by the constant `d = f − v`
/// (speed `s = |d|`, unit `e = d/s`, `p` the unit normal to `e` turned left). Free until
/// `|w₀ + d t| = R`, at `t_c = (−a + √(a² − |w₀|² + R²))/s` with `a = ⟨w₀, e⟩`, at the angle
/// `φ₀` of `w(t_c)` in the frame `(e, p)`. Then it slides: `w = R(cos φ e + sin φ p)`, its
/// velocity the tangential part of `d` (the normal part `s cos φ > 0` pushes outward), so
/// `R φ' = −s sin φ` and `tan(φ/2) = tan(φ₀/2) e^{−s(t − t_c)/R}`: it tends to the point of
/// the circle ahead, `c(t) + R e`, and never leaves the circle. The velocity jumps at `t_c`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointInsideMovingDisk {
    /// Radius `R` of the disk.
    pub radius: f64,
    /// Centre at `t = 0`.
    pub center: [f64; 2],
    /// Velocity of the centre.
    pub velocity: [f64; 2],
    /// Drift `f` (with `f ≠ v`).
    pub drift: [f64; 2],
    /// Start, inside the disk.
    pub start: [f64; 2],
    /// Horizon.
    pub t_end: f64,
}

impl Default for PointInsideMovingDisk {
    /// `R = 1`, centre `(0, 0)` moving at `(¼, 0)`, drift `(1, ½)`, start `(−½, −¼)`,
    /// `T = 4`: contact at `t ≈ 1.72`, then sliding towards the front of the disk.
    fn default() -> Self {
        Self {
            radius: 1.0,
            center: [0.0, 0.0],
            velocity: [0.25, 0.0],
            drift: [1.0, 0.5],
            start: [-0.5, -0.25],
            t_end: 4.0,
        }
    }
}

impl PointInsideMovingDisk {
    /// `(s, e, p)`: the relative drift's speed, its unit vector and the unit normal.
    fn frame(&self) -> (f64, [f64; 2], [f64; 2]) {
        let d = [
            self.drift[0] - self.velocity[0],
            self.drift[1] - self.velocity[1],
        ];
        let s = d[0].hypot(d[1]);
        let e = [d[0] / s, d[1] / s];
        (s, e, [-e[1], e[0]])
    }

    /// `(t_c, φ₀)`: the contact time and angle.
    fn contact(&self) -> (f64, f64) {
        let (s, e, p) = self.frame();
        let w0 = [
            self.start[0] - self.center[0],
            self.start[1] - self.center[1],
        ];
        let a = w0[0] * e[0] + w0[1] * e[1];
        let b = w0[0] * p[0] + w0[1] * p[1];
        let n2 = w0[0] * w0[0] + w0[1] * w0[1];
        let tc = (-a + (a * a - n2 + self.radius * self.radius).sqrt()) / s;
        (tc, b.atan2(a + s * tc))
    }
}

impl ExactCase for PointInsideMovingDisk {
    fn name(&self) -> String {
        "inside-disk".into()
    }

    fn problem(&self) -> Problem {
        let mut fam = KernelFamily::new("disk", InsideMovingDiskKernel);
        fam.push(
            [0, 1],
            (self.center, self.velocity, self.radius),
            "|z − c(t)| ≤ R",
        );
        let f = self.drift;
        Problem::new(
            self.start.to_vec(),
            move |_t: f64, _q: &[f64], out: &mut [f64]| {
                out.copy_from_slice(&f);
            },
        )
        .with_family(fam)
    }

    fn exact(&self, t: f64) -> Vec<f64> {
        let (tc, phi0) = self.contact();
        let c = [
            self.center[0] + self.velocity[0] * t,
            self.center[1] + self.velocity[1] * t,
        ];
        if t <= tc {
            return vec![
                self.start[0] + self.drift[0] * t,
                self.start[1] + self.drift[1] * t,
            ];
        }
        let (s, e, p) = self.frame();
        let phi = 2.0 * ((0.5 * phi0).tan() * (-s * (t - tc) / self.radius).exp()).atan();
        let (cos, sin) = (phi.cos(), phi.sin());
        vec![
            c[0] + self.radius * (cos * e[0] + sin * p[0]),
            c[1] + self.radius * (cos * e[1] + sin * p[1]),
        ]
    }

    fn t_end(&self) -> f64 {
        self.t_end
    }

    fn kinks(&self) -> Vec<f64> {
        vec![self.contact().0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn play_solution_stays_in_the_interval_and_rests_inside_it() {
        let c = PlayOperator::default();
        let d = 1e-6;
        for i in 1..600 {
            let t = i as f64 * 0.01 + 0.003;
            let (q, u) = (c.exact(t)[0], c.input(t));
            assert!((q - u).abs() <= c.radius + 1e-12, "t = {t}");
            let v = (c.exact(t + d)[0] - c.exact(t - d)[0]) / (2.0 * d);
            let on_wall = c.radius - (q - u).abs() < 1e-12;
            if on_wall {
                let du = c.amplitude * c.omega * (c.omega * t).cos();
                assert!((v - du).abs() < 1e-5, "t = {t}: q' = {v}, u' = {du}");
            } else if c.radius - (q - u).abs() > 1e-4 {
                assert!(v.abs() < 1e-9, "t = {t}: q' = {v} off the walls");
            }
        }
        assert_eq!(c.kinks().len(), 4, "{:?}", c.kinks());
    }

    #[test]
    fn inside_disk_solution_slides_on_the_circle_with_the_tangential_drift() {
        let c = PointInsideMovingDisk::default();
        let (tc, _) = c.contact();
        assert!((1.7..1.75).contains(&tc), "{tc}");
        let d = 1e-6;
        for i in 1..40 {
            let t = tc + (c.t_end - tc) * i as f64 / 40.0;
            let z = c.exact(t);
            let w = [z[0] - c.velocity[0] * t, z[1] - c.velocity[1] * t];
            assert!((w[0].hypot(w[1]) - c.radius).abs() < 1e-12, "t = {t}");
            let (zp, zm) = (c.exact(t + d), c.exact(t - d));
            let vel = [(zp[0] - zm[0]) / (2.0 * d), (zp[1] - zm[1]) / (2.0 * d)];
            // z' = v + tangential part of f − v.
            let n = [w[0] / c.radius, w[1] / c.radius];
            let rel = [c.drift[0] - c.velocity[0], c.drift[1] - c.velocity[1]];
            let dn = rel[0] * n[0] + rel[1] * n[1];
            assert!(dn > 0.0, "t = {t}: the drift does not push outward");
            let expect = [
                c.velocity[0] + rel[0] - dn * n[0],
                c.velocity[1] + rel[1] - dn * n[1],
            ];
            assert!(
                (vel[0] - expect[0]).hypot(vel[1] - expect[1]) < 1e-6,
                "t = {t}: {vel:?} vs {expect:?}"
            );
        }
        // Before contact: free motion inside.
        let z = c.exact(0.5 * tc);
        let w = [
            z[0] - c.velocity[0] * 0.5 * tc,
            z[1] - c.velocity[1] * 0.5 * tc,
        ];
        assert!(w[0].hypot(w[1]) < c.radius);
    }
}
