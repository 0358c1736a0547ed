//! Nobody is written after leaving, in any output, and each person's radius is written with
//! the trajectory. A U-shaped room whose exit, on the inner side of one wing, faces the other
//! wing: who leaves walks on along the exit's normal, across the gap and into the other wing,
//! through its wall (they are in no constraint any more). Written as they walked, they came
//! back into the room through a wall; the testkit's trajectory checker flags that, and the
//! outputs must not show it, also in a run resumed after people had left.

mod support;

use std::collections::BTreeMap;
use std::path::Path;
use support::sweep_run;
use sweeping_testkit::checker::{check_trajectory, radii_from_people, Geometry};

/// The U: wings `0 ≤ x ≤ 2` and `4 ≤ x ≤ 6` joined by `0 ≤ y ≤ 1`; the exit on the left
/// wing's inner wall `x = 2`, `2.4 ≤ y ≤ 3.6`, facing the right wing. Four people of random
/// radii in the left wing head for it; two stand in the right wing, in the way of those who
/// left.
const U_ROOM: &str = r#"
name = "u-room"
[room]
polygon = [[0.0, 0.0], [6.0, 0.0], [6.0, 4.0], [4.0, 4.0], [4.0, 1.0], [2.0, 1.0], [2.0, 4.0], [0.0, 4.0]]
[[exits]]
from = [2.0, 2.4]
to = [2.0, 3.6]
[[crowds]]
count = 4
region = [0.3, 2.0, 1.7, 3.8]
radius = [0.18, 0.24]
seed = 3
desired = { kind = "exit" }
[[people]]
position = [5.0, 3.0]
radius = 0.25
[[people]]
position = [4.6, 2.6]
radius = 0.2
[geodesic]
cell = 0.05
[run]
h = 0.01
t_end = 8.0
backend = "clarabel"
[output]
trajectory_every = 0.1
formats = ["csv", "sqlite"]
"#;

const ROOM: [[f64; 2]; 8] = [
    [0.0, 0.0],
    [6.0, 0.0],
    [6.0, 4.0],
    [4.0, 4.0],
    [4.0, 1.0],
    [2.0, 1.0],
    [2.0, 4.0],
    [0.0, 4.0],
];

fn geometry(radii: Vec<f64>) -> Geometry {
    Geometry {
        room: ROOM.to_vec(),
        exits: vec![([2.0, 2.4], [2.0, 3.6])],
        obstacles: Vec::new(),
        radii,
    }
}

/// Each person's row of `people.csv`: `(radius, departure [t, x, y])`.
fn people(out: &Path) -> Vec<(f64, Option<[f64; 3]>)> {
    let text = std::fs::read_to_string(out.join("people.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let left =
                (!f[2].is_empty()).then(|| [f[2], f[3], f[4]].map(|v| v.parse::<f64>().unwrap()));
            (f[1].parse().unwrap(), left)
        })
        .collect()
}

/// The frames of `trajectory.csv`: time (in µs) → person → (x, y).
fn frames(out: &Path) -> BTreeMap<i64, BTreeMap<usize, (f64, f64)>> {
    let text = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let mut frames: BTreeMap<i64, BTreeMap<usize, (f64, f64)>> = BTreeMap::new();
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

/// What every output of the run in `out` must show: the trajectory clean by the checker,
/// each person written up to their departure and never after (CSV and SQLite), the radii of
/// the people table in the scene's ranges and the same in SQLite.
fn check_outputs(out: &Path, from_start: bool) {
    let table = people(out);
    assert_eq!(table.len(), 6);
    let radii: Vec<f64> = table.iter().map(|p| p.0).collect();
    assert_eq!(radii, radii_from_people(&out.join("people.csv")));
    // The two listed people first, then the crowd of drawn radii.
    assert_eq!(radii[..2], [0.25, 0.2]);
    assert!(
        radii[2..].iter().all(|r| (0.18..=0.24).contains(r)),
        "{radii:?}"
    );
    assert!(radii[2..].windows(2).any(|w| w[0] != w[1]), "{radii:?}");
    let findings = check_trajectory(&out.join("trajectory.csv"), &geometry(radii.clone()), 1e-9);
    assert!(findings.problems.is_empty(), "{:?}", findings.problems);
    // Who left is written in every frame before their departure and none after it.
    let frames = frames(out);
    for (&t, frame) in &frames {
        let t = t as f64 * 1e-6;
        for (i, (_, left)) in table.iter().enumerate() {
            let gone = left.is_some_and(|d| d[0] <= t + 1e-9);
            assert_eq!(
                frame.contains_key(&i),
                !gone,
                "t = {t}: person {i}, {left:?}"
            );
        }
    }
    let left: Vec<usize> = (0..6).filter(|&i| table[i].1.is_some()).collect();
    assert!(left.iter().all(|&i| i >= 2), "{table:?}");
    if from_start {
        assert_eq!(left.len(), 4, "{table:?}");
    }
    // Each left wholly outside, beyond the exit (x ≥ 2 + r), and would have walked on into
    // the right wing (x ≥ 4) before the run's end: nobody is written there.
    for &i in &left {
        let [_, x, _] = table[i].1.unwrap();
        assert!(x >= 2.0 + radii[i] - 1e-9, "person {i} left at x = {x}");
    }
    for frame in frames.values() {
        for (&i, &(x, _)) in frame {
            assert!(i < 2 || x < 2.0 + radii[i], "person {i} written at x = {x}");
        }
    }
    // The SQLite trajectory: the same people in the same frames, and the same table.
    let db = rusqlite::Connection::open(out.join("trajectory.sqlite")).unwrap();
    let fps: f64 = db
        .query_row("SELECT value FROM metadata WHERE key = 'fps'", [], |r| {
            r.get::<_, String>(0)
        })
        .unwrap()
        .parse()
        .unwrap();
    let t0 = *frames.keys().next().unwrap() as f64 * 1e-6;
    let mut rows = db
        .prepare("SELECT frame, id FROM trajectory_data ORDER BY frame, id")
        .unwrap();
    let sqlite: Vec<(i64, i64)> = rows
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert!(!sqlite.is_empty());
    for (frame, id) in sqlite {
        let t = t0 + frame as f64 / fps;
        let written = &frames[&((t * 1e6).round() as i64)];
        assert!(written.contains_key(&(id as usize)), "frame {frame}: {id}");
    }
    let mut rows = db
        .prepare("SELECT radius, t_left, x_left FROM people ORDER BY id")
        .unwrap();
    let sqlite: Vec<(f64, Option<f64>, Option<f64>)> = rows
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .map(Result::unwrap)
        .collect();
    for (i, (r, t, x)) in sqlite.into_iter().enumerate() {
        assert_eq!(r, table[i].0);
        assert_eq!(t, table[i].1.map(|d| d[0]), "person {i}");
        assert_eq!(x, table[i].1.map(|d| d[1]), "person {i}");
    }
}

/// `scripts/check_trajectory.py` on a run: clean (skipped without Python 3.11's tomllib).
fn independent_check(scene: &Path, out: &Path) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/check_trajectory.py");
    let Ok(ran) = std::process::Command::new("python3")
        .arg(script)
        .arg(scene)
        .arg(out)
        .output()
    else {
        return;
    };
    let text =
        String::from_utf8_lossy(&ran.stdout).into_owned() + &String::from_utf8_lossy(&ran.stderr);
    if text.contains("No module named 'tomllib'") {
        return;
    }
    assert!(
        ran.status.success() && text.contains("FLAGS: none"),
        "{text}"
    );
}

#[test]
fn who_left_is_written_no_more_and_a_run_resumed_after_some_left_goes_on() {
    let whole = sweep_run("departures-whole", U_ROOM, &["--threads", "1"]);
    assert!(whole.success, "{}", whole.output);
    check_outputs(&whole.out, true);
    // Stopped once some had left, then resumed.
    let first = sweep_run(
        "departures-first",
        U_ROOM,
        &["--threads", "1", "--t-end", "1.3"],
    );
    assert!(first.success, "{}", first.output);
    let left_before = people(&first.out).iter().filter(|p| p.1.is_some()).count();
    assert!(
        (1..4).contains(&left_before),
        "{left_before} left by t = 1.3"
    );
    let resume = first.out.to_str().unwrap();
    let resumed = sweep_run(
        "departures-resumed",
        U_ROOM,
        &["--threads", "1", "--resume", resume],
    );
    assert!(resumed.success, "{}", resumed.output);
    check_outputs(&resumed.out, true);
    // The check written apart from the Rust code, where Python can run it.
    for (name, run) in [
        ("departures-whole", &whole),
        ("departures-resumed", &resumed),
    ] {
        independent_check(&run.out.with_file_name(format!("{name}.toml")), &run.out);
    }
    // The resumed run goes on as the whole one, but for rounding.
    let (whole_frames, resumed_frames) = (frames(&whole.out), frames(&resumed.out));
    for (t, frame) in &resumed_frames {
        let other = &whole_frames[t];
        assert!(frame.keys().eq(other.keys()), "t = {t} µs");
        for (i, p) in frame {
            let q = other[i];
            assert!(
                (p.0 - q.0).abs().max((p.1 - q.1).abs()) < 1e-9,
                "t = {t} µs: {i}"
            );
        }
    }
}
