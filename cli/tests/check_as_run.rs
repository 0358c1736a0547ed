//! `sweep check` refuses what `sweep run` refuses, and tells what `run` adjusts: a scene it
//! passes runs as written.

mod support;

use std::process::Command;
use support::sweep_run;

const ONE: &str = "[room]\nrectangle = [0.0, 0.0, 4.0, 4.0]\n[[people]]\nposition = [2.0, 2.0]\nradius = 0.2\n[run]\nh = 0.1\nt_end = 0.3\n";

/// `sweep check --no-constants` on `scene` written as `name.toml`: success and stdout + stderr.
fn sweep_check(name: &str, scene: &str) -> (bool, String) {
    let dir = sweeping_testkit::checker::scratch(name);
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, scene).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .arg("check")
        .arg(&path)
        .arg("--no-constants")
        .output()
        .unwrap();
    let output = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), output)
}

#[cfg(feature = "sqlite")]
#[test]
fn sqlite_frames_that_are_not_whole_steps_apart_are_refused_by_check_as_by_run() {
    let scene = format!("{ONE}[output]\nformats = [\"sqlite\"]\ntrajectory_every = 0.15\n");
    let run = sweep_run("run-sqlite-frames", &scene, &[]);
    assert!(!run.success, "{}", run.output);
    assert!(
        run.output.contains("not a whole number of steps"),
        "{}",
        run.output
    );
    let (ok, output) = sweep_check("check-sqlite-frames", &scene);
    assert!(!ok, "{output}");
    assert!(
        output.contains("(--format sqlite)")
            && output.contains("trajectory_every = 0.15 is not a whole number of steps h = 0.1"),
        "{output}"
    );
}

#[cfg(not(feature = "sqlite"))]
#[test]
fn sqlite_without_its_feature_is_refused_by_check_as_by_run() {
    let scene = format!("{ONE}[output]\nformats = [\"sqlite\"]\n");
    let (ok, output) = sweep_check("check-sqlite-missing", &scene);
    assert!(!ok, "{output}");
    assert!(
        output.contains("needs the cargo feature `sqlite`"),
        "{output}"
    );
}

#[cfg(not(feature = "clarabel"))]
#[test]
fn a_backend_left_out_of_the_build_is_refused_by_check_as_by_run() {
    let scene = format!("{ONE}backend = \"clarabel\"\n");
    let (ok, output) = sweep_check("check-backend-missing", &scene);
    assert!(!ok, "{output}");
    assert!(output.contains("clarabel"), "{output}");
}

#[test]
fn check_and_run_say_when_the_csv_rows_are_not_at_the_interval_asked_for() {
    let scene = format!("{ONE}[output]\ntrajectory_every = 0.26\n");
    let note = "trajectory_every = 0.26 is not a whole number of steps h = 0.1: a row is written every 3 step(s), every 0.3 s";
    let (ok, output) = sweep_check("check-csv-rounded", &scene);
    assert!(ok, "{output}");
    assert!(output.contains(note), "{output}");
    let run = sweep_run("run-csv-rounded", &scene, &[]);
    assert!(run.success, "{}", run.output);
    assert!(run.output.contains(note), "{}", run.output);
}

#[test]
fn check_and_run_say_when_an_interval_below_a_step_is_clamped() {
    let scene = format!("{ONE}[output]\ntrajectory_every = 0.01\nsnapshot_every = 0.02\n");
    let (ok, output) = sweep_check("check-clamped", &scene);
    assert!(ok, "{output}");
    for key in ["trajectory_every", "snapshot_every"] {
        assert!(
            output.contains(&format!("check-clamped.toml:9: [output] {key}: 0.0"))
                && output.contains("is shorter than the step h = 0.1"),
            "{output}"
        );
    }
    let run = sweep_run("run-clamped", &scene, &[]);
    assert!(run.success, "{}", run.output);
    assert!(
        run.output
            .contains("[output] trajectory_every: 0.01 is shorter"),
        "{}",
        run.output
    );
}

#[test]
fn a_name_that_would_leave_out_is_refused_before_any_directory_is_made() {
    let dir = sweeping_testkit::checker::scratch("name-escapes");
    let path = dir.join("scene.toml");
    std::fs::write(&path, format!("name = \"../escaped\"\n{ONE}")).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .current_dir(&dir)
        .arg("run")
        .arg(&path)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{stderr}");
    assert!(
        stderr.contains("scene.toml:1: name:") && stderr.contains("\"../escaped\""),
        "{stderr}"
    );
    assert!(!dir.join("escaped").exists(), "out/../escaped was created");
    assert!(!dir.join("out").exists(), "out/ was created");
}
