//! `--set key=value`: a scene field overridden from the command line or a batch plan.
//!
//! The override is written into the scene's TOML text before it is parsed, so that it is
//! checked exactly as if the file said it (unknown keys, types, the scene's own checks). The
//! text is edited in place: a value replaced keeps its line (a value written over several lines
//! keeps them as blank ones), and a key the file lacks gets a line of its own, which the line
//! numbers of errors skip: an error about the file still names the file's line, and one about
//! the override names the override.

use super::SceneError;
use std::fmt;
use std::ops::Range;
use toml_edit::{ArrayOfTables, ImDocument, InlineTable, Item, Table, Value};

/// One `key=value` override of a scene field: `key` a dotted path through the scene's tables,
/// list items numbered from 0 (`crowds.0.count`, `exits.1.from`, `run.h`); `value` a TOML value
/// (`200`, `1.5`, `[10.0, 4.4]`, `"native"`), or a bare word taken as a string
/// (`run.backend=native`).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct SetOverride {
    /// The dotted path of the field.
    pub key: String,
    /// The value, as written.
    pub value: String,
}

impl SetOverride {
    /// An override of `key` by `value`.
    pub fn new(key: impl Into<String>, value: impl Into<String>) -> Self {
        Self {
            key: key.into(),
            value: value.into(),
        }
    }
}

impl fmt::Display for SetOverride {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "--set {}={}", self.key, self.value)
    }
}

impl std::str::FromStr for SetOverride {
    type Err = String;

    /// Reads `key=value` (the first `=` splits them).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (key, value) = s
            .split_once('=')
            .ok_or_else(|| format!("`{s}` is not key=value (e.g. crowds.0.count=200)"))?;
        let key = key.trim();
        if key.is_empty() || key.split('.').any(|k| k.trim().is_empty()) {
            return Err(format!(
                "`{s}`: the key is a dotted path of names and item numbers (e.g. crowds.0.count)"
            ));
        }
        Ok(Self::new(key, value.trim()))
    }
}

/// A scene's text with overrides written into it.
#[derive(Debug, Clone, Default)]
pub(crate) struct Edited {
    /// The text.
    pub text: String,
    /// The bytes each override wrote, with the override's index.
    pub written: Vec<(Range<usize>, usize)>,
    /// Offsets of the newlines that overrides added (lines the file does not have).
    pub added_newlines: Vec<usize>,
}

impl Edited {
    /// The override whose bytes `span` touches, if any.
    pub fn override_at(&self, span: &Range<usize>) -> Option<usize> {
        self.written
            .iter()
            .find(|(r, _)| {
                span.start < r.end.max(r.start + 1) && r.start < span.end.max(span.start + 1)
            })
            .map(|(_, i)| *i)
    }

    /// Line and column (1-based) in the file of byte `offset` of the edited text.
    pub fn file_line_column(&self, offset: usize) -> (usize, usize) {
        let (line, column) = super::line_column(&self.text, offset);
        let added = self.added_newlines.partition_point(|&o| o < offset);
        (line - added, column)
    }

    /// Replaces `range` by `new` and records it as written by override `index`.
    fn splice(
        &mut self,
        range: Range<usize>,
        new: &str,
        index: usize,
        added_newline: Option<usize>,
    ) {
        let delta = new.len() as isize - range.len() as isize;
        let shift = |o: usize| {
            if o >= range.end {
                (o as isize + delta) as usize
            } else {
                o
            }
        };
        self.text.replace_range(range.clone(), new);
        // An earlier override's bytes inside the replaced range are gone.
        self.written
            .retain(|(r, _)| !(r.start >= range.start && r.end <= range.end && !range.is_empty()));
        for (r, _) in &mut self.written {
            *r = shift(r.start)..shift(r.end);
        }
        for o in &mut self.added_newlines {
            *o = shift(*o);
        }
        self.written
            .push((range.start..range.start + new.len(), index));
        if let Some(at) = added_newline {
            self.added_newlines.push(range.start + at);
            self.added_newlines.sort_unstable();
        }
    }
}

/// How a path ends: where the new value goes.
enum Edit {
    /// The key exists: its value's bytes are replaced.
    Replace(Range<usize>),
    /// The key is missing from a table with a header line (or the root, at `None`): a line
    /// `rest = value` after the header (a key of the root at the top of the file, a table the
    /// file lacks at its end).
    NewLine {
        header: Option<usize>,
        rest: Vec<String>,
    },
    /// The key is missing from an inline table whose `}` is at this offset.
    InInline {
        close: usize,
        empty: bool,
        rest: Vec<String>,
    },
}

/// Writes `sets` into `text`, one after the other.
///
/// # Errors
/// [`SceneError::Set`] naming the override: the file does not parse, a path through a value
/// or a missing list item, or a value that is not TOML.
pub(crate) fn apply(text: &str, file: &str, sets: &[SetOverride]) -> Result<Edited, SceneError> {
    let mut edited = Edited {
        text: text.to_string(),
        ..Edited::default()
    };
    for (index, set) in sets.iter().enumerate() {
        let fail = |message: String| SceneError::Set {
            file: file.to_string(),
            set: set.to_string(),
            message,
        };
        let value = value_text(&set.value).map_err(fail)?;
        let doc = match ImDocument::parse(edited.text.clone()) {
            Ok(doc) => doc,
            // The file's own error, reported as the file's when it is parsed.
            Err(_) => return Ok(edited),
        };
        let segments: Vec<String> = set.key.split('.').map(|s| s.trim().to_string()).collect();
        match locate(doc.as_table(), &segments).map_err(fail)? {
            Edit::Replace(range) => {
                // A value over several lines leaves them blank: the lines after it keep their
                // numbers.
                let lost = edited.text[range.clone()].matches('\n').count();
                let new = format!("{value}{}", "\n".repeat(lost));
                edited.splice(range, &new, index, None);
            }
            Edit::NewLine { header: None, rest } if rest.len() > 1 => {
                // A table the file lacks goes at its end, under a header: the file's lines
                // keep their numbers, and a table of dotted keys would not be read as one
                // with its position (`Spanned`).
                if !edited.text.is_empty() && !edited.text.ends_with('\n') {
                    edited.text.push('\n');
                    edited.added_newlines.push(edited.text.len() - 1);
                }
                let at = edited.text.len();
                let header = format!("[{}]\n", dotted(&rest[..1]));
                let new = format!("{header}{} = {value}\n", dotted(&rest[1..]));
                edited.splice(at..at, &new, index, Some(header.len() - 1));
                edited.added_newlines.push(at + new.len() - 1);
            }
            Edit::NewLine { header, rest } => {
                let line = format!("{} = {value}\n", dotted(&rest));
                let at = match header {
                    None => 0,
                    Some(start) => match edited.text[start..].find('\n') {
                        Some(nl) => start + nl + 1,
                        None => {
                            edited.text.push('\n');
                            edited.added_newlines.push(edited.text.len() - 1);
                            edited.text.len()
                        }
                    },
                };
                let newline = line.len() - 1;
                edited.splice(at..at, &line, index, Some(newline));
            }
            Edit::InInline { close, empty, rest } => {
                let sep = if empty { "" } else { ", " };
                let new = format!("{sep}{} = {value} ", dotted(&rest));
                edited.splice(close..close, &new, index, None);
            }
        }
    }
    Ok(edited)
}

/// The value as it goes into the file: TOML as written, or a bare word as a string.
fn value_text(raw: &str) -> Result<String, String> {
    let raw = raw.trim();
    if raw.contains('\n') {
        return Err("the value must be on one line".to_string());
    }
    match raw.parse::<Value>() {
        Ok(_) => Ok(raw.to_string()),
        Err(e) => {
            let bare = raw.chars().next().is_some_and(|c| c.is_alphabetic())
                && !matches!(raw, "true" | "false" | "inf" | "nan");
            if bare {
                Ok(Value::from(raw).to_string().trim().to_string())
            } else {
                Err(format!(
                    "the value is not TOML ({}); write a string in quotes",
                    e.message().trim()
                ))
            }
        }
    }
}

/// A key path as a TOML dotted key, quoting the parts that are not bare keys.
fn dotted(parts: &[String]) -> String {
    parts
        .iter()
        .map(|p| {
            if !p.is_empty()
                && p.chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            {
                p.clone()
            } else {
                Value::from(p.as_str()).to_string().trim().to_string()
            }
        })
        .collect::<Vec<_>>()
        .join(".")
}

/// A container on the way down a path.
enum Place<'a> {
    Table(&'a Table),
    Inline(&'a InlineTable),
    Array(&'a toml_edit::Array),
    Tables(&'a ArrayOfTables),
}

/// Follows `segments` down from the root to where the value goes.
fn locate(root: &Table, segments: &[String]) -> Result<Edit, String> {
    let mut place = Place::Table(root);
    // The nearest table with a header line (or the root), and where the path below it starts.
    let mut anchor: (Option<usize>, usize) = (None, 0);
    for (i, segment) in segments.iter().enumerate() {
        let here = segments[..i].join(".");
        let last = i + 1 == segments.len();
        let item_index = |len: usize| -> Result<usize, String> {
            let n: usize = segment.parse().map_err(|_| {
                format!("`{here}` is a list: its items are numbered from 0 (`{here}.0…`), not named `{segment}`")
            })?;
            if n >= len {
                let items = if len == 1 { "item" } else { "items" };
                return Err(format!(
                    "`{here}` has {len} {items} (numbered from 0): there is no item {n}; --set changes an item of a list, it does not add one"
                ));
            }
            Ok(n)
        };
        let whole_table = || {
            format!(
                "`{}` is a table: set its keys one by one (`{}.<key>=…`)",
                segments.join("."),
                segments.join(".")
            )
        };
        let missing = |rest: &[String]| -> Result<(), String> {
            match rest.iter().position(|s| s.parse::<usize>().is_ok()) {
                Some(j) => Err(format!(
                    "the scene has no `{}`: --set changes an item of a list, it does not add one",
                    segments[..i + j].join(".")
                )),
                None => Ok(()),
            }
        };
        place = match place {
            Place::Table(table) => match table.get(segment) {
                None => {
                    missing(&segments[i..])?;
                    let (header, from) = anchor;
                    return Ok(Edit::NewLine {
                        header,
                        rest: segments[from..].to_vec(),
                    });
                }
                Some(item) => {
                    let next = descend(item, last, &here, segment, whole_table)?;
                    match next {
                        Step::Value(range) => return Ok(Edit::Replace(range)),
                        Step::Into(next) => {
                            if let (Place::Table(t), Item::Table(_)) = (&next, item) {
                                if !t.is_implicit() && !t.is_dotted() {
                                    anchor = (t.span().map(|s| s.start), i + 1);
                                }
                            }
                            next
                        }
                    }
                }
            },
            Place::Inline(table) => match table.get(segment) {
                None => {
                    missing(&segments[i..])?;
                    let span = table.span().ok_or("no position for an inline table")?;
                    return Ok(Edit::InInline {
                        close: span.end - 1,
                        empty: table.is_empty(),
                        rest: segments[i..].to_vec(),
                    });
                }
                Some(value) => match descend_value(value, last, &here, segment)? {
                    Step::Value(range) => return Ok(Edit::Replace(range)),
                    Step::Into(next) => next,
                },
            },
            Place::Array(array) => {
                let n = item_index(array.len())?;
                let value = array.get(n).ok_or("a list item without a position")?;
                match descend_value(value, last, &here, segment)? {
                    Step::Value(range) => return Ok(Edit::Replace(range)),
                    Step::Into(next) => next,
                }
            }
            Place::Tables(tables) => {
                let n = item_index(tables.len())?;
                if last {
                    return Err(whole_table());
                }
                let table = tables.get(n).ok_or("a list item without a position")?;
                anchor = (table.span().map(|s| s.start), i + 1);
                Place::Table(table)
            }
        };
    }
    // A path of no segment: refused when it was read.
    Err("an empty key".to_string())
}

/// What one segment of a path leads to.
enum Step<'a> {
    /// The bytes of the value to replace.
    Value(Range<usize>),
    /// A container to go on in.
    Into(Place<'a>),
}

fn descend<'a>(
    item: &'a Item,
    last: bool,
    here: &str,
    segment: &str,
    whole_table: impl Fn() -> String,
) -> Result<Step<'a>, String> {
    match item {
        Item::Value(value) => descend_value(value, last, here, segment),
        Item::Table(_) | Item::ArrayOfTables(_) if last => Err(whole_table()),
        Item::Table(table) => Ok(Step::Into(Place::Table(table))),
        Item::ArrayOfTables(tables) => Ok(Step::Into(Place::Tables(tables))),
        Item::None => Err(format!("`{here}.{segment}` has no value")),
    }
}

fn descend_value<'a>(
    value: &'a Value,
    last: bool,
    here: &str,
    segment: &str,
) -> Result<Step<'a>, String> {
    let path = if here.is_empty() {
        segment.to_string()
    } else {
        format!("{here}.{segment}")
    };
    if last {
        let range = value
            .span()
            .ok_or_else(|| format!("`{path}` has no position in the file"))?;
        return Ok(Step::Value(range));
    }
    match value {
        Value::InlineTable(table) => Ok(Step::Into(Place::Inline(table))),
        Value::Array(array) => Ok(Step::Into(Place::Array(array))),
        _ => Err(format!(
            "`{path}` is a single value, not a table or a list: it has no `{path}.…`"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn edit(text: &str, sets: &[&str]) -> Result<Edited, String> {
        let sets: Vec<SetOverride> = sets.iter().map(|s| s.parse().unwrap()).collect();
        apply(text, "t.toml", &sets).map_err(|e| e.to_string())
    }

    #[test]
    fn values_are_replaced_in_place_and_missing_keys_get_a_line_of_their_own() {
        let text = "a = 1\n[run]\nh = 0.1 # step\n[[crowds]]\ncount = 5\n[[crowds]]\ncount = [\n 1,\n 2]\nx = { k = 1 }\n";
        let e = edit(
            text,
            &[
                "run.h=0.2",
                "crowds.1.count=7",
                "crowds.0.seed=3",
                "crowds.1.x.j=true",
                "top.level=\"s\"",
            ],
        )
        .unwrap();
        let want = "a = 1\n[run]\nh = 0.2 # step\n[[crowds]]\nseed = 3\ncount = 5\n[[crowds]]\ncount = 7\n\n\nx = { k = 1 , j = true }\n[top]\nlevel = \"s\"\n";
        assert_eq!(e.text, want);
        // Lines of the file keep their numbers; the added lines are skipped.
        let at = |s: &str| e.file_line_column(e.text.find(s).unwrap()).0;
        assert_eq!(at("a = 1"), 1);
        assert_eq!(at("count = 5"), 5);
        assert_eq!(at("x = {"), 10);
        assert_eq!(at("[top]"), 11);
        // Each override's bytes are known.
        let of = |s: &str| {
            let start = e.text.find(s).unwrap();
            e.override_at(&(start..start + 1))
        };
        assert_eq!(of("0.2"), Some(0));
        assert_eq!(of("count = 7"), None);
        assert_eq!(of("7\n"), Some(1));
        assert_eq!(of("seed"), Some(2));
        assert_eq!(of("j = true"), Some(3));
        assert_eq!(of("top"), Some(4));
        assert_eq!(of("a = 1"), None);
    }

    #[test]
    fn bare_words_are_strings_and_other_non_toml_is_refused() {
        let e = edit("[run]\nbackend = \"clarabel\"\n", &["run.backend=native"]).unwrap();
        assert_eq!(e.text, "[run]\nbackend = \"native\"\n");
        let err = edit("[run]\nh = 1.0\n", &["run.h=[1,"]).unwrap_err();
        assert!(
            err.starts_with("t.toml: --set run.h=[1,: the value is not TOML"),
            "{err}"
        );
    }

    #[test]
    fn paths_through_values_and_missing_items_are_named() {
        let text = "name = \"x\"\n[run]\nh = 1.0\n[[crowds]]\ncount = 5\nregion = [0, 0, 1, 1]\n";
        let cases = [
            (
                "crowds.1.count=3",
                "`crowds` has 1 item (numbered from 0): there is no item 1",
            ),
            (
                "crowds.first.count=3",
                "`crowds` is a list: its items are numbered from 0",
            ),
            (
                "name.x=3",
                "`name` is a single value, not a table or a list",
            ),
            ("run=3", "`run` is a table: set its keys one by one"),
            ("crowds.0=3", "`crowds.0` is a table"),
            ("crowds.0.region.4=3", "`crowds.0.region` has 4 items"),
            ("exits.0.from=[1, 2]", "the scene has no `exits`"),
        ];
        for (set, want) in cases {
            let err = edit(text, &[set]).unwrap_err();
            assert!(err.contains(want), "{set}: {err}");
            assert!(err.starts_with(&format!("t.toml: --set {set}: ")), "{err}");
        }
        assert!("crowds..count=1".parse::<SetOverride>().is_err());
        assert!("count".parse::<SetOverride>().is_err());
        assert_eq!(
            "a.b = [1, 2]".parse::<SetOverride>().unwrap(),
            SetOverride::new("a.b", "[1, 2]")
        );
    }
}
