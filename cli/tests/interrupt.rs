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
use sweeping_testkit::checker::{check_trajectory, Geometry};

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

/// A corridor 40 m long whose 150 people walk slowly to a 2 m door at its end: departures
/// all along a run of some 400 s, written often.
const EVACUATION: &str = r#"
name = "evacuation"
[room]
rectangle = [0.0, 0.0, 40.0, 10.0]
[[exits]]
from = [40.0, 4.0]
to = [40.0, 6.0]
[[crowds]]
count = 150
radius = 0.2
seed = 5
speed = 0.1
desired = { kind = "exit" }
[run]
h = 0.005
t_end = 1000.0
[output]
trajectory_every = 0.05
"#;

/// Killed outright (SIGKILL: no handler runs) after people have left, the run leaves a
/// trajectory ahead of its people table and maybe a row cut short. `--resume` goes on from
/// the last frame the table accounts for, and the two runs together are one evacuation:
/// everybody leaves once, nobody is written after leaving, none overlap or cross a wall.
#[test]
fn a_run_killed_outright_after_departures_is_resumed_from_what_it_wrote() {
    let (mut command, out) = sweep_run_command("interrupt-kill", EVACUATION, &["--threads", "1"]);
    let child = command
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("running sweep");
    // Killed once the people table has been rewritten with a departure, and some frames
    // later, so that the trajectory runs ahead of it.
    let people = out.join("people.csv");
    let start = Instant::now();
    let left_in_table = || {
        std::fs::read_to_string(&people)
            .is_ok_and(|t| t.lines().skip(1).any(|l| !l.ends_with(",,,")))
    };
    while !left_in_table() {
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "nobody left in the people table"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let csv = out.join("trajectory.csv");
    let written = std::fs::metadata(&csv).unwrap().len();
    while std::fs::metadata(&csv).unwrap().len() < written + 300_000 {
        std::thread::sleep(Duration::from_millis(5));
    }
    let killed = std::process::Command::new("kill")
        .args(["-KILL", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let output = child.wait_with_output().unwrap();
    assert_eq!(output.status.code(), None, "killed by a signal");
    assert!(
        !out.join("summary.json").exists(),
        "a killed run writes no summary"
    );

    let scene = out.parent().unwrap().join("interrupt-kill.toml");
    let resumed = out.parent().unwrap().join("resumed");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_sweep"))
        .arg("run")
        .arg(&scene)
        .arg("--resume")
        .arg(&out)
        .arg("--out")
        .arg(&resumed)
        .output()
        .unwrap();
    let printed = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{printed}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(resumed.join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(summary["people_remaining"], 0, "{summary}");

    // The resumed people table has everybody's departure, those before the resume included,
    // each once, and in time order with the frames: nobody written at or after leaving.
    let table = std::fs::read_to_string(resumed.join("people.csv")).unwrap();
    let left: Vec<f64> = table
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .nth(2)
                .unwrap()
                .parse()
                .expect("everybody left")
        })
        .collect();
    assert_eq!(left.len(), 150);
    let resumed_from = summary["resumed_from"]["t"].as_f64().unwrap();
    for dir in [&out, &resumed] {
        let text = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
        for row in text.lines().skip(1).filter(|r| r.split(',').count() == 4) {
            let f: Vec<&str> = row.split(',').collect();
            let (t, id): (f64, usize) = (f[0].parse().unwrap(), f[1].parse().unwrap());
            if dir == &resumed || t <= resumed_from {
                assert!(
                    t < left[id],
                    "{}: person {id} written at t = {t}, left at {}",
                    dir.display(),
                    left[id]
                );
            }
        }
    }
    // The resumed run, read by the independent checker: no overlap, no wall crossed, nobody
    // back after leaving.
    let geometry = Geometry {
        room: vec![[0.0, 0.0], [40.0, 0.0], [40.0, 10.0], [0.0, 10.0]],
        exits: vec![([40.0, 4.0], [40.0, 6.0])],
        obstacles: Vec::new(),
        radii: vec![0.2; 150],
    };
    let findings = check_trajectory(&resumed.join("trajectory.csv"), &geometry, 1e-9);
    assert!(findings.problems.is_empty(), "{:#?}", findings.problems);
    // The resumed run starts where the killed one's frames say, to the bit.
    let first_frame = |dir: &std::path::Path, t: f64| -> Vec<String> {
        let text = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
        text.lines()
            .skip(1)
            .filter(|r| {
                r.split(',').count() == 4
                    && r.split(',').next().unwrap().parse::<f64>().unwrap() == t
            })
            .map(str::to_string)
            .collect()
    };
    let before = first_frame(&out, resumed_from);
    assert!(
        !before.is_empty(),
        "the killed run wrote the frame at t = {resumed_from}"
    );
    assert_eq!(before, first_frame(&resumed, resumed_from));
}
