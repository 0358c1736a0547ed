//! One step of the scheme against the crowd size N (150, 1000, 5000), per compiled backend,
//! from a spread start (the paper's density, h = 0.01) and a jammed one (twice the density,
//! everyone walking to the centre, h = 0.1): the crowds of `sweeping::crowd::synthetic`. The
//! reference backend (Hildreth) runs at N = 150 only. The time split by stage, up to
//! N = 10⁵, is printed by `sweep bench`.

use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion};
use sweeping::backends::{make_projector, BackendChoice};
use sweeping::crowd::synthetic::{Start, SyntheticCrowd};
use sweeping::stepper::{Stepper, StepperSettings};

fn one_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    group.sample_size(10);
    for (start, h) in [(Start::Spread, 0.01), (Start::Jammed, 0.1)] {
        for n in [150usize, 1000, 5000] {
            let problem = SyntheticCrowd { n, start, seed: 7 }
                .problem()
                .expect("a synthetic crowd");
            for backend in [
                BackendChoice::Native,
                BackendChoice::Clarabel,
                BackendChoice::Osqp,
                BackendChoice::Reference,
            ] {
                if backend == BackendChoice::Reference && n > 150 {
                    continue;
                }
                let Ok(mut projector) = make_projector(backend) else {
                    continue; // not compiled in
                };
                let settings = StepperSettings {
                    h,
                    t_end: 10.0 * h,
                    ..Default::default()
                };
                let label = format!("{backend}-{start}");
                // A backend that cannot take this step (e.g. the reference on a jam) is
                // reported and skipped rather than aborting the whole bench.
                let mut probe = Stepper::new(&problem, settings.clone()).expect("a feasible start");
                if let Err(e) = probe.step(projector.as_mut()) {
                    eprintln!("skipping {label}/{n}: {e}");
                    continue;
                }
                group.bench_with_input(BenchmarkId::new(label, n), &n, |b, _| {
                    b.iter_batched(
                        || Stepper::new(&problem, settings.clone()).expect("a feasible start"),
                        |mut stepper| stepper.step(projector.as_mut()).expect("a step"),
                        BatchSize::LargeInput,
                    )
                });
            }
        }
    }
    group.finish();
}

criterion_group!(benches, one_step);
criterion_main!(benches);
