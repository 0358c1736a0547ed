//! The flags of `sweep run` and `sweep bench` that choose how a run is computed, not what it
//! computes (the threads a projection may use, the backend's name), and bench's bad sizes.

mod support;

use support::sweep_run;

/// A jam big enough for the native backend's large-block paths: 120 people walking to the
/// centre of a 6 m room, one block of a few hundred rows, taken by the interior point at its
/// start.
const JAM: &str = r#"
name = "jam"
[room]
rectangle = [0.0, 0.0, 6.0, 6.0]
[[crowds]]
count = 120
radius = 0.2
speed = 1.0
seed = 3
[desired]
kind = "point"
point = [3.0, 3.0]
[run]
h = 0.05
t_end = 1.5
[output]
trajectory_every = 0.05
"#;

#[test]
fn one_thread_or_two_write_the_same_trajectory() {
    let one = sweep_run("threads-1", JAM, &["--threads", "1"]);
    assert!(one.success, "{}", one.output);
    assert!(
        one.output.contains("backend native on 1 thread"),
        "{}",
        one.output
    );
    let two = sweep_run("threads-2", JAM, &["--threads", "2"]);
    assert!(two.success, "{}", two.output);
    assert!(
        two.output.contains("backend native on at most 2 threads"),
        "{}",
        two.output
    );
    let read = |run: &support::CliRun| std::fs::read(run.out.join("trajectory.csv")).unwrap();
    let (a, b) = (read(&one), read(&two));
    assert!(
        a.len() > 120 * 30 * 10,
        "a short trajectory: {} bytes",
        a.len()
    );
    assert!(a == b, "the trajectories differ");
}

#[test]
fn a_negative_thread_count_and_an_unknown_backend_are_refused_by_name() {
    let run = sweep_run("threads-negative", JAM, &["--threads=-1"]);
    assert!(!run.success);
    assert!(run.output.contains("--threads"), "{}", run.output);
    let run = sweep_run("backend-unknown", JAM, &["--backend", "gurobi"]);
    assert!(!run.success);
    for name in ["native", "cross-native", "clarabel", "osqp", "reference"] {
        assert!(run.output.contains(name), "`{name}` not in {}", run.output);
    }
}

fn sweep_bench(args: &[&str]) -> (bool, String) {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_sweep"))
        .arg("bench")
        .args(args)
        .output()
        .expect("running sweep bench");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), text)
}

#[test]
fn bench_runs_on_one_thread_and_refuses_an_empty_crowd_by_its_flag() {
    let (ok, text) = sweep_bench(&[
        "--n",
        "150",
        "--steps",
        "2",
        "--backends",
        "native",
        "--threads",
        "1",
    ]);
    assert!(ok, "{text}");
    assert!(text.contains("jammed      150 native"), "{text}");
    // A crowd of 0 was refused as a degenerate room of a synthetic scene.
    let (ok, text) = sweep_bench(&["--n", "150,0", "--steps", "2", "--backends", "native"]);
    assert!(!ok);
    assert!(
        text.contains("--n: every crowd size must be at least 1"),
        "{text}"
    );
    let (ok, text) = sweep_bench(&["--n", "150", "--steps", "0"]);
    assert!(!ok);
    assert!(text.contains("--steps must be at least 1"), "{text}");
}

#[test]
fn bench_writes_its_csv_row_by_row_and_refuses_a_path_it_cannot_write_before_measuring() {
    // It used to measure everything and fail at the end, writing the file at once.
    let (ok, text) = sweep_bench(&[
        "--n",
        "150",
        "--steps",
        "1",
        "--csv",
        "/nonexistent-directory/bench.csv",
    ]);
    assert!(!ok);
    assert!(
        text.contains("--csv: creating /nonexistent-directory/bench.csv"),
        "{text}"
    );
    assert!(!text.contains(" 150 "), "a row was measured first: {text}");
    let dir = sweeping_testkit::checker::scratch("bench-csv");
    let path = dir.join("bench.csv");
    let (ok, text) = sweep_bench(&[
        "--n",
        "150",
        "--start",
        "spread",
        "--steps",
        "1",
        "--backends",
        "native,clarabel",
        "--csv",
        path.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let csv = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3, "{csv}");
    assert!(
        lines[0].starts_with("start,n,backend,steps,threads,"),
        "{csv}"
    );
    assert!(lines[1].starts_with("spread,150,native,1,"), "{csv}");
    assert!(lines[2].starts_with("spread,150,clarabel,1,"), "{csv}");
}

#[test]
fn a_cross_checked_run_reports_the_gaps_it_saw_and_another_run_reports_none() {
    let run = sweep_run(
        "cross-report",
        JAM,
        &["--backend", "cross-native", "--threads", "1"],
    );
    assert!(run.success, "{}", run.output);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.out.join("summary.json")).unwrap())
            .unwrap();
    let cross = &summary["cross_check"];
    // Every solve was compared: the summary's solves, and the gaps are the two answers'.
    assert_eq!(cross["compared"], summary["solves"], "{summary}");
    let max_gap = cross["max_gap"].as_f64().unwrap();
    assert!((0.0..=1e-8).contains(&max_gap), "{max_gap}");
    assert!(cross["second_seconds"].as_f64().unwrap() > 0.0);
    assert!(
        run.output.contains(&format!(
            "cross-check: {} projections compared, largest gap {max_gap:.3e}",
            cross["compared"]
        )),
        "{}",
        run.output
    );
    // The largest gap's problem and both answers are kept, to be decided afterwards.
    let largest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.out.join("largest-gap.json")).unwrap())
            .unwrap();
    assert_eq!(largest["gap"].as_f64().unwrap(), max_gap);
    let coordinate = usize::try_from(largest["coordinate"].as_u64().unwrap()).unwrap();
    let point = |side: &str| largest[side]["x"][coordinate].as_f64().unwrap();
    assert_eq!((point("first") - point("second")).abs(), max_gap);
    assert!(largest["problem"]["y"].as_array().unwrap().len() > coordinate);
    assert!(run.output.contains("largest-gap.json"), "{}", run.output);
    // A run without a cross-check into the same directory removes it (it is not its own).
    let again = std::process::Command::new(env!("CARGO_BIN_EXE_sweep"))
        .arg("run")
        .arg(run.out.parent().unwrap().join("cross-report.toml"))
        .arg("--out")
        .arg(&run.out)
        .args(["--threads", "1"])
        .output()
        .unwrap();
    assert!(again.status.success());
    assert!(!run.out.join("largest-gap.json").exists());
    let plain = sweep_run("no-cross-report", JAM, &["--threads", "1"]);
    assert!(plain.success, "{}", plain.output);
    assert!(!plain.output.contains("cross-check"), "{}", plain.output);
    let summary = std::fs::read_to_string(plain.out.join("summary.json")).unwrap();
    assert!(!summary.contains("cross_check"), "{summary}");
    assert!(!plain.out.join("largest-gap.json").exists());
}

#[test]
fn a_cross_check_on_two_threads_runs_its_backends_at_once_and_writes_the_same_run() {
    let read =
        |run: &support::CliRun, file: &str| std::fs::read_to_string(run.out.join(file)).unwrap();
    let one = sweep_run(
        "cross-threads-1",
        JAM,
        &["--backend", "cross-native", "--threads", "1"],
    );
    let two = sweep_run(
        "cross-threads-2",
        JAM,
        &["--backend", "cross-native", "--threads", "2"],
    );
    assert!(one.success && two.success, "{}\n{}", one.output, two.output);
    // The native backend on two threads and Clarabel beside it: the same answers, so the
    // same trajectory to the byte and the same gaps.
    assert!(read(&one, "trajectory.csv") == read(&two, "trajectory.csv"));
    let cross = |run: &support::CliRun| {
        let summary: serde_json::Value = serde_json::from_str(&read(run, "summary.json")).unwrap();
        let c = summary["cross_check"].clone();
        (
            c["compared"].clone(),
            c["max_gap"].clone(),
            c["sum_gap"].clone(),
        )
    };
    assert_eq!(cross(&one), cross(&two));
}

#[test]
fn a_run_refused_before_its_first_step_writes_its_start_and_counts_everybody_in() {
    // 1e13 steps, beyond the stepper's limit: refused when the run starts. It reported
    // "left: 120, remaining: 0" and wrote no trajectory.
    let run = sweep_run(
        "refused-at-start",
        JAM,
        &["--t-end", "1e11", "--threads", "1"],
    );
    assert!(!run.success, "{}", run.output);
    assert!(run.output.contains("would take"), "{}", run.output);
    assert!(run.output.contains("remaining: 120"), "{}", run.output);
    let summary = std::fs::read_to_string(run.out.join("summary.json")).unwrap();
    assert!(summary.contains("\"people_remaining\": 120"), "{summary}");
    let csv = std::fs::read_to_string(run.out.join("trajectory.csv")).unwrap();
    let frames: std::collections::BTreeSet<&str> = csv
        .lines()
        .skip(1)
        .filter_map(|line| line.split(',').next())
        .collect();
    assert_eq!(frames.into_iter().collect::<Vec<_>>(), ["0"], "{csv}");
    assert_eq!(csv.lines().count(), 1 + 120);
}

#[test]
fn a_run_into_an_earlier_runs_directory_leaves_none_of_its_stale_files() {
    // First 1.5 s with the CSV, then 0.5 s with SQLite only, into the same directory: the
    // CSV and the snapshots after 0.5 s were the first run's, left beside the second's
    // summary.
    let first = sweep_run("rerun", JAM, &["--threads", "1"]);
    assert!(first.success, "{}", first.output);
    let snapshots = |run: &support::CliRun| -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(run.out.join("snapshots"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    };
    assert!(snapshots(&first).iter().any(|n| n.starts_with("t0001")));
    let mut second_args = vec!["--threads", "1", "--t-end", "0.5"];
    if cfg!(feature = "sqlite") {
        second_args.extend(["--format", "sqlite"]);
    }
    // An earlier cross-checked run's disagreement, which this run does not repeat.
    std::fs::write(first.out.join("disagreement.json"), "{}").unwrap();
    // Into the first run's directory (sweep_run would start a fresh one).
    let scene = first.out.with_file_name("rerun.toml");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_sweep"))
        .arg("run")
        .arg(&scene)
        .arg("--out")
        .arg(&first.out)
        .args(&second_args)
        .output()
        .unwrap();
    assert!(status.status.success(), "{status:?}");
    let second = &first;
    assert!(!second.out.join("disagreement.json").exists());
    if cfg!(feature = "sqlite") {
        assert!(!second.out.join("trajectory.csv").exists());
    }
    let names = snapshots(second);
    assert!(
        names
            .iter()
            .all(|n| n == "final.svg" || n.as_str() <= "t0000.50.svg"),
        "{names:?}"
    );
}

/// A run whose stderr is not a terminal (this test's pipe, a batch job, `nohup`) writes a plain
/// line at every tenth of its steps instead of the progress bar it cannot draw.
#[test]
fn a_run_without_a_terminal_says_how_far_it_got_in_plain_lines() {
    let run = sweep_run("progress-lines", JAM, &["--threads", "1"]);
    assert!(run.success, "{}", run.output);
    let lines: Vec<&str> = run
        .output
        .lines()
        .filter(|l| l.starts_with("t = ") && l.contains(" s elapsed"))
        .collect();
    // 30 steps of h = 0.05: a line at steps 3, 6, …, 30.
    assert_eq!(lines.len(), 10, "{}", run.output);
    assert!(
        lines[0].starts_with("t = 0.15 s, step 3/30, in the room 120/120, "),
        "{}",
        lines[0]
    );
    assert!(
        lines[9].starts_with("t = 1.50 s, step 30/30, "),
        "{}",
        lines[9]
    );
}

#[test]
fn bench_measures_a_scene_from_a_time_of_its_run_or_from_an_earlier_run_s_state() {
    let run = sweep_run("bench-scene", JAM, &["--threads", "1", "--t-end", "0.5"]);
    assert!(run.success, "{}", run.output);
    let scene = run.out.parent().unwrap().join("bench-scene.toml");
    let scene = scene.to_str().unwrap();
    let common = ["--steps", "2", "--backends", "native", "--threads", "1"];
    let (ok, text) = sweep_bench(&[&["--scene", scene, "--from", "0.5"], &common[..]].concat());
    assert!(ok, "{text}");
    assert!(text.contains("jam: running to t = 0.5 s first"), "{text}");
    let measured = |text: &str| -> Vec<String> {
        let row = text
            .lines()
            .find(|l| l.starts_with("jam "))
            .unwrap_or_else(|| panic!("no row for the scene: {text}"));
        row.split_whitespace().map(str::to_string).collect()
    };
    let from_time = measured(&text);
    // N, backend, steps; then the rows of a jam (not an empty projection).
    assert_eq!(from_time[1..4], ["120", "native", "2"], "{text}");
    assert!(from_time[10].parse::<usize>().unwrap() > 100, "{text}");
    let dir = run.out.to_str().unwrap();
    let (ok, text) = sweep_bench(&[&["--scene", scene, "--resume", dir], &common[..]].concat());
    assert!(ok, "{text}");
    assert!(!text.contains("running to"), "{text}");
    let resumed = measured(&text);
    // The same state: the same rows and active constraints per step.
    assert_eq!(resumed[10..12], from_time[10..12], "{text}");
    // Bad starts are refused by their flag.
    let (ok, text) = sweep_bench(&["--scene", scene, "--resume", "/nonexistent-run"]);
    assert!(!ok);
    assert!(
        text.contains("--resume /nonexistent-run: reading the run's last state"),
        "{text}"
    );
    let (ok, text) = sweep_bench(&["--start", "queue,crowded"]);
    assert!(!ok);
    assert!(text.contains("expected spread, jammed or queue"), "{text}");
}

/// The default solvers of a work–precision study are every compiled backend, the native one
/// (the default backend) among them; the reference run is an independent solver.
#[test]
fn a_work_precision_study_compares_the_native_backend_by_default() {
    let dir = sweeping_testkit::checker::scratch("work-precision-defaults");
    let scene = dir.join("scene.toml");
    std::fs::write(
        &scene,
        r#"
name = "few"
[room]
rectangle = [0.0, 0.0, 4.0, 4.0]
[[exits]]
from = [4.0, 1.5]
to = [4.0, 2.5]
[[crowds]]
count = 6
radius = 0.2
speed = 1.0
seed = 1
[desired]
kind = "exit"
[run]
h = 0.05
t_end = 0.2
"#,
    )
    .unwrap();
    let out = dir.join("out");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(["work-precision", scene.to_str().unwrap(), "--hs", "0.1"])
        .args(["--h-min", "0.05", "--samples", "2", "--serial", "--out"])
        .arg(&out)
        .output()
        .expect("running sweep work-precision");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "{text}");
    let csv = std::fs::read_to_string(out.join("work_precision.csv")).unwrap();
    assert!(
        csv.lines().skip(1).any(|l| l.contains("native")),
        "no native row: {csv}"
    );
    let json = std::fs::read_to_string(out.join("work_precision.json")).unwrap();
    let report: serde_json::Value = serde_json::from_str(&json).unwrap();
    let reference = report["settings"]["reference"]["backend"].as_str();
    assert!(
        reference.is_some_and(|b| b != "native"),
        "the reference run is not an independent solver: {json}"
    );
}
