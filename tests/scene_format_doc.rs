//! The guide's page on the scene format (`docs/guide/src/scene-format.md`) cannot drift from
//! the code.
//!
//! * Every key the format accepts is named on the page, as `` `key` ``, in the section of a
//!   table where it is accepted. The keys are not listed here: they are found by walking the
//!   schema's serde structs ([`SceneSpec`]) with a deserializer that records what each struct
//!   asks for (`deserialize_struct` receives the keys serde accepts, after `rename`,
//!   `rename_all` and with every `alias`), so a key added to `src/scene/spec.rs` must be
//!   documented before this test passes. The values of the enums (`kind`, `backend`,
//!   `formats`) are found the same way and must be named as `` `"value"` ``.
//! * Every ```` ```toml ```` block on the page (and on the crowds page) uses only keys the
//!   format accepts, where it accepts them; every block with a `[room]` table is a whole scene,
//!   and must parse and build with the library's loader ([`Scene::from_toml_str`],
//!   [`Scene::build`]).

use serde::de::value::BorrowedStrDeserializer;
use serde::de::{self, DeserializeSeed, Deserializer, EnumAccess, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;
use std::cell::RefCell;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fmt::Display;
use sweeping::scene::{Overrides, Scene, SceneSpec};

const PAGE: &str = "docs/guide/src/scene-format.md";
/// Other pages whose scenes must load (their keys are checked too).
const SCENE_PAGES: [&str; 2] = [PAGE, "docs/guide/src/crowds.md"];

fn read(page: &str) -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(page);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

// ---------------------------------------------------------------------------------------------
// The schema, by a walk of the serde structs.
// ---------------------------------------------------------------------------------------------

/// A path in the scene: `""` is the top level, `run` the table `[run]`, `exits[]` an entry of
/// `[[exits]]`, `obstacles[].disk` the `disk` table of an obstacle.
type Path = String;

/// One serde struct of the schema: the keys it accepts and the paths where it occurs.
#[derive(Debug, Default)]
struct Struct {
    keys: Vec<&'static str>,
    paths: BTreeSet<Path>,
}

/// What the walk found.
#[derive(Debug, Default)]
struct Schema {
    /// The structs, by their Rust names.
    structs: BTreeMap<&'static str, Struct>,
    /// The keys accepted at each path (for the TOML blocks).
    keys_at: BTreeMap<Path, BTreeSet<&'static str>>,
    /// The values of the enums, by path.
    values: BTreeMap<Path, Vec<&'static str>>,
    /// Paths where the walk could not see the shape of the value (an untagged enum, a map,
    /// `#[serde(flatten)]`).
    opaque: BTreeSet<Path>,
}

/// The walk's state across attempts: the schema of the current attempt, and the array lengths
/// learnt from earlier ones (`[f64; N]` fields refuse any other length).
#[derive(Debug, Default)]
struct WalkState {
    schema: Schema,
    lengths: HashMap<Path, usize>,
    last_seq: Path,
}

#[derive(Debug)]
struct WalkError(String);

impl Display for WalkError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for WalkError {}

impl de::Error for WalkError {
    fn custom<T: Display>(msg: T) -> Self {
        WalkError(msg.to_string())
    }
}

/// A deserializer that produces a value of any shape serde asks for, recording the keys of
/// every struct on the way.
struct Tracer<'w> {
    state: &'w RefCell<WalkState>,
    path: Path,
}

impl<'w> Tracer<'w> {
    fn at(&self, path: Path) -> Self {
        Tracer {
            state: self.state,
            path,
        }
    }

    fn child(&self, key: &str) -> Path {
        if self.path.is_empty() {
            key.to_string()
        } else {
            format!("{}.{key}", self.path)
        }
    }

    fn sequence<'de, V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value, WalkError> {
        let element = format!("{}[]", self.path);
        visitor.visit_seq(Elements {
            tracer: self.at(element),
            left: len,
        })
    }
}

/// `toml::Spanned<T>` deserializes as a struct of this name around `T`: transparent here.
fn is_spanned(name: &str) -> bool {
    name.starts_with("$__serde_spanned")
}

macro_rules! visit {
    ($($method:ident => $visit:ident($($value:expr)?);)*) => {
        $(fn $method<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, WalkError> {
            visitor.$visit($($value)?)
        })*
    };
}

impl<'de> Deserializer<'de> for Tracer<'_> {
    type Error = WalkError;

    /// Only an untagged enum (or a type that reads any value) asks for anything: it gets a
    /// number, and the path is marked as not seen into.
    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, WalkError> {
        self.state
            .borrow_mut()
            .schema
            .opaque
            .insert(self.path.clone());
        visitor.visit_f64(1.0)
    }

    visit! {
        deserialize_bool => visit_bool(false);
        deserialize_i8 => visit_i64(1);
        deserialize_i16 => visit_i64(1);
        deserialize_i32 => visit_i64(1);
        deserialize_i64 => visit_i64(1);
        deserialize_u8 => visit_u64(1);
        deserialize_u16 => visit_u64(1);
        deserialize_u32 => visit_u64(1);
        deserialize_u64 => visit_u64(1);
        deserialize_f32 => visit_f64(1.0);
        deserialize_f64 => visit_f64(1.0);
        deserialize_char => visit_char('x');
        deserialize_str => visit_borrowed_str("x");
        deserialize_string => visit_borrowed_str("x");
        deserialize_bytes => visit_borrowed_bytes(b"x");
        deserialize_byte_buf => visit_borrowed_bytes(b"x");
        deserialize_unit => visit_unit();
        deserialize_identifier => visit_borrowed_str("x");
        deserialize_ignored_any => visit_unit();
    }

    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, WalkError> {
        visitor.visit_some(self)
    }

    fn deserialize_unit_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, WalkError> {
        visitor.visit_unit()
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, WalkError> {
        visitor.visit_newtype_struct(self)
    }

    /// A `Vec`: as many elements as an earlier attempt learnt it needs, else one.
    fn deserialize_seq<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, WalkError> {
        let len = {
            let mut state = self.state.borrow_mut();
            state.last_seq = self.path.clone();
            state.lengths.get(&self.path).copied().unwrap_or(1)
        };
        self.sequence(len, visitor)
    }

    fn deserialize_tuple<V: Visitor<'de>>(
        self,
        len: usize,
        visitor: V,
    ) -> Result<V::Value, WalkError> {
        self.sequence(len, visitor)
    }

    fn deserialize_tuple_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        len: usize,
        visitor: V,
    ) -> Result<V::Value, WalkError> {
        self.sequence(len, visitor)
    }

    /// A map (or a struct with `#[serde(flatten)]`): its keys cannot be known.
    fn deserialize_map<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, WalkError> {
        self.state
            .borrow_mut()
            .schema
            .opaque
            .insert(self.path.clone());
        visitor.visit_map(Fields {
            tracer: self,
            keys: &[],
            next: 0,
            transparent: false,
        })
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        name: &'static str,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, WalkError> {
        let transparent = is_spanned(name);
        if !transparent {
            let mut state = self.state.borrow_mut();
            let schema = &mut state.schema;
            let s = schema.structs.entry(name).or_default();
            s.keys = fields.to_vec();
            s.paths.insert(self.path.clone());
            schema
                .keys_at
                .entry(self.path.clone())
                .or_default()
                .extend(fields);
        }
        visitor.visit_map(Fields {
            tracer: self,
            keys: fields,
            next: 0,
            transparent,
        })
    }

    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, WalkError> {
        self.state
            .borrow_mut()
            .schema
            .values
            .insert(self.path.clone(), variants.to_vec());
        let variant = variants.first().copied().unwrap_or("");
        visitor.visit_enum(Variant {
            tracer: self,
            variant,
        })
    }
}

/// A struct's fields, each key served once, in order.
struct Fields<'w> {
    tracer: Tracer<'w>,
    keys: &'static [&'static str],
    next: usize,
    /// `Spanned`'s fields all stand for the value itself.
    transparent: bool,
}

impl<'de> MapAccess<'de> for Fields<'_> {
    type Error = WalkError;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, WalkError> {
        match self.keys.get(self.next) {
            Some(&key) => seed
                .deserialize(BorrowedStrDeserializer::<WalkError>::new(key))
                .map(Some),
            None => Ok(None),
        }
    }

    fn next_value_seed<S: DeserializeSeed<'de>>(&mut self, seed: S) -> Result<S::Value, WalkError> {
        let key = self.keys[self.next];
        self.next += 1;
        let path = if self.transparent {
            self.tracer.path.clone()
        } else {
            self.tracer.child(key)
        };
        seed.deserialize(self.tracer.at(path))
    }
}

struct Elements<'w> {
    tracer: Tracer<'w>,
    left: usize,
}

impl<'de> SeqAccess<'de> for Elements<'_> {
    type Error = WalkError;

    fn next_element_seed<T: DeserializeSeed<'de>>(
        &mut self,
        seed: T,
    ) -> Result<Option<T::Value>, WalkError> {
        if self.left == 0 {
            return Ok(None);
        }
        self.left -= 1;
        seed.deserialize(self.tracer.at(self.tracer.path.clone()))
            .map(Some)
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.left)
    }
}

/// An enum's first variant.
struct Variant<'w> {
    tracer: Tracer<'w>,
    variant: &'static str,
}

impl<'de, 'w> EnumAccess<'de> for Variant<'w> {
    type Error = WalkError;
    type Variant = Tracer<'w>;

    fn variant_seed<S: DeserializeSeed<'de>>(
        self,
        seed: S,
    ) -> Result<(S::Value, Tracer<'w>), WalkError> {
        let value = seed.deserialize(BorrowedStrDeserializer::<WalkError>::new(self.variant))?;
        Ok((value, self.tracer))
    }
}

impl<'de> de::VariantAccess<'de> for Tracer<'_> {
    type Error = WalkError;

    fn unit_variant(self) -> Result<(), WalkError> {
        Ok(())
    }

    fn newtype_variant_seed<S: DeserializeSeed<'de>>(self, seed: S) -> Result<S::Value, WalkError> {
        seed.deserialize(self)
    }

    fn tuple_variant<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value, WalkError> {
        self.sequence(len, visitor)
    }

    fn struct_variant<V: Visitor<'de>>(
        self,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, WalkError> {
        self.deserialize_struct("struct variant", fields, visitor)
    }
}

/// The `N` of "expected N numbers, got k" (the scene's own fixed-size arrays) or of "expected
/// an array of length N" (serde's).
fn expected_length(message: &str) -> Option<usize> {
    let number_after = |marker: &str| {
        let at = message.find(marker)? + marker.len();
        let digits: String = message[at..]
            .chars()
            .take_while(char::is_ascii_digit)
            .collect();
        digits.parse().ok()
    };
    number_after("expected ").or_else(|| number_after("array of length "))
}

/// Walks [`SceneSpec`], learning the length of each fixed-size array from the error its first
/// attempt gets.
fn schema() -> Schema {
    let state = RefCell::new(WalkState::default());
    for _ in 0..100 {
        state.borrow_mut().schema = Schema::default();
        let result = SceneSpec::deserialize(Tracer {
            state: &state,
            path: Path::new(),
        });
        let mut st = state.borrow_mut();
        match result {
            Ok(_) => return std::mem::take(&mut st.schema),
            Err(e) => {
                let at = st.last_seq.clone();
                let n = expected_length(&e.0).unwrap_or_else(|| {
                    panic!(
                        "the walk of the scene schema stopped near `{at}`: {e}. Teach this \
                         test the new kind of value."
                    )
                });
                assert_ne!(
                    st.lengths.insert(at.clone(), n),
                    Some(n),
                    "the walk of the scene schema is stuck at `{at}`: {e}"
                );
            }
        }
    }
    panic!("the walk of the scene schema did not finish in 100 attempts");
}

/// A path as a reader of the page knows it: `[run]`, `[[obstacles]] disk`.
fn toml_name(path: &str) -> String {
    if path.is_empty() {
        return "the top level".to_string();
    }
    let (first, rest) = path.split_once('.').unwrap_or((path, ""));
    let table = match first.strip_suffix("[]") {
        Some(name) => format!("[[{name}]]"),
        None => format!("[{first}]"),
    };
    if rest.is_empty() {
        table
    } else {
        format!("{table} {}", rest.replace("[]", ""))
    }
}

/// The top-level table a path lies in (`obstacles` for `obstacles[].disk`).
fn top_table(path: &str) -> &str {
    let first = path.split('.').next().unwrap_or("");
    first.strip_suffix("[]").unwrap_or(first)
}

// ---------------------------------------------------------------------------------------------
// The page.
// ---------------------------------------------------------------------------------------------

/// A part of the page under a heading that names tables (`` ## `[run]` ``), down to the next
/// heading of the same or a higher level.
struct Section {
    tables: Vec<String>,
    text: String,
}

/// The names in brackets in a heading: `room` for `` `[room]` ``, `exits` for `` `[[exits]]` ``.
fn tables_named(heading: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut rest = heading;
    while let Some(open) = rest.find('[') {
        let after = rest[open..].trim_start_matches('[');
        let name: String = after
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_' || *c == '-')
            .collect();
        if !name.is_empty() && after[name.len()..].starts_with(']') {
            names.push(name.clone());
        }
        rest = &after[name.len()..];
    }
    names
}

fn sections(page: &str) -> Vec<Section> {
    let lines: Vec<&str> = page.lines().collect();
    let level = |line: &str| {
        let hashes = line.chars().take_while(|&c| c == '#').count();
        (hashes > 0 && line[hashes..].starts_with(' ')).then_some(hashes)
    };
    let mut in_code = false;
    let mut headings = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        if line.trim_start().starts_with("```") {
            in_code = !in_code;
        } else if !in_code {
            if let Some(l) = level(line) {
                headings.push((i, l));
            }
        }
    }
    headings
        .iter()
        .enumerate()
        .filter_map(|(k, &(start, l))| {
            let tables = tables_named(lines[start]);
            if tables.is_empty() {
                return None;
            }
            let end = headings[k + 1..]
                .iter()
                .find(|&&(_, l2)| l2 <= l)
                .map_or(lines.len(), |&(i, _)| i);
            Some(Section {
                tables,
                text: lines[start..end].join("\n"),
            })
        })
        .collect()
}

/// The fenced blocks of a language, with the page's line number of their first line.
fn blocks(page: &str, language: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut current: Option<(usize, String, bool)> = None;
    for (i, line) in page.lines().enumerate() {
        let fence = line.trim_start();
        match current.as_mut() {
            None if fence.starts_with("```") => {
                let tag = fence.trim_start_matches('`').trim();
                current = Some((i + 2, String::new(), tag == language));
            }
            None => {}
            Some(_) if fence.starts_with("```") => {
                let (line, text, wanted) = current.take().unwrap_or_default();
                if wanted {
                    out.push((line, text));
                }
            }
            Some((_, text, _)) => {
                text.push_str(line);
                text.push('\n');
            }
        }
    }
    out
}

fn code(word: &str) -> String {
    format!("`{word}`")
}

// ---------------------------------------------------------------------------------------------
// The tests.
// ---------------------------------------------------------------------------------------------

#[test]
fn the_walk_finds_the_schema() {
    let schema = schema();
    // A walk that finds nothing would let every page pass.
    let room = &schema.keys_at["room"];
    assert!(
        room.contains("rectangle") && room.contains("polygon"),
        "{room:?}"
    );
    assert!(schema.keys_at["obstacles[].disk"].contains("center"));
    assert!(schema.keys_at["people[].desired"].contains("kind"));
    assert!(schema.values["run.backend"].contains(&"cross-native"));
    // Where the walk cannot see inside a value, a key could hide: each such place is listed
    // here once someone has checked that it holds no table.
    let seen_as_opaque: BTreeSet<&str> = [
        "crowds[].radius",
        "crowds[].speed",
        "crowds[].pre_movement",
        "sources[].radius",
        "sources[].speed",
    ]
    .into();
    // A radius, speed or pre-movement time may be a distribution, whose keys the walk cannot
    // see: the page names them.
    let text = read(PAGE);
    for key in [
        "uniform = [min, max]",
        "normal = [mean, sd]",
        "within = [min, max]",
    ] {
        assert!(text.contains(key), "the page does not name {key}");
    }
    for path in &schema.opaque {
        assert!(
            seen_as_opaque.contains(path.as_str()),
            "the schema walk cannot see inside the value at {} (`{path}`: an untagged enum, a \
             map or a flattened struct). Check that no key hides there and document the keys \
             it accepts, then add `{path}` to the list in this test.",
            toml_name(path)
        );
    }
}

#[test]
fn every_key_of_the_scene_format_is_on_the_page() {
    let schema = schema();
    let page = read(PAGE);
    let sections = sections(&page);
    let mut missing = Vec::new();
    for (name, s) in &schema.structs {
        let tables: BTreeSet<&str> = s.paths.iter().map(|p| top_table(p)).collect();
        let at_top = s.paths.contains("");
        let texts: Vec<&str> = if at_top {
            vec![page.as_str()]
        } else {
            sections
                .iter()
                .filter(|sec| sec.tables.iter().any(|t| tables.contains(t.as_str())))
                .map(|sec| sec.text.as_str())
                .collect()
        };
        let where_ = s
            .paths
            .iter()
            .map(|p| toml_name(p))
            .collect::<Vec<_>>()
            .join(", ");
        if texts.is_empty() {
            missing.push(format!(
                "no section of {PAGE} has a heading naming {} (where `{name}` is accepted: \
                 {where_})",
                tables
                    .iter()
                    .map(|t| format!("`[{t}]` or `[[{t}]]`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
            continue;
        }
        for key in &s.keys {
            // A key that is itself a table is documented by its section's heading.
            let child = |p: &str| {
                if p.is_empty() {
                    key.to_string()
                } else {
                    format!("{p}.{key}")
                }
            };
            let is_table_with_heading = at_top
                && s.paths.iter().any(|p| {
                    let c = child(p);
                    schema.keys_at.contains_key(&c) || schema.keys_at.contains_key(&(c + "[]"))
                })
                && sections
                    .iter()
                    .any(|sec| sec.tables.iter().any(|t| t == key));
            if !is_table_with_heading && !texts.iter().any(|t| t.contains(&code(key))) {
                missing.push(format!(
                    "`{key}` (a key of {where_}, struct `{name}`) is not named as {} in {}",
                    code(key),
                    if at_top {
                        "the page".to_string()
                    } else {
                        format!("the page's section on {where_}")
                    }
                ));
            }
        }
    }
    for (path, variants) in &schema.values {
        for v in variants {
            let quoted = code(&format!("\"{v}\""));
            if !page.contains(&quoted) {
                missing.push(format!(
                    "the value {quoted} of {} is not named on the page",
                    toml_name(path)
                ));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "{PAGE} does not document every key the scene format accepts:\n  {}",
        missing.join("\n  ")
    );
}

/// The keys of a TOML table that the format does not accept at `path`.
fn unknown_keys(table: &toml::Table, path: &str, schema: &Schema, out: &mut Vec<(String, String)>) {
    let accepted = schema.keys_at.get(path);
    for (key, value) in table {
        if !accepted.is_some_and(|a| a.contains(key.as_str())) {
            out.push((key.clone(), toml_name(path)));
            continue;
        }
        let child = if path.is_empty() {
            key.clone()
        } else {
            format!("{path}.{key}")
        };
        // A value the walk cannot see inside (a distribution) is the loader's to check: a
        // whole scene's block is loaded below.
        if schema.opaque.contains(&child) {
            continue;
        }
        match value {
            toml::Value::Table(t) => unknown_keys(t, &child, schema, out),
            toml::Value::Array(items) => {
                for item in items {
                    if let toml::Value::Table(t) = item {
                        unknown_keys(t, &format!("{child}[]"), schema, out);
                    }
                }
            }
            _ => {}
        }
    }
}

#[test]
fn every_toml_block_uses_only_keys_of_the_format_and_every_scene_loads() {
    let schema = schema();
    let mut failures = Vec::new();
    let mut scenes = 0;
    for page in SCENE_PAGES {
        for (line, text) in blocks(&read(page), "toml") {
            let at = format!("{page}:{line}");
            let table: toml::Table = match toml::from_str(&text) {
                Ok(t) => t,
                Err(e) => {
                    failures.push(format!("{at}: the ```toml block is not valid TOML: {e}"));
                    continue;
                }
            };
            let mut unknown = Vec::new();
            unknown_keys(&table, "", &schema, &mut unknown);
            for (key, place) in unknown {
                failures.push(format!(
                    "{at}: the ```toml block uses `{key}` in {place}, which the scene format \
                     does not accept there"
                ));
            }
            if !table.contains_key("room") {
                continue; // a fragment, not a whole scene
            }
            scenes += 1;
            // An error names the block's own line: the page's is `line - 1` after the fence.
            let loaded = Scene::from_toml_str(&text, "the block")
                .and_then(|scene| scene.build(&Overrides::default()).map(|_| ()));
            if let Err(e) = loaded {
                let page_line = line + e.line().unwrap_or(1) - 1;
                failures.push(format!(
                    "{page}:{page_line}: the scene in the ```toml block at line {line} does not \
                     load: {e}"
                ));
            }
        }
        if page == PAGE {
            assert!(
                scenes > 0,
                "{PAGE} must show at least one whole scene (a ```toml block with [room])"
            );
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The scene module's documentation sends readers to this page, not to where the schema was
/// documented before.
#[test]
fn the_scene_module_points_at_this_page() {
    let module = read("src/scene/mod.rs");
    let doc: String = module
        .lines()
        .take_while(|l| l.starts_with("//!"))
        .collect::<Vec<_>>()
        .join("\n");
    assert!(doc.contains(PAGE), "{doc}");
    assert!(!doc.contains("README"), "{doc}");
}
