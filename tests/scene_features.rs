//! The scene features of groups in motion — sources (people arriving during a run), journeys
//! (chains of waypoints), radius distributions and gaps, geometry from WKT — each on the
//! shipped scene that uses it, run to its end with every step written and the trajectory
//! checked by the independent checker (`tests/common/checker.rs`), plus what each feature
//! promises and the checker cannot see.

use std::collections::BTreeMap;
use std::path::PathBuf;
use sweeping::backends::make_projector;
use sweeping::output::{Departure, PeopleWriter, RunSummary, SummaryCollector, TrajectoryWriter};
use sweeping::scene::{BuiltScene, Overrides, Scene};
use sweeping_testkit::checker::{check_trajectory, scratch, Findings};

mod common;
use common::scene_geometry::checker_geometry;

/// Overlap and penetration the checker lets through (the projection's tolerance).
const TOL: f64 = 1e-6;

fn shipped(file: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("examples/scenes")
        .join(file)
}

fn build(file: &str) -> BuiltScene {
    Scene::from_file(shipped(file))
        .and_then(|s| s.build(&Overrides::default()))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The people of one written state: id → position.
type Frame = BTreeMap<usize, (f64, f64)>;

/// A run of a shipped scene to its end, every step written.
struct Checked {
    built: BuiltScene,
    summary: RunSummary,
    findings: Findings,
    /// Per person: `(t, x, y, present)` at every step; the trajectory writes who is present
    /// only, so `x, y` of who is absent are NaN.
    rows: BTreeMap<usize, Vec<(f64, f64, f64, bool)>>,
    /// Per person, when and where they left (the people table).
    departures: Vec<Option<Departure>>,
}

fn run_checked(file: &str) -> Checked {
    let built = build(file);
    let dir = scratch(&format!("features-{file}"));
    let csv = dir.join("trajectory.csv");
    let mut writer = TrajectoryWriter::new(&csv, built.population.clone(), 1);
    let mut people = PeopleWriter::new(dir.join("people.csv"), built.population.clone());
    let mut summary = SummaryCollector::new(
        &built.name,
        &built.problem,
        built.population.clone(),
        "native",
        built.settings.h,
        built.settings.t_end,
    );
    let mut projector = make_projector(built.backend).unwrap();
    built
        .run(
            projector.as_mut(),
            &mut [&mut writer, &mut summary, &mut people],
        )
        .unwrap_or_else(|f| panic!("{file}: {f}"));
    let findings = check_trajectory(&csv, &checker_geometry(&built), TOL);
    assert!(
        findings.problems.is_empty(),
        "{file}: {:#?}",
        findings.problems
    );
    let mut frames: Vec<(f64, Frame)> = Vec::new();
    for line in std::fs::read_to_string(&csv).unwrap().lines().skip(1) {
        let c: Vec<&str> = line.split(',').collect();
        let t: f64 = c[0].parse().unwrap();
        if frames.last().is_none_or(|f| f.0 != t) {
            frames.push((t, BTreeMap::new()));
        }
        let id: usize = c[1].parse().unwrap();
        let p = (c[2].parse().unwrap(), c[3].parse().unwrap());
        frames.last_mut().unwrap().1.insert(id, p);
    }
    let mut rows: BTreeMap<usize, Vec<(f64, f64, f64, bool)>> = BTreeMap::new();
    for i in 0..built.population.len() {
        let row = frames.iter().map(|(t, f)| match f.get(&i) {
            Some(&(x, y)) => (*t, x, y, true),
            None => (*t, f64::NAN, f64::NAN, false),
        });
        rows.insert(i, row.collect());
    }
    let departures = people.departures().to_vec();
    Checked {
        summary: summary.summary().clone(),
        built,
        findings,
        rows,
        departures,
    }
}

#[test]
fn arrivals_come_in_when_due_at_their_place_and_wait_when_it_is_taken() {
    let run = run_checked("arrivals.toml");
    let (built, s) = (&run.built, &run.summary);
    let n = built.population.len();
    let arrivals = s
        .arrivals
        .expect("a scene with sources reports its arrivals");
    assert_eq!(
        (arrivals.scheduled, arrivals.arrived),
        (n, n),
        "{arrivals:?}"
    );
    assert_eq!(arrivals.still_waiting, 0);
    // The door's two places are taken again before they empty: people wait.
    assert!(
        arrivals.waited > 0 && arrivals.longest_wait > 0.0,
        "{arrivals:?}"
    );
    assert!(s.evacuation_time.is_some(), "everybody left: {s:?}");
    let q0 = built.problem.q0();
    let h = built.settings.h;
    let mut late = 0;
    for i in 0..n {
        let due = built
            .population
            .due(i)
            .expect("everybody comes from a source");
        let rows = &run.rows[&i];
        let first = rows.iter().position(|r| r.3).expect("everybody arrives");
        let (t, x, y, _) = rows[first];
        // Never before they are due, and at the place they were given, not moved while away.
        assert!(t >= due - 1e-9, "person {i} arrived at {t}, due at {due}");
        assert!(
            rows[..first].iter().all(|r| !r.3),
            "person {i} written before arriving: {:?}",
            &rows[..first]
        );
        assert_eq!((x, y), (q0[2 * i], q0[2 * i + 1]));
        if t > due + h + 1e-9 {
            late += 1;
        }
    }
    // Who came in later than the first step after they were due is who waited.
    assert_eq!(late, arrivals.waited);
    assert!(run.findings.max_overlap <= TOL);
}

#[test]
fn arrivals_are_the_same_from_the_same_seed_and_move_with_another() {
    let a = build("arrivals.toml");
    let b = build("arrivals.toml");
    assert_eq!(a.problem.q0(), b.problem.q0());
    assert_eq!(a.population.radii(), b.population.radii());
    let c = Scene::from_file(shipped("arrivals.toml"))
        .and_then(|s| {
            s.build(&Overrides {
                seed: Some(40),
                ..Default::default()
            })
        })
        .unwrap();
    assert_ne!(a.problem.q0(), c.problem.q0());
}

#[test]
fn a_run_with_arrivals_resumes_with_who_has_not_arrived_yet_still_to_come() {
    use sweeping::scene::ResumeState;
    let scene = Scene::from_file(shipped("arrivals.toml")).unwrap();
    let first = scene
        .build(&Overrides {
            t_end: Some(2.0),
            ..Default::default()
        })
        .unwrap();
    let mut projector = make_projector(first.backend).unwrap();
    let run = first.run(projector.as_mut(), &mut []).unwrap();
    let pop = &first.population;
    let n = pop.len();
    let present: Vec<bool> = (0..n).map(|i| pop.is_present(&run.q_final, i)).collect();
    let waiting = pop.pending_count();
    assert!(
        waiting > 0 && present.iter().any(|&p| p),
        "{waiting} still to come"
    );
    let mut rest = scene.build(&Overrides::default()).unwrap();
    rest.resume_at(ResumeState {
        t: run.t_final,
        q: run.q_final.clone(),
        // As a trajectory says it: who is not present is written gone.
        departed: present.iter().map(|p| !p).collect(),
    })
    .unwrap();
    let mut summary = SummaryCollector::new(
        &rest.name,
        &rest.problem,
        rest.population.clone(),
        "native",
        rest.settings.h,
        rest.settings.t_end,
    );
    rest.run(projector.as_mut(), &mut [&mut summary]).unwrap();
    let s = summary.summary();
    // Who was in stays in, who was to come comes, and everybody leaves.
    assert!(s.evacuation_time.is_some(), "{s:?}");
    let arrivals = s.arrivals.unwrap();
    assert_eq!(arrivals.arrived, n, "{arrivals:?}");
    assert_eq!(s.people_out.last().unwrap().1, n);
}

#[test]
fn a_group_with_a_gap_keeps_it_and_drawn_radii_stay_in_their_window() {
    let run = run_checked("distancing.toml");
    let built = &run.built;
    assert!(run.summary.evacuation_time.is_some(), "{:?}", run.summary);
    let gap = 0.4;
    let keeps = |i: usize| built.group_of[i] == 0;
    let body = |i: usize| built.population.radius(i) - if keeps(i) { gap / 2.0 } else { 0.0 };
    let n = built.population.len();
    for i in 0..n {
        let window = if keeps(i) { (0.15, 0.26) } else { (0.17, 0.23) };
        assert!(
            (window.0..=window.1).contains(&body(i)),
            "person {i}: radius {}",
            body(i)
        );
    }
    // The least distance between the bodies of two people of the group, over every step,
    // from the trajectory: at least the gap, and reached (the gap is what holds them apart).
    let frames = run.rows[&0].len();
    let mut least = f64::INFINITY;
    for f in 0..frames {
        let at = |i: usize| run.rows[&i][f];
        for i in (0..n).filter(|&i| keeps(i) && at(i).3) {
            for j in (i + 1..n).filter(|&j| keeps(j) && at(j).3) {
                let d = (at(i).1 - at(j).1).hypot(at(i).2 - at(j).2) - body(i) - body(j);
                least = least.min(d);
            }
        }
    }
    assert!(
        least >= gap - TOL && least < gap + 0.01,
        "least gap {least}"
    );
}

#[test]
fn a_radius_distribution_moves_nobody_and_a_gap_grows_the_disks() {
    let scene = |radius: &str, gap: &str| {
        let text = format!(
            "[room]\nrectangle = [0.0, 0.0, 6.0, 6.0]\n[[crowds]]\ncount = 20\nradius = {radius}\nseed = 9\n{gap}"
        );
        Scene::from_toml_str(&text, "inline")
            .and_then(|s| s.build(&Overrides::default()))
            .unwrap()
    };
    let fixed = scene("0.2", "");
    // Drawn from a stream of its own: the placement draws the same positions.
    let drawn = scene("{ uniform = [0.2, 0.2] }", "");
    assert_eq!(fixed.problem.q0(), drawn.problem.q0());
    let varied = scene("{ normal = [0.2, 0.02], within = [0.15, 0.25] }", "");
    let radii = varied.population.radii();
    assert!(radii.iter().all(|r| (0.15..=0.25).contains(r)));
    assert!(radii.windows(2).any(|w| w[0] != w[1]));
    let grown = scene("0.2", "gap = 0.3\n");
    assert!(grown.population.radii().iter().all(|&r| r == 0.2 + 0.15));
    assert!(grown.effects.iter().any(|e| e
        .to_string()
        .starts_with("gaps: 20 people keep a least distance (up to 0.3)")));
}

#[test]
fn each_group_passes_its_waypoint_before_leaving_by_its_own_exit() {
    let run = run_checked("journeys.toml");
    let built = &run.built;
    assert!(run.summary.evacuation_time.is_some(), "{:?}", run.summary);
    let inside = |r: [f64; 4], x: f64, y: f64| r[0] <= x && x <= r[2] && r[1] <= y && y <= r[3];
    for i in 0..built.population.len() {
        let rows = &run.rows[&i];
        let left = run.departures[i].expect("everybody leaves");
        let [x, y] = left.position;
        let reached = rows
            .iter()
            .take_while(|r| r.0 < left.t)
            .position(|&(_, x, y, _)| {
                if built.group_of[i] == 0 {
                    inside([9.0, 6.0, 11.0, 7.5], x, y)
                } else {
                    (x - 7.0).hypot(y - 6.5) <= 0.6
                }
            });
        assert!(
            reached.is_some(),
            "person {i} left without passing their waypoint"
        );
        if built.group_of[i] == 0 {
            // Out through the top door (exit 2), left of the partition.
            assert!(y > 8.0 && x < 6.0, "person {i} left at ({x}, {y})");
        } else {
            assert!(x > 12.0 && y < 4.0, "person {i} left at ({x}, {y})");
        }
    }
    // Each journey's record has its 12 people past its one waypoint.
    assert_eq!(built.journeys.len(), 2);
    for (g, progress) in built.journeys.iter().enumerate() {
        let past: Vec<usize> = (0..built.population.len())
            .filter(|&i| progress.stage(i) == 1)
            .collect();
        assert_eq!(past.len(), 12);
        assert!(past.iter().all(|&i| built.group_of[i] == g));
    }
}

#[test]
fn a_scene_with_journeys_is_not_resumed_since_the_stages_are_not_in_a_state() {
    let mut built = build("journeys.toml");
    let state = sweeping::scene::ResumeState {
        t: 1.0,
        q: built.problem.q0().to_vec(),
        departed: vec![false; built.population.len()],
    };
    let e = built.resume_at(state).unwrap_err();
    assert!(e.to_string().contains("cannot be resumed"), "{e}");
}

#[test]
fn a_hall_read_from_wkt_is_the_hall_written_out_and_runs_cleanly() {
    let from_wkt = build("wkt-hall.toml");
    // The same hall with every coordinate written in TOML.
    let written = Scene::from_toml_str(
        r#"
        name = "wkt-hall"
        [room]
        polygon = [[0, 0], [12, 0], [12, 6], [6, 6], [6, 10], [0, 10]]
        [[exits]]
        from = [12.0, 1.5]
        to = [12.0, 3.0]
        [[exits]]
        from = [1.5, 10.0]
        to = [3.0, 10.0]
        [[obstacles]]
        polygon = [[2.5, 3.0], [4.0, 3.0], [4.0, 4.5], [2.5, 4.5]]
        [[obstacles]]
        polygon = [[8.0, 2.0], [9.0, 2.0], [9.0, 3.5], [8.0, 3.5]]
        [[crowds]]
        count = 60
        region = [0.5, 0.5, 5.5, 9.5]
        radius = [0.18, 0.23]
        seed = 6
        [desired]
        kind = "exit"
        [run]
        h = 0.02
        t_end = 60.0
        stop_when_empty = true
        "#,
        "written",
    )
    .and_then(|s| s.build(&Overrides::default()))
    .unwrap();
    assert_eq!(from_wkt.geometry, written.geometry);
    assert_eq!(from_wkt.problem.q0(), written.problem.q0());
    let run = run_checked("wkt-hall.toml");
    assert!(run.summary.evacuation_time.is_some(), "{:?}", run.summary);
    // Nobody went through the hole (the checker sees its edges as walls).
    assert!(run.findings.max_penetration <= TOL);
}

#[test]
fn wkt_as_shapely_writes_it_multipolygons_of_one_and_the_builder() {
    use sweeping::scene::spec::{CrowdSpec, DesiredSpec, RadiusSpec};
    use sweeping::scene::CrowdBuilder;
    // A MULTIPOLYGON of one polygon, exits as one LINESTRING, in code.
    let built = CrowdBuilder::new("multi")
        .wkt(
            "MULTIPOLYGON (((0 0, 6 0, 6 4, 0 4, 0 0)))",
            Some("LINESTRING (6 1.5, 6 2.5)".into()),
        )
        .crowd(CrowdSpec::new(5, RadiusSpec::Fixed(0.2)).seed(1))
        .desired(DesiredSpec::exit())
        .build()
        .unwrap();
    assert_eq!(built.geometry.room.len(), 4);
    assert_eq!(built.geometry.exits.len(), 1);
    assert_eq!(built.geometry.exits[0].a, [6.0, 1.5]);
}

#[test]
fn the_bottleneck_study_scene_runs_cleanly_with_its_inflow() {
    let run = run_checked("bottleneck/bottleneck.toml");
    let s = &run.summary;
    let arrivals = s.arrivals.unwrap();
    assert_eq!(arrivals.arrived, run.built.population.len());
    assert!(s.evacuation_time.is_some(), "{s:?}");
    // The door is exit 1, 1.2 m wide, in the middle of the right wall.
    let door = &run.built.geometry.exits[0];
    assert_eq!((door.a, door.b), ([10.0, 3.4], [10.0, 4.6]));
}
