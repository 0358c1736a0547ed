//! The recorded projections of congested crowds, each solved cold by the native backend and by
//! Clarabel: the door queues and jams of the test fixtures (`sweeping_testkit::fixtures`), each one
//! block recorded where a method struggled (their tests say where each comes from).
//!
//! `cargo bench -p sweeping-native --bench recorded_qps`; one problem:
//! `cargo bench -p sweeping-native --bench recorded_qps -- door_queue_qp/native`. A sequence
//! of projections along a real queue, warm-started as in a run, is timed by
//! `sweep bench --start queue`.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use sweeping_api::{ProjectionProblem, Projector};
use sweeping_clarabel::ClarabelProjector;
use sweeping_native::NativeProjector;

/// A fresh projector of one backend.
type MakeProjector = fn() -> Box<dyn Projector>;

/// The recorded problems, by file name, in name order.
fn recorded() -> Vec<(String, ProjectionProblem)> {
    sweeping_testkit::fixtures::all_ending_with("_qp.json")
        .iter()
        .map(|path| {
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            let stem = name.trim_end_matches(".json").to_owned();
            (stem, sweeping_testkit::fixtures::problem(&name))
        })
        .collect()
}

fn cold(c: &mut Criterion) {
    for (name, problem) in recorded() {
        let mut group = c.benchmark_group(&name);
        group.sample_size(10);
        eprintln!(
            "{name}: {} rows on {} unknowns",
            problem.n_rows(),
            problem.dim()
        );
        let backends: [(&str, MakeProjector); 2] = [
            ("native", || Box::new(NativeProjector::default())),
            ("clarabel", || Box::new(ClarabelProjector::default())),
        ];
        for (label, make) in backends {
            group.bench_function(label, |b| {
                b.iter_batched(
                    make,
                    |mut projector| projector.project(&problem).expect("a recorded projection"),
                    BatchSize::LargeInput,
                )
            });
        }
        group.finish();
    }
}

criterion_group!(benches, cold);
criterion_main!(benches);
