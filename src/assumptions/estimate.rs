//! [`estimate_problem`]: the constants of the assumptions measured on samples of a run, and the
//! paper's constants derived from them.

use super::hull::{coordinate_groups, hull_distance, SparseVector};
use super::monitor;
use super::report::fmt_num;
use super::report::{AssumptionReport, Witness};
use crate::constraint::{ConstraintFamily, Curvature};
use crate::curvature::{
    concave_direction, convex_direction, describe_point, second_order_norms,
    symmetric_spectral_norm, Norms, AFFINE_CLAIM, CONCAVITY, CONCAVITY_MEANING, CONVEXITY,
    CONVEXITY_MEANING, CONVEXITY_TOLERANCE,
};
use crate::error::SweepError;
use crate::problem::Problem;
use crate::stepper::Trajectory;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use sweeping_api::Projector;

/// Settings of [`estimate_problem`]; plain values with documented defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EstimateSettings {
    /// `ρ` of A5: constraints with `gᵢ ≤ ρ` form `I_ρ(t, q)`. Default `0.05`.
    pub rho: f64,
    /// Constraints with `gᵢ ≤ neighbourhood` at a sample contribute to `α`, `β`, `M` (they
    /// stand for the neighbourhoods `Uᵢ(t)` of activity). Default `0.5`.
    pub neighbourhood: f64,
    /// A constraint counts as active (A5') when `gᵢ ≤ active_tolerance` (at most `ρ`).
    /// Default `1e-6`
    /// (computed contacts sit at the solver's tolerance, not exactly at 0).
    pub active_tolerance: f64,
    /// A group of normals whose hull lies within this distance of the origin is taken as
    /// positively dependent (`γ = ∞`). The distance is read off a projection, accurate to the
    /// backend's tolerance, so this must exceed it. Default `1e-6` (`γ > 10⁶` counts as
    /// infinite).
    pub dependence_tolerance: f64,
    /// A sample with some `gᵢ < −feasibility_tolerance` is reported as outside `Q(t)` (A5 is
    /// stated on `Q(t)`). Default `1e-6`.
    pub feasibility_tolerance: f64,
    /// When positive, each contributing constraint is also evaluated at the sample moved by
    /// `probe_depth` against its unit normal (outside `Qᵢ(t)`, inside `Uᵢ(t)` when
    /// `probe_depth < c`), so that A1, A3 and A4 are sampled on `Uᵢ(t) ∖ Qᵢ(t)` too.
    /// Default `0.0` (off).
    pub probe_depth: f64,
}

impl Default for EstimateSettings {
    fn default() -> Self {
        Self {
            rho: 0.05,
            neighbourhood: 0.5,
            active_tolerance: 1e-6,
            dependence_tolerance: 1e-6,
            feasibility_tolerance: 1e-6,
            probe_depth: 0.0,
        }
    }
}

/// A1 counts as failed when the measured `α` is below `ALPHA_RELATIVE_FLOOR · β` (β of A1, the
/// largest `|∇gᵢ|` sampled): near contact the constraint is then flat to six digits of the
/// problem's own scale, so its linearization pins points where `∇gᵢ` vanishes instead of
/// following `Q(t)`.
pub const ALPHA_RELATIVE_FLOOR: f64 = 1e-6;

/// The states of a recorded trajectory as samples for [`estimate_problem`].
pub fn samples_from_trajectory(trajectory: &Trajectory) -> Vec<(f64, Vec<f64>)> {
    trajectory
        .times
        .iter()
        .copied()
        .zip(trajectory.states.iter().cloned())
        .collect()
}

struct Tracker {
    best: Option<Witness>,
    want_max: bool,
}

impl Tracker {
    fn new(want_max: bool) -> Self {
        Self {
            best: None,
            want_max,
        }
    }
    fn see(&mut self, value: f64, t: f64, sample: usize, constraint: impl FnOnce() -> String) {
        let better = match &self.best {
            None => true,
            Some(b) => {
                if self.want_max {
                    value > b.value
                } else {
                    value < b.value
                }
            }
        };
        if better {
            self.best = Some(Witness {
                value,
                t,
                sample,
                constraint: constraint(),
            });
        }
    }
}

/// One near-active constraint at a sample.
struct Near {
    family: usize,
    index: usize,
    value: f64,
    normal: SparseVector,
}

/// `γ` over `near` (filtered by `gᵢ ≤ level`): the global value (`γ² = Σ γₖ²`, at least 1)
/// and the worst group with its members.
fn gamma_of(
    problem: &Problem,
    near: &[Near],
    level: f64,
    settings: &EstimateSettings,
    projector: &mut dyn Projector,
    sample: usize,
    t: f64,
) -> Result<Option<(f64, f64, String)>, SweepError> {
    let chosen: Vec<&Near> = near.iter().filter(|n| n.value <= level).collect();
    if chosen.is_empty() {
        return Ok(None);
    }
    let vectors: Vec<SparseVector> = chosen.iter().map(|n| n.normal.clone()).collect();
    let mut sum_sq = 0.0;
    let mut worst: (f64, Vec<usize>) = (0.0, Vec::new());
    for group in coordinate_groups(&vectors) {
        let gv: Vec<SparseVector> = group.iter().map(|&i| vectors[i].clone()).collect();
        let d = hull_distance(&gv, projector).map_err(|e| SweepError::Projection {
            step: sample,
            t,
            rows: gv.len(),
            source: e,
        })?;
        let g = if d <= settings.dependence_tolerance {
            f64::INFINITY
        } else {
            (1.0 / d).max(1.0)
        };
        sum_sq += g * g;
        if g > worst.0 || worst.1.is_empty() {
            worst = (g, group);
        }
    }
    let names: Vec<String> = worst
        .1
        .iter()
        .take(8)
        .map(|&i| problem.families()[chosen[i].family].describe(chosen[i].index))
        .collect();
    let mut label = names.join("; ");
    if worst.1.len() > 8 {
        let _ = write!(label, "; … and {} more", worst.1.len() - 8);
    }
    Ok(Some((sum_sq.sqrt().max(1.0), worst.0, label)))
}

/// Measures the constants of A0–A5 on the given samples `(t, q)` and derives the paper's.
///
/// Every constraint with `gᵢ(t, q) ≤ max(neighbourhood, ρ)` (found through the families'
/// candidates, so far-apart pairs are never enumerated) is evaluated; see the module docs for
/// what each constant bounds and how `γ` is computed (one small projection per group of
/// near-active constraints, by `projector`).
///
/// # Errors
/// [`SweepError::InvalidInput`] for no samples, a sample of the wrong dimension or with
/// non-finite entries, or settings out of range; [`SweepError::Projection`] when the backend
/// fails on a `γ` problem (its `step` is then the sample's index).
///
/// ```
/// use std::sync::Arc;
/// use sweeping::assumptions::{estimate_problem, EstimateSettings};
/// use sweeping::crowd::{DiskPairs, Population};
/// use sweeping::problem::{NoPerturbation, Problem};
/// use sweeping::api::conformance::ReferenceProjector;
///
/// // Two people of radius 0.5 in contact.
/// let pop = Population::new(vec![0.5, 0.5]).shared();
/// let q = vec![0.0, 0.0, 1.0, 0.0];
/// let problem = Problem::new(q.clone(), NoPerturbation).with_family(DiskPairs::new(pop));
/// let report = estimate_problem(&problem, &[(0.0, q)], &EstimateSettings::default(),
///                               &mut ReferenceProjector::default()).unwrap();
/// assert!((report.alpha.unwrap().value - 2f64.sqrt()).abs() < 1e-12); // |∇D| = √2
/// assert!((report.m_hess.unwrap().value - 2.0).abs() < 1e-9);        // 2/|q₁ − q₂|
/// assert!(report.failures.is_empty());
/// ```
pub fn estimate_problem(
    problem: &Problem,
    samples: &[(f64, Vec<f64>)],
    settings: &EstimateSettings,
    projector: &mut dyn Projector,
) -> Result<AssumptionReport, SweepError> {
    let s = settings;
    validate_estimate_inputs(problem, samples, s)?;

    let mut scan = Scan::new();
    scan.check_affine_claims(problem, samples);
    let cutoff = s.neighbourhood.max(s.rho);
    let mut scratch = crate::problem::LinearizeScratch::default();
    let mut probe_q: Vec<f64> = Vec::new();
    for (k, (t, q)) in samples.iter().enumerate() {
        let t = *t;
        let (near, worst_violation) =
            scan.scan_sample(problem, k, t, q, s, cutoff, &mut scratch, &mut probe_q);
        scan.report_infeasible(k, t, worst_violation);
        scan.see_gammas(problem, &near, k, t, s, projector)?;
    }
    scan.report_totals(s.rho);

    let mut notes: Vec<String> = Vec::new();
    let c = a0_margin(problem, &mut notes);
    let (k_l, h_max) = lipschitz_step_bound(problem, &mut notes);
    if s.probe_depth == 0.0 {
        notes.push(
            "A1, A3, A4 were sampled on Q(t) near activity only (probe_depth = 0), A2 near \
             activity only: the suprema over Uᵢ(t) and R^d may be larger"
                .into(),
        );
    }
    Ok(scan.into_report(samples.len(), s, c, k_l, h_max, notes))
}

/// Checks the inputs of [`estimate_problem`], in order: at least one sample, every setting
/// finite and `≥ 0`, `ρ > 0` (A5), `active_tolerance ≤ ρ` (the active set lies inside
/// `I_ρ`), every sample of the problem's dimension and finite, and every family reading
/// only coordinates of `q`.
fn validate_estimate_inputs(
    problem: &Problem,
    samples: &[(f64, Vec<f64>)],
    s: &EstimateSettings,
) -> Result<(), SweepError> {
    if samples.is_empty() {
        return Err(SweepError::InvalidInput(
            "no samples to estimate the assumptions on".into(),
        ));
    }
    let nonneg = [
        ("rho", s.rho),
        ("neighbourhood", s.neighbourhood),
        ("active_tolerance", s.active_tolerance),
        ("dependence_tolerance", s.dependence_tolerance),
        ("feasibility_tolerance", s.feasibility_tolerance),
        ("probe_depth", s.probe_depth),
    ];
    for (name, v) in nonneg {
        if !(v.is_finite() && v >= 0.0) {
            return Err(SweepError::InvalidInput(format!(
                "estimate setting {name} = {v} must be finite and ≥ 0"
            )));
        }
    }
    if s.rho <= 0.0 {
        return Err(SweepError::InvalidInput(format!(
            "ρ = {} must be positive (A5 needs ρ > 0)",
            s.rho
        )));
    }
    if s.active_tolerance > s.rho {
        return Err(SweepError::InvalidInput(format!(
            "active_tolerance = {} must not exceed ρ = {} (the active set lies inside I_ρ)",
            s.active_tolerance, s.rho
        )));
    }
    for (k, (t, q)) in samples.iter().enumerate() {
        if q.len() != problem.dim() {
            return Err(SweepError::InvalidInput(format!(
                "sample {k} has dimension {} but the problem has {}",
                q.len(),
                problem.dim()
            )));
        }
        if !t.is_finite() || q.iter().any(|v| !v.is_finite()) {
            return Err(SweepError::InvalidInput(format!(
                "sample {k} (t = {t}) has a non-finite entry"
            )));
        }
    }
    problem.check_family_dimensions()
}

/// The running extremes of the sampled quantities of A1–A5 (and of the curvature of §2),
/// with the failures found so far and how many of each kind were seen.
struct Scan {
    /// A1: smallest `|∇gᵢ|` (`α`).
    alpha: Tracker,
    /// A1: largest `|∇gᵢ|` (one part of `β`).
    beta_grad: Tracker,
    /// A2: largest `|∂ₜgᵢ|` (the other part of `β`).
    beta_dt: Tracker,
    /// A4: largest `|D²_q gᵢ|` (one part of `M`).
    m_hess: Tracker,
    /// A3: largest `|∂ₜ∇_q gᵢ|` (the other part of `M`).
    m_dt_grad: Tracker,
    /// A5 at `ρ`: largest global `γ`.
    gamma: Tracker,
    /// A5': largest `γ'` over the active sets.
    gamma_prime: Tracker,
    /// Largest `γₖ` of one coordinate group at `ρ`.
    gamma_group: Tracker,
    /// §2: smallest eigenvalue of `D²gᵢ`.
    curvature: Tracker,
    concave_reported: usize,
    /// Evaluations where a `g` declared concave has a positive eigenvalue.
    concavity_false: usize,
    /// Whether some non-affine family declares itself concave (a convex set).
    concave_declared: bool,
    affine_claims_false: usize,
    a1_reported: usize,
    infeasible_reported: usize,
    /// Samples with `γ = ∞` at `ρ` and with `γ' = ∞` over the active set.
    dependent_reported: (usize, usize),
    evaluations: usize,
    failures: Vec<String>,
}

impl Scan {
    fn new() -> Self {
        Self {
            alpha: Tracker::new(false),
            beta_grad: Tracker::new(true),
            beta_dt: Tracker::new(true),
            m_hess: Tracker::new(true),
            m_dt_grad: Tracker::new(true),
            gamma: Tracker::new(true),
            gamma_prime: Tracker::new(true),
            gamma_group: Tracker::new(true),
            curvature: Tracker::new(false),
            concave_reported: 0,
            concavity_false: 0,
            concave_declared: false,
            affine_claims_false: 0,
            a1_reported: 0,
            infeasible_reported: 0,
            dependent_reported: (0, 0),
            evaluations: 0,
            failures: Vec::new(),
        }
    }

    /// A family that declares itself affine skips the Hessian everywhere: verifies the claim
    /// once, on its first member at the first sample (`|D²g| = 0` within
    /// [`CONVEXITY_TOLERANCE`]), and records each false claim.
    fn check_affine_claims(&mut self, problem: &Problem, samples: &[(f64, Vec<f64>)]) {
        let Some((t, q)) = samples.first() else {
            return;
        };
        for fam in problem.families() {
            if !fam.is_affine() || fam.count() == 0 {
                continue;
            }
            if let Some(h) = fam.affine_check(0, *t, q) {
                let n = (h.len() as f64).sqrt().round() as usize;
                let norm = symmetric_spectral_norm(&h, n);
                if monitor::not_within(norm, CONVEXITY_TOLERANCE) {
                    self.affine_claims_false += 1;
                    let v = monitor::affine_claim_violation(0, *t, fam.describe(0), norm);
                    self.failures.push(format!(
                        "{}: {} at t = {} (sample 0): |D²g| = {} ≠ 0: {}",
                        AFFINE_CLAIM,
                        v.constraint,
                        crate::numbers::display_number(*t),
                        fmt_num(norm),
                        v.note
                    ));
                }
            }
        }
    }

    /// Evaluates every constraint with `gᵢ(t, q) ≤ cutoff` at sample `k`: records its norms
    /// (see [`Self::see_constraint`]) and returns the near-active ones (`gᵢ ≤ ρ`, with their
    /// unit normals, for `γ`) and the most violated constraint when `q ∉ Q(t)` beyond the
    /// feasibility tolerance.
    #[allow(clippy::too_many_arguments)]
    fn scan_sample(
        &mut self,
        problem: &Problem,
        k: usize,
        t: f64,
        q: &[f64],
        s: &EstimateSettings,
        cutoff: f64,
        scratch: &mut crate::problem::LinearizeScratch,
        probe_q: &mut Vec<f64>,
    ) -> (Vec<Near>, Option<(f64, String)>) {
        let mut near: Vec<Near> = Vec::new();
        let mut worst_violation: Option<(f64, String)> = None;
        let _ = problem.for_each_linearized(
            t,
            q,
            |_| Some(cutoff),
            false,
            scratch,
            |fam, id, row| {
                let (fi, idx) = (id.family, id.member);
                if monitor::not_within(row.value, cutoff) {
                    return Ok(());
                }
                if row.value < -s.feasibility_tolerance
                    && worst_violation.as_ref().is_none_or(|w| row.value < w.0)
                {
                    worst_violation = Some((row.value, fam.describe(idx)));
                }
                if let Some(n) = self.see_constraint(fam, fi, idx, k, t, q, s, probe_q) {
                    near.push(n);
                }
                Ok::<(), std::convert::Infallible>(())
            },
        );
        (near, worst_violation)
    }

    /// Evaluates constraint `idx` of family `fam` at `(t, q)` and, when `probe_depth > 0`,
    /// also at the probe `q − probe_depth·∇g/|∇g|` (inside `Uᵢ(t)`, off `Q(t)`); feeds each
    /// evaluation to [`Self::see_evaluation`]. Returns the constraint as [`Near`] when
    /// `gᵢ ≤ ρ` with a non-vanishing gradient.
    #[allow(clippy::too_many_arguments)]
    fn see_constraint(
        &mut self,
        fam: &dyn ConstraintFamily,
        fi: usize,
        idx: usize,
        k: usize,
        t: f64,
        q: &[f64],
        s: &EstimateSettings,
        probe_q: &mut Vec<f64>,
    ) -> Option<Near> {
        let so = fam.second_order(idx, t, q);
        let norms = second_order_norms(fam, &so);
        let mut evals = vec![(norms, so.value)];
        if s.probe_depth > 0.0 && norms.grad > 0.0 {
            probe_q.clear();
            probe_q.extend_from_slice(q);
            for (c, g) in so.columns.iter().zip(&so.gradient) {
                probe_q[*c] -= s.probe_depth * g / norms.grad;
            }
            let sp = fam.second_order(idx, t, probe_q);
            evals.push((second_order_norms(fam, &sp), sp.value));
        }
        for (e, (nm, value)) in evals.iter().enumerate() {
            let at: &[f64] = if e == 0 { q } else { probe_q };
            self.see_evaluation(fam, idx, k, t, nm, *value, &so.columns, at);
        }
        if so.value <= s.rho && norms.grad > 1e-12 {
            Some(Near {
                family: fi,
                index: idx,
                value: so.value,
                normal: SparseVector {
                    columns: so.columns.clone(),
                    values: so.gradient.iter().map(|g| g / norms.grad).collect(),
                },
            })
        } else {
            None
        }
    }

    /// Records one evaluation's norms: the smallest eigenvalue of `D²g` (§2, reporting a
    /// concave direction of a non-affine constraint at the point `at`), `α` and `β` (A1) from
    /// `|∇g|`, `β` (A2) from `|∂ₜg|`, `M` (A4) from `|D²g|`, `M` (A3) from `|∂ₜ∇g|`, and a
    /// vanishing gradient as an A1 failure (the first 10 of each are reported).
    #[allow(clippy::too_many_arguments)]
    fn see_evaluation(
        &mut self,
        fam: &dyn ConstraintFamily,
        idx: usize,
        k: usize,
        t: f64,
        nm: &Norms,
        value: f64,
        columns: &[usize],
        at: &[f64],
    ) {
        self.evaluations += 1;
        let name = || fam.describe(idx);
        if !fam.is_affine() && fam.curvature() == Curvature::Concave {
            self.concave_declared = true;
            if convex_direction(nm.max_eig, nm.hess, CONVEXITY_TOLERANCE) {
                self.concavity_false += 1;
                if self.concavity_false <= 10 {
                    self.failures.push(format!(
                        "{CONCAVITY}: the largest eigenvalue of D²g is {} > 0 for {} at t = {} \
                         (sample {k}), at {}, g = {}: {CONCAVITY_MEANING}",
                        fmt_num(nm.max_eig),
                        fam.describe(idx),
                        crate::stepper::display_number(t),
                        describe_point(columns, at),
                        fmt_num(value),
                    ));
                }
            }
        } else if !fam.is_affine() {
            self.curvature.see(nm.min_eig, t, k, name);
            if concave_direction(nm.min_eig, nm.hess, CONVEXITY_TOLERANCE) {
                self.concave_reported += 1;
                if self.concave_reported <= 10 {
                    let point = describe_point(columns, at);
                    self.failures.push(format!(
                        "{CONVEXITY}: the smallest eigenvalue of D²g is {} < 0 for {} \
                         at t = {} (sample {k}), at {point}, g = {}{}",
                        fmt_num(nm.min_eig),
                        fam.describe(idx),
                        crate::numbers::display_number(t),
                        fmt_num(value),
                        if self.concave_reported == 1 {
                            format!(": {CONVEXITY_MEANING}")
                        } else {
                            String::new()
                        }
                    ));
                }
            }
        }
        self.alpha.see(nm.grad, t, k, name);
        self.beta_grad.see(nm.grad, t, k, name);
        self.beta_dt.see(nm.dt, t, k, name);
        self.m_hess.see(nm.hess, t, k, name);
        self.m_dt_grad.see(nm.dt_grad, t, k, name);
        let vanishing = monitor::not_within(1e-12, nm.grad);
        if vanishing {
            self.a1_reported += 1;
        }
        if vanishing && self.a1_reported <= 10 {
            self.failures.push(format!(
                "A1: |∇g| = {} vanishes at t = {t} (sample {k}) for {}",
                fmt_num(nm.grad),
                fam.describe(idx)
            ));
        }
    }

    /// Reports sample `k` as outside `Q(t)` (A5 is stated on `Q(t)`) when a constraint is
    /// violated there (the first 10 such samples).
    fn report_infeasible(&mut self, k: usize, t: f64, worst_violation: Option<(f64, String)>) {
        let Some((v, name)) = worst_violation else {
            return;
        };
        self.infeasible_reported += 1;
        if self.infeasible_reported <= 10 {
            self.failures.push(format!(
                "sample {k} (t = {}) is not in Q(t): {name} = {} (A5 is stated on Q(t)){}",
                crate::numbers::display_number(t),
                fmt_num(v),
                if self.concave_reported > 0 {
                    "; expected here: a constraint is not convex (above), so its \
                     linearization lets computed states end outside Q(t)"
                } else {
                    ""
                }
            ));
        }
    }

    /// Records sample `k`'s `γ` (A5 at `ρ`, global and of the worst coordinate group) and
    /// `γ'` (A5', over the active set `gᵢ ≤ active_tolerance`), reporting `γ' = ∞`
    /// (positively dependent active gradients: MFCQ fails) for the first 10 samples.
    fn see_gammas(
        &mut self,
        problem: &Problem,
        near: &[Near],
        k: usize,
        t: f64,
        s: &EstimateSettings,
        projector: &mut dyn Projector,
    ) -> Result<(), SweepError> {
        if let Some((g, g_group, label)) = gamma_of(problem, near, s.rho, s, projector, k, t)? {
            self.gamma.see(g, t, k, || label.clone());
            self.gamma_group.see(g_group, t, k, || label.clone());
            if g_group.is_infinite() {
                self.dependent_reported.0 += 1;
            }
        }
        if let Some((g, _, label)) =
            gamma_of(problem, near, s.active_tolerance, s, projector, k, t)?
        {
            self.gamma_prime.see(g, t, k, || label.clone());
            if g.is_infinite() {
                self.dependent_reported.1 += 1;
                if self.dependent_reported.1 <= 10 {
                    self.failures.push(format!(
                        "A5': active gradients positively dependent at t = {t} (sample {k}): {label} \
                         (γ' = ∞: MFCQ fails, Q(t) is not prox-regular there and the motion may jam)"
                    ));
                }
            }
        }
        Ok(())
    }

    /// After all samples: the totals of the failures reported only 10 at a time (A5',
    /// convexity, A1, samples outside `Q(t)`), then `γ = ∞` at `ρ` (A5) when A5' did not
    /// already report dependence.
    fn report_totals(&mut self, rho: f64) {
        if self.dependent_reported.1 > 10 {
            self.failures.push(format!(
                "A5': … positively dependent active gradients at {} samples in all",
                self.dependent_reported.1
            ));
        }
        let concave_reported = self.concave_reported;
        if concave_reported > 10 {
            self.failures.push(format!(
                "{CONVEXITY}: … {concave_reported} evaluations with a negative eigenvalue in all"
            ));
        }
        let a1_reported = self.a1_reported;
        if a1_reported > 10 {
            self.failures
                .push(format!("A1: … {a1_reported} vanishing gradients in all"));
        }
        // A gradient tiny against the problem's own scale fails A1 as surely as a zero one.
        if let (Some(a), Some(b)) = (&self.alpha.best, &self.beta_grad.best) {
            if a1_reported == 0 && a.value < ALPHA_RELATIVE_FLOOR * b.value {
                self.failures.push(format!(
                    "A1: α = {} < {ALPHA_RELATIVE_FLOOR:e} · β = {} (|∇g| at t = {}, sample {}, \
                     for {}): the constraint is flat near contact, so its linearization stops \
                     points where ∇g vanishes instead of following Q(t), and η, Θ, r (which \
                     divide by α) are meaningless",
                    fmt_num(a.value),
                    fmt_num(b.value),
                    crate::numbers::display_number(a.t),
                    a.sample,
                    a.constraint
                ));
            }
        }
        let infeasible_reported = self.infeasible_reported;
        if infeasible_reported > 10 {
            self.failures.push(format!(
                "… {infeasible_reported} samples outside Q(t) in all{}",
                if concave_reported > 0 {
                    " (a constraint is not convex: see above)"
                } else {
                    ""
                }
            ));
        }
        if let Some(g) = &self.gamma.best {
            if g.value.is_infinite() && self.dependent_reported.1 == 0 {
                self.failures.push(format!(
                    "A5 at ρ = {}: near-active gradients positively dependent at t = {} (sample {}): {} \
                     (γ = ∞: Θ and r of Theorem 4.1 are not available; a smaller ρ may help)",
                    fmt_num(rho),
                    g.t,
                    g.sample,
                    g.constraint
                ));
            }
        }
    }

    /// The report: the measured witnesses, the paper's `β = max(β of A1, β of A2)` and
    /// `M = max(M of A3, M of A4)`, and `η`, `Θ`, `r` from [`derived_constants`] unless
    /// convexity failed (then `None`, with a note).
    fn into_report(
        self,
        samples: usize,
        s: &EstimateSettings,
        c: Option<f64>,
        k_l: Option<f64>,
        h_max: Option<f64>,
        mut notes: Vec<String>,
    ) -> AssumptionReport {
        let a = self.alpha.best.as_ref().map(|w| w.value);
        let beta = max_of(&self.beta_grad, &self.beta_dt);
        let m = max_of(&self.m_hess, &self.m_dt_grad);
        let g = self.gamma.best.as_ref().map_or(1.0, |w| w.value);
        let gp = self.gamma_prime.best.as_ref().map_or(1.0, |w| w.value);
        let (eta, theta, r) = derived_constants(a, beta, m, g, gp, s.rho);
        let convexity_failed =
            self.concave_reported > 0 || self.affine_claims_false > 0 || self.concavity_false > 0;
        let (eta, theta, r) = if convexity_failed {
            notes.push(
                "η, Θ and r are not claimed: Prop 2.2 and Theorem 4.1 are proved for gᵢ convex in q, \
                 and convexity fails here (see FAILED)"
                    .into(),
            );
            (None, None, None)
        } else if self.concave_declared {
            notes.push(
                "η, Θ and r are not claimed: some gᵢ are declared concave (convex sets, Moreau's \
                 class), which Prop 2.2 and Theorem 4.1 do not cover; each step projects onto \
                 those sets exactly (see the guide's chapter on the two classes)"
                    .into(),
            );
            (None, None, None)
        } else {
            (eta, theta, r)
        };
        AssumptionReport {
            samples,
            evaluations: self.evaluations,
            rho: s.rho,
            neighbourhood: s.neighbourhood,
            alpha: self.alpha.best,
            beta_grad: self.beta_grad.best,
            beta_dt: self.beta_dt.best,
            m_hess: self.m_hess.best,
            m_dt_grad: self.m_dt_grad.best,
            gamma: self.gamma.best,
            gamma_prime: self.gamma_prime.best,
            gamma_group: self.gamma_group.best,
            min_curvature: self.curvature.best,
            convexity_failed,
            beta,
            m,
            c,
            eta,
            theta,
            r,
            k_l,
            h_max,
            failures: self.failures,
            notes,
        }
    }
}

/// The larger of two trackers' values (`β` from A1 and A2, `M` from A3 and A4); `None` when
/// neither saw anything.
fn max_of(x: &Tracker, y: &Tracker) -> Option<f64> {
    match (&x.best, &y.best) {
        (Some(x), Some(y)) => Some(x.value.max(y.value)),
        (Some(x), None) | (None, Some(x)) => Some(x.value),
        (None, None) => None,
    }
}

/// A0's margin `c`: the smallest over the families (an affine family is smooth everywhere,
/// `c = ∞`); `None`, with a note, when some family does not state it.
fn a0_margin(problem: &Problem, notes: &mut Vec<String>) -> Option<f64> {
    let mut c: Option<f64> = Some(f64::INFINITY);
    for fam in problem.families() {
        let margin = fam
            .a0_margin()
            .or_else(|| fam.is_affine().then_some(f64::INFINITY));
        match margin {
            Some(m) => c = c.map(|v| v.min(m)),
            None => {
                c = None;
                notes.push(format!(
                    "A0: family `{}` does not state where its constraints stop being smooth; c not derived",
                    fam.name()
                ));
            }
        }
    }
    c
}

/// `(K_L, h_max)` of Prop 2.3. A static problem has Q(t) = Q(0) for all t:
/// d_H(Q(t), Q(s)) = 0, so K_L = 0 and the well-posedness bound h < c/K_L holds for every h.
/// With moving constraints the paper asserts K_L exists (Prop 2.3) without a formula, and we
/// do not invent one: `(None, None)` with a note.
fn lipschitz_step_bound(problem: &Problem, notes: &mut Vec<String>) -> (Option<f64>, Option<f64>) {
    let static_problem = problem.families().iter().all(|f| !f.is_time_dependent());
    if static_problem {
        (Some(0.0), Some(f64::INFINITY))
    } else {
        notes.push(
            "K_L (Prop 2.3) is not derived for moving constraints: the paper asserts it exists \
             without a formula, so the step bound h < c/K_L is not available"
                .into(),
        );
        (None, None)
    }
}

/// The derived constants from `α`, `β`, `M`, `γ` (A5 at `ρ`) and `γ'` (A5'):
/// `η = α/(Mγ')` (Prop 2.2; 0 when `γ' = ∞`), `Θ = 2γβ/α` and
/// `r = min(4ρ/(13β), α/(2Mγ))` (Theorem 4.1; the second term 0 when `γ = ∞`); a division
/// by zero gives `∞`.
fn derived_constants(
    a: Option<f64>,
    beta: Option<f64>,
    m: Option<f64>,
    g: f64,
    gp: f64,
    rho: f64,
) -> (Option<f64>, Option<f64>, Option<f64>) {
    let ratio = |num: f64, den: f64| -> f64 {
        if den == 0.0 {
            f64::INFINITY
        } else {
            num / den
        }
    };
    let eta = match (a, m) {
        (Some(a), Some(m)) => Some(if gp.is_infinite() {
            0.0
        } else {
            ratio(a, m * gp)
        }),
        _ => None,
    };
    let theta = match (a, beta) {
        (Some(a), Some(b)) if a > 0.0 => Some(2.0 * g * b / a),
        _ => None,
    };
    let r = match (a, beta, m) {
        (Some(a), Some(b), Some(m)) => {
            let second = if g.is_infinite() {
                0.0
            } else {
                ratio(a, 2.0 * m * g)
            };
            Some(ratio(4.0 * rho, 13.0 * b).min(second))
        }
        _ => None,
    };
    (eta, theta, r)
}
