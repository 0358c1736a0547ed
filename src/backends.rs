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
    type Err = BackendError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|b| b.to_string() == s)
            .ok_or_else(|| BackendError::Unknown {
                name: s.to_string(),
            })
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
    /// The backend takes no tolerance (the cross-check runs both backends at their defaults).
    #[error("backend `{backend}` takes no tolerance: the cross-check runs both backends at their defaults")]
    NoTolerance {
        /// The backend asked for.
        backend: BackendChoice,
    },
    /// No backend has this name.
    #[error("unknown backend `{name}` (expected clarabel, osqp, cross or reference)")]
    Unknown {
        /// The name given.
        name: String,
    },
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

/// Builds the chosen backend with its accuracy tolerances set to `tolerance` (OSQP:
/// `eps_abs = eps_rel`; Clarabel: `tol_gap_abs = tol_gap_rel = tol_feas`; reference: its KKT
/// tolerance), or with its default (tight) settings when `tolerance` is `None`.
///
/// # Errors
/// [`BackendError::NotCompiled`] when the backend's cargo feature is off;
/// [`BackendError::NoTolerance`] for a tolerance asked of the cross-check (which runs both
/// backends at their defaults).
pub fn make_projector_with_tolerance(
    choice: BackendChoice,
    tolerance: Option<f64>,
) -> Result<Box<dyn Projector>, BackendError> {
    let Some(tol) = tolerance else {
        return make_projector(choice);
    };
    match choice {
        BackendChoice::Reference => Ok(Box::new(sweeping_api::conformance::ReferenceProjector {
            tolerance: tol,
            ..Default::default()
        })),
        #[cfg(feature = "osqp")]
        BackendChoice::Osqp => Ok(Box::new(OsqpProjector::new(OsqpSettings {
            eps_abs: tol,
            eps_rel: tol,
            ..Default::default()
        }))),
        #[cfg(feature = "clarabel")]
        BackendChoice::Clarabel => Ok(Box::new(ClarabelProjector::new(ClarabelSettings {
            tol_gap_abs: tol,
            tol_gap_rel: tol,
            tol_feas: tol,
            ..Default::default()
        }))),
        BackendChoice::Cross => Err(BackendError::NoTolerance { backend: choice }),
        #[allow(unreachable_patterns)]
        other => make_projector(other),
    }
}

#[allow(unused_imports)]
use CrossCheck as _;

#[cfg(test)]
mod tests {
    use super::{BackendChoice, BackendError};

    #[test]
    fn backend_names_round_trip_and_unknown_names_are_typed_errors() {
        for b in BackendChoice::ALL {
            assert_eq!(b.to_string().parse::<BackendChoice>(), Ok(b));
        }
        assert_eq!(
            "gurobi".parse::<BackendChoice>(),
            Err(BackendError::Unknown {
                name: "gurobi".into()
            })
        );
    }
}
