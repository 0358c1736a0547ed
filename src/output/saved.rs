//! A run's directory read back as the state to go on from: its CSV trajectory (the people
//! present at each written state) and its people table (radii, who left, when and where).
//!
//! A run killed outright (a power cut, `kill -9`) leaves a trajectory whose last line may be
//! cut, and a people table written before its last departures. So the state is the last frame
//! the people table accounts for: everybody missing from it left by then (said by the table)
//! or has not arrived yet (never written before). Later frames, and a last line cut short,
//! are passed over and said ([`SavedRun::passed_over`]).

use super::people::{Departure, PEOPLE_FILE};
use crate::scene::{BuiltScene, ResumeError, ResumeState, TrajectoryFormat};
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// A saved run that cannot be resumed, with the file and line that say why.
#[derive(Debug, thiserror::Error)]
pub enum SavedRunError {
    /// A file cannot be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A line of a file is not of its form, or contradicts the other file.
    #[error("{}:{line}: {message}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// The line, from 1.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A file as a whole does not fit (no frame, another number of people…).
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The run wrote its trajectory as SQLite only, which rounds the time to its frame.
    #[error(
        "the run wrote no {csv} but a {sqlite}, which rounds the time to its frame: not a \
         state to go on from to the bit; --resume reads the CSV: run with --format csv or \
         --format csv,sqlite to be able to resume",
        csv = TrajectoryFormat::Csv.file_name(),
        sqlite = TrajectoryFormat::Sqlite.file_name()
    )]
    SqliteOnly,
    /// The scene refuses the state (someone present outside the room, gone inside it…), at
    /// the line the person was read from.
    #[error("{at}: {source}")]
    State {
        /// `file:line` of the person.
        at: String,
        /// What the scene says.
        source: Box<ResumeError>,
    },
}

/// One frame of a trajectory: its time, the line (1-based) of its first row, and each row's
/// `(id, x, y)` in the file's order (the people present then).
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Its time.
    pub t: f64,
    /// The line of its first row: row `k` is on line `line + k`.
    pub line: usize,
    /// `(id, x, y)`, row by row.
    pub rows: Vec<(usize, f64, f64)>,
}

impl Frame {
    /// The line of person `id`'s row, if the frame has one.
    pub fn line_of(&self, id: usize) -> Option<usize> {
        self.rows
            .iter()
            .position(|r| r.0 == id)
            .map(|k| self.line + k)
    }
}

/// One row of the people table: the radius, and the departure if the person left.
#[derive(Debug, Clone, PartialEq)]
pub struct SavedPerson {
    /// The radius.
    pub radius: f64,
    /// When and where they left.
    pub left: Option<Departure>,
}

/// What a resumed run reads from a run's directory: the first frame of its trajectory, to
/// tell whether it is a run of the scene at all, the frame to go on from, and its people.
#[derive(Debug, Clone, PartialEq)]
pub struct SavedRun {
    /// The CSV trajectory.
    pub trajectory: PathBuf,
    /// The people table.
    pub people_file: PathBuf,
    /// The first frame.
    pub first: Frame,
    /// The frame the state is taken from: the last one the people table accounts for.
    pub last: Frame,
    /// The people, from the people table.
    pub people: Vec<SavedPerson>,
    /// The state to resume from: the people present where the frame has them, those who had
    /// left where they left (when everybody had left, at the last departure).
    pub state: ResumeState,
    /// Who is neither in the frame nor said to have left, and was never written before it:
    /// not arrived yet (a scene's sources). Their place in `state` is set from the scene by
    /// [`resume`](Self::resume).
    pub absent: Vec<usize>,
    /// What was written after the state and passed over: the time of the last frame begun
    /// and whether its last line was cut short (a run killed while writing).
    pub passed_over: Option<PassedOver>,
}

/// Frames written after the state [`SavedRun`] resumes from, which the people table does
/// not account for (a run killed between two writes of it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PassedOver {
    /// The time of the last frame begun in the trajectory.
    pub last_t: f64,
    /// Whether the trajectory's last line was cut short.
    pub cut_line: bool,
}

impl SavedRun {
    /// Reads the run written to `dir` (its `trajectory.csv` and `people.csv`).
    ///
    /// # Errors
    /// A file cannot be read (or only the SQLite trajectory exists); a line that is not of
    /// its file's form (by its line); frames out of time order or a frame's ids not
    /// increasing; no frame at all; a person written in a frame after the time the people
    /// table says they left.
    pub fn read(dir: &Path) -> Result<Self, SavedRunError> {
        let trajectory = dir.join(TrajectoryFormat::Csv.file_name());
        let people_file = dir.join(PEOPLE_FILE);
        if !trajectory.exists() && dir.join(TrajectoryFormat::Sqlite.file_name()).exists() {
            return Err(SavedRunError::SqliteOnly);
        }
        Self::read_files(&trajectory, &people_file)
    }

    /// Reads a run from its trajectory and people table, wherever they are.
    ///
    /// # Errors
    /// As [`read`](Self::read).
    pub fn read_files(trajectory: &Path, people_file: &Path) -> Result<Self, SavedRunError> {
        // The trajectory is the run's main file: its absence is said first.
        std::fs::metadata(trajectory).map_err(|source| SavedRunError::Io {
            path: trajectory.to_path_buf(),
            source,
        })?;
        let people = read_people(people_file)?;
        let scan = scan_frames(trajectory, &people)?;
        // The first frame is always accounted for (nobody was written before it).
        let Some((last, absent)) = scan.resumable else {
            return Err(SavedRunError::File {
                path: trajectory.to_path_buf(),
                message: "no frame after the header".to_string(),
            });
        };
        let passed_over = match scan.last_t {
            Some(t) if t != last.t || scan.cut_line => Some(PassedOver {
                last_t: t,
                cut_line: scan.cut_line,
            }),
            _ => None,
        };
        let state = state_at(&last, &people);
        Ok(Self {
            trajectory: trajectory.to_path_buf(),
            people_file: people_file.to_path_buf(),
            first: scan.first.unwrap_or_else(|| last.clone()),
            last,
            people,
            state,
            absent,
            passed_over,
        })
    }

    /// Each person's departure before the state, for the resumed run's people table.
    pub fn departures(&self) -> Vec<Option<Departure>> {
        self.people
            .iter()
            .zip(&self.state.departed)
            .map(|(p, &gone)| p.left.filter(|_| gone))
            .collect()
    }

    /// Where person `i` of the state was read: their row of the frame, or, for anyone else,
    /// of the people table.
    pub fn place_of(&self, i: usize) -> String {
        match self.last.line_of(i) {
            Some(line) => format!("{}:{line}", self.trajectory.display()),
            None => format!("{}:{}", self.people_file.display(), i + 2),
        }
    }

    /// Sets `built` to the saved state, once it is known to be a state of this scene: the
    /// same people and radii, a first frame at the scene's start where the scene puts them,
    /// who is absent one the scene brings in later (put at their place, not arrived), and
    /// the state one the scene accepts ([`BuiltScene::resume_at`]).
    ///
    /// # Errors
    /// Another number of people or radius, a first frame that is not the scene's, someone
    /// absent whom the scene has from the start (a frame cut short, or another scene's run),
    /// and what [`BuiltScene::resume_at`] refuses: by the line each was read from.
    pub fn resume(&self, built: &mut BuiltScene) -> Result<(), SavedRunError> {
        let due = |i| built.population.due(i).is_some();
        let mut state = self.state.clone();
        let q0 = built.problem.q0();
        for &i in &self.absent {
            if !due(i) {
                return Err(SavedRunError::Line {
                    path: self.trajectory.clone(),
                    line: self.last.line,
                    message: format!(
                        "the frame at t = {} lists {} of {} people, and person {i}, missing, has \
                         not left ({}:{}): a frame cut short or a run of another scene",
                        self.last.t,
                        self.last.rows.len(),
                        self.people.len(),
                        self.people_file.display(),
                        i + 2
                    ),
                });
            }
            // Written absent at their place, as the library has who has not arrived yet.
            state.q[2 * i] = q0[2 * i];
            state.q[2 * i + 1] = q0[2 * i + 1];
            state.departed[i] = true;
        }
        self.check_start(
            built.problem.t0(),
            built.problem.q0(),
            built.population.radii(),
            due,
        )?;
        built
            .resume_at(state)
            .map_err(|source| SavedRunError::State {
                at: source.person().map_or_else(
                    || self.trajectory.display().to_string(),
                    |i| self.place_of(i),
                ),
                source: Box::new(source),
            })
    }

    /// Whether the run is one of the scene that starts at `start` with the people at `q0`
    /// and of radii `radii`: the people table has the scene's radii, and the first frame,
    /// when it is at the scene's start (a resumed run's trajectory starts later), lists
    /// everybody but who arrives later (`due`) where the scene puts them, to the bit the
    /// trajectory keeps.
    ///
    /// # Errors
    /// Another number of people or another radius, a first frame before the scene's start,
    /// or at it with someone missing or elsewhere: by its line.
    pub fn check_start(
        &self,
        start: f64,
        q0: &[f64],
        radii: &[f64],
        due: impl Fn(usize) -> bool,
    ) -> Result<(), SavedRunError> {
        let first = &self.first;
        let n = q0.len() / 2;
        let other = "the trajectory of another scene, or of this one with another --seed";
        let at = |path: &Path, line: usize, message: String| SavedRunError::Line {
            path: path.to_path_buf(),
            line,
            message,
        };
        if self.people.len() != n {
            return Err(SavedRunError::File {
                path: self.people_file.clone(),
                message: format!(
                    "lists {} people, the scene has {n}: {other}",
                    self.people.len()
                ),
            });
        }
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()));
        if let Some(i) = (0..n).find(|&i| !close(self.people[i].radius, radii[i])) {
            return Err(at(
                &self.people_file,
                i + 2,
                format!(
                    "person {i} has radius {}, the scene gives them {}: {other}",
                    self.people[i].radius, radii[i]
                ),
            ));
        }
        if first.t < start {
            return Err(at(
                &self.trajectory,
                first.line,
                format!(
                    "the first frame is at t = {}, before the scene's start t = {start}: {other}",
                    first.t
                ),
            ));
        }
        if first.t > start {
            return Ok(());
        }
        let expected: Vec<usize> = (0..n)
            .filter(|&i| !due(i) || first.line_of(i).is_some())
            .collect();
        if first.rows.len() != expected.len() {
            return Err(at(
                &self.trajectory,
                first.line,
                format!(
                    "the first frame (the scene's start, t = {}) lists {} people, the scene has \
                     {} there: {other}",
                    first.t,
                    first.rows.len(),
                    expected.len()
                ),
            ));
        }
        for (k, (&(id, x, y), &i)) in first.rows.iter().zip(&expected).enumerate() {
            let (x0, y0) = (q0[2 * i], q0[2 * i + 1]);
            if id != i || !close(x, x0) || !close(y, y0) {
                return Err(at(
                    &self.trajectory,
                    first.line + k,
                    format!(
                        "the first frame (the scene's start, t = {}) has person {id} at ({x}, \
                         {y}), where the scene starts person {i} at ({x0}, {y0}): {other}",
                        first.t
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// What a pass over the trajectory finds: its first frame, the last frame the people table
/// accounts for with who is absent from it unexplained, the time of the last frame begun,
/// and whether the last line was cut short.
struct Scan {
    first: Option<Frame>,
    resumable: Option<(Frame, Vec<usize>)>,
    last_t: Option<f64>,
    cut_line: bool,
}

/// Tolerance on a departure's time against a frame's: both are written from the same `f64`.
fn time_tolerance(t: f64) -> f64 {
    1e-9 * t.abs().max(1.0)
}

/// Reads the trajectory frame by frame, keeping the last one `people` accounts for.
fn scan_frames(path: &Path, people: &[SavedPerson]) -> Result<Scan, SavedRunError> {
    let io = |source| SavedRunError::Io {
        path: path.to_path_buf(),
        source,
    };
    let at = |line: usize, message: String| SavedRunError::Line {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut reader = std::io::BufReader::new(std::fs::File::open(path).map_err(io)?);
    let mut line = String::new();
    reader.read_line(&mut line).map_err(io)?;
    let fields = match line.trim_end_matches(['\n', '\r']) {
        "t,id,x,y" => 4,
        "t,id,x,y,pressure" => 5,
        other => {
            return Err(at(
                1,
                format!(
                    "expected the header `t,id,x,y` (or `t,id,x,y,pressure`) of `sweep run`'s \
                     trajectory, found {other:?}"
                ),
            ))
        }
    };
    let mut scan = Scan {
        first: None,
        resumable: None,
        last_t: None,
        cut_line: false,
    };
    let mut seen = vec![false; people.len()];
    let mut frame: Option<Frame> = None;
    let mut number = 1;
    loop {
        line.clear();
        if reader.read_line(&mut line).map_err(io)? == 0 {
            break;
        }
        number += 1;
        if !line.ends_with('\n') {
            // The run was killed while writing this line.
            scan.cut_line = true;
            break;
        }
        let text = line.trim_end_matches(['\n', '\r']);
        if text.is_empty() {
            continue;
        }
        let (t, row) = parse_row(text, fields).map_err(|m| at(number, format!("{text:?}: {m}")))?;
        if row.0 >= people.len() {
            return Err(at(
                number,
                format!("person {}, the people table has {}", row.0, people.len()),
            ));
        }
        match &mut frame {
            Some(f) if f.t == t => {
                let previous = f.rows.last().map_or(0, |r| r.0);
                if row.0 <= previous {
                    return Err(at(
                        number,
                        format!(
                            "person {} after person {previous} in the frame at t = {t}: the \
                             people of a frame are listed in increasing id order",
                            row.0
                        ),
                    ));
                }
                f.rows.push(row);
            }
            Some(f) if t < f.t => {
                return Err(at(
                    number,
                    format!(
                        "t = {t} comes after t = {}: frames must be in time order",
                        f.t
                    ),
                ))
            }
            _ => {
                let done = frame.replace(Frame {
                    t,
                    line: number,
                    rows: vec![row],
                });
                if let Some(done) = done {
                    scan.consider(done, people, &mut seen, path)?;
                }
            }
        }
    }
    if let Some(done) = frame {
        scan.consider(done, people, &mut seen, path)?;
    }
    Ok(scan)
}

impl Scan {
    /// Takes a whole frame: the first, the resumable one if `people` accounts for it.
    fn consider(
        &mut self,
        frame: Frame,
        people: &[SavedPerson],
        seen: &mut [bool],
        path: &Path,
    ) -> Result<(), SavedRunError> {
        let tol = time_tolerance(frame.t);
        let mut written = vec![false; people.len()];
        for &(id, ..) in &frame.rows {
            if let Some(d) = people[id].left.filter(|d| d.t <= frame.t + tol) {
                return Err(SavedRunError::Line {
                    path: path.to_path_buf(),
                    line: frame.line_of(id).unwrap_or(frame.line),
                    message: format!(
                        "person {id} is in the frame at t = {}, but the people table says they \
                         left at t = {}: the files of two runs",
                        frame.t, d.t
                    ),
                });
            }
            written[id] = true;
        }
        let mut absent = Vec::new();
        let mut accounted = true;
        for (i, person) in people.iter().enumerate() {
            if written[i] || person.left.is_some_and(|d| d.t <= frame.t + tol) {
                continue;
            }
            if seen[i] {
                // Written before, missing now, and not said to have left: the people table
                // was written before this frame (or the frame is cut short).
                accounted = false;
            } else {
                absent.push(i);
            }
        }
        for (s, w) in seen.iter_mut().zip(&written) {
            *s |= w;
        }
        self.last_t = Some(frame.t);
        if self.first.is_none() {
            self.first = Some(frame.clone());
        }
        if accounted {
            self.resumable = Some((frame, absent));
        }
        Ok(())
    }
}

/// The state at `frame`: who is in it where it has them, who had left where they left; when
/// everybody had left, at the last departure (where a run stops when the room is empty).
fn state_at(frame: &Frame, people: &[SavedPerson]) -> ResumeState {
    let everybody_left = people.iter().all(|p| p.left.is_some());
    let t = if everybody_left {
        people
            .iter()
            .filter_map(|p| p.left.map(|d| d.t))
            .fold(frame.t, f64::max)
    } else {
        frame.t
    };
    let tol = time_tolerance(t);
    let mut q = vec![0.0; 2 * people.len()];
    let mut departed = vec![false; people.len()];
    for &(id, x, y) in &frame.rows {
        q[2 * id] = x;
        q[2 * id + 1] = y;
    }
    for (i, person) in people.iter().enumerate() {
        if let Some(d) = person.left.filter(|d| d.t <= t + tol) {
            q[2 * i] = d.position[0];
            q[2 * i + 1] = d.position[1];
            departed[i] = true;
        }
    }
    ResumeState { t, q, departed }
}

/// `people.csv`: `id,radius,t_left,x_left,y_left`, one row per person in id order.
fn read_people(path: &Path) -> Result<Vec<SavedPerson>, SavedRunError> {
    let text = std::fs::read_to_string(path).map_err(|source| SavedRunError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let at = |line: usize, message: String| SavedRunError::Line {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default();
    if header != "id,radius,t_left,x_left,y_left" {
        return Err(at(
            1,
            format!(
                "expected the header `id,radius,t_left,x_left,y_left` of `sweep run`'s people \
                 table, found {header:?}"
            ),
        ));
    }
    let mut people = Vec::new();
    for (k, line) in lines.enumerate() {
        let parsed =
            parse_person(line, people.len()).map_err(|m| at(k + 2, format!("{line:?}: {m}")))?;
        people.push(parsed);
    }
    Ok(people)
}

/// A number of a row, finite.
fn number(name: &str, v: &str) -> Result<f64, String> {
    let parsed: f64 = v
        .trim()
        .parse()
        .map_err(|_| format!("{name} = {v:?} is not a number"))?;
    if !parsed.is_finite() {
        return Err(format!("{name} = {v} is not finite"));
    }
    Ok(parsed)
}

/// `id,radius,t_left,x_left,y_left` of person `expected`.
fn parse_person(line: &str, expected: usize) -> Result<SavedPerson, String> {
    let fields: Vec<&str> = line.split(',').collect();
    let [id, radius, t, x, y] = fields[..] else {
        return Err(format!("expected 5 fields, found {}", fields.len()));
    };
    if id.trim().parse::<usize>().ok() != Some(expected) {
        return Err(format!(
            "id = {id:?} where person {expected} belongs: every person, in id order"
        ));
    }
    let radius = number("radius", radius)?;
    if radius <= 0.0 {
        return Err(format!("radius = {radius} is not positive"));
    }
    let left = match (t.trim(), x.trim(), y.trim()) {
        ("", "", "") => None,
        _ => Some(Departure {
            t: number("t_left", t)?,
            position: [number("x_left", x)?, number("y_left", y)?],
        }),
    };
    Ok(SavedPerson { radius, left })
}

/// `t,id,x,y[,pressure]` as `(t, (id, x, y))`.
fn parse_row(line: &str, expected: usize) -> Result<(f64, (usize, f64, f64)), String> {
    let fields: Vec<&str> = line.split(',').collect();
    if fields.len() != expected {
        return Err(format!(
            "expected {expected} fields, found {}",
            fields.len()
        ));
    }
    let id: usize = fields[1]
        .trim()
        .parse()
        .map_err(|_| format!("id = {:?} is not a person's number", fields[1]))?;
    Ok((
        number("t", fields[0])?,
        (id, number("x", fields[2])?, number("y", fields[3])?),
    ))
}

#[cfg(test)]
#[path = "saved_tests.rs"]
mod tests;
