//! `sweep run --resume DIR`: the state a run left in `DIR`, read back from the last frame of
//! its `trajectory.csv` (which `sweep run` writes at the last step it finished, also when it
//! was interrupted or failed) and its `people.csv` (who had left, when and where: the
//! trajectory writes nobody after they left).

use anyhow::{bail, Context, Result};
use std::io::BufRead;
use std::path::{Path, PathBuf};
use sweeping::output::{Departure, TrajectoryFormat, PEOPLE_FILE};
use sweeping::scene::ResumeState;

/// The trajectory file a resumed run reads: the one `sweep run` writes as CSV.
pub const TRAJECTORY: &str = TrajectoryFormat::Csv.file_name();

/// The people table a resumed run reads beside it.
pub const PEOPLE: &str = PEOPLE_FILE;

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

/// One row of `people.csv`: the radius, and the departure if the person left.
#[derive(Debug, Clone, PartialEq)]
pub struct Person {
    /// The radius.
    pub radius: f64,
    /// When and where they left.
    pub left: Option<Departure>,
}

/// What a resumed run reads from a run's directory: the first frame of its trajectory, to
/// tell whether it is a run of the scene at all, its last, the state to go on from, and its
/// people.
#[derive(Debug, Clone, PartialEq)]
pub struct Saved {
    /// The first frame.
    pub first: Frame,
    /// The last frame (the first too, when there is one frame only).
    pub last: Frame,
    /// The people, from `people.csv`.
    pub people: Vec<Person>,
    /// The last frame as the state to resume from: the people present where it has them,
    /// those who had left where they left.
    pub state: ResumeState,
    /// Who is neither in the last frame nor said to have left: not arrived yet, or missing
    /// from a frame cut short. Their place in `state` is unset until
    /// [`place_absent`](Self::place_absent).
    pub absent: Vec<usize>,
}

impl Saved {
    /// Places who is absent from the last frame: someone the scene brings in later (`due`)
    /// has not arrived yet and is put at their place in `q0`, written absent as the library's
    /// [`ResumeState`] has them; anyone else was lost from a frame cut short.
    ///
    /// # Errors
    /// Someone absent whom the scene has from the start, by the last frame's line.
    pub fn place_absent(
        &mut self,
        due: impl Fn(usize) -> bool,
        q0: &[f64],
        (trajectory, people): (&Path, &Path),
    ) -> Result<()> {
        for &i in &self.absent {
            if !due(i) {
                bail!(
                    "{}:{}: the last frame (t = {}) lists {} of {} people, and person {i}, \
                        missing, has not left ({}:{}): a frame cut short (a run killed while \
                        writing it) or a run of another scene",
                    trajectory.display(),
                    self.last.line,
                    self.last.t,
                    self.last.rows.len(),
                    self.people.len(),
                    people.display(),
                    i + 2
                );
            }
            self.state.q[2 * i] = q0[2 * i];
            self.state.q[2 * i + 1] = q0[2 * i + 1];
            self.state.departed[i] = true;
        }
        Ok(())
    }

    /// Each person's departure before the state, for the resumed run's people table.
    pub fn departures(&self) -> Vec<Option<Departure>> {
        self.people
            .iter()
            .zip(&self.state.departed)
            .map(|(p, &gone)| p.left.filter(|_| gone))
            .collect()
    }

    /// Where person `i` of the state was read: their row of the last frame, or, for who had
    /// left, of the people table.
    pub fn place_of(&self, i: usize, trajectory: &Path, people: &Path) -> String {
        match self.last.line_of(i) {
            Some(line) => format!("{}:{line}", trajectory.display()),
            None => format!("{}:{}", people.display(), i + 2),
        }
    }
}

/// The run's `trajectory.csv` (`t,id,x,y`, maybe `pressure`; frames in time order, each
/// listing the people present in id order) and `people.csv`, combined into the state of the
/// last frame (or, when everybody had left, of the last departure). Whether it fits the scene is checked when the scene takes it ([`check_start`],
/// [`sweeping::scene::BuiltScene::resume_at`]).
///
/// # Errors
/// A file cannot be read; a line that is not of its file's form (by its line); a last frame
/// whose ids are not increasing; no frame at all; a person listed in the last frame though
/// the people table says they had left.
pub fn read(trajectory: &Path, people: &Path) -> Result<Saved> {
    let (first, last) = read_frames(trajectory)?;
    let table = read_people(people)?;
    if let Some(&(id, ..)) = last.rows.iter().find(|r| r.0 >= table.len()) {
        bail!(
            "{}:{}: the last frame (t = {}) lists person {id}, {} has {} people",
            trajectory.display(),
            last.line_of(id).unwrap_or(last.line),
            last.t,
            people.display(),
            table.len()
        );
    }
    // A frame without anybody has no rows: when everybody had left, the state is at the last
    // departure (where a run stops when the room is empty), after the last frame written.
    let t = match table
        .iter()
        .map(|p| p.left.map(|d| d.t))
        .collect::<Option<Vec<f64>>>()
    {
        Some(times) => times.into_iter().fold(last.t, f64::max),
        None => last.t,
    };
    let mut q = vec![0.0; 2 * table.len()];
    let mut departed = vec![false; table.len()];
    let mut absent = Vec::new();
    let tol = 1e-9 * t.abs().max(1.0);
    for (i, person) in table.iter().enumerate() {
        let row = last.rows.iter().find(|r| r.0 == i);
        let left = person.left.filter(|d| d.t <= t + tol);
        match (row, left) {
            (Some(&(_, x, y)), None) => {
                q[2 * i] = x;
                q[2 * i + 1] = y;
            }
            (Some(_), Some(d)) if d.t <= last.t + tol => bail!(
                "{}:{}: person {i} is in the last frame (t = {}), but {}:{} says they left at \
                    t = {}: the files of two runs",
                trajectory.display(),
                last.line_of(i).unwrap_or(last.line),
                last.t,
                people.display(),
                i + 2,
                d.t
            ),
            (_, Some(d)) => {
                q[2 * i] = d.position[0];
                q[2 * i + 1] = d.position[1];
                departed[i] = true;
            }
            // Not yet arrived (a scene's sources) or a frame cut short: the scene tells
            // which ([`Saved::place_absent`]).
            (None, None) => absent.push(i),
        }
    }
    let state = ResumeState { t, q, departed };
    Ok(Saved {
        first,
        last,
        people: table,
        state,
        absent,
    })
}

/// The first and last frames of the CSV trajectory `path`.
fn read_frames(path: &Path) -> Result<(Frame, Frame)> {
    let file = std::fs::File::open(path).with_context(|| format!("{}", path.display()))?;
    let mut lines = std::io::BufReader::new(file).lines();
    let header = lines
        .next()
        .transpose()
        .with_context(|| format!("{}", path.display()))?;
    let fields = match header.as_deref() {
        Some("t,id,x,y") => 4,
        Some("t,id,x,y,pressure") => 5,
        _ => bail!(
            "{}:1: expected the header `t,id,x,y` (or `t,id,x,y,pressure`) of `sweep run`'s \
                trajectory, found {:?}",
            path.display(),
            header.unwrap_or_default()
        ),
    };
    // The first frame, once a second one starts, and the frame being read.
    let mut first: Option<Frame> = None;
    let mut frame: Option<Frame> = None;
    for (k, line) in lines.enumerate() {
        let number = k + 2;
        let line = line.with_context(|| format!("{}:{number}", path.display()))?;
        if line.is_empty() {
            continue;
        }
        let (t, row) = parse_row(&line, fields)
            .with_context(|| format!("{}:{number}: {line:?}", path.display()))?;
        match &mut frame {
            Some(f) if f.t == t => {
                let previous = f.rows.last().map_or(0, |r| r.0);
                if row.0 <= previous {
                    bail!(
                        "{}:{number}: person {} after person {previous} in the frame at t = {t}: \
                            the people of a frame are listed in increasing id order",
                        path.display(),
                        row.0
                    );
                }
                f.rows.push(row);
            }
            Some(f) if t < f.t => bail!(
                "{}:{number}: t = {t} comes after t = {}: frames must be in time order",
                path.display(),
                f.t
            ),
            _ => {
                let done = frame.replace(Frame {
                    t,
                    line: number,
                    rows: vec![row],
                });
                if first.is_none() {
                    first = done;
                }
            }
        }
    }
    let Some(last) = frame else {
        bail!("{}: no frame after the header", path.display());
    };
    Ok((first.unwrap_or_else(|| last.clone()), last))
}

/// `people.csv`: `id,radius,t_left,x_left,y_left`, one row per person in id order.
fn read_people(path: &Path) -> Result<Vec<Person>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default();
    if header != "id,radius,t_left,x_left,y_left" {
        bail!(
            "{}:1: expected the header `id,radius,t_left,x_left,y_left` of `sweep run`'s \
                people table, found {header:?}",
            path.display()
        );
    }
    let mut people = Vec::new();
    for (k, line) in lines.enumerate() {
        let number = k + 2;
        let parsed = parse_person(line, people.len())
            .with_context(|| format!("{}:{number}: {line:?}", path.display()))?;
        people.push(parsed);
    }
    Ok(people)
}

/// A number of a row, finite.
fn number(name: &str, v: &str) -> Result<f64> {
    let parsed: f64 = v
        .trim()
        .parse()
        .with_context(|| format!("{name} = {v:?} is not a number"))?;
    if !parsed.is_finite() {
        bail!("{name} = {v} is not finite");
    }
    Ok(parsed)
}

/// `id,radius,t_left,x_left,y_left` of person `expected`.
fn parse_person(line: &str, expected: usize) -> Result<Person> {
    let fields: Vec<&str> = line.split(',').collect();
    let [id, radius, t, x, y] = fields[..] else {
        bail!("expected 5 fields, found {}", fields.len());
    };
    if id.trim().parse::<usize>().ok() != Some(expected) {
        bail!("id = {id:?} where person {expected} belongs: every person, in id order");
    }
    let radius = number("radius", radius)?;
    if radius <= 0.0 {
        bail!("radius = {radius} is not positive");
    }
    let left = match (t.trim(), x.trim(), y.trim()) {
        ("", "", "") => None,
        _ => Some(Departure {
            t: number("t_left", t)?,
            position: [number("x_left", x)?, number("y_left", y)?],
        }),
    };
    Ok(Person { radius, left })
}

/// `t,id,x,y[,pressure]` as `(t, (id, x, y))`.
fn parse_row(line: &str, expected: usize) -> Result<(f64, (usize, f64, f64))> {
    let fields: Vec<&str> = line.split(',').collect();
    if fields.len() != expected {
        bail!("expected {expected} fields, found {}", fields.len());
    }
    let id: usize = fields[1]
        .trim()
        .parse()
        .with_context(|| format!("id = {:?} is not a person's number", fields[1]))?;
    Ok((
        number("t", fields[0])?,
        (id, number("x", fields[2])?, number("y", fields[3])?),
    ))
}

/// Whether the trajectory `path` read as `saved` is one of the scene that starts at
/// `start` with the people at `q0` and of radii `radii`: the people table has the scene's
/// radii, and the first frame, when it is at the scene's start (a resumed run's trajectory
/// starts later), lists every person where the scene puts them, to the bit the trajectory
/// keeps.
///
/// # Errors
/// Another number of people or another radius, a first frame before the scene's start, or
/// at it with someone missing or elsewhere: by its line.
pub fn check_start(
    saved: &Saved,
    (path, people): (&Path, &Path),
    start: f64,
    q0: &[f64],
    radii: &[f64],
    due: impl Fn(usize) -> bool,
) -> Result<()> {
    let first = &saved.first;
    let n = q0.len() / 2;
    let other = "the trajectory of another scene, or of this one with another --seed";
    if saved.people.len() != n {
        bail!(
            "{}: lists {} people, the scene has {n}: {other}",
            people.display(),
            saved.people.len()
        );
    }
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()));
    if let Some(i) = (0..n).find(|&i| !close(saved.people[i].radius, radii[i])) {
        bail!(
            "{}:{}: person {i} has radius {}, the scene gives them {}: {other}",
            people.display(),
            i + 2,
            saved.people[i].radius,
            radii[i]
        );
    }
    if first.t < start {
        bail!(
            "{}:{}: the first frame is at t = {}, before the scene's start t = {}: {other}",
            path.display(),
            first.line,
            first.t,
            start
        );
    }
    if first.t > start {
        return Ok(());
    }
    // At the start everybody is there but who arrives later (a scene's sources).
    let expected: Vec<usize> = (0..n).filter(|&i| !due(i) || first.line_of(i).is_some()).collect();
    if first.rows.len() != expected.len() {
        bail!(
            "{}:{}: the first frame (the scene's start, t = {}) lists {} people, the scene has \
                {} there: {other}",
            path.display(),
            first.line,
            first.t,
            first.rows.len(),
            expected.len()
        );
    }
    for (k, (&(id, x, y), &i)) in first.rows.iter().zip(&expected).enumerate() {
        let (x0, y0) = (q0[2 * i], q0[2 * i + 1]);
        if id != i || !close(x, x0) || !close(y, y0) {
            bail!(
                "{}:{}: the first frame (the scene's start, t = {}) has person {id} at \
                    ({x}, {y}), where the scene starts person {i} at ({x0}, {y0}): {other}",
                path.display(),
                first.line + k,
                first.t,
            );
        }
    }
    Ok(())
}

/// The output directory of a run resumed from `dir` at `t` when none is given:
/// `DIR-from-t<t>` beside it.
pub fn default_out(dir: &Path, t: f64) -> PathBuf {
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "run".to_string());
    dir.with_file_name(format!(
        "{name}-from-t{}",
        sweeping::stepper::display_number(t)
    ))
}

/// Whether `a` and `b` name the same directory (`b` need not exist yet).
pub fn same_dir(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `trajectory` and `people` written as a run's files in a fresh directory `name`.
    fn write(name: &str, trajectory: &str, people: &str) -> (PathBuf, PathBuf) {
        let dir = std::env::temp_dir().join(format!("sweep-resume-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (t, p) = (dir.join(TRAJECTORY), dir.join(PEOPLE));
        std::fs::write(&t, trajectory).unwrap();
        std::fs::write(&p, people).unwrap();
        (t, p)
    }

    const TWO: &str = "id,radius,t_left,x_left,y_left\n0,0.2,,,\n1,0.25,0.4,-0.25,4\n";

    #[test]
    fn the_last_frame_is_read_with_who_had_left_where_they_left() {
        let (t, p) = write("ok", "t,id,x,y\n0,0,1,2\n0,1,3,4\n0.5,0,1.5,2.5\n", TWO);
        let saved = read(&t, &p).unwrap();
        let state = saved.state.clone();
        assert_eq!(state.t, 0.5);
        assert_eq!(state.q, vec![1.5, 2.5, -0.25, 4.0]);
        assert_eq!(state.departed, vec![false, true]);
        assert_eq!(saved.people[1].radius, 0.25);
        assert_eq!(saved.place_of(1, &t, &p), format!("{}:3", p.display()));
        assert_eq!(saved.place_of(0, &t, &p), format!("{}:4", t.display()));
        // With the pressure column.
        let (t, p) = write(
            "pressure",
            "t,id,x,y,pressure\n0,0,1,2,\n0,1,3,4,\n0.5,0,1.5,2.5,0.3\n",
            TWO,
        );
        assert_eq!(read(&t, &p).unwrap().state, state);
    }

    #[test]
    fn with_everybody_gone_the_state_is_at_the_last_departure() {
        let (t, p) = write(
            "gone",
            "t,id,x,y\n0,0,1,2\n0,1,3,4\n0.3,0,1.5,2.5\n",
            "id,radius,t_left,x_left,y_left\n0,0.2,0.35,4.3,2\n1,0.25,0.2,-0.25,4\n",
        );
        let saved = read(&t, &p).unwrap();
        assert_eq!(saved.state.t, 0.35);
        assert_eq!(saved.state.q, vec![4.3, 2.0, -0.25, 4.0]);
        assert_eq!(saved.state.departed, vec![true, true]);
        assert_eq!(saved.departures().iter().flatten().count(), 2);
    }

    #[test]
    fn a_bad_line_is_named_by_its_number() {
        let (t, p) = write("bad", "t,id,x,y\n0,0,1,2\n0,1,x,4\n", TWO);
        let e = format!("{:#}", read(&t, &p).unwrap_err());
        assert!(
            e.contains("trajectory.csv:3") && e.contains("x = \"x\""),
            "{e}"
        );
        let (t, p) = write("nan", "t,id,x,y\n0,0,1,NaN\n", TWO);
        let e = format!("{:#}", read(&t, &p).unwrap_err());
        assert!(e.contains(":2") && e.contains("not finite"), "{e}");
        let (t, p) = write(
            "bad-people",
            "t,id,x,y\n0,0,1,2\n",
            "id,radius,t_left,x_left,y_left\n0,0.2,,,\n1,0.2,1,,\n",
        );
        let e = format!("{:#}", read(&t, &p).unwrap_err());
        assert!(e.contains("people.csv:3") && e.contains("x_left"), "{e}");
    }

    #[test]
    fn a_frame_cut_short_out_of_order_or_none_is_refused() {
        // Person 1 has not left, and is missing from the last frame.
        let (t, p) = write(
            "cut",
            "t,id,x,y\n0,0,1,2\n0,1,3,4\n0.1,0,1,2\n",
            "id,radius,t_left,x_left,y_left\n0,0.2,,,\n1,0.2,,,\n",
        );
        let mut saved = read(&t, &p).unwrap();
        assert_eq!(saved.absent, vec![1]);
        let q0 = [1.0, 2.0, 3.0, 4.0];
        let e = format!("{:#}", saved.clone().place_absent(|_| false, &q0, (&t, &p)).unwrap_err());
        assert!(
            e.contains("trajectory.csv:4") && e.contains("person 1, missing, has not left"),
            "{e}"
        );
        // Unless the scene brings them in later: not arrived yet, at their place, absent.
        saved.place_absent(|i| i == 1, &q0, (&t, &p)).unwrap();
        assert_eq!((saved.state.q, saved.state.departed), (q0.to_vec(), vec![false, true]));
        // Listed though the table says they left.
        let (t, p) = write(
            "listed",
            "t,id,x,y\n0,0,1,2\n0,1,3,4\n0.5,0,1,2\n0.5,1,3,4\n",
            TWO,
        );
        let e = format!("{:#}", read(&t, &p).unwrap_err());
        assert!(
            e.contains("trajectory.csv:5") && e.contains("says they left"),
            "{e}"
        );
        let (t, p) = write("order", "t,id,x,y\n0.1,0,1,2\n0,0,1,2\n", TWO);
        let e = format!("{:#}", read(&t, &p).unwrap_err());
        assert!(e.contains(":3") && e.contains("time order"), "{e}");
        let (t, p) = write("ids", "t,id,x,y\n0,1,1,2\n0,0,1,2\n", TWO);
        let e = format!("{:#}", read(&t, &p).unwrap_err());
        assert!(e.contains(":3") && e.contains("increasing id order"), "{e}");
        let (t, p) = write("empty", "t,id,x,y\n", TWO);
        assert!(format!("{:#}", read(&t, &p).unwrap_err()).contains("no frame"));
        let (t, p) = write("header", "time,x\n", TWO);
        assert!(format!("{:#}", read(&t, &p).unwrap_err()).contains(":1"));
    }

    #[test]
    fn the_first_frame_and_the_radii_are_checked_against_the_scene() {
        let (t, p) = write("start", "t,id,x,y\n0,0,1,2\n0,1,3,4\n0.5,0,1.5,2.5\n", TWO);
        let saved = read(&t, &p).unwrap();
        assert_eq!(
            (saved.first.t, saved.first.line, saved.last.line),
            (0.0, 2, 4)
        );
        let radii = [0.2, 0.25];
        let files = (t.as_path(), p.as_path());
        check_start(&saved, files, 0.0, &[1.0, 2.0, 3.0, 4.0], &radii, |_| false).unwrap();
        // A trajectory that starts later (of a resumed run) has no start to compare.
        check_start(&saved, files, -1.0, &[9.0; 4], &radii, |_| false).unwrap();
        let e = format!(
            "{:#}",
            check_start(&saved, files, 0.0, &[1.0, 2.0, 3.0, 4.5], &radii, |_| false).unwrap_err()
        );
        assert!(e.contains(":3") && e.contains("another scene"), "{e}");
        let e = format!(
            "{:#}",
            check_start(&saved, files, 0.1, &[1.0, 2.0, 3.0, 4.0], &radii, |_| false).unwrap_err()
        );
        assert!(
            e.contains(":2") && e.contains("before the scene's start"),
            "{e}"
        );
        let e = format!(
            "{:#}",
            check_start(&saved, files, 0.0, &[1.0, 2.0, 3.0, 4.0], &[0.2, 0.2], |_| false).unwrap_err()
        );
        assert!(
            e.contains("people.csv:3") && e.contains("radius 0.25"),
            "{e}"
        );
        // Who arrives later is not in the start's frame; anyone else must be.
        let (t, p) = write("later", "t,id,x,y\n0,1,3,4\n0.5,0,1,2\n0.5,1,3,4\n", TWO_STAYING);
        let saved = read(&t, &p).unwrap();
        let files = (t.as_path(), p.as_path());
        let q0 = [1.0, 2.0, 3.0, 4.0];
        check_start(&saved, files, 0.0, &q0, &[0.2, 0.2], |i| i == 0).unwrap();
        let e = format!("{:#}", check_start(&saved, files, 0.0, &q0, &[0.2, 0.2], |_| false).unwrap_err());
        assert!(e.contains("lists 1 people, the scene has 2 there"), "{e}");
    }

    const TWO_STAYING: &str = "id,radius,t_left,x_left,y_left\n0,0.2,,,\n1,0.2,,,\n";

    #[test]
    fn a_resumed_run_goes_beside_the_one_it_resumes() {
        let out = default_out(Path::new("out/hall"), 32.79);
        assert_eq!(out, PathBuf::from("out/hall-from-t32.79"));
    }
}
