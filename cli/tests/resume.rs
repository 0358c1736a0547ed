//! `sweep run --resume DIR`: a run that goes on from the last frame an earlier run of the
//! same scene wrote, read back from its `trajectory.csv` and `people.csv`, agrees with the run
//! that never stopped, and what does not fit is refused by name.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use sweeping_testkit::checker::scratch;

/// Twelve people leaving a 4 m room by a door in its right wall: the first of them are out
/// by t = 2 s, the rest still queueing at t = 3 s.
const ROOM: &str = r#"
name = "resume"
[room]
rectangle = [0.0, 0.0, 4.0, 4.0]
[[exits]]
from = [4.0, 1.6]
to = [4.0, 2.4]
[[crowds]]
count = 12
region = [2.0, 0.5, 3.8, 3.5]
radius = 0.2
speed = 1.0
seed = 7
[desired]
kind = "exit"
[geodesic]
cell = 0.05
[run]
h = 0.01
t_end = 3.0
backend = "clarabel"
[output]
trajectory_every = 0.1
"#;

/// `sweep run` on `scene`, written to a fresh scratch directory `name`, with `args` as they
/// are (no `--out` added): whether it succeeded, what it printed, and the directory.
fn sweep(name: &str, scene: &str, args: &[&str]) -> (bool, String, PathBuf) {
    let dir = scratch(name);
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .arg("run")
        .arg(&path)
        .args(args)
        .current_dir(&dir)
        .output()
        .unwrap();
    let printed = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), printed, dir)
}

/// A frame: person present → (x, y).
type Frame = BTreeMap<usize, (f64, f64)>;

/// The frames of a run's `trajectory.csv`, by time rounded to 1e-6 (a resumed run's times
/// are `t₀ + k h`, the other's `k h`: equal but for the last bits).
fn frames(out: &Path) -> BTreeMap<i64, Frame> {
    let text = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let mut frames: BTreeMap<i64, Frame> = BTreeMap::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let t: f64 = f[0].parse().unwrap();
        frames.entry((t * 1e6).round() as i64).or_default().insert(
            f[1].parse().unwrap(),
            (f[2].parse().unwrap(), f[3].parse().unwrap()),
        );
    }
    frames
}

/// Each person's `[t_left, x_left, y_left]` in a run's `people.csv`, `None` while present.
fn departures(out: &Path) -> Vec<Option<Vec<f64>>> {
    let text = std::fs::read_to_string(out.join("people.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (!f[2].is_empty()).then(|| f[2..].iter().map(|v| v.parse().unwrap()).collect())
        })
        .collect()
}

fn gap(a: &Frame, b: &Frame) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .map(|(i, p)| (p.0 - b[i].0).abs().max((p.1 - b[i].1).abs()))
        .fold(0.0, f64::max)
}

#[test]
fn a_resumed_run_goes_on_as_the_run_that_never_stopped() {
    let (ok, printed, whole) = sweep("resume-whole", ROOM, &["--out", "whole"]);
    assert!(ok, "{printed}");
    let (ok, printed, dir) = sweep("resume-first", ROOM, &["--t-end", "2", "--out", "first"]);
    assert!(ok, "{printed}");
    let first_out = dir.join("first");
    // Without --out, beside the run it resumes.
    let (ok, printed, _) = sweep(
        "resume-second",
        ROOM,
        &["--resume", first_out.to_str().unwrap()],
    );
    assert!(ok, "{printed}");
    assert!(
        printed.contains("resuming")
            && printed.contains("from t = 2")
            && printed.contains("resumed "),
        "{printed}"
    );
    let resumed_out = dir.join("first-from-t2");
    let dir = first_out.to_str().unwrap();
    let whole_out = whole.join("whole");

    let (whole, first, second) = (
        frames(&whole.join("whole")),
        frames(&first_out),
        frames(&resumed_out),
    );
    let t2 = 2_000_000;
    // The resumed run starts at the first run's last frame, to the bit, with whoever had left
    // gone: somebody had, so the latches are what is tested.
    assert_eq!(second.keys().next(), Some(&t2));
    assert_eq!(second[&t2], first[&t2]);
    let gone: Vec<usize> = (0..12).filter(|i| !first[&t2].contains_key(i)).collect();
    assert!(!gone.is_empty(), "nobody left by t = 2 s");
    assert!(gone.len() < 12, "everybody left by t = 2 s");
    for frame in second.values() {
        assert!(
            gone.iter().all(|i| !frame.contains_key(i)),
            "a person who had left came back"
        );
    }
    // From there on both runs make the same projections (Clarabel keeps nothing from one to
    // the next), but for the last bits of the times: the gap stays at rounding.
    assert_eq!(second.keys().last(), whole.keys().last());
    for (t, frame) in &second {
        let g = gap(frame, &whole[t]);
        assert!(
            g < 1e-9,
            "t = {}: {g:e} from the run that never stopped",
            *t as f64 * 1e-6
        );
        assert!(
            frame.keys().eq(whole[t].keys()),
            "t = {}: another set of people present",
            *t as f64 * 1e-6
        );
    }
    // The people table of the resumed run keeps the departures of the first, and has the
    // later ones: the whole run's, but for rounding (times `t₀ + k h` against `k h`).
    let (resumed_people, whole_people) = (departures(&resumed_out), departures(&whole_out));
    assert_eq!(resumed_people.len(), 12);
    for (i, (a, b)) in resumed_people.iter().zip(&whole_people).enumerate() {
        match (a, b) {
            (None, None) => {}
            (Some(a), Some(b)) => assert!(
                a.iter().zip(b).all(|(u, v)| (u - v).abs() < 1e-9),
                "person {i}: {a:?} against {b:?}"
            ),
            _ => panic!("person {i}: {a:?} against {b:?}"),
        }
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(resumed_out.join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(summary["resumed_from"]["run"], dir);
    assert_eq!(summary["resumed_from"]["t"], 2.0);
    assert_eq!(summary["steps"], 100);
}

#[test]
fn a_resume_that_does_not_fit_is_refused_by_name() {
    let (ok, printed, scratch_dir) = sweep(
        "resume-refused",
        ROOM,
        &["--t-end", "0.5", "--out", "first"],
    );
    assert!(ok, "{printed}");
    let first = scratch_dir.join("first");
    let dir = first.to_str().unwrap();
    let refused = |name: &str, scene: &str, args: &[&str], says: &str| {
        let (ok, printed, _) = sweep(name, scene, args);
        assert!(!ok && printed.contains(says), "{name}: {printed}");
    };

    // Into its own directory: its trajectory would be overwritten.
    refused(
        "resume-own",
        ROOM,
        &["--resume", dir, "--out", dir],
        "another directory",
    );

    // A directory without a trajectory.
    let empty = scratch_dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let empty = empty.to_str().unwrap();
    refused(
        "resume-none",
        ROOM,
        &["--resume", empty],
        "empty/trajectory.csv",
    );
    // A trajectory without its people table.
    let alone = scratch_dir.join("alone");
    std::fs::create_dir_all(&alone).unwrap();
    std::fs::copy(first.join("trajectory.csv"), alone.join("trajectory.csv")).unwrap();
    let alone = alone.to_str().unwrap();
    refused(
        "resume-alone",
        ROOM,
        &["--resume", alone],
        "alone/people.csv",
    );

    // A run that wrote its trajectory in SQLite only: the file that can be resumed from is
    // named, and how to get it.
    let (ok, printed, sqlite_dir) = sweep(
        "resume-sqlite",
        ROOM,
        &["--t-end", "0.5", "--format", "sqlite", "--out", "first"],
    );
    assert!(ok, "{printed}");
    let sqlite_only = sqlite_dir.join("first");
    assert!(sqlite_only.join("trajectory.sqlite").exists());
    refused(
        "resume-sqlite-again",
        ROOM,
        &["--resume", sqlite_only.to_str().unwrap()],
        "no trajectory.csv but a trajectory.sqlite",
    );

    // Another crowd: the scene with two people fewer.
    let fewer = ROOM.replace("count = 12", "count = 10");
    let says = "people.csv: lists 12 people, the scene has 10: the trajectory of another scene";
    refused("resume-other", &fewer, &["--resume", dir], says);
    // Another crowd of as many people with other radii.
    let wider = ROOM.replace("radius = 0.2", "radius = 0.19");
    refused(
        "resume-radii",
        &wider,
        &["--resume", dir],
        "people.csv:2: person 0 has radius 0.2, the scene gives them 0.19",
    );

    // A last frame cut short, as a run killed while writing it leaves it: the run goes on
    // from the frame before, the last whole one, and says so.
    let csv = first.join("trajectory.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let time_of = |line: &str| line[..line.find(',').unwrap()].to_string();
    let last_t = time_of(lines[lines.len() - 1]);
    let before = lines
        .iter()
        .rev()
        .map(|l| time_of(l))
        .find(|t| *t != last_t)
        .unwrap();
    let goes_on = |name: &str, trajectory: String| {
        let dir = scratch_dir.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::copy(first.join("people.csv"), dir.join("people.csv")).unwrap();
        std::fs::write(dir.join("trajectory.csv"), trajectory).unwrap();
        let (ok, printed, _) = sweep(
            &format!("resume-{name}"),
            ROOM,
            &["--resume", dir.to_str().unwrap(), "--out", "resumed"],
        );
        assert!(
            ok && printed.contains(&format!("frames up to t = {last_t}"))
                && printed.contains(&format!("it goes on from t = {before}")),
            "{name}: {printed}"
        );
    };
    goes_on("cut", lines[..lines.len() - 3].join("\n") + "\n");
    // Cut inside a line (no line end): that line is passed over too.
    let mut short = lines[..lines.len() - 1].join("\n");
    short.push('\n');
    short.push_str(&lines[lines.len() - 1][..lines[lines.len() - 1].rfind(',').unwrap()]);
    goes_on("inside", short);

    // A state at the horizon: nothing left to run.
    let args = ["--resume", dir, "--t-end", "0.5"];
    refused("resume-late", ROOM, &args, "not before the horizon");

    // A frame whose person is not where a scene could start: inside a wall.
    let csv = first.join("trajectory.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let last = lines.len() - 1;
    let f: Vec<String> = lines[last].split(',').map(str::to_string).collect();
    lines[last] = format!("{},{},-0.05,2", f[0], f[1]);
    let broken = scratch_dir.join("broken");
    std::fs::create_dir_all(&broken).unwrap();
    std::fs::copy(first.join("people.csv"), broken.join("people.csv")).unwrap();
    std::fs::write(broken.join("trajectory.csv"), lines.join("\n") + "\n").unwrap();
    let broken = broken.to_str().unwrap();
    refused(
        "resume-wall",
        ROOM,
        &["--resume", broken],
        "broken/trajectory.csv",
    );
}

#[test]
fn a_run_resumed_after_everybody_left_takes_no_step() {
    // The same room, run until it empties: resumed from its last frame, where nobody is
    // left, the run ends where it starts. It used to take one step past the end the first
    // run had reached, and report it.
    let until_empty = ROOM.replace("t_end = 3.0", "t_end = 30.0\nstop_when_empty = true");
    let (ok, printed, dir) = sweep("resume-empty", &until_empty, &["--out", "first"]);
    assert!(ok && printed.contains("everybody left"), "{printed}");
    let first_out = dir.join("first");
    let summary = |out: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
    };
    let t_empty = summary(&first_out)["t_final"].as_f64().unwrap();
    // Nobody is written after leaving: the last frame with rows is before the room emptied.
    let first = frames(&first_out);
    let (&t_last, _) = first.last_key_value().unwrap();
    assert!((t_last as f64) * 1e-6 < t_empty, "{t_last} {t_empty}");
    let (ok, printed, again_dir) = sweep(
        "resume-empty-again",
        &until_empty,
        &["--resume", first_out.to_str().unwrap(), "--out", "again"],
    );
    assert!(ok, "{printed}");
    let again_out = again_dir.join("again");
    // It starts where the room emptied, writes nobody, and keeps everybody's departure.
    assert!(frames(&again_out).is_empty());
    let summary = summary(&again_out);
    assert_eq!(summary["steps"], 0, "{summary}");
    assert_eq!(summary["status"], "everybody left", "{summary}");
    assert_eq!(summary["t_final"].as_f64().unwrap(), t_empty, "{summary}");
    let people = |out: &Path| std::fs::read_to_string(out.join("people.csv")).unwrap();
    assert_eq!(people(&again_out), people(&first_out));
}

/// `lines` written as the `trajectory.csv` of a fresh directory `name` under `dir`, and
/// `people` as its `people.csv`.
fn write_trajectory(dir: &Path, name: &str, lines: &[String], people: &str) -> String {
    let d = dir.join(name);
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("trajectory.csv"), lines.join("\n") + "\n").unwrap();
    std::fs::write(d.join("people.csv"), people).unwrap();
    d.to_str().unwrap().to_string()
}

/// `--resume` once trusted what it read. Two people inside the room marked as
/// gone resumed and walked through a wall; a person at x = −3 marked present was silently
/// taken as gone; a trajectory starting at t = −100, and one of another scene, were resumed
/// from. Each is refused now, naming the row, the person and what does not fit.
#[test]
fn an_edited_or_foreign_state_is_refused_by_row_and_person() {
    let (ok, printed, scratch_dir) =
        sweep("resume-edited", ROOM, &["--t-end", "2", "--out", "first"]);
    assert!(ok, "{printed}");
    let text = std::fs::read_to_string(scratch_dir.join("first/trajectory.csv")).unwrap();
    let people = std::fs::read_to_string(scratch_dir.join("first/people.csv")).unwrap();
    let lines: Vec<String> = text.lines().map(str::to_string).collect();
    // The last frame, at t = 2: (index in `lines`, id, x) of each row, the people present.
    let last: Vec<(usize, usize, f64)> = lines
        .iter()
        .enumerate()
        .filter(|(_, l)| l.starts_with("2,"))
        .map(|(k, l)| {
            let f: Vec<&str> = l.split(',').collect();
            (k, f[1].parse().unwrap(), f[2].parse().unwrap())
        })
        .collect();
    assert!(last.len() < 12 && !last.is_empty(), "{last:?}");
    let inside: Vec<(usize, usize)> = last
        .iter()
        .filter(|r| r.2 < 3.7)
        .map(|r| (r.0, r.1))
        .collect();
    assert!(inside.len() >= 2, "{last:?}");
    let refused = |name: &str, scene: &str, dir: &str, says: &[String]| {
        let (ok, printed, _) = sweep(name, scene, &["--resume", dir, "--out", "again"]);
        assert!(!ok, "{name}: resumed:\n{printed}");
        for s in says {
            assert!(
                printed.contains(s.as_str()),
                "{name}: no `{s}` in\n{printed}"
            );
        }
    };
    // `people.csv` with person `id` marked as having left at t = 2 (the last frame, which lists them no more) at (x, y).
    let left_at = |people: &str, id: usize, x: f64, y: f64| -> String {
        people
            .lines()
            .enumerate()
            .map(|(k, l)| {
                if k == id + 1 {
                    let r: Vec<&str> = l.split(',').collect();
                    format!("{id},{},2,{x},{y}", r[1])
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
            + "\n"
    };

    // Two people inside marked gone where they stand: their rows of the last frame dropped,
    // the people table saying they left there.
    let (mut edited, mut table) = (lines.clone(), people.clone());
    for &(k, id) in inside[..2].iter().rev() {
        let f: Vec<&str> = lines[k].split(',').collect();
        table = left_at(&table, id, f[2].parse().unwrap(), f[3].parse().unwrap());
        edited.remove(k);
    }
    let id = inside[0].1;
    let dir = write_trajectory(&scratch_dir, "gone-inside", &edited, &table);
    let says = [
        format!("people.csv:{}", id + 2),
        format!("person {id} is marked gone at t = 2"),
        "not wholly outside the room".to_string(),
    ];
    refused("resume-gone-inside", ROOM, &dir, &says);

    // A person at x = −3 present, then gone: no exit is on that side.
    let (k, id) = inside[0];
    let mut moved = lines.clone();
    moved[k] = format!("2,{id},-3,2");
    let dir = write_trajectory(&scratch_dir, "outside-present", &moved, &people);
    let says = [
        format!("trajectory.csv:{}", k + 1),
        format!("person {id} is marked present"),
        "at (-3, 2)".to_string(),
        "wholly outside the room".to_string(),
    ];
    refused("resume-outside-present", ROOM, &dir, &says);
    let mut dropped = lines.clone();
    dropped.remove(k);
    let dir = write_trajectory(
        &scratch_dir,
        "outside-gone",
        &dropped,
        &left_at(&people, id, -3.0, 2.0),
    );
    let says = [
        format!("people.csv:{}", id + 2),
        format!("person {id} is marked gone"),
        "at (-3, 2)".to_string(),
        "on no exit's outer side".to_string(),
    ];
    refused("resume-outside-gone", ROOM, &dir, &says);

    // The scene's start, written at t = −100.
    let mut early = vec![lines[0].clone()];
    early.extend(
        lines[1..13]
            .iter()
            .map(|l| format!("-100{}", &l[l.find(',').unwrap()..])),
    );
    let fresh = left_free(&people);
    let dir = write_trajectory(&scratch_dir, "early", &early, &fresh);
    let says = [
        "trajectory.csv:2".to_string(),
        "before the scene's start t = 0".to_string(),
    ];
    refused("resume-early", ROOM, &dir, &says);

    // Cut inside the first frame.
    let dir = write_trajectory(&scratch_dir, "cut-first", &lines[..6], &fresh);
    let says = ["lists 5 of 12 people, and person 5, missing, has not left".to_string()];
    refused("resume-cut-first", ROOM, &dir, &says);

    // Another crowd of as many people in the same room.
    let other = ROOM.replace("seed = 7", "seed = 8");
    let (ok, printed, other_dir) = sweep(
        "resume-other-seed",
        &other,
        &["--t-end", "2", "--out", "first"],
    );
    assert!(ok, "{printed}");
    let dir = other_dir.join("first");
    let says = [
        "trajectory.csv:2".to_string(),
        "the trajectory of another scene".to_string(),
    ];
    refused("resume-foreign", ROOM, dir.to_str().unwrap(), &says);
}

/// `people.csv` with nobody having left.
fn left_free(people: &str) -> String {
    people
        .lines()
        .enumerate()
        .map(|(k, l)| {
            if k == 0 {
                l.to_string()
            } else {
                let r: Vec<&str> = l.split(',').collect();
                format!("{},{},,,", r[0], r[1])
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

mod fuzz {
    use super::*;
    use proptest::prelude::*;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::OnceLock;

    /// One change to a trajectory.
    #[derive(Debug, Clone)]
    enum Edit {
        /// A row of the last frame dropped.
        Drop(usize),
        /// A row of the last frame dropped, and the people table saying the person left at
        /// this point.
        Leave(usize, f64, f64),
        /// A row of the last frame moved to a point.
        Move(usize, f64, f64),
        /// A row of the last frame moved by a little.
        Nudge(usize, f64, f64),
        /// The last frame put at another time.
        Time(f64),
        /// The file cut at this fraction of its length.
        Cut(f64),
    }

    fn edit() -> impl Strategy<Value = Edit> {
        prop_oneof![
            (0..12usize).prop_map(Edit::Drop),
            (0..12usize, -1.0..5.0f64, -1.0..5.0f64).prop_map(|(i, x, y)| Edit::Leave(i, x, y)),
            (0..12usize, -1.0..5.0f64, -1.0..5.0f64).prop_map(|(i, x, y)| Edit::Move(i, x, y)),
            (0..12usize, -0.2..0.2f64, -0.2..0.2f64).prop_map(|(i, x, y)| Edit::Nudge(i, x, y)),
            prop_oneof![-2.0..4.0f64, 0.95..1.25f64].prop_map(Edit::Time),
            (0.0..1.0f64).prop_map(Edit::Cut),
        ]
    }

    /// The trajectory and people table of ROOM to t = 1, made once.
    fn base() -> &'static (String, String) {
        static TEXT: OnceLock<(String, String)> = OnceLock::new();
        TEXT.get_or_init(|| {
            let (ok, printed, dir) = sweep(
                "resume-fuzz-base",
                ROOM,
                &["--t-end", "1", "--out", "first"],
            );
            assert!(ok, "{printed}");
            let read = |name: &str| std::fs::read_to_string(dir.join("first").join(name)).unwrap();
            (read("trajectory.csv"), read("people.csv"))
        })
    }

    /// `text` and `people` with the edits made.
    fn apply((text, people): &(String, String), edits: &[Edit]) -> (String, String) {
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        let mut table: Vec<String> = people.lines().map(str::to_string).collect();
        for e in edits {
            let n = lines.len();
            let last = n.saturating_sub(12).max(1)..n;
            match *e {
                Edit::Drop(i) if last.start + i < n => {
                    lines.remove(last.start + i);
                }
                Edit::Leave(i, x, y) if last.start + i < n => {
                    let row = lines.remove(last.start + i);
                    let id: usize = row
                        .split(',')
                        .nth(1)
                        .and_then(|v| v.parse().ok())
                        .unwrap_or(0);
                    if let Some(line) = table.get_mut(id + 1) {
                        let radius = line.split(',').nth(1).unwrap_or("0.2").to_string();
                        *line = format!("{id},{radius},0.95,{x},{y}");
                    }
                }
                Edit::Move(i, _, _) | Edit::Nudge(i, _, _) if last.start + i < n => {
                    let k = last.start + i;
                    let mut f: Vec<String> = lines[k].split(',').map(str::to_string).collect();
                    if f.len() != 4 {
                        continue;
                    }
                    let coordinate = |v: &str| v.parse::<f64>().unwrap_or(0.0);
                    match *e {
                        Edit::Move(_, x, y) => {
                            f[2] = x.to_string();
                            f[3] = y.to_string();
                        }
                        _ => {
                            let (dx, dy) = match *e {
                                Edit::Nudge(_, dx, dy) => (dx, dy),
                                _ => (0.0, 0.0),
                            };
                            f[2] = (coordinate(&f[2]) + dx).to_string();
                            f[3] = (coordinate(&f[3]) + dy).to_string();
                        }
                    }
                    lines[k] = f.join(",");
                }
                Edit::Time(t) => {
                    for line in &mut lines[last] {
                        if let Some(c) = line.find(',') {
                            *line = format!("{t}{}", &line[c..]);
                        }
                    }
                }
                Edit::Cut(at) => {
                    let joined = lines.join("\n");
                    let mut cut = (joined.len() as f64 * at) as usize;
                    while !joined.is_char_boundary(cut) {
                        cut -= 1;
                    }
                    lines = joined[..cut].lines().map(str::to_string).collect();
                }
                _ => {}
            }
        }
        (lines.join("\n") + "\n", table.join("\n") + "\n")
    }

    fn cases() -> u32 {
        std::env::var("SWEEP_RESUME_FUZZ_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(12)
    }

    fn has_tomllib() -> bool {
        Command::new("python3")
            .args(["-c", "import tomllib"])
            .status()
            .is_ok_and(|s| s.success())
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: cases(),
            failure_persistence: None,
            ..ProptestConfig::default()
        })]

        /// Every edit or cut of a real trajectory is either refused with an error that names
        /// what it read, or resumed into a run that the independent checker
        /// (`scripts/check_trajectory.py`) finds clean. `SWEEP_RESUME_FUZZ_CASES` sets how
        /// many (12 by default, to stay quick).
        #[test]
        fn an_edited_or_cut_trajectory_is_refused_or_resumed_soundly(
            edits in prop::collection::vec(edit(), 1..3)
        ) {
            static CASE: AtomicUsize = AtomicUsize::new(0);
            let case = CASE.fetch_add(1, Ordering::Relaxed);
            let scratch_dir = scratch(&format!("resume-fuzz-{case}"));
            let (text, people) = apply(base(), &edits);
            let lines: Vec<String> = text.lines().map(str::to_string).collect();
            let dir = write_trajectory(&scratch_dir, "edited", &lines, &people);
            let name = format!("resume-fuzz-run-{case}");
            let (ok, printed, run_dir) =
                sweep(&name, ROOM, &["--resume", &dir, "--out", "again", "--t-end", "1.3"]);
            prop_assert!(!printed.contains("panicked"), "{edits:?}: {printed}");
            if !ok {
                prop_assert!(
                    printed.contains("error: --resume")
                        && (printed.contains("trajectory.csv") || printed.contains("people.csv")),
                    "{edits:?}: an error that does not say what it read:\n{printed}"
                );
            } else if has_tomllib() {
                let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/check_trajectory.py");
                let checked = Command::new("python3")
                    .arg(script)
                    .arg(run_dir.join("scene.toml"))
                    .arg(run_dir.join("again"))
                    .output()
                    .unwrap();
                prop_assert!(
                    checked.status.success(),
                    "{edits:?}: the resumed run is not clean:\n{}",
                    String::from_utf8_lossy(&checked.stdout)
                );
            }
        }
    }
}

/// A run with arrivals, resumed while people are queueing through the source's door (some in,
/// touching their neighbours, some still waiting for their place): the resumed run starts with
/// exactly who was in, and goes on as the run that never stopped. It used to let in again, in
/// order of their due times, everybody of a source it found in the room, so that people touching
/// an earlier one vanished from the room until their place came free, and people still waiting
/// took theirs at once.
#[test]
fn a_run_with_arrivals_resumed_mid_queue_goes_on_as_the_run_that_never_stopped() {
    let scene = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes/arrivals.toml"),
    )
    .unwrap();
    fn args<'a>(rest: &[&'a str]) -> Vec<&'a str> {
        let mut a = vec!["--backend", "clarabel", "--threads", "1"];
        a.extend_from_slice(rest);
        a
    }
    let (ok, printed, whole) = sweep(
        "resume-arrivals-whole",
        &scene,
        &args(&["--t-end", "5", "--out", "whole"]),
    );
    assert!(ok, "{printed}");
    let (ok, printed, dir) = sweep(
        "resume-arrivals",
        &scene,
        &args(&["--t-end", "3", "--out", "first"]),
    );
    assert!(ok, "{printed}");
    let first_out = dir.join("first");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(first_out.join("summary.json")).unwrap())
            .unwrap();
    assert!(
        summary["arrivals"]["still_waiting"].as_u64().unwrap() > 0,
        "nobody waiting at t = 3 s: {summary}"
    );
    let second_out = dir.join("second");
    let (ok, printed, _) = sweep(
        "resume-arrivals-second",
        &scene,
        &args(&[
            "--resume",
            first_out.to_str().unwrap(),
            "--t-end",
            "5",
            "--out",
            second_out.to_str().unwrap(),
        ]),
    );
    assert!(ok, "{printed}");
    let (whole, first, second) = (
        frames(&whole.join("whole")),
        frames(&first_out),
        frames(&second_out),
    );
    let t3 = 3_000_000;
    assert_eq!(second.keys().next(), Some(&t3));
    assert_eq!(second[&t3], first[&t3]);
    assert_eq!(second.keys().last(), whole.keys().last());
    for (t, frame) in &second {
        assert!(
            frame.keys().eq(whole[t].keys()),
            "t = {}: {:?} present, the run that never stopped has {:?}",
            *t as f64 * 1e-6,
            frame.keys().collect::<Vec<_>>(),
            whole[t].keys().collect::<Vec<_>>()
        );
        let g = gap(frame, &whole[t]);
        assert!(
            g < 1e-9,
            "t = {}: {g:e} from the run that never stopped",
            *t as f64 * 1e-6
        );
    }
}
