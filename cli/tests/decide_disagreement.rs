//! `scripts/decide-disagreement`, which decides a cross-check's stop from its
//! `disagreement.json` with an independent solver (SciPy), on the file `sweep run
//! examples/scenes/paper-evacuation.toml --backend cross` wrote at its stop (t = 11.83 s, 164
//! rows): Clarabel's answer is the projection, OSQP's is 3.16e-6 from it.
//!
//! Ignored: the script needs NumPy and SciPy, which it installs with pip into
//! `target/decide-venv` when the system's Python lacks them (network, a minute). Run with
//! `cargo test -p sweeping-cli --test decide_disagreement -- --ignored`.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository's root.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `scripts/decide-disagreement FILE`: whether a support certified (its exit status), and
/// what it printed.
fn decide(file: &Path) -> (bool, String) {
    let out = Command::new(root().join("scripts/decide-disagreement"))
        .arg(file)
        .output()
        .expect("the script runs");
    let printed = String::from_utf8_lossy(&out.stdout).into_owned();
    eprintln!("{printed}{}", String::from_utf8_lossy(&out.stderr));
    (out.status.success(), printed)
}

/// An empty directory of this process's own under the system's temporary one.
fn fresh_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
#[ignore = "needs NumPy and SciPy (installed by the script with pip when missing)"]
fn the_paper_cross_stop_is_decided_for_clarabel() {
    let (certified, printed) = decide(&sweeping_testkit::fixtures::path(
        "paper_cross_disagreement.json",
    ));
    assert!(certified, "the certificate failed");
    let distance = |name: &str| -> f64 {
        let line = printed
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{name}:")))
            .unwrap_or_else(|| panic!("no line for {name}"));
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    };
    let (clarabel, osqp) = (distance("clarabel"), distance("osqp"));
    assert!(clarabel < 1e-12, "clarabel {clarabel:e}");
    assert!((3.0e-6..3.3e-6).contains(&osqp), "osqp {osqp:e}");
    assert!(printed.contains("clarabel: ") && printed.contains("(within 1e-09)"));
    assert!(printed.contains("(NOT within 1e-09)"));
}

/// A cross-checked run's closest call, `largest-gap.json`, is decided the same way: on a jam of
/// 120 people, both answers are within 1e-9 of the certified projection.
#[test]
#[ignore = "needs NumPy and SciPy (installed by the script with pip when missing)"]
fn a_cross_checked_runs_largest_gap_is_decided() {
    let dir = fresh_dir("sweep-largest-gap");
    let scene = dir.join("jam.toml");
    std::fs::write(
        &scene,
        "name = \"jam\"\n[room]\nrectangle = [0.0, 0.0, 6.0, 6.0]\n[[crowds]]\ncount = 120\n\
         radius = 0.2\nspeed = 1.0\nseed = 3\n[desired]\nkind = \"point\"\npoint = [3.0, 3.0]\n\
         [run]\nh = 0.05\nt_end = 1.5\n",
    )
    .unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .arg("run")
        .arg(&scene)
        .args(["--backend", "cross-native", "--threads", "1", "--out"])
        .arg(dir.join("out"))
        .output()
        .expect("sweep runs");
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let (certified, printed) = decide(&dir.join("out/largest-gap.json"));
    assert!(certified, "no support certified");
    assert!(printed.contains("certified: yes"), "{printed}");
    assert_eq!(printed.matches("(within 1e-09)").count(), 2, "{printed}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A support can miss a row that depends on it and is tight at the projection (the hall's door
/// queue at t = 14.8 s, where the least-distance program's support missed such rows by
/// 1.25e-14). The miniature: `x₀ ≥ 1` and `x₀ + 10⁻³ x₁ ≥ 1 + 5·10⁻¹⁴` from `y = 0`, both
/// tight at the projection `(1, 5·10⁻¹¹)`; the first answer's multipliers name only the first
/// row, whose projection `(1, 0)` violates the second by 5e-14. The row joins and the support
/// certifies, without the least-distance program. Without multipliers, the least-distance
/// program finds both rows itself.
#[test]
#[ignore = "needs NumPy and SciPy (installed by the script with pip when missing)"]
fn a_support_missing_a_tight_row_certifies_once_the_row_joins() {
    let dir = fresh_dir("sweep-decide-sliver");
    let file = |multipliers: &str| {
        format!(
            r#"{{"first_backend": "native", "second_backend": "clarabel", "gap": 5e-11,
            "coordinate": 1,
            "problem": {{"y": [0.0, 0.0], "b": [1.0, 1.00000000000005],
              "a": {{"n_cols": 2, "row_ptr": [0, 1, 3], "col_idx": [0, 0, 1],
                     "values": [1.0, 1.0, 0.001]}},
              "keys": [[0, 0], [0, 1]]}},
            "first": {{"x": [1.0, 5e-11]{multipliers}}},
            "second": {{"x": [1.0, 0.0]}}}}"#
        )
    };
    let with = dir.join("with-multipliers.json");
    std::fs::write(&with, file(r#", "multipliers": [1.0, 0.0]"#)).unwrap();
    let (certified, printed) = decide(&with);
    assert!(certified, "{printed}");
    let tries: Vec<&str> = printed
        .lines()
        .filter(|l| l.contains("certified:"))
        .collect();
    assert_eq!(tries, ["  certified: NO", "  certified: yes"], "{printed}");
    assert!(
        printed.contains("native's (+1 rows it violated) support, 2 rows"),
        "{printed}"
    );
    assert!(!printed.contains("least-distance program:"), "{printed}");
    assert!(
        printed.contains("native: ") && printed.contains("clarabel: 4.99"),
        "{printed}"
    );

    let without = dir.join("without-multipliers.json");
    std::fs::write(&without, file("")).unwrap();
    let (certified, printed) = decide(&without);
    assert!(certified, "{printed}");
    assert!(
        printed.contains("least-distance program: ") && printed.contains("support of 2 rows"),
        "{printed}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
