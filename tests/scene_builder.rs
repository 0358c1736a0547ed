//! `CrowdBuilder`: a scene built in code is the scene its TOML file describes (same people,
//! families, effects, settings), and it is refused by the same checks with the same messages,
//! without a line.

use sweeping::crowd::Motion;
use sweeping::scene::spec::{CrowdSpec, DesiredSpec, RadiusSpec};
use sweeping::scene::{BuiltScene, CrowdBuilder, ObstacleShape, Overrides, Scene, SceneError};

const TOML: &str = r#"
name = "built"
[room]
polygon = [[0.0, 0.0], [8.0, 0.0], [8.0, 5.0], [0.0, 5.0]]
[[exits]]
from = [8.0, 2.0]
to = [8.0, 3.0]
[[obstacles]]
disk = { center = [5.0, 2.5], radius = 0.4 }
[[obstacles]]
segment = { from = [3.0, 4.0], to = [3.0, 4.5] }
velocity = [0.1, 0.0]
[[obstacles]]
polygon = [[6.0, 0.5], [6.5, 0.5], [6.5, 1.0]]
path = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.5]]
[desired]
kind = "exit"
[[people]]
position = [1.0, 1.0]
radius = 0.25
speed = 1.3
[[people]]
position = [1.0, 4.0]
radius = 0.2
desired = { kind = "point", point = [4.0, 4.0] }
[[crowds]]
count = 25
region = [0.5, 1.5, 4.0, 3.5]
radius = [0.18, 0.24]
seed = 7
[geodesic]
cell = 0.1
[run]
h = 0.02
t_end = 3.0
stop_when_empty = true
"#;

fn from_code() -> CrowdBuilder {
    CrowdBuilder::new("built")
        .polygon(vec![[0.0, 0.0], [8.0, 0.0], [8.0, 5.0], [0.0, 5.0]])
        .exit([8.0, 2.0], [8.0, 3.0])
        .obstacle(
            ObstacleShape::Disk {
                center: [5.0, 2.5],
                radius: 0.4,
            },
            Motion::Static,
        )
        .obstacle(
            ObstacleShape::Segment {
                a: [3.0, 4.0],
                b: [3.0, 4.5],
            },
            Motion::Velocity([0.1, 0.0]),
        )
        .obstacle(
            ObstacleShape::Polygon(vec![[6.0, 0.5], [6.5, 0.5], [6.5, 1.0]]),
            Motion::Path(vec![(0.0, [0.0, 0.0]), (2.0, [0.0, 0.5])]),
        )
        .desired(DesiredSpec::exit())
        .person_with(sweeping::scene::spec::PersonSpec {
            position: [1.0, 1.0],
            radius: 0.25,
            speed: Some(1.3),
            pre_movement: None,
            desired: None,
        })
        .person_with(sweeping::scene::spec::PersonSpec {
            position: [1.0, 4.0],
            radius: 0.2,
            speed: None,
            pre_movement: None,
            desired: Some(DesiredSpec::point([4.0, 4.0])),
        })
        .crowd(
            CrowdSpec::new(25, RadiusSpec::Range([0.18, 0.24]))
                .region([0.5, 1.5, 4.0, 3.5])
                .seed(7),
        )
        .geodesic_cell(0.1)
        .step(0.02)
        .horizon(3.0)
        .stop_when_empty(true)
}

fn names(b: &BuiltScene) -> Vec<String> {
    b.problem
        .families()
        .iter()
        .map(|f| f.name().to_string())
        .collect()
}

#[test]
fn a_scene_built_in_code_is_the_scene_of_its_file() {
    let file = Scene::from_toml_str(TOML, "built.toml")
        .unwrap()
        .build(&Overrides::default())
        .unwrap();
    let code = from_code().build().unwrap();
    assert_eq!(code.name, file.name);
    assert_eq!(code.problem.q0(), file.problem.q0());
    assert_eq!(code.population.len(), 27);
    assert_eq!(names(&code), names(&file));
    assert_eq!(code.effects, file.effects);
    assert_eq!(code.speeds, file.speeds);
    assert_eq!(code.group_of, file.group_of);
    assert_eq!(code.groups, file.groups);
    assert_eq!(code.settings, file.settings);
    assert_eq!(code.stop_when_empty, file.stop_when_empty);
    assert_eq!(code.output, file.output);
    assert_eq!(code.geometry, file.geometry);
    assert!(code.distance_field.is_some() && file.distance_field.is_some());
    // The same perturbation: every person's desired velocity agrees.
    let q0 = file.problem.q0();
    let (mut a, mut b) = (vec![0.0; q0.len()], vec![0.0; q0.len()]);
    code.problem.perturbation().eval(0.5, q0, &mut a);
    file.problem.perturbation().eval(0.5, q0, &mut b);
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 1e-12, "{x} vs {y}");
    }
}

/// Each check of the file applies to the builder, with the file's item names and no line.
#[test]
fn a_scene_built_in_code_is_refused_like_its_file() {
    let cases: Vec<(CrowdBuilder, &str, &str)> = vec![
        (
            CrowdBuilder::new("no-room").person([1.0, 1.0], 0.2),
            "[room]",
            "give `rectangle = [x0, y0, x1, y1]`, `polygon = [[x, y], …]`",
        ),
        (
            CrowdBuilder::new("overlap")
                .rectangle([0.0, 0.0, 4.0, 4.0])
                .person([1.0, 1.0], 0.3)
                .person([1.2, 1.0], 0.3),
            "[[people]] #1 and [[people]] #2",
            "the two people overlap at t = 0",
        ),
        (
            CrowdBuilder::new("door")
                .rectangle([0.0, 0.0, 4.0, 4.0])
                .exit([2.0, 2.0], [3.0, 2.0])
                .person([1.0, 1.0], 0.3),
            "[[exits]] #1",
            "is not on a wall of the room",
        ),
        (
            CrowdBuilder::new("full")
                .rectangle([0.0, 0.0, 2.0, 2.0])
                .crowd(CrowdSpec::new(1000, RadiusSpec::Fixed(0.2))),
            "[[crowds]] #1",
            "cannot fit",
        ),
        (
            CrowdBuilder::new("step")
                .rectangle([0.0, 0.0, 4.0, 4.0])
                .person([1.0, 1.0], 0.3)
                .step(-1.0),
            "[run] h",
            "the time step must be positive and finite",
        ),
        (
            CrowdBuilder::new("nowhere")
                .rectangle([0.0, 0.0, 4.0, 4.0])
                .person([1.0, 1.0], 0.3)
                .desired(DesiredSpec::exit()),
            "[desired] desired",
            "kind = \"exit\" needs at least one [[exits]]",
        ),
    ];
    for (builder, item, fragment) in cases {
        let name = builder.spec().name.clone().unwrap();
        let e = builder
            .build()
            .err()
            .unwrap_or_else(|| panic!("{name} was accepted"));
        let m = e.to_string();
        assert_eq!(e.line(), None, "{m}");
        assert!(
            matches!(&e, SceneError::Invalid { item: i, .. } if i == item),
            "expected item `{item}` in `{m}`"
        );
        assert!(m.contains(fragment), "expected `{fragment}` in `{m}`");
        assert!(m.starts_with(&format!("{name} (built in code): ")), "{m}");
    }
}

/// The same check on the file names the line: the builder only drops it.
#[test]
fn the_file_names_the_line_the_builder_cannot() {
    let text = "[room]\nrectangle = [0.0, 0.0, 4.0, 4.0]\n[[people]]\nposition = [1.0, 1.0]\nradius = 0.3\n[[people]]\nposition = [1.2, 1.0]\nradius = 0.3\n";
    let e = Scene::from_toml_str(text, "bad.toml")
        .unwrap()
        .build(&Overrides::default())
        .err()
        .unwrap();
    assert_eq!(e.line(), Some(6));
    assert!(e.to_string().contains("the two people overlap at t = 0"));
}

/// Speeds and pre-movement times drawn per person come from streams of the crowd's seed of
/// their own: the same seed draws the same values, and adding a distribution does not move
/// anybody.
#[test]
fn drawn_speeds_and_times_are_reproducible_and_leave_the_placement_alone() {
    let crowd = |extra: &str| {
        let text = format!(
            "[room]\nrectangle = [0.0, 0.0, 10.0, 10.0]\n[[crowds]]\ncount = 30\nradius = 0.2\n\
             seed = 5\n{extra}"
        );
        sweeping::scene::Scene::from_toml_str(&text, "crowd.toml")
            .and_then(|s| s.build(&sweeping::scene::Overrides::default()))
            .unwrap_or_else(|e| panic!("{e}"))
    };
    let plain = crowd("");
    let drawn = crowd(
        "speed = { normal = [1.3, 0.2], within = [0.8, 1.8] }\n\
         pre_movement = { uniform = [0.0, 5.0] }\n",
    );
    let again = crowd(
        "speed = { normal = [1.3, 0.2], within = [0.8, 1.8] }\n\
         pre_movement = { uniform = [0.0, 5.0] }\n",
    );
    assert_eq!(plain.problem.q0(), drawn.problem.q0());
    assert_eq!(drawn.speeds, again.speeds);
    assert!(plain.speeds.iter().all(|&v| v == 1.0));
    assert!(drawn.speeds.iter().all(|v| (0.8..=1.8).contains(v)));
    let distinct: std::collections::BTreeSet<u64> =
        drawn.speeds.iter().map(|v| v.to_bits()).collect();
    assert!(distinct.len() > 20, "{:?}", drawn.speeds);
}
