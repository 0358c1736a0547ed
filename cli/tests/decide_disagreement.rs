//! `scripts/decide-disagreement`, which decides a cross-check's stop from its
//! `disagreement.json` with an independent solver (SciPy), on the file `sweep run
//! examples/scenes/paper-evacuation.toml --backend cross` wrote at its stop (t = 11.83 s, 164
//! rows): Clarabel's answer is the projection, OSQP's is 3.16e-6 from it.
//!
//! Ignored: the script needs NumPy and SciPy, which it installs with pip into
//! `target/decide-venv` when the system's Python lacks them (network, a minute). Run with
//! `cargo test -p sweeping-cli --test decide_disagreement -- --ignored`.

use std::path::Path;
use std::process::Command;

#[test]
#[ignore = "needs NumPy and SciPy (installed by the script with pip when missing)"]
fn the_paper_cross_stop_is_decided_for_clarabel() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = Command::new(root.join("scripts/decide-disagreement"))
        .arg(root.join("tests/data/paper_cross_disagreement.json"))
        .output()
        .expect("the script runs");
    let printed = String::from_utf8_lossy(&out.stdout);
    eprintln!("{printed}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "the certificate failed");
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
