//! One step of the scheme against the crowd size N (150, 1000, 5000), per compiled backend,
//! from a spread start (the paper's density, h = 0.01) and a jammed one (twice the density,
//! everyone walking to the centre, h = 0.1): the crowds of `sweeping::scene::synthetic`. The
//! reference backend (Hildreth) runs at N = 150 only. The time split by stage, up to
//! N = 10⁵, is printed by `sweep bench`.
//!
//! `queue`: the projections of steps 1000–1400 of the paper's evacuation, the queue at its door
//! (t = 10–14 s), recorded once with Clarabel, then projected in turn by a fresh projector of
//! each backend (warm-starting itself along the sequence). An evacuation is chaotic: a change
//! in a backend's last bits changes the run, its length and how long the queue lasts, so
//! timing whole runs of two versions compares different work. A change to the native backend
//! times the same problems here (`cargo bench --bench step -- queue/native --save-baseline
//! before`, then `--baseline before` after the change).

use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion};
use std::sync::Arc;
use sweeping::api::{Projection, ProjectionError, ProjectionProblem, Projector};
use sweeping::backends::{make_projector, BackendChoice};
use sweeping::constraint::ConstraintFamily;
use sweeping::crowd::{DiskPairs, Population};
use sweeping::scene::synthetic::{Start, SyntheticCrowd};
use sweeping::scene::{Overrides, Scene};
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

/// A projector that keeps a copy of every problem it is given.
struct Recorder<'a> {
    inner: &'a mut dyn Projector,
    problems: Vec<ProjectionProblem>,
}

impl Projector for Recorder<'_> {
    fn name(&self) -> &str {
        "recorder"
    }
    fn project(&mut self, p: &ProjectionProblem) -> Result<Projection, ProjectionError> {
        self.problems.push(p.clone());
        self.inner.project(p)
    }
}

/// The projections of steps `steps` of a run of `problem`, run with Clarabel (whose answers,
/// and so the run, do not change with the native backend).
fn recorded(
    problem: &sweeping::problem::Problem,
    settings: &StepperSettings,
    steps: std::ops::Range<usize>,
) -> Vec<ProjectionProblem> {
    let mut clarabel = make_projector(BackendChoice::Clarabel).expect("the Clarabel backend");
    let mut recorder = Recorder {
        inner: clarabel.as_mut(),
        problems: Vec::new(),
    };
    let mut stepper = Stepper::new(problem, settings.clone()).expect("a feasible start");
    while stepper.steps_done() < steps.end {
        stepper.step(&mut recorder).expect("the run goes on");
    }
    recorder.problems.split_off(steps.start)
}

/// Times each backend projecting `problems` in turn, from a fresh projector.
fn project_in_turn(c: &mut Criterion, group: &str, problems: &[ProjectionProblem]) {
    let rows: usize = problems.iter().map(ProjectionProblem::n_rows).sum();
    eprintln!(
        "{group}: {} projections, {} rows on average",
        problems.len(),
        rows / problems.len()
    );
    let mut group = c.benchmark_group(group);
    group.sample_size(10);
    for backend in [BackendChoice::Native, BackendChoice::Clarabel] {
        group.bench_function(backend.to_string(), |b| {
            b.iter_batched(
                || make_projector(backend).expect("compiled in"),
                |mut projector| {
                    for p in problems {
                        projector.project(p).expect("a recorded projection");
                    }
                },
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

fn recorded_runs(c: &mut Criterion) {
    if make_projector(BackendChoice::Clarabel).is_err()
        || make_projector(BackendChoice::Native).is_err()
    {
        eprintln!("queue, jam: skipped, they need the Clarabel and native backends");
        return;
    }
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/scenes/paper-evacuation.toml"
    );
    let paper = Scene::from_file(path)
        .expect("the shipped scene")
        .build(&Overrides::default())
        .expect("the shipped scene builds");
    project_in_turn(
        c,
        "queue",
        &recorded(&paper.problem, &paper.settings, 1000..1400),
    );
    let jam = SyntheticCrowd {
        n: 1000,
        start: Start::Jammed,
        seed: 7,
    }
    .problem()
    .expect("a synthetic crowd");
    let settings = StepperSettings {
        h: 0.1,
        t_end: 1.0,
        ..Default::default()
    };
    project_in_turn(c, "jam", &recorded(&jam, &settings, 0..10));
}

/// The pairs' broad phase alone (`DiskPairs::candidates`) on the spread start of 5000, at the
/// cutoffs a step asks for: 0 (the smallest), 0.05 (about twice the drift of a step at h =
/// 0.01) and 0.2. `list`: a query the neighbour list answers (most steps of a walking crowd);
/// `build`: the first query of a fresh family, which searches the grid at the cutoff plus the
/// skin and keeps the list. `cargo bench --bench step -- broad_phase`.
fn broad_phase(c: &mut Criterion) {
    let mut group = c.benchmark_group("broad_phase");
    let problem = SyntheticCrowd {
        n: 5000,
        start: Start::Spread,
        seed: 7,
    }
    .problem()
    .expect("a synthetic crowd");
    let q = problem.q0().to_vec();
    let pairs = problem
        .families()
        .iter()
        .find(|f| f.name() == "pairs of people")
        .expect("the pair family");
    // The synthetic crowd's people all have radius 0.2.
    let population = Population::new(vec![0.2; q.len() / 2]).shared();
    let mut out = Vec::new();
    for cutoff in [0.0, 0.05, 0.2] {
        group.bench_with_input(
            BenchmarkId::new("pairs-5000-list", cutoff),
            &cutoff,
            |b, &c| {
                b.iter(|| {
                    out.clear();
                    pairs.candidates(0.0, &q, c, &mut out);
                    out.len()
                })
            },
        );
        group.bench_with_input(
            BenchmarkId::new("pairs-5000-build", cutoff),
            &cutoff,
            |b, &c| {
                b.iter_batched(
                    || DiskPairs::new(Arc::clone(&population)),
                    |fresh| {
                        out.clear();
                        fresh.candidates(0.0, &q, c, &mut out);
                        out.len()
                    },
                    BatchSize::SmallInput,
                )
            },
        );
    }
    group.finish();
}

criterion_group!(benches, one_step, recorded_runs, broad_phase);
criterion_main!(benches);
