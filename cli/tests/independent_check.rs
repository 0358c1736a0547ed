//! `scripts/check_trajectory.py`, the check of a run's outputs written apart from the Rust
//! code, on a run of the real binary: clean as written, and flagged once a person is moved
//! onto another in the trajectory.

#[path = "../../tests/common/mod.rs"]
mod common;
mod support;

use std::path::Path;
use std::process::Command;

use support::sweep_run;

const SMALL: &str = r#"
name = "small"
[room]
rectangle = [0.0, 0.0, 4.0, 4.0]
[[exits]]
from = [4.0, 1.5]
to = [4.0, 2.5]
[[people]]
position = [1.0, 1.0]
radius = 0.2
[[people]]
position = [2.0, 2.0]
radius = 0.25
[desired]
kind = "exit"
[run]
h = 0.01
t_end = 1.0
"#;

/// Runs the script on `scene` and `out`: its exit code and what it printed.
fn check(scene: &Path, out: &Path) -> Option<(i32, String)> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/check_trajectory.py");
    let ran = Command::new("python3")
        .arg(script)
        .arg(scene)
        .arg(out)
        .output()
        .ok()?;
    let text =
        String::from_utf8_lossy(&ran.stdout).into_owned() + &String::from_utf8_lossy(&ran.stderr);
    Some((ran.status.code()?, text))
}

#[test]
fn the_independent_check_passes_a_run_and_flags_an_overlap_put_into_it() {
    let has_tomllib = Command::new("python3")
        .args(["-c", "import tomllib"])
        .status()
        .is_ok_and(|s| s.success());
    if !has_tomllib {
        eprintln!("skipped: no python3 with tomllib (Python 3.11 or later) on this machine");
        return;
    }
    let run = sweep_run("independent-check", SMALL, &["--threads", "1"]);
    assert!(run.success, "{}", run.output);
    let scene = run.out.with_file_name("independent-check.toml");
    let (code, text) = check(&scene, &run.out).unwrap();
    assert_eq!(code, 0, "{text}");
    assert!(text.contains("FLAGS: none"), "{text}");
    // Person 1 put 0.3 m from person 0 in the last frame: 0.15 of overlap.
    let csv = run.out.join("trajectory.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let last_t = lines.last().unwrap().split(',').next().unwrap().to_string();
    let zero: Vec<String> = lines
        .iter()
        .find(|l| l.starts_with(&format!("{last_t},0,")))
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let (x0, y0): (f64, f64) = (zero[2].parse().unwrap(), zero[3].parse().unwrap());
    for line in lines.iter_mut() {
        if line.starts_with(&format!("{last_t},1,")) {
            *line = format!("{last_t},1,{},{y0},1", x0 + 0.3);
        }
    }
    std::fs::write(&csv, lines.join("\n") + "\n").unwrap();
    let (code, text) = check(&scene, &run.out).unwrap();
    assert_eq!(code, 1, "{text}");
    assert!(
        text.contains("OVERLAP") && text.contains("1.500e-01"),
        "{text}"
    );
}
