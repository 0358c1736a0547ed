//! The constants of assumptions A0–A5 of Bernicot & Venel, measured for any problem, the
//! constants the paper derives from them, and run-time checks of declared bounds.
//!
//! # What is measured
//! [`estimate_problem`] evaluates, at sampled states `(t, q)` (a computed trajectory, or any
//! list of configurations), every constraint within [`EstimateSettings::neighbourhood`] of
//! activity (`gᵢ(t, q) ≤ neighbourhood`, found through the families' candidates):
//!
//! | constant | assumption | quantity | norm |
//! |---|---|---|---|
//! | `α`, `β` | A1 | `|∇_q gᵢ|`, smallest and largest | Euclidean |
//! | `β` | A2 | `|∂ₜ gᵢ|`, largest | absolute value |
//! | `M` | A3 | `|∂ₜ ∇_q gᵢ|`, largest | Euclidean |
//! | `M` | A4 | `|D²_q gᵢ|`, largest | spectral (largest `|eigenvalue|`) |
//! | `γ` | A5 at `ρ` | `1/dist(0, conv{∇gᵢ/|∇gᵢ|, gᵢ ≤ ρ})`, largest | — |
//! | `γ'` | A5' | the same over the active set (`gᵢ ≤ active_tolerance`) | — |
//! | `c` | A0 | from the families ([`ConstraintFamily::a0_margin`](crate::constraint::ConstraintFamily::a0_margin)); `∞` for affine ones | — |
//! | `λ_min` | §2: `gᵢ` convex in `q` | smallest eigenvalue of `D²_q gᵢ` | must be `≥ 0` |
//!
//! Convexity is not one of A0–A5 but the standing assumption of the paper's section 2; when
//! some `D²gᵢ` has a negative eigenvalue (beyond `1e-9 · max(1, |D²gᵢ|)`), the report names
//! the constraint, the sample and the eigenvalue, and claims none of the derived constants
//! `η`, `Θ`, `r` (they are proved for convex `gᵢ` only). A family that declares itself affine
//! has that claim verified on its first member at the first sample.
//!
//! The paper uses one `β` for A1 and A2 and one `M` for A3 and A4; the report keeps each part
//! and their maximum. The assumptions quantify over the open sets `Uᵢ(t) ⊃ Qᵢ(t)` (A1, A3, A4)
//! and over all of `R^d` (A2): sampling near activity gives lower estimates of the suprema
//! (and an upper estimate of `α`), exact when the quantity is constant (pairs of disks:
//! `|∇D| = √2`; straight walls: `D² = 0`) and otherwise as good as the samples. Set
//! [`EstimateSettings::probe_depth`] to also sample each constraint a little outside `Qᵢ(t)`,
//! inside `Uᵢ(t)`.
//!
//! `γ` is computed on the coordinate groups of the near-active set (constraints sharing no
//! coordinate are orthogonal, and `γ² = Σ γₖ²` over groups, see [`coordinate_groups`]); each
//! group's `γₖ` is one small projection ([`hull_distance`]) by the backend given. The paper's
//! `γ` is the global one, which grows like the square root of the number of separate contacts;
//! the largest group's `γₖ` is reported beside it as `gamma_group`.
//!
//! # What is derived (paper, Propositions 2.2–2.3 and Theorem 4.1)
//! * `η = α/(Mγ')`: `Q(t)` is `η`-prox-regular (Prop 2.2, which needs A1, A4, A5');
//! * `Θ = 2γβ/α` and `r = min(4ρ/(13β), α/(2Mγ))`: the metric qualification of Theorem 4.1;
//! * `K_L` (Prop 2.3) and the step bound `h < c/K_L`: **not derived**. The paper only asserts
//!   that some `K_L` exists (referring to Venel's earlier work for the proof) and gives no
//!   formula; we report `None` rather than a guess. A first-order argument (push along a
//!   direction `w` with `⟨nᵢ, w⟩ ≥ 1/γ`) suggests `γβ/α` for small `|t − s|`, but it needs a
//!   second-order remainder and the `Uᵢ` sets we have not bounded, so it is not reported.
//!
//! # Run-time checks
//! [`BoundsMonitor`] is an [`crate::stepper::Observer`] that, after each step, re-linearizes
//! the near-active constraints at the new state and compares `|∇g|`, `|∂ₜg|` (and, on a
//! schedule, `|D²g|`, `|∂ₜ∇g|`) with declared [`Bounds`], under a [`Policy`] (off, warn,
//! error). Under `error` the run stops with [`SweepError::AssumptionViolated`](crate::error::SweepError::AssumptionViolated) naming the
//! constraint (the people, for crowds), the time, the bound and the value, and the
//! [`crate::stepper::RunFailure`] keeps what was computed.

mod estimate;
mod hull;
mod monitor;
mod report;
mod serde_ext;

pub use crate::curvature::{
    symmetric_max_eigenvalue, symmetric_min_eigenvalue, symmetric_spectral_norm, AFFINE_CLAIM,
    CONCAVITY, CONVEXITY, CONVEXITY_TOLERANCE,
};
pub use estimate::{
    estimate_problem, samples_from_trajectory, EstimateSettings, ALPHA_RELATIVE_FLOOR,
};
pub use hull::{coordinate_groups, hull_distance, SparseVector};
pub use monitor::{BoundViolation, Bounds, BoundsMonitor, MonitorSettings, Policy};
pub use report::{AssumptionReport, Witness};
