//! The projection backends compiled in (cargo features `clarabel`, `osqp` and `native`), and a
//! constructor by name for command lines and scene files.

use serde::{Deserialize, Serialize};
use sweeping_api::{CrossCheck, Projector};

#[cfg(feature = "clarabel")]
pub use sweeping_clarabel::{ClarabelProjector, ClarabelSettings};
#[cfg(feature = "native")]
pub use sweeping_native::{NativeProjector, NativeSettings};
#[cfg(feature = "osqp")]
pub use sweeping_osqp::{OsqpProjector, OsqpSettings};

/// A backend chosen by name. The default is `native` when its feature is compiled in (the
/// fastest backend whose every answer is certified: README, "Performance"), else `clarabel`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BackendChoice {
    /// Clarabel (interior point), tight settings.
    Clarabel,
    /// OSQP (ADMM), tight settings.
    Osqp,
    /// Both on every step, failing when they disagree by more than the cross-check tolerance.
    Cross,
    /// The dependency-free reference (Hildreth); small problems only.
    Reference,
    /// The native active-set backend, certified by its KKT residuals, falling back to
    /// Clarabel (when compiled in) on the blocks it cannot certify.
    Native,
    /// Native and Clarabel on every step, failing when they disagree by more than
    /// [`NATIVE_CROSS_TOLERANCE`].
    CrossNative,
}

impl Default for BackendChoice {
    fn default() -> Self {
        if cfg!(feature = "native") {
            Self::Native
        } else {
            Self::Clarabel
        }
    }
}

impl BackendChoice {
    /// Every backend this enum can name (compiled in or not: see [`make_projector`]).
    pub const ALL: [BackendChoice; 6] = [
        BackendChoice::Native,
        BackendChoice::Clarabel,
        BackendChoice::Osqp,
        BackendChoice::Cross,
        BackendChoice::CrossNative,
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
            Self::Native => "native",
            Self::CrossNative => "cross-native",
        })
    }
}

/// Default ∞-norm tolerance of the cross-check between Clarabel and OSQP at their tight
/// settings: `1e-6`.
pub const DEFAULT_CROSS_TOLERANCE: f64 = 1e-6;

/// ∞-norm tolerance of the cross-check between the native backend and Clarabel: `1e-8`
/// (both finish with an exact active-set solve).
pub const NATIVE_CROSS_TOLERANCE: f64 = 1e-8;

/// The native backend with its default settings, falling back to Clarabel when compiled in.
#[cfg(feature = "native")]
pub fn native_projector() -> NativeProjector {
    native_projector_on_threads(0)
}

/// The native backend with its default settings but [`NativeSettings::threads`], falling back
/// to Clarabel when compiled in.
#[cfg(feature = "native")]
fn native_projector_on_threads(threads: usize) -> NativeProjector {
    let settings = NativeSettings {
        threads,
        ..NativeSettings::default()
    };
    #[cfg(feature = "clarabel")]
    {
        NativeProjector::with_fallback(settings, Box::new(ClarabelProjector::default()))
    }
    #[cfg(not(feature = "clarabel"))]
    {
        NativeProjector::new(settings)
    }
}

/// The names [`BackendChoice`] parses, for error messages: `native, clarabel, …`.
fn backend_names() -> String {
    BackendChoice::ALL.map(|b| b.to_string()).join(", ")
}

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
    #[error("unknown backend `{name}` (expected one of {})", backend_names())]
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
    make_projector_on_threads(choice, 0)
}

/// Builds the chosen backend with its default (tight) settings, its projections on at most
/// `threads` threads, `0` meaning as many as the cores the process may run on. Only the
/// native backend runs a projection on more than one ([`NativeSettings::threads`]: its
/// blocks and its speculated rescues); the others, and the cross-checks' second backends,
/// run on the caller's thread whatever `threads` says. The answers do not depend on it.
///
/// # Errors
/// [`BackendError::NotCompiled`] when the backend's cargo feature is off.
pub fn make_projector_on_threads(
    choice: BackendChoice,
    threads: usize,
) -> Result<Box<dyn Projector>, BackendError> {
    #[cfg(not(feature = "native"))]
    let _ = threads;
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
        #[cfg(feature = "native")]
        BackendChoice::Native => Ok(Box::new(native_projector_on_threads(threads))),
        #[cfg(all(feature = "clarabel", feature = "native"))]
        BackendChoice::CrossNative => Ok(Box::new(CrossCheck::new(
            native_projector_on_threads(threads),
            ClarabelProjector::default(),
            NATIVE_CROSS_TOLERANCE,
        ))),
        #[allow(unreachable_patterns)]
        other => Err(BackendError::NotCompiled {
            backend: other,
            features: match other {
                BackendChoice::Cross => "clarabel,osqp".to_string(),
                BackendChoice::CrossNative => "clarabel,native".to_string(),
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
        #[cfg(feature = "native")]
        BackendChoice::Native => {
            let mut native = native_projector();
            native.settings.kkt_tolerance = tol;
            Ok(Box::new(native))
        }
        BackendChoice::Cross | BackendChoice::CrossNative => {
            Err(BackendError::NoTolerance { backend: choice })
        }
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
        // The message lists every name that parses (an earlier one left out `native` and
        // `cross-native`).
        let message = "gurobi".parse::<BackendChoice>().unwrap_err().to_string();
        for b in BackendChoice::ALL {
            assert!(
                message.contains(&format!("{b},")) || message.ends_with(&format!("{b})")),
                "{message}"
            );
        }
    }
}
