//! The trajectory in JuPedSim's SQLite trajectory format, which PedPy
//! (`load_trajectory_from_jupedsim_sqlite`, `load_walkable_area_from_jupedsim_sqlite`) and
//! JuPedSim's viewer read.
//!
//! The schema, as JuPedSim's `SqliteTrajectoryWriter`
//! (`python_modules/jupedsim/jupedsim/sqlite_serialization.py`) creates it for database
//! **version 2**:
//!
//! ```sql
//! CREATE TABLE trajectory_data (frame INTEGER NOT NULL, id INTEGER NOT NULL,
//!     pos_x REAL NOT NULL, pos_y REAL NOT NULL, ori_x REAL NOT NULL, ori_y REAL NOT NULL)
//! CREATE TABLE metadata(key TEXT NOT NULL UNIQUE PRIMARY KEY, value TEXT NOT NULL)
//!     -- keys: version, fps, and xmin, xmax, ymin, ymax (the geometry's bounds)
//! CREATE TABLE geometry(hash INTEGER NOT NULL, wkt TEXT NOT NULL)
//! CREATE UNIQUE INDEX geometry_hash on geometry(hash)
//! CREATE TABLE frame_data(frame INTEGER NOT NULL, geometry_hash INTEGER NOT NULL)
//! CREATE INDEX frame_id_idx ON trajectory_data(frame, id)
//! ```
//!
//! Why version 2 and not JuPedSim's current 3 (which only drops `ori_x`, `ori_y`): PedPy 1.5.1
//! (`pedpy/io/jupedsim_loader.py`) loads the walkable area of versions 1 and 2 only ("Supported
//! are versions: 1, 2"), while JuPedSim upgrades a version-2 file to 3 in place when it opens
//! it (`convert_database_v2_to_v3` only changes the version number). Version 2 is the one both
//! read.
//!
//! What we write in it:
//!
//! * `frame` = step / `every`, so frame `n` is the state at `t₀ + n·every·h`, and
//!   `fps = 1 / (every·h)`; a run's last state, when it is not on that grid, is not written
//!   (the CSV has it);
//! * `id` = the person's index (the same as in `trajectory.csv`), positions in metres;
//! * `ori_x, ori_y` = the unit direction of the person's displacement since the previous frame,
//!   `(0, 0)` at the first frame and for someone who did not move;
//! * only people **present** in the room (their disk not wholly outside): JuPedSim removes an
//!   agent that reaches its exit and writes no more rows for it, and so do we;
//! * one `frame_data` row per frame (also when nobody is left), pointing at the single
//!   geometry row: the [`WalkableArea`] as WKT, whose hash is a 64-bit FNV-1a of the text
//!   (JuPedSim uses Python's `hash`, which is only an identifier);
//! * a few metadata keys of our own (`generator`, `scene`, `h`), which readers ignore;
//! * tables of our own, which readers ignore too: `people(id, radius, t_left, x_left,
//!   y_left)`, each person's radius and when and where they left (`NULL` while they have
//!   not), as `people.csv` has them; and, with the contact forces
//!   ([`SqliteTrajectoryWriter::with_contact_forces`]), `pressure(frame, id, pressure)` and
//!   `contacts(frame, a, b, kind, force)` for each frame after the first.
//!
//! Streaming: the schema and the geometry are committed when the writer is created (so a path
//! that cannot be written fails before the run), then frames go in transactions of
//! `frames_per_commit` frames; nothing is held in memory but the open transaction's pages and
//! the previous frame's positions. A run that fails is committed up to its last frame in
//! `on_finish`; a process that dies mid-transaction leaves the file as of the last commit
//! (SQLite rolls the open transaction back), still valid.

use super::contacts::{self, ContactKinds};
use super::people::{Departure, DepartureLog};
use super::{OutputError, WalkableArea};
use crate::crowd::Population;
use crate::error::SweepError;
use crate::stepper::{Observer, ObserverError, StepReport};
use rusqlite::{params, Connection};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The JuPedSim trajectory database version written (see the module's documentation).
pub const JUPEDSIM_DATABASE_VERSION: u32 = 2;

/// Frames per transaction unless [`SqliteTrajectoryWriter::with_frames_per_commit`] says
/// otherwise.
pub const DEFAULT_FRAMES_PER_COMMIT: usize = 10;

/// 64-bit FNV-1a of the WKT, as the geometry's hash.
fn fnv1a(text: &str) -> i64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h as i64
}

/// Writes the trajectory into a JuPedSim SQLite trajectory file as the run goes.
pub struct SqliteTrajectoryWriter {
    path: PathBuf,
    conn: Option<Connection>,
    population: Arc<Population>,
    every: usize,
    t0: f64,
    h: f64,
    frames_per_commit: usize,
    frames_in_transaction: usize,
    geometry_hash: i64,
    previous: Vec<f64>,
    frames: usize,
    rows: u64,
    departures: DepartureLog,
    /// People seen leaving since the last frame, written with the next one.
    pending: Vec<usize>,
    forces: Option<(ContactKinds, Vec<f64>)>,
}

impl SqliteTrajectoryWriter {
    /// [`Self::create`] for a run of `built`: its people, start time, step, trajectory
    /// interval and name.
    ///
    /// # Errors
    /// As [`Self::create`].
    pub fn for_scene(
        path: impl Into<PathBuf>,
        walkable: &WalkableArea,
        built: &crate::scene::BuiltScene,
    ) -> Result<Self, OutputError> {
        Self::create(
            path,
            walkable,
            built.population.clone(),
            built.problem.t0(),
            built.settings.h,
            built.output.trajectory_every,
            &built.name,
        )
    }

    /// Creates (or replaces) the file at `path` with the schema, the metadata and the walkable
    /// area, for a run of step `h` from `t0` writing a frame every `trajectory_every`
    /// seconds.
    ///
    /// # Errors
    /// [`OutputError::FrameInterval`] when `trajectory_every` is not a whole number of steps
    /// (the frames would not be at the rate asked for), [`OutputError::Io`] or
    /// [`OutputError::Sqlite`] when the file cannot be created or written.
    pub fn create(
        path: impl Into<PathBuf>,
        walkable: &WalkableArea,
        population: Arc<Population>,
        t0: f64,
        h: f64,
        trajectory_every: f64,
        scene: &str,
    ) -> Result<Self, OutputError> {
        let path = path.into();
        let every = super::sqlite_frame_steps(trajectory_every, h)?;
        let fps = 1.0 / (every as f64 * h);
        // A new file, not tables dropped in an old one. A journal left beside the old file by
        // a killed run goes too: SQLite would take it for the new file's own hot journal and
        // "roll back" pages of another database into it.
        let mut journal = path.clone().into_os_string();
        journal.push("-journal");
        for old in [path.clone(), PathBuf::from(journal)] {
            if old.exists() {
                std::fs::remove_file(&old).map_err(|e| OutputError::Io {
                    path: old.clone(),
                    message: format!("cannot replace the old file: {e}"),
                })?;
            }
        }
        let sql = |e: rusqlite::Error| OutputError::Sqlite {
            path: path.clone(),
            message: e.to_string(),
        };
        let conn = Connection::open(&path).map_err(sql)?;
        // The default rollback journal: a commit is atomic, so the file is valid after any
        // crash; `synchronous = NORMAL` skips the fsyncs that only matter on power loss.
        conn.execute_batch("PRAGMA synchronous = NORMAL;")
            .map_err(sql)?;
        let wkt = walkable.to_wkt();
        let geometry_hash = fnv1a(&wkt);
        let [xmin, ymin, xmax, ymax] = walkable.bounds();
        let fmt = crate::numbers::display_number;
        conn.execute_batch(
            "BEGIN;
             CREATE TABLE trajectory_data (frame INTEGER NOT NULL, id INTEGER NOT NULL, \
                 pos_x REAL NOT NULL, pos_y REAL NOT NULL, ori_x REAL NOT NULL, \
                 ori_y REAL NOT NULL);
             CREATE TABLE metadata(key TEXT NOT NULL UNIQUE PRIMARY KEY, value TEXT NOT NULL);
             CREATE TABLE geometry(hash INTEGER NOT NULL, wkt TEXT NOT NULL);
             CREATE UNIQUE INDEX geometry_hash on geometry(hash);
             CREATE TABLE frame_data(frame INTEGER NOT NULL, geometry_hash INTEGER NOT NULL);
             CREATE INDEX frame_id_idx ON trajectory_data(frame, id);
             CREATE TABLE people(id INTEGER PRIMARY KEY, radius REAL NOT NULL, t_left REAL, \
                 x_left REAL, y_left REAL);",
        )
        .map_err(sql)?;
        {
            let mut person = conn
                .prepare("INSERT INTO people(id, radius) VALUES(?1, ?2)")
                .map_err(sql)?;
            for (i, r) in population.radii().iter().enumerate() {
                person.execute(params![i as i64, r]).map_err(sql)?;
            }
        }
        {
            let mut meta = conn
                .prepare("INSERT INTO metadata VALUES(?1, ?2)")
                .map_err(sql)?;
            for (k, v) in [
                ("version", JUPEDSIM_DATABASE_VERSION.to_string()),
                ("fps", format!("{fps:?}")),
                ("xmin", format!("{xmin:?}")),
                ("xmax", format!("{xmax:?}")),
                ("ymin", format!("{ymin:?}")),
                ("ymax", format!("{ymax:?}")),
                (
                    "generator",
                    format!("sweeping {}", env!("CARGO_PKG_VERSION")),
                ),
                ("scene", scene.to_string()),
                ("h", fmt(h)),
            ] {
                meta.execute(params![k, v]).map_err(sql)?;
            }
        }
        conn.execute(
            "INSERT INTO geometry VALUES(?1, ?2)",
            params![geometry_hash, wkt],
        )
        .map_err(sql)?;
        conn.execute_batch("COMMIT;").map_err(sql)?;
        Ok(Self {
            path,
            conn: Some(conn),
            every,
            t0,
            h,
            frames_per_commit: DEFAULT_FRAMES_PER_COMMIT,
            frames_in_transaction: 0,
            geometry_hash,
            previous: Vec::new(),
            frames: 0,
            rows: 0,
            departures: DepartureLog::new(population.len(), &[]),
            pending: Vec::new(),
            population,
            forces: None,
        })
    }

    /// The departures an earlier run saw, for a run resumed from it: written in `people` now.
    ///
    /// # Errors
    /// [`OutputError::Sqlite`] when the table cannot be written.
    pub fn with_departures_before(
        mut self,
        before: &[Option<Departure>],
    ) -> Result<Self, OutputError> {
        self.departures = DepartureLog::new(self.population.len(), before);
        let pending: Vec<usize> = (0..self.population.len())
            .filter(|&i| self.departures.get(i).is_some())
            .collect();
        if let Some(conn) = self.conn.as_ref() {
            self.write_departures(conn, &pending)
                .map_err(|message| OutputError::Sqlite {
                    path: self.path.clone(),
                    message,
                })?;
        }
        Ok(self)
    }

    /// Writes the contact forces too: the tables `pressure(frame, id, pressure)` (each person
    /// present) and `contacts(frame, a, b, kind, force)` (`b` `NULL` for a wall or obstacle)
    /// for every frame after the first, `kinds` saying what each family keeps apart. The run
    /// must keep its contacts
    /// ([`StepperSettings::record_contacts`](crate::stepper::StepperSettings::record_contacts)).
    ///
    /// # Errors
    /// [`OutputError::Sqlite`] when the tables cannot be created.
    pub fn with_contact_forces(mut self, kinds: ContactKinds) -> Result<Self, OutputError> {
        if let Some(conn) = self.conn.as_ref() {
            conn.execute_batch(
                "CREATE TABLE pressure(frame INTEGER NOT NULL, id INTEGER NOT NULL, \
                     pressure REAL NOT NULL);
                 CREATE TABLE contacts(frame INTEGER NOT NULL, a INTEGER NOT NULL, b INTEGER, \
                     kind TEXT NOT NULL, force REAL NOT NULL);",
            )
            .map_err(|e| OutputError::Sqlite {
                path: self.path.clone(),
                message: e.to_string(),
            })?;
        }
        self.forces = Some((kinds, Vec::new()));
        Ok(self)
    }

    /// Sets `people`'s departure columns of `who`.
    fn write_departures(&self, conn: &Connection, who: &[usize]) -> Result<(), String> {
        let mut update = conn
            .prepare_cached("UPDATE people SET t_left = ?2, x_left = ?3, y_left = ?4 WHERE id = ?1")
            .map_err(|e| self.err(e))?;
        for &i in who {
            if let Some(d) = self.departures.get(i) {
                update
                    .execute(params![i as i64, d.t, d.position[0], d.position[1]])
                    .map_err(|e| self.err(format!("person {i}: {e}")))?;
            }
        }
        Ok(())
    }

    /// The frame's pressures and contacts, from the step that made it.
    fn insert_forces(
        &mut self,
        conn: &Connection,
        frame: usize,
        q: &[f64],
        report: &StepReport,
    ) -> Result<(), String> {
        let Some((kinds, pressure)) = self.forces.as_mut() else {
            return Ok(());
        };
        let pop = &self.population;
        contacts::pressures(report, pop.len(), pressure);
        let err = |e: rusqlite::Error| format!("{}: frame {frame}: {e}", self.path.display());
        let mut insert = conn
            .prepare_cached("INSERT INTO pressure VALUES(?1, ?2, ?3)")
            .map_err(err)?;
        for i in (0..pop.len()).filter(|&i| pop.is_present(q, i)) {
            insert
                .execute(params![frame as i64, i as i64, pressure[i]])
                .map_err(err)?;
        }
        let mut insert = conn
            .prepare_cached("INSERT INTO contacts VALUES(?1, ?2, ?3, ?4, ?5)")
            .map_err(err)?;
        for c in kinds.forces(report) {
            insert
                .execute(params![
                    frame as i64,
                    c.a as i64,
                    c.b.map(|b| b as i64),
                    c.with.as_str(),
                    c.force
                ])
                .map_err(err)?;
        }
        Ok(())
    }

    /// Commits every `n` frames (at least 1; default [`DEFAULT_FRAMES_PER_COMMIT`]).
    #[must_use]
    pub fn with_frames_per_commit(mut self, n: usize) -> Self {
        self.frames_per_commit = n.max(1);
        self
    }

    /// Where it writes.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Steps between frames.
    pub fn steps_per_frame(&self) -> usize {
        self.every
    }

    /// Frames written so far.
    pub fn frames_written(&self) -> usize {
        self.frames
    }

    /// Trajectory rows written so far.
    pub fn rows_written(&self) -> u64 {
        self.rows
    }

    fn err(&self, e: impl std::fmt::Display) -> String {
        format!("{}: {e}", self.path.display())
    }

    fn write_frame(
        &mut self,
        frame: usize,
        q: &[f64],
        report: Option<&StepReport>,
    ) -> Result<(), String> {
        let Some(conn) = self.conn.take() else {
            return Ok(());
        };
        let written = self.write_frame_on(&conn, frame, q, report);
        self.conn = Some(conn);
        written?;
        self.frames += 1;
        self.frames_in_transaction += 1;
        if self.frames_in_transaction >= self.frames_per_commit {
            self.commit()?;
        }
        Ok(())
    }

    fn write_frame_on(
        &mut self,
        conn: &Connection,
        frame: usize,
        q: &[f64],
        report: Option<&StepReport>,
    ) -> Result<(), String> {
        if self.frames_in_transaction == 0 {
            conn.execute_batch("BEGIN;").map_err(|e| self.err(e))?;
        }
        // A frame goes in whole or not at all: a write that fails half-way is rolled back to
        // this savepoint, and the frames before it are still committed in `on_finish`.
        conn.execute_batch("SAVEPOINT frame;")
            .map_err(|e| self.err(e))?;
        let inserted = self.insert_frame(conn, frame, q).and_then(|rows| {
            if let Some(report) = report {
                self.insert_forces(conn, frame, q, report)?;
            }
            self.write_departures(conn, &self.pending)?;
            Ok(rows)
        });
        match inserted {
            Ok(rows) => {
                conn.execute_batch("RELEASE frame;")
                    .map_err(|e| self.err(e))?;
                self.rows += rows;
                self.pending.clear();
            }
            Err(e) => {
                let _ = conn.execute_batch("ROLLBACK TO frame; RELEASE frame;");
                return Err(e);
            }
        }
        self.previous.clear();
        self.previous.extend_from_slice(q);
        Ok(())
    }

    fn insert_frame(&self, conn: &Connection, frame: usize, q: &[f64]) -> Result<u64, String> {
        let pop = &self.population;
        let first = self.previous.is_empty();
        let mut rows = 0u64;
        let mut insert = conn
            .prepare_cached("INSERT INTO trajectory_data VALUES(?1, ?2, ?3, ?4, ?5, ?6)")
            .map_err(|e| self.err(e))?;
        for i in 0..pop.len() {
            if !pop.is_present(q, i) {
                continue;
            }
            let (x, y) = (q[2 * i], q[2 * i + 1]);
            let (ox, oy) = if first {
                (0.0, 0.0)
            } else {
                let (dx, dy) = (x - self.previous[2 * i], y - self.previous[2 * i + 1]);
                let n = dx.hypot(dy);
                if n > 1e-12 {
                    (dx / n, dy / n)
                } else {
                    (0.0, 0.0)
                }
            };
            insert
                .execute(params![frame as i64, i as i64, x, y, ox, oy])
                .map_err(|e| self.err(format!("frame {frame}, person {i}: {e}")))?;
            rows += 1;
        }
        conn.execute(
            "INSERT INTO frame_data VALUES(?1, ?2)",
            params![frame as i64, self.geometry_hash],
        )
        .map_err(|e| self.err(format!("frame {frame}: {e}")))?;
        Ok(rows)
    }

    fn commit(&mut self) -> Result<(), String> {
        if self.frames_in_transaction == 0 {
            return Ok(());
        }
        if let Some(conn) = self.conn.as_ref() {
            conn.execute_batch("COMMIT;").map_err(|e| self.err(e))?;
        }
        self.frames_in_transaction = 0;
        Ok(())
    }
}

impl Observer for SqliteTrajectoryWriter {
    fn name(&self) -> &str {
        "sqlite trajectory writer"
    }

    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        let population = self.population.clone();
        self.pending = self.departures.update(&population, t, q);
        self.write_frame(0, q, None)?;
        // The first frame on disk at once: a run that dies early still leaves a loadable file.
        Ok(self.commit()?)
    }

    fn on_step(&mut self, report: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        let population = self.population.clone();
        let new = self.departures.update(&population, report.t, q);
        self.pending.extend(new);
        let k = report.step + 1;
        if !k.is_multiple_of(self.every) {
            return Ok(());
        }
        // The last step of a horizon that is not a whole number of steps is shorter: its state
        // is not on the frame grid.
        let on_grid = self.t0 + k as f64 * self.h;
        if (report.t - on_grid).abs() > 1e-9 * on_grid.abs().max(1.0) {
            return Ok(());
        }
        Ok(self.write_frame(k / self.every, q, Some(report))?)
    }

    fn on_finish(&mut self, _error: Option<&SweepError>) -> Result<(), ObserverError> {
        // Departures seen after the last frame.
        if let Some(conn) = self.conn.take() {
            let written = self.write_departures(&conn, &self.pending);
            self.conn = Some(conn);
            written?;
            self.pending.clear();
        }
        self.commit()?;
        if let Some(conn) = self.conn.take() {
            conn.close().map_err(|(_, e)| self.err(e))?;
        }
        Ok(())
    }
}
