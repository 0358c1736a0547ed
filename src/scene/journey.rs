//! `kind = "journey"`: a chain of waypoints (points with a reach, or regions), each headed for
//! by a straight line or the geodesic route, then the exits or a point. Checked here, and
//! turned into a [`Journey`] field: one geodesic field per distinct waypoint, shared by every
//! journey through it, as the exit fields are shared per set of exits.

use super::build::{chosen_exits, ExitFields};
use super::spec::{DesiredKind, DesiredSpec, Route, WaypointSpec};
use super::{finite, fmt_pt, Ctx, SceneError};
use crate::crowd::fast_marching::{DistanceField, Target};
use crate::crowd::journey::{Journey, JourneyProgress, Stage};
use crate::crowd::velocity::{TowardsExits, TowardsPoint, TowardsTarget, VelocityField};
use crate::crowd::Room;
use std::sync::Arc;

/// A waypoint's reach when not given.
pub(super) const DEFAULT_REACH: f64 = 0.5;

/// The geodesic fields to the places people head for, one per place.
pub(super) type TargetFields = Vec<(Target, Arc<DistanceField>)>;

/// The target of a waypoint (checked).
fn target_of(w: &WaypointSpec) -> Target {
    match (w.point, w.region) {
        (Some(at), _) => Target::Point {
            at,
            reach: w.reach.unwrap_or(DEFAULT_REACH),
        },
        (None, Some(r)) => Target::Region(r),
        (None, None) => unreachable!("a waypoint is checked to have a point or a region"),
    }
}

/// The end of a journey, or a `kind = "point"` desire, as a target: the point, reached where
/// the straight field slows down.
fn end_point(at: [f64; 2]) -> Target {
    Target::Point {
        at,
        reach: TowardsPoint::ARRIVAL,
    }
}

/// A target for messages.
pub(super) fn describe(t: &Target) -> String {
    match t {
        Target::Point { at, .. } => format!("the point {}", fmt_pt(*at)),
        Target::Region(r) => format!("the region {r:?}"),
    }
}

/// Every place somebody heads for by the geodesic route, once each.
pub(super) fn geodesic_targets(terms: &[(DesiredSpec, Vec<usize>)]) -> Vec<Target> {
    let mut out: Vec<Target> = Vec::new();
    let mut want = |t: Target| {
        if !out.contains(&t) {
            out.push(t);
        }
    };
    for (d, _) in terms {
        let point_by_geodesic = d.route == Some(Route::Geodesic);
        match d.kind {
            DesiredKind::Point if point_by_geodesic => want(end_point(d.point.unwrap_or_default())),
            DesiredKind::Journey => {
                for w in d.waypoints.iter().flatten() {
                    if w.route != Some(Route::Straight) {
                        want(target_of(w));
                    }
                }
                if let (Some(at), true) = (d.point, point_by_geodesic) {
                    want(end_point(at));
                }
            }
            _ => {}
        }
    }
    out
}

/// The field towards `target` by `route`: straight to the point (or the region's centre), or
/// down its geodesic field.
fn towards(target: Target, route: Route, targets: &TargetFields) -> Box<dyn VelocityField> {
    let geodesic = targets.iter().find(|(t, _)| *t == target);
    match (route, geodesic) {
        (Route::Geodesic, Some((_, field))) => Box::new(TowardsTarget {
            field: field.clone(),
            target,
        }),
        _ => Box::new(TowardsPoint {
            point: match target {
                Target::Point { at, .. } => at,
                Target::Region([x0, y0, x1, y1]) => [(x0 + x1) / 2.0, (y0 + y1) / 2.0],
            },
        }),
    }
}

/// A `kind = "point"` desire's field: straight, or by the geodesic route.
pub(super) fn towards_point(d: &DesiredSpec, targets: &TargetFields) -> Box<dyn VelocityField> {
    let at = d.point.unwrap_or_default();
    towards(end_point(at), d.route.unwrap_or(Route::Straight), targets)
}

/// A journey's field; `None` when the exit field it ends with was not computed.
pub(super) fn journey(
    d: &DesiredSpec,
    exits: &ExitFields,
    targets: &TargetFields,
    progress: Arc<JourneyProgress>,
) -> Option<Journey> {
    let stages = d
        .waypoints
        .iter()
        .flatten()
        .map(|w| {
            let target = target_of(w);
            Stage {
                target,
                field: towards(target, w.route.unwrap_or(Route::Geodesic), targets),
            }
        })
        .collect();
    let last: Box<dyn VelocityField> = match d.point {
        Some(at) => towards(end_point(at), d.route.unwrap_or(Route::Straight), targets),
        None => {
            let chosen = chosen_exits(d);
            let (_, field) = exits.iter().find(|(c, _)| *c == chosen)?;
            Box::new(TowardsExits {
                field: field.clone(),
                exits: chosen,
            })
        }
    };
    Some(Journey::new(stages, last, progress))
}

/// A journey's waypoints: at least one, each exactly one of `point` (with a positive `reach`)
/// and `region`, finite, inside the room.
pub(super) fn check_waypoints(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    d: &DesiredSpec,
    room: &Room,
) -> Result<(), SceneError> {
    let err = |m: String| Err(cx.err(line, item.to_string(), m));
    let waypoints = match &d.waypoints {
        None => {
            return err("kind = \"journey\" needs `waypoints = [{ point = [x, y] }, …]`".into())
        }
        Some(w) if w.is_empty() => return err(
            "waypoints = [] is no journey: give at least one, or use kind = \"exit\" or \"point\""
                .into(),
        ),
        Some(w) => w,
    };
    for (k, w) in waypoints.iter().enumerate() {
        let which = format!("waypoint {}", k + 1);
        let centre = match (w.point, w.region) {
            (Some(p), None) => {
                if !finite(&p) {
                    return err(format!("{which}: the point is not finite"));
                }
                if let Some(r) = w.reach {
                    if !(r.is_finite() && r > 0.0) {
                        return err(format!(
                            "{which}: reach must be positive and finite, got {r}"
                        ));
                    }
                }
                p
            }
            (None, Some(r)) => {
                if !(finite(&r) && r[2] > r[0] && r[3] > r[1]) {
                    return err(format!(
                        "{which}: the region [x0, y0, x1, y1] = {r:?} needs finite numbers, x1 > x0 and y1 > y0"
                    ));
                }
                if w.reach.is_some() {
                    return err(format!(
                        "{which}: `reach` goes with `point`; a region is reached once the centre is inside"
                    ));
                }
                [(r[0] + r[2]) / 2.0, (r[1] + r[3]) / 2.0]
            }
            _ => return err(format!("{which}: give exactly one of `point` and `region`")),
        };
        if !room.contains(centre) {
            return err(format!(
                "{which}: {} is outside the room: nobody could reach it",
                fmt_pt(centre)
            ));
        }
    }
    Ok(())
}
