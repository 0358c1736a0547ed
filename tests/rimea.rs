//! The RiMEA verification tests (RiMEA guideline, Annex 1) that a model of people in one plane
//! can run, on the scenes shipped in `examples/scenes/rimea/`, each with the suite's own pass
//! criterion checked on the trajectory, and every run's trajectory read again by the
//! independent checker (`sweeping_testkit::checker`). Tests 1, 5, 6, 7, 8 (one storey), 10 and
//! 12, and short runs of tests 4 and 16, run in the default test run; test 9 (2 × 1000 people)
//! and the full measurements of tests 4 and 16 are ignored here and run by `scripts/rimea`. The
//! guide's page "The RiMEA tests" says which tests pass, which fail, which cannot be written
//! yet, and why.

use std::path::PathBuf;
use sweeping::backends::make_projector;
use sweeping::crowd::Population;
use sweeping::output::{RunSummary, SummaryCollector, TrajectoryWriter};
use sweeping::scene::{BuiltScene, Overrides, Scene};
use sweeping::stepper::{Observer, ObserverError, StepReport};
use sweeping_testkit::checker::{check_trajectory, scratch};

mod common;
use common::scene_geometry::checker_geometry;

/// Overlap and penetration the independent checker lets through (the projection's tolerance).
const CHECKER_TOL: f64 = 1e-6;

/// Most rows of the trajectory written for the checker: a longer run is written every few
/// steps, so that the file stays small.
const CHECKED_ROWS: usize = 2_000_000;

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
    scene_with(file, &Overrides::default())
}

fn scene_with(file: &str, overrides: &Overrides) -> BuiltScene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("examples/scenes/rimea")
        .join(file);
    Scene::from_file(&path)
        .and_then(|s| s.build(overrides))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Runs `built` with its own backend; the summary, and every step when `record`. The run also
/// writes its trajectory, which the independent checker reads again: nobody overlaps, crosses
/// a wall or comes back after leaving.
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
    let steps = (built.settings.t_end / built.settings.h).ceil() as usize + 1;
    let rows = steps * built.population.len();
    let stride = rows.div_ceil(CHECKED_ROWS).max(1);
    let csv = scratch(&format!("rimea-{}", built.name)).join("trajectory.csv");
    let mut writer = TrajectoryWriter::new(&csv, built.population.clone(), stride);
    let result = if record {
        built.run(
            projector.as_mut(),
            &mut [&mut summary, &mut writer, &mut recorder],
        )
    } else {
        built.run(projector.as_mut(), &mut [&mut summary, &mut writer])
    };
    result.unwrap_or_else(|e| panic!("{}: {e}", built.name));
    let summary = summary.summary().clone();
    // No overlap and no wall crossed, whatever the test measures.
    assert!(summary.max_overlap <= 1e-9, "{summary:?}");
    assert!(summary.max_wall_penetration <= 1e-9, "{summary:?}");
    let findings = check_trajectory(&csv, &checker_geometry(built), CHECKER_TOL);
    assert!(
        findings.problems.is_empty(),
        "{}: the independent checker found {:#?}",
        built.name,
        findings.problems
    );
    assert!(findings.times >= 2, "{}: {findings:?}", built.name);
    let _ = std::fs::remove_dir_all(csv.parent().expect("the scratch directory"));
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

/// What a measuring area saw between two times: people per square metre (or per metre, for a
/// one-dimensional window), their mean speed along the corridor, and the mean desired speed
/// of the people whose speeds were sampled.
#[derive(Debug, Clone, Copy)]
struct Measured {
    density: f64,
    speed: f64,
    desired: f64,
}

impl Measured {
    fn flow(&self) -> f64 {
        self.density * self.speed
    }
}

/// Measures in the area `x0 ≤ x ≤ x1` across the corridor (its area `area`) from `t0` to `t1`,
/// as the community's suite does: at each step, who is inside, and each one's speed along `x`
/// over the step.
fn measure(
    recorder: &Recorder,
    speeds: &[f64],
    (x0, x1): (f64, f64),
    area: f64,
    (t0, t1): (f64, f64),
) -> Measured {
    let (mut count, mut steps, mut speed, mut desired) = (0usize, 0usize, 0.0, 0.0);
    for w in recorder.frames.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        if a.t < t0 - 1e-9 || a.t >= t1 - 1e-9 {
            continue;
        }
        steps += 1;
        for (i, &v0) in speeds.iter().enumerate() {
            let x = a.q[2 * i];
            if a.present[i] && b.present[i] && (x0..=x1).contains(&x) {
                count += 1;
                speed += (b.q[2 * i] - x) / (b.t - a.t);
                desired += v0;
            }
        }
    }
    assert!(
        steps > 0 && count > 0,
        "nobody in [{x0}, {x1}] between {t0} and {t1} s"
    );
    Measured {
        density: count as f64 / steps as f64 / area,
        speed: speed / count as f64,
        desired: desired / count as f64,
    }
}

/// The model has no relation between density and speed: a group pushed together moves at the
/// mean of its desired velocities, so every measuring area sees the mean desired speed of the
/// people crossing it, whatever the density. The guide's page says why this fails tests 4
/// and 16; this pins that explanation to the runs.
fn assert_speed_is_the_desired_speed(name: &str, m: &Measured) {
    assert!(
        (m.speed - m.desired).abs() <= 0.02,
        "{name}: measured {} m/s, desired {} m/s",
        m.speed,
        m.desired
    );
}

/// The corridors of test 4 and their densities (people per square metre).
const CORRIDORS: [(&str, f64); 5] = [
    ("test-04-corridor-050.toml", 0.5),
    ("test-04-corridor-100.toml", 1.0),
    ("test-04-corridor-200.toml", 2.0),
    ("test-04-corridor-300.toml", 3.0),
    ("test-04-corridor-400.toml", 4.0),
];

/// Test 4's measuring points: the main one, then the two controls (x ranges; each spans the
/// corridor's width of 2 m, so 4 m²).
const MEASURING_POINTS: [(f64, f64); 3] = [(105.0, 107.0), (100.0, 102.0), (110.0, 112.0)];

/// One density of test 4: what the main and the two control points measured.
struct CorridorPoint {
    nominal: f64,
    points: [Measured; 3],
}

/// Runs test 4's corridors to `t_end` and measures from `t0` on.
fn fundamental_diagram_2d(t_end: f64, t0: f64) -> Vec<CorridorPoint> {
    let overrides = Overrides {
        t_end: Some(t_end),
        ..Overrides::default()
    };
    CORRIDORS
        .iter()
        .map(|&(file, nominal)| {
            let built = scene_with(file, &overrides);
            let (_, recorder) = run(&built, true);
            let points =
                MEASURING_POINTS.map(|x| measure(&recorder, &built.speeds, x, 4.0, (t0, t_end)));
            let [main, c1, c2] = points;
            eprintln!(
                "RiMEA 4: {nominal} /m²: main {:.2} /m², {:.3} m/s, flow {:.2} /(m s); \
                 controls {:.3} and {:.3} m/s",
                main.density,
                main.speed,
                main.flow(),
                c1.speed,
                c2.speed
            );
            CorridorPoint { nominal, points }
        })
        .collect()
}

/// Test 4, a short measurement (5 to 15 s): the corridors hold the densities the test asks
/// for at the main measuring point, the control points agree with it, and the speed is the
/// desired speed at every density.
#[test]
fn rimea_4_the_fundamental_diagram_is_measured_in_a_corridor() {
    let (t0, t1) = (5.0, 15.0);
    for p in fundamental_diagram_2d(t1, t0) {
        let [main, c1, c2] = p.points;
        let name = format!("{} /m²", p.nominal);
        // People are placed at random: the count over the strip of crowd that passes the point
        // is Poisson-like, so the measured density may miss by a few of its standard deviations.
        let passing = 2.0 * (2.0 + main.speed * (t1 - t0));
        let tolerance = 3.0 * (p.nominal / passing).sqrt();
        assert!(
            (main.density - p.nominal).abs() <= tolerance,
            "{name}: the main point measured {} /m² (tolerance {tolerance})",
            main.density
        );
        for c in [c1, c2] {
            assert!(
                (c.speed - main.speed).abs() <= 0.05,
                "{name}: control {} m/s, main {} m/s",
                c.speed,
                main.speed
            );
        }
        for m in &p.points {
            assert_speed_is_the_desired_speed(&name, m);
        }
    }
}

/// Test 4 as the guideline states it: the mean speed at each measuring point over 60 s after a
/// transient of 10 s, at densities of 0.5 to 4 people per square metre. The criterion the
/// test exists for is the shape of the fundamental diagram: the speed falls as the density
/// grows, to well under half the free speed at 4 /m² (Weidmann's curve gives 0.16 m/s there).
#[test]
#[ignore = "5 corridors for 70 s each, and it fails (the speed does not fall with density): run by scripts/rimea"]
fn rimea_4_the_speed_falls_with_density() {
    let diagram = fundamental_diagram_2d(70.0, 10.0);
    for p in &diagram {
        for m in &p.points {
            assert_speed_is_the_desired_speed(&format!("{} /m²", p.nominal), m);
        }
    }
    let main: Vec<f64> = diagram.iter().map(|p| p.points[0].speed).collect();
    for (pair, w) in diagram.windows(2).zip(main.windows(2)) {
        assert!(
            w[1] < w[0],
            "the speed at {} /m² ({} m/s) is not below that at {} /m² ({} m/s)",
            pair[1].nominal,
            w[1],
            pair[0].nominal,
            w[0]
        );
    }
    let (free, dense) = (main[0], main[main.len() - 1]);
    assert!(
        dense < 0.5 * free,
        "{dense} m/s at 4 /m², {free} m/s at 0.5 /m²"
    );
}

/// The single-file corridors of test 16 and the density each was filled at (people per
/// metre).
const SINGLE_FILE: [(&str, f64); 4] = [
    ("test-16-single-file-040.toml", 0.4),
    ("test-16-single-file-075.toml", 0.75),
    ("test-16-single-file-125.toml", 1.25),
    ("test-16-single-file-175.toml", 1.75),
];

/// Test 16's reference: the 10th and 90th percentiles of the measured speeds per density bin
/// of 0.5 /m, `(from, to, samples, p10, p90)`, of the single-file experiment of Seyfried et al.
/// (2005) as the JuPedSim project's SingleFileComparator collects it, computed as its
/// `percentiles` does (linear interpolation, every bin with at least 5 samples).
const ENVELOPE: [(f64, f64, usize, f64, f64); 4] = [
    (0.0, 0.5, 6, 1.108, 1.170),
    (0.5, 1.0, 64, 0.703, 1.136),
    (1.0, 1.5, 31, 0.287, 0.388),
    (1.5, 2.0, 24, 0.140, 0.232),
];

/// The envelope's bin holding `density`, if any.
fn envelope_bin(density: f64) -> Option<(f64, f64, usize, f64, f64)> {
    ENVELOPE
        .iter()
        .copied()
        .find(|&(from, to, ..)| (from..to).contains(&density))
}

/// Runs test 16's corridors to `t_end` and measures in the window x = 120 to 130 m from `t0`
/// on; `(nominal density, measured)`.
fn fundamental_diagram_1d(t_end: f64, t0: f64) -> Vec<(f64, Measured)> {
    let overrides = Overrides {
        t_end: Some(t_end),
        ..Overrides::default()
    };
    SINGLE_FILE
        .iter()
        .map(|&(file, nominal)| {
            let built = scene_with(file, &overrides);
            let (_, recorder) = run(&built, true);
            let m = measure(&recorder, &built.speeds, (120.0, 130.0), 10.0, (t0, t_end));
            let reference = envelope_bin(m.density)
                .map(|(_, _, _, p10, p90)| format!("{p10:.3} to {p90:.3} m/s"))
                .unwrap_or_else(|| "no reference".into());
            eprintln!(
                "RiMEA 16: {nominal} /m: measured {:.3} /m, {:.3} m/s (experiment: {reference})",
                m.density, m.speed
            );
            (nominal, m)
        })
        .collect()
}

/// Test 16, a short measurement (5 to 25 s): each corridor holds a density in the bin of the
/// reference it was filled for, and the speed is the desired speed at every density.
#[test]
fn rimea_16_the_single_file_fundamental_diagram_is_measured() {
    for (nominal, m) in fundamental_diagram_1d(25.0, 5.0) {
        let name = format!("{nominal} /m");
        assert_eq!(
            envelope_bin(m.density).map(|b| b.0),
            envelope_bin(nominal).map(|b| b.0),
            "{name}: measured {} /m",
            m.density
        );
        assert_speed_is_the_desired_speed(&name, &m);
    }
}

/// Test 16 as RiMEA 4.x states it: the simulated one-dimensional fundamental diagram lies in
/// the 10 %–90 % percentile envelope of the experiments' speeds, measured here over 60 s
/// after a transient of 10 s.
#[test]
#[ignore = "4 corridors for 70 s each, and it fails (the speed does not fall with density): run by scripts/rimea"]
fn rimea_16_the_single_file_speeds_lie_in_the_experiments_envelope() {
    let outside: Vec<String> = fundamental_diagram_1d(70.0, 10.0)
        .iter()
        .filter_map(|(nominal, m)| {
            let (from, to, _, p10, p90) = envelope_bin(m.density)?;
            (!(p10..=p90).contains(&m.speed)).then(|| {
                format!(
                    "{nominal} /m: {:.3} m/s at {:.3} /m, the experiment's [{from}, {to}) /m \
                     bin spans {p10} to {p90} m/s",
                    m.speed, m.density
                )
            })
        })
        .collect();
    assert!(outside.is_empty(), "outside the envelope: {outside:#?}");
}

/// The storey of test 8 with everybody's `speed = 1.0` replaced by `speed`.
fn storey_with_speed(speed: &str) -> BuiltScene {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/scenes/rimea/test-08-storey.toml");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(
        text.matches("speed = 1.0\n").count(),
        32,
        "one speed per room"
    );
    let text = text.replace("speed = 1.0\n", &format!("speed = {speed}\n"));
    Scene::from_toml_str(&text, "test-08-storey.toml")
        .and_then(|s| s.build(&Overrides::default()))
        .unwrap_or_else(|e| panic!("speed = {speed}: {e}"))
}

/// The evacuation time of the storey of test 8 with the speed `speed` (a number or a
/// distribution, as the scene format writes it).
fn storey_evacuation_time(speed: &str) -> f64 {
    let (summary, _) = run(&storey_with_speed(speed), false);
    summary.evacuation_time.unwrap_or_else(|| {
        panic!(
            "speed = {speed}: {} people still in the storey at t = {} s",
            summary.people_remaining, summary.t_final
        )
    })
}

/// Test 8 on one storey: the evacuation time against the people's speed, once the same for
/// everybody (0.5 to 1.5 m/s), once spread evenly around a mean of 0.75 m/s, as the guideline
/// asks. The guideline sets no pass criterion (the community's suite only documents the
/// times); what is checked is the trend the study exists to show: everybody leaves, and the
/// faster everybody walks, the sooner the storey is empty.
#[test]
fn rimea_8_the_evacuation_time_falls_as_the_speed_grows() {
    let speeds = [0.5, 0.75, 1.0, 1.25, 1.5];
    let times: Vec<f64> = speeds
        .iter()
        .map(|v| storey_evacuation_time(&format!("{v:.2}")))
        .collect();
    for (v, t) in speeds.iter().zip(&times) {
        eprintln!("RiMEA 8: everybody at {v} m/s: the storey is empty after {t:.2} s");
    }
    for (v, w) in speeds.windows(2).zip(times.windows(2)) {
        assert!(
            w[1] < w[0],
            "{} s at {} m/s, {} s at {} m/s",
            w[1],
            v[1],
            w[0],
            v[0]
        );
    }
    for (lo, hi) in [(0.5, 1.0), (0.25, 1.25)] {
        let t = storey_evacuation_time(&format!("{{ uniform = [{lo}, {hi}] }}"));
        eprintln!(
            "RiMEA 8: speeds uniform in [{lo}, {hi}] m/s: the storey is empty after {t:.2} s"
        );
    }
}
