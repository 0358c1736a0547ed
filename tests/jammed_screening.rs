//! A jam of the synthetic benchmark (twice the paper's density, everybody walking to the
//! centre, h = 0.1): its blocks go to the native engine's interior point, first on the rows
//! that `y` leaves within reach of being violated, and the rows left out that the answer
//! violates are added by the finish (or the whole block solved again). Every step is checked
//! against Clarabel at the cross-check's tolerance.
#![cfg(all(feature = "native", feature = "clarabel"))]

use sweeping::backends::{ClarabelProjector, NativeProjector, NATIVE_CROSS_TOLERANCE};
use sweeping::prelude::*;
use sweeping::scene::synthetic::{Start, SyntheticCrowd};

#[test]
fn a_jam_screened_for_the_interior_point_is_projected_as_clarabel_projects_it() {
    let crowd = SyntheticCrowd {
        n: 600,
        start: Start::Jammed,
        seed: 7,
    };
    let problem = crowd.problem().unwrap();
    let settings = StepperSettings {
        h: 0.1,
        t_end: 1.5,
        ..Default::default()
    };
    let mut native = NativeProjector::default();
    native.settings_mut().threads = 1;
    let mut both = CrossCheck::new(native, ClarabelProjector::default(), NATIVE_CROSS_TOLERANCE);
    let run = Stepper::new(&problem, settings)
        .unwrap()
        .run(&mut both, &mut [])
        .unwrap_or_else(|f| panic!("{f}"));
    let stats = both.stats().clone();
    assert_eq!(run.stats.steps, 15);
    assert!(
        stats.max_gap <= NATIVE_CROSS_TOLERANCE,
        "largest gap {:.3e}",
        stats.max_gap
    );
    assert!(
        run.stats.max_violation <= 1e-9,
        "violation {:.3e}",
        run.stats.max_violation
    );
    // The interior point took the jam's blocks (the screened path is the one under test).
    assert!(
        run.stats.counters.escalations > 0,
        "no block reached the interior point: {:?}",
        run.stats.counters
    );
}

/// The jam again with no finish, so that every screened run whose answer violates a row it
/// left out is run again with that row, started from nothing but the multipliers of the run
/// before (no step-to-step warm start): from them it takes fewer iterations than from
/// Mehrotra's point (`interior_point_warm_floor = 0`), and the runs end where the cold ones do.
#[test]
fn a_screened_run_repeated_with_the_rows_it_missed_starts_from_its_multipliers() {
    let problem = SyntheticCrowd {
        n: 600,
        start: Start::Jammed,
        seed: 7,
    }
    .problem()
    .unwrap();
    let run = |warm_floor: f64| {
        let mut native = NativeProjector::default();
        let s = native.settings_mut();
        (s.threads, s.warm_start, s.finish_iterations) = (1, false, 0);
        s.active_set_iterations = 0;
        s.interior_point_warm_floor = warm_floor;
        let settings = StepperSettings {
            h: 0.1,
            t_end: 1.5,
            ..Default::default()
        };
        Stepper::new(&problem, settings)
            .unwrap()
            .run(&mut native, &mut [])
            .unwrap_or_else(|f| panic!("{f}"))
    };
    let (repeated_warm, repeated_cold) = (run(0.1), run(0.0));
    let (w, c) = (
        repeated_warm.stats.iterations,
        repeated_cold.stats.iterations,
    );
    assert!(
        w < c,
        "{w} iterations from the last multipliers, {c} from Mehrotra's point"
    );
    let apart = repeated_warm
        .q_final
        .iter()
        .zip(&repeated_cold.q_final)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(apart < 1e-6, "the runs end {apart:e} apart");
}
