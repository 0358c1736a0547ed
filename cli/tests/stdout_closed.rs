//! `sweep` with its standard output or error closed, or its output full: the run's files are
//! written, and the process says so without a panic (it panicked in `println!`, and in
//! `eprintln!` at its first progress line, exit code 101).

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

/// Which of `sweep run`'s pipes the test closes before the run writes to it.
#[derive(Clone, Copy, PartialEq)]
enum Closed {
    None,
    Stdout,
    Stderr,
}

/// `sweep run` on [`SMALL`] in the scratch directory `name`, its standard output `stdout`,
/// the pipe `closed` closed at once: the exit code, standard error and standard output (as
/// far as they were read), and whether `trajectory.csv` and `summary.json` exist.
fn run_closing(name: &str, stdout: Stdio, closed: Closed) -> (Option<i32>, String, String, bool) {
    let (mut command, out) = sweep_run_command(name, SMALL, &["--threads", "1"]);
    let mut child = command
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .expect("running sweep");
    // The reader goes away before the run writes: the pipe is closed.
    match closed {
        Closed::Stdout => drop(child.stdout.take()),
        Closed::Stderr => drop(child.stderr.take()),
        Closed::None => {}
    }
    let output = child.wait_with_output().unwrap();
    let written = out.join("trajectory.csv").is_file() && out.join("summary.json").is_file();
    (
        output.status.code(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
        String::from_utf8_lossy(&output.stdout).into_owned(),
        written,
    )
}

/// As [`run_closing`], without standard output: the exit code, standard error, and whether
/// the files exist.
fn run_with_stdout(name: &str, stdout: Stdio, close_at_once: bool) -> (Option<i32>, String, bool) {
    let closed = if close_at_once {
        Closed::Stdout
    } else {
        Closed::None
    };
    let (code, stderr, _, written) = run_closing(name, stdout, closed);
    (code, stderr, written)
}

#[test]
fn a_closed_pipe_on_standard_output_is_not_an_error() {
    let (code, stderr, written) = run_with_stdout("stdout-closed", Stdio::piped(), true);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(code, Some(0), "{stderr}");
    assert!(written);
}

#[test]
fn a_closed_pipe_on_standard_error_does_not_stop_the_run() {
    // As `2>&1 | head -1` leaves it after the first line.
    let (code, _, stdout, written) = run_closing("stderr-closed", Stdio::piped(), Closed::Stderr);
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
