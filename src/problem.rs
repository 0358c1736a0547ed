//! A perturbed sweeping process: the configuration space, the constraints `gᵢ(t, q) ≥ 0`, the
//! perturbation `f(t, q)` and the start `q₀`.

use crate::constraint::{
    ConstraintFamily, ConstraintId, ConstraintKernel, KernelFamily, LinearizedRow,
};
use crate::error::{SweepError, Violation};
use sweeping_api::{Metric, ProjectionProblem, SparseRows};

/// The perturbation `f(t, q)` of `dq/dt + N(Q(t), q) ∋ f(t, q)` (in crowds: the desired
/// velocities).
///
/// Closures `Fn(f64, &[f64], &mut [f64])` implement it.
///
/// ```
/// use sweeping::problem::Perturbation;
/// let f = |_t: f64, q: &[f64], out: &mut [f64]| { out[0] = -q[0]; out[1] = 1.0; };
/// let mut v = [0.0; 2];
/// f.eval(0.0, &[2.0, 0.0], &mut v);
/// assert_eq!(v, [-2.0, 1.0]);
/// ```
pub trait Perturbation: Send + Sync {
    /// Writes `f(t, q)` into `out` (same length as `q`).
    fn eval(&self, t: f64, q: &[f64], out: &mut [f64]);

    /// Whether `f` depends on `t` (the averaged prediction integrates only then). Default
    /// `true`.
    fn is_time_dependent(&self) -> bool {
        true
    }
}

impl<F: Fn(f64, &[f64], &mut [f64]) + Send + Sync> Perturbation for F {
    fn eval(&self, t: f64, q: &[f64], out: &mut [f64]) {
        self(t, q, out)
    }
}

/// `f = 0`: a pure sweeping process.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoPerturbation;

impl Perturbation for NoPerturbation {
    fn eval(&self, _t: f64, _q: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|v| *v = 0.0);
    }
    fn is_time_dependent(&self) -> bool {
        false
    }
}

/// The data of a sweeping process.
///
/// ```
/// use sweeping::prelude::*;
/// // One point on a line, pushed left at speed 1, kept right of the wall x ≥ t/2.
/// struct Wall;
/// impl ConstraintKernel<1> for Wall {
///     type Params = ();
///     fn value<D: Scalar>(&self, _: &(), t: D, z: [D; 1]) -> D {
///         z[0] - t * 0.5
///     }
///     fn is_affine(&self) -> bool { true }
/// }
/// let problem = Problem::new(vec![1.0], |_t: f64, _q: &[f64], f: &mut [f64]| f[0] = -1.0)
///     .with_family(KernelFamily::single("wall", Wall, [0]));
/// assert_eq!(problem.dim(), 1);
/// problem.validate(1e-12).unwrap();
/// ```
pub struct Problem {
    q0: Vec<f64>,
    families: Vec<Box<dyn ConstraintFamily>>,
    /// The families of equality constraints `hⱼ(t, q) = 0`.
    equalities: Vec<Box<dyn ConstraintFamily>>,
    /// The metric `W` of every step's projection.
    metric: Metric,
    perturbation: Box<dyn Perturbation>,
    t0: f64,
}

impl Problem {
    /// A problem in dimension `q0.len()` starting at `q0` at `t = 0`, without constraints yet.
    pub fn new(q0: Vec<f64>, perturbation: impl Perturbation + 'static) -> Self {
        Self {
            q0,
            families: Vec::new(),
            equalities: Vec::new(),
            metric: Metric::Identity,
            perturbation: Box::new(perturbation),
            t0: 0.0,
        }
    }

    /// Adds a family of equality constraints `hⱼ(t, q) = 0`, written as the `gᵢ` are (a
    /// [`ConstraintKernel`] wrapped in a [`KernelFamily`], or any [`ConstraintFamily`]) and
    /// linearized the same way, into rows `∇hⱼ · u = −hⱼ`. Every member is assembled at every
    /// step (an equality is always active; its multiplier has either sign).
    ///
    /// What the theory covers: an affine `hⱼ` (in `q`) cuts the sets `Q(t)` with an affine
    /// subspace, and the scheme stays a projection onto a convex set intersected with the
    /// paper's class. A nonlinear `hⱼ` (a point on a circle) is linearized like a `gᵢ` but has
    /// no convexity to keep it exact: after each step `|hⱼ(t_{k+1}, q_{k+1})|` is of the
    /// order of the step squared, measured and reported
    /// ([`StepReport::max_equality_residual`](crate::stepper::StepReport::max_equality_residual)),
    /// never refused.
    ///
    /// ```
    /// use sweeping::prelude::*;
    /// // A point on the line x₀ = x₁ + t, pushed along (1, 0).
    /// struct Line;
    /// impl ConstraintKernel<2> for Line {
    ///     type Params = ();
    ///     fn value<D: Scalar>(&self, _: &(), t: D, z: [D; 2]) -> D { z[0] - z[1] - t }
    ///     fn is_affine(&self) -> bool { true }
    /// }
    /// let problem = Problem::new(vec![0.0, 0.0], |_t: f64, _q: &[f64], f: &mut [f64]| {
    ///     f[0] = 1.0;
    ///     f[1] = 0.0;
    /// })
    /// .with_equality(KernelFamily::single("line", Line, [0, 1]));
    /// let run = problem.solve(StepperSettings { h: 0.1, t_end: 1.0, ..Default::default() })?;
    /// let q = &run.q_final;
    /// assert!((q[0] - q[1] - 1.0).abs() < 1e-9);
    /// # Ok::<(), Box<RunFailure>>(())
    /// ```
    pub fn with_equality(mut self, family: impl ConstraintFamily + 'static) -> Self {
        self.equalities.push(Box::new(family));
        self
    }

    /// Projects every step in the metric `W` (symmetric positive definite: masses on the
    /// diagonal, or a stiffness), `q_{k+1} = argmin ½ (x − y)ᵀ W (x − y)` over the linearized
    /// set: the scheme for `dq/dt + W⁻¹ N(Q(t), q) ∋ f(t, q)`, the sweeping process in the
    /// inner product `⟨u, v⟩_W = uᵀWv`. The default, [`Metric::Identity`], is the paper's
    /// Euclidean projection and costs nothing. `W` is checked (dimension, symmetry, positive
    /// definiteness) by [`Problem::validate`].
    pub fn with_metric(mut self, metric: Metric) -> Self {
        self.metric = metric;
        self
    }

    /// The metric `W` of the projections.
    pub fn metric(&self) -> &Metric {
        &self.metric
    }

    /// The families of equality constraints, in the order added.
    pub fn equalities(&self) -> &[Box<dyn ConstraintFamily>] {
        &self.equalities
    }

    /// The family of a row's origin in the stepper's numbering: the inequality families
    /// first ([`Self::families`]), then the equality families ([`Self::equalities`]).
    ///
    /// # Panics
    /// When `family` is past both lists.
    pub fn family_at(&self, family: usize) -> &dyn ConstraintFamily {
        match self.families.get(family) {
            Some(f) => f.as_ref(),
            None => self.equalities[family - self.families.len()].as_ref(),
        }
    }

    /// Adds a constraint family.
    pub fn with_family(mut self, family: impl ConstraintFamily + 'static) -> Self {
        self.families.push(Box::new(family));
        self
    }

    /// Adds one constraint reading the coordinates `support` of `q`, with default parameters
    /// (`()` for a kernel without any): the one-line form of
    /// `with_family(KernelFamily::single(name, kernel, support))`.
    pub fn with_constraint<C, const K: usize>(
        self,
        name: impl Into<String>,
        kernel: C,
        support: [usize; K],
    ) -> Self
    where
        C: ConstraintKernel<K> + 'static,
        C::Params: Default + 'static,
    {
        self.with_family(KernelFamily::single(name, kernel, support))
    }

    /// Adds a boxed constraint family.
    pub fn push_family(&mut self, family: Box<dyn ConstraintFamily>) {
        self.families.push(family);
    }

    /// Replaces the family at `index` (of [`families`](Self::families)): the same constraints
    /// assembled another way, such as a crowd's pairs without culling
    /// ([`DiskPairs::all_pairs`](crate::crowd::DiskPairs::all_pairs)).
    ///
    /// # Panics
    /// When `index` is not a family of this problem.
    pub fn replace_family(&mut self, index: usize, family: Box<dyn ConstraintFamily>) {
        self.families[index] = family;
    }

    /// Sets the initial time (default 0).
    pub fn with_start_time(mut self, t0: f64) -> Self {
        self.t0 = t0;
        self
    }

    /// Starts the problem at `q0` at time `t0` instead (a run resumed from a state an
    /// earlier run reached).
    ///
    /// # Panics
    /// When `q0` is not of the problem's dimension (a caller's mistake: the dimension comes
    /// from the problem).
    pub fn set_start(&mut self, t0: f64, q0: Vec<f64>) {
        assert_eq!(q0.len(), self.q0.len(), "a start of another dimension");
        self.t0 = t0;
        self.q0 = q0;
    }

    /// Dimension of the configuration space.
    pub fn dim(&self) -> usize {
        self.q0.len()
    }

    /// The initial configuration.
    pub fn q0(&self) -> &[f64] {
        &self.q0
    }

    /// The initial time.
    pub fn t0(&self) -> f64 {
        self.t0
    }

    /// The constraint families.
    pub fn families(&self) -> &[Box<dyn ConstraintFamily>] {
        &self.families
    }

    /// A constraint named for people: its family's description of the member (for a crowd,
    /// "no overlap of people 3 and 17").
    ///
    /// # Panics
    /// When `id.family` is not a family of this problem (inequality families first, then the
    /// equality families, as [`Self::family_at`] numbers them).
    pub fn describe(&self, id: ConstraintId) -> String {
        self.family_at(id.family).describe(id.member)
    }

    /// The perturbation.
    pub fn perturbation(&self) -> &dyn Perturbation {
        self.perturbation.as_ref()
    }

    /// Calls `f(family, id, row)` for every candidate of every family at `(t, q)`, linearized
    /// (with `∂ₜg` if `want_dt`): the one place where "each family's candidates, then their
    /// linearization" is written. `cutoff(family)` is the value cutoff passed to
    /// [`ConstraintFamily::candidates`], or `None` to skip the family. `scratch` holds the
    /// buffers, so that a caller looping over states allocates nothing once warm. Stops at the
    /// first `Err` of `f`.
    ///
    /// # Errors
    /// The first error `f` returns.
    pub fn for_each_linearized<E>(
        &self,
        t: f64,
        q: &[f64],
        mut cutoff: impl FnMut(&dyn ConstraintFamily) -> Option<f64>,
        want_dt: bool,
        scratch: &mut LinearizeScratch,
        mut f: impl FnMut(&dyn ConstraintFamily, ConstraintId, &LinearizedRow) -> Result<(), E>,
    ) -> Result<(), E> {
        for (family, fam) in self.families.iter().enumerate() {
            let Some(c) = cutoff(fam.as_ref()) else {
                continue;
            };
            scratch.cands.clear();
            fam.candidates(t, q, c, &mut scratch.cands);
            for &member in &scratch.cands {
                fam.linearize(member, t, q, want_dt, &mut scratch.row);
                f(fam.as_ref(), ConstraintId { family, member }, &scratch.row)?;
            }
        }
        Ok(())
    }

    /// Smallest `gᵢ(t, q)` over all constraints (found through the families' candidates, so
    /// without enumerating far-apart pairs), with the constraint's description; `None` when
    /// no constraint lies within `cutoff` of violation.
    pub fn min_constraint(&self, t: f64, q: &[f64], cutoff: f64) -> Option<(f64, String)> {
        let mut best: Option<(f64, ConstraintId)> = None;
        let _ = self.for_each_linearized(
            t,
            q,
            |_| Some(cutoff),
            false,
            &mut LinearizeScratch::default(),
            |_, id, row| {
                if best.is_none_or(|(v, _)| row.value < v) {
                    best = Some((row.value, id));
                }
                Ok::<(), std::convert::Infallible>(())
            },
        );
        best.map(|(v, id)| (v, self.describe(id)))
    }

    /// Checks that no constraint reads a coordinate twice or beyond `q`'s dimension.
    ///
    /// # Errors
    /// [`SweepError::InvalidSupport`] naming the first constraint whose support does, and
    /// [`SweepError::InvalidInput`] naming a family that reads beyond `q` otherwise.
    pub(crate) fn check_family_dimensions(&self) -> Result<(), SweepError> {
        for fam in self.families.iter().chain(&self.equalities) {
            if let Some((member, support)) = fam.invalid_support(self.dim()) {
                return Err(SweepError::InvalidSupport {
                    constraint: fam.describe(member),
                    support,
                    dim: self.dim(),
                });
            }
            if fam.min_dimension() > self.dim() {
                return Err(SweepError::InvalidInput(format!(
                    "constraint family `{}` reads coordinate {} but q has dimension {}",
                    fam.name(),
                    fam.min_dimension() - 1,
                    self.dim()
                )));
            }
        }
        Ok(())
    }

    /// Checks dimensions, finiteness, the metric, and `q₀ ∈ Q(t₀)` up to `tolerance`
    /// (`gᵢ ≥ −tolerance`, `|hⱼ| ≤ tolerance`).
    ///
    /// # Errors
    /// [`SweepError::InvalidInput`] for a dimension mismatch, a non-finite `q₀` or a metric
    /// that is not symmetric positive definite of the problem's dimension,
    /// [`SweepError::InvalidSupport`] for a constraint reading a coordinate twice or beyond
    /// `q`, and
    /// [`SweepError::InfeasibleStart`] listing the violated constraints (worst first).
    pub fn validate(&self, tolerance: f64) -> Result<(), SweepError> {
        if self.q0.is_empty() {
            return Err(SweepError::InvalidInput(
                "the configuration space has dimension 0 (q₀ is empty)".into(),
            ));
        }
        if let Some(i) = self.q0.iter().position(|v| !v.is_finite()) {
            return Err(SweepError::InvalidInput(format!(
                "q₀[{i}] = {} is not finite",
                self.q0[i]
            )));
        }
        if !self.t0.is_finite() {
            return Err(SweepError::InvalidInput(format!(
                "the start time {} is not finite",
                self.t0
            )));
        }
        self.check_family_dimensions()?;
        ProjectionProblem::new(self.q0.clone(), SparseRows::new(self.dim()), Vec::new())
            .and_then(|p| p.with_metric(self.metric.clone()))
            .map_err(|e| SweepError::InvalidInput(format!("the problem's {e}")))?;
        let mut f = vec![0.0; self.dim()];
        self.perturbation.eval(self.t0, &self.q0, &mut f);
        if let Some(i) = f.iter().position(|v| !v.is_finite()) {
            return Err(SweepError::InvalidInput(format!(
                "f(t₀, q₀)[{i}] = {} is not finite",
                f[i]
            )));
        }
        let mut violations = Vec::new();
        let _ = self.for_each_linearized(
            self.t0,
            &self.q0,
            |_| Some(0.0),
            false,
            &mut LinearizeScratch::default(),
            |fam, id, row| {
                if !row.value.is_finite() || row.value < -tolerance {
                    violations.push(Violation {
                        constraint: fam.describe(id.member),
                        value: row.value,
                    });
                }
                Ok::<(), std::convert::Infallible>(())
            },
        );
        let mut row = LinearizedRow::default();
        for fam in &self.equalities {
            for member in 0..fam.count() {
                let h = fam.value(member, self.t0, &self.q0, &mut row);
                if h.is_nan() || h.abs() > tolerance {
                    // Listed by −|h|, with the orders of the inequalities' violations.
                    violations.push(Violation {
                        constraint: format!("equality {} (h = {h:.3e})", fam.describe(member)),
                        value: -h.abs(),
                    });
                }
            }
        }
        if violations.is_empty() {
            return Ok(());
        }
        violations.sort_by(|a, b| a.value.total_cmp(&b.value));
        violations.truncate(20);
        Err(SweepError::InfeasibleStart {
            t: self.t0,
            violations,
        })
    }
}

/// The buffers of [`Problem::for_each_linearized`] (candidates and one row), reused across
/// calls.
#[derive(Debug, Clone, Default)]
pub struct LinearizeScratch {
    cands: Vec<usize>,
    row: LinearizedRow,
}
