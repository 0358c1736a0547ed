//! The projection backends compiled in (cargo features `clarabel` and `osqp`), and a
//! constructor by name for command lines and scene files.

use serde::{Deserialize, Serialize};
use sweeping_api::{CrossCheck, Projector};

#[cfg(feature = "clarabel")]
pub use sweeping_clarabel::{ClarabelProjector, ClarabelSettings};
#[cfg(feature = "osqp")]
pub use sweeping_osqp::{OsqpProjector, OsqpSettings};

/// A backend chosen by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum BackendChoice {
    /// Clarabel (interior point), tight settings.
    #[default]
    Clarabel,
    /// OSQP (ADMM), tight settings.
    Osqp,
    /// Both on every step, failing when they disagree by more than the cross-check tolerance.
    Cross,
    /// The dependency-free reference (Hildreth); small problems only.
    Reference,
}

impl BackendChoice {
    /// Every backend this enum can name (compiled in or not: see [`make_projector`]).
    pub const ALL: [BackendChoice; 4] = [
        BackendChoice::Clarabel,
        BackendChoice::Osqp,
        BackendChoice::Cross,
        BackendChoice::Reference,
    ];
}

impl std::str::FromStr for BackendChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "clarabel" => Ok(Self::Clarabel),
            "osqp" => Ok(Self::Osqp),
            "cross" => Ok(Self::Cross),
            "reference" => Ok(Self::Reference),
            other => Err(format!(
                "unknown backend `{other}` (expected clarabel, osqp, cross or reference)"
            )),
        }
    }
}

impl std::fmt::Display for BackendChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Clarabel => "clarabel",
            Self::Osqp => "osqp",
            Self::Cross => "cross",
            Self::Reference => "reference",
        })
    }
}

/// Default ∞-norm tolerance of the cross-check between Clarabel and OSQP at their tight
/// settings: `1e-6`.
pub const DEFAULT_CROSS_TOLERANCE: f64 = 1e-6;

/// Why [`make_projector`] could not build a backend.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum BackendError {
    /// The backend's cargo feature is off in this build.
    #[error("backend `{backend}` is not compiled in: build with `--features {features}`")]
    NotCompiled {
        /// The backend asked for.
        backend: BackendChoice,
        /// The cargo features it needs.
        features: String,
    },
}

/// Builds the chosen backend with its default (tight) settings.
///
/// # Errors
/// [`BackendError::NotCompiled`] when the backend's cargo feature is off.
pub fn make_projector(choice: BackendChoice) -> Result<Box<dyn Projector>, BackendError> {
    match choice {
        BackendChoice::Reference => Ok(Box::new(
            sweeping_api::conformance::ReferenceProjector::default(),
        )),
        #[cfg(feature = "clarabel")]
        BackendChoice::Clarabel => Ok(Box::new(ClarabelProjector::default())),
        #[cfg(feature = "osqp")]
        BackendChoice::Osqp => Ok(Box::new(OsqpProjector::default())),
        #[cfg(all(feature = "clarabel", feature = "osqp"))]
        BackendChoice::Cross => Ok(Box::new(CrossCheck::new(
            ClarabelProjector::default(),
            OsqpProjector::default(),
            DEFAULT_CROSS_TOLERANCE,
        ))),
        #[allow(unreachable_patterns)]
        other => Err(BackendError::NotCompiled {
            backend: other,
            features: match other {
                BackendChoice::Cross => "clarabel,osqp".to_string(),
                o => o.to_string(),
            },
        }),
    }
}

#[allow(unused_imports)]
use CrossCheck as _;
