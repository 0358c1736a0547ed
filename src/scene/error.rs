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
    /// A `--set key=value` override that does not fit the scene: an unknown key, a wrong
    /// type, a path through a value or to a list item the scene lacks, a value that is not
    /// TOML.
    #[error("{file}: {set}: {message}")]
    Set {
        /// The scene file.
        file: String,
        /// The override, as `--set key=value`.
        set: String,
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
            SceneError::Io { .. } | SceneError::Set { .. } => None,
            SceneError::Parse { line, .. } => Some(*line),
            SceneError::Invalid { line, .. } => *line,
        }
    }
}

/// Why a run cannot go on from a state an earlier run is said to have reached
/// ([`BuiltScene::resume_at`](super::BuiltScene::resume_at)): what does not fit, and the
/// person at fault where there is one.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ResumeError {
    /// Another number of people than the scene's.
    #[error("the state has {found} people, the scene {expected}")]
    PeopleCount {
        /// People in the state.
        found: usize,
        /// People in the scene.
        expected: usize,
    },
    /// A coordinate that is not a number, or infinite.
    #[error("person {person}'s {axis} coordinate is {value}")]
    NotFinite {
        /// The person.
        person: usize,
        /// `"x"` or `"y"`.
        axis: &'static str,
        /// The value.
        value: f64,
    },
    /// A time before the scene starts: no run of it is there.
    #[error("the state is at t = {}, before the scene's start t = {}", display_number(*t), display_number(*start))]
    BeforeStart {
        /// The state's time.
        t: f64,
        /// The scene's start.
        start: f64,
    },
    /// A time at or past the horizon: nothing is left to run.
    #[error("the state is at t = {}, not before the horizon T = {}", display_number(*t), display_number(*t_end))]
    NotBeforeHorizon {
        /// The state's time.
        t: f64,
        /// The horizon.
        t_end: f64,
    },
    /// A person marked present where the model has nobody present.
    #[error("person {person} is marked present at t = {}, at ({}, {}), but {what}", display_number(*t), display_number(position[0]), display_number(position[1]))]
    PresentOutside {
        /// The person.
        person: usize,
        /// The state's time.
        t: f64,
        /// The person's centre.
        position: [f64; 2],
        /// What is wrong.
        what: String,
    },
    /// A person marked gone who cannot have left through an exit.
    #[error("person {person} is marked gone at t = {}, at ({}, {}), but {what}", display_number(*t), display_number(position[0]), display_number(position[1]))]
    GoneInside {
        /// The person.
        person: usize,
        /// The state's time.
        t: f64,
        /// The person's centre.
        position: [f64; 2],
        /// What is wrong.
        what: String,
    },
    /// A scene with journeys: the waypoint each person had reached is not in a state.
    #[error("the scene has journeys (kind = \"journey\"), and the waypoint each person had reached is not in the state: a run of it cannot be resumed; run it from its start")]
    Journeys,
    /// People present overlapping each other, a wall or an obstacle, as a scene's start is
    /// refused for.
    #[error("the state at t = {} is not one a run of the scene reaches: {source}", display_number(*t))]
    Infeasible {
        /// The state's time.
        t: f64,
        /// The check of the start that failed.
        source: crate::error::SweepError,
    },
}

impl ResumeError {
    /// The person the error is about, when it is about one.
    pub fn person(&self) -> Option<usize> {
        match self {
            ResumeError::NotFinite { person, .. }
            | ResumeError::PresentOutside { person, .. }
            | ResumeError::GoneInside { person, .. } => Some(*person),
            _ => None,
        }
    }
}

fn display_number(v: f64) -> String {
    crate::numbers::display_number(v)
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
