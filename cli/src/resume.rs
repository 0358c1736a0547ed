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

/// The last frame of the CSV trajectory `path` (`t,id,x,y,present`, frames in time order, each
/// with every person in id order). Whether it has the scene's number of people is checked
/// when the scene takes it ([`sweeping::scene::BuiltScene::resume_at`]).
///
/// # Errors
/// The file cannot be read; a line that is not `t,id,x,y,present` with numbers (by its line);
/// a last frame that does not list its people as `0, 1, 2, …` in order, or no frame at all.
pub fn last_frame(path: &Path) -> Result<ResumeState> {
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
    // The frame being read: its time, its first line, and each person's (x, y, present).
    let mut frame: Option<(f64, usize)> = None;
    let mut rows: Vec<(usize, f64, f64, bool)> = Vec::new();
    for (k, line) in lines.enumerate() {
        let number = k + 2;
        let line = line.with_context(|| format!("{}:{number}", path.display()))?;
        if line.is_empty() {
            continue;
        }
        let (t, row) =
            parse_row(&line).with_context(|| format!("{}:{number}: {line:?}", path.display()))?;
        match frame {
            Some((ft, _)) if ft == t => {}
            Some((ft, _)) if t < ft => bail!(
                "{}:{number}: t = {t} comes after t = {ft}: frames must be in time order",
                path.display()
            ),
            _ => {
                frame = Some((t, number));
                rows.clear();
            }
        }
        rows.push(row);
    }
    let Some((t, first)) = frame else {
        bail!("{}: no frame after the header", path.display());
    };
    if let Some(k) = rows.iter().enumerate().position(|(i, r)| r.0 != i) {
        bail!(
            "{}:{}: the last frame (t = {t}) lists person {} where person {k} belongs: every \
             person, in id order, is expected",
            path.display(),
            first + k,
            rows[k].0
        );
    }
    Ok(ResumeState {
        t,
        q: rows.iter().flat_map(|r| [r.1, r.2]).collect(),
        departed: rows.iter().map(|r| !r.3).collect(),
    })
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
        let state = last_frame(&path).unwrap();
        assert_eq!(state.t, 0.5);
        assert_eq!(state.q, vec![1.5, 2.5, -0.25, 4.0]);
        assert_eq!(state.departed, vec![false, true]);
    }

    #[test]
    fn a_bad_line_is_named_by_its_number() {
        let path = write("bad", "t,id,x,y,present\n0,0,1,2,1\n0,1,x,4,1\n");
        let e = format!("{:#}", last_frame(&path).unwrap_err());
        assert!(
            e.contains("trajectory.csv:3") && e.contains("x = \"x\""),
            "{e}"
        );
        let path = write("nan", "t,id,x,y,present\n0,0,1,NaN,1\n");
        let e = format!("{:#}", last_frame(&path).unwrap_err());
        assert!(e.contains(":2") && e.contains("not finite"), "{e}");
    }

    #[test]
    fn a_frame_missing_a_person_or_out_of_order_or_none_is_refused() {
        let path = write(
            "gap",
            "t,id,x,y,present\n0,0,1,2,1\n0.1,0,1,2,1\n0.1,2,1,2,1\n",
        );
        let e = format!("{:#}", last_frame(&path).unwrap_err());
        assert!(
            e.contains(":4") && e.contains("lists person 2 where person 1"),
            "{e}"
        );
        let path = write("order", "t,id,x,y,present\n0.1,0,1,2,1\n0,0,1,2,1\n");
        let e = format!("{:#}", last_frame(&path).unwrap_err());
        assert!(e.contains(":3") && e.contains("time order"), "{e}");
        let path = write("empty", "t,id,x,y,present\n");
        assert!(format!("{:#}", last_frame(&path).unwrap_err()).contains("no frame"));
        let path = write("header", "time,x\n");
        assert!(format!("{:#}", last_frame(&path).unwrap_err()).contains(":1"));
    }

    #[test]
    fn a_resumed_run_goes_beside_the_one_it_resumes() {
        let out = default_out(Path::new("out/hall"), 32.79);
        assert_eq!(out, PathBuf::from("out/hall-from-t32.79"));
    }
}
