//! The projection backends compiled in (cargo features `clarabel`, `osqp` and `native`), and a
//! constructor by name for command lines and scene files.

use serde::{Deserialize, Serialize};
use sweeping_api::{Blocked, CrossCheck, Projector};

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
    /// Clarabel (interior point), tight settings, block by block ([`Blocked`]).
    Clarabel,
    /// OSQP (ADMM), tight settings, block by block ([`Blocked`]).
    Osqp,
    /// Both on every step, failing when they disagree by more than the cross-check tolerance.
    Cross,
    /// The dependency-free reference (Hildreth); small problems only.
    Reference,
    /// The native backend (the engine of `sweeping-qp`: a warm active set, an interior point
    /// for rigid clusters), certified by its KKT residuals, falling back to Clarabel (when
    /// compiled in) on the blocks it cannot certify.
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
/// (the native answers lie within `1e-10` of the block's length scale of the projection,
/// Clarabel's are polished by an exact active-set solve).
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

/// How [`make_projector_with`] builds a backend; the default builds what [`make_projector`]
/// does.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ProjectorOptions {
    /// The backend's accuracy tolerances (OSQP: `eps_abs = eps_rel`; Clarabel: `tol_gap_abs =
    /// tol_gap_rel = tol_feas`; native: its KKT tolerance; reference: its KKT tolerance), or
    /// `None` for its default (tight) settings. The cross-checks take none. Default `None`.
    pub tolerance: Option<f64>,
    /// Most threads a projection runs on, `0` meaning as many as the cores the process may run
    /// on. The native backend runs a projection's large blocks on more than one
    /// ([`NativeSettings::threads`](crate::backends::NativeSettings::threads)), and the
    /// cross-checks, with two or more, run their two backends at once
    /// ([`CrossCheck::concurrent`]; `cross-native`'s native backend then on one thread
    /// fewer); Clarabel and OSQP run on one thread whatever it says. The answers do not depend
    /// on it. Default `0`.
    pub threads: usize,
}

/// How reports name [`ProjectorOptions::threads`] after a backend's name: nothing for `0`
/// (every core), ` on 1 thread`, ` on at most N threads`.
pub fn threads_phrase(threads: usize) -> String {
    match threads {
        0 => String::new(),
        1 => " on 1 thread".to_string(),
        n => format!(" on at most {n} threads"),
    }
}

/// Builds the chosen backend with its default (tight) settings.
///
/// # Errors
/// [`BackendError::NotCompiled`] when the backend's cargo feature is off.
pub fn make_projector(choice: BackendChoice) -> Result<Box<dyn Projector>, BackendError> {
    make_projector_with(choice, ProjectorOptions::default())
}

/// Builds the chosen backend with its accuracy tolerances set to `tolerance`, or with its
/// default (tight) settings when `tolerance` is `None` (see [`ProjectorOptions::tolerance`]).
///
/// # Errors
/// As [`make_projector_with`].
pub fn make_projector_with_tolerance(
    choice: BackendChoice,
    tolerance: Option<f64>,
) -> Result<Box<dyn Projector>, BackendError> {
    make_projector_with(
        choice,
        ProjectorOptions {
            tolerance,
            ..ProjectorOptions::default()
        },
    )
}

/// Builds the chosen backend with `options`.
///
/// Clarabel and OSQP are handed a projection block by block ([`Blocked`]: the connected
/// components of its rows that hold a row `y` violates), as the native backend
/// splits it itself. Neither solver finds the blocks on its own: given the whole problem, each
/// iterates on every unknown and every row of a crowd where a few queues are jammed. Blocks
/// change which rounding a solver's answer carries, not the projection (the split is exact).
///
/// # Errors
/// [`BackendError::NotCompiled`] when the backend's cargo feature is off;
/// [`BackendError::NoTolerance`] for a tolerance asked of a cross-check (which runs both
/// backends at their defaults).
pub fn make_projector_with(
    choice: BackendChoice,
    options: ProjectorOptions,
) -> Result<Box<dyn Projector>, BackendError> {
    let ProjectorOptions { tolerance, threads } = options;
    // The cross-checks run their two backends at once when they may use two threads; then
    // `cross-native`'s native backend runs on the threads Clarabel leaves it, so that the
    // projection still runs on at most `threads`.
    let usable = match threads {
        0 => std::thread::available_parallelism().map_or(1, usize::from),
        n => n,
    };
    #[allow(unused_variables)]
    let concurrent = usable >= 2;
    match (choice, tolerance) {
        (BackendChoice::Cross | BackendChoice::CrossNative, Some(_)) => {
            Err(BackendError::NoTolerance { backend: choice })
        }
        (BackendChoice::Reference, tol) => {
            let mut reference = sweeping_api::conformance::ReferenceProjector::default();
            if let Some(tol) = tol {
                reference.tolerance = tol;
            }
            Ok(Box::new(reference))
        }
        #[cfg(feature = "clarabel")]
        (BackendChoice::Clarabel, None) => Ok(Box::new(Blocked::new(ClarabelProjector::default()))),
        #[cfg(feature = "clarabel")]
        (BackendChoice::Clarabel, Some(tol)) => Ok(Box::new(Blocked::new(ClarabelProjector::new(
            ClarabelSettings {
                tol_gap_abs: tol,
                tol_gap_rel: tol,
                tol_feas: tol,
                ..Default::default()
            },
        )))),
        #[cfg(feature = "osqp")]
        (BackendChoice::Osqp, None) => Ok(Box::new(Blocked::new(OsqpProjector::default()))),
        #[cfg(feature = "osqp")]
        (BackendChoice::Osqp, Some(tol)) => {
            Ok(Box::new(Blocked::new(OsqpProjector::new(OsqpSettings {
                eps_abs: tol,
                eps_rel: tol,
                ..Default::default()
            }))))
        }
        #[cfg(all(feature = "clarabel", feature = "osqp"))]
        (BackendChoice::Cross, None) => Ok(Box::new(
            CrossCheck::new(
                Blocked::new(ClarabelProjector::default()),
                Blocked::new(OsqpProjector::default()),
                DEFAULT_CROSS_TOLERANCE,
            )
            .concurrent(concurrent),
        )),
        #[cfg(feature = "native")]
        (BackendChoice::Native, tol) => {
            let mut native = native_projector_on_threads(threads);
            if let Some(tol) = tol {
                native.settings_mut().kkt_tolerance = tol;
            }
            Ok(Box::new(native))
        }
        #[cfg(all(feature = "clarabel", feature = "native"))]
        (BackendChoice::CrossNative, None) => Ok(Box::new(
            CrossCheck::new(
                native_projector_on_threads(if concurrent { usable - 1 } else { threads }),
                Blocked::new(ClarabelProjector::default()),
                NATIVE_CROSS_TOLERANCE,
            )
            .concurrent(concurrent),
        )),
        #[allow(unreachable_patterns)]
        (other, _) => Err(BackendError::NotCompiled {
            backend: other,
            features: match other {
                BackendChoice::Cross => "clarabel,osqp".to_string(),
                BackendChoice::CrossNative => "clarabel,native".to_string(),
                o => o.to_string(),
            },
        }),
    }
}

#[allow(unused_imports)]
use {Blocked as _, CrossCheck as _};

#[cfg(test)]
mod tests {
    use super::{
        make_projector, make_projector_with, BackendChoice, BackendError, ProjectorOptions,
    };

    #[test]
    fn a_tolerance_reaches_every_backend_but_the_cross_checks_which_refuse_it() {
        let loose = ProjectorOptions {
            tolerance: Some(1e-3),
            threads: 1,
        };
        let mut built = 0;
        for choice in BackendChoice::ALL {
            match (make_projector(choice), make_projector_with(choice, loose)) {
                (_, Err(BackendError::NoTolerance { backend })) => {
                    assert_eq!(backend, choice);
                    assert!(matches!(
                        choice,
                        BackendChoice::Cross | BackendChoice::CrossNative
                    ));
                }
                (Ok(tight), Ok(loose)) => {
                    assert!(
                        loose.tolerance() > tight.tolerance(),
                        "{choice}: {} against {}",
                        loose.tolerance(),
                        tight.tolerance()
                    );
                    built += 1;
                }
                (Err(BackendError::NotCompiled { .. }), Err(BackendError::NotCompiled { .. })) => {}
                (tight, loose) => panic!("{choice}: {:?} against {:?}", tight.err(), loose.err()),
            }
        }
        // The reference backend at least is always compiled in.
        assert!(built >= 1);
    }

    /// `k` pairs of people on a line, each pair pushed together (`x₂ᵢ₊₁ − x₂ᵢ ≥ 0.4`, violated
    /// at `y`) and 10 m from the next: `k` independent blocks.
    fn pushed_pairs(k: usize) -> sweeping_api::ProjectionProblem {
        let rows: Vec<Vec<(usize, f64)>> = (0..k)
            .map(|i| vec![(2 * i, -1.0), (2 * i + 1, 1.0)])
            .collect();
        let a = sweeping_api::SparseRows::from_rows(2 * k, &rows);
        let y = (0..k)
            .flat_map(|i| [10.0 * i as f64, 10.0 * i as f64 + 0.1])
            .collect();
        sweeping_api::ProjectionProblem::new(y, a, vec![0.4; k]).unwrap()
    }

    #[test]
    fn clarabel_and_osqp_by_name_solve_each_block_on_its_own() {
        // Given the whole problem, Clarabel and OSQP iterate on all 50 pairs at once; block by
        // block (`Blocked`) every pair is a solve of its own, of at least two iterations, and
        // the statistics add them up.
        let k = 50;
        let p = pushed_pairs(k);
        let options = ProjectorOptions {
            tolerance: None,
            threads: 1,
        };
        let mut solved = 0;
        // `cross` reports its first backend's statistics, Clarabel's.
        for choice in [
            BackendChoice::Clarabel,
            BackendChoice::Osqp,
            BackendChoice::Cross,
        ] {
            let Ok(mut projector) = make_projector_with(choice, options) else {
                continue;
            };
            let answer = projector.project(&p).unwrap();
            assert!(
                answer.stats.iterations >= 2 * k as u32,
                "{choice}: {} iterations for {k} blocks",
                answer.stats.iterations
            );
            for i in 0..k {
                let (left, right) = (answer.x[2 * i], answer.x[2 * i + 1]);
                let centre = 10.0 * i as f64 + 0.05;
                assert!((left - (centre - 0.2)).abs() < 1e-7, "{choice}: pair {i}");
                assert!((right - (centre + 0.2)).abs() < 1e-7, "{choice}: pair {i}");
            }
            solved += 1;
        }
        assert!(solved >= usize::from(cfg!(feature = "clarabel")));
    }

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
        // The message lists every name that parses, `native` and `cross-native` included.
        let message = "gurobi".parse::<BackendChoice>().unwrap_err().to_string();
        for b in BackendChoice::ALL {
            assert!(
                message.contains(&format!("{b},")) || message.ends_with(&format!("{b})")),
                "{message}"
            );
        }
    }
}
