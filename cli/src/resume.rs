//! `sweep run --resume DIR`: the state a run left in `DIR`, read back from the last frame of
//! its `trajectory.csv` (which `sweep run` writes at the last step it finished, also when it
//! was interrupted or failed).

use anyhow::{bail, Context, Result};
use std::io::BufRead;
use std::path::{Path, PathBuf};
use sweeping::output::TrajectoryFormat;
use sweeping::scene::ResumeState;

/// The trajectory file a resumed run reads: the one `sweep run` writes as CSV.
pub const TRAJECTORY: &str = TrajectoryFormat::Csv.file_name();

/// One frame of a trajectory: its time, the line (1-based) of its first row, and each row's
/// `(id, x, y, present)` in the file's order.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Its time.
    pub t: f64,
    /// The line of its first row: row `k` is on line `line + k`.
    pub line: usize,
    /// `(id, x, y, present)`, row by row.
    pub rows: Vec<(usize, f64, f64, bool)>,
}

/// What a resumed run reads from a trajectory: its first frame, to tell whether it is a run
/// of the scene at all, and its last, the state to go on from.
#[derive(Debug, Clone, PartialEq)]
pub struct Saved {
    /// The first frame.
    pub first: Frame,
    /// The last frame (the first too, when there is one frame only).
    pub last: Frame,
    /// The last frame as the state to resume from.
    pub state: ResumeState,
}

/// The first and last frames of the CSV trajectory `path` (`t,id,x,y,present`, frames in
/// time order, each with every person in id order). Whether they fit the scene is checked
/// when the scene takes them ([`check_start`], [`sweeping::scene::BuiltScene::resume_at`]).
///
/// # Errors
/// The file cannot be read; a line that is not `t,id,x,y,present` with numbers (by its line);
/// a last frame that does not list its people as `0, 1, 2, …` in order, or no frame at all.
pub fn read(path: &Path) -> Result<Saved> {
    let file = std::fs::File::open(path).with_context(|| format!("{}", path.display()))?;
    let mut lines = std::io::BufReader::new(file).lines();
    let header = lines
        .next()
        .transpose()
        .with_context(|| format!("{}", path.display()))?;
    if header.as_deref() != Some("t,id,x,y,present") {
        bail!(
            "{}:1: expected the header `t,id,x,y,present` of `sweep run`'s trajectory, found {:?}",
            path.display(),
            header.unwrap_or_default()
        );
    }
    // The first frame, once a second one starts, and the frame being read.
    let mut first: Option<Frame> = None;
    let mut frame: Option<Frame> = None;
    for (k, line) in lines.enumerate() {
        let number = k + 2;
        let line = line.with_context(|| format!("{}:{number}", path.display()))?;
        if line.is_empty() {
            continue;
        }
        let (t, row) =
            parse_row(&line).with_context(|| format!("{}:{number}: {line:?}", path.display()))?;
        match &mut frame {
            Some(f) if f.t == t => f.rows.push(row),
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
    if let Some(k) = last.rows.iter().enumerate().position(|(i, r)| r.0 != i) {
        bail!(
            "{}:{}: the last frame (t = {}) lists person {} where person {k} belongs: every \
             person, in id order, is expected",
            path.display(),
            last.line + k,
            last.t,
            last.rows[k].0
        );
    }
    let state = ResumeState {
        t: last.t,
        q: last.rows.iter().flat_map(|r| [r.1, r.2]).collect(),
        departed: last.rows.iter().map(|r| !r.3).collect(),
    };
    Ok(Saved {
        first: first.unwrap_or_else(|| last.clone()),
        last,
        state,
    })
}

/// The last frame of the CSV trajectory `path` as the state to resume from ([`read`]).
///
/// # Errors
/// As [`read`].
pub fn last_frame(path: &Path) -> Result<ResumeState> {
    read(path).map(|saved| saved.state)
}

/// Whether the trajectory `path` read as `saved` is one of the scene that starts at
/// `start` with the people at `q0`: its first frame, when it is at the scene's start (a
/// resumed run's trajectory starts later), lists every person present where the scene puts
/// them, to the bit the trajectory keeps.
///
/// # Errors
/// A first frame before the scene's start, or at it with another number of people, or a
/// person elsewhere or gone: by its line.
pub fn check_start(saved: &Saved, path: &Path, start: f64, q0: &[f64]) -> Result<()> {
    let first = &saved.first;
    let n = q0.len() / 2;
    let other = "the trajectory of another scene, or of this one with another --seed";
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
    if first.rows.len() != n {
        bail!(
            "{}:{}: the first frame (the scene's start, t = {}) lists {} people, the scene has \
             {n}: {other}",
            path.display(),
            first.line,
            first.t,
            first.rows.len()
        );
    }
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()));
    for (k, &(id, x, y, present)) in first.rows.iter().enumerate() {
        let (x0, y0) = (q0[2 * k], q0[2 * k + 1]);
        if id != k || !present || !close(x, x0) || !close(y, y0) {
            bail!(
                "{}:{}: the first frame (the scene's start, t = {}) has person {id} {} at \
                 ({x}, {y}), where the scene starts person {k} present at ({x0}, {y0}): {other}",
                path.display(),
                first.line + k,
                first.t,
                if present { "present" } else { "gone" }
            );
        }
    }
    Ok(())
}

/// `t,id,x,y,present` as `(t, (id, x, y, present))`.
fn parse_row(line: &str) -> Result<(f64, (usize, f64, f64, bool))> {
    let fields: Vec<&str> = line.split(',').collect();
    let [t, id, x, y, present] = fields[..] else {
        bail!("expected 5 fields, found {}", fields.len());
    };
    let number = |name: &str, v: &str| -> Result<f64> {
        let parsed: f64 = v
            .trim()
            .parse()
            .with_context(|| format!("{name} = {v:?} is not a number"))?;
        if !parsed.is_finite() {
            bail!("{name} = {v} is not finite");
        }
        Ok(parsed)
    };
    let id: usize = id
        .trim()
        .parse()
        .with_context(|| format!("id = {id:?} is not a person's number"))?;
    let present = match present.trim() {
        "1" => true,
        "0" => false,
        other => bail!("present = {other:?}, expected 0 or 1"),
    };
    Ok((
        number("t", t)?,
        (id, number("x", x)?, number("y", y)?, present),
    ))
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

    fn write(name: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("sweep-resume-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(TRAJECTORY);
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn the_last_frame_is_read_with_who_had_left() {
        let path = write(
            "ok",
            "t,id,x,y,present\n0,0,1,2,1\n0,1,3,4,1\n0.5,0,1.5,2.5,1\n0.5,1,-0.25,4,0\n",
        );
        let state = read(&path).unwrap().state;
        assert_eq!(state.t, 0.5);
        assert_eq!(state.q, vec![1.5, 2.5, -0.25, 4.0]);
        assert_eq!(state.departed, vec![false, true]);
    }

    #[test]
    fn a_bad_line_is_named_by_its_number() {
        let path = write("bad", "t,id,x,y,present\n0,0,1,2,1\n0,1,x,4,1\n");
        let e = format!("{:#}", read(&path).unwrap_err());
        assert!(
            e.contains("trajectory.csv:3") && e.contains("x = \"x\""),
            "{e}"
        );
        let path = write("nan", "t,id,x,y,present\n0,0,1,NaN,1\n");
        let e = format!("{:#}", read(&path).unwrap_err());
        assert!(e.contains(":2") && e.contains("not finite"), "{e}");
    }

    #[test]
    fn a_frame_missing_a_person_or_out_of_order_or_none_is_refused() {
        let path = write(
            "gap",
            "t,id,x,y,present\n0,0,1,2,1\n0.1,0,1,2,1\n0.1,2,1,2,1\n",
        );
        let e = format!("{:#}", read(&path).unwrap_err());
        assert!(
            e.contains(":4") && e.contains("lists person 2 where person 1"),
            "{e}"
        );
        let path = write("order", "t,id,x,y,present\n0.1,0,1,2,1\n0,0,1,2,1\n");
        let e = format!("{:#}", read(&path).unwrap_err());
        assert!(e.contains(":3") && e.contains("time order"), "{e}");
        let path = write("empty", "t,id,x,y,present\n");
        assert!(format!("{:#}", read(&path).unwrap_err()).contains("no frame"));
        let path = write("header", "time,x\n");
        assert!(format!("{:#}", read(&path).unwrap_err()).contains(":1"));
    }

    #[test]
    fn the_first_frame_is_checked_against_the_scene_start() {
        let path = write(
            "start",
            "t,id,x,y,present\n0,0,1,2,1\n0,1,3,4,1\n0.5,0,1.5,2.5,1\n0.5,1,-0.25,4,0\n",
        );
        let saved = read(&path).unwrap();
        assert_eq!(
            (saved.first.t, saved.first.line, saved.last.line),
            (0.0, 2, 4)
        );
        check_start(&saved, &path, 0.0, &[1.0, 2.0, 3.0, 4.0]).unwrap();
        // A trajectory that starts later (of a resumed run) has no start to compare.
        check_start(&saved, &path, -1.0, &[9.0; 4]).unwrap();
        let e = format!(
            "{:#}",
            check_start(&saved, &path, 0.0, &[1.0, 2.0, 3.0, 4.5]).unwrap_err()
        );
        assert!(e.contains(":3") && e.contains("another scene"), "{e}");
        let e = format!(
            "{:#}",
            check_start(&saved, &path, 0.1, &[1.0, 2.0, 3.0, 4.0]).unwrap_err()
        );
        assert!(
            e.contains(":2") && e.contains("before the scene's start"),
            "{e}"
        );
    }

    #[test]
    fn a_resumed_run_goes_beside_the_one_it_resumes() {
        let out = default_out(Path::new("out/hall"), 32.79);
        assert_eq!(out, PathBuf::from("out/hall-from-t32.79"));
    }
}
