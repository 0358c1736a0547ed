//! The checks of a scene that more than one build step makes: a desired velocity and the
//! exits it names, the resolution of the scene's coordinates, and the shape of a polygon
//! (its area, edges that meet, its bounding box).

use super::spec::{self, DesiredKind, DesiredSpec, RadiusSpec};
use super::{finite, journey, Ctx, SceneError};

/// Checks a desired velocity: the keys its kind takes, the exits it names, a journey's
/// waypoints (inside `room`).
pub(super) fn check_desired(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    d: &DesiredSpec,
    (exit_count, room): (usize, &crate::crowd::Room),
) -> Result<(), SceneError> {
    let item = format!("{item} desired");
    let err = |m: &str| Err(cx.err(line, item.clone(), m.to_string()));
    if d.exits.is_some() && !matches!(d.kind, DesiredKind::Exit | DesiredKind::Journey) {
        return err("`exits` goes only with kind = \"exit\" or \"journey\"");
    }
    if d.waypoints.is_some() && d.kind != DesiredKind::Journey {
        return err("`waypoints` goes only with kind = \"journey\"");
    }
    let to_point =
        d.kind == DesiredKind::Point || (d.kind == DesiredKind::Journey && d.point.is_some());
    if d.route.is_some() && !to_point {
        return err("`route` goes only with kind = \"point\", or a journey ending at `point`");
    }
    match d.kind {
        DesiredKind::Exit => {
            check_exits_named(cx, line, &item, d, exit_count)?;
            if d.point.is_some() || d.velocity.is_some() {
                return err("kind = \"exit\" takes neither `point` nor `velocity`");
            }
        }
        DesiredKind::Journey => {
            journey::check_waypoints(cx, line, &item, d, room)?;
            if d.velocity.is_some() {
                return err("kind = \"journey\" does not take `velocity`");
            }
            match d.point {
                Some(_) if d.exits.is_some() => {
                    return err("a journey ends at `point` or at the exits (`exits`), not both")
                }
                Some(p) if !finite(&p) => return err("the point is not finite"),
                Some(_) => {}
                None => check_exits_named(cx, line, &item, d, exit_count)?,
            }
        }
        DesiredKind::Point => match d.point {
            None => return err("kind = \"point\" needs `point = [x, y]`"),
            Some(p) if !finite(&p) => return err("the point is not finite"),
            Some(_) if d.velocity.is_some() => {
                return err("kind = \"point\" does not take `velocity`")
            }
            _ => {}
        },
        DesiredKind::Constant => match d.velocity {
            None => return err("kind = \"constant\" needs `velocity = [vx, vy]`"),
            Some(v) if !finite(&v) => return err("the velocity is not finite"),
            Some(_) if d.point.is_some() => {
                return err("kind = \"constant\" does not take `point`")
            }
            _ => {}
        },
    }
    Ok(())
}

/// The exits a desire heads for: at least one in the scene, and those it names exist, once
/// each.
fn check_exits_named(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    d: &DesiredSpec,
    exit_count: usize,
) -> Result<(), SceneError> {
    let kind = if d.kind == DesiredKind::Journey {
        "a journey ending at the exits"
    } else {
        "kind = \"exit\""
    };
    if exit_count == 0 {
        return Err(cx.err(line, item, format!("{kind} needs at least one [[exits]]")));
    }
    if let Some(chosen) = &d.exits {
        let mut seen = std::collections::BTreeSet::new();
        if chosen.is_empty() {
            return Err(cx.err(
                line,
                item,
                "exits = [] heads nowhere: name at least one exit, or drop `exits`",
            ));
        }
        for &e in chosen {
            if !(1..=exit_count).contains(&e) {
                return Err(cx.err(
                    line,
                    item,
                    format!(
                        "exits = {chosen:?}: exit {e} does not exist; the scene's \
                         [[exits]] are numbered 1 to {exit_count} in file order"
                    ),
                ));
            }
            if !seen.insert(e) {
                return Err(cx.err(
                    line,
                    item,
                    format!("exits = {chosen:?} names exit {e} twice"),
                ));
            }
        }
    }
    Ok(())
}

/// Refuses scenes whose coordinates f64 cannot resolve at the people's size. Positions are
/// stored as absolute coordinates, so a constraint value computed from them carries a rounding
/// error of a few units in the last place of the largest coordinate: 16 ε max|x| must stay
/// below `1e-6 · min(r_min, 1)` (the run-time violation tolerance is 1e-6). A 5 m room at
/// (1e12, 1e12) with people of radius 0.2 is refused (ε·1e12 ≈ 2e-4); at (1e6, 1e6) it runs.
pub(super) fn check_resolution(
    cx: &Ctx<'_>,
    spec: &spec::SceneSpec,
    room_line: Option<usize>,
    room: &[[f64; 2]],
) -> Result<(), SceneError> {
    let mut max_abs = 0.0f64;
    // Non-finite numbers are reported by their own checks, with their item.
    let mut see = |v: f64| {
        if v.is_finite() {
            max_abs = max_abs.max(v.abs());
        }
    };
    for p in room {
        see(p[0]);
        see(p[1]);
    }
    let mut r_min = f64::INFINITY;
    for o in &spec.obstacles {
        let o = o.get_ref();
        if let Some(d) = &o.disk {
            see(d.center[0].abs() + d.radius.abs());
            see(d.center[1].abs() + d.radius.abs());
        }
        if let Some(sg) = &o.segment {
            sg.from.iter().chain(&sg.to).for_each(|&v| see(v));
        }
        for p in o.polygon.iter().flatten() {
            see(p[0]);
            see(p[1]);
        }
        for w in o.path.iter().flatten() {
            see(w[1]);
            see(w[2]);
        }
    }
    for p in &spec.people {
        let p = p.get_ref();
        see(p.position[0]);
        see(p.position[1]);
        if p.radius > 0.0 {
            r_min = r_min.min(p.radius);
        }
    }
    for c in &spec.crowds {
        let c = c.get_ref();
        c.region.iter().flatten().for_each(|&v| see(v));
        if let Some(r) = least_radius(c.radius) {
            r_min = r_min.min(r);
        }
    }
    for s in &spec.sources {
        let s = s.get_ref();
        s.region.iter().flatten().for_each(|&v| see(v));
        if let Some(d) = &s.door {
            d.from.iter().chain(&d.to).for_each(|&v| see(v));
        }
        if let Some(r) = least_radius(s.radius) {
            r_min = r_min.min(r);
        }
    }
    if !r_min.is_finite() {
        return Ok(()); // nobody (or bad radii): reported with their own errors
    }
    let needed = 1e-6 * r_min.min(1.0);
    let rounding = 16.0 * f64::EPSILON * max_abs;
    if rounding > needed {
        let limit = needed / (16.0 * f64::EPSILON);
        return Err(cx.err(
            room_line,
            "[room]",
            format!(
                "coordinates as large as {max_abs:.3e} are resolved by 64-bit floats only to \
                 about {rounding:.1e}, too coarse for people of radius {r_min} (a contact must \
                 be resolved to {needed:.1e}); keep every coordinate within ±{limit:.2e}, \
                 for instance by moving the scene nearer the origin"
            ),
        ));
    }
    Ok(())
}

/// The least radius `radius` allows, when it is positive.
fn least_radius(radius: RadiusSpec) -> Option<f64> {
    let r = match radius {
        RadiusSpec::Fixed(r) => r,
        RadiusSpec::Range([a, _]) => a,
        RadiusSpec::Distribution(d) => match (d.uniform, d.within) {
            (Some([a, _]), _) | (None, Some([a, _])) => a,
            (None, None) => return None,
        },
    };
    (r > 0.0).then_some(r)
}

pub(super) fn polygon_area(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    0.5 * (0..n)
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
}

/// Two edges of the closed polygon `p` that are not neighbours and meet (cross or touch), by
/// their numbers from 1 (edge `k` runs from vertex `k` to the next); `None` for a simple
/// polygon. `O(n²)`: rooms and obstacles have few vertices.
pub(super) fn meeting_edges(p: &[[f64; 2]]) -> Option<(usize, usize)> {
    let n = p.len();
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let within = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        c[0] >= a[0].min(b[0])
            && c[0] <= a[0].max(b[0])
            && c[1] >= a[1].min(b[1])
            && c[1] <= a[1].max(b[1])
    };
    let meet = |a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]| {
        let (d1, d2) = (cross(c, d, a), cross(c, d, b));
        let (d3, d4) = (cross(a, b, c), cross(a, b, d));
        ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
            && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
            || (d1 == 0.0 && within(c, d, a))
            || (d2 == 0.0 && within(c, d, b))
            || (d3 == 0.0 && within(a, b, c))
            || (d4 == 0.0 && within(a, b, d))
    };
    for i in 0..n {
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue; // the last edge and the first share vertex 1
            }
            if meet(p[i], p[(i + 1) % n], p[j], p[(j + 1) % n]) {
                return Some((i + 1, j + 1));
            }
        }
    }
    None
}

pub(super) fn bbox(p: &[[f64; 2]]) -> (f64, f64, f64, f64) {
    p.iter().fold(
        (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), v| (a.min(v[0]), b.min(v[1]), c.max(v[0]), d.max(v[1])),
    )
}
