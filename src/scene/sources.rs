//! `[[sources]]`: people who arrive during the run. Each is given, when the scene is built,
//! the time they are due and their place (in the source's region, or in the row of places
//! just inside its door); the configuration holds them there from the start, absent from
//! every constraint, until [`Population::admit`](crate::crowd::Population::admit) lets them
//! in once they are due and nobody present covers their place. Places are disjoint and
//! clear of the walls and the obstacles; people share them in turn (person `k` of a source
//! takes place `k mod P`), so whoever finds their place taken waits.

use super::build::{check_gap, check_radii, Clearance, People};
use super::checks::check_desired;
use super::spec::SourceSpec;
use super::{drawn, finite, fmt_pt, Ctx, Origin, SceneError, MAX_PEOPLE};
use crate::crowd::segment_distance;
use crate::stepper::display_number;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Attempts at drawing a place in a region, per place wanted (and at least
/// [`MIN_ATTEMPTS`]): the region is full long before.
const ATTEMPTS_PER_PLACE: usize = 2000;
const MIN_ATTEMPTS: usize = 10_000;

/// One `[[sources]]` entry (index `k`): checks it, then adds its people, absent until due,
/// at their places. `seed` is the override's for the whole scene (this source uses
/// `seed + first`, `first` the index of the scene's random groups it comes after).
pub(super) fn add_source(
    cx: &Ctx<'_>,
    k: usize,
    source: &toml::Spanned<SourceSpec>,
    seed_override: Option<u64>,
    first: usize,
    clear: &Clearance<'_>,
    people: &mut People,
) -> Result<(), SceneError> {
    let line = cx.line_of(source);
    let item = format!("[[sources]] #{}", k + 1);
    let ss = source.get_ref();
    let due = due_times(cx, line, &item, ss)?;
    let total = people.positions.len().saturating_add(due.len());
    if total > MAX_PEOPLE {
        return Err(cx.err(
            line,
            item,
            format!("{total} people: a scene holds at most {MAX_PEOPLE}"),
        ));
    }
    let radii = check_radii(cx, line, &item, ss.radius)?;
    let gap = check_gap(cx, line, &item, ss.gap)?;
    let speed = drawn::check(cx, line, &item, &drawn::SPEED, ss.speed.as_ref(), 1.0)?;
    if let Some(d) = &ss.desired {
        check_desired(cx, line, &item, d, (clear.exit_count, &clear.room.room))?;
    }
    let seed = match seed_override {
        Some(s) => s.wrapping_add((first + k) as u64),
        None => ss.seed.unwrap_or(0),
    };
    // Every place holds the largest person the source can bring.
    let widest = radii.range().1 + gap / 2.0;
    let places = match (&ss.region, &ss.door) {
        (Some(region), None) => region_places(cx, line, &item, *region, widest, due.len(), seed, clear)?,
        (None, Some(door)) => door_places(cx, line, &item, [door.from, door.to], widest, clear)?,
        _ => {
            return Err(cx.err(
                line,
                item,
                "give exactly one of `region = [x0, y0, x1, y1]` and `door = { from = [x, y], to = [x, y] }`",
            ))
        }
    };
    let n = due.len();
    let radius = drawn::draw(
        cx,
        line,
        &item,
        &drawn::RADIUS,
        radii.law(),
        n,
        &mut drawn::source(seed, drawn::RADIUS_STREAM),
    )?;
    let speeds = drawn::draw(
        cx,
        line,
        &item,
        &drawn::SPEED,
        speed,
        n,
        &mut drawn::source(seed, 1),
    )?;
    for (j, &t) in due.iter().enumerate() {
        let origin = Origin {
            item: format!("{item}, person {}", j + 1),
            line,
        };
        let given = ss.speed.map(|_| speeds[j]);
        people.push(
            places[j % places.len()],
            radius[j] + gap / 2.0,
            (speeds[j], given),
            ss.desired.clone(),
            origin,
            (0.0, Some(t), gap),
        );
    }
    let (first_t, last_t) = (due[0], due[n - 1]);
    people.groups.push(format!(
        "{item} ({n} people arriving from t = {} to {}, {} places)",
        display_number(first_t),
        display_number(last_t),
        places.len()
    ));
    Ok(())
}

/// When each person of the source is due: `count` people `1/rate` apart from `start`, or
/// `counts[k]` people (one by default) at each of `times`. Non-decreasing, not empty.
fn due_times(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    ss: &SourceSpec,
) -> Result<Vec<f64>, SceneError> {
    let err = |m: String| Err(cx.err(line, item.to_string(), m));
    let time_ok = |t: f64| t.is_finite() && t >= 0.0;
    match (ss.rate, &ss.times) {
        (Some(rate), None) => {
            if ss.counts.is_some() {
                return err("`counts` goes with `times`; with `rate`, give `count`".into());
            }
            if !(rate.is_finite() && rate > 0.0) {
                return err(format!(
                    "rate: people per second must be positive and finite, got {rate}"
                ));
            }
            let count = match ss.count {
                Some(0) => return err("count = 0 brings nobody: give at least 1".into()),
                Some(c) if c > MAX_PEOPLE => {
                    return err(format!(
                        "count = {c}: a scene holds at most {MAX_PEOPLE} people"
                    ))
                }
                Some(c) => c,
                None => return err("`rate` needs `count`, how many people arrive".into()),
            };
            let start = ss.start.unwrap_or(0.0);
            if !time_ok(start) {
                return err(format!("start: must be ≥ 0 and finite, got {start}"));
            }
            Ok((0..count).map(|j| start + j as f64 / rate).collect())
        }
        (None, Some(times)) => {
            if ss.count.is_some() || ss.start.is_some() {
                return err(
                    "`count` and `start` go with `rate`; with `times`, give `counts`".into(),
                );
            }
            if times.is_empty() {
                return err("times = [] brings nobody: give at least one time".into());
            }
            if let Some(t) = times.iter().find(|&&t| !time_ok(t)) {
                return err(format!("times: every time must be ≥ 0 and finite, got {t}"));
            }
            if let Some(w) = times.windows(2).find(|w| w[1] < w[0]) {
                return err(format!(
                    "times: must not decrease, got {} after {}",
                    w[1], w[0]
                ));
            }
            let counts = match &ss.counts {
                None => vec![1; times.len()],
                Some(c) if c.len() != times.len() => {
                    return err(format!(
                        "counts: one count per time, got {} counts for {} times",
                        c.len(),
                        times.len()
                    ))
                }
                Some(c) => c.clone(),
            };
            if let Some(j) = counts.iter().position(|&c| c == 0) {
                return err(format!(
                    "counts: counts[{j}] = 0 brings nobody at t = {}: drop that time",
                    times[j]
                ));
            }
            let total = counts.iter().fold(0usize, |a, &c| a.saturating_add(c));
            if total > MAX_PEOPLE {
                return err(format!(
                    "counts: {total} people: a scene holds at most {MAX_PEOPLE}"
                ));
            }
            Ok(times
                .iter()
                .zip(&counts)
                .flat_map(|(&t, &c)| std::iter::repeat_n(t, c))
                .collect())
        }
        (Some(_), Some(_)) => err("give either `rate` (with `count`) or `times`, not both".into()),
        (None, None) => err(
            "say when people arrive: `rate = people per second` with `count`, or `times = [t, …]`"
                .into(),
        ),
    }
}

/// Up to `wanted` disjoint places of radius `r` drawn in `region` (from the seed's first
/// stream), each clear of the walls and the obstacles.
#[allow(clippy::too_many_arguments)]
fn region_places(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    region: [f64; 4],
    r: f64,
    wanted: usize,
    seed: u64,
    clear: &Clearance<'_>,
) -> Result<Vec<[f64; 2]>, SceneError> {
    if !(finite(&region) && region[2] > region[0] && region[3] > region[1]) {
        return Err(cx.err(
            line,
            item,
            format!("the region [x0, y0, x1, y1] = {region:?} needs finite numbers, x1 > x0 and y1 > y0"),
        ));
    }
    // Disjoint disks of radius r in the region grown by r: a bound on how many there can be.
    let grown = (region[2] - region[0] + 2.0 * r) * (region[3] - region[1] + 2.0 * r);
    let fit = (grown / (std::f64::consts::PI * r * r)).floor() as usize;
    let wanted = wanted.min(fit.max(1));
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut places: Vec<[f64; 2]> = Vec::new();
    let mut last_refusal = None;
    let attempts = wanted.saturating_mul(ATTEMPTS_PER_PLACE).max(MIN_ATTEMPTS);
    for _ in 0..attempts {
        if places.len() == wanted {
            break;
        }
        let p = [
            rng.gen_range(region[0]..=region[2]),
            rng.gen_range(region[1]..=region[3]),
        ];
        if let Err(why) = clear.check(p, r) {
            last_refusal = Some(why);
            continue;
        }
        if places
            .iter()
            .all(|q| (p[0] - q[0]).hypot(p[1] - q[1]) >= 2.0 * r)
        {
            places.push(p);
        }
    }
    if places.is_empty() {
        return Err(cx.err(
            line,
            item,
            format!(
                "no place for a person of radius {r} in the region {region:?}: {}",
                last_refusal.unwrap_or_else(|| "the region is too small".into())
            ),
        ));
    }
    Ok(places)
}

/// The row of places just inside a door: disks of radius `r` touching the wall, side by
/// side along the door; a place that crosses another wall or an obstacle is left out.
fn door_places(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    [from, to]: [[f64; 2]; 2],
    r: f64,
    clear: &Clearance<'_>,
) -> Result<Vec<[f64; 2]>, SceneError> {
    let room = clear.room;
    if !finite(&from) || !finite(&to) {
        return Err(cx.err(line, item, "door: an end is not finite"));
    }
    let on_edge = (0..room.vertices.len()).any(|e| {
        let (a, b) = room.edge(e);
        segment_distance(from, a, b) <= room.on_tol && segment_distance(to, a, b) <= room.on_tol
    });
    if !on_edge {
        return Err(cx.err(
            line,
            item,
            format!(
                "door: {}–{} is not on a wall of the room (both ends must lie on the same edge of the room's boundary)",
                fmt_pt(from),
                fmt_pt(to)
            ),
        ));
    }
    let along = [to[0] - from[0], to[1] - from[1]];
    let len = along[0].hypot(along[1]);
    let slots = (len / (2.0 * r)).floor() as usize;
    if slots == 0 {
        return Err(cx.err(
            line,
            item,
            format!(
                "door: {} wide, narrower than one person of the source ({} across)",
                display_number(len),
                display_number(2.0 * r)
            ),
        ));
    }
    let unit = [along[0] / len, along[1] / len];
    let mid = [(from[0] + to[0]) / 2.0, (from[1] + to[1]) / 2.0];
    // Inwards: the side of the door the room is on.
    let mut inward = [-unit[1], unit[0]];
    let probe = [
        mid[0] + inward[0] * 1e-6 * room.scale,
        mid[1] + inward[1] * 1e-6 * room.scale,
    ];
    if !room.room.contains(probe) {
        inward = [-inward[0], -inward[1]];
    }
    // A hair more than r from the wall, so that rounding never puts a place into it.
    let depth = r * (1.0 + 1e-9) + room.on_tol;
    let spacing = len / slots as f64;
    let mut refusal = None;
    let places: Vec<[f64; 2]> = (0..slots)
        .map(|j| {
            let s = (j as f64 + 0.5) * spacing;
            [
                from[0] + unit[0] * s + inward[0] * depth,
                from[1] + unit[1] * s + inward[1] * depth,
            ]
        })
        .filter(|&p| match clear.check(p, r) {
            Ok(()) => true,
            Err(why) => {
                refusal.get_or_insert(why);
                false
            }
        })
        .collect();
    if places.is_empty() {
        return Err(cx.err(
            line,
            item,
            format!(
                "door: no place inside it for a person of radius {r}: {}",
                refusal.unwrap_or_default()
            ),
        ));
    }
    Ok(places)
}
