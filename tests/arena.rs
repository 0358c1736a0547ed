//! A crowd in a round arena (`[arena]`): people kept inside a circle (one concave constraint
//! each, a convex set) and apart from each other (the pairs, the paper's class). The shipped
//! scene runs, and an independent checker reads the trajectory it wrote: no overlap, no
//! penetration of the round wall; its pictures draw the round wall. Bad `[arena]` tables are
//! errors naming the line.

use sweeping::constraint::Curvature;
use sweeping::crowd::{ArenaWall, DiskPairs, Population};
use sweeping::output::{render_svg, TrajectoryWriter};
use sweeping::prelude::*;
use sweeping::scene::spec::DesiredSpec;
use sweeping::scene::{Arena, BuiltScene, CrowdBuilder, Effect, Overrides, Scene, SceneError};
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
    let svg = picture_at_start(&built);
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
    let svg = picture_at_start(&room_only);
    assert!(!svg.contains(r#"fill="none" stroke"#), "{svg}");
}

/// The projection of `y` onto `{x : aₖ·x ≥ bₖ} ∩ {x : |xᵢ − c| ≤ ρᵢ}` by Dykstra's alternating
/// projections (one set at a time, each exactly, with its correction), independently of the
/// library: it converges to the projection onto the intersection.
fn dykstra(
    y: &[f64],
    halfspaces: &[(Vec<f64>, f64)],
    balls: &[(usize, [f64; 2], f64)],
) -> Vec<f64> {
    let n = y.len();
    let sets = halfspaces.len() + balls.len();
    let mut x = y.to_vec();
    let mut corrections = vec![vec![0.0; n]; sets];
    for _ in 0..200_000 {
        let before = x.clone();
        for (s, correction) in corrections.iter_mut().enumerate() {
            let z: Vec<f64> = x
                .iter()
                .zip(correction.iter())
                .map(|(a, b)| a + b)
                .collect();
            let mut p = z.clone();
            if s < halfspaces.len() {
                let (a, b) = &halfspaces[s];
                let slack = a.iter().zip(&z).map(|(a, z)| a * z).sum::<f64>() - b;
                if slack < 0.0 {
                    let a2: f64 = a.iter().map(|a| a * a).sum();
                    for (pk, ak) in p.iter_mut().zip(a) {
                        *pk -= slack / a2 * ak;
                    }
                }
            } else {
                let (i, c, rho) = balls[s - halfspaces.len()];
                let (dx, dy) = (z[2 * i] - c[0], z[2 * i + 1] - c[1]);
                let d = dx.hypot(dy);
                if d > rho {
                    p[2 * i] = c[0] + dx * rho / d;
                    p[2 * i + 1] = c[1] + dy * rho / d;
                }
            }
            for k in 0..n {
                correction[k] = z[k] - p[k];
            }
            x = p;
        }
        let moved = x
            .iter()
            .zip(&before)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if moved < 1e-15 {
            break;
        }
    }
    x
}

/// Three people pushed together against the round wall: each step is the projection of the
/// prediction onto the pairs linearized at the step's start and the exact disks of the arena
/// (the scheme, both classes at once), checked against Dykstra's projection onto the same sets.
/// The people keep pressing into the wall, so the cuts of a member whose distance does not
/// halve are merged into one aggregate row, and that path is checked too.
#[test]
fn each_step_in_the_arena_is_the_projection_onto_the_linearized_pairs_and_the_exact_disks() {
    let (center, radius) = ([0.0, 0.0], 1.5);
    let radii = vec![0.3, 0.35, 0.25];
    let population = Population::new(radii.clone()).shared();
    let q0 = vec![0.6, 0.0, 0.0, 0.62, -0.1, -0.6];
    let target = [5.0, 1.0];
    let mut problem = Problem::new(q0, move |_t: f64, q: &[f64], f: &mut [f64]| {
        for i in 0..q.len() / 2 {
            let (dx, dy) = (target[0] - q[2 * i], target[1] - q[2 * i + 1]);
            let d = dx.hypot(dy);
            f[2 * i] = dx / d;
            f[2 * i + 1] = dy / d;
        }
    });
    problem.push_family(Box::new(ArenaWall::new(population.clone(), center, radius)));
    problem.push_family(Box::new(DiskPairs::new(population.clone())));
    let settings = StepperSettings {
        h: 0.05,
        t_end: 1.5,
        kkt_tolerance: 1e-10,
        concave_tolerance: 1e-12,
        ..Default::default()
    };
    let mut stepper = Stepper::new(&problem, settings).unwrap();
    let mut backend = ReferenceProjector {
        tolerance: 1e-13,
        ..Default::default()
    };
    let mut worst: f64 = 0.0;
    let mut cut_steps = 0;
    while stepper.steps_done() < stepper.n_steps() {
        let (t, q) = (stepper.time(), stepper.state().to_vec());
        let mut f = vec![0.0; q.len()];
        problem.perturbation().eval(t, &q, &mut f);
        let report = stepper.step(&mut backend).unwrap();
        let y: Vec<f64> = q.iter().zip(&f).map(|(q, f)| q + report.h * f).collect();
        let mut halfspaces = Vec::new();
        for i in 0..3 {
            for j in i + 1..3 {
                // g = |qᵢ − qⱼ| − rᵢ − rⱼ linearized at q: ∇g·x ≥ ∇g·q − g(q).
                let (dx, dy) = (q[2 * i] - q[2 * j], q[2 * i + 1] - q[2 * j + 1]);
                let d = dx.hypot(dy);
                let (ex, ey) = (dx / d, dy / d);
                let mut a = vec![0.0; 6];
                (a[2 * i], a[2 * i + 1], a[2 * j], a[2 * j + 1]) = (ex, ey, -ex, -ey);
                let aq: f64 = a.iter().zip(&q).map(|(a, q)| a * q).sum();
                halfspaces.push((a, aq - (d - radii[i] - radii[j])));
            }
        }
        let balls: Vec<_> = (0..3).map(|i| (i, center, radius - radii[i])).collect();
        let expect = dykstra(&y, &halfspaces, &balls);
        let x = stepper.state();
        let err = x
            .iter()
            .zip(&expect)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        worst = worst.max(err);
        cut_steps += usize::from(report.cuts > 0);
    }
    println!("arena, three people: largest distance to the projection {worst:.2e}, {cut_steps} steps with cuts");
    assert!(cut_steps > 10, "{cut_steps} steps with cuts");
    assert!(worst < 1e-8, "{worst:.2e}");
}

/// The scene's SVG picture at its start.
fn picture_at_start(built: &BuiltScene) -> String {
    render_svg(
        &built.geometry,
        &built.population,
        &built.group_of,
        built.problem.q0(),
        0.0,
        &built.name,
        None,
    )
}
