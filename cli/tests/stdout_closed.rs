//! `sweep` with its standard output closed or full: the run's files are written, and the
//! process says so without a panic (it panicked in `println!`, exit code 101).

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
