//! The conformance kit: checks every projection backend must pass.
//!
//! Each check is a plain function `fn(&mut dyn Projector, &Tolerances) -> Result<(), String>`
//! that returns a message saying what went wrong. [`conformance_tests!`](crate::conformance_tests)
//! turns the whole kit into one `#[test]` per check for a backend crate:
//!
//! ```ignore
//! // In a crate that depends on `sweeping` (the library re-exports this crate as `sweeping::api`):
//! sweeping::api::conformance_tests!(MyBackend::default(), sweeping::api::conformance::Tolerances::default());
//! ```
//!
//! The checks test answers by what a projection *is* — the KKT conditions and idempotence —
//! and by closed forms where one exists, never by stored numbers.
//!
//! [`ReferenceProjector`] is a small, slow, dependency-free backend (Hildreth's dual coordinate
//! ascent) that passes the kit; it is the third opinion in tests and the example of a
//! user-written backend.

use crate::{
    Metric, Projection, ProjectionError, ProjectionProblem, Projector, SolveStats, SolveStatus,
    SparseRows,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Tolerances a backend claims to meet.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerances {
    /// Largest KKT residual allowed (absolute, ∞-norm), for problems scaled to O(1).
    pub kkt: f64,
    /// Largest ∞-norm distance allowed from a closed-form answer.
    pub point: f64,
    /// Whether an infeasible set must be reported as [`ProjectionError::Infeasible`] (a
    /// certificate); when `false` any error is accepted.
    pub certifies_infeasibility: bool,
}

impl Default for Tolerances {
    /// `kkt = 1e-6`, `point = 1e-6`, `certifies_infeasibility = true`.
    fn default() -> Self {
        Self {
            kkt: 1e-6,
            point: 1e-6,
            certifies_infeasibility: true,
        }
    }
}

/// A named check of the kit.
pub type Check = fn(&mut dyn Projector, &Tolerances) -> Result<(), String>;

/// Every check of the kit, with its name.
pub fn all_checks() -> Vec<(&'static str, Check)> {
    vec![
        ("no_rows", check_no_rows as Check),
        ("already_feasible", check_already_feasible),
        ("half_space_closed_form", check_half_space),
        ("orthant_closed_form", check_orthant),
        ("vertex_of_wedge", check_wedge_vertex),
        ("redundant_rows", check_redundant_rows),
        ("near_parallel_rows", check_near_parallel_rows),
        ("far_from_origin", check_far_from_origin),
        ("infeasible_set", check_infeasible),
        ("random_kkt_and_idempotence", check_random_kkt),
        ("repeated_pattern_changing_values", check_repeated_pattern),
        ("weighted_half_space_closed_form", check_weighted_half_space),
        ("equality_closed_form", check_equality),
        ("weighted_equality_closed_form", check_weighted_equality),
        ("infeasible_equalities", check_infeasible_equalities),
        ("random_weighted_with_equalities", check_random_weighted),
    ]
}

/// Runs every check, returning the failures as `(name, message)`.
pub fn run_all(projector: &mut dyn Projector, tol: &Tolerances) -> Vec<(&'static str, String)> {
    all_checks()
        .into_iter()
        .filter_map(|(name, check)| check(projector, tol).err().map(|m| (name, m)))
        .collect()
}

/// How [`agreement_on_random_instances`] draws its instances and judges the answers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Agreement {
    /// Seed of instance 0 ([`random_instance`]); instance `k` uses `first_seed + k`.
    pub first_seed: u64,
    /// How many instances.
    pub instances: u64,
    /// Instance `k` has `n = 2 + (11 k mod n_spread)` coordinates…
    pub n_spread: usize,
    /// …and `m = 17 k mod m_spread` rows.
    pub m_spread: usize,
    /// Largest KKT residual allowed of the backend under test.
    pub kkt: f64,
    /// Largest ∞-norm distance allowed between the two answers.
    pub gap: f64,
    /// Draw the instances with a metric and equality rows ([`random_weighted_instance`])
    /// instead of plain ones ([`random_instance`]).
    pub weighted: bool,
}

/// Solves a sequence of random instances with `under_test` and with `other`: every answer of
/// `under_test` must exist, meet `agreement.kkt` (in the instance's metric, with free-sign
/// multipliers on its equality rows when [`Agreement::weighted`]) and pass `also`; wherever `other` answers
/// (a slow reference may run out of iterations on a degenerate instance), the two points must
/// agree within `agreement.gap`. Returns how many instances were compared, or what failed
/// first (naming the instance, `n` and `m`).
///
/// ```
/// use sweeping_api::conformance::{agreement_on_random_instances, Agreement, ReferenceProjector};
/// let agreement = Agreement {
///     first_seed: 7, instances: 5, n_spread: 10, m_spread: 12, kkt: 1e-8, gap: 1e-6,
///     weighted: true,
/// };
/// let compared = agreement_on_random_instances(
///     &mut ReferenceProjector::default(),
///     &mut ReferenceProjector::default(),
///     &agreement,
///     |_| Ok(()),
/// )
/// .unwrap();
/// assert!(compared <= 5);
/// ```
///
/// # Errors
/// The first failure, as a message.
pub fn agreement_on_random_instances(
    under_test: &mut dyn Projector,
    other: &mut dyn Projector,
    agreement: &Agreement,
    mut also: impl FnMut(&Projection) -> Result<(), String>,
) -> Result<usize, String> {
    let mut compared = 0;
    for k in 0..agreement.instances {
        let n = 2 + (k as usize * 11) % agreement.n_spread;
        let m = (k as usize * 17) % agreement.m_spread;
        let what = format!("instance {k} (n = {n}, m = {m})");
        let seed = agreement.first_seed + k;
        let problem = if agreement.weighted {
            random_weighted_instance(seed, n, m)
        } else {
            random_instance(seed, n, m)
        };
        let sol = under_test
            .project(&problem)
            .map_err(|e| format!("{what}: {e}"))?;
        also(&sol).map_err(|e| format!("{what}: {e}"))?;
        let kkt = problem.kkt_residuals(&sol.x, &sol.multipliers).max();
        if kkt > agreement.kkt {
            return Err(format!("{what}: KKT residual {kkt:.3e}"));
        }
        let Ok(expected) = other.project(&problem) else {
            continue;
        };
        compared += 1;
        let gap = max_gap(&sol.x, &expected.x);
        if gap > agreement.gap {
            return Err(format!("{what}: gap {gap:.3e} from {}", other.name()));
        }
    }
    Ok(compared)
}

fn solve(p: &mut dyn Projector, problem: &ProjectionProblem) -> Result<Projection, String> {
    let sol = p
        .project(problem)
        .map_err(|e| format!("{}: unexpected error: {e}", p.name()))?;
    if sol.x.len() != problem.dim() || sol.multipliers.len() != problem.n_rows() {
        return Err(format!(
            "{}: answer has {} coordinates and {} multipliers, expected {} and {}",
            p.name(),
            sol.x.len(),
            sol.multipliers.len(),
            problem.dim(),
            problem.n_rows()
        ));
    }
    Ok(sol)
}

fn expect_kkt(
    problem: &ProjectionProblem,
    sol: &Projection,
    tol: f64,
    what: &str,
) -> Result<(), String> {
    let r = problem.kkt_residuals(&sol.x, &sol.multipliers);
    if r.max() > tol || r.max().is_nan() {
        return Err(format!("{what}: KKT residuals {r:?} exceed {tol:.1e}"));
    }
    Ok(())
}

/// The ∞-norm distance `maxᵢ |aᵢ − bᵢ|` between two answers (over their common length; 0 for
/// none): how the kit and the backends' tests compare points.
///
/// ```
/// use sweeping_api::conformance::max_gap;
/// assert_eq!(max_gap(&[1.0, 2.0], &[1.5, -1.0]), 3.0);
/// ```
pub fn max_gap(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(u, v)| (u - v).abs())
        .fold(0.0, crate::max_or_nan)
}

fn expect_point(x: &[f64], expected: &[f64], tol: f64, what: &str) -> Result<(), String> {
    let gap = max_gap(x, expected);
    if gap > tol || gap.is_nan() {
        return Err(format!(
            "{what}: x = {x:?}, expected {expected:?} (gap {gap:.3e} > {tol:.1e})"
        ));
    }
    Ok(())
}

/// No rows: the answer is `y` itself.
pub fn check_no_rows(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let y = vec![0.3, -1.2, 7.0];
    let problem = ProjectionProblem::new(y.clone(), SparseRows::new(3), vec![]).unwrap();
    let sol = solve(p, &problem)?;
    expect_point(&sol.x, &y, tol.point, "no rows")
}

/// `y` already satisfies every row: `x = y`, `λ = 0`.
pub fn check_already_feasible(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let y = vec![1.0, 2.0];
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, 1.0), (1, 1.0)]]);
    let problem = ProjectionProblem::new(y.clone(), a, vec![0.5, 1.0]).unwrap();
    let sol = solve(p, &problem)?;
    expect_point(&sol.x, &y, tol.point, "already feasible")?;
    if sol.multipliers.iter().any(|l| l.abs() > tol.kkt) {
        return Err(format!(
            "already feasible: multipliers {:?} should vanish",
            sol.multipliers
        ));
    }
    Ok(())
}

/// One half-space: `x = y + max(0, b − a·y)/|a|² · a`, `λ = max(0, b − a·y)/|a|²`.
pub fn check_half_space(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let y = [3.0, 4.0, 0.0];
    let a = [1.0, 2.0, -2.0];
    let b = 20.0;
    let ay: f64 = a.iter().zip(&y).map(|(u, v)| u * v).sum();
    let lambda = (b - ay) / 9.0;
    let expected: Vec<f64> = y.iter().zip(&a).map(|(v, u)| v + lambda * u).collect();
    let rows = SparseRows::from_rows(3, &[vec![(0, a[0]), (1, a[1]), (2, a[2])]]);
    let problem = ProjectionProblem::new(y.to_vec(), rows, vec![b]).unwrap();
    let sol = solve(p, &problem)?;
    expect_point(&sol.x, &expected, tol.point, "half-space")?;
    if (sol.multipliers[0] - lambda).abs() > tol.point * 10.0 {
        return Err(format!(
            "half-space: multiplier {} expected {lambda}",
            sol.multipliers[0]
        ));
    }
    expect_kkt(&problem, &sol, tol.kkt, "half-space")
}

/// The non-negative orthant: `x = max(y, 0)`, `λ = max(−y, 0)`.
pub fn check_orthant(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let y = vec![-1.0, 2.0, -0.5, 0.0, 3.0, -4.0];
    let rows: Vec<Vec<(usize, f64)>> = (0..y.len()).map(|i| vec![(i, 1.0)]).collect();
    let problem =
        ProjectionProblem::new(y.clone(), SparseRows::from_rows(6, &rows), vec![0.0; 6]).unwrap();
    let sol = solve(p, &problem)?;
    let expected: Vec<f64> = y.iter().map(|v| v.max(0.0)).collect();
    expect_point(&sol.x, &expected, tol.point, "orthant")?;
    let expected_l: Vec<f64> = y.iter().map(|v| (-v).max(0.0)).collect();
    expect_point(
        &sol.multipliers,
        &expected_l,
        tol.point * 10.0,
        "orthant multipliers",
    )
}

/// `y` in the normal cone at the vertex of a wedge: the answer is the vertex.
pub fn check_wedge_vertex(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    // x₁ ≥ x₀ and x₁ ≥ −x₀, vertex at the origin; y = (0.2, −3) lies in its normal cone.
    let rows = SparseRows::from_rows(2, &[vec![(0, -1.0), (1, 1.0)], vec![(0, 1.0), (1, 1.0)]]);
    let problem = ProjectionProblem::new(vec![0.2, -3.0], rows, vec![0.0, 0.0]).unwrap();
    let sol = solve(p, &problem)?;
    expect_point(&sol.x, &[0.0, 0.0], tol.point, "wedge vertex")?;
    expect_kkt(&problem, &sol, tol.kkt, "wedge vertex")
}

/// The same half-space written three times (once scaled): the point is still the
/// half-space projection; multipliers are not unique, so only KKT is checked for them.
pub fn check_redundant_rows(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let rows = SparseRows::from_rows(
        2,
        &[
            vec![(0, 1.0), (1, 1.0)],
            vec![(0, 1.0), (1, 1.0)],
            vec![(0, 2.0), (1, 2.0)],
        ],
    );
    let problem = ProjectionProblem::new(vec![0.0, 0.0], rows, vec![2.0, 2.0, 4.0]).unwrap();
    let sol = solve(p, &problem)?;
    expect_point(&sol.x, &[1.0, 1.0], tol.point, "redundant rows")?;
    expect_kkt(&problem, &sol, tol.kkt, "redundant rows")
}

/// Two nearly parallel rows (angle 1e-6), a degenerate vertex far away.
pub fn check_near_parallel_rows(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let eps = 1e-6;
    let rows = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, 1.0), (1, eps)]]);
    let problem = ProjectionProblem::new(vec![0.0, 0.0], rows, vec![1.0, 1.0]).unwrap();
    let sol = solve(p, &problem)?;
    expect_point(&sol.x, &[1.0, 0.0], tol.point * 10.0, "near-parallel rows")?;
    let r = problem.kkt_residuals(&sol.x, &sol.multipliers);
    // Multipliers of near-parallel rows are ill-conditioned; the primal side must still hold.
    if r.primal > tol.kkt {
        return Err(format!("near-parallel rows: primal residual {}", r.primal));
    }
    Ok(())
}

/// A problem translated far from the origin (crowds live at coordinates ~10²): the answer
/// must translate with it.
pub fn check_far_from_origin(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let shift = 250.0;
    // x₀ − x₂ ≥ 0.4 − d, i.e. two points on a line kept apart, near (shift, shift).
    let rows = SparseRows::from_rows(4, &[vec![(0, -1.0), (2, 1.0)]]);
    let y = vec![shift, shift, shift + 0.1, shift];
    // Row: x₂ − x₀ ≥ 0.4.
    let problem = ProjectionProblem::new(y, rows, vec![0.4]).unwrap();
    let sol = solve(p, &problem)?;
    let expected = [shift - 0.15, shift, shift + 0.25, shift];
    expect_point(&sol.x, &expected, tol.point, "far from origin")?;
    expect_kkt(&problem, &sol, tol.kkt, "far from origin")
}

/// `x₀ ≥ 1` and `−x₀ ≥ 0` have no common point: the backend must return an error
/// ([`ProjectionError::Infeasible`] when `tol.certifies_infeasibility`).
pub fn check_infeasible(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let rows = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, -1.0)]]);
    let problem = ProjectionProblem::new(vec![0.0, 0.0], rows, vec![1.0, 0.0]).unwrap();
    match p.project(&problem) {
        Ok(sol) => Err(format!(
            "infeasible set: got an answer {:?} instead of an error",
            sol.x
        )),
        Err(ProjectionError::Infeasible { .. }) => Ok(()),
        Err(_) if !tol.certifies_infeasibility => Ok(()),
        Err(e) => Err(format!(
            "infeasible set: expected ProjectionError::Infeasible, got {e}"
        )),
    }
}

/// A random feasible instance: `n` coordinates, `m` sparse rows with 1–4 entries each, a
/// known feasible point (so the set is not empty) with some rows tight at it, and `y` drawn
/// around it. Shared by the kit and by backend benchmarks.
pub fn random_instance(seed: u64, n: usize, m: usize) -> ProjectionProblem {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let x0: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let mut a = SparseRows::new(n);
    let mut b = Vec::with_capacity(m);
    for _ in 0..m {
        let k = rng.gen_range(1..=4.min(n));
        let mut cols: Vec<usize> = Vec::with_capacity(k);
        while cols.len() < k {
            let c = rng.gen_range(0..n);
            if !cols.contains(&c) {
                cols.push(c);
            }
        }
        let entries: Vec<(usize, f64)> = cols
            .iter()
            .map(|&c| (c, rng.gen_range(-1.0..1.0)))
            .collect();
        let ax0: f64 = entries.iter().map(|&(c, v)| v * x0[c]).sum();
        let slack = if rng.gen_bool(0.3) {
            0.0
        } else {
            rng.gen_range(0.0..0.5)
        };
        a.push_row(entries);
        b.push(ax0 - slack);
    }
    let y: Vec<f64> = x0.iter().map(|v| v + rng.gen_range(-1.5..1.5)).collect();
    ProjectionProblem::new(y, a, b).unwrap()
}

/// [`random_instance`] with a metric and equality rows: `W` diagonal (masses in `[0.5, 4]`)
/// on even seeds, masses plus random springs (`k (eᵢ − eⱼ)(eᵢ − eⱼ)ᵀ`, a lattice-spring
/// stiffness) on odd ones; the first `1 + seed mod 3` rows (at most half of them) made
/// equalities through the known feasible point. Shared by the kit and the backends' tests.
pub fn random_weighted_instance(seed: u64, n: usize, m: usize) -> ProjectionProblem {
    let base = random_instance(seed, n, m);
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_f3e7);
    let masses: Vec<f64> = (0..n).map(|_| rng.gen_range(0.5..4.0)).collect();
    let metric = if seed.is_multiple_of(2) {
        Metric::Diagonal(masses)
    } else {
        let mut dense = vec![vec![0.0; n]; n];
        for (i, w) in masses.iter().enumerate() {
            dense[i][i] = *w;
        }
        for _ in 0..n {
            let (i, j) = (rng.gen_range(0..n), rng.gen_range(0..n));
            if i != j {
                let k = rng.gen_range(0.1..3.0);
                dense[i][i] += k;
                dense[j][j] += k;
                dense[i][j] -= k;
                dense[j][i] -= k;
            }
        }
        let rows: Vec<Vec<(usize, f64)>> = dense
            .iter()
            .map(|r| {
                r.iter()
                    .enumerate()
                    .filter(|(_, v)| **v != 0.0)
                    .map(|(j, v)| (j, *v))
                    .collect()
            })
            .collect();
        Metric::Symmetric(SparseRows::from_rows(n, &rows))
    };
    // The feasible point of `random_instance` is not returned; its tight rows are: a row with
    // zero slack there becomes an equality when it is among the first rows, and the other
    // candidates are kept as inequalities. So the set stays non-empty.
    let k = ((1 + seed % 3) as usize).min(m / 2);
    let x0 = feasible_point_of(seed, n);
    let mut b = base.b().to_vec();
    let mut ax0 = vec![0.0; m];
    base.a().mul_vec(&x0, &mut ax0);
    b[..k].copy_from_slice(&ax0[..k]);
    ProjectionProblem::new(base.y().to_vec(), base.a().clone(), b)
        .and_then(|p| p.with_metric(metric))
        .and_then(|p| p.with_leading_equalities(k))
        .expect("a valid instance")
}

/// The feasible point [`random_instance`] draws first for `seed` and `n`.
fn feasible_point_of(seed: u64, n: usize) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect()
}

/// One row in the metric `W = [[2, −1, 0], [−1, 2, 0], [0, 0, 4]]` (two unit masses joined by
/// a spring, and a mass 4): `x = y + λ W⁻¹a` with `λ = (b − a·y)/(aᵀW⁻¹a)`; here `a = (1, 1, 1)`,
/// `W⁻¹a = (1, 1, ¼)`, `y = 0`, `b = 1`, so `λ = 4/9` and `x = (4/9, 4/9, 1/9)`. Also with the
/// masses alone, `W = diag(1, 2, 4)`: `W⁻¹a = (1, ½, ¼)`, `λ = 4/7`.
pub fn check_weighted_half_space(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let row = SparseRows::from_rows(3, &[vec![(0, 1.0), (1, 1.0), (2, 1.0)]]);
    let spring = SparseRows::from_rows(
        3,
        &[
            vec![(0, 2.0), (1, -1.0)],
            vec![(0, -1.0), (1, 2.0)],
            vec![(2, 4.0)],
        ],
    );
    let cases = [
        (Metric::Symmetric(spring), 4.0 / 9.0, [1.0, 1.0, 0.25]),
        (
            Metric::Diagonal(vec![1.0, 2.0, 4.0]),
            4.0 / 7.0,
            [1.0, 0.5, 0.25],
        ),
    ];
    for (metric, lambda, direction) in cases {
        let what = format!("weighted half-space, W = {metric:?}");
        let problem = ProjectionProblem::new(vec![0.0; 3], row.clone(), vec![1.0])
            .and_then(|q| q.with_metric(metric))
            .map_err(|e| e.to_string())?;
        let sol = solve(p, &problem)?;
        let expected: Vec<f64> = direction.iter().map(|u| lambda * u).collect();
        expect_point(&sol.x, &expected, tol.point, &what)?;
        expect_point(&sol.multipliers, &[lambda], tol.point * 10.0, &what)?;
        expect_kkt(&problem, &sol, tol.kkt, &what)?;
    }
    Ok(())
}

/// An equality and an inequality: `x₀ + x₁ = 1`, `x₂ ≥ 1` from `y = (2, 2, 0)`: `x = (½, ½, 1)`,
/// `λ = (−3/2, 1)` — the equality pulls back, so its multiplier is negative.
pub fn check_equality(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let rows = SparseRows::from_rows(3, &[vec![(0, 1.0), (1, 1.0)], vec![(2, 1.0)]]);
    let problem = ProjectionProblem::new(vec![2.0, 2.0, 0.0], rows, vec![1.0, 1.0])
        .and_then(|q| q.with_leading_equalities(1))
        .map_err(|e| e.to_string())?;
    let sol = solve(p, &problem)?;
    expect_point(&sol.x, &[0.5, 0.5, 1.0], tol.point, "equality")?;
    expect_point(
        &sol.multipliers,
        &[-1.5, 1.0],
        tol.point * 10.0,
        "equality multipliers",
    )?;
    expect_kkt(&problem, &sol, tol.kkt, "equality")
}

/// Masses 1 and 3 on the line `x₀ + x₁ = 1` from `y = (2, 2)`: `W(x − y) = λ(1, 1)` gives
/// `λ = −9/4`, `x = (−¼, 5/4)` (the heavy mass moves a third as far); and from a `y` already
/// on the line, `x = y`, `λ = 0`.
pub fn check_weighted_equality(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let rows = SparseRows::from_rows(2, &[vec![(0, 1.0), (1, 1.0)]]);
    for (y, x, lambda) in [
        ([2.0, 2.0], [-0.25, 1.25], -2.25),
        ([0.25, 0.75], [0.25, 0.75], 0.0),
    ] {
        let problem = ProjectionProblem::new(y.to_vec(), rows.clone(), vec![1.0])
            .and_then(|q| q.with_metric(Metric::Diagonal(vec![1.0, 3.0])))
            .and_then(|q| q.with_leading_equalities(1))
            .map_err(|e| e.to_string())?;
        let what = format!("weighted equality from y = {y:?}");
        let sol = solve(p, &problem)?;
        expect_point(&sol.x, &x, tol.point, &what)?;
        expect_point(&sol.multipliers, &[lambda], tol.point * 10.0, &what)?;
        expect_kkt(&problem, &sol, tol.kkt, &what)?;
    }
    Ok(())
}

/// `x₀ = 1` and `x₀ ≥ 2` have no common point: an error, as for [`check_infeasible`].
pub fn check_infeasible_equalities(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let rows = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, 1.0)]]);
    let problem = ProjectionProblem::new(vec![0.0, 0.0], rows, vec![1.0, 2.0])
        .and_then(|q| q.with_leading_equalities(1))
        .map_err(|e| e.to_string())?;
    match p.project(&problem) {
        Ok(sol) => Err(format!(
            "infeasible equalities: got an answer {:?} instead of an error",
            sol.x
        )),
        Err(ProjectionError::Infeasible { .. }) => Ok(()),
        Err(_) if !tol.certifies_infeasibility => Ok(()),
        Err(e) => Err(format!(
            "infeasible equalities: expected ProjectionError::Infeasible, got {e}"
        )),
    }
}

/// On 30 random instances with a metric and equality rows ([`random_weighted_instance`]):
/// the KKT conditions `W(x − y) = Aᵀλ`, `λᵢ ≥ 0` on the inequality rows, `Ax ≥ b`,
/// `|Ax − b| = 0` on the equality rows and complementarity, within `tol.kkt`; and
/// idempotence within `tol.point`.
pub fn check_random_weighted(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    for seed in 0..30u64 {
        let n = 2 + (seed as usize * 7) % 20;
        let m = (seed as usize * 13) % 30;
        let problem = random_weighted_instance(seed, n, m);
        let what = format!(
            "weighted instance {seed} (n = {n}, m = {m}, {} equalities)",
            problem.equalities()
        );
        let sol = solve(p, &problem)?;
        expect_kkt(&problem, &sol, tol.kkt, &what)?;
        let again =
            ProjectionProblem::new(sol.x.clone(), problem.a().clone(), problem.b().to_vec())
                .and_then(|q| q.with_metric(problem.metric().clone()))
                .and_then(|q| q.with_leading_equalities(problem.equalities()))
                .map_err(|e| e.to_string())?;
        let sol2 = solve(p, &again)?;
        expect_point(
            &sol2.x,
            &sol.x,
            tol.point,
            &format!("idempotence on {what}"),
        )?;
    }
    Ok(())
}

/// On 40 random instances: KKT within `tol.kkt`, and projecting the answer again returns it
/// (idempotence) within `tol.point`.
pub fn check_random_kkt(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    for seed in 0..40u64 {
        let n = 2 + (seed as usize * 7) % 30;
        let m = (seed as usize * 13) % 45;
        let problem = random_instance(seed, n, m);
        let sol = solve(p, &problem)?;
        expect_kkt(
            &problem,
            &sol,
            tol.kkt,
            &format!("random instance {seed} (n = {n}, m = {m})"),
        )?;
        let again =
            ProjectionProblem::new(sol.x.clone(), problem.a().clone(), problem.b().to_vec())
                .unwrap();
        let sol2 = solve(p, &again)?;
        expect_point(
            &sol2.x,
            &sol.x,
            tol.point,
            &format!("idempotence on instance {seed}"),
        )?;
    }
    Ok(())
}

/// The same sparsity pattern solved repeatedly with changing `y` and `b`, as in a time loop
/// (backends that cache or warm-start must not return stale answers).
pub fn check_repeated_pattern(p: &mut dyn Projector, tol: &Tolerances) -> Result<(), String> {
    let base = random_instance(99, 12, 20);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for k in 0..8 {
        let y: Vec<f64> = base
            .y()
            .iter()
            .map(|v| v + rng.gen_range(-0.5..0.5))
            .collect();
        // Shift b down (never up) so the known feasible point stays feasible.
        let b: Vec<f64> = base
            .b()
            .iter()
            .map(|v| v - rng.gen_range(0.0..0.3))
            .collect();
        let problem = ProjectionProblem::new(y, base.a().clone(), b).unwrap();
        let sol = solve(p, &problem)?;
        expect_kkt(
            &problem,
            &sol,
            tol.kkt,
            &format!("repeated pattern, solve {k}"),
        )?;
    }
    Ok(())
}

/// Generates one `#[test]` per conformance check for a backend.
///
/// `$make` is an expression building a fresh backend (it is evaluated once per test), `$tol`
/// a [`Tolerances`].
#[macro_export]
macro_rules! conformance_tests {
    ($make:expr, $tol:expr) => {
        $crate::conformance_tests!(@one no_rows, check_no_rows, $make, $tol);
        $crate::conformance_tests!(@one already_feasible, check_already_feasible, $make, $tol);
        $crate::conformance_tests!(@one half_space_closed_form, check_half_space, $make, $tol);
        $crate::conformance_tests!(@one orthant_closed_form, check_orthant, $make, $tol);
        $crate::conformance_tests!(@one vertex_of_wedge, check_wedge_vertex, $make, $tol);
        $crate::conformance_tests!(@one redundant_rows, check_redundant_rows, $make, $tol);
        $crate::conformance_tests!(@one near_parallel_rows, check_near_parallel_rows, $make, $tol);
        $crate::conformance_tests!(@one far_from_origin, check_far_from_origin, $make, $tol);
        $crate::conformance_tests!(@one infeasible_set, check_infeasible, $make, $tol);
        $crate::conformance_tests!(@one random_kkt_and_idempotence, check_random_kkt, $make, $tol);
        $crate::conformance_tests!(@one repeated_pattern_changing_values, check_repeated_pattern, $make, $tol);
        $crate::conformance_tests!(@one weighted_half_space_closed_form, check_weighted_half_space, $make, $tol);
        $crate::conformance_tests!(@one equality_closed_form, check_equality, $make, $tol);
        $crate::conformance_tests!(@one weighted_equality_closed_form, check_weighted_equality, $make, $tol);
        $crate::conformance_tests!(@one infeasible_equalities, check_infeasible_equalities, $make, $tol);
        $crate::conformance_tests!(@one random_weighted_with_equalities, check_random_weighted, $make, $tol);
    };
    (@one $name:ident, $check:ident, $make:expr, $tol:expr) => {
        #[test]
        fn $name() {
            let mut projector = $make;
            let tol: $crate::conformance::Tolerances = $tol;
            if let Err(msg) = $crate::conformance::$check(&mut projector, &tol) {
                panic!("conformance check `{}` failed: {}", stringify!($name), msg);
            }
        }
    };
}

/// Hildreth's dual coordinate ascent: a slow, dependency-free projector for small problems.
///
/// It maximizes the dual `−½‖Aᵀλ‖² + λᵀ(b − Ay)` over `λ ≥ 0` one coordinate at a time,
/// keeping `x = y + Aᵀλ` (in a metric `W`: `−½ λᵀAW⁻¹Aᵀλ + λᵀ(b − Ay)`, keeping
/// `x = y + W⁻¹Aᵀλ`; an equality row's multiplier is not clamped at zero). Exact in the limit; stops when the KKT residuals fall below
/// `tolerance` or after `max_sweeps` sweeps (then [`ProjectionError::NotConverged`]). It
/// cannot certify infeasibility (the dual is then unbounded and it runs out of sweeps).
#[derive(Debug, Clone)]
pub struct ReferenceProjector {
    /// KKT tolerance (absolute). Default `1e-10`.
    pub tolerance: f64,
    /// Most sweeps over the rows. Default `200_000`.
    pub max_sweeps: u32,
}

impl Default for ReferenceProjector {
    fn default() -> Self {
        Self {
            tolerance: 1e-10,
            max_sweeps: 200_000,
        }
    }
}

impl Projector for ReferenceProjector {
    fn name(&self) -> &str {
        "reference"
    }

    fn tolerance(&self) -> f64 {
        self.tolerance
    }

    fn project(&mut self, problem: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        let start = std::time::Instant::now();
        let a = problem.a();
        if problem.n_rows() == 0 || problem.max_violation(problem.y()) == 0.0 {
            return Ok(Projection::identity(problem, self.name()));
        }
        // In the metric W, x = y + W⁻¹Aᵀλ: a row moves x along W⁻¹aᵣ.
        let directions = metric_directions(problem)?;
        let norms2: Vec<f64> = (0..a.n_rows())
            .map(|r| {
                let u = &directions[r];
                a.row(r)
                    .map(|(c, v)| v * u.iter().find(|(j, _)| *j == c).map_or(0.0, |(_, w)| *w))
                    .sum()
            })
            .collect();
        let k = problem.equalities();
        let mut lambda = vec![0.0; a.n_rows()];
        let mut x = problem.y().to_vec();
        for sweep in 0..self.max_sweeps {
            for r in 0..a.n_rows() {
                if norms2[r] == 0.0 {
                    continue;
                }
                let ax: f64 = a.row(r).map(|(c, v)| v * x[c]).sum();
                let free = lambda[r] + (problem.b()[r] - ax) / norms2[r];
                // An equality's multiplier has no sign.
                let new = if r < k { free } else { free.max(0.0) };
                let d = new - lambda[r];
                if d != 0.0 {
                    for &(c, v) in &directions[r] {
                        x[c] += d * v;
                    }
                    lambda[r] = new;
                }
            }
            if sweep % 16 == 15 || sweep + 1 == self.max_sweeps {
                if problem.kkt_residuals(&x, &lambda).max() <= self.tolerance {
                    return Ok(Projection {
                        x,
                        multipliers: lambda,
                        stats: SolveStats {
                            backend: self.name().to_string(),
                            status: SolveStatus::Solved,
                            iterations: sweep + 1,
                            solve_seconds: start.elapsed().as_secs_f64(),
                            setup_seconds: 0.0,
                            warm_started: false,
                            counters: crate::BackendCounters::default(),
                        },
                    });
                }
                if lambda.iter().any(|l| !l.is_finite() || l.abs() > 1e12) {
                    break;
                }
            }
        }
        Err(ProjectionError::NotConverged {
            backend: self.name().to_string(),
            iterations: self.max_sweeps,
            status: "max sweeps".into(),
        })
    }
}

/// Each row's direction `W⁻¹aᵣ`, as its non-zero entries (`aᵣ` itself in the identity).
fn metric_directions(
    problem: &ProjectionProblem,
) -> Result<Vec<Vec<(usize, f64)>>, ProjectionError> {
    let a = problem.a();
    let Some(factor) = problem.metric().validate(problem.dim())? else {
        return Ok((0..a.n_rows()).map(|r| a.row(r).collect()).collect());
    };
    let mut v = vec![0.0; problem.dim()];
    Ok((0..a.n_rows())
        .map(|r| {
            v.iter_mut().for_each(|x| *x = 0.0);
            a.row(r).for_each(|(c, x)| v[c] += x);
            factor.solve_l(&mut v, 0);
            factor.solve_lt(&mut v);
            v.iter()
                .enumerate()
                .filter(|(_, x)| **x != 0.0)
                .map(|(c, x)| (c, *x))
                .collect()
        })
        .collect())
}

/// The reference projector as the crate's own tests run it through the kit (here and behind
/// [`crate::Blocked`]): capped at 20 000 sweeps so that the infeasible check ends quickly (it
/// cannot certify infeasibility), and the tolerances it meets so.
#[cfg(test)]
pub(crate) mod testing {
    use super::{ReferenceProjector, Tolerances};

    pub(crate) fn capped_reference() -> ReferenceProjector {
        ReferenceProjector {
            tolerance: 1e-10,
            max_sweeps: 20_000,
        }
    }

    pub(crate) const CAPPED_REFERENCE_TOLERANCES: Tolerances = Tolerances {
        kkt: 1e-8,
        point: 1e-6,
        certifies_infeasibility: false,
    };
}

#[cfg(test)]
mod tests {
    use super::testing::{capped_reference, CAPPED_REFERENCE_TOLERANCES};

    crate::conformance_tests!(capped_reference(), CAPPED_REFERENCE_TOLERANCES);
}
