//! The JuPedSim SQLite trajectory file, read back from Rust (no Python): schema, metadata,
//! frames, ids, positions, who is written, the walkable area's WKT; a run that fails and a
//! writer that dies mid-transaction still leave a valid file; bad output paths are errors
//! before the run; and the `sweep run --format` / `[output] formats` plumbing.
#![cfg(feature = "sqlite")]

use rusqlite::Connection;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use sweeping::api::conformance::ReferenceProjector;
use sweeping::crowd::Population;
use sweeping::error::SweepError;
use sweeping::output::{
    prepare_output_dir, OutputError, SqliteTrajectoryWriter, TrajectoryFormat, WalkableArea,
};
use sweeping::scene::{BuiltScene, Overrides, Scene};
use sweeping::stepper::{Observer, ObserverError, StepReport};

/// A 4 m × 4 m room with a 1 m door, 12 people heading out: some leave during the run.
const SCENE: &str = r#"
name = "sqlite-test"
[room]
rectangle = [0.0, 0.0, 4.0, 4.0]
[[exits]]
from = [4.0, 1.5]
to = [4.0, 2.5]
[desired]
kind = "exit"
[[crowds]]
count = 12
region = [0.5, 0.5, 3.0, 3.5]
radius = [0.18, 0.24]
speed = 1.2
seed = 3
[run]
h = 0.05
t_end = 6.0
[output]
trajectory_every = 0.1
formats = ["sqlite", "csv"]
"#;

fn built() -> BuiltScene {
    Scene::from_toml_str(SCENE, "sqlite-test.toml")
        .unwrap()
        .build(&Overrides::default())
        .unwrap()
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("sqlite-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn writer(b: &BuiltScene, path: &Path) -> SqliteTrajectoryWriter {
    let walkable = WalkableArea::of_scene(&b.geometry, &b.population).unwrap();
    SqliteTrajectoryWriter::for_scene(path, &walkable, b).unwrap()
}

/// What the file should hold, kept independently of the writer: at every frame step, the
/// present people and their positions.
struct Expected {
    population: Arc<Population>,
    every: usize,
    frames: BTreeMap<i64, Vec<(i64, f64, f64)>>,
}

impl Expected {
    fn record(&mut self, frame: i64, q: &[f64]) {
        let present = (0..self.population.len())
            .filter(|&i| self.population.is_present(q, i))
            .map(|i| (i as i64, q[2 * i], q[2 * i + 1]))
            .collect();
        self.frames.insert(frame, present);
    }
}

impl Observer for Expected {
    fn on_start(&mut self, _t: f64, q: &[f64]) -> Result<(), ObserverError> {
        self.record(0, q);
        Ok(())
    }
    fn on_step(&mut self, r: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        let k = r.step + 1;
        if k.is_multiple_of(self.every) {
            self.record((k / self.every) as i64, q);
        }
        Ok(())
    }
}

/// Fails at step `k` (its `on_step` returns an error), like a full disk or a violated bound.
struct FailAt(usize);
impl Observer for FailAt {
    fn on_step(&mut self, r: &StepReport, _q: &[f64]) -> Result<(), ObserverError> {
        if r.step + 1 == self.0 {
            Err("injected failure".into())
        } else {
            Ok(())
        }
    }
}

/// Panics at step `k`: the process would die with the writer's transaction open.
struct PanicAt(usize);
impl Observer for PanicAt {
    fn on_step(&mut self, r: &StepReport, _q: &[f64]) -> Result<(), ObserverError> {
        assert!(r.step + 1 != self.0, "injected panic");
        Ok(())
    }
}

fn rows_by_frame(conn: &Connection) -> BTreeMap<i64, Vec<(i64, f64, f64)>> {
    let mut out: BTreeMap<i64, Vec<(i64, f64, f64)>> = BTreeMap::new();
    let mut st = conn
        .prepare("SELECT frame, id, pos_x, pos_y FROM trajectory_data ORDER BY frame, id")
        .unwrap();
    let rows = st
        .query_map([], |r| {
            Ok((
                r.get::<_, i64>(0)?,
                r.get::<_, i64>(1)?,
                r.get::<_, f64>(2)?,
                r.get::<_, f64>(3)?,
            ))
        })
        .unwrap();
    for row in rows {
        let (f, id, x, y) = row.unwrap();
        out.entry(f).or_default().push((id, x, y));
    }
    out
}

fn frame_data(conn: &Connection) -> Vec<(i64, i64)> {
    let mut st = conn
        .prepare("SELECT frame, geometry_hash FROM frame_data ORDER BY frame")
        .unwrap();
    st.query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

/// The one value `sql` selects.
fn scalar<T: rusqlite::types::FromSql>(conn: &Connection, sql: &str) -> T {
    conn.query_row(sql, [], |r| r.get(0))
        .unwrap_or_else(|e| panic!("{sql}: {e}"))
}

/// Opens the file at `path` and asserts SQLite finds it intact.
fn open_intact(path: &Path) -> Connection {
    let conn = Connection::open(path).unwrap();
    let integrity: String = scalar(&conn, "PRAGMA integrity_check");
    assert_eq!(integrity, "ok");
    conn
}

fn metadata(conn: &Connection, key: &str) -> Option<String> {
    conn.query_row("SELECT value FROM metadata WHERE key = ?1", [key], |r| {
        r.get(0)
    })
    .ok()
}

/// `(name, declared type, not null)` of each column, in order.
fn columns(conn: &Connection, table: &str) -> Vec<(String, String, bool)> {
    let mut st = conn
        .prepare(&format!("PRAGMA table_info({table})"))
        .unwrap();
    st.query_map([], |r| Ok((r.get(1)?, r.get(2)?, r.get::<_, i64>(3)? == 1)))
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

/// The rings of `POLYGON ((x y, …), (x y, …))`, each closed (first point repeated last).
fn parse_wkt_polygon(wkt: &str) -> Vec<Vec<[f64; 2]>> {
    let body = wkt
        .strip_prefix("POLYGON (")
        .and_then(|s| s.strip_suffix(')'))
        .unwrap_or_else(|| panic!("not a POLYGON: {wkt}"));
    body.split("), (")
        .map(|ring| {
            ring.trim_matches(|c| c == '(' || c == ')')
                .split(", ")
                .map(|pt| {
                    let v: Vec<f64> = pt.split(' ').map(|x| x.parse().unwrap()).collect();
                    assert_eq!(v.len(), 2, "point `{pt}`");
                    [v[0], v[1]]
                })
                .collect()
        })
        .collect()
}

fn shoelace(ring: &[[f64; 2]]) -> f64 {
    0.5 * ring
        .windows(2)
        .map(|w| w[0][0] * w[1][1] - w[1][0] * w[0][1])
        .sum::<f64>()
}

#[test]
fn schema_metadata_and_geometry_are_jupedsims_version_2() {
    let b = built();
    let dir = temp_dir("schema");
    let path = dir.join("t.sqlite");
    let mut w = writer(&b, &path);
    w.on_finish(None).unwrap();
    let conn = Connection::open(&path).unwrap();
    let col = |n: &str, t: &str| (n.to_string(), t.to_string(), true);
    assert_eq!(
        columns(&conn, "trajectory_data"),
        vec![
            col("frame", "INTEGER"),
            col("id", "INTEGER"),
            col("pos_x", "REAL"),
            col("pos_y", "REAL"),
            col("ori_x", "REAL"),
            col("ori_y", "REAL"),
        ]
    );
    assert_eq!(
        columns(&conn, "metadata"),
        vec![col("key", "TEXT"), col("value", "TEXT")]
    );
    assert_eq!(
        columns(&conn, "geometry"),
        vec![col("hash", "INTEGER"), col("wkt", "TEXT")]
    );
    assert_eq!(
        columns(&conn, "frame_data"),
        vec![col("frame", "INTEGER"), col("geometry_hash", "INTEGER")]
    );
    let indexes: Vec<String> = conn
        .prepare(
            "SELECT name FROM sqlite_master WHERE type = 'index' AND sql IS NOT NULL ORDER BY name",
        )
        .unwrap()
        .query_map([], |r| r.get(0))
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(indexes, vec!["frame_id_idx", "geometry_hash"]);

    assert_eq!(metadata(&conn, "version").as_deref(), Some("2"));
    let fps: f64 = metadata(&conn, "fps").unwrap().parse().unwrap();
    assert!((fps - 10.0).abs() < 1e-9, "fps {fps}");
    // The geometry's bounds: the room plus the door's apron, as deep as the largest radius.
    let bound = |k: &str| metadata(&conn, k).unwrap().parse::<f64>().unwrap();
    let r_max = b.population.max_radius();
    assert!((bound("xmin") - 0.0).abs() < 1e-12 && (bound("ymin") - 0.0).abs() < 1e-12);
    assert!((bound("xmax") - (4.0 + r_max)).abs() < 1e-12);
    assert!((bound("ymax") - 4.0).abs() < 1e-12);

    let (count, wkt): (i64, String) = conn
        .query_row("SELECT count(*), max(wkt) FROM geometry", [], |r| {
            Ok((r.get(0)?, r.get(1)?))
        })
        .unwrap();
    assert_eq!(count, 1);
    let rings = parse_wkt_polygon(&wkt);
    assert_eq!(rings.len(), 1, "no obstacles, no holes: {wkt}");
    assert_eq!(rings[0].first(), rings[0].last(), "ring closed");
    let area = shoelace(&rings[0]);
    assert!(
        (area - (16.0 + 1.0 * r_max)).abs() < 1e-9,
        "area {area}, counter-clockwise shell of the room and the apron"
    );
}

#[test]
fn frames_ids_and_positions_match_the_run_and_people_who_left_are_not_written() {
    let b = built();
    let dir = temp_dir("contents");
    let path = dir.join("t.sqlite");
    let mut w = writer(&b, &path).with_frames_per_commit(7);
    let every = w.steps_per_frame();
    assert_eq!(every, 2);
    let mut expected = Expected {
        population: b.population.clone(),
        every,
        frames: BTreeMap::new(),
    };
    let run = b
        .run(
            &mut ReferenceProjector::default(),
            &mut [&mut w, &mut expected],
        )
        .unwrap();
    let (frames_written, rows_written) = (w.frames_written(), w.rows_written());
    drop(w);
    let final_present = b.population.present_count(&run.q_final);
    assert!(
        final_present < b.population.len(),
        "the test needs people who left"
    );

    let conn = Connection::open(&path).unwrap();
    let got = rows_by_frame(&conn);
    let fd = frame_data(&conn);
    // 6 s at 10 fps: frames 0..=60, each in frame_data, numbered without gaps.
    assert_eq!(fd.len(), 61);
    assert_eq!(frames_written, 61);
    assert!(fd.iter().enumerate().all(|(i, (f, _))| *f == i as i64));
    let hash: i64 = scalar(&conn, "SELECT hash FROM geometry");
    assert!(fd.iter().all(|(_, h)| *h == hash));
    // Every row of every frame is exactly the run's present people, positions to the bit.
    let total: usize = expected.frames.values().map(Vec::len).sum();
    let rows: i64 = scalar(&conn, "SELECT count(*) FROM trajectory_data");
    assert_eq!(rows as usize, total);
    assert_eq!(rows_written as usize, total);
    for (frame, want) in &expected.frames {
        let have = got.get(frame).cloned().unwrap_or_default();
        assert_eq!(&have, want, "frame {frame}");
    }
    // Someone left: their id stops appearing, and is never seen again.
    let first = &expected.frames[&0];
    let last = &expected.frames[&60];
    assert_eq!(first.len(), 12);
    assert_eq!(last.len(), final_present);
    let distinct: i64 = scalar(&conn, "SELECT count(DISTINCT id) FROM trajectory_data");
    assert_eq!(distinct, 12);
    // Orientation: zero at frame 0, unit vectors (or zero when still) after.
    let mut st = conn
        .prepare("SELECT frame, ori_x, ori_y FROM trajectory_data")
        .unwrap();
    for row in st
        .query_map([], |r| {
            Ok((
                r.get::<_, i64>(0)?,
                r.get::<_, f64>(1)?,
                r.get::<_, f64>(2)?,
            ))
        })
        .unwrap()
    {
        let (f, ox, oy) = row.unwrap();
        let n = ox.hypot(oy);
        if f == 0 {
            assert_eq!(n, 0.0);
        } else {
            assert!(
                n == 0.0 || (n - 1.0).abs() < 1e-12,
                "frame {f}: |ori| = {n}"
            );
        }
    }
    // Every position written lies in the walkable area (the doorway's apron included), as
    // PedPy expects of a JuPedSim file.
    let walkable = WalkableArea::of_scene(&b.geometry, &b.population).unwrap();
    for (frame, people) in &got {
        for (id, x, y) in people {
            assert!(
                walkable.contains([*x, *y]),
                "frame {frame}: person {id} at ({x}, {y})"
            );
        }
    }
}

#[test]
fn an_old_file_and_its_stale_journal_are_replaced() {
    let b = built();
    let dir = temp_dir("replace");
    let path = dir.join("t.sqlite");
    std::fs::write(&path, "not a database").unwrap();
    let journal = dir.join("t.sqlite-journal");
    std::fs::write(&journal, "left by a killed run").unwrap();
    let mut w = writer(&b, &path);
    assert!(!journal.exists());
    w.on_finish(None).unwrap();
    let conn = Connection::open(&path).unwrap();
    assert_eq!(metadata(&conn, "version").as_deref(), Some("2"));
}

#[test]
fn a_failed_run_leaves_a_valid_file_up_to_its_last_frame() {
    let b = built();
    let dir = temp_dir("failed");
    let path = dir.join("t.sqlite");
    let mut w = writer(&b, &path).with_frames_per_commit(4);
    let failure = b
        .run(
            &mut ReferenceProjector::default(),
            &mut [&mut w, &mut FailAt(37)],
        )
        .unwrap_err();
    assert!(
        matches!(failure.error, SweepError::Observer { .. }),
        "{}",
        failure.error
    );
    drop(w);
    let conn = open_intact(&path);
    // Steps 1..=37 ran; frames are every 2 steps: 0..=18, all of them committed by on_finish.
    let fd = frame_data(&conn);
    assert_eq!(fd.len(), 19);
    assert_eq!(fd.last().unwrap().0, 18);
    let got = rows_by_frame(&conn);
    assert_eq!(got.len(), 19);
    assert!(got.values().all(|v| !v.is_empty()));
}

#[test]
fn a_writer_that_dies_mid_transaction_leaves_the_last_commit() {
    let b = built();
    let dir = temp_dir("died");
    let path = dir.join("t.sqlite");
    let mut w = writer(&b, &path).with_frames_per_commit(5);
    let panicked = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let _ = b.run(
            &mut ReferenceProjector::default(),
            &mut [&mut w, &mut PanicAt(29)],
        );
    }));
    assert!(panicked.is_err());
    // Frames 0..=14 were written (step 28 → frame 14); on_finish never ran. Frame 0 is
    // committed alone, then every 5 frames: 1..=5, 6..=10; frames 11..=14 are rolled back when
    // the connection closes with its transaction open, as SQLite does when a process dies.
    assert_eq!(w.frames_written(), 15);
    drop(w);
    let conn = open_intact(&path);
    let fd = frame_data(&conn);
    assert_eq!(
        fd.iter().map(|f| f.0).collect::<Vec<_>>(),
        (0..=10).collect::<Vec<_>>()
    );
    assert_eq!(rows_by_frame(&conn).len(), 11);
}

#[test]
fn unwritable_paths_and_uneven_frames_are_errors_before_the_run() {
    let b = built();
    let dir = temp_dir("errors");
    // A regular file where a directory should be (root can write anywhere, so permissions
    // would not test this).
    let blocker = dir.join("not-a-directory");
    std::fs::write(&blocker, "x").unwrap();
    let inside = blocker.join("out");
    let err = prepare_output_dir(&inside).unwrap_err();
    assert!(matches!(err, OutputError::Io { .. }));
    assert!(err.to_string().contains("not-a-directory"), "{err}");
    let walkable = WalkableArea::of_scene(&b.geometry, &b.population).unwrap();
    let err = SqliteTrajectoryWriter::create(
        inside.join("t.sqlite"),
        &walkable,
        b.population.clone(),
        0.0,
        0.05,
        0.1,
        "x",
    )
    .err()
    .unwrap();
    assert!(err.to_string().contains("not-a-directory"), "{err}");
    // 0.125 s is 2.5 steps of 0.05: no fixed frame rate.
    let err = SqliteTrajectoryWriter::create(
        dir.join("t.sqlite"),
        &walkable,
        b.population.clone(),
        0.0,
        0.05,
        0.125,
        "x",
    )
    .err()
    .unwrap();
    assert!(matches!(err, OutputError::FrameInterval { .. }), "{err}");
    assert!(err.to_string().contains("0.125"), "{err}");
}

#[test]
fn output_formats_key_is_parsed_and_checked_with_its_line() {
    assert_eq!(
        built().output.formats,
        vec![TrajectoryFormat::Sqlite, TrajectoryFormat::Csv]
    );
    let default = Scene::from_toml_str(
        "[room]\nrectangle = [0.0, 0.0, 4.0, 4.0]\n[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n",
        "default.toml",
    )
    .unwrap()
    .build(&Overrides::default())
    .unwrap();
    assert_eq!(default.output.formats, vec![TrajectoryFormat::Csv]);
    let empty = Scene::from_toml_str(
        "[room]\nrectangle = [0.0, 0.0, 4.0, 4.0]\n[[people]]\nposition = [1.0, 1.0]\nradius = 0.2\n[output]\nformats = []\n",
        "empty.toml",
    )
    .unwrap()
    .build(&Overrides::default())
    .err()
    .unwrap()
    .to_string();
    assert!(
        empty.contains("empty.toml:6") && empty.contains("formats"),
        "{empty}"
    );
    let unknown = Scene::from_toml_str(
        "[room]\nrectangle = [0.0, 0.0, 4.0, 4.0]\n[output]\nformats = [\"xml\"]\n",
        "unknown.toml",
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        unknown.contains("unknown.toml") && unknown.contains("xml"),
        "{unknown}"
    );
}

fn sweep(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn sweep_run_format_sqlite_writes_only_the_sqlite_trajectory() {
    let dir = temp_dir("cli");
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.join("out");
    let o = sweep(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--backend",
        "reference",
        "--t-end",
        "1",
        "--format",
        "sqlite",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("trajectory.sqlite").is_file());
    assert!(!out.join("trajectory.csv").exists());
    let conn = Connection::open(out.join("trajectory.sqlite")).unwrap();
    assert_eq!(frame_data(&conn).len(), 11);

    let blocker = dir.join("file");
    std::fs::write(&blocker, "x").unwrap();
    let o = sweep(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        blocker.join("sub").to_str().unwrap(),
        "--backend",
        "reference",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("file/sub") || err.contains("file"), "{err}");
    assert!(!err.contains("running `"), "failed before the run: {err}");
}

#[test]
fn every_shipped_scene_has_a_walkable_area() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes");
    let mut checked = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let b = Scene::from_file(&path)
            .unwrap()
            .build(&Overrides {
                t_end: Some(0.1),
                ..Default::default()
            })
            .unwrap();
        let w = WalkableArea::of_scene(&b.geometry, &b.population)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        // The room's area, plus an apron of exit width × largest radius per exit, minus the
        // static obstacles' holes (each smaller than the room).
        let room = shoelace(
            &b.geometry
                .room
                .iter()
                .chain(b.geometry.room.first())
                .copied()
                .collect::<Vec<_>>(),
        )
        .abs();
        let aprons: f64 = b
            .geometry
            .exits
            .iter()
            .map(|e| (e.b[0] - e.a[0]).hypot(e.b[1] - e.a[1]) * b.population.max_radius())
            .sum();
        let holes: f64 = w
            .holes
            .iter()
            .map(|h| shoelace(&h.iter().chain(h.first()).copied().collect::<Vec<_>>()).abs())
            .sum();
        assert!(
            (w.area() - (room + aprons - holes)).abs() < 1e-9 * room,
            "{}: {} vs {}",
            path.display(),
            w.area(),
            room + aprons - holes
        );
        let rings = parse_wkt_polygon(&w.to_wkt());
        assert_eq!(rings.len(), 1 + w.holes.len());
        checked += 1;
    }
    assert!(checked >= 5);
}
