//! Runs the real `sweep` binary of this crate on a scene written to a scratch directory; the
//! trajectory it writes is then read back by the shared checker (`tests/common/checker.rs` of
//! the library crate, which knows nothing of the binary).

use std::path::PathBuf;
use std::process::Command;

use crate::common::checker::scratch;

/// The outcome of `sweep run`.
pub struct CliRun {
    /// Exit status success.
    pub success: bool,
    /// stdout + stderr.
    pub output: String,
    /// The output directory.
    pub out: PathBuf,
}

/// Writes `scene` and runs the real `sweep run` binary on it with `args`.
pub fn sweep_run(name: &str, scene: &str, args: &[&str]) -> CliRun {
    let dir = scratch(name);
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, scene).unwrap();
    let out = dir.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .arg("run")
        .arg(&path)
        .arg("--out")
        .arg(&out)
        .args(args)
        .output()
        .expect("running sweep");
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
