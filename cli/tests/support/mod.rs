//! Runs the real `sweep` binary of this crate on a scene written to a scratch directory; the
//! trajectory it writes is then read back by the shared checker (`tests/common/checker.rs` of
//! the library crate, which knows nothing of the binary).

use std::path::PathBuf;
use std::process::Command;

use sweeping_testkit::checker::scratch;

/// The outcome of `sweep run`.
#[allow(dead_code)] // each test binary compiles this module and uses part of it
pub struct CliRun {
    /// Exit status success.
    pub success: bool,
    /// stdout + stderr.
    pub output: String,
    /// The output directory.
    pub out: PathBuf,
}

/// Writes `scene` to a fresh scratch directory `name` and makes the `sweep run` command on
/// it with `args`, its output directory `out` there (returned), for a caller that spawns it
/// itself (to choose its standard streams, or signal it).
#[allow(dead_code)] // each test binary compiles this module and uses part of it
pub fn sweep_run_command(name: &str, scene: &str, args: &[&str]) -> (Command, PathBuf) {
    let dir = scratch(name);
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, scene).unwrap();
    let out = dir.join("out");
    let mut command = Command::new(env!("CARGO_BIN_EXE_sweep"));
    command
        .arg("run")
        .arg(&path)
        .arg("--out")
        .arg(&out)
        .args(args);
    (command, out)
}

/// Writes `scene` and runs the real `sweep run` binary on it with `args`.
#[allow(dead_code)]
pub fn sweep_run(name: &str, scene: &str, args: &[&str]) -> CliRun {
    let (mut command, out) = sweep_run_command(name, scene, args);
    let o = command.output().expect("running sweep");
    CliRun {
        success: o.status.success(),
        output: format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        ),
        out,
    }
}

/// A scene of `count` people walking to the centre of a 10 m room for 1000 s, a frame every
/// step: far longer than a test waits, for tests that stop a run or race it.
#[allow(dead_code)]
pub fn long_scene(count: usize) -> String {
    format!(
        r#"
name = "long"
[room]
rectangle = [0.0, 0.0, 10.0, 10.0]
[[crowds]]
count = {count}
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
"#
    )
}
