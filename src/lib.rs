//! # sweeping
//!
//! Perturbed sweeping processes `dq/dt + N(Q(t), q) ∋ f(t, q)`, with
//! `Q(t) = ∩ᵢ {q : gᵢ(t, q) ≥ 0}` and each `gᵢ` convex in `q`, solved by the
//! prediction–correction scheme of Bernicot & Venel (see [`stepper`]), and the Maury–Venel
//! crowd-motion model on top of it (see [`crowd`]).
//!
//! A first problem needs only [`prelude`]: a [`ConstraintKernel`](constraint::ConstraintKernel)
//! written over a [`Scalar`](constraint::Scalar) (its docs list the arithmetic spellings that
//! compile, such as `t * 0.5` and `-x + 1.0`), [`Problem::with_constraint`](problem::Problem::with_constraint)
//! and [`Problem::solve`](problem::Problem::solve); the README walks through it, then through
//! exact-solution checks, measured assumptions and declared bounds. Each `gᵢ` must be convex
//! in `q`: [`assumptions`] checks it and says what to do when it is not.
//!
//! * [`constraint`] — write each `gᵢ` once over dual numbers; value, `∇g`, `D²g`, `∂ₜg`,
//!   `∂ₜ∇g` by autodiff; constraint families.
//! * [`problem`] — the process: constraints, perturbation, start.
//! * [`stepper`] — the scheme, step reports, observers, culling with proof.
//! * [`backends`] — the projection backends enabled by cargo features (`clarabel`, `osqp`) and
//!   a by-name constructor.
//! * [`assumptions`] — the constants of assumptions A0–A5 measured, the paper's derived
//!   constants (η, Θ, r), and run-time bound checks.
//! * [`crowd`] — disks that may not overlap: pairs, walls, obstacles; desired velocities.
//! * [`scene`] — crowd scenes as TOML files, built with only the effects they call for.
//! * [`output`] — trajectory CSV, run summary, SVG snapshots, HTML animation.
//! * [`study`] — convergence orders (against a reference or an exact solution) and
//!   work–precision studies.
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod assumptions;
pub mod backends;
pub mod constraint;
pub mod crowd;
pub mod curvature;
pub mod error;
pub mod meter;
pub mod numbers;
pub mod observers;
pub mod output;
pub mod problem;
pub mod report;
pub mod scene;
mod solve;
pub mod stepper;
pub mod study;
pub mod svg;
// Many runs of scenes, one results table (`sweep batch`): a client of `scene` and `output`.
pub mod batch;

pub use error::SweepError;
#[doc(inline)]
pub use sweeping_api as api;

/// The names a first problem, a custom backend and a backend swap need: everything a
/// program writes after `use sweeping::prelude::*;` in the README and the examples.
pub mod prelude {
    pub use crate::assumptions::{
        estimate_problem, Bounds, BoundsMonitor, EstimateSettings, MonitorSettings, Policy,
    };
    pub use crate::backends::{make_projector, BackendChoice, BackendError};
    pub use crate::constraint::{
        Constraint, ConstraintFamily, ConstraintKernel, Curvature, KernelFamily, Scalar,
    };
    pub use crate::error::SweepError;
    pub use crate::problem::{NoPerturbation, Perturbation, Problem};
    pub use crate::stepper::{
        Observer, ObserverError, Prediction, Run, RunFailure, StepReport, Stepper, StepperSettings,
    };
    pub use num_dual::DualNum;
    pub use sweeping_api::conformance::ReferenceProjector;
    pub use sweeping_api::{
        CrossCheck, Projection, ProjectionError, ProjectionProblem, Projector, SolveStats,
        SolveStatus, SparseRows,
    };
}

/// The README's code blocks, compiled and run as doc tests so that they stay true.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// The guide's code blocks (`docs/guide/src`), compiled and run as doc tests so that the
/// guide cannot drift from the library.
#[cfg(doctest)]
pub mod guide_doctests {
    #[doc = include_str!("../docs/guide/src/introduction.md")]
    pub struct Introduction;
    #[doc = include_str!("../docs/guide/src/first-problem.md")]
    pub struct FirstProblem;
    #[doc = include_str!("../docs/guide/src/step-two.md")]
    pub struct StepTwo;
    #[doc = include_str!("../docs/guide/src/checks-and-assumptions.md")]
    pub struct ChecksAndAssumptions;
    #[doc = include_str!("../docs/guide/src/accuracy.md")]
    pub struct Accuracy;
    #[doc = include_str!("../docs/guide/src/crowds.md")]
    pub struct Crowds;
    #[doc = include_str!("../docs/guide/src/scene-format.md")]
    pub struct SceneFormat;
    #[doc = include_str!("../docs/guide/src/analysing-a-run.md")]
    pub struct AnalysingARun;
    #[doc = include_str!("../docs/guide/src/rimea.md")]
    pub struct Rimea;
    #[doc = include_str!("../docs/guide/src/backends.md")]
    pub struct Backends;
    #[doc = include_str!("../docs/guide/src/performance.md")]
    pub struct Performance;
    #[doc = include_str!("../docs/guide/src/common-mistakes.md")]
    pub struct CommonMistakes;
    #[doc = include_str!("../docs/guide/src/theory.md")]
    pub struct Theory;
    #[doc = include_str!("../docs/guide/src/development.md")]
    pub struct Development;
    #[doc = include_str!("../docs/guide/src/two-classes.md")]
    pub struct TwoClasses;
    #[doc = include_str!("../docs/guide/src/batch.md")]
    pub struct Batch;
    #[doc = include_str!("../docs/guide/src/bottleneck.md")]
    pub struct Bottleneck;
    #[doc = include_str!("../docs/guide/src/metric-and-equalities.md")]
    pub struct MetricAndEqualities;
}
