//! The output directory of `sweep run`: one run at a time writes in it, and only files that
//! `sweep run` writes are ever replaced or removed there.
//!
//! A run takes a new or empty directory, or one of an earlier run, which it knows by the lock
//! file [`LOCK_FILE`] that every run leaves (or, from before that file, by its
//! `summary.json`). Any other directory that holds files is refused, naming a few: the run
//! would replace or remove a user's own files of the same names, or mix its files with them.

use anyhow::{bail, Context, Result};
use std::fs::TryLockError;
use std::io::{ErrorKind, Write};
use std::path::Path;
use sweeping::output::{TrajectoryFormat, CONTACTS_FILE, DISAGREEMENT_FILE, LARGEST_GAP_FILE};

/// The file a run holds locked while it writes in its output directory. Left in place after
/// the run, it marks the directory as `sweep run`'s; the lock itself ends with the process,
/// however the process ends.
pub const LOCK_FILE: &str = ".sweep.lock";

/// The prefix of the file [`sweeping::output::prepare_output_dir`] writes and removes at once to
/// check that the directory can be written: another run's, seen in passing, is not a user's.
const WRITE_PROBE: &str = ".sweep-write-test-";

/// An output directory taken by this run: the lock is held until it is dropped.
pub struct OutDir {
    _lock: std::fs::File,
}

/// Takes `out` (which exists) for a run writing the trajectory `formats`, and removes what an
/// earlier run wrote there that this one would not overwrite.
///
/// # Errors
/// `out` holds files and is not the output of an earlier `sweep run`; another run holds it;
/// the lock file cannot be created, or an earlier run's file cannot be removed.
pub fn claim(out: &Path, formats: &[TrajectoryFormat]) -> Result<OutDir> {
    let lock_path = out.join(LOCK_FILE);
    // Checked before the lock file is made: made in a user's directory, it would mark that
    // directory as a run's for the next run.
    if !lock_path.exists() && !has_earlier_summary(out) {
        let others = entries(out)?;
        if !others.is_empty() {
            let shown: Vec<&str> = others.iter().take(4).map(String::as_str).collect();
            let more = match others.len() - shown.len() {
                0 => String::new(),
                n => format!(" and {n} more"),
            };
            bail!(
                "--out {}: the folder holds files that `sweep run` did not write ({}{more}); a \
                 run writes only into a new or empty folder or an earlier run's, so as never to \
                 replace or delete other files: choose another --out, or move these files away",
                out.display(),
                shown.join(", ")
            );
        }
    }
    let mut lock = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(&lock_path)
        .with_context(|| format!("creating the lock file {}", lock_path.display()))?;
    match lock.try_lock() {
        Ok(()) => {
            // Who holds it, for the message of a run refused meanwhile.
            let _ = lock
                .set_len(0)
                .and_then(|()| write!(lock, "{}", std::process::id()));
        }
        Err(TryLockError::WouldBlock) => {
            let holder = std::fs::read_to_string(&lock_path)
                .ok()
                .filter(|pid| !pid.trim().is_empty())
                .map(|pid| format!(" (process {})", pid.trim()))
                .unwrap_or_default();
            bail!(
                "--out {}: another `sweep run`{holder} is using this folder (it holds {} \
                 locked); wait until it ends, or choose another --out",
                out.display(),
                lock_path.display()
            );
        }
        // A file system without locks: the run goes on unguarded rather than not at all.
        Err(TryLockError::Error(e)) if e.kind() == ErrorKind::Unsupported => {
            crate::stdout::errln!(
                "note: {} cannot be locked ({e}): another run into {} would not be refused",
                lock_path.display(),
                out.display()
            );
        }
        Err(TryLockError::Error(e)) => {
            return Err(e).with_context(|| format!("locking {}", lock_path.display()));
        }
    }
    remove_stale_outputs(out, formats)?;
    Ok(OutDir { _lock: lock })
}

/// Whether `out/summary.json` is a `sweep run` summary: the mark of a run's directory from
/// before [`LOCK_FILE`].
fn has_earlier_summary(out: &Path) -> bool {
    let Ok(text) = std::fs::read_to_string(out.join("summary.json")) else {
        return false;
    };
    serde_json::from_str::<serde_json::Value>(&text).is_ok_and(|summary| {
        ["scene", "status", "backend", "steps"]
            .iter()
            .all(|key| summary.get(key).is_some())
    })
}

/// The names in `out`, sorted, but for another run's write probe.
fn entries(out: &Path) -> Result<Vec<String>> {
    let read = match std::fs::read_dir(out) {
        Err(e) if e.kind() == ErrorKind::NotFound => return Ok(Vec::new()),
        read => read.with_context(|| format!("reading {}", out.display()))?,
    };
    let mut names = Vec::new();
    for entry in read {
        let entry = entry.with_context(|| format!("reading {}", out.display()))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if !name.starts_with(WRITE_PROBE) {
            names.push(name);
        }
    }
    names.sort();
    Ok(names)
}

/// Removes from `out` what an earlier run wrote there and this one will not overwrite: a
/// trajectory in a format not asked for now, the contact forces, and the snapshots (named by their times, so a
/// longer earlier run's outlast this one's), so that a run into the same directory never
/// leaves an earlier trajectory beside its own summary. Only the names `sweep run` writes are
/// touched.
fn remove_stale_outputs(out: &Path, formats: &[TrajectoryFormat]) -> Result<()> {
    let remove = |path: &Path| match std::fs::remove_file(path) {
        Err(e) if e.kind() != ErrorKind::NotFound => Err(anyhow::anyhow!(
            "removing the earlier run's {}: {e}",
            path.display()
        )),
        _ => Ok(()),
    };
    for format in [TrajectoryFormat::Csv, TrajectoryFormat::Sqlite] {
        if !formats.contains(&format) {
            remove(&out.join(format.file_name()))?;
        }
    }
    // An earlier cross-checked run's disagreement and largest gap: this run writes its own,
    // if any.
    remove(&out.join(DISAGREEMENT_FILE))?;
    remove(&out.join(LARGEST_GAP_FILE))?;
    // An earlier run's contact forces: this run writes its own, if asked.
    remove(&out.join(CONTACTS_FILE))?;
    let snapshots = out.join("snapshots");
    if let Ok(entries) = std::fs::read_dir(&snapshots) {
        for entry in entries.flatten() {
            let name = entry.file_name();
            let name = name.to_string_lossy();
            let ours = name == "final.svg"
                || (name.len() > "t.svg".len()
                    && name.starts_with('t')
                    && name.ends_with(".svg")
                    && name[1..name.len() - 4]
                        .chars()
                        .all(|c| c.is_ascii_digit() || c == '.'));
            if ours {
                remove(&entry.path())?;
            }
        }
    }
    Ok(())
}
