//! Ctrl-C (SIGINT) during `sweep run`: the run stops after the step it came in, exiting
//! non-zero, with every file finished and its summary's status `"interrupted"` (it was
//! `"failed"`, with an error naming an observer). Killed outright, it left `trajectory.csv` cut in the middle of a
//! row and no `summary.json`.

#![cfg(unix)]

#[path = "../../tests/common/mod.rs"]
mod common;
mod support;

use std::process::Stdio;
use std::time::{Duration, Instant};

use support::sweep_run_command;

/// 100 people for 1000 s: far longer than the test waits.
const LONG: &str = r#"
name = "long"
[room]
rectangle = [0.0, 0.0, 10.0, 10.0]
[[crowds]]
count = 100
radius = 0.2
seed = 2
[desired]
kind = "point"
point = [5.0, 5.0]
[run]
h = 0.01
t_end = 1000.0
[output]
trajectory_every = 0.01
"#;

#[test]
fn ctrl_c_stops_the_run_with_its_files_finished() {
    let (mut command, out) = sweep_run_command("interrupt", LONG, &["--threads", "1"]);
    let child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("running sweep");
    // Interrupted once it has written some steps (the handler is installed before the run).
    let csv = out.join("trajectory.csv");
    let start = Instant::now();
    while std::fs::metadata(&csv).map_or(0, |m| m.len()) < 100_000 {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no trajectory written"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let killed = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("interrupted by the user (Ctrl-C)"),
        "{stderr}"
    );
    assert!(!stderr.contains("observer"), "{stderr}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "interrupted", "{summary}");
    let error = summary["error"].as_str().unwrap();
    assert!(
        error.contains("interrupted by the user (Ctrl-C)"),
        "{error}"
    );
    // Whole rows only, the last state's 100 people included.
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.ends_with('\n'));
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert!(
        rows.iter().all(|row| row.split(',').count() == 5),
        "a cut row"
    );
    let last_t = rows.last().unwrap().split(',').next().unwrap();
    assert_eq!(
        rows.iter()
            .filter(|r| r.starts_with(&format!("{last_t},")))
            .count(),
        100
    );
}
