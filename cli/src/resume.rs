//! Where `sweep run --resume DIR` writes: beside the run it resumes (reading that run back is
//! the library's, [`sweeping::output::SavedRun`]).

use std::path::{Path, PathBuf};

/// The output directory of a run resumed from `dir` at `t` when none is given:
/// `DIR-from-t<t>` beside it.
pub fn default_out(dir: &Path, t: f64) -> PathBuf {
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "run".to_string());
    dir.with_file_name(format!(
        "{name}-from-t{}",
        sweeping::numbers::display_number(t)
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

    #[test]
    fn a_resumed_run_goes_beside_the_one_it_resumes() {
        let out = default_out(Path::new("out/hall"), 32.79);
        assert_eq!(out, PathBuf::from("out/hall-from-t32.79"));
    }
}
