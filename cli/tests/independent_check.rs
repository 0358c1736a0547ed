//! `scripts/check_trajectory.py`, the check of a run's outputs written apart from the Rust
//! code, on a run of the real binary: clean as written, and flagged once a person is moved
//! onto another in the trajectory.

mod support;

use std::path::{Path, PathBuf};
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

/// Whether this machine lacks a `python3` with `tomllib` (3.11 or later), which the script
/// needs; says so, for the test that is then skipped.
fn no_python_with_tomllib() -> bool {
    let has_tomllib = Command::new("python3")
        .args(["-c", "import tomllib"])
        .status()
        .is_ok_and(|s| s.success());
    if !has_tomllib {
        eprintln!("skipped: no python3 with tomllib (Python 3.11 or later) on this machine");
    }
    !has_tomllib
}

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

/// Runs `scene` (named `name`) on one thread and the script on its outputs, which must pass:
/// the scene file's path and the output directory, for a test to tamper with.
fn run_checked_clean(name: &str, scene: &str) -> (PathBuf, PathBuf) {
    let run = sweep_run(name, scene, &["--threads", "1"]);
    assert!(run.success, "{}", run.output);
    let scene = run.out.with_file_name(format!("{name}.toml"));
    let (code, text) = check(&scene, &run.out).unwrap();
    assert_eq!(code, 0, "{text}");
    assert!(text.contains("FLAGS: none"), "{text}");
    (scene, run.out)
}

#[test]
fn the_independent_check_passes_a_run_and_flags_an_overlap_put_into_it() {
    if no_python_with_tomllib() {
        return;
    }
    let (scene, out) = run_checked_clean("independent-check", SMALL);
    // Person 1 put 0.3 m from person 0 in the last frame: 0.15 of overlap.
    let csv = out.join("trajectory.csv");
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
            *line = format!("{last_t},1,{},{y0}", x0 + 0.3);
        }
    }
    std::fs::write(&csv, lines.join("\n") + "\n").unwrap();
    let (code, text) = check(&scene, &out).unwrap();
    assert_eq!(code, 1, "{text}");
    assert!(
        text.contains("OVERLAP") && text.contains("1.500e-01"),
        "{text}"
    );
}

/// An obstacle whose path turns between two frames is checked at its
/// waypoints too. A wall that pushes a person 0.07 m at h = 0.005 (waypoints on step ends)
/// is clean; the same trajectory with the person put back where it started, as a run that
/// did not see the wall's waypoints left it, is flagged, though at the frames' own times the
/// wall is back where it started.
#[test]
fn the_independent_check_sees_an_obstacle_at_its_waypoints_between_frames() {
    if no_python_with_tomllib() {
        return;
    }
    let scene = "[room]\nrectangle = [0.0, 0.0, 4.0, 4.0]\n[[obstacles]]\n\
                 segment = { from = [1.0, 0.5], to = [1.0, 3.5] }\n\
                 path = [[0.0, 0.0, 0.0], [0.005, 0.07, 0.0], [0.01, 0.0, 0.0], [0.015, 0.07, 0.0], [0.02, 0.0, 0.0]]\n\
                 [[people]]\nposition = [1.25, 2.0]\nradius = 0.25\nspeed = 0\n\
                 [desired]\nkind = \"constant\"\nvelocity = [0.0, 0.0]\n\
                 [run]\nh = 0.005\nt_end = 0.05\n[output]\ntrajectory_every = 0.01\n";
    let (scene, out) = run_checked_clean("independent-check-waypoints", scene);
    let csv = out.join("trajectory.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let unpushed: Vec<String> = text
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            if f[1] == "0" {
                format!("{},0,1.25,{}", f[0], f[3])
            } else {
                l.to_string()
            }
        })
        .collect();
    std::fs::write(&csv, unpushed.join("\n") + "\n").unwrap();
    let (code, text) = check(&scene, &out).unwrap();
    assert_eq!(code, 1, "{text}");
    assert!(
        text.contains("OBSTACLE") && text.contains("7.000e-02") && text.contains("waypoint"),
        "{text}"
    );
}

/// A run that ends with everybody gone between two sampled frames ends on a frame with no rows
/// (the file cannot show it): the check takes it from the summary's final time when
/// `people.csv` says everybody left by then, and flags the summary when it does not.
#[test]
fn the_independent_check_reads_an_empty_last_frame_from_the_departures() {
    if no_python_with_tomllib() {
        return;
    }
    let scene = "[room]\nrectangle = [0.0, 0.0, 4.0, 4.0]\n[[exits]]\nfrom = [4.0, 1.0]\n\
                 to = [4.0, 3.0]\n[[people]]\nposition = [3.5, 2.0]\nradius = 0.2\n\
                 [desired]\nkind = \"exit\"\n[run]\nh = 0.01\nt_end = 5.0\nstop_when_empty = true\n\
                 [output]\ntrajectory_every = 0.5\n";
    let (scene, out) = run_checked_clean("independent-check-empty-end", scene);
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&summary).unwrap();
    let t_final = summary["t_final"].as_f64().unwrap();
    assert!(
        t_final > 0.5 && t_final < 1.0 && summary["people_remaining"] == 0,
        "{summary}"
    );
    let (_, text) = check(&scene, &out).unwrap();
    assert!(text.contains("empty (everybody left by then"), "{text}");
    // The same run with the departure struck from people.csv: the last frame written still
    // holds the person, and the summary's count of nobody left disagrees with it.
    let people = out.join("people.csv");
    let text = std::fs::read_to_string(&people).unwrap();
    let struck: Vec<String> = text
        .lines()
        .map(|l| match l.split_once(',') {
            Some(("0", rest)) => format!("0,{},,,", rest.split(',').next().unwrap()),
            _ => l.to_string(),
        })
        .collect();
    std::fs::write(&people, struck.join("\n") + "\n").unwrap();
    let (code, text) = check(&scene, &out).unwrap();
    assert_eq!(code, 1, "{text}");
    assert!(text.contains("SUMMARY_REMAINING(0 vs 1)"), "{text}");
}

/// People who arrive during the run (a source) and a crowd that keeps a gap: the check reads
/// whom it expects when, and which radii (half the gap added), from the scene; a source's
/// person written before they are due is flagged.
#[test]
fn the_independent_check_follows_sources_and_gaps_and_flags_an_early_arrival() {
    if no_python_with_tomllib() {
        return;
    }
    let scene = "[room]\nrectangle = [0.0, 0.0, 6.0, 4.0]\n[[exits]]\nfrom = [6.0, 1.0]\n\
                 to = [6.0, 3.0]\n[[crowds]]\ncount = 6\nregion = [1.0, 0.5, 3.0, 3.5]\n\
                 radius = { normal = [0.2, 0.02], within = [0.16, 0.24] }\ngap = 0.3\nseed = 7\n\
                 [[sources]]\ndoor = { from = [0.0, 1.5], to = [0.0, 2.5] }\nrate = 4.0\n\
                 count = 6\nstart = 0.6\nradius = { uniform = [0.18, 0.22] }\nseed = 1\n\
                 [desired]\nkind = \"exit\"\n[run]\nh = 0.02\nt_end = 30.0\n\
                 stop_when_empty = true\n[output]\ntrajectory_every = 0.2\n";
    let (scene, out) = run_checked_clean("independent-check-sources", scene);
    // The last source's person (id 11, due at 0.6 + 5/4 = 1.85 s) written at t = 0 too.
    let csv = out.join("trajectory.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    assert!(!lines.iter().any(|l| l.starts_with("0,11,")), "{text}");
    lines.insert(1, "0,11,0.3,2.0".to_string());
    std::fs::write(&csv, lines.join("\n") + "\n").unwrap();
    let (code, text) = check(&scene, &out).unwrap();
    assert_eq!(code, 1, "{text}");
    assert!(text.contains("EARLY_ARRIVAL"), "{text}");
}

/// Moves person `id` to `(x, y)` in every frame of the run's trajectory.
fn move_person(out: &Path, id: usize, x: f64, y: f64) {
    let csv = out.join("trajectory.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let moved: Vec<String> = text
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            if f.len() >= 4 && f[1] == id.to_string() {
                format!("{},{id},{x},{y}", f[0])
            } else {
                l.to_string()
            }
        })
        .collect();
    std::fs::write(&csv, moved.join("\n") + "\n").unwrap();
}

/// A room, its hole and its exits given in WKT, and a round arena: the check reads the same
/// geometry as the run (clean as written), and flags a person put into the hole, or across
/// the arena's wall.
#[test]
fn the_independent_check_reads_wkt_rooms_and_arenas() {
    if no_python_with_tomllib() {
        return;
    }
    let wkt = "[room]\nwkt = \"POLYGON ((0 0, 6 0, 6 4, 0 4, 0 0), (3 1, 4 1, 4 3, 3 3, 3 1))\"\n\
               exits_wkt = \"LINESTRING (6 1.5, 6 2.5)\"\n[[people]]\nposition = [1.0, 2.0]\n\
               radius = 0.2\n[[people]]\nposition = [1.0, 3.0]\nradius = 0.2\n\
               [desired]\nkind = \"exit\"\n[run]\nh = 0.02\nt_end = 1.0\n";
    let (scene, out) = run_checked_clean("independent-check-wkt", wkt);
    move_person(&out, 1, 3.5, 2.0);
    let (code, text) = check(&scene, &out).unwrap();
    assert_eq!(code, 1, "{text}");
    assert!(text.contains("OBSTACLE"), "{text}");

    let arena = "[room]\nrectangle = [0.0, 0.0, 8.0, 8.0]\n[arena]\ncenter = [4.0, 4.0]\n\
                 radius = 3.0\n[[people]]\nposition = [4.0, 4.0]\nradius = 0.25\n\
                 [desired]\nkind = \"point\"\npoint = [7.5, 4.0]\n[run]\nh = 0.02\n\
                 t_end = 3.0\n";
    let (scene, out) = run_checked_clean("independent-check-arena", arena);
    // Pressed against the round wall, not through it; 0.1 m through once moved.
    move_person(&out, 0, 6.85, 4.0);
    let (code, text) = check(&scene, &out).unwrap();
    assert_eq!(code, 1, "{text}");
    assert!(
        text.contains("WALL") && text.contains("1.000e-01"),
        "{text}"
    );
}
