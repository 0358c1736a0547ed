//! The projection engine of `sweeping`: `min ½‖x − y‖² s.t. A x ≥ b`, block by block.
//!
//! [`Engine`] is the method of the native backend (`sweeping-native`); its [`active_set`] also
//! polishes Clarabel's answers (`sweeping-clarabel`). A projection splits into blocks
//! (connected components of the rows, [`sweeping_api::Blocks`]). A jam's block holds every
//! candidate pair, most of them far apart: rows with more room at `y` than half the block's
//! largest violation are left out first, and the rows kept split into blocks of their own;
//! rows left out that the answer violates join, and the blocks they change are solved again.
//! Each block is solved by
//!
//! 1. **the active set** ([`active_set`]: Lawson–Hanson on the dual, its `LDLᵀ` factors
//!    bordered as rows join and leave) from the previous projection's support, matched by
//!    [`sweeping_api::RowKey`], for at most [`EngineSettings::active_set_iterations`]. A crowd
//!    walking, or a queue moving, changes its support by a few rows a step: one to a few
//!    iterations, its tests at `1e-12`. A block of 400 rows or more that went to the interior
//!    point at its last three projections or more skips this attempt (but at powers of two).
//! 2. otherwise **the interior point** (Mehrotra's predictor–corrector on the normal equations
//!    `(I + AᵀWA) Δd = …`, one sparse Cholesky factorization an iteration, the pattern
//!    analysed once per block), started from the previous projection's multipliers by row key
//!    where the block has any ([`EngineSettings::interior_point_warm_floor`]). A jam — more
//!    tight rows than unknowns, rows of contact loops linearly dependent, multipliers not
//!    unique — is its normal case: the normal matrix stays positive definite whatever the
//!    rows. It runs to its accuracy contract ([`Tolerance`]),
//!    and its answer, certified, is the block's: within that accuracy of the projection. An
//!    answer short of the contract or failing the certificate is **finished** by the active set from its support (the rows whose
//!    multiplier exceeds their slack) within [`EngineSettings::finish_iterations`]; the
//!    finish is kept only where it agrees with the interior point's answer.
//!
//! Every answer passes the KKT check ([`sweeping_api::ProjectionProblem::kkt_residuals`]) at
//! [`EngineSettings::kkt_tolerance`] before it is returned; a block that neither method
//! certifies goes to the caller's fallback backend. Infeasibility is reported only with a
//! checked Farkas certificate.
//!
//! ```
//! use sweeping_api::{ProjectionProblem, SparseRows};
//! use sweeping_qp::Engine;
//!
//! // Two points on a line, 0.1 apart, that must be at least 0.4 apart: x₁ − x₀ ≥ 0.4.
//! let a = SparseRows::from_rows(2, &[vec![(0, -1.0), (1, 1.0)]]);
//! let p = ProjectionProblem::new(vec![0.0, 0.1], a, vec![0.4]).unwrap();
//! let sol = Engine::default().project(&p, "engine", None).unwrap();
//! assert!((sol.x[0] + 0.15).abs() < 1e-12 && (sol.x[1] - 0.25).abs() < 1e-12);
//! ```
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod active_set;
mod csc;
mod engine;
mod ipm;
mod ldl;
mod normal;
mod screen;
mod simplicial;

pub use engine::{Engine, EngineSettings, Method};
pub use ipm::{Iterate, Tolerance};

/// The interior point alone on `min ½‖d‖²` s.t. `A d ≥ r`, run to `tolerance` (for
/// benchmarks and measurements): `None` without rows or when the normal matrix cannot be
/// factored.
///
/// ```
/// use sweeping_api::SparseRows;
/// use sweeping_qp::{interior_point, Tolerance};
///
/// // d₀ ≥ 1 and d₀ + d₁ ≥ 3: the projection of 0 is (1.5, 1.5).
/// let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(0, 1.0), (1, 1.0)]]);
/// let it = interior_point(&a, &[1.0, 3.0], Tolerance::default(), 100).unwrap();
/// assert!(it.converged);
/// assert!((it.d[0] - 1.5).abs() < 1e-9 && (it.d[1] - 1.5).abs() < 1e-9);
/// ```
pub fn interior_point(
    a: &sweeping_api::SparseRows,
    r: &[f64],
    tolerance: Tolerance,
    max_iterations: u32,
) -> Option<Iterate> {
    let mut normal = normal::NormalMatrix::new(a).ok()?;
    ipm::solve(
        a,
        r,
        &mut normal,
        tolerance,
        f64::INFINITY,
        max_iterations,
        None,
    )
}
