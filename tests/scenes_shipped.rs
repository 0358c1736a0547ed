//! Every scene under `examples/scenes/` parses, builds, and runs a few steps without overlap
//! or wall penetration; the full runs (long) are `#[ignore]`d.

use std::path::{Path, PathBuf};
use sweeping::api::conformance::ReferenceProjector;
use sweeping::backends::make_projector;
use sweeping::output::{RunSummary, SummaryCollector};
use sweeping::scene::{Overrides, Scene};

/// Overlap and penetration allowed after a step (solver tolerance).
const TOL: f64 = 1e-6;

/// No overlap nor wall penetration beyond [`TOL`] in the run of the scene at `path`.
fn assert_within_tolerance(s: &RunSummary, path: &Path) {
    assert!(
        s.max_overlap <= TOL,
        "{}: overlap {}",
        path.display(),
        s.max_overlap
    );
    assert!(
        s.max_wall_penetration <= TOL,
        "{}: penetration {}",
        path.display(),
        s.max_wall_penetration
    );
}

fn scenes() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/scenes");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    v
}

#[test]
fn the_five_scenes_are_shipped() {
    let names: Vec<String> = scenes()
        .iter()
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    for want in [
        "paper-evacuation",
        "pillar",
        "corridor",
        "crossing",
        "moving-wall",
    ] {
        assert!(names.iter().any(|n| n == want), "missing {want}: {names:?}");
    }
}

#[test]
fn every_scene_builds_and_runs_a_few_steps_cleanly() {
    for path in scenes() {
        let scene = Scene::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
        let probe = scene.build(&Overrides::default()).unwrap();
        let h = probe.settings.h;
        let built = scene
            .build(&Overrides {
                t_end: Some(5.0 * h),
                ..Default::default()
            })
            .unwrap();
        assert!(!built.describe().is_empty());
        let mut summary = SummaryCollector::new(
            &built.name,
            &built.problem,
            built.population.clone(),
            "reference",
            h,
            5.0 * h,
        );
        let run = built
            .run(&mut ReferenceProjector::default(), &mut [&mut summary])
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let s = summary.summary();
        assert_eq!(run.stats.steps, 5, "{}", path.display());
        assert_within_tolerance(s, &path);
    }
}

#[test]
fn the_paper_scene_is_the_papers() {
    let scene = Scene::from_file(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/scenes/paper-evacuation.toml"),
    )
    .unwrap();
    let built = scene.build(&Overrides::default()).unwrap();
    assert_eq!(built.population.len(), 150);
    assert!(built
        .population
        .radii()
        .iter()
        .all(|r| (r - 0.2).abs() < 1e-15));
    assert!(
        built.distance_field.is_some(),
        "the desired velocity is geodesic"
    );
    assert_eq!(built.geometry.exits.len(), 1);
    // A different seed gives a different placement, still valid.
    let other = scene
        .build(&Overrides {
            seed: Some(99),
            ..Default::default()
        })
        .unwrap();
    assert!(other
        .problem
        .q0()
        .iter()
        .zip(built.problem.q0())
        .any(|(a, b)| (a - b).abs() > 1e-6));
}

/// Full runs with each scene's backend (needs the backend's cargo feature): every scene that
/// stops when empty does empty, without overlap or penetration beyond tolerance.
#[test]
#[ignore = "full runs: minutes"]
fn full_runs() {
    for path in scenes() {
        let built = Scene::from_file(&path)
            .unwrap()
            .build(&Overrides::default())
            .unwrap();
        let Ok(mut projector) = make_projector(built.backend) else {
            eprintln!(
                "{}: backend {} not compiled in, skipped",
                path.display(),
                built.backend
            );
            continue;
        };
        let mut summary = SummaryCollector::new(
            &built.name,
            &built.problem,
            built.population.clone(),
            &built.backend.to_string(),
            built.settings.h,
            built.settings.t_end,
        );
        built
            .run(projector.as_mut(), &mut [&mut summary])
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let s = summary.summary();
        if built.stop_when_empty {
            assert!(
                s.evacuation_time.is_some(),
                "{}: {} remain",
                path.display(),
                s.people_remaining
            );
        }
        assert_within_tolerance(s, &path);
    }
}
