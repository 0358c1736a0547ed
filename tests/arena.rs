//! A crowd in a round arena (`[arena]`): people kept inside a circle (one concave constraint
//! each, a convex set) and apart from each other (the pairs, the paper's class). The shipped
//! scene runs, and an independent checker reads the trajectory it wrote: no overlap, no
//! penetration of the round wall; its pictures draw the round wall. Bad `[arena]` tables are
//! errors naming the line.

use sweeping::constraint::Curvature;
use sweeping::output::{render_svg, TrajectoryWriter};
use sweeping::prelude::*;
use sweeping::scene::spec::DesiredSpec;
use sweeping::scene::{Arena, CrowdBuilder, Effect, Overrides, Scene, SceneError};
use sweeping_testkit::checker::{check_trajectory, scratch, Geometry, Obstacle};

const TOL: f64 = 1e-6;

fn shipped() -> Scene {
    Scene::from_file(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes/arena.toml"),
    )
    .unwrap()
}

#[test]
fn the_shipped_arena_runs_with_no_overlap_and_no_wall_penetration() {
    let built = shipped()
        .build(&Overrides {
            t_end: Some(8.0),
            ..Default::default()
        })
        .unwrap();
    assert!(built
        .effects
        .iter()
        .any(|e| matches!(e, Effect::Arena { radius } if *radius == 5.0)));
    assert!(built
        .problem
        .families()
        .iter()
        .any(|f| f.curvature() == Curvature::Concave));
    let dir = scratch("arena");
    let csv = dir.join("trajectory.csv");
    let mut writer = TrajectoryWriter::new(&csv, built.population.clone(), 5);
    let mut cuts = 0usize;
    let mut counter = CountCuts(&mut cuts);
    let mut backend = make_projector(built.backend).unwrap();
    let run = built
        .run(backend.as_mut(), &mut [&mut writer, &mut counter])
        .unwrap();
    drop(writer);
    let geometry = Geometry {
        room: vec![[0.0, 0.0], [12.0, 0.0], [12.0, 12.0], [0.0, 12.0]],
        exits: Vec::new(),
        obstacles: vec![Obstacle::Enclosure([6.0, 6.0], 5.0)],
        radii: built.population.radii().to_vec(),
    };
    let findings = check_trajectory(&csv, &geometry, TOL);
    println!(
        "arena: {} steps, {} cuts, {} frames; largest overlap {:.2e}, largest wall penetration {:.2e}",
        run.stats.steps, cuts, findings.times, findings.max_overlap, findings.max_penetration
    );
    assert!(findings.problems.is_empty(), "{:?}", findings.problems);
    assert_eq!(findings.present_at_end, 80);
    // The crowd reached the round wall (within the tolerance of touching it) and was held
    // there by refined projections, not by luck.
    assert!(
        findings.max_penetration > -TOL,
        "{:.3e}",
        findings.max_penetration
    );
    assert!(cuts > 0);
    // Everybody is inside the arena at the end, by the library's own count too.
    assert!(
        run.stats.max_violation <= TOL,
        "{:.3e}",
        run.stats.max_violation
    );
}

/// Sums the cuts of the concave constraints over a run.
struct CountCuts<'a>(&'a mut usize);
impl Observer for CountCuts<'_> {
    fn name(&self) -> &str {
        "cuts"
    }
    fn on_step(&mut self, report: &StepReport, _q: &[f64]) -> Result<(), ObserverError> {
        *self.0 += report.cuts;
        Ok(())
    }
}

#[test]
fn the_builder_makes_the_same_arena_as_the_file() {
    let built = CrowdBuilder::new("round")
        .rectangle([0.0, 0.0, 10.0, 10.0])
        .arena([5.0, 5.0], 4.0)
        .person([5.0, 5.0], 0.3)
        .person([8.0, 5.0], 0.3)
        .desired(DesiredSpec::point([9.5, 5.0]))
        .step(0.05)
        .horizon(4.0)
        .build()
        .unwrap();
    let run = built
        .run(&mut ReferenceProjector::default(), &mut [])
        .unwrap();
    // The front one ends pressed against the wall at x = 5 + 4 − 0.3 on the line y = 5, the
    // other against it from behind: the wall and the pair hold together.
    let q = &run.q_final;
    assert!(
        (q[2] - 8.7).abs() < 1e-6 && (q[3] - 5.0).abs() < 1e-6,
        "{q:?}"
    );
    let d = (q[0] - q[2]).hypot(q[1] - q[3]);
    assert!((d - 0.6).abs() < 1e-6, "distance {d}: {q:?}");
    for i in 0..2 {
        let r = (q[2 * i] - 5.0).hypot(q[2 * i + 1] - 5.0);
        assert!(r <= 3.7 + 1e-9, "person {i} at {r} from the centre");
    }
}

fn error_of(text: &str) -> SceneError {
    match Scene::from_toml_str(text, "bad.toml").and_then(|s| s.build(&Overrides::default())) {
        Ok(_) => panic!("the scene was accepted:\n{text}"),
        Err(e) => e,
    }
}

fn assert_message(e: &SceneError, line: usize, fragments: &[&str]) {
    let m = e.to_string();
    assert!(
        m.starts_with(&format!("bad.toml:{line}")),
        "expected bad.toml:{line} in `{m}`"
    );
    for f in fragments {
        assert!(m.contains(f), "expected `{f}` in `{m}`");
    }
}

const ROOM: &str = "[room]\nrectangle = [0.0, 0.0, 10.0, 10.0]\n";
const PERSON: &str = "[[people]]\nposition = [5.0, 5.0]\nradius = 0.3\n";

#[test]
fn bad_arenas_are_errors_naming_the_line() {
    for (arena, fragments) in [
        (
            "[arena]\ncenter = [5.0, 5.0]\nradius = 0.0\n",
            &["[arena]", "the radius 0 must be positive and finite"][..],
        ),
        (
            "[arena]\ncenter = [5.0, 5.0]\nradius = nan\n",
            &["[arena]", "must be positive and finite"][..],
        ),
        (
            "[arena]\ncenter = [5.0, inf]\nradius = 1.0\n",
            &["[arena]", "the centre is not finite"][..],
        ),
        (
            "[arena]\ncenter = [5.0, 5.0]\nradius = 6.0\n",
            &["[arena]", "reaches outside the room"][..],
        ),
        (
            "[arena]\ncenter = [12.0, 5.0]\nradius = 1.0\n",
            &["[arena]", "reaches outside the room"][..],
        ),
    ] {
        let e = error_of(&format!("{ROOM}{arena}{PERSON}"));
        assert_message(&e, 3, fragments);
    }
    // Schema errors: the parser's own line.
    let e = error_of(&format!(
        "{ROOM}[arena]\ncenter = [5.0, 5.0, 1.0]\nradius = 1.0\n{PERSON}"
    ));
    assert_message(&e, 4, &["expected 2 numbers, got 3"]);
    let e = error_of(&format!(
        "{ROOM}[arena]\ncenter = [5.0, 5.0]\nradius = 1.0\nwidth = 2.0\n{PERSON}"
    ));
    assert_message(&e, 6, &["unknown field `width`"]);
    let e = error_of(&format!("{ROOM}[arena]\ncenter = [5.0, 5.0]\n{PERSON}"));
    assert_message(&e, 3, &["missing field `radius`"]);
}

#[test]
fn people_outside_the_arena_are_refused_and_crowds_are_drawn_inside() {
    let arena = "[arena]\ncenter = [5.0, 5.0]\nradius = 2.0\n";
    let outside = "[[people]]\nposition = [6.8, 5.0]\nradius = 0.3\n";
    let e = error_of(&format!("{ROOM}{arena}{outside}"));
    assert_message(
        &e,
        6,
        &[
            "[[people]] #1",
            "crosses the arena wall (circle of radius 2 about (5, 5))",
        ],
    );
    let crowd = "[[crowds]]\ncount = 20\nradius = 0.2\nseed = 4\n";
    let built = Scene::from_toml_str(&format!("{ROOM}{arena}{crowd}"), "ok.toml")
        .unwrap()
        .build(&Overrides::default())
        .unwrap();
    let q = built.problem.q0();
    for i in 0..20 {
        let r = (q[2 * i] - 5.0).hypot(q[2 * i + 1] - 5.0);
        assert!(r <= 1.8 + 1e-12, "person {i} drawn at {r} from the centre");
    }
}

#[test]
fn the_arena_is_drawn_as_a_round_wall() {
    let built = shipped().build(&Overrides::default()).unwrap();
    assert_eq!(
        built.geometry.arena,
        Some(Arena {
            center: [6.0, 6.0],
            radius: 5.0
        })
    );
    let svg = render_svg(
        &built.geometry,
        &built.population,
        &built.group_of,
        built.problem.q0(),
        0.0,
        "arena",
        None,
    );
    // SVG's y axis points down: the centre (6, 6) is drawn at (6, −6).
    assert!(
        svg.contains(r#"<circle cx="6.0000" cy="-6.0000" r="5.0000" fill="none""#),
        "{svg}"
    );
    let room_only = Scene::from_toml_str(
        &std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes/arena.toml"),
        )
        .unwrap()
        .replace("[arena]\ncenter = [6.0, 6.0]\nradius = 5.0\n", ""),
        "no-arena.toml",
    )
    .unwrap()
    .build(&Overrides::default())
    .unwrap();
    assert_eq!(room_only.geometry.arena, None);
    let svg = render_svg(
        &room_only.geometry,
        &room_only.population,
        &room_only.group_of,
        room_only.problem.q0(),
        0.0,
        "no arena",
        None,
    );
    assert!(!svg.contains(r#"fill="none" stroke"#), "{svg}");
}
