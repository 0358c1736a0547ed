//! Issue #9: hard cases stay numerically stable. Each reproduction of the issue either fails
//! loudly (non-zero exit, a typed error naming step, time and constraint) or runs correctly, as
//! judged by an independent checker reading the `trajectory.csv` the real `sweep` binary wrote.

mod common;

use common::checker::{check_trajectory, moving, still, sweep_run, Geometry, Obstacle};

const TOL: f64 = 1e-6;

fn assert_clean(name: &str, csv: &std::path::Path, g: &Geometry) -> common::checker::Findings {
    let f = check_trajectory(csv, g, TOL);
    assert!(f.rows > 0, "{name}: empty trajectory");
    assert!(f.problems.is_empty(), "{name}: {:#?}", f.problems);
    f
}

/// Item 1: people who left cannot walk back in through a wall of a U-shaped room.
#[test]
fn once_left_always_left_in_a_u_shaped_room() {
    let scene = r#"
[room]
polygon = [[0,0],[6,0],[6,5],[4,5],[4,2],[2,2],[2,5],[0,5]]
[[exits]]
from = [2,3]
to = [2,4]
[[people]]
position = [1, 3.5]
radius = 0.2
[[people]]
position = [4.2, 3.5]
radius = 0.2
speed = 0
[desired]
kind = "exit"
[run]
t_end = 6
[output]
trajectory_every = 0.01
"#;
    let run = sweep_run("u-room", scene, &[]);
    assert!(run.success, "{}", run.output);
    let g = Geometry {
        room: vec![
            [0., 0.],
            [6., 0.],
            [6., 5.],
            [4., 5.],
            [4., 2.],
            [2., 2.],
            [2., 5.],
            [0., 5.],
        ],
        exits: vec![([2., 3.], [2., 4.])],
        obstacles: vec![],
        radii: vec![0.2, 0.2],
    };
    let f = assert_clean("u-room", &run.out.join("trajectory.csv"), &g);
    assert_eq!(
        f.present_at_end, 1,
        "the standing person stays, the walker is gone"
    );
    assert!(f.times > 500, "{} times", f.times);
}

/// Item 2: a moving wall cannot jump people when its step is longer than their distance.
#[test]
fn moving_wall_with_long_steps_fails_and_names_a_step_that_would_do() {
    let scene = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/scenes/moving-wall.toml"
    ))
    .unwrap();
    for h in ["1.0", "0.5"] {
        let run = sweep_run(&format!("moving-wall-{h}"), &scene, &["--h", h]);
        assert!(!run.success, "h = {h} completed:\n{}", run.output);
        assert!(
            run.output.contains("too long for the moving constraint")
                && run.output.contains("would do")
                && run.output.contains("obstacles #0"),
            "{}",
            run.output
        );
        // What was written before the failure is physically right.
        let g = Geometry {
            room: vec![[0., 0.], [6., 0.], [6., 3.], [0., 3.]],
            exits: vec![],
            obstacles: vec![Obstacle::Segment(
                [0.3, 0.05],
                [0.3, 2.95],
                moving([0.4, 0.0]),
            )],
            radii: vec![0.2; 40],
        };
        assert_clean("moving wall", &run.out.join("trajectory.csv"), &g);
    }
}

/// Item 2: the same scene at a step the rule accepts runs clean to the end (the wall moves
/// 0.4 m/s for 8 s and the crowd is compressed, nobody jumped).
#[test]
fn moving_wall_at_an_accepted_step_runs_clean() {
    let scene = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/scenes/moving-wall.toml"
    ))
    .unwrap();
    let run = sweep_run("moving-wall-ok", &scene, &["--h", "0.1"]);
    assert!(run.success, "{}", run.output);
    let path = |t: f64| [0.4 * t.min(8.0), 0.0];
    let g = Geometry {
        room: vec![[0., 0.], [6., 0.], [6., 3.], [0., 3.]],
        exits: vec![],
        obstacles: vec![Obstacle::Segment([0.3, 0.05], [0.3, 2.95], Box::new(path))],
        radii: vec![0.2; 40],
    };
    assert_clean("moving wall h = 0.1", &run.out.join("trajectory.csv"), &g);
}

/// Item 2: a segment at 2 m/s with a person 0.6 m ahead and h = 0.5; a small disk at 30 m/s
/// at the default h; a fast path.
#[test]
fn fast_obstacles_fail_loudly() {
    let cases = [
        (
            "segment",
            "segment = { from = [1.0, 1.0], to = [1.0, 4.0] }\nvelocity = [2.0, 0.0]",
            "0.5",
        ),
        (
            "disk",
            "disk = { center = [1.0, 2.5], radius = 0.1 }\nvelocity = [30.0, 0.0]",
            "0.01",
        ),
        (
            "path",
            "disk = { center = [1.0, 2.5], radius = 0.3 }\npath = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.05, 5.0, 0.0]]",
            "0.1",
        ),
    ];
    for (name, obstacle, h) in cases {
        let scene = format!(
            "[room]\nrectangle = [0.0, 0.0, 10.0, 5.0]\n[[obstacles]]\n{obstacle}\n\
             [[people]]\nposition = [1.8, 2.5]\nradius = 0.2\nspeed = 0\n\
             [run]\nh = {h}\nt_end = 2.0\n"
        );
        let run = sweep_run(&format!("fast-{name}"), &scene, &[]);
        assert!(!run.success, "{name} completed:\n{}", run.output);
        assert!(
            run.output.contains("too long for the moving constraint")
                && run.output.contains("would do"),
            "{name}: {}",
            run.output
        );
    }
}

/// Item 3: 40 people pushed into a corner at 1e12 m/s: no backend's answer is accepted with
/// an overlap (exit non-zero, the error names the step and the constraint or the check).
#[test]
fn a_corner_at_1e12_never_completes_with_overlaps() {
    let scene = r#"
[room]
rectangle = [0, 0, 5, 5]
[[crowds]]
count = 40
radius = 0.2
desired = { kind = "constant", velocity = [-1e12, -1e12] }
[run]
t_end = 0.05
"#;
    for backend in ["osqp", "clarabel"] {
        let run = sweep_run(&format!("corner-{backend}"), scene, &["--backend", backend]);
        let csv = run.out.join("trajectory.csv");
        let g = Geometry {
            room: vec![[0., 0.], [5., 0.], [5., 5.], [0., 5.]],
            exits: vec![],
            obstacles: vec![],
            radii: vec![0.2; 40],
        };
        if run.success {
            assert_clean(backend, &csv, &g);
        } else {
            assert!(run.output.contains("step 0, t = 0.01"), "{}", run.output);
            assert_clean(backend, &csv, &g);
        }
    }
    // The static obstacle helper is exercised too.
    let _ = Obstacle::Disk([0.0, 0.0], 1.0, still());
}
