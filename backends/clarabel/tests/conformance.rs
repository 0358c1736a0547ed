//! The conformance kit, agreement with the reference projector, status mapping, a crowd-like
//! problem, and inputs that must not make the backend panic.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sweeping_api::conformance::{
    agreement_on_random_instances, max_gap, random_instance, Agreement, ReferenceProjector,
    Tolerances,
};
use sweeping_api::{
    CrossCheck, ProjectionError, ProjectionProblem, Projector, SolveStatus, SparseRows,
};
use sweeping_clarabel::{ClarabelProjector, ClarabelSettings};

sweeping_api::conformance_tests!(
    ClarabelProjector::default(),
    Tolerances {
        kkt: 1e-7,
        point: 1e-6,
        certifies_infeasibility: true
    }
);

#[test]
fn agrees_with_reference_on_random_instances() {
    // Hildreth's method stalls on a few degenerate instances; those are skipped.
    let compared = agreement_on_random_instances(
        &mut ClarabelProjector::default(),
        &mut ReferenceProjector::default(),
        &Agreement {
            first_seed: 1000,
            instances: 150,
            n_spread: 50,
            m_spread: 80,
            kkt: 1e-7,
            gap: 1e-6,
            weighted: false,
        },
        |_| Ok(()),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(compared >= 140, "only {compared} instances compared");
}

#[test]
fn agrees_with_reference_on_weighted_instances_with_equalities() {
    let compared = agreement_on_random_instances(
        &mut ClarabelProjector::default(),
        &mut ReferenceProjector::default(),
        &Agreement {
            first_seed: 1500,
            instances: 80,
            n_spread: 30,
            m_spread: 40,
            kkt: 1e-7,
            gap: 1e-8,
            weighted: true,
        },
        |_| Ok(()),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(compared >= 70, "only {compared} instances compared");
}

#[test]
fn cross_check_with_reference_passes() {
    let mut both = CrossCheck::new(
        ClarabelProjector::default(),
        ReferenceProjector::default(),
        1e-6,
    );
    for seed in 0..20u64 {
        both.project(&random_instance(seed, 10, 12)).unwrap();
    }
    assert_eq!(both.stats().compared, 20);
    assert!(both.stats().max_gap <= 1e-6);
}

#[test]
fn polished_answers_meet_tighter_tolerances() {
    // Every check but the near-parallel rows, whose point is ill-conditioned (moving along the
    // second row by 1e-7 changes it by 1e-13).
    let tol = Tolerances {
        kkt: 1e-9,
        point: 1e-8,
        certifies_infeasibility: true,
    };
    let mut clarabel = ClarabelProjector::default();
    for (name, check) in sweeping_api::conformance::all_checks() {
        if name != "near_parallel_rows" {
            check(&mut clarabel, &tol).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
}

#[test]
fn unpolished_answers_still_pass_the_kit_at_reduced_point_accuracy() {
    // Without polishing a weakly active row (the orthant's y has a coordinate exactly on the
    // boundary) leaves the point off by ~1e-5: the fallback when polishing is refused.
    let mut clarabel = ClarabelProjector::new(ClarabelSettings {
        polish: false,
        ..ClarabelSettings::default()
    });
    let tol = Tolerances {
        kkt: 1e-7,
        point: 1e-4,
        certifies_infeasibility: true,
    };
    let failures = sweeping_api::conformance::run_all(&mut clarabel, &tol);
    assert!(failures.is_empty(), "{failures:?}");
}

#[test]
fn reports_the_tolerance_it_meets() {
    let mut clarabel = ClarabelProjector::default();
    assert_eq!(clarabel.name(), "clarabel");
    let tol = clarabel.tolerance();
    assert!((tol - 1e-8).abs() < 1e-20, "tolerance {tol}");
    assert_meets_its_tolerance(&mut clarabel, 5000);
}

/// `clarabel`'s answers on 60 random instances (seeds from `first_seed`) have KKT residuals
/// within the tolerance it reports.
fn assert_meets_its_tolerance(clarabel: &mut ClarabelProjector, first_seed: u64) {
    let tol = clarabel.tolerance();
    for seed in 0..60u64 {
        let problem = random_instance(
            first_seed + seed,
            3 + seed as usize % 40,
            seed as usize % 70,
        );
        let sol = clarabel.project(&problem).unwrap();
        let kkt = problem.kkt_residuals(&sol.x, &sol.multipliers).max();
        assert!(
            kkt <= tol,
            "instance {seed}: KKT residual {kkt:.3e} > {tol:.1e}"
        );
    }
}

#[test]
fn the_loose_preset_is_clarabels_own_tolerances_and_meets_them() {
    let loose = ClarabelSettings::loose();
    assert_eq!(
        (loose.tol_gap_abs, loose.tol_gap_rel, loose.tol_feas),
        (1e-8, 1e-8, 1e-8)
    );
    assert!(loose.accept_almost_solved);
    // Nothing else differs from the defaults.
    let default = ClarabelSettings::default();
    assert_eq!(
        ClarabelSettings {
            tol_gap_abs: default.tol_gap_abs,
            tol_gap_rel: default.tol_gap_rel,
            tol_feas: default.tol_feas,
            accept_almost_solved: default.accept_almost_solved,
            ..loose.clone()
        },
        default
    );
    let mut clarabel = ClarabelProjector::new(loose);
    let tol = clarabel.tolerance();
    assert!((tol - 1e-6).abs() < 1e-18, "tolerance {tol}");
    assert_meets_its_tolerance(&mut clarabel, 7000);
}

#[test]
fn infeasible_set_is_certified() {
    // x₀ + x₁ ≥ 1 with x₀ ≤ 0 and x₁ ≤ 0: empty.
    let a = SparseRows::from_rows(
        3,
        &[vec![(0, 1.0), (1, 1.0)], vec![(0, -1.0)], vec![(1, -1.0)]],
    );
    let problem = ProjectionProblem::new(vec![0.5, 0.5, 9.0], a, vec![1.0, 0.0, 0.0]).unwrap();
    match ClarabelProjector::default().project(&problem) {
        Err(ProjectionError::Infeasible {
            backend, detail, ..
        }) => {
            assert_eq!(backend, "clarabel");
            assert!(detail.contains("PrimalInfeasible"), "detail: {detail}");
        }
        other => panic!("expected Infeasible, got {other:?}"),
    }
}

#[test]
fn empty_row_with_positive_bound_is_infeasible() {
    // Row 1 reads 0 ≥ 0.5 (its entries cancel); no solver is needed to see it.
    let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 2.0), (1, -2.0)]]);
    let problem = ProjectionProblem::new(vec![0.0, 0.0], a, vec![1.0, 0.5]).unwrap();
    let err = ClarabelProjector::default().project(&problem).unwrap_err();
    assert!(
        matches!(err, ProjectionError::Infeasible { .. }),
        "got {err}"
    );
    // No coordinates at all, one row 0 ≥ 1.
    let a = SparseRows::from_rows(0, &[vec![]]);
    let problem = ProjectionProblem::new(vec![], a, vec![1.0]).unwrap();
    let err = ClarabelProjector::default().project(&problem).unwrap_err();
    assert!(
        matches!(err, ProjectionError::Infeasible { .. }),
        "got {err}"
    );
}

#[test]
fn iteration_and_time_limits_are_not_converged() {
    let problem = random_instance(3, 20, 30);
    // Without polishing, which could turn even a poor iterate into a verified answer.
    let mut one_iteration = ClarabelProjector::new(ClarabelSettings {
        max_iter: 1,
        polish: false,
        ..ClarabelSettings::default()
    });
    match one_iteration.project(&problem) {
        Err(ProjectionError::NotConverged {
            backend,
            iterations,
            status,
        }) => {
            assert_eq!(backend, "clarabel");
            assert_eq!(status, "MaxIterations");
            assert!(iterations <= 1);
        }
        other => panic!("expected NotConverged, got {other:?}"),
    }
    let mut no_time = ClarabelProjector::new(ClarabelSettings {
        time_limit: Some(0.0),
        polish: false,
        ..ClarabelSettings::default()
    });
    match no_time.project(&problem) {
        Err(ProjectionError::NotConverged { status, .. }) => assert_eq!(status, "MaxTime"),
        other => panic!("expected NotConverged, got {other:?}"),
    }
}

#[test]
fn stalled_solves_are_verified_by_their_kkt_residuals() {
    // At tolerances of 1e-14 Clarabel stalls at the floor of double precision on some
    // instances (InsufficientProgress or AlmostSolved); the polished iterate meets the KKT
    // conditions to within `tolerance()` = 1e-12 and is returned as solved.
    let tight = |polish| ClarabelSettings {
        tol_gap_abs: 1e-14,
        tol_gap_rel: 1e-14,
        tol_feas: 1e-14,
        polish,
        ..ClarabelSettings::default()
    };
    let mut unpolished = ClarabelProjector::new(tight(false));
    let mut polished = ClarabelProjector::new(tight(true));
    let mut stalled = 0;
    for seed in 0..40u64 {
        let n = 2 + (seed as usize * 7) % 30;
        let m = (seed as usize * 13) % 45;
        let problem = random_instance(seed, n, m);
        match unpolished.project(&problem) {
            Ok(_) => {}
            Err(ProjectionError::NotConverged { status, .. }) => {
                assert!(
                    status == "InsufficientProgress" || status == "AlmostSolved",
                    "instance {seed}: status {status}"
                );
                stalled += 1;
            }
            Err(e) => panic!("instance {seed}: {e}"),
        }
        let sol = polished
            .project(&problem)
            .unwrap_or_else(|e| panic!("instance {seed}: {e}"));
        assert!(matches!(
            sol.stats.status,
            SolveStatus::Solved | SolveStatus::Trivial
        ));
        let kkt = problem.kkt_residuals(&sol.x, &sol.multipliers).max();
        assert!(
            kkt <= polished.tolerance(),
            "instance {seed}: KKT {kkt:.3e}"
        );
    }
    assert!(
        stalled > 0,
        "no instance stalled: the verification path went untested"
    );
}

#[test]
fn invalid_settings_are_a_backend_error() {
    let problem = random_instance(4, 5, 5);
    for settings in [
        ClarabelSettings {
            tol_feas: f64::NAN,
            ..ClarabelSettings::default()
        },
        ClarabelSettings {
            tol_gap_abs: 0.0,
            ..ClarabelSettings::default()
        },
        ClarabelSettings {
            time_limit: Some(-1.0),
            ..ClarabelSettings::default()
        },
    ] {
        let err = ClarabelProjector::new(settings)
            .project(&problem)
            .unwrap_err();
        assert!(matches!(err, ProjectionError::Backend { .. }), "got {err}");
    }
}

#[test]
fn statistics_are_filled() {
    let problem = random_instance(8, 30, 40);
    let sol = ClarabelProjector::default().project(&problem).unwrap();
    assert_eq!(sol.stats.backend, "clarabel");
    assert_eq!(sol.stats.status, SolveStatus::Solved);
    assert!(sol.stats.iterations > 0);
    assert!(sol.stats.setup_seconds > 0.0 && sol.stats.solve_seconds > 0.0);
    assert!(!sol.stats.warm_started);

    // Feasible y: the solver is skipped.
    let feasible =
        ProjectionProblem::new(sol.x.clone(), problem.a().clone(), problem.b().to_vec()).unwrap();
    let again = ClarabelProjector::default().project(&feasible).unwrap();
    assert_eq!(again.stats.status, SolveStatus::Trivial);
    assert_eq!(again.stats.iterations, 0);
    assert_eq!(again.x, sol.x);
}

#[test]
fn settings_round_trip_through_serde() {
    let loose = ClarabelSettings::loose();
    assert!(loose.accept_almost_solved && loose.tol_feas > ClarabelSettings::default().tol_feas);
    let text = serde_json::to_string(&loose).unwrap();
    let back: ClarabelSettings = serde_json::from_str(&text).unwrap();
    assert_eq!(back, loose);
    // Missing fields take their defaults.
    let partial: ClarabelSettings = serde_json::from_str(r#"{"max_iter": 50}"#).unwrap();
    assert_eq!(
        partial,
        ClarabelSettings {
            max_iter: 50,
            ..ClarabelSettings::default()
        }
    );
    let mut loose_projector = ClarabelProjector::new(loose);
    let problem = random_instance(12, 25, 35);
    let sol = loose_projector.project(&problem).unwrap();
    let kkt = problem.kkt_residuals(&sol.x, &sol.multipliers).max();
    assert!(kkt <= loose_projector.tolerance(), "KKT residual {kkt:.3e}");
}

/// Disks of radius `r` on an `nx × ny` grid (spacing slightly above `2r`, jittered), all
/// pushed a distance `h` towards a point beyond the grid, with the linearized non-overlap
/// row `e_ij · (x_j − x_i) ≥ 2r` for every pair closer than `2r + 2h` (`e_ij` the unit vector
/// from `i` to `j`), the whole scene translated by `offset`.
fn crowd(nx: usize, ny: usize, h: f64, offset: f64) -> ProjectionProblem {
    let (r, spacing) = (0.2, 0.41);
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let mut q = Vec::new();
    for i in 0..nx {
        for j in 0..ny {
            q.push(offset + i as f64 * spacing + rng.gen_range(0.0..0.005));
            q.push(offset + j as f64 * spacing + rng.gen_range(0.0..0.005));
        }
    }
    let people = q.len() / 2;
    let target = (
        offset + 1.3 * nx as f64 * spacing,
        offset + 0.5 * ny as f64 * spacing,
    );
    let mut y = q.clone();
    for k in 0..people {
        let (dx, dy) = (target.0 - q[2 * k], target.1 - q[2 * k + 1]);
        let d = dx.hypot(dy);
        y[2 * k] += h * dx / d;
        y[2 * k + 1] += h * dy / d;
    }
    let mut a = SparseRows::new(2 * people);
    let mut b = Vec::new();
    for i in 0..people {
        for j in i + 1..people {
            let (dx, dy) = (q[2 * j] - q[2 * i], q[2 * j + 1] - q[2 * i + 1]);
            let d = dx.hypot(dy);
            if d < 2.0 * r + 2.0 * h {
                let (ex, ey) = (dx / d, dy / d);
                a.push_row([(2 * i, -ex), (2 * i + 1, -ey), (2 * j, ex), (2 * j + 1, ey)]);
                b.push(2.0 * r);
            }
        }
    }
    ProjectionProblem::new(y, a, b).unwrap()
}

#[test]
fn crowd_of_sixty_on_a_grid() {
    for (h, offset, min_active) in [(0.1, 0.0, 20), (0.3, 100.0, 40), (0.5, 250.0, 50)] {
        let problem = crowd(10, 6, h, offset);
        assert_eq!(problem.dim(), 120);
        let sol = ClarabelProjector::default()
            .project(&problem)
            .unwrap_or_else(|e| panic!("h = {h}: {e}"));
        assert_eq!(sol.stats.status, SolveStatus::Solved);
        let kkt = problem.kkt_residuals(&sol.x, &sol.multipliers);
        assert!(kkt.max() <= 1e-9, "h = {h}: {kkt:?}");
        assert!(
            sol.active_count(1e-6) >= min_active,
            "h = {h}: a jam should press many contacts, got {}",
            sol.active_count(1e-6)
        );
        let reference = ReferenceProjector::default().project(&problem).unwrap();
        let gap = max_gap(&sol.x, &reference.x);
        assert!(gap <= 1e-8, "h = {h}: gap to the reference {gap:.3e}");
    }
}

#[test]
fn awkward_inputs_do_not_panic() {
    let mut clarabel = ClarabelProjector::default();
    // A column repeated within a row (summed, as `SparseRows::mul_vec` does).
    let a = SparseRows::from_rows(2, &[vec![(0, 0.5), (1, 1.0), (0, 0.5)]]);
    let problem = ProjectionProblem::new(vec![0.0, 0.0], a, vec![2.0]).unwrap();
    let sol = clarabel.project(&problem).unwrap();
    assert!(max_gap(&sol.x, &[1.0, 1.0]) < 1e-7, "x = {:?}", sol.x);
    assert!(problem.kkt_residuals(&sol.x, &sol.multipliers).max() < 1e-7);

    // Explicit zeros and an all-zero row that is satisfied (0 ≥ −1).
    let a = SparseRows::from_rows(2, &[vec![(0, 0.0), (1, 1.0)], vec![(0, 0.0)]]);
    let problem = ProjectionProblem::new(vec![3.0, -1.0], a, vec![0.0, -1.0]).unwrap();
    let sol = clarabel.project(&problem).unwrap();
    assert!(max_gap(&sol.x, &[3.0, 0.0]) < 1e-7, "x = {:?}", sol.x);

    // Badly scaled, huge and tiny data: any answer or error, but no panic.
    let scales = [1e-150, 1e-20, 1e20, 1e150, 1e300];
    for (k, &s) in scales.iter().enumerate() {
        let a = SparseRows::from_rows(2, &[vec![(0, s), (1, 1.0)], vec![(0, 1.0), (1, -s)]]);
        let y = vec![s.sqrt(), -s];
        if let Ok(problem) = ProjectionProblem::new(y, a, vec![s, 1.0]) {
            let _ = clarabel.project(&problem);
        }
        let _ = k;
    }
    // The same point pushed into many identical rows.
    let rows: Vec<Vec<(usize, f64)>> = (0..50).map(|_| vec![(0, 1.0), (1, 1.0)]).collect();
    let problem = ProjectionProblem::new(
        vec![0.0, 0.0],
        SparseRows::from_rows(2, &rows),
        vec![1.0; 50],
    )
    .unwrap();
    let sol = clarabel.project(&problem).unwrap();
    assert!(max_gap(&sol.x, &[0.5, 0.5]) < 1e-6, "x = {:?}", sol.x);
}

#[test]
fn random_awkward_problems_never_panic() {
    // Small problems mixing empty rows, repeated columns, explicit zeros and entries spread
    // over sixteen orders of magnitude: any answer or error is fine, a panic is not.
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let values = [0.0, 1.0, -1.0, 1e-8, -1e-8, 1e8, -1e8, 0.5];
    let mut clarabel = ClarabelProjector::default();
    let (mut solved, mut failed) = (0, 0);
    for _ in 0..500 {
        let n = rng.gen_range(0..6);
        let m = rng.gen_range(0..8);
        let mut a = SparseRows::new(n);
        for _ in 0..m {
            let k = if n == 0 { 0 } else { rng.gen_range(0..4) };
            let row: Vec<(usize, f64)> = (0..k)
                .map(|_| (rng.gen_range(0..n), values[rng.gen_range(0..values.len())]))
                .collect();
            a.push_row(row);
        }
        let y: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.0..3.0)).collect();
        let b: Vec<f64> = (0..m).map(|_| rng.gen_range(-2.0..2.0)).collect();
        let problem = ProjectionProblem::new(y, a, b).unwrap();
        match clarabel.project(&problem) {
            Ok(sol) => {
                solved += 1;
                assert!(sol.x.iter().all(|v| v.is_finite()));
                assert!(sol.multipliers.iter().all(|l| l.is_finite() && *l >= 0.0));
            }
            Err(_) => failed += 1,
        }
    }
    assert!(
        solved > 100 && failed > 10,
        "solved {solved}, failed {failed}"
    );
}
