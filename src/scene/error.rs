//! Errors in scene files: which file, which line, which item.

/// Why a scene could not be read or built.
///
/// Every variant names the file; parse errors and errors about one item also name its line
/// (1-based).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// The file could not be read.
    #[error("{file}: cannot read the scene file: {reason}")]
    Io {
        /// The file.
        file: String,
        /// The system's error (in the message, so not also a `source`).
        reason: std::io::Error,
    },
    /// The file is not valid TOML, or does not match the schema (missing field, unknown key,
    /// wrong type).
    #[error("{file}:{line}:{column}: {message}")]
    Parse {
        /// The file.
        file: String,
        /// Line (1-based).
        line: usize,
        /// Column (1-based).
        column: usize,
        /// What the parser said.
        message: String,
    },
    /// The file parses but describes an impossible scene (an exit off the walls, two people
    /// overlapping, a negative radius…).
    #[error("{}: {item}: {message}", location(file, *line))]
    Invalid {
        /// The file.
        file: String,
        /// Line of the item (1-based), when it has one.
        line: Option<usize>,
        /// The item, e.g. `[[people]] #3`.
        item: String,
        /// What is wrong.
        message: String,
    },
}

fn location(file: &str, line: Option<usize>) -> String {
    match line {
        Some(l) => format!("{file}:{l}"),
        None => file.to_string(),
    }
}

impl SceneError {
    /// The line the error points at, if any.
    pub fn line(&self) -> Option<usize> {
        match self {
            SceneError::Io { .. } => None,
            SceneError::Parse { line, .. } => Some(*line),
            SceneError::Invalid { line, .. } => *line,
        }
    }
}

/// Line and column (1-based) of byte `offset` in `text`.
pub fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let mut cut = offset;
    while !text.is_char_boundary(cut) {
        cut -= 1;
    }
    let before = &text[..cut];
    let line = before.matches('\n').count() + 1;
    let column = before
        .rfind('\n')
        .map_or(before.chars().count(), |p| before[p + 1..].chars().count())
        + 1;
    (line, column)
}
