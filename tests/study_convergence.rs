//! The study tools: order fits on exact power laws, the true error of the scheme on exact
//! solutions, and a short convergence study on a small crowd (the paper's protocol).

use std::sync::Arc;
use sweeping::api::conformance::ReferenceProjector;
use sweeping::crowd::{rectangle_walls, DiskPairs, PersonShapes, Population};
use sweeping::prelude::*;
use sweeping::study::exact::{
    true_error_study, ExactCase, PointAroundDisk, PointBehindMovingWall, TwoDisksOnALine,
};
use sweeping::study::{
    converge, fit_order, BoxError, ConvergenceReport, ConvergenceSettings, StudyError,
};

fn reference() -> Result<Box<dyn Projector>, BoxError> {
    Ok(Box::new(ReferenceProjector::default()))
}

/// The steps of the true-error studies on the moving wall and the disk.
const SMALL_HS: [f64; 5] = [0.005, 0.01, 0.02, 0.04, 0.08];

/// The true error of the scheme on `case` at each step of `hs`, 10 comparison times, with
/// the reference projector and the default stepper settings, in parallel.
fn true_error_of(case: &dyn ExactCase, hs: &[f64]) -> ConvergenceReport {
    true_error_study(case, hs, 10, &reference, &StepperSettings::default(), true).unwrap()
}

/// Every run of the study ended each step within `tol` of the true constraints.
fn assert_rows_feasible(report: &ConvergenceReport, tol: f64) {
    for r in &report.rows {
        assert!(
            r.cost.max_violation < tol,
            "h = {}: violation {}",
            r.h,
            r.cost.max_violation
        );
    }
}

/// Hildreth's method crawls on jammed crowds at 1e-10; 1e-8 is far below the errors studied.
fn crowd_reference() -> Result<Box<dyn Projector>, BoxError> {
    Ok(Box::new(ReferenceProjector {
        tolerance: 1e-8,
        ..Default::default()
    }))
}

#[test]
fn fit_order_recovers_exact_power_laws() {
    let hs = [0.5, 0.2, 0.1, 0.0625, 0.05, 0.02];
    for (c, p) in [(2.0, 0.5), (0.3, 1.0), (7.0, 2.0), (1.0, 0.2)] {
        let es: Vec<f64> = hs.iter().map(|h: &f64| c * h.powf(p)).collect();
        let fit = fit_order(&hs, &es).unwrap();
        assert!((fit.order - p).abs() < 1e-12, "order {} vs {p}", fit.order);
        assert!((fit.constant - c).abs() < 1e-10 * c);
        assert!((fit.r_squared - 1.0).abs() < 1e-12);
        assert_eq!(fit.points, hs.len());
    }
}

#[test]
fn fit_order_is_the_least_squares_slope_of_noisy_points() {
    // log e = log h + (+δ, −δ, +δ, −δ): symmetric noise leaves the slope near 1 and lowers R².
    let hs = [0.1, 0.2, 0.4, 0.8];
    let d = 0.1f64;
    let es: Vec<f64> = hs
        .iter()
        .zip([d, -d, d, -d])
        .map(|(h, n)| h * n.exp())
        .collect();
    let fit = fit_order(&hs, &es).unwrap();
    // Exact least squares of (x, y) with x = log h: slope = 1 + Σ(x − x̄)n / Σ(x − x̄)².
    let x: Vec<f64> = hs.iter().map(|h| h.ln()).collect();
    let mx = x.iter().sum::<f64>() / 4.0;
    let num: f64 = x
        .iter()
        .zip([d, -d, d, -d])
        .map(|(a, n)| (a - mx) * n)
        .sum();
    let den: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    assert!((fit.order - (1.0 + num / den)).abs() < 1e-12);
    assert!(fit.r_squared < 1.0 && fit.r_squared > 0.9);
}

#[test]
fn fit_order_rejects_what_it_cannot_fit() {
    assert!(matches!(
        fit_order(&[0.1], &[1.0]),
        Err(StudyError::InvalidInput(_))
    ));
    assert!(fit_order(&[0.1, 0.2], &[1.0]).is_err());
    assert!(fit_order(&[0.1, 0.2], &[0.0, 1.0]).is_err());
    assert!(fit_order(&[0.1, 0.1], &[1.0, 2.0]).is_err());
    assert!(fit_order(&[0.1, f64::NAN], &[1.0, 2.0]).is_err());
}

#[test]
fn the_scheme_is_exact_at_grid_points_for_two_disks_on_a_line() {
    // Collinear disks: the linearized constraint is the constraint, so q_k = q(t_k); only
    // the interpolant across the contact step errs. With d₀ = 0.64/3 and h = 0.16/2^j the
    // contact falls a third into that step, so the sup error is √2 h/9: order exactly 1.
    let case = TwoDisksOnALine::default();
    let hs = [0.01, 0.02, 0.04, 0.08, 0.16];
    let report = true_error_of(&case, &hs);
    for r in &report.rows {
        let sup = r.error_sup.unwrap();
        let expect = 2f64.sqrt() * r.h / 9.0;
        assert!(
            (sup - expect).abs() < 1e-9,
            "h = {}: sup {sup}, expected {expect}",
            r.h
        );
    }
    let fit = report.order_sup.unwrap();
    assert!(
        (fit.order - 1.0).abs() < 1e-6,
        "sup-norm order {}",
        fit.order
    );
    // At grid points the scheme is exact: the comparison times that are grid points of h
    // (tᵢ = 0.1 i is one for h = 0.01 and 0.02) show rounding only.
    assert!(report.rows[0].error < 1e-12 && report.rows[1].error < 1e-12);
}

#[test]
fn true_error_behind_a_moving_wall_converges_at_order_one() {
    let report = true_error_of(&PointBehindMovingWall::default(), &SMALL_HS);
    let (o, s) = (report.order.unwrap(), report.order_sup.unwrap());
    assert!(
        o.order > 0.8 && s.order > 0.8,
        "orders {} and {}",
        o.order,
        s.order
    );
    // The error shrinks with h: the smallest step beats the largest by a wide margin.
    assert!(report.rows[0].error_sup.unwrap() < 0.2 * report.rows[4].error_sup.unwrap());
}

#[test]
fn true_error_around_a_disk_converges_at_least_at_order_one_half() {
    let report = true_error_of(&PointAroundDisk::default(), &SMALL_HS);
    let (o, s) = (report.order.unwrap(), report.order_sup.unwrap());
    assert!(
        o.order >= 0.5 && s.order >= 0.5,
        "orders {} and {}",
        o.order,
        s.order
    );
    assert_rows_feasible(&report, 1e-8);
}

/// 16 people (r = 0.2) on a 4 × 4 grid in the room [0, 4]², walking towards (2, 0.6), near
/// the bottom wall: they jam against the wall and each other within the horizon.
fn small_crowd() -> Result<Problem, BoxError> {
    let n_side = 4;
    let r = 0.2;
    let pop: Arc<Population> = Population::new(vec![r; n_side * n_side]).shared();
    let mut q0 = Vec::new();
    for i in 0..n_side {
        for j in 0..n_side {
            q0.push(1.1 + 0.55 * i as f64 + 0.03 * j as f64);
            q0.push(1.4 + 0.55 * j as f64);
        }
    }
    let target = [2.0, 0.6];
    let velocity = move |_t: f64, q: &[f64], f: &mut [f64]| {
        for (p, v) in q.chunks(2).zip(f.chunks_mut(2)) {
            let d = [target[0] - p[0], target[1] - p[1]];
            let n = (d[0] * d[0] + d[1] * d[1]).sqrt().max(0.5);
            v[0] = d[0] / n;
            v[1] = d[1] / n;
        }
    };
    let walls = rectangle_walls(0.0, 0.0, 4.0, 4.0);
    Ok(Problem::new(q0, velocity)
        .with_family(DiskPairs::new(pop.clone()))
        .with_family(PersonShapes::new("walls", pop, walls)))
}

#[test]
fn a_small_crowd_converges_at_order_at_least_one_half() {
    let settings = ConvergenceSettings {
        h_min: 0.005,
        hs: vec![0.02, 0.025, 0.04, 0.05, 0.1, 0.2],
        t_end: 1.2,
        t_short: Some(0.6),
        samples: 10,
        parallel: true,
    };
    let report = converge(
        "small crowd",
        &small_crowd,
        &crowd_reference,
        &StepperSettings::default(),
        &settings,
    )
    .unwrap();
    println!("{}", report.summary());
    let fit = report.order.unwrap();
    assert!(
        fit.order >= 0.5,
        "fitted order {}\n{}",
        fit.order,
        report.summary()
    );
    assert!(report.order_short.is_some());
    // The crowd did jam: contacts were active, and the runs stayed feasible.
    assert_rows_feasible(&report, 1e-6);
    assert!(report.rows.iter().all(|r| r.error > 0.0));
    // Outputs: CSV tables and an SVG plot.
    let dir = std::env::temp_dir().join(format!("sweeping-study-{}", std::process::id()));
    report.write_csv(&dir.join("convergence.csv")).unwrap();
    report.write_times_csv(&dir.join("times.csv")).unwrap();
    report.plot(&dir.join("convergence.svg")).unwrap();
    let csv = std::fs::read_to_string(dir.join("convergence.csv")).unwrap();
    assert!(csv.starts_with("h,error,error_short"));
    assert_eq!(
        csv.lines().filter(|l| !l.starts_with('#')).count(),
        1 + settings.hs.len()
    );
    let svg = std::fs::read_to_string(dir.join("convergence.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.contains("slope"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// 400 coordinates near 1000 translated at a constant velocity with a constraint far away:
/// the scheme is exact, so every `e_h` is round-off of the reference and the run.
fn translation() -> Result<Problem, BoxError> {
    struct Below;
    impl ConstraintKernel<1> for Below {
        type Params = ();
        fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 1]) -> D {
            D::from(1e6) - z[0]
        }
        fn is_time_dependent(&self) -> bool {
            false
        }
    }
    let q0: Vec<f64> = (0..400).map(|i| 1000.0 + 0.37 * i as f64).collect();
    let velocity = |_t: f64, _q: &[f64], f: &mut [f64]| {
        for (i, v) in f.iter_mut().enumerate() {
            *v = 0.1 + 0.013 * (i % 7) as f64;
        }
    };
    Ok(Problem::new(q0, velocity).with_family(KernelFamily::single("below", Below, [0])))
}

/// Errors at round-off (above the absolute floor of 1e-12) fit a slope that is no order:
/// the report carries a caveat and prints it in the order's place.
#[test]
fn round_off_errors_are_reported_with_a_caveat_not_as_an_order() {
    let settings = ConvergenceSettings {
        h_min: 0.01,
        hs: vec![0.02, 0.025, 0.04, 0.05, 0.1],
        t_end: 2.0,
        t_short: None,
        samples: 10,
        parallel: true,
    };
    let report = converge(
        "translation",
        &translation,
        &reference,
        &StepperSettings::default(),
        &settings,
    )
    .unwrap();
    let summary = report.summary();
    println!("{summary}");
    assert!(
        report.rows.iter().all(|r| r.error < r.round_off),
        "{summary}"
    );
    if let Some(fit) = report.order {
        assert!(
            matches!(
                fit.caveat,
                Some(sweeping::study::FitCaveat::RoundOff { .. })
            ),
            "{summary}"
        );
    }
    assert!(!summary.contains("R² ="), "{summary}");
    // The numbers: round-off of a long chain, each error under its floor.
    let fit = sweeping::study::fit_order_checked(
        &[0.1, 0.05, 0.04, 0.02],
        &[4e-12, 8e-11, 2e-11, 6e-12],
        &[200, 400, 500, 1000],
        &[1e-10; 4],
    )
    .unwrap();
    assert!(fit.caveat.is_some() && fit.describe().contains("round-off"));
}

/// Step sizes that take the same number of steps (both clamp to one step of T) are refused,
/// and a fit over such points says so instead of reporting order 0 with R² = 1.
#[test]
fn step_sizes_with_the_same_step_count_are_refused() {
    let settings = ConvergenceSettings {
        h_min: 0.01,
        hs: vec![2.0, 5.0],
        t_end: 1.0,
        t_short: None,
        samples: 10,
        parallel: false,
    };
    let err = converge(
        "translation",
        &translation,
        &reference,
        &StepperSettings::default(),
        &settings,
    )
    .unwrap_err();
    assert!(
        matches!(&err, StudyError::InvalidInput(m) if m.contains("both take 1 step")),
        "{err}"
    );
    let fit =
        sweeping::study::fit_order_checked(&[2.0, 5.0], &[0.3, 0.3], &[1, 1], &[1e-12; 2]).unwrap();
    assert!(
        matches!(
            fit.caveat,
            Some(sweeping::study::FitCaveat::RepeatedSteps { steps: 1 })
        ),
        "{fit:?}"
    );
}
