//! Agreement with tight OSQP wherever OSQP converges, on random instances (with linearly
//! dependent rows as well) and on the contact-loop step of the paper's evacuation.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sweeping_api::conformance::{max_gap, random_instance};
use sweeping_api::{ProjectionProblem, Projector, SparseRows};
use sweeping_native::NativeProjector;
use sweeping_osqp::OsqpProjector;

/// `p` with every third row repeated, scaled by 2 (dependent rows, same set).
fn with_copies(p: &ProjectionProblem) -> ProjectionProblem {
    let mut a = SparseRows::new(p.dim());
    let mut b = Vec::new();
    for r in 0..p.n_rows() {
        a.push_row(p.a().row(r));
        b.push(p.b()[r]);
        if r % 3 == 0 {
            a.push_row(p.a().row(r).map(|(c, v)| (c, 2.0 * v)));
            b.push(2.0 * p.b()[r]);
        }
    }
    ProjectionProblem::new(p.y().to_vec(), a, b).unwrap()
}

#[test]
fn agrees_with_tight_osqp_where_it_converges() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let (mut compared, mut worst) = (0, 0.0_f64);
    for seed in 0..150u64 {
        let n = rng.gen_range(2..40);
        let m = rng.gen_range(1..60);
        let base = random_instance(9000 + seed, n, m);
        for p in [base.clone(), with_copies(&base)] {
            let native = NativeProjector::default().project(&p).unwrap();
            assert_eq!(native.stats.counters.fallbacks, 0);
            // OSQP at eps = 1e-9 is within ~2e-7 of an exact projection (its documentation;
            // the worst gap measured here was 9.9e-8, and the bound is OSQP's tolerance, 1e-6);
            // near-degenerate instances that end NotConverged are skipped.
            let Ok(osqp) = OsqpProjector::default().project(&p) else {
                continue;
            };
            compared += 1;
            let gap = max_gap(&native.x, &osqp.x);
            worst = worst.max(gap);
            assert!(
                gap <= 1e-6,
                "instance {seed} (n = {n}, m = {m}): gap {gap:.3e}"
            );
        }
    }
    eprintln!("{compared} instances, worst ‖x_native − x_osqp‖∞ = {worst:.3e}");
    assert!(compared >= 250, "only {compared} instances compared");
}

#[test]
fn agrees_with_tight_osqp_on_the_contact_loop() {
    let p = sweeping_testkit::fixtures::problem("contact_loop_qp.json");
    let native = NativeProjector::default().project(&p).unwrap();
    let osqp = OsqpProjector::default().project(&p).unwrap();
    let gap = max_gap(&native.x, &osqp.x);
    eprintln!("contact loop: ‖x_native − x_osqp‖∞ = {gap:.3e}");
    // Measured 1.2e-9; the README found OSQP off by up to 1e-7 on this scene's contact loops,
    // so the bound is OSQP's tolerance.
    assert!(gap <= 1e-6, "gap {gap:.3e}");
}
