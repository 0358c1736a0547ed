//! `sweep` with its standard output or error closed, or its output full: the run's files are
//! written, and the process says so without a panic (it panicked in `println!`, and in
//! `eprintln!` at its first progress line, exit code 101).

#[path = "../../tests/common/mod.rs"]
mod common;
mod support;

use std::process::Stdio;

use support::sweep_run_command;

const SMALL: &str = r#"
name = "small"
[room]
rectangle = [0.0, 0.0, 4.0, 4.0]
[[exits]]
from = [4.0, 1.5]
to = [4.0, 2.5]
[[crowds]]
count = 10
radius = 0.2
seed = 1
[desired]
kind = "exit"
[run]
h = 0.01
t_end = 1.0
"#;

/// `sweep run` on [`SMALL`] in the scratch directory `name`, its standard output `stdout`:
/// the exit code, standard error, and whether `trajectory.csv` and `summary.json` exist.
fn run_with_stdout(name: &str, stdout: Stdio, close_at_once: bool) -> (Option<i32>, String, bool) {
    let (mut command, out) = sweep_run_command(name, SMALL, &["--threads", "1"]);
    let mut child = command
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .expect("running sweep");
    if close_at_once {
        // The reader goes away before the run prints its summary: the pipe is closed.
        drop(child.stdout.take());
    }
    let output = child.wait_with_output().unwrap();
    let written = out.join("trajectory.csv").is_file() && out.join("summary.json").is_file();
    (
        output.status.code(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
        written,
    )
}

#[test]
fn a_closed_pipe_on_standard_output_is_not_an_error() {
    let (code, stderr, written) = run_with_stdout("stdout-closed", Stdio::piped(), true);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(code, Some(0), "{stderr}");
    assert!(written);
}

/// `sweep run` on [`SMALL`] with its standard error closed at once (as `2>&1 | head -1`
/// leaves it after the first line): whether it succeeded, its standard output, and whether
/// its files were written.
fn run_with_stderr_closed(name: &str) -> (Option<i32>, String, bool) {
    let (mut command, out) = sweep_run_command(name, SMALL, &["--threads", "1"]);
    let mut child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("running sweep");
    drop(child.stderr.take());
    let output = child.wait_with_output().unwrap();
    let written = out.join("trajectory.csv").is_file() && out.join("summary.json").is_file();
    (
        output.status.code(),
        String::from_utf8_lossy(&output.stdout).into_owned(),
        written,
    )
}

#[test]
fn a_closed_pipe_on_standard_error_does_not_stop_the_run() {
    let (code, stdout, written) = run_with_stderr_closed("stderr-closed");
    assert_eq!(code, Some(0), "{stdout}");
    assert!(written, "the run's files are written");
    // The run went to its end: the summary on standard output says so.
    assert!(
        stdout.contains("(completed") && stdout.contains("t = 1.00 s"),
        "{stdout}"
    );
}

#[test]
#[cfg(target_os = "linux")]
fn a_full_standard_output_is_said_on_standard_error_and_fails_the_command() {
    let full = std::fs::File::create("/dev/full").unwrap();
    let (code, stderr, written) = run_with_stdout("stdout-full", Stdio::from(full), false);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("could not write to standard output"),
        "{stderr}"
    );
    assert!(written, "the run's files are written all the same");
}
