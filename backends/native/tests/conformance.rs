//! The conformance kit (with and without the Clarabel fallback), agreement with Clarabel on
//! random instances, the fallback path, and typed errors.

use sweeping_api::conformance::{agreement_on_random_instances, max_gap, Agreement, Tolerances};
use sweeping_api::{ProjectionError, ProjectionProblem, Projector, SparseRows};
use sweeping_clarabel::ClarabelProjector;
use sweeping_native::{NativeProjector, NativeSettings};

// KKT residuals are held to 1e-10 (the certificate). Points are checked at 1e-7 because of
// one check: on the near-parallel rows (angle 1e-6) an answer with KKT residuals of 1e-13 sits
// 4.9e-7 from the exact vertex (measured; the kit allows 10 × `point` there): the point error
// of an ill-conditioned vertex goes like the square root of the residuals. Every other check
// passes at 1e-9.

/// The kit alone, without a fallback: every answer is the native method's own.
mod alone {
    use super::*;
    sweeping_api::conformance_tests!(
        NativeProjector::default(),
        Tolerances {
            kkt: 1e-10,
            point: 1e-7,
            certifies_infeasibility: true
        }
    );
}

/// The kit as the root crate builds the backend: with Clarabel behind it.
mod with_fallback {
    use super::*;
    sweeping_api::conformance_tests!(
        NativeProjector::with_fallback(
            NativeSettings::default(),
            Box::new(ClarabelProjector::default())
        ),
        Tolerances {
            kkt: 1e-10,
            point: 1e-7,
            certifies_infeasibility: true
        }
    );
}

#[test]
fn agrees_with_clarabel_on_random_instances_without_fallback() {
    let compared = agreement_on_random_instances(
        &mut NativeProjector::default(),
        &mut ClarabelProjector::default(),
        &Agreement {
            first_seed: 5000,
            instances: 200,
            n_spread: 50,
            m_spread: 80,
            kkt: 1e-10,
            gap: 1e-8,
            weighted: false,
        },
        |sol| match sol.stats.counters.fallbacks {
            0 => Ok(()),
            k => Err(format!("{k} fallbacks")),
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    // Clarabel answers every instance: all are compared.
    assert_eq!(compared, 200);
}

/// Weighted instances with equality rows (the engine solves them in `z = Lᵀx`, equalities as
/// pairs of inequalities), by the active set and by the interior point alone: the KKT
/// conditions in `W` with free-sign multipliers, and agreement with Clarabel (`P = W`, zero
/// cone).
#[test]
fn weighted_instances_with_equalities_agree_with_clarabel() {
    for active_set_iterations in [48, 0] {
        let compared = agreement_on_random_instances(
            &mut NativeProjector::new(NativeSettings {
                active_set_iterations,
                ..NativeSettings::default()
            }),
            &mut ClarabelProjector::default(),
            &Agreement {
                first_seed: 9000,
                instances: 120,
                n_spread: 40,
                m_spread: 60,
                kkt: 1e-9,
                gap: 1e-6,
                weighted: true,
            },
            |sol| match sol.stats.counters.fallbacks {
                0 => Ok(()),
                k => Err(format!("{k} fallbacks")),
            },
        )
        .unwrap_or_else(|e| panic!("active set iterations {active_set_iterations}: {e}"));
        assert_eq!(compared, 120);
    }
}

/// The kit with the active set's warm attempt off, so that every block goes to the interior
/// point (and its finish): the same KKT tolerance, and points within `1e-6`, the measure of
/// an interior point accepted short of its tolerance (it stalls from a `y` already on the
/// boundary of a degenerate set, as the kit's idempotence check has it, when the finish
/// cannot take it over).
mod interior_point {
    use super::*;
    sweeping_api::conformance_tests!(
        NativeProjector::new(NativeSettings {
            active_set_iterations: 0,
            ..NativeSettings::default()
        }),
        Tolerances {
            kkt: 1e-10,
            point: 1e-6,
            certifies_infeasibility: true
        }
    );
}

#[test]
fn interior_point_answers_agree_with_clarabel_on_random_instances() {
    let mut interior = 0;
    let compared = agreement_on_random_instances(
        &mut NativeProjector::new(NativeSettings {
            active_set_iterations: 0,
            ..NativeSettings::default()
        }),
        &mut ClarabelProjector::default(),
        &Agreement {
            first_seed: 7000,
            instances: 200,
            n_spread: 50,
            m_spread: 80,
            kkt: 1e-10,
            gap: 1e-8,
            weighted: false,
        },
        |sol| {
            interior += sol.stats.counters.escalations;
            match sol.stats.counters.fallbacks {
                0 => Ok(()),
                k => Err(format!("{k} fallbacks")),
            }
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(compared, 200);
    assert!(
        interior >= 200,
        "only {interior} blocks went to the interior point"
    );
}

/// A support method capped at one guess cannot finish a problem that needs rows to join: the
/// interior point takes the blocks, or (capped at one iteration too) the block goes to the
/// fallback, is counted, and the answer is the fallback's.
#[test]
fn capped_solver_goes_to_the_interior_point_or_falls_back_and_counts() {
    // Two independent wedges (blocks); projecting onto each needs more than one step from the
    // violated rows: y violates only the first row of each, the second becomes violated after.
    let rows = SparseRows::from_rows(
        4,
        &[
            vec![(0, 1.0)],
            vec![(0, -1.0), (1, 1.0)],
            vec![(2, 1.0)],
            vec![(2, -1.0), (3, 1.0)],
        ],
    );
    let p =
        ProjectionProblem::new(vec![-1.0, 0.0, -1.0, 0.0], rows, vec![0.0, 0.5, 0.0, 0.5]).unwrap();
    let rescue = NativeProjector::new(NativeSettings {
        active_set_iterations: 1,
        ..NativeSettings::default()
    })
    .project(&p)
    .unwrap();
    assert_eq!(
        (
            rescue.stats.counters.escalations,
            rescue.stats.counters.fallbacks
        ),
        (2, 0)
    );
    let capped = NativeSettings {
        active_set_iterations: 1,
        interior_point_iterations: 1,
        finish_iterations: 0,
        ..NativeSettings::default()
    };
    // Neither method finishing, and no fallback: a typed error naming the block.
    match NativeProjector::new(capped.clone()).project(&p) {
        Err(ProjectionError::NotConverged {
            backend, status, ..
        }) => {
            assert_eq!(backend, "native");
            assert!(status.contains("block 0"), "{status}");
        }
        other => panic!("expected NotConverged, got {other:?}"),
    }
    let mut native = NativeProjector::with_fallback(capped, Box::new(ClarabelProjector::default()));
    let sol = native.project(&p).unwrap();
    assert_eq!(sol.stats.counters.fallbacks, 2, "both blocks fell back");
    assert_eq!(sol.stats.backend, "native");
    let exact = NativeProjector::default().project(&p).unwrap();
    assert_eq!(
        (
            exact.stats.counters.fallbacks,
            exact.stats.counters.escalations
        ),
        (0, 0)
    );
    assert!(max_gap(&sol.x, &exact.x) <= 1e-8);
    assert!(max_gap(&rescue.x, &exact.x) <= 1e-12);
    assert!(p.kkt_residuals(&sol.x, &sol.multipliers).max() <= 1e-8);
}

#[test]
fn infeasible_sets_are_certified_with_the_rows() {
    // x₀ + x₁ ≥ 1, −x₀ ≥ 0, −x₁ ≥ 0, plus an unrelated feasible block.
    let rows = SparseRows::from_rows(
        3,
        &[
            vec![(2, 1.0)],
            vec![(0, 1.0), (1, 1.0)],
            vec![(0, -1.0)],
            vec![(1, -1.0)],
        ],
    );
    let p = ProjectionProblem::new(vec![0.0; 3], rows, vec![1.0, 1.0, 0.0, 0.0]).unwrap();
    match NativeProjector::default().project(&p) {
        Err(ProjectionError::Infeasible {
            backend, detail, ..
        }) => {
            assert_eq!(backend, "native");
            assert!(detail.contains("[1, 2, 3]"), "{detail}");
        }
        other => panic!("expected Infeasible, got {other:?}"),
    }
    let empty = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 0.0)]]);
    let p = ProjectionProblem::new(vec![0.0; 2], empty, vec![1.0, 0.5]).unwrap();
    match NativeProjector::default().project(&p) {
        Err(ProjectionError::Infeasible { detail, .. }) => {
            assert!(detail.contains("row 1"), "{detail}")
        }
        other => panic!("expected Infeasible, got {other:?}"),
    }
}

#[test]
fn tolerance_is_the_weaker_of_own_and_fallback() {
    assert_eq!(NativeProjector::default().tolerance(), 1e-10);
    let with = NativeProjector::with_fallback(
        NativeSettings::default(),
        Box::new(ClarabelProjector::default()),
    );
    assert_eq!(with.tolerance(), ClarabelProjector::default().tolerance());
}
