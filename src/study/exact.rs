//! Sweeping processes whose solution is known in closed form, and the true error of the
//! scheme on them.
//!
//! * [`TwoDisksOnALine`] — two disks on a line; the rear one walks at speed 1 into the front
//!   one, at rest: free until the gap closes at `t = d₀`, then both at speed ½.
//! * [`PointBehindMovingWall`] — a point on a line kept right of a wall `c(t) = c₀ + v t`,
//!   driven by `f(t) = b + a cos(ωt)`: the one-dimensional Skorokhod problem,
//!   `x(t) = y(t) + max(0, sup_{s≤t} (c(s) − y(s)))` with `y = x₀ + ∫f`.
//! * [`PointAroundDisk`] — a point in the plane walking at velocity `(1, 0)` into a fixed disk
//!   of radius `R`, sliding around it and leaving it at its top (derived below): a curved,
//!   non-convex constraint, where the linearization matters.
//!
//! * [`PlayOperator`] and [`PointInsideMovingDisk`] — Moreau's class, sweeping by moving
//!   convex sets (module `convex_sets`): the play operator of hysteresis, and a point kept
//!   inside a moving disk by a constraint declared concave.
//! * [`MassesAgainstMovingWall`] — a point with masses `(m₁, m₂)` pushed by a moving wall,
//!   projected in the metric `W = diag(m)`: the reaction moves it along `W⁻¹n`.
//! * [`PointOnMovingCircle`] — a point held on a moving circle by an equality constraint,
//!   sliding round it (`tan(θ/2) = tan(θ₀/2) e^{−wt/R}`).
//!
//! [`true_error_study`] measures `|q(tᵢ) − qⁿ(tᵢ)|` with the paper's protocol and the sup
//! over `[t₀, T]` of `|q(t) − qⁿ(t)|`, in the same [`ConvergenceReport`] form as
//! [`super::converge`].

use super::{
    distance, map_runs, run_sampled, ConvergenceReport, ConvergenceRow, ConvergenceSettings,
    ProjectorFactory, StudyError,
};
use crate::constraint::{ConstraintKernel, KernelFamily};
use crate::problem::Problem;
use crate::stepper::{StepperSettings, Trajectory};
use num_dual::DualNum;

mod convex_sets;
mod weighted;
pub use convex_sets::{
    InsideMovingDiskKernel, PlayOperator, PlayWallKernel, PointInsideMovingDisk,
};
pub use weighted::{
    MassesAgainstMovingWall, ObliqueWallKernel, OnMovingCircleKernel, PointOnMovingCircle,
};

/// A sweeping process with a known solution.
///
/// ```
/// use sweeping::prelude::*;
/// use sweeping::study::exact::ExactCase;
///
/// /// Free motion at unit speed: no constraint at all.
/// struct Free;
/// impl ExactCase for Free {
///     fn name(&self) -> String { "free".into() }
///     fn problem(&self) -> Problem {
///         Problem::new(vec![0.0], |_t: f64, _q: &[f64], f: &mut [f64]| f[0] = 1.0)
///     }
///     fn exact(&self, t: f64) -> Vec<f64> { vec![t] }
///     fn t_end(&self) -> f64 { 1.0 }
/// }
/// assert_eq!(Free.exact(0.5), vec![0.5]);
/// ```
pub trait ExactCase: Sync {
    /// A short name (file names, legends).
    fn name(&self) -> String;
    /// The process.
    fn problem(&self) -> Problem;
    /// The exact solution at `t`.
    fn exact(&self, t: f64) -> Vec<f64>;
    /// The horizon of the study.
    fn t_end(&self) -> f64;
    /// Times where the exact solution's velocity jumps (evaluated by the sup norm in addition
    /// to the grid). Default none.
    fn kinks(&self) -> Vec<f64> {
        Vec::new()
    }
}

/// Two disks of radius `r` on the x-axis, gap `d₀` between them; the rear one (person 0, at
/// the origin) has desired velocity `(1, 0)`, the front one (person 1) is at rest.
///
/// Exact solution: `x₀(t) = t`, `x₁ = 2r + d₀` until `t = d₀`; then both move at `½`:
/// `x₀ = d₀ + (t − d₀)/2`, `x₁ = 2r + d₀ + (t − d₀)/2`. The pair constraint, linearized at a
/// collinear configuration, is the exact constraint `x₁ − x₀ ≥ 2r`, so the scheme is exact at
/// every grid point: its only error is that of the piecewise-linear interpolant across the
/// step `[t_k, t_k + h]` that contains `t = d₀`. With `a = d₀ − t_k`, `b = h − a`, both
/// coordinates are off by `ab/(2h)` at `t = d₀`, so `sup_t |q − qⁿ| = √2 ab/(2h) ≤ √2 h/8`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoDisksOnALine {
    /// Radius of both disks.
    pub radius: f64,
    /// Initial gap `d₀`.
    pub gap: f64,
    /// Horizon.
    pub t_end: f64,
}

impl Default for TwoDisksOnALine {
    /// `r = 0.2`, `d₀ = 0.64/3`, `T = 1`. For the dyadic steps `h = 0.16/2^j`, `d₀/h` has
    /// fractional part ⅓ or ⅔, so `ab = 2h²/9` and the sup error is exactly `√2 h/9`: order 1.
    /// (A gap near a common grid point, such as 0.3183 ≈ 0.32, would make `b` the same tiny
    /// number for every `h` and hide the order.)
    fn default() -> Self {
        Self {
            radius: 0.2,
            gap: 0.64 / 3.0,
            t_end: 1.0,
        }
    }
}

impl ExactCase for TwoDisksOnALine {
    fn name(&self) -> String {
        "two-disks".into()
    }

    fn problem(&self) -> Problem {
        let q0 = vec![0.0, 0.0, 2.0 * self.radius + self.gap, 0.0];
        Problem::new(q0, |_t: f64, _q: &[f64], f: &mut [f64]| {
            f.copy_from_slice(&[1.0, 0.0, 0.0, 0.0]);
        })
        .with_family(KernelFamily::single_with(
            "disks",
            DiskGapKernel,
            [0, 1, 2, 3],
            2.0 * self.radius,
        ))
    }

    fn exact(&self, t: f64) -> Vec<f64> {
        let front = 2.0 * self.radius + self.gap;
        if t <= self.gap {
            vec![t, 0.0, front, 0.0]
        } else {
            let s = 0.5 * (t - self.gap);
            vec![self.gap + s, 0.0, front + s, 0.0]
        }
    }

    fn t_end(&self) -> f64 {
        self.t_end
    }

    fn kinks(&self) -> Vec<f64> {
        vec![self.gap]
    }
}

/// Two disks' gap `g(t, z) = |(z₂, z₃) − (z₀, z₁)| − d` with params `d` (the sum of the
/// radii): the crowd model's contact, written here so that the core's studies need no crowd.
#[derive(Debug, Clone, Copy, Default)]
pub struct DiskGapKernel;

impl ConstraintKernel<4> for DiskGapKernel {
    type Params = f64;

    fn value<D: DualNum<Primitive = f64> + Copy>(&self, d: &f64, _t: D, z: [D; 4]) -> D {
        let dx = z[2] - z[0];
        let dy = z[3] - z[1];
        (dx * dx + dy * dy).sqrt() - *d
    }

    fn is_time_dependent(&self) -> bool {
        false
    }
}

/// `g(t, x) = x − c₀ − v t` with params `(c₀, v)`.
#[derive(Debug, Clone, Copy, Default)]
pub struct MovingWallKernel;

impl ConstraintKernel<1> for MovingWallKernel {
    type Params = (f64, f64);

    fn value<D: DualNum<Primitive = f64> + Copy>(&self, p: &(f64, f64), t: D, z: [D; 1]) -> D {
        z[0] - t * p.1 - p.0
    }

    fn is_affine(&self) -> bool {
        true
    }
}

/// A point on a line kept right of the wall `c(t) = c₀ + v t`, driven by
/// `f(t) = b + a cos(ωt)`: `x' + N([c(t), ∞), x) ∋ f(t)`.
///
/// Exact solution (Skorokhod): with `y(t) = x₀ + b t + (a/ω) sin(ωt)` and
/// `φ(s) = c(s) − y(s)`, `x(t) = y(t) + max(0, sup_{0≤s≤t} φ(s))`. The sup is taken over
/// `s = 0`, `s = t` and the critical points of `φ` in between, where
/// `cos(ωs) = (v − b)/a`: `ωs = ±arccos((v − b)/a) + 2πk`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointBehindMovingWall {
    /// Start `x₀ ≥ c₀`.
    pub x0: f64,
    /// Wall at `t = 0`.
    pub c0: f64,
    /// Wall speed.
    pub v: f64,
    /// Mean of `f`.
    pub b: f64,
    /// Amplitude of `f` (≠ 0).
    pub a: f64,
    /// Angular frequency of `f` (> 0).
    pub omega: f64,
    /// Horizon.
    pub t_end: f64,
}

impl Default for PointBehindMovingWall {
    /// `x₀ = 0.5`, `c₀ = 0`, `v = 0.5`, `f = cos 2t`, `T = 6`: free, caught by the wall near
    /// `t ≈ 1.4`, pushed, released, caught again — several switches within the horizon.
    fn default() -> Self {
        Self {
            x0: 0.5,
            c0: 0.0,
            v: 0.5,
            b: 0.0,
            a: 1.0,
            omega: 2.0,
            t_end: 6.0,
        }
    }
}

impl PointBehindMovingWall {
    fn free(&self, t: f64) -> f64 {
        self.x0 + self.b * t + self.a / self.omega * (self.omega * t).sin()
    }

    fn phi(&self, s: f64) -> f64 {
        self.c0 + self.v * s - self.free(s)
    }
}

impl ExactCase for PointBehindMovingWall {
    fn name(&self) -> String {
        "moving-wall".into()
    }

    fn problem(&self) -> Problem {
        let (a, b, w) = (self.a, self.b, self.omega);
        let mut fam = KernelFamily::new("wall", MovingWallKernel);
        fam.push([0], (self.c0, self.v), "x ≥ c₀ + v t");
        Problem::new(vec![self.x0], move |t: f64, _q: &[f64], f: &mut [f64]| {
            f[0] = b + a * (w * t).cos();
        })
        .with_family(fam)
    }

    fn exact(&self, t: f64) -> Vec<f64> {
        let mut sup = self.phi(0.0).max(self.phi(t));
        let kappa = (self.v - self.b) / self.a;
        if kappa.abs() <= 1.0 {
            let alpha = kappa.acos();
            let period = 2.0 * std::f64::consts::PI / self.omega;
            let mut k = 0.0;
            loop {
                let base = k * period;
                if base - alpha / self.omega > t {
                    break;
                }
                for s in [base + alpha / self.omega, base - alpha / self.omega] {
                    if (0.0..=t).contains(&s) {
                        sup = sup.max(self.phi(s));
                    }
                }
                k += 1.0;
            }
        }
        vec![self.free(t) + sup.max(0.0)]
    }

    fn t_end(&self) -> f64 {
        self.t_end
    }
}

/// `g(z) = |z| − R` with params `R`: outside a disk centred at the origin.
#[derive(Debug, Clone, Copy, Default)]
pub struct OutsideDiskKernel;

impl ConstraintKernel<2> for OutsideDiskKernel {
    type Params = f64;

    fn value<D: DualNum<Primitive = f64> + Copy>(&self, r: &f64, _t: D, z: [D; 2]) -> D {
        (z[0] * z[0] + z[1] * z[1]).sqrt() - *r
    }

    fn is_time_dependent(&self) -> bool {
        false
    }
}

/// A point starting at `(x₀, y₀)` (`0 < y₀ < R`, left of the disk) walking at velocity
/// `(1, 0)` into the disk `|z| ≤ R`, which it must stay out of.
///
/// Derivation. Free until it touches the circle at `t_c = −√(R² − y₀²) − x₀`, at the angle
/// `φ₀ = π − asin(y₀/R)`. On the circle, `z = R(cos φ, sin φ)` and the velocity is the
/// tangential part of `u = (1, 0)` (its normal part `cos φ < 0` points inwards), so
/// `R φ' = −sin φ`, whence `tan(φ/2) = tan(φ₀/2) e^{−(t − t_c)/R}`. At `φ = π/2` the normal
/// part of `u` vanishes and the point leaves the circle from its top, at
/// `t_l = t_c + R ln tan(φ₀/2)`, and walks on along `y = R`: `z = (t − t_l, R)`.
/// The velocity jumps at `t_c` and is continuous at `t_l`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointAroundDisk {
    /// Radius of the obstacle.
    pub radius: f64,
    /// Start.
    pub start: [f64; 2],
    /// Horizon.
    pub t_end: f64,
}

impl Default for PointAroundDisk {
    /// `R = 1`, start `(−2, 0.5)`, `T = 4`: contact at `t ≈ 1.134`, leaves at `t ≈ 2.451`.
    fn default() -> Self {
        Self {
            radius: 1.0,
            start: [-2.0, 0.5],
            t_end: 4.0,
        }
    }
}

impl PointAroundDisk {
    fn contact(&self) -> (f64, f64) {
        let r = self.radius;
        let [x0, y0] = self.start;
        let tc = -(r * r - y0 * y0).sqrt() - x0;
        let phi0 = std::f64::consts::PI - (y0 / r).asin();
        (tc, phi0)
    }

    fn leave_time(&self) -> f64 {
        let (tc, phi0) = self.contact();
        tc + self.radius * (0.5 * phi0).tan().ln()
    }
}

impl ExactCase for PointAroundDisk {
    fn name(&self) -> String {
        "around-disk".into()
    }

    fn problem(&self) -> Problem {
        let mut fam = KernelFamily::new("obstacle", OutsideDiskKernel);
        fam.push([0, 1], self.radius, "|z| ≥ R");
        Problem::new(self.start.to_vec(), |_t: f64, _q: &[f64], f: &mut [f64]| {
            f[0] = 1.0;
            f[1] = 0.0;
        })
        .with_family(fam)
    }

    fn exact(&self, t: f64) -> Vec<f64> {
        let (tc, phi0) = self.contact();
        let tl = self.leave_time();
        if t <= tc {
            vec![self.start[0] + t, self.start[1]]
        } else if t <= tl {
            let phi = 2.0 * ((0.5 * phi0).tan() * (-(t - tc) / self.radius).exp()).atan();
            vec![self.radius * phi.cos(), self.radius * phi.sin()]
        } else {
            vec![t - tl, self.radius]
        }
    }

    fn t_end(&self) -> f64 {
        self.t_end
    }

    fn kinks(&self) -> Vec<f64> {
        vec![self.contact().0, self.leave_time()]
    }
}

/// The cases above with their default parameters: the paper's class (two disks, a moving
/// wall, around a disk), Moreau's (the play operator, inside a moving disk), then the
/// weighted ones (masses against a wall, on a circle).
pub fn standard_cases() -> Vec<Box<dyn ExactCase>> {
    vec![
        Box::new(TwoDisksOnALine::default()),
        Box::new(PointBehindMovingWall::default()),
        Box::new(PointAroundDisk::default()),
        Box::new(PlayOperator::default()),
        Box::new(PointInsideMovingDisk::default()),
        Box::new(MassesAgainstMovingWall::default()),
        Box::new(PointOnMovingCircle::default()),
    ]
}

/// Subdivisions of each step at which the sup norm is evaluated, besides the step ends and
/// the kinks.
const SUP_SUBDIVISIONS: usize = 8;

/// `sup_t |q(t) − qⁿ(t)|` over a recorded run: at every step end, at seven interior points of
/// every step (a grid eight times finer than the step), and at the kinks. When the exact
/// solution is piecewise linear with its breaks among the kinks (as for [`TwoDisksOnALine`]),
/// the difference is piecewise linear with breaks at the step ends and kinks, so this is the
/// exact sup; otherwise it is the sup over that grid.
pub fn sup_error(case: &dyn ExactCase, trajectory: &Trajectory) -> f64 {
    let kinks = case.kinks();
    let mut worst = 0.0f64;
    let (times, states) = (&trajectory.times, &trajectory.states);
    if let (Some(t), Some(q)) = (times.first(), states.first()) {
        worst = distance(q, &case.exact(*t));
    }
    for (tw, w) in times.windows(2).zip(states.windows(2)) {
        let ((ta, qa), (tb, qb)) = ((&tw[0], &w[0]), (&tw[1], &w[1]));
        let mut ts: Vec<f64> = (1..=SUP_SUBDIVISIONS)
            .map(|i| ta + (tb - ta) * i as f64 / SUP_SUBDIVISIONS as f64)
            .collect();
        ts.extend(kinks.iter().copied().filter(|k| k > ta && k < tb));
        for t in ts {
            let s = if tb > ta { (t - ta) / (tb - ta) } else { 1.0 };
            let q: Vec<f64> = qa.iter().zip(qb).map(|(a, b)| a + s * (b - a)).collect();
            worst = worst.max(distance(&q, &case.exact(t)));
        }
    }
    worst
}

/// The true error of the scheme on `case` for each `h`: `e_h = max_i |q(tᵢ) − qⁿ(tᵢ)|`
/// (`tᵢ = iT/samples`), the sup norm ([`sup_error`]), and their fitted orders.
///
/// ```
/// use sweeping::prelude::*;
/// use sweeping::study::exact::{true_error_study, PointAroundDisk};
/// use sweeping::api::conformance::ReferenceProjector;
/// let proj = || -> Result<Box<dyn Projector>, sweeping::study::BoxError> {
///     Ok(Box::new(ReferenceProjector::default()))
/// };
/// let report = true_error_study(&PointAroundDisk::default(), &[0.05, 0.1, 0.2], 10, &proj,
///                               &StepperSettings::default(), false).unwrap();
/// assert!(report.order_sup.unwrap().order > 0.5);
/// ```
///
/// # Errors
/// [`StudyError::InvalidInput`] for an empty or non-positive `hs`; the first failing run's
/// error otherwise.
pub fn true_error_study(
    case: &dyn ExactCase,
    hs: &[f64],
    samples: usize,
    make_projector: &ProjectorFactory<'_>,
    base: &StepperSettings,
    parallel: bool,
) -> Result<ConvergenceReport, StudyError> {
    if hs.is_empty() || hs.iter().any(|h| !(h.is_finite() && *h > 0.0)) {
        return Err(StudyError::InvalidInput(format!(
            "the step sizes must be positive and finite, got {hs:?}"
        )));
    }
    if samples == 0 {
        return Err(StudyError::InvalidInput(
            "at least one comparison time is needed".into(),
        ));
    }
    let make_problem = || -> Result<Problem, super::BoxError> { Ok(case.problem()) };
    let t0 = case.problem().t0();
    let t_end = case.t_end();
    if t_end.is_nan() || t_end <= t0 {
        return Err(StudyError::InvalidInput(format!(
            "the case's horizon {t_end} must exceed t₀ = {t0}"
        )));
    }
    let times = super::comparison_times(t0, t_end, samples);
    let exact_at: Vec<Vec<f64>> = times.iter().map(|t| case.exact(*t)).collect();
    let runs = map_runs(hs, parallel, |&h| {
        run_sampled(&make_problem, make_projector, base, h, t_end, &times, true)
    });
    let runs = runs.into_iter().collect::<Result<Vec<_>, _>>()?;
    let rows: Vec<ConvergenceRow> = runs
        .iter()
        .map(|run| ConvergenceRow {
            error_sup: Some(sup_error(case, &run.trajectory)),
            ..ConvergenceRow::measured(run, super::distances(&run.samples, &exact_at))
        })
        .collect();
    let mut report = ConvergenceReport {
        label: format!("{} (exact solution)", case.name()),
        settings: ConvergenceSettings {
            h_min: 0.0,
            hs: hs.to_vec(),
            t_end,
            t_short: None,
            samples,
            parallel,
        },
        times,
        times_short: Vec::new(),
        reference: None,
        order: None,
        order_short: None,
        order_sup: None,
        rows,
    };
    report.fit();
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moving_wall_solution_stays_right_of_the_wall_and_touches_it() {
        let c = PointBehindMovingWall::default();
        let mut touched = false;
        for i in 0..=600 {
            let t = i as f64 * 0.01;
            let x = c.exact(t)[0];
            let wall = c.c0 + c.v * t;
            assert!(x >= wall - 1e-12, "t = {t}: x = {x} < wall {wall}");
            touched |= (x - wall).abs() < 1e-12;
        }
        assert!(touched);
    }

    #[test]
    fn moving_wall_solution_solves_the_skorokhod_problem_by_finite_differences() {
        // Where x is strictly right of the wall, x' = f; on the wall, x' = v ≥ f.
        let c = PointBehindMovingWall::default();
        let d = 1e-6;
        for i in 1..600 {
            let t = i as f64 * 0.01 + 0.003;
            let x = c.exact(t)[0];
            let v = (c.exact(t + d)[0] - c.exact(t - d)[0]) / (2.0 * d);
            let f = c.b + c.a * (c.omega * t).cos();
            if x - (c.c0 + c.v * t) > 1e-4 {
                assert!((v - f).abs() < 1e-5, "t = {t}: x' = {v}, f = {f}");
            } else if x - (c.c0 + c.v * t) < 1e-12 {
                assert!((v - c.v).abs() < 1e-5 && f <= c.v + 1e-5, "t = {t}");
            }
        }
    }

    #[test]
    fn around_disk_solution_is_continuous_and_on_the_circle_while_sliding() {
        let c = PointAroundDisk::default();
        let (tc, tl) = (c.kinks()[0], c.kinks()[1]);
        for &t in &[tc, tl] {
            let a = c.exact(t - 1e-9);
            let b = c.exact(t + 1e-9);
            assert!(distance(&a, &b) < 1e-8, "jump at {t}");
        }
        let d = 1e-6;
        for i in 1..20 {
            let t = tc + (tl - tc) * i as f64 / 20.0;
            let z = c.exact(t);
            assert!((distance(&z, &[0.0, 0.0]) - c.radius).abs() < 1e-12);
            // The velocity is the tangential part of (1, 0).
            let (zp, zm) = (c.exact(t + d), c.exact(t - d));
            let vel = [(zp[0] - zm[0]) / (2.0 * d), (zp[1] - zm[1]) / (2.0 * d)];
            let n = [z[0] / c.radius, z[1] / c.radius];
            let un = n[0];
            let expect = [1.0 - un * n[0], -un * n[1]];
            assert!(
                distance(&vel, &expect) < 1e-6,
                "t = {t}: {vel:?} vs {expect:?}"
            );
        }
    }
}
