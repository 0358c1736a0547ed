//! The flags of `sweep run` and `sweep bench` that choose how a run is computed, not what it
//! computes (the threads a projection may use, the backend's name), and bench's bad sizes.

#[path = "../../tests/common/mod.rs"]
mod common;
mod support;

use support::sweep_run;

/// A jam big enough for the native backend's large-block paths: 120 people walking to the
/// centre of a 6 m room, one block of a few hundred rows, rescued by the interior point at
/// its start (which a second thread speculates on).
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
