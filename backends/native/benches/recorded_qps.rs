//! The recorded projections of congested crowds, each solved cold by the native backend and by
//! Clarabel: the door queues and jams of `tests/data/` (this crate's and the root's), each one
//! block recorded where a method struggled (their tests say where each comes from).
//!
//! `cargo bench -p sweeping-native --bench recorded_qps`; one problem:
//! `cargo bench -p sweeping-native --bench recorded_qps -- door_queue_qp/native`. A sequence
//! of projections along a real queue, warm-started as in a run, is timed by
//! `sweep bench --start queue`.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use std::path::{Path, PathBuf};
use sweeping_api::{ProjectionProblem, Projector};
use sweeping_clarabel::ClarabelProjector;
use sweeping_native::NativeProjector;

/// A fresh projector of one backend.
type MakeProjector = fn() -> Box<dyn Projector>;

/// The recorded problems, by file name, in name order.
fn recorded() -> Vec<(String, ProjectionProblem)> {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<PathBuf> = [here.join("tests/data"), here.join("../../tests/data")]
        .iter()
        .flat_map(|dir| std::fs::read_dir(dir).expect("the fixtures' folder"))
        .map(|entry| entry.expect("a fixture").path())
        .filter(|p| p.to_string_lossy().ends_with("_qp.json"))
        .collect();
    files.sort_by_key(|p| p.file_name().map(ToOwned::to_owned));
    files
        .iter()
        .map(|path| {
            let text = std::fs::read_to_string(path).expect("a readable fixture");
            let value: serde_json::Value = serde_json::from_str(&text).expect("JSON");
            // Some fixtures wrap the problem with what was recorded beside it.
            let value = value.get("problem").cloned().unwrap_or(value);
            let name = path.file_stem().unwrap().to_string_lossy().into_owned();
            (
                name,
                serde_json::from_value(value).expect("a projection problem"),
            )
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
