//! Batch plans: expansion, errors with their lines, a run into one table checked against the
//! trials' own summaries and trajectories, failures kept, and resuming after a kill.

use std::path::{Path, PathBuf};
use sweeping::batch::{
    middle_flow, run_batch, run_trial, trial_state, BatchError, BatchSettings, Plan, ResultsTable,
    Trial, TrialRecord, TrialState, OUTPUTS, RECORD_FILE,
};
use sweeping::output::{RunStatus, RunSummary};
use sweeping_testkit::checker::{check_trajectory, left_from_people, scratch, Geometry};

const ROOM: &str = r#"name = "room"
[room]
rectangle = [0.0, 0.0, 4.0, 4.0]
[[exits]]
from = [4.0, 1.5]
to = [4.0, 2.5]
[[crowds]]
count = 4
region = [0.0, 0.0, 2.0, 4.0]
radius = 0.2
[desired]
kind = "exit"
[run]
h = 0.05
t_end = 10.0
stop_when_empty = true
[output]
snapshot_every = 100.0
animation_frames = 10
"#;

/// A folder holding `room.toml` and `plan.toml` (the text given); the plan's path.
fn plan_dir(name: &str, plan: &str) -> PathBuf {
    let dir = scratch(&format!("batch-{name}"));
    std::fs::write(dir.join("room.toml"), ROOM).unwrap();
    std::fs::write(dir.join("plan.toml"), plan).unwrap();
    dir.join("plan.toml")
}

fn plan_error(name: &str, plan: &str) -> BatchError {
    let path = plan_dir(name, plan);
    match Plan::from_file(&path).and_then(|p| p.check_scenes().map(|()| p)) {
        Ok(_) => panic!("the plan was accepted:\n{plan}"),
        Err(e) => e,
    }
}

#[test]
fn a_plan_expands_scenes_times_trials_times_grid_times_seeds_in_order() {
    let path = plan_dir(
        "expand",
        r#"
scenes = ["room.toml"]
seeds = [7, 8]
[grid]
crowds.0.count = [2, 3]
"crowds.0.radius" = [0.2, 0.25, 0.3]
[[trials]]
set = { "run.h" = 0.05 }
tags = { label = "fine" }
[[trials]]
set = { "run.h" = 0.1 }
tags = { label = "coarse" }
"#,
    );
    let plan = Plan::from_file(&path).unwrap();
    plan.check_scenes().unwrap();
    assert_eq!(plan.name, "plan");
    assert_eq!(
        plan.parameters(),
        ["crowds.0.count", "crowds.0.radius", "run.h", "label"]
    );
    let trials = plan.trials();
    assert_eq!(trials.len(), 2 * 2 * 3 * 2);
    assert_eq!(plan.trial_count(), trials.len());
    // Seeds vary fastest, then the grid's last key, then its first, then the trials.
    let t = |i: usize| {
        let tr = &trials[i];
        (
            tr.parameter("run.h").unwrap(),
            tr.parameter("crowds.0.count").unwrap(),
            tr.parameter("crowds.0.radius").unwrap(),
            tr.seed.unwrap(),
            tr.parameter("label").unwrap(),
        )
    };
    let s = |a: &str, b: &str, c: &str, d: u64, e: &str| {
        (
            a.to_string(),
            b.to_string(),
            c.to_string(),
            d,
            e.to_string(),
        )
    };
    assert_eq!(t(0), s("0.05", "2", "0.2", 7, "fine"));
    assert_eq!(t(1), s("0.05", "2", "0.2", 8, "fine"));
    assert_eq!(t(2), s("0.05", "2", "0.25", 7, "fine"));
    assert_eq!(t(6), s("0.05", "3", "0.2", 7, "fine"));
    assert_eq!(t(12), s("0.1", "2", "0.2", 7, "coarse"));
    assert_eq!(t(23), s("0.1", "3", "0.3", 8, "coarse"));
    for (i, tr) in trials.iter().enumerate() {
        assert_eq!(tr.index, i);
        assert_eq!(tr.dir_name(), format!("trial-{i:04}"));
        // The trial's overrides first, then the grid's; tags are not overrides.
        let keys: Vec<&str> = tr.sets.iter().map(|s| s.key.as_str()).collect();
        assert_eq!(keys, ["run.h", "crowds.0.count", "crowds.0.radius"]);
    }
    assert_eq!(plan.trial(23).unwrap(), trials[23]);
    assert!(matches!(
        plan.trial(24),
        Err(BatchError::NoSuchTrial {
            trial: 24,
            count: 24
        })
    ));
    // Without grid, trials or seeds: one trial, the scene as written.
    let plan = Plan::from_toml_str("scenes = [\"room.toml\"]", &path).unwrap();
    let trials = plan.trials();
    assert_eq!(trials.len(), 1);
    assert!(trials[0].sets.is_empty() && trials[0].seed.is_none());
}

#[test]
fn plan_errors_name_the_line_and_the_item() {
    let cases: &[(&str, usize, &[&str])] = &[
        (
            "scenes = [\"room.toml\"]\nseeds = [1]\nsedes = [2]\n",
            3,
            &["unknown field `sedes`"],
        ),
        (
            "scenes = [\"room.toml\",\n  \"nowhere.toml\"]\n",
            2,
            &["scenes[1]", "no scene file", "nowhere.toml"],
        ),
        ("scenes = []\n", 1, &["scenes", "no scene"]),
        (
            "scenes = [\"room.toml\"]\nseeds = [1, 2, 1]\n",
            2,
            &["seeds", "seed 1 is listed twice"],
        ),
        (
            "scenes = [\"room.toml\"]\n[grid]\n\"crowds.0.count\" = []\n",
            3,
            &["[grid] crowds.0.count", "an empty list"],
        ),
        (
            "scenes = [\"room.toml\"]\n[grid]\n\n\"crowds.0.count\" = 5\n",
            4,
            &["[grid] crowds.0.count", "a list of values is expected"],
        ),
        (
            "scenes = [\"room.toml\"]\n[grid]\n\"run.h\" = [0.1]\n[[trials]]\nset = { \"run.h\" = 0.2 }\n",
            5,
            &["[[trials]] #1 set run.h", "also a key of [grid]"],
        ),
        (
            "scenes = [\"room.toml\"]\n[[trials]]\ntags = { seed = 3 }\n",
            3,
            &["[[trials]] #1 tags seed", "already a column"],
        ),
        (
            "scenes = [\"room.toml\"]\n[grid]\n\"run.h\" = [0.1]\n[plot]\nx = \"run.t\"\ny = \"evacuation_time\"\n",
            4,
            &["[plot] x", "`run.t` is not a parameter", "seed, run.h"],
        ),
        (
            "scenes = [\"room.toml\"]\n[grid]\n\"run.h\" = [0.1]\n[plot]\nx = \"run.h\"\ny = \"evac\"\n",
            4,
            &["[plot] y", "`evac` is not an output", "evacuation_time"],
        ),
        (
            "scenes = [\"room.toml\"]\n[grid]\n\"run.h\" = [0.1]\n[plot]\nx = \"run.h\"\ny = \"flow / width\"\n",
            4,
            &["[plot] y", "`width` (what `flow` is divided by) is neither"],
        ),
        (
            "scenes = [\"room.toml\"]\n[grid]\n\"run.h\" = [0.1]\n[plot]\nx = \"run.h\"\ny = \"flow / run.h\"\nband = { from = 2.0, to = 1.6 }\n",
            4,
            &["[plot] band", "`from` (2) must be below `to` (1.6)"],
        ),
        (
            "scenes = [\"room.toml\"]\n[grid]\n\"run.h\" = [0.1, 0.1]\n",
            3,
            &["the value 0.1 is listed twice"],
        ),
        (
            "scenes = [\"room.toml\"]\n[grid]\n\"crowds..count\" = [1]\n",
            3,
            &["[grid] crowds..count", "dotted path"],
        ),
    ];
    for (i, (plan, line, fragments)) in cases.iter().enumerate() {
        let e = plan_error(&format!("err{i}"), plan);
        let m = e.to_string();
        assert_eq!(e.line(), Some(*line), "{m}");
        assert!(m.contains(&format!("plan.toml:{line}")), "{m}");
        for f in *fragments {
            assert!(m.contains(f), "expected `{f}` in `{m}`");
        }
    }
}

#[test]
fn an_override_that_does_not_fit_a_scene_is_refused_before_any_trial_runs() {
    let e = plan_error(
        "override",
        "scenes = [\"room.toml\"]\n[grid]\n\"crowds.0.count\" = [2]\n\"crowds.0.cuont\" = [1, 2]\n",
    );
    let BatchError::Scene {
        line, item, source, ..
    } = &e
    else {
        panic!("{e}");
    };
    assert_eq!(*line, Some(4));
    assert_eq!(item, "[grid] crowds.0.cuont");
    let m = source.to_string();
    assert!(
        m.contains("room.toml: --set crowds.0.cuont=1: unknown field `cuont`"),
        "{m}"
    );
    let e = plan_error(
        "override-item",
        "scenes = [\"room.toml\"]\n[[trials]]\nset = { \"crowds.1.count\" = 2 }\n",
    );
    assert_eq!(e.line(), Some(3), "{e}");
    assert!(e.to_string().contains("`crowds` has 1 item"), "{e}");
}

const RUN_PLAN: &str = r#"
scenes = ["room.toml"]
seeds = [1, 2]
[grid]
"crowds.0.count" = [3, 200]
[plot]
x = "crowds.0.count"
y = "evacuation_time"
"#;

/// Reads `results.csv` as rows of `(column, cell)`.
fn read_table(path: &Path) -> Vec<Vec<(String, String)>> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            header
                .iter()
                .cloned()
                .zip(rec.iter().map(String::from))
                .collect()
        })
        .collect()
}

fn cell<'a>(row: &'a [(String, String)], column: &str) -> &'a str {
    &row.iter().find(|(c, _)| c == column).unwrap().1
}

#[test]
fn a_batch_writes_one_table_that_says_what_each_trial_wrote() {
    let path = plan_dir("run", RUN_PLAN);
    let out = path.parent().unwrap().join("out");
    let plan = Plan::from_file(&path).unwrap();
    let report = run_batch(&plan, &out, &BatchSettings::default(), &()).unwrap();
    assert_eq!((report.ran, report.skipped, report.not_run), (4, 0, 0));
    let rows = read_table(&out.join("results.csv"));
    assert_eq!(rows.len(), 4);
    let header: Vec<&str> = rows[0].iter().map(|(c, _)| c.as_str()).collect();
    let mut want = vec![
        "trial",
        "scene",
        "seed",
        "crowds.0.count",
        "status",
        "error",
    ];
    want.extend(OUTPUTS);
    want.push("dir");
    assert_eq!(header, want);
    for (i, row) in rows.iter().enumerate() {
        let trial = plan.trial(i).unwrap();
        assert_eq!(cell(row, "trial"), i.to_string());
        assert_eq!(cell(row, "seed"), trial.seed.unwrap().to_string());
        assert_eq!(
            cell(row, "crowds.0.count"),
            trial.parameter("crowds.0.count").unwrap()
        );
        let dir = out.join(cell(row, "dir"));
        let record: TrialRecord =
            serde_json::from_str(&std::fs::read_to_string(dir.join(RECORD_FILE)).unwrap()).unwrap();
        assert_eq!(
            cell(row, "wall_seconds"),
            record.wall_seconds.unwrap().to_string()
        );
        if cell(row, "crowds.0.count") == "200" {
            // The crowd does not fit: a failed trial with the scene's error, and no numbers.
            assert_eq!(cell(row, "status"), "failed");
            assert!(
                cell(row, "error").contains("200 people of radius ≥ 0.2 cannot fit"),
                "{row:?}"
            );
            assert_eq!(cell(row, "people"), "");
            assert!(!dir.join("summary.json").exists());
            continue;
        }
        // Every number is the trial's own summary's, to the bit.
        let s: RunSummary =
            serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap())
                .unwrap();
        assert_eq!(cell(row, "status"), s.status.to_string());
        assert_eq!(s.status, RunStatus::EverybodyLeft);
        assert_eq!(cell(row, "error"), "");
        let num = |c: &str| cell(row, c).parse::<f64>().unwrap();
        assert_eq!(num("people"), s.people as f64);
        assert_eq!(num("people"), 3.0);
        assert_eq!(num("people_out"), s.people_out.last().unwrap().1 as f64);
        assert_eq!(num("people_out"), (s.people - s.people_remaining) as f64);
        assert_eq!(num("people_remaining"), 0.0);
        assert_eq!(num("evacuation_time"), s.evacuation_time.unwrap());
        assert_eq!(
            cell(row, "flow"),
            middle_flow(&s.people_out, s.people).map_or(String::new(), |f| f.to_string())
        );
        assert_eq!(num("t_final"), s.t_final);
        assert_eq!(num("steps"), s.steps as f64);
        assert_eq!(num("solves"), s.solves as f64);
        assert_eq!(num("solver_iterations"), s.solver_iterations as f64);
        assert_eq!(num("max_overlap"), s.max_overlap);
        assert_eq!(num("ms_per_step"), s.ms_per_step.total);
        // The trial's seed placed its people: the two seeds' first rows differ.
        // And the run is right: an independent check of its trajectory.
        let g = Geometry {
            room: vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]],
            exits: vec![([4.0, 1.5], [4.0, 2.5])],
            obstacles: vec![],
            radii: vec![0.2; 3],
        };
        let f = check_trajectory(&dir.join("trajectory.csv"), &g, 1e-6);
        assert!(f.problems.is_empty(), "{:?}", f.problems);
        let left = left_from_people(&dir.join("people.csv"));
        assert!(left.iter().all(Option::is_some), "{left:?}");
    }
    let first_rows = |i: usize| {
        let t = std::fs::read_to_string(out.join(format!("trials/trial-{i:04}/trajectory.csv")))
            .unwrap();
        t.lines().nth(1).unwrap().to_string()
    };
    assert_ne!(
        first_rows(0),
        first_rows(1),
        "seeds 1 and 2 placed the crowd alike"
    );
    // The plot: a mean over the two seeds of the trials that have an evacuation time.
    let svg = std::fs::read_to_string(out.join("plot.svg")).unwrap();
    assert!(
        svg.contains("evacuation_time against crowds.0.count"),
        "{svg}"
    );
    assert!(svg.contains("2 trial(s) without a value left out"), "{svg}");
    let t0 = report.table.rows[0].output("evacuation_time").unwrap();
    let t1 = report.table.rows[1].output("evacuation_time").unwrap();
    let mean = (t0 + t1) / 2.0;
    assert!(
        svg.contains(&format!("mean {}", (mean * 1e6).round() / 1e6)),
        "mean {mean} not in the plot's point titles"
    );
    // Collecting from the folders alone gives the same table.
    assert_eq!(ResultsTable::collect(&plan, &out), report.table);
}

fn mtime(path: &Path) -> std::time::SystemTime {
    std::fs::metadata(path).unwrap().modified().unwrap()
}

#[test]
fn a_batch_run_again_skips_finished_trials_and_reruns_unfinished_ones() {
    let path = plan_dir("resume", RUN_PLAN);
    let out = path.parent().unwrap().join("out");
    let plan = Plan::from_file(&path).unwrap();
    let trials = plan.trials();
    // Trial 0 runs alone (as a Slurm task would).
    let record = run_trial(&trials[0], &out, 1, &()).unwrap().unwrap();
    assert_eq!(record.status, RunStatus::EverybodyLeft);
    assert!(matches!(
        trial_state(&trials[0], &out),
        TrialState::Finished(_)
    ));
    // Trial 1 as a kill leaves it: a record saying `running`, a trajectory cut short, no
    // summary.
    let dir1 = out.join("trials").join(trials[1].dir_name());
    std::fs::create_dir_all(&dir1).unwrap();
    let mut killed = TrialRecord::of(&trials[1]);
    killed.status = RunStatus::Running;
    std::fs::write(
        dir1.join(RECORD_FILE),
        serde_json::to_string(&killed).unwrap(),
    )
    .unwrap();
    std::fs::write(dir1.join("trajectory.csv"), "t,id,x,y,present\n0,0,1.0,").unwrap();
    assert!(matches!(
        trial_state(&trials[1], &out),
        TrialState::Unfinished(_)
    ));
    // Trial 2's folder holds the record of another plan's trial: not this one's.
    let dir2 = out.join("trials").join(trials[2].dir_name());
    std::fs::create_dir_all(&dir2).unwrap();
    let mut other = TrialRecord::of(&trials[2]);
    other.seed = Some(99);
    other.status = RunStatus::Completed;
    std::fs::write(
        dir2.join(RECORD_FILE),
        serde_json::to_string(&other).unwrap(),
    )
    .unwrap();
    assert_eq!(trial_state(&trials[2], &out), TrialState::NotRun);
    let before = mtime(&out.join("trials/trial-0000/summary.json"));
    let table = ResultsTable::collect(&plan, &out);
    let statuses: Vec<&str> = table.rows.iter().map(|r| r.status.as_str()).collect();
    assert_eq!(
        statuses,
        ["everybody left", "running", "not run", "not run"]
    );

    let report = run_batch(&plan, &out, &BatchSettings::default(), &()).unwrap();
    assert_eq!((report.ran, report.skipped), (3, 1));
    assert_eq!(mtime(&out.join("trials/trial-0000/summary.json")), before);
    let statuses: Vec<&str> = report
        .table
        .rows
        .iter()
        .map(|r| r.status.as_str())
        .collect();
    assert_eq!(
        statuses,
        ["everybody left", "everybody left", "failed", "failed"]
    );
    // The rerun trial's trajectory is whole, and checks.
    let g = Geometry {
        room: vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]],
        exits: vec![([4.0, 1.5], [4.0, 2.5])],
        obstacles: vec![],
        radii: vec![0.2; 3],
    };
    let f = check_trajectory(&dir1.join("trajectory.csv"), &g, 1e-6);
    assert!(f.problems.is_empty(), "{f:?}");
    let left = left_from_people(&dir1.join("people.csv"));
    assert!(left.iter().all(Option::is_some), "{left:?}");
    // The same trial run alone and in the batch: the same result.
    assert_eq!(
        report.table.rows[0]
            .summary
            .as_ref()
            .unwrap()
            .evacuation_time,
        record_summary(&out, 0).evacuation_time
    );

    // Everything finished: nothing runs; failures are kept unless asked to retry.
    let report = run_batch(&plan, &out, &BatchSettings::default(), &()).unwrap();
    assert_eq!((report.ran, report.skipped), (0, 4));
    let retry = BatchSettings {
        retry_failed: true,
        ..BatchSettings::default()
    };
    let report = run_batch(&plan, &out, &retry, &()).unwrap();
    assert_eq!((report.ran, report.skipped), (2, 2));
}

fn record_summary(out: &Path, i: usize) -> RunSummary {
    serde_json::from_str(
        &std::fs::read_to_string(out.join(format!("trials/trial-{i:04}/summary.json"))).unwrap(),
    )
    .unwrap()
}

#[test]
fn a_trial_held_by_another_process_is_left_to_it() {
    let path = plan_dir("held", RUN_PLAN);
    let out = path.parent().unwrap().join("out");
    let plan = Plan::from_file(&path).unwrap();
    let trial = plan.trial(0).unwrap();
    let dir = out.join("trials").join(trial.dir_name());
    std::fs::create_dir_all(&dir).unwrap();
    let lock = std::fs::File::create(dir.join(".sweep.lock")).unwrap();
    lock.lock().unwrap();
    assert_eq!(run_trial(&trial, &out, 1, &()).unwrap(), None);
    drop(lock);
    assert!(run_trial(&trial, &out, 1, &()).unwrap().is_some());
}

#[test]
fn every_shipped_plan_reads_and_fits_its_scenes() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/plans");
    let mut plans: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    plans.sort();
    assert!(plans.len() >= 2, "{plans:?}");
    for path in plans {
        let plan = Plan::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
        plan.check_scenes().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            Some(plan.name.as_str()),
            path.file_stem().and_then(|s| s.to_str())
        );
    }
}

#[test]
fn the_bottleneck_plan_moves_the_door_and_plots_its_specific_flow() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/plans/bottleneck.toml");
    let plan = Plan::from_file(&path).unwrap();
    // Five widths, five seeds.
    assert_eq!(plan.trial_count(), 25);
    let plot = plan.plot.as_ref().unwrap();
    assert_eq!(plot.x, "door_width");
    assert_eq!(plot.y_terms(), ("flow", Some("door_width")));
    let band = plot.band.as_ref().unwrap();
    assert_eq!((band.from, band.to), (1.6, 2.0));
    let mut widths = Vec::new();
    for trial in plan.trials() {
        let (a, b, width) = door_of(&trial);
        // Both ends on the right wall, the door centred at y = 4 and as wide as its tag.
        assert_eq!((a[0], b[0]), (10.0, 10.0), "{trial:?}");
        assert!(((b[1] - a[1]) - width).abs() < 1e-12, "{trial:?}");
        assert!(((a[1] + b[1]) / 2.0 - 4.0).abs() < 1e-12, "{trial:?}");
        // The same inflow at every width.
        assert_eq!(trial.parameter("sources.0.rate").as_deref(), Some("40.0"));
        assert_eq!(trial.parameter("sources.0.count").as_deref(), Some("400"));
        if !widths.contains(&width) {
            widths.push(width);
        }
    }
    assert_eq!(widths, [0.8, 1.2, 1.6, 2.0, 2.4]);
}

#[test]
fn the_shipped_plan_reads_and_fits_its_scene() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/plans/door-width.toml");
    let plan = Plan::from_file(&path).unwrap();
    plan.check_scenes().unwrap();
    assert_eq!(plan.name, "door-width");
    assert_eq!(plan.trial_count(), 15);
    assert_eq!(
        plan.parameters(),
        ["exits.0.from", "exits.0.to", "door_width"]
    );
    let plot = plan.plot.as_ref().unwrap();
    assert_eq!(
        (plot.x.as_str(), plot.y.as_str()),
        ("door_width", "evacuation_time")
    );
    // Each width is the distance between the door's two ends.
    for trial in plan.trials() {
        let (a, b, width) = door_of(&trial);
        assert!(((b[1] - a[1]) - width).abs() < 1e-12, "{trial:?}");
        assert_eq!(a[0], b[0]);
    }
}

/// A trial's door: its two ends (`exits.0.from`, `exits.0.to`) and its `door_width` tag.
fn door_of(trial: &Trial) -> (Vec<f64>, Vec<f64>, f64) {
    let end = |key: &str| -> Vec<f64> {
        let v = trial.parameter(key).unwrap();
        v.trim_matches(['[', ']'])
            .split(',')
            .map(|x| x.trim().parse().unwrap())
            .collect()
    };
    let width = trial.parameter("door_width").unwrap().parse().unwrap();
    (end("exits.0.from"), end("exits.0.to"), width)
}
