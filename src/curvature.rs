//! The curvature of a constraint at a point: the spectrum of `D²g`, whether it is convex or
//! concave there beyond rounding, and what a failed check means. The stepper's checks and the
//! assumptions' estimates both read it, so it sits below them.

use crate::constraint::{ConstraintFamily, SecondOrderData};

/// The assumption name of a failed convexity check.
pub const CONVEXITY: &str = "convexity (g convex in q)";
/// The assumption name of a false concavity declaration ([`Curvature::Concave`](crate::constraint::Curvature::Concave)).
pub const CONCAVITY: &str = "concavity (g declared concave in q)";
/// The assumption name of a false `is_affine` claim.
pub const AFFINE_CLAIM: &str = "affine claim (D²g = 0)";

/// The spectral norm (largest `|eigenvalue|`) of the symmetric `n × n` matrix stored
/// row-major in `h` (symmetrized first, so rounding asymmetry does not matter).
pub fn symmetric_spectral_norm(h: &[f64], n: usize) -> f64 {
    if n == 0 {
        return 0.0;
    }
    let m = nalgebra::DMatrix::from_fn(n, n, |i, j| 0.5 * (h[i * n + j] + h[j * n + i]));
    nalgebra::SymmetricEigen::new(m)
        .eigenvalues
        .iter()
        .map(|v| v.abs())
        .fold(0.0, f64::max)
}

/// The smallest eigenvalue of the symmetric `n × n` matrix stored row-major in `h`
/// (symmetrized first); `0` for `n = 0`. Negative for a Hessian means `g` is not convex there.
pub fn symmetric_min_eigenvalue(h: &[f64], n: usize) -> f64 {
    symmetric_extremes(h, n).0
}

/// The largest eigenvalue of the symmetric `n × n` matrix stored row-major in `h`
/// (symmetrized first); `0` for `n = 0`. Positive for a Hessian means `g` is not concave there.
pub fn symmetric_max_eigenvalue(h: &[f64], n: usize) -> f64 {
    symmetric_spectrum(h, n).1
}

/// (smallest eigenvalue, largest |eigenvalue|) of a row-major symmetric matrix, one
/// decomposition for both.
fn symmetric_extremes(h: &[f64], n: usize) -> (f64, f64) {
    let (min, _, norm) = symmetric_spectrum(h, n);
    (min, norm)
}

/// (smallest eigenvalue, largest eigenvalue, largest |eigenvalue|) of a row-major symmetric
/// matrix.
pub(crate) fn symmetric_spectrum(h: &[f64], n: usize) -> (f64, f64, f64) {
    if n == 0 {
        return (0.0, 0.0, 0.0);
    }
    let m = nalgebra::DMatrix::from_fn(n, n, |i, j| 0.5 * (h[i * n + j] + h[j * n + i]));
    let eig = nalgebra::SymmetricEigen::new(m).eigenvalues;
    (
        eig.iter().copied().fold(f64::INFINITY, f64::min),
        eig.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        eig.iter().map(|v| v.abs()).fold(0.0, f64::max),
    )
}

/// The relative rounding allowance of the convexity and affine checks of
/// [`estimate_problem`](crate::assumptions::estimate_problem): `1e-9 · max(1, |D²g|)` (autodiff Hessians are exact up to rounding).
pub const CONVEXITY_TOLERANCE: f64 = 1e-9;

/// Whether the smallest eigenvalue `min_eig` of a Hessian of spectral norm `norm` is negative
/// beyond rounding (`relative_tolerance · max(1, norm)`): `g` is then not convex there.
pub(crate) fn concave_direction(min_eig: f64, norm: f64, relative_tolerance: f64) -> bool {
    min_eig < -relative_tolerance * norm.max(1.0)
}

/// Whether the largest eigenvalue `max_eig` of a Hessian of spectral norm `norm` is positive
/// beyond rounding (`relative_tolerance · max(1, norm)`): a `g` declared concave is then not
/// concave there.
pub(crate) fn convex_direction(max_eig: f64, norm: f64, relative_tolerance: f64) -> bool {
    max_eig > relative_tolerance * norm.max(1.0)
}

/// What a failed concavity check means, for messages.
pub(crate) const CONCAVITY_MEANING: &str = "g is declared concave in q (Curvature::Concave: \
    {g >= 0} convex) but is not concave there, so a linearization of g does not contain \
    {g >= 0} and the refined projection could cut off allowed points. Declare it \
    Curvature::Convex if g is convex, or write the region as an intersection of constraints \
    that are convex or concave";

/// What a failed convexity check means, for messages.
pub(crate) const CONVEXITY_MEANING: &str = "g is not convex in q there (section 2 of the paper \
    requires it), so the linearized set is not an inner approximation of Q(t): steps may end \
    outside Q(t) and the order-1/2 guarantee does not hold. Write a convex region as an \
    intersection of convex constraints (affine sides <n, q> - d >= 0, or \"outside a ball\" \
    |q - c| - r >= 0); otherwise expect violations of order h²·|D²g|·|velocity|² per step";

/// The support coordinates of an evaluation, for messages: `q[0] = 2, q[1] = 0.1`.
pub(crate) fn describe_point(columns: &[usize], q: &[f64]) -> String {
    columns
        .iter()
        .map(|&c| format!("q[{c}] = {}", crate::numbers::display_number(q[c])))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Norms of one evaluation: `|∇g|`, `|∂ₜg|`, `|D²g|` (spectral), `|∂ₜ∇g|`, and the smallest
/// eigenvalue of `D²g`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Norms {
    pub grad: f64,
    pub dt: f64,
    pub hess: f64,
    pub dt_grad: f64,
    pub min_eig: f64,
    pub max_eig: f64,
}

pub(crate) fn second_order_norms(fam: &dyn ConstraintFamily, so: &SecondOrderData) -> Norms {
    let n = so.columns.len();
    let (min_eig, max_eig, hess) = if fam.is_affine() {
        (0.0, 0.0, 0.0)
    } else {
        symmetric_spectrum(&so.hessian, n)
    };
    Norms {
        grad: so.gradient.iter().map(|v| v * v).sum::<f64>().sqrt(),
        dt: so.dt.abs(),
        hess,
        min_eig,
        max_eig,
        dt_grad: if fam.is_time_dependent() {
            so.dt_gradient.iter().map(|v| v * v).sum::<f64>().sqrt()
        } else {
            0.0
        },
    }
}
