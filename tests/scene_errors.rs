//! Every kind of bad scene gives a clear error naming the file, the line and the item — and
//! never a panic.

use sweeping::scene::{Overrides, Scene, SceneError};

const ROOM: &str = "[room]\nrectangle = [0.0, 0.0, 4.0, 4.0]\n";

/// Parses and builds `text` as `bad.toml`; returns the error.
fn error_of(text: &str) -> SceneError {
    error_with(text, &Overrides::default())
}

fn error_with(text: &str, overrides: &Overrides) -> SceneError {
    match Scene::from_toml_str(text, "bad.toml").and_then(|s| s.build(overrides)) {
        Ok(_) => panic!("the scene was accepted:\n{text}"),
        Err(e) => e,
    }
}

/// Asserts the message names `bad.toml` at `line` and contains every fragment.
fn assert_message(e: &SceneError, line: usize, fragments: &[&str]) {
    let m = e.to_string();
    assert!(
        m.starts_with(&format!("bad.toml:{line}")),
        "expected bad.toml:{line} in `{m}`"
    );
    assert_eq!(e.line(), Some(line), "{m}");
    for f in fragments {
        assert!(m.contains(f), "expected `{f}` in `{m}`");
    }
}

#[test]
fn malformed_toml() {
    let e = error_of("[room\nrectangle = [0.0, 0.0, 4.0, 4.0]\n");
    assert!(matches!(e, SceneError::Parse { .. }));
    assert_message(&e, 1, &["bad.toml:1:"]);
}

#[test]
fn missing_room() {
    let e = error_of("name = \"x\"\n");
    assert_message(&e, 1, &["missing field `room`"]);
}

#[test]
fn missing_field_in_a_person() {
    let text = format!("{ROOM}\n[[people]]\nposition = [1.0, 1.0]\n");
    assert_message(&error_of(&text), 4, &["missing field `radius`"]);
}

#[test]
fn unknown_top_level_key() {
    let text = format!("{ROOM}colour = \"red\"\n");
    assert_message(&error_of(&text), 3, &["unknown field `colour`"]);
}

#[test]
fn unknown_key_in_a_table() {
    let text = format!("{ROOM}\n[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\nmass = 80.0\n");
    assert_message(&error_of(&text), 7, &["unknown field `mass`"]);
}

#[test]
fn unknown_key_in_run() {
    let text = format!("{ROOM}[run]\nhh = 0.1\n");
    assert_message(&error_of(&text), 4, &["unknown field `hh`"]);
}

#[test]
fn wrong_type() {
    let text = format!("{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = \"big\"\n");
    assert_message(&error_of(&text), 5, &["invalid type"]);
}

#[test]
fn bad_radius_of_a_crowd() {
    let text = format!("{ROOM}[[crowds]]\ncount = 3\nradius = \"big\"\n");
    assert_message(
        &error_of(&text),
        5,
        &["a radius (a number), a range [min, max], or a distribution"],
    );
}

#[test]
fn unknown_desired_kind() {
    let text = format!(
        "{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\ndesired = {{ kind = \"home\" }}\n"
    );
    assert_message(&error_of(&text), 6, &["unknown variant `home`"]);
}

#[test]
fn unknown_backend() {
    let text = format!("{ROOM}[run]\nbackend = \"gurobi\"\n");
    assert_message(&error_of(&text), 4, &["unknown variant `gurobi`"]);
}

#[test]
fn overlapping_people() {
    let text = format!(
        "{ROOM}\n[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n\n[[people]]\nposition = [1.3, 1.0]\nradius = 0.2\n"
    );
    assert_message(
        &error_of(&text),
        8,
        &["[[people]] #1 and [[people]] #2", "overlap at t = 0"],
    );
}

#[test]
fn person_outside_the_room() {
    let text = format!("{ROOM}\n[[people]]\nposition = [5.0, 1.0]\nradius = 0.2\n");
    assert_message(&error_of(&text), 4, &["[[people]] #1", "outside the room"]);
}

#[test]
fn person_through_a_wall() {
    let text = format!("{ROOM}\n[[people]]\nposition = [0.1, 1.0]\nradius = 0.2\n");
    assert_message(&error_of(&text), 4, &["[[people]] #1", "crosses the wall"]);
}

#[test]
fn person_inside_an_obstacle() {
    let text = format!(
        "{ROOM}[[obstacles]]\ndisk = {{ center = [2.0, 2.0], radius = 0.5 }}\n\n[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n\n[[people]]\nposition = [2.1, 2.0]\nradius = 0.2\n"
    );
    assert_message(
        &error_of(&text),
        10,
        &["[[people]] #2", "inside obstacle #1"],
    );
}

#[test]
fn person_inside_a_polygon_obstacle() {
    let text = format!(
        "{ROOM}[[obstacles]]\npolygon = [[1.0, 1.0], [3.0, 1.0], [3.0, 3.0], [1.0, 3.0]]\n[[people]]\nposition = [2.0, 2.0]\nradius = 0.2\n"
    );
    assert_message(
        &error_of(&text),
        5,
        &["[[people]] #1", "inside obstacle #1"],
    );
}

#[test]
fn exit_not_on_a_wall() {
    let text = format!("{ROOM}\n[[exits]]\nfrom = [2.0, 1.0]\nto = [2.0, 2.0]\n");
    assert_message(&error_of(&text), 4, &["[[exits]] #1", "not on a wall"]);
}

#[test]
fn exit_across_a_corner() {
    let text = format!("{ROOM}\n[[exits]]\nfrom = [4.0, 3.0]\nto = [3.0, 4.0]\n");
    assert_message(&error_of(&text), 4, &["[[exits]] #1", "not on a wall"]);
}

/// An exit and a segment obstacle share one schema; a value that is not a table says what
/// is expected, in the user's words rather than a Rust type's name.
#[test]
fn an_exit_or_a_segment_that_is_not_a_table_says_what_a_segment_is() {
    let exit = format!("exits = [1]\n{ROOM}");
    let segment = format!("{ROOM}[[obstacles]]\nsegment = 2.0\n");
    for (text, line) in [(exit, 1), (segment, 4)] {
        let e = error_of(&text);
        assert_message(&e, line, &["a segment: a table with `from = [x, y]`"]);
        assert!(!e.to_string().contains("Spec"), "{e}");
    }
}

#[test]
fn overlapping_exits() {
    let text = format!(
        "{ROOM}[[exits]]\nfrom = [4.0, 1.0]\nto = [4.0, 2.0]\n[[exits]]\nfrom = [4.0, 1.5]\nto = [4.0, 3.0]\n"
    );
    assert_message(
        &error_of(&text),
        6,
        &["[[exits]] #2", "overlaps another exit"],
    );
}

#[test]
fn nan_position() {
    let text = format!("{ROOM}[[people]]\nposition = [nan, 1.0]\nradius = 0.2\n");
    assert_message(&error_of(&text), 3, &["[[people]] #1", "not finite"]);
}

#[test]
fn nan_radius() {
    let text = format!("{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = nan\n");
    assert_message(
        &error_of(&text),
        3,
        &["[[people]] #1", "radius must be positive and finite"],
    );
}

#[test]
fn a_crowds_bad_radius_is_quoted_as_written() {
    // The message used to print the parser's own form, `got Fixed(0.0)`.
    let crowd = "[[crowds]]\ncount = 3\nregion = [0.0, 0.0, 4.0, 4.0]\n";
    let text = format!("{ROOM}{crowd}radius = 0.0\n");
    assert_message(
        &error_of(&text),
        3,
        &[
            "[[crowds]] #1",
            "must be positive and finite, got radius = 0.0",
        ],
    );
    let text = format!("{ROOM}{crowd}radius = [0.3, 0.2]\n");
    assert_message(
        &error_of(&text),
        3,
        &["[[crowds]] #1", "0 < min ≤ max", "got radius = [0.3, 0.2]"],
    );
}

#[test]
fn infinite_room() {
    let e = error_of("[room]\nrectangle = [0.0, 0.0, inf, 4.0]\n");
    assert_message(&e, 1, &["[room]", "non-finite"]);
}

#[test]
fn negative_radius() {
    let text = format!("{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = -0.2\n");
    assert_message(&error_of(&text), 3, &["[[people]] #1", "got -0.2"]);
}

#[test]
fn negative_speed() {
    let text = format!("{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\nspeed = -1.0\n");
    assert_message(&error_of(&text), 3, &["[[people]] #1", "speed must be ≥ 0"]);
}

#[test]
fn negative_crowd_radius_range() {
    let text = format!("{ROOM}[[crowds]]\ncount = 3\nradius = [0.3, 0.1]\n");
    assert_message(&error_of(&text), 3, &["[[crowds]] #1", "0 < min ≤ max"]);
}

#[test]
fn negative_step() {
    let text = format!("{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n[run]\nh = -0.01\n");
    assert_message(
        &error_of(&text),
        6,
        &["[run] h", "positive and finite, got -0.01"],
    );
}

#[test]
fn nan_step() {
    let text = format!("{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n[run]\nh = nan\n");
    assert_message(&error_of(&text), 6, &["[run] h", "positive and finite"]);
}

#[test]
fn zero_horizon() {
    let text =
        format!("{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n[run]\nt_end = 0.0\n");
    assert_message(&error_of(&text), 6, &["[run] t_end", "positive"]);
}

/// The message of a one-person scene refused for `overrides` from the command line.
fn command_line_error(overrides: Overrides) -> String {
    let text = format!("{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n");
    error_with(&text, &overrides).to_string()
}

#[test]
fn negative_step_from_the_command_line() {
    let m = command_line_error(Overrides {
        h: Some(-1.0),
        ..Default::default()
    });
    assert!(m.starts_with("bad.toml: --h:"), "{m}");
    assert!(m.contains("got -1"), "{m}");
}

#[test]
fn infinite_horizon_from_the_command_line() {
    let m = command_line_error(Overrides {
        t_end: Some(f64::INFINITY),
        ..Default::default()
    });
    assert!(m.starts_with("bad.toml: --t-end:"), "{m}");
    assert!(
        m.contains("the horizon must be positive and finite, got inf"),
        "{m}"
    );
}

#[test]
fn crowd_that_does_not_fit() {
    // Beyond the area bound: refused before any placement.
    let text = format!("{ROOM}[[crowds]]\ncount = 200\nradius = 0.2\n");
    assert_message(&error_of(&text), 3, &["[[crowds]] #1", "cannot fit"]);
    // Under the bound (127) but beyond what random placement achieves.
    let text = format!("{ROOM}[[crowds]]\ncount = 120\nradius = 0.2\n");
    assert_message(&error_of(&text), 3, &["[[crowds]] #1", "could place only"]);
}

#[test]
fn crowd_region_inverted() {
    let text =
        format!("{ROOM}[[crowds]]\ncount = 2\nradius = 0.2\nregion = [3.0, 0.0, 1.0, 4.0]\n");
    assert_message(&error_of(&text), 3, &["[[crowds]] #1", "x1 > x0"]);
}

#[test]
fn exit_target_without_exits() {
    let text = format!(
        "{ROOM}[desired]\nkind = \"exit\"\n[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n"
    );
    assert_message(
        &error_of(&text),
        3,
        &["[desired]", "needs at least one [[exits]]"],
    );
}

#[test]
fn point_target_without_point() {
    let text = format!(
        "{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\ndesired = {{ kind = \"point\" }}\n"
    );
    assert_message(
        &error_of(&text),
        3,
        &["[[people]] #1 desired", "needs `point"],
    );
}

#[test]
fn constant_velocity_without_velocity() {
    let text = format!(
        "{ROOM}[desired]\nkind = \"constant\"\n[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n"
    );
    assert_message(&error_of(&text), 3, &["[desired]", "needs `velocity"]);
}

#[test]
fn room_with_both_shapes() {
    let e = error_of("[room]\nrectangle = [0.0, 0.0, 4.0, 4.0]\npolygon = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]\n");
    assert_message(&e, 1, &["[room]", "not both"]);
}

#[test]
fn empty_rectangle() {
    let e = error_of("[room]\nrectangle = [0.0, 0.0, 0.0, 4.0]\n");
    assert_message(&e, 1, &["[room]", "x1 > x0"]);
}

#[test]
fn flat_polygon_room() {
    let e = error_of("[room]\npolygon = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]\n");
    assert_message(&e, 1, &["[room]", "zero area"]);
}

#[test]
fn obstacle_with_two_shapes() {
    let text = format!(
        "{ROOM}[[obstacles]]\ndisk = {{ center = [2.0, 2.0], radius = 0.5 }}\nsegment = {{ from = [1.0, 1.0], to = [2.0, 1.0] }}\n"
    );
    assert_message(&error_of(&text), 3, &["[[obstacles]] #1", "exactly one"]);
}

#[test]
fn obstacle_path_going_back_in_time() {
    let text = format!(
        "{ROOM}[[obstacles]]\nsegment = {{ from = [1.0, 1.0], to = [2.0, 1.0] }}\npath = [[0.0, 0.0, 0.0], [2.0, 1.0, 0.0], [1.0, 0.0, 0.0]]\n"
    );
    assert_message(
        &error_of(&text),
        3,
        &["[[obstacles]] #1", "times must increase"],
    );
}

#[test]
fn obstacle_with_negative_radius() {
    let text = format!("{ROOM}[[obstacles]]\ndisk = {{ center = [2.0, 2.0], radius = -0.5 }}\n");
    assert_message(
        &error_of(&text),
        3,
        &["[[obstacles]] #1", "radius must be positive"],
    );
}

#[test]
fn nobody() {
    let e = error_of(ROOM);
    let m = e.to_string();
    assert!(m.starts_with("bad.toml: "), "{m}");
    assert!(m.contains("nobody in it"), "{m}");
}

#[test]
fn bad_output_setting() {
    let text = format!(
        "{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n[output]\nsnapshot_every = -1.0\n"
    );
    assert_message(
        &error_of(&text),
        6,
        &["[output] snapshot_every", "positive"],
    );
}

#[test]
fn missing_file_names_the_file() {
    let e = Scene::from_file("/nonexistent/dir/scene.toml").unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }));
    assert!(
        e.to_string()
            .starts_with("/nonexistent/dir/scene.toml: cannot read"),
        "{e}"
    );
}

#[test]
fn errors_from_a_file_name_the_file() {
    let dir = std::env::temp_dir().join(format!("sweeping-scene-errors-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("broken.toml");
    std::fs::write(
        &path,
        format!("{ROOM}\n[[people]]\nposition = [9.0, 1.0]\nradius = 0.2\n"),
    )
    .unwrap();
    let e = Scene::from_file(&path)
        .and_then(|s| s.build(&Overrides::default()))
        .map(|_| ())
        .unwrap_err();
    let m = e.to_string();
    assert!(
        m.starts_with(&format!("{}:4: [[people]] #1", path.display())),
        "{m}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn threads_negative_are_refused_and_the_command_line_beats_the_scene() {
    let person = "[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n";
    let text = format!("{ROOM}{person}[run]\nthreads = -1\n");
    assert_message(&error_of(&text), 7, &["integer `-1`", "expected usize"]);
    let text = format!("{ROOM}{person}[run]\nthreads = 1\n");
    let scene = Scene::from_toml_str(&text, "ok.toml").unwrap();
    let built = scene.build(&Overrides::default()).unwrap();
    assert_eq!(built.threads, 1);
    assert!(
        built.describe().contains("on 1 thread"),
        "{}",
        built.describe()
    );
    let built = scene
        .build(&Overrides {
            threads: Some(0),
            ..Default::default()
        })
        .unwrap();
    assert_eq!(built.threads, 0);
    // Without either: as many as the cores.
    let text = format!("{ROOM}{person}");
    let built = Scene::from_toml_str(&text, "ok.toml")
        .and_then(|s| s.build(&Overrides::default()))
        .unwrap();
    assert_eq!(built.threads, 0);
}

#[test]
fn a_speed_that_a_constant_desired_velocity_would_ignore_is_refused() {
    // The constant velocity's length is the speed: `speed = 0` was ignored and the person
    // walked at 1 m/s.
    let text = format!(
        "{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\nspeed = 0.0\n\
         [desired]\nkind = \"constant\"\nvelocity = [1.0, 0.0]\n"
    );
    let e = error_of(&text);
    assert_message(
        &e,
        3,
        &["[[people]] #1", "speed = 0 has no effect", "drop `speed`"],
    );
    // The same for a crowd with its own constant desire.
    let text = format!(
        "{ROOM}[[crowds]]\ncount = 3\nradius = 0.2\nspeed = 2.0\n\
         desired = {{ kind = \"constant\", velocity = [0.0, 0.5] }}\n"
    );
    let e = error_of(&text);
    assert_message(&e, 3, &["speed = 2 has no effect"]);
    // A speed equal to the velocity's length says the same thing twice: accepted.
    let text = format!(
        "{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\nspeed = 1.0\n\
         [desired]\nkind = \"constant\"\nvelocity = [0.6, 0.8]\n"
    );
    Scene::from_toml_str(&text, "ok.toml")
        .and_then(|s| s.build(&Overrides::default()))
        .unwrap();
}

#[test]
fn a_polygon_that_crosses_or_touches_itself_is_refused() {
    // A bow tie: edges 1 ((0,0)→(4,4)) and 3 ((4,0)→(0,3)) cross. It was accepted.
    let e = error_of("[room]\npolygon = [[0.0, 0.0], [4.0, 4.0], [4.0, 0.0], [0.0, 3.0]]\n");
    assert_message(&e, 1, &["[room]", "edges 1 and 3 of the polygon meet"]);
    // A vertex on a non-adjacent edge: vertex 4 (2, 0) lies on edge 1.
    let e = error_of(
        "[room]\npolygon = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [2.0, 0.0], [0.0, 4.0]]\n",
    );
    assert_message(&e, 1, &["of the polygon meet"]);
    // An obstacle's bow tie.
    let e = error_of(&format!(
        "{ROOM}[[obstacles]]\npolygon = [[1.0, 1.0], [2.0, 2.0], [2.0, 1.0], [1.0, 1.8]]\n"
    ));
    assert_message(
        &e,
        3,
        &["[[obstacles]] #1", "edges 1 and 3 of the polygon meet"],
    );
    // Simple polygons, convex or not, pass (an L-shaped room and a triangle in it).
    let ok = "[room]\npolygon = [[0.0, 0.0], [4.0, 0.0], [4.0, 2.0], [2.0, 2.0], [2.0, 4.0], [0.0, 4.0]]\n\
              [[obstacles]]\npolygon = [[0.5, 0.5], [1.5, 0.5], [1.0, 1.5]]\n\
              [[people]]\nposition = [3.0, 1.0]\nradius = 0.2\n";
    Scene::from_toml_str(ok, "ok.toml")
        .and_then(|s| s.build(&Overrides::default()))
        .unwrap();
}

/// A state to resume from is checked against the scene, since the run
/// trusts it from then on; each refusal names the person and leaves the scene as it was.
#[test]
fn a_state_that_does_not_fit_the_scene_is_not_resumed_from() {
    use sweeping::scene::{ResumeError, ResumeState};
    let text =
        "[room]\nrectangle = [0.0, 0.0, 4.0, 4.0]\n[[exits]]\nfrom = [4.0, 1.5]\nto = [4.0, 2.5]\n\
                [[obstacles]]\npolygon = [[1.0, 3.0], [2.0, 3.0], [2.0, 3.9], [1.0, 3.9]]\n\
                [[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n\
                [[people]]\nposition = [2.0, 2.0]\nradius = 0.2\n\
                [run]\nt_end = 5.0\n";
    let scene = Scene::from_toml_str(text, "resume.toml").unwrap();
    let mut built = scene.build(&Overrides::default()).unwrap();
    let state = |t: f64, q: [f64; 4], departed: [bool; 2]| ResumeState {
        t,
        q: q.to_vec(),
        departed: departed.to_vec(),
    };
    let cases: [(ResumeState, &str); 8] = [
        (state(-100.0, [1.0, 1.0, 2.0, 2.0], [false; 2]), "before the scene's start t = 0"),
        (state(5.0, [1.0, 1.0, 2.0, 2.0], [false; 2]), "not before the horizon T = 5"),
        (
            state(1.0, [1.0, 1.0, 2.0, 2.0], [false, true]),
            "person 1 is marked gone at t = 1, at (2, 2), but their disk (radius 0.2) is not wholly outside the room",
        ),
        (
            state(1.0, [-3.0, 2.0, 2.0, 2.0], [false; 2]),
            "person 0 is marked present at t = 1, at (-3, 2), but their disk (radius 0.2) is wholly outside the room",
        ),
        (
            state(1.0, [-3.0, 2.0, 2.0, 2.0], [true, false]),
            "person 0 is marked gone at t = 1, at (-3, 2), but they are outside the room on no exit's outer side",
        ),
        (
            state(1.0, [1.5, 3.5, 2.0, 2.0], [false; 2]),
            "person 0 is marked present at t = 1, at (1.5, 3.5), but they are inside obstacle #1",
        ),
        (
            state(1.0, [2.1, 2.0, 2.0, 2.0], [false; 2]),
            "the state at t = 1 is not one a run of the scene reaches",
        ),
        (state(1.0, [f64::NAN, 2.0, 2.0, 2.0], [false; 2]), "person 0's x coordinate is NaN"),
    ];
    for (s, says) in cases {
        let e: ResumeError = built.resume_at(s.clone()).unwrap_err();
        assert!(e.to_string().contains(says), "{s:?}: {e}");
        assert_eq!(built.problem.t0(), 0.0, "{e}");
        assert_eq!(built.problem.q0(), &[1.0, 1.0, 2.0, 2.0], "{e}");
    }
    // Who left through the exit, and is beyond it, is gone; the rest as the run had them.
    built
        .resume_at(state(1.0, [4.5, 2.0, 2.0, 2.0], [true, false]))
        .unwrap();
    assert_eq!(built.departed_at_start, vec![true, false]);
}

#[test]
fn a_crowd_of_nobody_is_refused() {
    let text = format!(
        "{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n[[crowds]]\ncount = 0\nradius = 0.2\n"
    );
    assert_message(&error_of(&text), 6, &["[[crowds]] #1", "count = 0"]);
}

#[test]
fn a_bad_geodesic_cell_is_refused_even_when_nobody_heads_for_an_exit() {
    let text =
        format!("{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n[geodesic]\ncell = -1.0\n");
    assert_message(
        &error_of(&text),
        6,
        &["[geodesic] cell", "positive and finite, got -1"],
    );
}

#[test]
fn people_listed_one_by_one_count_towards_the_limit() {
    // One person more than the limit, all at one place: the limit is reported, not the overlap.
    let n = sweeping::scene::MAX_PEOPLE + 1;
    let mut text = String::from("people = [\n");
    for _ in 0..n {
        text.push_str("{ position = [1.0, 1.0], radius = 0.2 },\n");
    }
    text.push_str("]\n");
    text.push_str(ROOM);
    let e = error_of(&text);
    assert_message(
        &e,
        1 + n,
        &[
            &format!("[[people]] #{n}"),
            &format!("{n} people: a scene holds at most 1000000"),
        ],
    );
}

#[test]
fn an_exit_over_a_vertex_between_collinear_edges_is_on_the_wall() {
    // The east wall is two edges, (4, 0)–(4, 2) and (4, 2)–(4, 4); the exit spans the vertex.
    let text = "[room]\npolygon = [[0.0, 0.0], [4.0, 0.0], [4.0, 2.0], [4.0, 4.0], [0.0, 4.0]]\n\
                [[exits]]\nfrom = [4.0, 1.5]\nto = [4.0, 2.5]\n[desired]\nkind = \"exit\"\n\
                [[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n";
    let built = Scene::from_toml_str(text, "ok.toml")
        .and_then(|s| s.build(&Overrides::default()))
        .unwrap_or_else(|e| panic!("refused: {e}"));
    let walls = &built.geometry.walls;
    assert!(
        walls.contains(&([4.0, 0.0], [4.0, 1.5])) && walls.contains(&([4.0, 2.5], [4.0, 4.0])),
        "{walls:?}"
    );
    // No wall runs across the doorway.
    assert!(
        !walls.iter().any(|(a, b)| a[0] == 4.0
            && b[0] == 4.0
            && a[1].min(b[1]) < 2.5
            && a[1].max(b[1]) > 1.5),
        "{walls:?}"
    );
}

#[test]
fn a_geodesic_cell_too_coarse_for_an_exit_names_the_exit_width_unrounded() {
    // 1.3 − 1.1 is 0.19999999999999996: the cell 0.1 is just over half of it, and the message
    // must not call the width 0.2, of which 0.1 is half.
    let text = format!(
        "{ROOM}[[exits]]\nfrom = [4.0, 1.1]\nto = [4.0, 1.3]\n[desired]\nkind = \"exit\"\n\
         [[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n[geodesic]\ncell = 0.1\n"
    );
    let e = error_of(&text);
    assert_message(
        &e,
        11,
        &[
            "[geodesic] cell",
            "0.19999999999999996",
            "0.09999999999999998",
        ],
    );
    assert!(!e.to_string().contains("(0.2)"), "{e}");
}

#[test]
fn a_name_with_a_control_character_is_refused_at_its_line() {
    let text = format!(
        "# a scene\nname = \"bell\\u0007\"\n{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n"
    );
    assert_message(
        &error_of(&text),
        2,
        &["name", "control characters", "--out"],
    );
}

#[test]
fn bad_distributions_of_a_crowd() {
    let crowd =
        |speed: &str| format!("{ROOM}[[crowds]]\ncount = 3\nradius = 0.2\nspeed = {speed}\n");
    for (speed, fragment) in [
        (
            "{ normal = [1.3, 0.2] }",
            "speed: a normal distribution needs `within = [min, max]`",
        ),
        (
            "{ uniform = [1.5, 1.0] }",
            "speed: uniform = [min, max] needs 0 ≤ min ≤ max",
        ),
        (
            "{ uniform = [-1.0, 1.0] }",
            "speed: uniform = [min, max] needs 0 ≤ min ≤ max",
        ),
        (
            "{ uniform = [1.0, 1.2], normal = [1.3, 0.2] }",
            "give exactly one of",
        ),
        (
            "{ normal = [1.3, 0.01], within = [3.0, 4.0] }",
            "the window lies too far in the tail",
        ),
        ("-0.5", "speed: must be ≥ 0 and finite, got -0.5"),
        (
            "{ normal = [1.3, -0.2], within = [0.5, 2.0] }",
            "normal = [mean, sd] needs a finite mean and a finite sd ≥ 0",
        ),
        (
            "{ normal = [nan, 0.2], within = [0.5, 2.0] }",
            "normal = [mean, sd] needs a finite mean",
        ),
        (
            "{ normal = [1.3, inf], within = [0.5, 2.0] }",
            "normal = [mean, sd] needs a finite mean and a finite sd ≥ 0",
        ),
        (
            "{ normal = [1.3, 0.2], within = [2.0, 0.5] }",
            "within = [min, max] needs 0 ≤ min ≤ max",
        ),
        (
            "{ normal = [1.3, 0.2], within = [-1.0, 2.0] }",
            "within = [min, max] needs 0 ≤ min ≤ max",
        ),
        (
            "{ normal = [1.3, 0.2], within = [0.5, inf] }",
            "within = [min, max] needs 0 ≤ min ≤ max, both finite",
        ),
    ] {
        assert_message(&error_of(&crowd(speed)), 3, &["[[crowds]] #1", fragment]);
    }
    // Not a distribution at all: the parser's error, at the key.
    assert_message(
        &error_of(&crowd("{ uniform = [1.0] }")),
        6,
        &["a number, or a distribution: { uniform = [min, max] }"],
    );
}

#[test]
fn a_negative_pre_movement_time() {
    let text =
        format!("{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\npre_movement = -1.0\n");
    assert_message(
        &error_of(&text),
        3,
        &["pre_movement: must be ≥ 0 and finite, got -1"],
    );
}

#[test]
fn exits_of_a_desire_must_exist_and_go_with_kind_exit() {
    let scene = |desired: &str| {
        format!(
            "{ROOM}[[exits]]\nfrom = [4.0, 1.0]\nto = [4.0, 2.0]\n[[people]]\nposition = [1.0, 1.0]\n\
             radius = 0.2\ndesired = {desired}\n"
        )
    };
    for (desired, fragment) in [
        (
            "{ kind = \"exit\", exits = [2] }",
            "exit 2 does not exist; the scene's [[exits]] are numbered 1 to 1",
        ),
        ("{ kind = \"exit\", exits = [0] }", "exit 0 does not exist"),
        ("{ kind = \"exit\", exits = [1, 1] }", "names exit 1 twice"),
        (
            "{ kind = \"exit\", exits = [] }",
            "exits = [] heads nowhere",
        ),
        (
            "{ kind = \"point\", point = [2.0, 2.0], exits = [1] }",
            "`exits` goes only with kind = \"exit\"",
        ),
    ] {
        assert_message(
            &error_of(&scene(desired)),
            6,
            &["[[people]] #1 desired", fragment],
        );
    }
}

#[test]
fn contact_forces_must_be_true_or_false() {
    for value in ["\"yes\"", "1", "[true]"] {
        let text = format!(
            "{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n[output]\ncontact_forces = {value}\n"
        );
        let e = error_of(&text);
        assert!(matches!(e, SceneError::Parse { .. }), "{e}");
        assert_message(&e, 7, &["invalid type", "expected a boolean"]);
    }
}

#[test]
fn bad_sources() {
    // Line 3 is the `[[sources]]` header.
    let source = |body: &str| format!("{ROOM}[[sources]]\nradius = 0.2\n{body}\n");
    let region = "region = [0.5, 0.5, 3.5, 3.5]\n";
    for (body, fragment) in [
        (region.to_string(), "say when people arrive: `rate"),
        (format!("{region}rate = 2.0"), "`rate` needs `count`"),
        (
            format!("{region}rate = 0.0\ncount = 3"),
            "rate: people per second must be positive",
        ),
        (
            format!("{region}rate = 2.0\ncount = 0"),
            "count = 0 brings nobody",
        ),
        (
            format!("{region}rate = 2.0\ncount = 3\nstart = -1.0"),
            "start: must be ≥ 0",
        ),
        (
            format!("{region}rate = 2.0\ncount = 3\ntimes = [1.0]"),
            "not both",
        ),
        (
            format!("{region}rate = 2.0\ncount = 3\ncounts = [1]"),
            "`counts` goes with `times`",
        ),
        (format!("{region}times = []"), "times = [] brings nobody"),
        (
            format!("{region}times = [2.0, 1.0]"),
            "times: must not decrease, got 1 after 2",
        ),
        (
            format!("{region}times = [-1.0]"),
            "times: every time must be ≥ 0",
        ),
        (
            format!("{region}times = [1.0, 2.0]\ncounts = [1]"),
            "counts: one count per time, got 1 counts for 2 times",
        ),
        (
            format!("{region}times = [1.0, 2.0]\ncounts = [1, 0]"),
            "counts[1] = 0 brings nobody at t = 2",
        ),
        (
            format!("{region}times = [1.0]\ncount = 2"),
            "`count` and `start` go with `rate`",
        ),
        ("times = [1.0]".to_string(), "give exactly one of `region"),
        (
            format!("{region}times = [1.0]\ndoor = {{ from = [0.0, 1.0], to = [0.0, 2.0] }}"),
            "give exactly one of `region",
        ),
        (
            "times = [1.0]\nregion = [3.0, 0.5, 1.0, 3.5]".to_string(),
            "needs finite numbers, x1 > x0",
        ),
        (
            "times = [1.0]\nregion = [5.0, 5.0, 6.0, 6.0]".to_string(),
            "no place for a person of radius 0.2 in the region",
        ),
        (
            "times = [1.0]\ndoor = { from = [1.0, 1.0], to = [2.0, 1.0] }".to_string(),
            "door: (1, 1)–(2, 1) is not on a wall",
        ),
        (
            "times = [1.0]\ndoor = { from = [0.0, 1.0], to = [0.0, 1.3] }".to_string(),
            "door: 0.3 wide, narrower than one person",
        ),
        (
            format!("{region}times = [1.0]\ngap = -0.1"),
            "gap: must be ≥ 0 and finite, got -0.1",
        ),
        (
            format!("{region}times = [1.0]\nspeed = -1.0"),
            "speed: must be ≥ 0",
        ),
        (
            format!("{region}times = [1.0]\ndesired = {{ kind = \"exit\" }}"),
            "kind = \"exit\" needs at least one [[exits]]",
        ),
    ] {
        assert_message(&error_of(&source(&body)), 3, &["[[sources]] #1", fragment]);
    }
    // A door whose places are all taken by an obstacle.
    let text = format!(
        "{ROOM}[[obstacles]]\ndisk = {{ center = [0.5, 2.0], radius = 0.4 }}\n[[sources]]\nradius = 0.2\ntimes = [1.0]\ndoor = {{ from = [0.0, 1.6], to = [0.0, 2.4] }}\n"
    );
    assert_message(
        &error_of(&text),
        5,
        &["door: no place inside it", "inside obstacle #1"],
    );
    // An unknown key, at its line.
    assert_message(
        &error_of(&source(
            "times = [1.0]\nregion = [0.5, 0.5, 3.5, 3.5]\nflow = 2.0",
        )),
        7,
        &["unknown field `flow`"],
    );
}

#[test]
fn bad_radius_distributions_and_gaps_of_a_crowd() {
    let crowd = |radius: &str, extra: &str| {
        format!("{ROOM}[[crowds]]\ncount = 3\nradius = {radius}\n{extra}")
    };
    for (text, fragment) in [
        (
            crowd("{ uniform = [0.0, 0.2] }", ""),
            "radius: uniform = [min, max] needs 0 < min ≤ max",
        ),
        (
            crowd("{ uniform = [0.3, 0.2] }", ""),
            "radius: uniform = [min, max] needs 0 < min ≤ max",
        ),
        (
            crowd("{ normal = [0.2, 0.02] }", ""),
            "radius: a normal distribution needs `within",
        ),
        (
            crowd("{ normal = [0.2, 0.02], within = [0.0, 0.3] }", ""),
            "radius: within = [min, max] needs 0 < min ≤ max",
        ),
        (
            crowd("{ normal = [0.2, 0.001], within = [0.3, 0.4] }", ""),
            "radius: no value of normal = [0.2, 0.001] fell within [0.3, 0.4]",
        ),
        (
            crowd("0.2", "gap = -0.5\n"),
            "gap: must be ≥ 0 and finite, got -0.5",
        ),
        (
            crowd("0.2", "gap = inf\n"),
            "gap: must be ≥ 0 and finite, got inf",
        ),
        (
            crowd("[0.2, 0.1]", ""),
            "a range of radii needs 0 < min ≤ max",
        ),
    ] {
        assert_message(&error_of(&text), 3, &["[[crowds]] #1", fragment]);
    }
    // A gap that no longer lets the crowd fit: the area bound counts the grown disks.
    assert_message(
        &error_of(&crowd("0.2", "count = 40\ngap = 0.6\n").replace("count = 3\n", "")),
        3,
        &["cannot fit"],
    );
}

#[test]
fn bad_journeys() {
    let exits = "[[exits]]\nfrom = [4.0, 1.5]\nto = [4.0, 2.5]\n";
    // Line 6 is the person's header.
    let person = |desired: &str| {
        format!(
            "{ROOM}{exits}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\ndesired = {desired}\n"
        )
    };
    for (desired, fragment) in [
        ("{ kind = \"journey\" }", "kind = \"journey\" needs `waypoints"),
        ("{ kind = \"journey\", waypoints = [] }", "waypoints = [] is no journey"),
        ("{ kind = \"journey\", waypoints = [{ reach = 1.0 }] }", "waypoint 1: give exactly one of `point` and `region`"),
        ("{ kind = \"journey\", waypoints = [{ point = [1.0, 3.0], region = [0.5, 0.5, 1.0, 1.0] }] }", "waypoint 1: give exactly one"),
        ("{ kind = \"journey\", waypoints = [{ point = [2.0, 2.0] }, { point = [1.0, 3.0], reach = 0.0 }] }", "waypoint 2: reach must be positive and finite, got 0"),
        ("{ kind = \"journey\", waypoints = [{ point = [5.0, 2.0] }] }", "waypoint 1: (5, 2) is outside the room"),
        ("{ kind = \"journey\", waypoints = [{ region = [2.0, 2.0, 1.0, 3.0] }] }", "waypoint 1: the region [x0, y0, x1, y1] = [2.0, 2.0, 1.0, 3.0] needs finite numbers"),
        ("{ kind = \"journey\", waypoints = [{ region = [1.0, 2.0, 2.0, 3.0], reach = 0.5 }] }", "waypoint 1: `reach` goes with `point`"),
        ("{ kind = \"journey\", waypoints = [{ point = [2.0, 2.0] }], point = [3.0, 3.0], exits = [1] }", "a journey ends at `point` or at the exits (`exits`), not both"),
        ("{ kind = \"journey\", waypoints = [{ point = [2.0, 2.0] }], exits = [2] }", "exits = [2]: exit 2 does not exist"),
        ("{ kind = \"journey\", waypoints = [{ point = [2.0, 2.0] }], velocity = [1.0, 0.0] }", "kind = \"journey\" does not take `velocity`"),
        ("{ kind = \"journey\", waypoints = [{ point = [2.0, 2.0] }], route = \"straight\" }", "`route` goes only with kind = \"point\", or a journey ending at `point`"),
        ("{ kind = \"exit\", route = \"geodesic\" }", "`route` goes only with kind = \"point\""),
        ("{ kind = \"point\", point = [2.0, 2.0], waypoints = [{ point = [2.0, 2.0] }] }", "`waypoints` goes only with kind = \"journey\""),
    ] {
        assert_message(&error_of(&person(desired)), 6, &["[[people]] #1 desired", fragment]);
    }
    // Without exits, a journey must end at a point.
    let text = format!(
        "{ROOM}[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\ndesired = {{ kind = \"journey\", waypoints = [{{ point = [2.0, 2.0] }}] }}\n"
    );
    assert_message(
        &error_of(&text),
        3,
        &["a journey ending at the exits needs at least one [[exits]]"],
    );
    // An unknown route, and an unknown key of a waypoint: the parser's errors.
    let e = error_of(&person(
        "{ kind = \"point\", point = [2.0, 2.0], route = \"shortest\" }",
    ));
    assert!(e.to_string().contains("unknown variant `shortest`"), "{e}");
    let e = error_of(&person(
        "{ kind = \"journey\", waypoints = [{ point = [2.0, 2.0], wait = 3.0 }] }",
    ));
    assert!(e.to_string().contains("unknown field `wait`"), "{e}");
    // A waypoint inside an obstacle: the field to it cannot be computed.
    let text = format!(
        "{ROOM}{exits}[[obstacles]]\ndisk = {{ center = [2.0, 3.0], radius = 0.5 }}\n[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\ndesired = {{ kind = \"journey\", waypoints = [{{ point = [2.0, 3.0], reach = 0.2 }}] }}\n"
    );
    let e = error_of(&text);
    assert!(
        e.to_string()
            .contains("the field to the point (2, 3): no free node"),
        "{e}"
    );
}

#[test]
fn bad_geometry_in_wkt() {
    let room = |keys: &str| {
        format!("name = \"w\"\n[room]\n{keys}\n[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n")
    };
    let square = "wkt = \"POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0))\"";
    for (keys, item, fragment) in [
        ("wkt = \"POLYGON ((0 0, 4 0, 4 4\"".to_string(), "[room] wkt", "not valid WKT"),
        ("wkt = \"POINT (1 1)\"".to_string(), "[room] wkt", "a POINT where polygons are expected"),
        ("wkt = \"POLYGON Z ((0 0 1, 4 0 1, 4 4 1, 0 0 1))\"".to_string(), "[room] wkt", "coordinates with z or m"),
        ("wkt = \"MULTIPOLYGON (((0 0, 2 0, 2 2, 0 0)), ((3 3, 4 3, 4 4, 3 3)))\"".to_string(), "[room] wkt", "a MULTIPOLYGON of 2 polygons: the walkable area must be one polygon"),
        (format!("{square}\nrectangle = [0.0, 0.0, 4.0, 4.0]"), "[room]", "give one of `rectangle`, `polygon`, `wkt` and `wkt_file`"),
        (format!("{square}\nwkt_file = \"x.wkt\""), "[room]", "give one of"),
        ("wkt_file = \"no-such-file.wkt\"".to_string(), "[room] wkt_file", "cannot read"),
        (format!("{square}\nexits_wkt = \"POLYGON ((0 0, 1 0, 1 1, 0 0))\""), "[room] exits_wkt", "a POLYGON where exits are expected"),
        (format!("{square}\nexits_wkt = \"LINESTRING (4 1, 4 2, 4 3)\""), "[room] exits_wkt", "line 1 has 3 points: an exit is a LINESTRING of two points"),
        (format!("{square}\nobstacles_wkt = \"POLYGON ((1 1, 3 1, 3 3, 1 3, 1 1), (1.5 1.5, 2 1.5, 2 2, 1.5 1.5))\""), "[room] obstacles_wkt", "an obstacle with holes"),
        // Read into the scene's items, then checked as they are.
        ("wkt = \"POLYGON ((0 0, 4 0, 0 3, 3 4, 0 0))\"".to_string(), "[room]", "edges 2 and 4 of the polygon meet"),
        (format!("{square}\nexits_wkt = \"LINESTRING (2 2, 3 3)\""), "[[exits]] #1", "is not on a wall of the room"),
        ("exits_wkt = \"LINESTRING (4 1, 4 2)\"".to_string(), "[room]", "give `rectangle"),
    ] {
        assert_message(&error_of(&room(&keys)), 2, &[item, fragment]);
    }
    // A hole is an obstacle: a person inside it is refused, named by its number.
    let text = room("wkt = \"POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0), (0.5 0.5, 1.5 0.5, 1.5 1.5, 0.5 1.5, 0.5 0.5))\"");
    assert_message(
        &error_of(&text),
        4,
        &["[[people]] #1", "inside obstacle #1"],
    );
}
