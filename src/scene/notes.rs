//! What a user is told about a scene before it runs: things that are allowed but rarely
//! meant — nobody moving, people cut off from every exit, a run of very many steps, a
//! trajectory file of hundreds of megabytes. One sentence each; the run goes on.

use super::spec::TrajectoryFormat;
use super::OutputSettings;
use crate::crowd::fast_marching::DistanceField;
use std::sync::Arc;

/// Runs of more steps than this are pointed out.
pub(super) const MANY_STEPS: f64 = 1e7;

/// Trajectories estimated above this many bytes are pointed out.
pub(super) const LARGE_TRAJECTORY_BYTES: f64 = 5e8;

/// About how many bytes a CSV trajectory row takes (`t,id,x,y` with coordinates to
/// the last digit).
const CSV_ROW_BYTES: f64 = 48.0;

/// People listed by name in a note; the rest are counted.
const LISTED: usize = 5;

/// What the notes look at.
pub(super) struct SceneFacts<'a> {
    pub positions: &'a [[f64; 2]],
    /// People with no desired velocity.
    pub still: usize,
    /// People heading for exits, each with the geodesic field of their exits.
    pub routes: &'a [(usize, Arc<DistanceField>)],
    pub has_exits: bool,
    pub moving_obstacles: bool,
    pub h: f64,
    pub t_end: f64,
}

/// The notes on `facts`, in the order a reader meets them.
pub(super) fn scene_notes(facts: &SceneFacts<'_>, output: &OutputSettings) -> Vec<String> {
    let mut notes = Vec::new();
    let n = facts.positions.len();
    if facts.still == n && !facts.moving_obstacles {
        notes.push(
            "nobody has a desired velocity (no `[desired]`, none of their own) and no obstacle \
             moves: nobody will move; `[desired]` with `kind = \"exit\"` sends everybody to \
             the exits"
                .to_string(),
        );
    } else if facts.still > 0 && facts.has_exits {
        notes.push(format!(
            "{} of {n} people have no desired velocity (no `[desired]`, none of their own): \
             they stand still unless pushed",
            facts.still
        ));
    }
    {
        let cut_off: Vec<usize> = facts
            .routes
            .iter()
            .filter(|(i, field)| !field.reaches_exit(facts.positions[*i]))
            .map(|(i, _)| *i)
            .collect();
        if !cut_off.is_empty() {
            notes.push(format!(
                "{} of the {} people heading for the exits cannot reach any exit without \
                 crossing a fixed obstacle or a wall ({}): they walk into what cuts them off \
                 and stop there",
                cut_off.len(),
                facts.routes.len(),
                listed(&cut_off, facts.positions),
            ));
        }
    }
    let steps = (facts.t_end / facts.h).ceil();
    if steps > MANY_STEPS {
        notes.push(format!(
            "the run takes {steps:.1e} steps (t_end = {} s at h = {} s)",
            facts.t_end, facts.h
        ));
    }
    let rows = ((facts.t_end / output.trajectory_every).floor() + 1.0) * n as f64;
    let bytes = rows * CSV_ROW_BYTES;
    if output.formats.contains(&TrajectoryFormat::Csv) && bytes > LARGE_TRAJECTORY_BYTES {
        notes.push(format!(
            "the trajectory will hold about {rows:.1e} rows, about {:.0} MB of CSV: `[output] \
             trajectory_every` (now {} s) sets how often everybody is written",
            bytes / 1e6,
            output.trajectory_every
        ));
    } else if output.formats.contains(&TrajectoryFormat::Sqlite) && bytes > LARGE_TRAJECTORY_BYTES {
        notes.push(format!(
            "the trajectory will hold about {rows:.1e} rows: `[output] trajectory_every` (now \
             {} s) sets how often everybody is written",
            output.trajectory_every
        ));
    }
    notes
}

/// `person 3 at (2, 5), person 7 at (1, 1), … and 4 more`.
fn listed(people: &[usize], positions: &[[f64; 2]]) -> String {
    let mut text: Vec<String> = people
        .iter()
        .take(LISTED)
        .map(|&i| format!("person {i} at ({}, {})", positions[i][0], positions[i][1]))
        .collect();
    if people.len() > LISTED {
        text.push(format!("and {} more", people.len() - LISTED));
    }
    text.join(", ")
}
