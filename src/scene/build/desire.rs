//! Where people want to go: one velocity term per distinct desire, the geodesic fields the
//! desires call for, and the desired velocity `f` they make up.

use super::geometry::{Placed, RoomPlan};
use super::People;
use crate::crowd::fast_marching::{DistanceField, MarchingDomain};
use crate::crowd::velocity::{
    ConstantVelocity, DesiredVelocity, ExitSegment, TowardsExits, VelocityField,
};
use crate::crowd::Population;
use crate::scene::journey::{self, TargetFields};
use crate::scene::spec::{DesiredKind, DesiredSpec, SceneSpec};
use crate::scene::{Ctx, Effect, ObstacleShape, SceneError};
use std::sync::Arc;

/// Each distinct desire with the people who have it.
pub(super) type DesireTerms = Vec<(DesiredSpec, Vec<usize>)>;

/// One velocity term per distinct desire, with its people; a person's own desire wins over
/// the scene's `[desired]`. A constant desire sets that person's speed to its norm, and a
/// `speed` the file gives that differs from it is an error rather than ignored (a person
/// given `speed = 0` would walk at the velocity's 1 m/s). Also returns how many people have
/// no desire at all (they stand still).
pub(super) fn desire_terms(
    cx: &Ctx<'_>,
    people: &mut People,
    default: Option<&DesiredSpec>,
) -> Result<(DesireTerms, usize), SceneError> {
    let mut terms: DesireTerms = Vec::new();
    let mut still = 0usize;
    for (i, d) in people.desired.iter().enumerate() {
        match d.clone().or_else(|| default.cloned()) {
            None => still += 1,
            Some(d) => {
                if d.kind == DesiredKind::Constant {
                    let v = d.velocity.unwrap_or([0.0, 0.0]);
                    let norm = (v[0] * v[0] + v[1] * v[1]).sqrt();
                    if let Some(given) = people.speeds_given[i] {
                        if (given - norm).abs() > 1e-12 * norm.max(1.0) {
                            let origin = &people.origins[i];
                            return Err(cx.err(
                                origin.line,
                                origin.item.clone(),
                                format!(
                                    "speed = {given} has no effect with the constant desired velocity ({}, {}), whose length {norm} is the speed: drop `speed`, or scale the velocity",
                                    v[0], v[1]
                                ),
                            ));
                        }
                    }
                    people.speeds[i] = norm;
                }
                match terms.iter_mut().find(|(s, _)| *s == d) {
                    Some((_, who)) => who.push(i),
                    None => terms.push((d, vec![i])),
                }
            }
        }
    }
    Ok((terms, still))
}

/// The geodesic fields the desires call for, one per distinct set of exits (by index from 0,
/// sorted; `None`: every exit).
pub(in crate::scene) type ExitFields = Vec<(Option<Vec<usize>>, Arc<DistanceField>)>;

/// The exits a desire `kind = "exit"` heads for, by index from 0 and sorted (`None`: all).
pub(in crate::scene) fn chosen_exits(d: &DesiredSpec) -> Option<Vec<usize>> {
    d.exits.as_ref().map(|e| {
        let mut e: Vec<usize> = e.iter().map(|n| n - 1).collect();
        e.sort_unstable();
        e
    })
}

/// Who heads for which exits, for the notes: each person of a desire `kind = "exit"` with
/// their field.
pub(super) fn routes(terms: &DesireTerms, fields: &ExitFields) -> Vec<(usize, Arc<DistanceField>)> {
    terms
        .iter()
        .filter(|(d, _)| d.kind == DesiredKind::Exit)
        .filter_map(|(d, who)| {
            let chosen = chosen_exits(d);
            let (_, field) = fields.iter().find(|(c, _)| *c == chosen)?;
            Some(who.iter().map(move |&i| (i, field.clone())))
        })
        .flatten()
        .collect()
}

/// The geodesic distance to the exits by fast marching, one field per set of exits that
/// somebody heads for, only when somebody does (`[geodesic] cell` is checked either way);
/// and one per waypoint (or point) somebody heads for by the geodesic route. Static
/// obstacles are holes in their domain.
pub(super) fn geodesic_fields(
    cx: &Ctx<'_>,
    spec: &SceneSpec,
    terms: &[(DesiredSpec, Vec<usize>)],
    room: &RoomPlan,
    exits: &[ExitSegment],
    obstacles: &[Placed],
) -> Result<(ExitFields, TargetFields), SceneError> {
    let cell = spec
        .geodesic
        .as_ref()
        .and_then(|g| g.get_ref().cell)
        .unwrap_or(0.05);
    let geodesic_line = spec.geodesic.as_ref().and_then(|g| cx.line_of(g));
    // A wrong value is wrong whether or not the field is needed: the file is checked as a whole.
    if !(cell.is_finite() && cell > 0.0) {
        return Err(cx.err(
            geodesic_line,
            "[geodesic] cell",
            format!("the cell size must be positive and finite, got {cell}"),
        ));
    }
    let mut wanted: Vec<Option<Vec<usize>>> = Vec::new();
    let heads_for_exits = |d: &DesiredSpec| {
        d.kind == DesiredKind::Exit || (d.kind == DesiredKind::Journey && d.point.is_none())
    };
    for (d, _) in terms.iter().filter(|(d, _)| heads_for_exits(d)) {
        let chosen = chosen_exits(d);
        if !wanted.contains(&chosen) {
            wanted.push(chosen);
        }
    }
    let targets = journey::geodesic_targets(terms);
    if wanted.is_empty() && targets.is_empty() {
        return Ok((Vec::new(), Vec::new()));
    }
    // A grid coarser than the room (or than a door) cannot represent the routes: the field
    // would point people anywhere. Refuse it rather than run with it.
    let (bx0, by0, bx1, by1) = room.bbox;
    let room_side = (bx1 - bx0).min(by1 - by0);
    let shortest_exit = exits
        .iter()
        .map(|e| (e.b[0] - e.a[0]).hypot(e.b[1] - e.a[1]))
        .fold(f64::INFINITY, f64::min);
    // The numbers are printed to the last digit: rounded, a width of 0.19999999999999996
    // would read 0.2, and a refused cell 0.1 would look like half of it.
    if cell > room_side / 4.0 || cell > shortest_exit / 2.0 {
        return Err(cx.err(
            geodesic_line,
            "[geodesic] cell",
            format!(
                "the cell {cell} is too coarse for the geodesic field: it must be at most {}, a \
                 quarter of the room's smallest side ({room_side}), and at most {}, half the \
                 narrowest exit ({shortest_exit})",
                room_side / 4.0,
                shortest_exit / 2.0,
            ),
        ));
    }
    let fixed = || {
        obstacles
            .iter()
            .filter(|(o, _, _)| o.motion.is_static())
            .map(|(o, _, _)| &o.shape)
    };
    let domain = |chosen: &Option<Vec<usize>>| MarchingDomain {
        room: room.vertices.clone(),
        exits: exits
            .iter()
            .enumerate()
            .filter(|(k, _)| chosen.as_ref().is_none_or(|c| c.contains(k)))
            .map(|(_, e)| (e.a, e.b))
            .collect(),
        disks: fixed()
            .filter_map(|s| match s {
                ObstacleShape::Disk { center, radius } => Some((*center, *radius)),
                _ => None,
            })
            .collect(),
        segments: fixed()
            .filter_map(|s| match s {
                ObstacleShape::Segment { a, b } => Some((*a, *b)),
                _ => None,
            })
            .collect(),
        polygons: fixed()
            .filter_map(|s| match s {
                ObstacleShape::Polygon(p) => Some(p.clone()),
                _ => None,
            })
            .collect(),
        targets: Vec::new(),
    };
    let exit_fields = wanted
        .into_iter()
        .map(|chosen| {
            let field = DistanceField::compute(&domain(&chosen), cell)
                .map_err(|e| cx.err(geodesic_line, "[geodesic]", e.to_string()))?;
            Ok((chosen, Arc::new(field)))
        })
        .collect::<Result<ExitFields, SceneError>>()?;
    // A waypoint's field: the room without its exits, the target the only place d = 0.
    let target_fields = targets
        .into_iter()
        .map(|target| {
            let domain = MarchingDomain {
                exits: Vec::new(),
                targets: vec![target],
                ..domain(&None)
            };
            let field = DistanceField::compute(&domain, cell).map_err(|e| {
                cx.err(
                    geodesic_line,
                    "[geodesic]",
                    format!("the field to {}: {e}", journey::describe(&target)),
                )
            })?;
            Ok((target, Arc::new(field)))
        })
        .collect::<Result<TargetFields, SceneError>>()?;
    Ok((exit_fields, target_fields))
}

/// The perturbation `f`: each person's desired velocity (at their speed, from their start
/// time), one term per distinct desire.
pub(super) fn desired_velocity(
    population: &Arc<Population>,
    people: &People,
    exits: &[ExitSegment],
    (terms, still): (DesireTerms, usize),
    (fields, targets): (&ExitFields, &TargetFields),
    effects: &mut Vec<Effect>,
    journeys: &mut Vec<Arc<crate::crowd::journey::JourneyProgress>>,
) -> DesiredVelocity {
    let starts = &people.starts;
    let mut velocity =
        DesiredVelocity::new(population.clone(), people.speeds.clone(), exits.to_vec());
    if starts.iter().any(|&s| s > 0.0) {
        velocity = velocity.with_start_times(starts.to_vec());
    }
    for (d, people) in terms {
        let field: Box<dyn VelocityField> = match d.kind {
            DesiredKind::Exit => {
                let chosen = chosen_exits(&d);
                match fields.iter().find(|(c, _)| *c == chosen) {
                    Some((_, f)) => Box::new(TowardsExits {
                        field: f.clone(),
                        exits: chosen,
                    }),
                    None => continue,
                }
            }
            DesiredKind::Point => journey::towards_point(&d, targets),
            DesiredKind::Constant => Box::new(ConstantVelocity(d.velocity.unwrap_or_default())),
            DesiredKind::Journey => {
                let progress = Arc::new(crate::crowd::journey::JourneyProgress::new(
                    population.len(),
                ));
                journeys.push(progress.clone());
                match journey::journey(&d, fields, targets, progress) {
                    Some(j) => Box::new(j),
                    None => continue,
                }
            }
        };
        effects.push(Effect::DesiredVelocity {
            field: field.describe(),
            people: people.len(),
        });
        velocity = velocity.with_term(field, people);
    }
    if still > 0 {
        effects.push(Effect::StandingStill { people: still });
    }
    velocity
}
