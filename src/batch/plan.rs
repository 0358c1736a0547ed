//! The plan file: its schema, its checks and its expansion into trials.

use super::BatchError;
use crate::scene::{line_column, Scene, SetOverride};
use serde::Deserialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// The plan file as written; unknown keys refused.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanSpec {
    /// Names the output folder `out/<name>`; default the file's stem.
    name: Option<Spanned<String>>,
    /// Free text.
    #[allow(dead_code)]
    description: Option<String>,
    /// Scene files, relative to the plan's folder.
    scenes: Spanned<Vec<Spanned<String>>>,
    /// Seeds of the random placements; default none (each scene's own).
    seeds: Option<Spanned<Vec<u64>>>,
    /// Each key a list of values: every combination is a trial.
    grid: Option<toml::Table>,
    /// Explicit trials: each a set of overrides and tags.
    #[serde(default)]
    trials: Vec<Spanned<TrialSpec>>,
    /// The plot of the results.
    plot: Option<Spanned<PlotSpec>>,
    /// Slurm settings of `sweep batch --slurm`.
    slurm: Option<SlurmSpec>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct TrialSpec {
    /// Overrides, `key = value`.
    #[serde(default)]
    set: toml::Table,
    /// Values recorded in the table and not given to the scene (a door's width when the
    /// overrides move its two ends).
    #[serde(default)]
    tags: toml::Table,
}

/// The plot of a plan's results (`[plot]`): an output against a parameter.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlotSpec {
    /// The parameter on the horizontal axis: an override key, a tag or `seed`; its values
    /// must be numbers.
    pub x: String,
    /// The vertical axis: one of [`OUTPUTS`](super::OUTPUTS), or one divided by a parameter
    /// or another output, `"flow / door_width"` (a flow per metre of door).
    pub y: String,
    /// A band of reference values of `y` drawn behind the trials (an experiment's range).
    pub band: Option<PlotBand>,
}

impl PlotSpec {
    /// `y` as (output, divisor): `"flow / door_width"` gives `("flow", Some("door_width"))`.
    pub fn y_terms(&self) -> (&str, Option<&str>) {
        match self.y.split_once('/') {
            Some((a, b)) => (a.trim(), Some(b.trim())),
            None => (self.y.trim(), None),
        }
    }
}

/// A band of reference values on a plot's vertical axis (`band = { from = 1.6, to = 2.0,
/// label = "experiments" }`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlotBand {
    /// Its lower end.
    pub from: f64,
    /// Its upper end.
    pub to: f64,
    /// What it is, written in the band.
    #[serde(default)]
    pub label: String,
}

/// Slurm settings (`[slurm]`), for `sweep batch --slurm`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlurmSpec {
    /// Lines `#SBATCH <option>` added to the script (`--time=00:30:00`,
    /// `--partition=short`). Default none.
    #[serde(default)]
    pub options: Vec<String>,
    /// Most tasks of the array running at once (`--array=0-N%max`). Default no limit.
    pub max_parallel: Option<usize>,
}

/// One run of a plan: a scene, its overrides, tags and seed.
#[derive(Debug, Clone, PartialEq)]
pub struct Trial {
    /// Its number, from 0, in the plan's order (scenes, then trials, then the grid, then
    /// seeds).
    pub index: usize,
    /// The scene as the plan names it.
    pub scene: String,
    /// The scene file (relative to the plan's folder when the plan names it so).
    pub scene_path: PathBuf,
    /// The overrides, in the order applied.
    pub sets: Vec<SetOverride>,
    /// Tags: `(name, value)`.
    pub tags: Vec<(String, String)>,
    /// The seed of the random placements; `None`: the scene's.
    pub seed: Option<u64>,
}

impl Trial {
    /// Its folder's name: `trial-0007`.
    pub fn dir_name(&self) -> String {
        format!("trial-{:04}", self.index)
    }

    /// The value of `parameter` in this trial (an override's key, a tag or `seed`), as
    /// written in the table (a string without its quotes).
    pub fn parameter(&self, parameter: &str) -> Option<String> {
        if parameter == "seed" {
            return self.seed.map(|s| s.to_string());
        }
        self.sets
            .iter()
            .rev()
            .find(|s| s.key == parameter)
            .map(|s| unquoted(&s.value))
            .or_else(|| {
                self.tags
                    .iter()
                    .find(|(k, _)| k == parameter)
                    .map(|(_, v)| v.clone())
            })
    }
}

/// A TOML value as a table cell: a string without its quotes, anything else as written.
fn unquoted(value: &str) -> String {
    match value.parse::<toml_edit::Value>() {
        Ok(toml_edit::Value::String(s)) => s.into_value(),
        _ => value.to_string(),
    }
}

/// A value from the plan as TOML, to go into a scene.
fn toml_text(value: &toml::Value) -> String {
    value.to_string()
}

/// An override or a tag with where the plan writes it.
#[derive(Debug, Clone)]
struct Written {
    key: String,
    value: String,
    line: Option<usize>,
    item: String,
}

/// An explicit trial's overrides and tags.
type TrialSets = (Vec<Written>, Vec<Written>);

/// A checked plan.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Its name: `name`, else the file's stem.
    pub name: String,
    /// The plan file, as given.
    pub file: PathBuf,
    /// The scenes: as written, resolved, line.
    scenes: Vec<(String, PathBuf, Option<usize>)>,
    seeds: Vec<Option<u64>>,
    /// Each explicit trial's overrides and tags (one empty trial without `[[trials]]`).
    trial_sets: Vec<TrialSets>,
    /// Each grid key's values, in the order written.
    grid: Vec<Vec<Written>>,
    /// The parameters, in the order first written.
    parameters: Vec<String>,
    /// The plot.
    pub plot: Option<PlotSpec>,
    /// Slurm settings.
    pub slurm: SlurmSpec,
}

impl Plan {
    /// Reads a plan file.
    ///
    /// # Errors
    /// [`BatchError::Io`], or as [`Plan::from_toml_str`].
    pub fn from_file(path: impl AsRef<Path>) -> Result<Plan, BatchError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| BatchError::Io {
            path: path.to_path_buf(),
            message: format!("cannot read the plan: {e}"),
        })?;
        Self::from_toml_str(&text, path)
    }

    /// Parses and checks a plan; `file` names it in errors, and scenes are found relative to
    /// its folder.
    ///
    /// # Errors
    /// [`BatchError::Parse`] (line and column) for invalid TOML, an unknown key or a wrong
    /// type; [`BatchError::Invalid`] (line and item) for no scene, a scene file that is not
    /// there, an empty or repeated list of values, a key both in `[grid]` and in a trial, a
    /// plot of something the table does not have.
    pub fn from_toml_str(text: &str, file: &Path) -> Result<Plan, BatchError> {
        let name_of_file = file.display().to_string();
        let spec: PlanSpec = toml::from_str(text).map_err(|e| {
            let (line, column) = e
                .span()
                .map(|s| line_column(text, s.start))
                .unwrap_or((1, 1));
            BatchError::Parse {
                file: name_of_file.clone(),
                line,
                column,
                message: e.message().trim().to_string(),
            }
        })?;
        let line = |start: usize| Some(line_column(text, start).0);
        let invalid = |line: Option<usize>, item: &str, message: String| BatchError::Invalid {
            file: name_of_file.clone(),
            line,
            item: item.to_string(),
            message,
        };
        let name = match &spec.name {
            Some(n) => {
                let v = n.get_ref();
                if v.is_empty() || v.contains(['/', '\\', ':']) || v == "." || v == ".." {
                    return Err(invalid(
                        line(n.span().start),
                        "name",
                        format!("`{v}` cannot name a folder"),
                    ));
                }
                v.clone()
            }
            None => file
                .file_stem()
                .map_or("batch".to_string(), |s| s.to_string_lossy().into_owned()),
        };
        let base = file.parent().unwrap_or(Path::new(""));
        let scenes = scenes(&spec, base, &line, &invalid)?;
        let seeds = match &spec.seeds {
            None => vec![None],
            Some(s) => {
                let l = line(s.span().start);
                if s.get_ref().is_empty() {
                    return Err(invalid(
                        l,
                        "seeds",
                        "an empty list: leave `seeds` out to use each scene's own".into(),
                    ));
                }
                let mut seen = std::collections::HashSet::new();
                if let Some(d) = s.get_ref().iter().find(|v| !seen.insert(**v)) {
                    return Err(invalid(l, "seeds", format!("seed {d} is listed twice")));
                }
                s.get_ref().iter().map(|&v| Some(v)).collect()
            }
        };
        let places = KeyPlaces::of(text);
        let grid = grid(&spec, &places, &invalid)?;
        let trial_sets = explicit_trials(&spec, &places, &line, &invalid)?;
        // A key of the grid in a trial's overrides: which one would win is not obvious.
        for (sets, _) in &trial_sets {
            for w in sets {
                if grid.iter().any(|values| values[0].key == w.key) {
                    return Err(invalid(
                        w.line,
                        &w.item,
                        format!("`{}` is also a key of [grid]: give it in one place", w.key),
                    ));
                }
            }
        }
        let mut parameters: Vec<(Option<usize>, String)> = Vec::new();
        let all = grid
            .iter()
            .flatten()
            .chain(trial_sets.iter().flat_map(|(s, t)| s.iter().chain(t)));
        for w in all {
            if !parameters.iter().any(|(_, k)| *k == w.key) {
                parameters.push((w.line, w.key.clone()));
            }
        }
        parameters.sort_by_key(|(l, _)| *l);
        let parameters: Vec<String> = parameters.into_iter().map(|(_, k)| k).collect();
        if let Some(p) = &spec.plot {
            let l = line(p.span().start);
            let p = p.get_ref();
            if p.x != "seed" && !parameters.contains(&p.x) {
                return Err(invalid(
                    l,
                    "[plot] x",
                    format!(
                        "`{}` is not a parameter of the plan (it has: seed{}{})",
                        p.x,
                        if parameters.is_empty() { "" } else { ", " },
                        parameters.join(", ")
                    ),
                ));
            }
            let (output, per) = p.y_terms();
            if !super::OUTPUTS.contains(&output) {
                return Err(invalid(
                    l,
                    "[plot] y",
                    format!(
                        "`{output}` is not an output of the table (it has: {})",
                        super::OUTPUTS.join(", ")
                    ),
                ));
            }
            if let Some(per) = per {
                if !parameters.iter().any(|q| q == per) && !super::OUTPUTS.contains(&per) {
                    return Err(invalid(
                        l,
                        "[plot] y",
                        format!(
                            "`{per}` (what `{output}` is divided by) is neither a parameter of the plan nor an output of the table"
                        ),
                    ));
                }
            }
            if let Some(b) = &p.band {
                if !(b.from.is_finite() && b.to.is_finite() && b.from < b.to) {
                    return Err(invalid(
                        l,
                        "[plot] band",
                        format!(
                            "`from` ({}) must be below `to` ({}), both finite",
                            b.from, b.to
                        ),
                    ));
                }
            }
        }
        Ok(Plan {
            name,
            file: file.to_path_buf(),
            scenes,
            seeds,
            trial_sets,
            grid,
            parameters,
            plot: spec.plot.map(Spanned::into_inner),
            slurm: spec.slurm.unwrap_or_default(),
        })
    }

    /// The parameters: override keys and tags, in the order the plan first writes them.
    pub fn parameters(&self) -> &[String] {
        &self.parameters
    }

    /// How many trials the plan has.
    pub fn trial_count(&self) -> usize {
        let grid: usize = self.grid.iter().map(Vec::len).product();
        self.scenes.len() * self.trial_sets.len() * grid * self.seeds.len()
    }

    /// Every trial, numbered from 0: for each scene, each explicit trial, each combination of
    /// the grid (the last key varying fastest), each seed.
    pub fn trials(&self) -> Vec<Trial> {
        let mut combos: Vec<Vec<&Written>> = vec![Vec::new()];
        for values in &self.grid {
            combos = combos
                .iter()
                .flat_map(|c| {
                    values.iter().map(move |v| {
                        let mut c = c.clone();
                        c.push(v);
                        c
                    })
                })
                .collect();
        }
        let mut trials = Vec::with_capacity(self.trial_count());
        for (scene, path, _) in &self.scenes {
            for (sets, tags) in &self.trial_sets {
                for combo in &combos {
                    for &seed in &self.seeds {
                        trials.push(Trial {
                            index: trials.len(),
                            scene: scene.clone(),
                            scene_path: path.clone(),
                            sets: sets
                                .iter()
                                .chain(combo.iter().copied())
                                .map(|w| SetOverride::new(&w.key, &w.value))
                                .collect(),
                            tags: tags
                                .iter()
                                .map(|w| (w.key.clone(), unquoted(&w.value)))
                                .collect(),
                            seed,
                        });
                    }
                }
            }
        }
        trials
    }

    /// Trial `index`.
    ///
    /// # Errors
    /// [`BatchError::NoSuchTrial`] past the last.
    pub fn trial(&self, index: usize) -> Result<Trial, BatchError> {
        let count = self.trial_count();
        self.trials()
            .into_iter()
            .nth(index)
            .ok_or(BatchError::NoSuchTrial {
                trial: index,
                count,
            })
    }

    /// Checks every override against every scene, each as if the scene file said it (unknown
    /// keys, wrong types, list items the scene lacks), before any trial runs.
    ///
    /// # Errors
    /// [`BatchError::Scene`] naming the plan's line and item, and the scene's error.
    pub fn check_scenes(&self) -> Result<(), BatchError> {
        let written = self
            .grid
            .iter()
            .flatten()
            .chain(self.trial_sets.iter().flat_map(|(s, _)| s));
        let written: Vec<&Written> = written.collect();
        for (_, path, line) in &self.scenes {
            let text = std::fs::read_to_string(path).map_err(|e| BatchError::Io {
                path: path.clone(),
                message: format!("cannot read the scene: {e}"),
            })?;
            let origin = path.display().to_string();
            let scene_error = |line, item: &str, source| BatchError::Scene {
                file: self.file.display().to_string(),
                line,
                item: item.to_string(),
                source: Box::new(source),
            };
            Scene::from_toml_str_with(&text, &origin, &[])
                .map_err(|e| scene_error(*line, "scenes", e))?;
            for w in &written {
                let set = [SetOverride::new(&w.key, &w.value)];
                Scene::from_toml_str_with(&text, &origin, &set)
                    .map_err(|e| scene_error(w.line, &w.item, e))?;
            }
        }
        Ok(())
    }
}

type Invalid<'a> = &'a dyn Fn(Option<usize>, &str, String) -> BatchError;
type LineOf<'a> = &'a dyn Fn(usize) -> Option<usize>;

fn scenes(
    spec: &PlanSpec,
    base: &Path,
    line: LineOf<'_>,
    invalid: Invalid<'_>,
) -> Result<Vec<(String, PathBuf, Option<usize>)>, BatchError> {
    if spec.scenes.get_ref().is_empty() {
        return Err(invalid(
            line(spec.scenes.span().start),
            "scenes",
            "no scene: list at least one scene file".into(),
        ));
    }
    let mut out: Vec<(String, PathBuf, Option<usize>)> = Vec::new();
    for (i, s) in spec.scenes.get_ref().iter().enumerate() {
        let l = line(s.span().start);
        let written = s.get_ref().clone();
        let path = base.join(&written);
        if !path.is_file() {
            return Err(invalid(
                l,
                &format!("scenes[{i}]"),
                format!(
                    "no scene file {} (scenes are found relative to the plan's folder)",
                    path.display()
                ),
            ));
        }
        if out.iter().any(|(w, _, _)| *w == written) {
            return Err(invalid(
                l,
                &format!("scenes[{i}]"),
                format!("`{written}` is listed twice"),
            ));
        }
        out.push((written, path, l));
    }
    Ok(out)
}

/// A table of overrides as `(dotted key, value)`, a nested table giving its keys one by one.
fn flatten(prefix: &str, value: &toml::Value, out: &mut Vec<(String, toml::Value)>) {
    match value {
        toml::Value::Table(t) => {
            for (k, v) in t {
                flatten(&format!("{prefix}.{k}"), v, out);
            }
        }
        v => out.push((prefix.to_string(), v.clone())),
    }
}

fn check_key(
    key: &str,
    l: Option<usize>,
    item: &str,
    invalid: Invalid<'_>,
) -> Result<(), BatchError> {
    format!("{key}=0")
        .parse::<SetOverride>()
        .map(|_| ())
        .map_err(|e| invalid(l, item, e))
}

fn grid(
    spec: &PlanSpec,
    places: &KeyPlaces,
    invalid: Invalid<'_>,
) -> Result<Vec<Vec<Written>>, BatchError> {
    let Some(grid) = &spec.grid else {
        return Ok(Vec::new());
    };
    let mut out = Vec::new();
    for (key, values, l) in places.flat(grid, "grid") {
        let item = format!("[grid] {key}");
        check_key(&key, l, &item, invalid)?;
        let toml::Value::Array(values) = values else {
            return Err(invalid(
                l,
                &item,
                format!("a list of values is expected, e.g. `\"{key}\" = [{values}, …]`"),
            ));
        };
        if values.is_empty() {
            return Err(invalid(l, &item, "an empty list of values".into()));
        }
        let texts: Vec<String> = values.iter().map(toml_text).collect();
        if let Some(d) = texts
            .iter()
            .enumerate()
            .find(|(i, t)| texts[..*i].contains(t))
        {
            return Err(invalid(
                l,
                &item,
                format!("the value {} is listed twice", d.1),
            ));
        }
        out.push(
            texts
                .into_iter()
                .map(|value| Written {
                    key: key.clone(),
                    value,
                    line: l,
                    item: item.clone(),
                })
                .collect(),
        );
    }
    Ok(out)
}

/// Where each key of the plan is written: its rank in the file and its line, by dotted path
/// (`grid.crowds.0.count`, a quoted `"crowds.0.count"` giving the same path), read with
/// toml_edit, which keeps both.
struct KeyPlaces(HashMap<String, (usize, usize)>);

impl KeyPlaces {
    fn of(text: &str) -> Self {
        let mut places = HashMap::new();
        if let Ok(doc) = toml_edit::ImDocument::parse(text) {
            let mut rank = 0;
            walk_table(doc.as_table(), "", text, &mut rank, &mut places);
        }
        KeyPlaces(places)
    }

    /// The leaves of `table` (the plan's table at `path`) as `(dotted key, value, line)`, in
    /// the order written: a nested table (a key written without quotes, `crowds.0.count =
    /// …`) gives its keys one by one.
    fn flat(&self, table: &toml::Table, path: &str) -> Vec<(String, toml::Value, Option<usize>)> {
        let mut leaves = Vec::new();
        for (k, v) in table {
            flatten(k, v, &mut leaves);
        }
        let mut placed: Vec<(usize, String, toml::Value, Option<usize>)> = leaves
            .into_iter()
            .map(|(k, v)| {
                let place = self.0.get(&format!("{path}.{k}"));
                (place.map_or(usize::MAX, |p| p.0), k, v, place.map(|p| p.1))
            })
            .collect();
        placed.sort_by_key(|p| p.0);
        placed.into_iter().map(|(_, k, v, l)| (k, v, l)).collect()
    }
}

fn walk_table(
    table: &dyn toml_edit::TableLike,
    path: &str,
    text: &str,
    rank: &mut usize,
    out: &mut HashMap<String, (usize, usize)>,
) {
    for (key, item) in table.iter() {
        let here = if path.is_empty() {
            key.to_string()
        } else {
            format!("{path}.{key}")
        };
        if let Some(span) = table.key(key).and_then(toml_edit::Key::span) {
            *rank += 1;
            out.entry(here.clone())
                .or_insert((*rank, line_column(text, span.start).0));
        }
        match item {
            toml_edit::Item::Table(t) => walk_table(t, &here, text, rank, out),
            toml_edit::Item::Value(toml_edit::Value::InlineTable(t)) => {
                walk_table(t, &here, text, rank, out)
            }
            toml_edit::Item::ArrayOfTables(a) => {
                for (i, t) in a.iter().enumerate() {
                    walk_table(t, &format!("{here}.{i}"), text, rank, out);
                }
            }
            _ => {}
        }
    }
}

fn explicit_trials(
    spec: &PlanSpec,
    places: &KeyPlaces,
    line: LineOf<'_>,
    invalid: Invalid<'_>,
) -> Result<Vec<TrialSets>, BatchError> {
    if spec.trials.is_empty() {
        return Ok(vec![(Vec::new(), Vec::new())]);
    }
    let mut out = Vec::new();
    for (i, t) in spec.trials.iter().enumerate() {
        let item = format!("[[trials]] #{}", i + 1);
        let l = line(t.span().start);
        let written = |table: &toml::Table, what: &str| {
            let mut ws = Vec::new();
            for (key, v, vl) in places.flat(table, &format!("trials.{i}.{what}")) {
                let item = format!("{item} {what} {key}");
                check_key(&key, vl, &item, invalid)?;
                ws.push(Written {
                    key,
                    value: toml_text(&v),
                    line: vl.or(l),
                    item,
                });
            }
            Ok::<_, BatchError>(ws)
        };
        let sets = written(&t.get_ref().set, "set")?;
        let tags = written(&t.get_ref().tags, "tags")?;
        if let Some(w) = tags
            .iter()
            .find(|w| w.key == "seed" || sets.iter().any(|s| s.key == w.key))
        {
            return Err(invalid(
                w.line,
                &w.item,
                format!(
                    "`{}` is already a column of the table: name the tag otherwise",
                    w.key
                ),
            ));
        }
        if sets.is_empty() && tags.is_empty() {
            return Err(invalid(
                l,
                &item,
                "neither `set` nor `tags`: an empty trial".into(),
            ));
        }
        out.push((sets, tags));
    }
    let texts: Vec<String> = out
        .iter()
        .map(|(s, t)| {
            format!(
                "{:?}",
                s.iter()
                    .chain(t)
                    .map(|w| (&w.key, &w.value))
                    .collect::<Vec<_>>()
            )
        })
        .collect();
    if let Some((i, _)) = texts
        .iter()
        .enumerate()
        .find(|(i, t)| texts[..*i].contains(t))
    {
        return Err(invalid(
            line(spec.trials[i].span().start),
            &format!("[[trials]] #{}", i + 1),
            "the same as an earlier trial".into(),
        ));
    }
    Ok(out)
}
