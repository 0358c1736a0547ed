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
