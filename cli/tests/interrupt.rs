//! Ctrl-C (SIGINT), SIGTERM and SIGHUP during `sweep run`: the run stops after the step the
//! signal came in, exiting non-zero, with every file finished and its summary's status
//! `"interrupted"` (it was `"failed"`, with an error naming an observer). Killed outright, it
//! left `trajectory.csv` cut in the middle of a row and no `summary.json`; SIGTERM and SIGHUP
//! still did (exit codes 143 and 129).

#![cfg(unix)]

mod support;

use std::process::Stdio;
use std::time::{Duration, Instant};

use support::{long_scene, sweep_run_command};

#[test]
fn ctrl_c_stops_the_run_with_its_files_finished() {
    stop_with("INT", "interrupted (Ctrl-C)");
}

#[test]
fn sigterm_stops_the_run_with_its_files_finished() {
    stop_with("TERM", "terminated (SIGTERM)");
}

#[test]
fn sighup_stops_the_run_with_its_files_finished() {
    if sighup_ignored() {
        // Inherited by the run, which then leaves SIGHUP ignored (as under `nohup`).
        eprintln!("skipped: this test runs with SIGHUP ignored");
        return;
    }
    stop_with("HUP", "hung up (SIGHUP)");
}

/// Whether this process ignores SIGHUP (Linux's `/proc/self/status`; elsewhere, taken so).
fn sighup_ignored() -> bool {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|status| {
            let mask = status.lines().find_map(|l| l.strip_prefix("SigIgn:"))?;
            u64::from_str_radix(mask.trim(), 16).ok()
        })
        .is_none_or(|mask| mask & 1 != 0)
}

/// Sends `signal` (a name for `kill -`) to a long run once it has written some steps, and
/// checks that it stopped as asked, saying `said` when the signal came.
fn stop_with(signal: &str, said: &str) {
    let name = format!("interrupt-{}", signal.to_lowercase());
    let (mut command, out) = sweep_run_command(&name, &long_scene(100), &["--threads", "1"]);
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
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains(said), "{stderr}");
    assert!(
        stderr.contains("interrupted (Ctrl-C, SIGTERM or SIGHUP)"),
        "{stderr}"
    );
    assert!(!stderr.contains("observer"), "{stderr}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "interrupted", "{summary}");
    let error = summary["error"].as_str().unwrap();
    assert!(
        error.contains("interrupted (Ctrl-C, SIGTERM or SIGHUP)"),
        "{error}"
    );
    // Whole rows only, the last state's 100 people included.
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.ends_with('\n'));
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert!(
        rows.iter().all(|row| row.split(',').count() == 4),
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

/// Under `nohup` SIGHUP stays ignored: the run goes on when its terminal closes.
#[test]
fn a_run_under_nohup_goes_on_after_sighup() {
    let (command, out) =
        sweep_run_command("interrupt-nohup", &long_scene(100), &["--threads", "1"]);
    let mut nohup = std::process::Command::new("nohup");
    nohup.arg(command.get_program()).args(command.get_args());
    let Ok(mut child) = nohup.stdout(Stdio::null()).stderr(Stdio::piped()).spawn() else {
        eprintln!("skipped: no `nohup` here");
        return;
    };
    let csv = out.join("trajectory.csv");
    let start = Instant::now();
    while std::fs::metadata(&csv).map_or(0, |m| m.len()) < 100_000 {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no trajectory written"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let pid = child.id().to_string();
    let kill = |signal: &str| {
        std::process::Command::new("kill")
            .args([signal, &pid])
            .status()
            .unwrap()
    };
    assert!(kill("-HUP").success());
    std::thread::sleep(Duration::from_millis(500));
    assert!(
        child.try_wait().unwrap().is_none(),
        "SIGHUP stopped the run"
    );
    assert!(kill("-INT").success());
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("hung up"), "{stderr}");
}
