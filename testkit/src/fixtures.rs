//! The recorded projection problems: blocks of real runs where a method once struggled,
//! kept so that every backend is tested on them. `fixtures/README.md` says where each was
//! recorded and what made it hard.

use serde::de::DeserializeOwned;
use std::path::PathBuf;
use sweeping_api::ProjectionProblem;

/// The path of the fixture `name` (a file name in `fixtures/`, such as `"door_queue_qp.json"`).
pub fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

/// Every fixture whose name ends with `suffix`, sorted by name.
pub fn all_ending_with(suffix: &str) -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("read {}: {e}", dir.display()))
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.to_string_lossy().ends_with(suffix))
        .collect();
    files.sort();
    files
}

/// The text of the fixture `name`.
///
/// # Panics
/// When it cannot be read: a test without its fixture cannot go on.
pub fn text(name: &str) -> String {
    let p = path(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("read {}: {e}", p.display()))
}

/// The fixture `name` read as `T` (a problem with what was recorded beside it).
///
/// # Panics
/// When it cannot be read or parsed.
pub fn read<T: DeserializeOwned>(name: &str) -> T {
    serde_json::from_str(&text(name)).unwrap_or_else(|e| panic!("parse {name}: {e}"))
}

/// The projection problem of the fixture `name`: the file's top level, or its key `problem`
/// (the files that also hold recorded answers).
///
/// # Panics
/// When it cannot be read, or holds no problem.
pub fn problem(name: &str) -> ProjectionProblem {
    #[derive(serde::Deserialize)]
    #[serde(untagged)]
    enum File {
        Bare(ProjectionProblem),
        Wrapped { problem: ProjectionProblem },
    }
    match read::<File>(name) {
        File::Bare(p) | File::Wrapped { problem: p } => p,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_fixture_is_a_problem_and_the_readme_names_it() {
        let readme = text("README.md");
        let files = all_ending_with(".json");
        assert!(files.len() >= 15, "the corpus is {} files", files.len());
        for file in files {
            let name = file.file_name().unwrap().to_string_lossy().into_owned();
            let p = problem(&name);
            assert!(p.n_rows() > 0 && !p.y().is_empty(), "{name} is empty");
            assert!(
                readme.contains(&format!("`{name}`")),
                "README.md does not name {name}"
            );
        }
    }
}
