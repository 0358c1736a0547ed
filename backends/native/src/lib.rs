//! The native projection backend of `sweeping`: the projection engine of `sweeping-qp`, block
//! by block, warm-started across steps by row keys, and certified.
//!
//! [`NativeProjector`] is a [`Projector`] around [`sweeping_qp::Engine`]: each block of a
//! projection (connected component of the rows) is solved by the engine's support method from
//! the previous step's support, or by its interior point when the support does not settle (a
//! jam), and every answer passes the KKT check at [`NativeSettings::kkt_tolerance`]. A block
//! that neither method certifies goes to the fallback given to
//! [`NativeProjector::with_fallback`] (the root crate passes Clarabel), counted in
//! [`BackendCounters::fallbacks`](sweeping_api::BackendCounters::fallbacks); without one it is a
//! [`ProjectionError::NotConverged`]. Infeasibility is reported only with a checked Farkas
//! certificate.
//!
//! ```
//! use sweeping_api::{ProjectionProblem, Projector, SparseRows};
//! use sweeping_native::NativeProjector;
//!
//! // Two points on a line, 0.1 apart, that must be at least 0.4 apart: x₁ − x₀ ≥ 0.4.
//! let a = SparseRows::from_rows(2, &[vec![(0, -1.0), (1, 1.0)]]);
//! let p = ProjectionProblem::new(vec![0.0, 0.1], a, vec![0.4]).unwrap();
//! let sol = NativeProjector::default().project(&p).unwrap();
//! assert!((sol.x[0] + 0.15).abs() < 1e-12 && (sol.x[1] - 0.25).abs() < 1e-12);
//! assert_eq!(sol.stats.counters.fallbacks, 0);
//! ```
#![deny(missing_docs)]
#![forbid(unsafe_code)]

use sweeping_api::{Projection, ProjectionError, ProjectionProblem, Projector};
use sweeping_qp::Engine;
pub use sweeping_qp::EngineSettings as NativeSettings;

/// The name this backend reports in statistics and errors.
pub const NAME: &str = "native";

/// The native backend; see the [crate documentation](crate).
pub struct NativeProjector {
    engine: Engine,
    fallback: Option<Box<dyn Projector>>,
}

impl Default for NativeProjector {
    fn default() -> Self {
        Self::new(NativeSettings::default())
    }
}

impl std::fmt::Debug for NativeProjector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NativeProjector")
            .field("engine", &self.engine)
            .field("fallback", &self.fallback.as_ref().map(|p| p.name()))
            .finish()
    }
}

impl NativeProjector {
    /// A projector without fallback: a block it cannot certify is an error.
    pub fn new(settings: NativeSettings) -> Self {
        Self {
            engine: Engine::new(settings),
            fallback: None,
        }
    }

    /// A projector that hands the blocks it cannot certify to `fallback`.
    pub fn with_fallback(settings: NativeSettings, fallback: Box<dyn Projector>) -> Self {
        Self {
            fallback: Some(fallback),
            ..Self::new(settings)
        }
    }

    /// The settings used for every solve.
    pub fn settings(&self) -> &NativeSettings {
        &self.engine.settings
    }

    /// The settings, to change before the next solve.
    pub fn settings_mut(&mut self) -> &mut NativeSettings {
        &mut self.engine.settings
    }
}

impl Projector for NativeProjector {
    fn name(&self) -> &str {
        NAME
    }

    /// `kkt_tolerance`, or the fallback's tolerance when larger (its answers are accepted).
    fn tolerance(&self) -> f64 {
        let own = self.engine.settings.kkt_tolerance;
        self.fallback
            .as_ref()
            .map_or(own, |f| own.max(f.tolerance()))
    }

    fn project(&mut self, problem: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        self.engine
            .project(problem, NAME, self.fallback.as_deref_mut())
    }
}
