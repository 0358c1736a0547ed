//! The RiMEA verification tests (RiMEA guideline, Annex 1) that a model of people in one plane
//! can run, on the scenes shipped in `examples/scenes/rimea/`, each with the suite's own pass
//! criterion checked on the trajectory. Tests 1, 5, 6, 7, 10 and 12 run in the default test run; test 9
//! (2 × 1000 people) is ignored here and run by `scripts/rimea`. The guide's page "The RiMEA
//! tests" says which tests pass, which cannot be written yet, and why.

use std::path::PathBuf;
use sweeping::backends::make_projector;
use sweeping::crowd::Population;
use sweeping::output::{RunSummary, SummaryCollector};
use sweeping::scene::{BuiltScene, Overrides, Scene};
use sweeping::stepper::{Observer, ObserverError, StepReport};

/// Every step's time and positions, and who was still in the room.
#[derive(Default)]
struct Recorder {
    population: Option<std::sync::Arc<Population>>,
    frames: Vec<Frame>,
}

struct Frame {
    t: f64,
    q: Vec<f64>,
    present: Vec<bool>,
}

impl Recorder {
    fn push(&mut self, t: f64, q: &[f64]) {
        let population = self.population.as_ref().expect("set before the run");
        let present = (0..population.len())
            .map(|i| population.is_present(q, i))
            .collect();
        self.frames.push(Frame {
            t,
            q: q.to_vec(),
            present,
        });
    }

    /// The first time person `i`'s centre reaches `x = line` going right (interpolated
    /// between steps), if it does.
    fn crossing_x(&self, i: usize, line: f64) -> Option<f64> {
        self.frames.windows(2).find_map(|w| {
            let (x0, x1) = (w[0].q[2 * i], w[1].q[2 * i]);
            (x0 < line && x1 >= line).then(|| w[0].t + (line - x0) / (x1 - x0) * (w[1].t - w[0].t))
        })
    }
}

impl Observer for Recorder {
    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        self.push(t, q);
        Ok(())
    }
    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        self.push(report.t, q);
        Ok(())
    }
}

fn scene(file: &str) -> BuiltScene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("examples/scenes/rimea")
        .join(file);
    Scene::from_file(&path)
        .and_then(|s| s.build(&Overrides::default()))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Runs `built` with its own backend; the summary, and every step when `record`.
fn run(built: &BuiltScene, record: bool) -> (RunSummary, Recorder) {
    let mut projector = make_projector(built.backend).expect("the scene's backend");
    let mut summary = SummaryCollector::new(
        &built.name,
        &built.problem,
        built.population.clone(),
        &built.backend.to_string(),
        built.settings.h,
        built.settings.t_end,
    );
    let mut recorder = Recorder {
        population: Some(built.population.clone()),
        frames: Vec::new(),
    };
    if record {
        built
            .run(projector.as_mut(), &mut [&mut summary, &mut recorder])
            .unwrap_or_else(|e| panic!("{}: {e}", built.name));
    } else {
        built
            .run(projector.as_mut(), &mut [&mut summary])
            .unwrap_or_else(|e| panic!("{}: {e}", built.name));
    }
    let summary = summary.summary().clone();
    // No overlap and no wall crossed, whatever the test measures.
    assert!(summary.max_overlap <= 1e-9, "{summary:?}");
    assert!(summary.max_wall_penetration <= 1e-9, "{summary:?}");
    (summary, recorder)
}

/// Flow through the vertical line `x = line`: people crossing it, less one, over the time
/// between the first and the last crossing (people per second).
fn flow_through(recorder: &Recorder, people: usize, line: f64) -> f64 {
    let mut times: Vec<f64> = (0..people)
        .filter_map(|i| recorder.crossing_x(i, line))
        .collect();
    times.sort_by(f64::total_cmp);
    assert!(times.len() >= 2, "fewer than two people crossed x = {line}");
    (times.len() - 1) as f64 / (times[times.len() - 1] - times[0])
}

/// Test 1: one person at 1.33 m/s covers the measured 40 m of a corridor in 26 to 34 s.
#[test]
fn rimea_1_the_walking_speed_is_kept_in_a_corridor() {
    let built = scene("test-01-corridor.toml");
    let (summary, recorder) = run(&built, true);
    assert_eq!(summary.people_remaining, 0, "{summary:?}");
    let enter = recorder.crossing_x(0, 0.0).expect("reaches x = 0");
    let leave = recorder.crossing_x(0, 40.0).expect("reaches x = 40");
    let travel = leave - enter;
    eprintln!("RiMEA 1: 40 m in {travel:.2} s (pass: 26 to 34 s)");
    assert!((26.0..=34.0).contains(&travel), "40 m in {travel} s");
}

/// Test 5: ten people with reaction times of 10, 20, …, 100 s start walking at those times
/// (the community's suite allows two frames at 8 per second, 0.25 s).
#[test]
fn rimea_5_people_start_at_their_reaction_times() {
    let built = scene("test-05-pre-movement.toml");
    assert_eq!(built.population.len(), 10);
    let (summary, recorder) = run(&built, true);
    assert_eq!(summary.people_remaining, 0, "{summary:?}");
    let start = &recorder.frames[0].q;
    let mut worst: f64 = 0.0;
    for i in 0..10 {
        let reaction = 10.0 * (i + 1) as f64;
        let moved = recorder
            .frames
            .iter()
            .find(|f| (f.q[2 * i] - start[2 * i]).hypot(f.q[2 * i + 1] - start[2 * i + 1]) > 1e-9)
            .map(|f| f.t)
            .expect("everybody moves");
        // The position at `t` is that after the step ending at `t`: a person who starts at
        // `reaction` has moved at the end of the step that begins there.
        let error = moved - built.settings.h - reaction;
        worst = worst.max(error.abs());
        assert!(
            (-1e-9..=0.25).contains(&error),
            "person {i}: reaction time {reaction} s, moved at {moved} s"
        );
    }
    eprintln!("RiMEA 5: every start within {worst:.3} s of its reaction time (pass: 0.25 s)");
}

/// Test 7: walking speeds drawn per age group lie in the group's range, and every measured
/// walking speed (distance over time from the start to 40 m on) within the ranges' union,
/// 0.46 to 1.61 m/s (the community's suite's criterion).
#[test]
fn rimea_7_speeds_drawn_per_group_are_kept() {
    let built = scene("test-07-speeds.toml");
    let ranges = [[0.58, 1.61], [1.41, 1.54], [0.68, 1.41], [0.46, 0.76]];
    assert_eq!(built.population.len(), 200);
    for (i, &v) in built.speeds.iter().enumerate() {
        let [lo, hi] = ranges[built.group_of[i]];
        assert!(
            (lo..=hi).contains(&v),
            "person {i}: speed {v} outside [{lo}, {hi}]"
        );
    }
    // The draws spread over each range rather than sitting on one value.
    for (g, [lo, hi]) in ranges.iter().enumerate() {
        let group: Vec<f64> = (0..200)
            .filter(|&i| built.group_of[i] == g)
            .map(|i| built.speeds[i])
            .collect();
        let (min, max) = group
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
        assert!(
            max - min > 0.2 * (hi - lo),
            "group {g}: speeds {min} to {max}"
        );
    }
    let (summary, recorder) = run(&built, true);
    assert_eq!(summary.people_remaining, 0, "{summary:?}");
    let (mut slowest, mut fastest) = (f64::INFINITY, 0.0f64);
    for i in 0..200 {
        let x0 = recorder.frames[0].q[2 * i];
        let t = recorder.crossing_x(i, x0 + 40.0).expect("walks 40 m");
        let v = 40.0 / t;
        slowest = slowest.min(v);
        fastest = fastest.max(v);
    }
    eprintln!("RiMEA 7: measured speeds {slowest:.3} to {fastest:.3} m/s (pass: 0.46 to 1.61)");
    assert!(slowest >= 0.46 && fastest <= 1.61, "{slowest} to {fastest}");
}

/// Test 6: 20 people walk around a corner; nobody is ever in the square inside the corner
/// (`[0, 10] × [2, 12]`), and everybody leaves.
#[test]
fn rimea_6_nobody_cuts_the_corner() {
    let built = scene("test-06-corner.toml");
    assert_eq!(built.population.len(), 20);
    let (summary, recorder) = run(&built, true);
    assert_eq!(summary.people_remaining, 0, "{summary:?}");
    eprintln!(
        "RiMEA 6: {} positions checked, none inside the corner; everybody out by {:.2} s",
        recorder.frames.len() * 20,
        summary.evacuation_time.unwrap_or(f64::NAN)
    );
    for frame in &recorder.frames {
        for i in 0..20 {
            let (x, y) = (frame.q[2 * i], frame.q[2 * i + 1]);
            let inside = (0.0..=10.0).contains(&x) && (2.0..=12.0).contains(&y);
            assert!(
                !(frame.present[i] && inside),
                "person {i} at ({x}, {y}) at t = {}",
                frame.t
            );
        }
    }
}

/// Test 10: 23 people in twelve rooms off a corridor leave by the exit each is assigned (the
/// lower rooms' by exit 2 at the corridor's right end, the upper rooms' by exit 1 at its left
/// end), not by the nearest.
#[test]
fn rimea_10_everybody_uses_their_assigned_exit() {
    let built = scene("test-10-assigned-exits.toml");
    let n = built.population.len();
    assert_eq!(n, 23);
    let (summary, recorder) = run(&built, true);
    assert_eq!(summary.people_remaining, 0, "{summary:?}");
    let start = &recorder.frames[0].q;
    for i in 0..n {
        let gone = recorder
            .frames
            .iter()
            .find(|f| !f.present[i])
            .expect("everybody leaves");
        let (x, y) = (gone.q[2 * i], gone.q[2 * i + 1]);
        let assigned_right = start[2 * i + 1] < 5.0;
        let by_right = x > 23.0 && (4.0..=6.0).contains(&y);
        let by_left = x < 1.0 && (4.0..=6.0).contains(&y);
        assert!(
            if assigned_right { by_right } else { by_left },
            "person {i} (assigned exit {}) left at ({x}, {y})",
            if assigned_right { 2 } else { 1 }
        );
    }
    eprintln!(
        "RiMEA 10: all {n} people left by their assigned exits, the last at {:.2} s",
        summary.evacuation_time.unwrap_or(f64::NAN)
    );
}

/// Test 12: 150 people leave through a corridor 1 m wide into a second room with an exit
/// 1 m wide: the corridor meters the flow, and there is no jam at the last exit. The
/// criterion of the community's automated suite: the flow 1 m before the last exit exceeds
/// the flow out of the corridor by at most 0.05 people per second. And, as a direct test of
/// "no jam", everybody crosses the second room (10 m) in at most 1.5 times the time it takes
/// at the free walking speed.
#[test]
fn rimea_12_no_jam_at_the_last_exit() {
    let built = scene("test-12-bottleneck.toml");
    let n = built.population.len();
    assert_eq!(n, 150);
    let (summary, recorder) = run(&built, true);
    assert_eq!(summary.people_remaining, 0, "{summary:?}");
    let out_of_corridor = flow_through(&recorder, n, 15.0);
    let before_exit = flow_through(&recorder, n, 24.0);
    let slowest = (0..n)
        .filter_map(|i| Some(recorder.crossing_x(i, 24.0)? - recorder.crossing_x(i, 15.0)?))
        .fold(0.0, f64::max);
    eprintln!(
        "RiMEA 12: flow out of the corridor {out_of_corridor:.2} /s, before the last exit \
         {before_exit:.2} /s; slowest crossing of the second room {slowest:.2} s (free: {:.2} s)",
        9.0 / 1.33
    );
    assert!(
        out_of_corridor - before_exit >= -0.05,
        "flow out of the corridor {out_of_corridor} /s, before the last exit {before_exit} /s"
    );
    let free = 9.0 / 1.33;
    for i in 0..n {
        let crossing =
            recorder.crossing_x(i, 24.0).unwrap() - recorder.crossing_x(i, 15.0).unwrap();
        assert!(
            crossing <= 1.5 * free,
            "person {i} took {crossing} s from the corridor to the exit"
        );
    }
}

/// Test 9: 1000 people leave a room of 30 m × 20 m by four exits 1 m wide, then, from the
/// same start, by the two exits of the lower wall only: the evacuation takes about twice as
/// long. The criterion of the community's automated suite: the time with two exits is within
/// 50 % of twice the time with four.
#[test]
#[ignore = "2 × 1000 people for minutes of simulated time, and it fails (the doors clog): run by scripts/rimea"]
fn rimea_9_closing_half_the_exits_doubles_the_evacuation_time() {
    let four = run(&scene("test-09-four-exits.toml"), false).0;
    let two = run(&scene("test-09-two-exits.toml"), false).0;
    let t4 = four.evacuation_time.unwrap_or_else(|| {
        panic!(
            "four exits: {} people still in the room at t = {} s",
            four.people_remaining, four.t_final
        )
    });
    let t2 = two.evacuation_time.unwrap_or_else(|| {
        panic!(
            "four exits: out after {t4} s; two exits: {} people still in the room at t = {} s \
             (the doors clogged)",
            two.people_remaining, two.t_final
        )
    });
    eprintln!(
        "RiMEA 9: four exits {t4} s, two exits {t2} s, ratio {}",
        t2 / t4
    );
    let error = (t2 - 2.0 * t4).abs() / (2.0 * t4);
    assert!(error <= 0.5, "four exits {t4} s, two {t2} s");
}
