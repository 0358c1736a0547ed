//! Who is in the scene at the start: the people the file lists, the random crowds placed clear
//! of the room's walls, the obstacles and each other, and their checked speeds, gaps and radii.

use super::geometry::{shapes_of, Placed, RoomPlan, Wall};
use crate::constraint::ConstraintKernel;
use crate::crowd::{segment_distance, PersonShapeKernel, Room, ShapeParams};
use crate::numbers::display_number;
use crate::scene::checks::{check_desired, polygon_area};
use crate::scene::spec::{CrowdSpec, DesiredSpec, Drawn, RadiusSpec, SceneSpec};
use crate::scene::Arena;
use crate::scene::{
    drawn, finite, fmt_pt, sources, Ctx, ObstacleShape, Origin, SceneError, MAX_PEOPLE,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// How far a person placed at `t = 0` may cross a wall, an obstacle or another person:
/// rounding. A person written as touching a wall (at (9.8, 9.8) with radius 0.2 in a room of
/// 10) is 0.1999999999999993 from it in floating point, and must not be refused as crossing
/// it; the stepper itself accepts `q₀` within `feasibility_tolerance` (1e-9).
pub(super) const TOUCHING: f64 = 1e-12;

/// Where a person of a given radius may stand at `t = 0`: inside the room, clear of the walls
/// and of the obstacles (to within [`TOUCHING`]). The message says what is in the way.
pub(in crate::scene) struct Clearance<'a> {
    pub room: &'a RoomPlan,
    pub walls: &'a [Wall],
    pub obstacles: &'a [Placed],
    /// The round arena, when there is one.
    pub arena: Option<Arena>,
    /// How many exits a desire `kind = "exit"` can head for.
    pub exit_count: usize,
}

impl Clearance<'_> {
    fn walls(&self, p: [f64; 2], r: f64) -> Result<(), String> {
        if !self.room.room.contains(p) {
            return Err(format!("the person at {} is outside the room", fmt_pt(p)));
        }
        if let Some((a, b)) = self
            .walls
            .iter()
            .find(|(a, b)| segment_distance(p, *a, *b) < r - TOUCHING)
        {
            return Err(format!(
                "the person at {} (radius {r}) crosses the wall {}–{}",
                fmt_pt(p),
                fmt_pt(*a),
                fmt_pt(*b)
            ));
        }
        Ok(())
    }

    fn obstacles(&self, p: [f64; 2], r: f64) -> Result<(), String> {
        for (o, _, k) in self.obstacles {
            let inside_polygon = matches!(&o.shape, ObstacleShape::Polygon(v) if (Room { vertices: v.clone() }).contains(p));
            let touches = shapes_of(o).iter().any(|s| {
                let params = ShapeParams {
                    shape: s.clone(),
                    motion: o.motion.clone(),
                    person_radius: r,
                };
                PersonShapeKernel.value(&params, 0.0, p) < -TOUCHING
            });
            if inside_polygon || touches {
                return Err(format!(
                    "the person at {} (radius {r}) is inside obstacle #{} at t = 0",
                    fmt_pt(p),
                    k + 1
                ));
            }
        }
        Ok(())
    }

    fn arena(&self, p: [f64; 2], r: f64) -> Result<(), String> {
        match self.arena {
            Some(Arena { center, radius })
                if (p[0] - center[0]).hypot(p[1] - center[1]) > radius - r + TOUCHING =>
            {
                Err(format!(
                    "the person at {} (radius {r}) crosses the arena wall (circle of radius {radius} about {})",
                    fmt_pt(p),
                    fmt_pt(center)
                ))
            }
            _ => Ok(()),
        }
    }

    pub(in crate::scene) fn check(&self, p: [f64; 2], r: f64) -> Result<(), String> {
        self.walls(p, r)?;
        self.arena(p, r)?;
        self.obstacles(p, r)
    }
}

/// Everybody placed so far, person by person.
#[derive(Default)]
pub(in crate::scene) struct People {
    pub positions: Vec<[f64; 2]>,
    pub radii: Vec<f64>,
    pub speeds: Vec<f64>,
    /// The speed as the scene file gave it (`None`: the default).
    pub speeds_given: Vec<Option<f64>>,
    /// When each person starts walking (their pre-movement time).
    pub starts: Vec<f64>,
    pub desired: Vec<Option<DesiredSpec>>,
    pub origins: Vec<Origin>,
    pub group_of: Vec<usize>,
    pub groups: Vec<String>,
    /// When each person arrives (`None`: there from the start).
    pub due: Vec<Option<f64>>,
    /// The least gap each person keeps (`gap`; their radius includes half of it).
    pub gaps: Vec<f64>,
}

impl People {
    pub(in crate::scene) fn push(
        &mut self,
        p: [f64; 2],
        r: f64,
        (speed, given): (f64, Option<f64>),
        d: Option<DesiredSpec>,
        origin: Origin,
        (start, due, gap): (f64, Option<f64>, f64),
    ) {
        self.due.push(due);
        self.gaps.push(gap);
        self.positions.push(p);
        self.radii.push(r);
        self.speeds.push(speed);
        self.speeds_given.push(given);
        self.starts.push(start);
        self.desired.push(d);
        self.origins.push(origin);
        self.group_of.push(self.groups.len());
    }
}

fn check_speed(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    speed: Option<f64>,
) -> Result<f64, SceneError> {
    let speed = speed.unwrap_or(1.0);
    if !(speed.is_finite() && speed >= 0.0) {
        return Err(cx.err(
            line,
            item,
            format!("the speed must be ≥ 0 and finite, got {speed}"),
        ));
    }
    Ok(speed)
}

/// `gap`: the least distance a group keeps, ≥ 0 and finite (default 0).
pub(in crate::scene) fn check_gap(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    gap: Option<f64>,
) -> Result<f64, SceneError> {
    let gap = gap.unwrap_or(0.0);
    if !(gap.is_finite() && gap >= 0.0) {
        return Err(cx.err(
            line,
            item,
            format!("gap: must be ≥ 0 and finite, got {gap}"),
        ));
    }
    Ok(gap)
}

/// A group's radii: a number or a range drawn with the placement (so that the crowds of
/// earlier scenes keep their places), or a distribution drawn from a stream of its own.
#[derive(Clone, Copy)]
pub(in crate::scene) enum Radii {
    Placement(f64, f64),
    Drawn(drawn::Checked),
}

impl Radii {
    /// The least and the largest radius.
    pub fn range(self) -> (f64, f64) {
        match self {
            Radii::Placement(a, b) => (a, b),
            Radii::Drawn(c) => drawn::range(c),
        }
    }

    /// As a law to draw from, a range drawn uniformly.
    pub fn law(self) -> drawn::Checked {
        match self {
            Radii::Placement(a, b) if a == b => drawn::Checked::Fixed(a),
            Radii::Placement(a, b) => drawn::Checked::Uniform(a, b),
            Radii::Drawn(c) => c,
        }
    }
}

pub(in crate::scene) fn check_radii(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    radius: RadiusSpec,
) -> Result<Radii, SceneError> {
    let (rmin, rmax) = match radius {
        RadiusSpec::Fixed(r) => (r, r),
        RadiusSpec::Range([a, b]) => (a, b),
        RadiusSpec::Distribution(d) => {
            let law = Drawn::Distribution(d);
            return drawn::check(cx, line, item, &drawn::RADIUS, Some(&law), 0.0).map(Radii::Drawn);
        }
    };
    if !(rmin.is_finite() && rmax.is_finite() && rmin > 0.0 && rmax >= rmin) {
        return Err(cx.err(
            line,
            item,
            match radius {
                RadiusSpec::Range([a, b]) => format!(
                    "a range of radii needs 0 < min ≤ max, both finite, got radius = [{a:?}, {b:?}]"
                ),
                _ => format!("the radius must be positive and finite, got radius = {rmin:?}"),
            },
        ));
    }
    Ok(Radii::Placement(rmin, rmax))
}

/// Everybody in the scene: the `[[people]]`, then each `[[crowds]]` entry placed, then the
/// people of each `[[sources]]` entry; an error when that is nobody.
pub(super) fn everybody(
    cx: &Ctx<'_>,
    spec: &SceneSpec,
    seed: Option<u64>,
    clear: &Clearance<'_>,
) -> Result<People, SceneError> {
    let mut people = explicit_people(cx, spec, clear)?;
    for (g, c) in spec.crowds.iter().enumerate() {
        place_crowd(cx, g, c, seed, clear, &mut people)?;
    }
    for (k, s) in spec.sources.iter().enumerate() {
        let first = spec.crowds.len();
        sources::add_source(cx, k, s, seed, first, clear, &mut people)?;
    }
    if people.positions.is_empty() {
        return Err(cx.err(
            None,
            "[[people]] / [[crowds]] / [[sources]]",
            "the scene has nobody in it",
        ));
    }
    Ok(people)
}

/// The `[[people]]`, each its own group, then a check that no two of them overlap.
fn explicit_people(
    cx: &Ctx<'_>,
    spec: &SceneSpec,
    clear: &Clearance<'_>,
) -> Result<People, SceneError> {
    let exit_count = clear.exit_count;
    // Checked before any person: a million checks would come first, for an error in the end.
    if let Some(p) = spec.people.get(MAX_PEOPLE) {
        return Err(cx.err(
            cx.line_of(p),
            format!("[[people]] #{}", MAX_PEOPLE + 1),
            format!(
                "{} people: a scene holds at most {MAX_PEOPLE}",
                spec.people.len()
            ),
        ));
    }
    let mut people = People::default();
    for (k, p) in spec.people.iter().enumerate() {
        let line = cx.line_of(p);
        let item = format!("[[people]] #{}", k + 1);
        let ps = p.get_ref();
        if !finite(&ps.position) {
            return Err(cx.err(
                line,
                item,
                format!("the position {:?} is not finite", ps.position),
            ));
        }
        if !(ps.radius.is_finite() && ps.radius > 0.0) {
            return Err(cx.err(
                line,
                item,
                format!("the radius must be positive and finite, got {}", ps.radius),
            ));
        }
        let speed = check_speed(cx, line, &item, ps.speed)?;
        let (radius, gap) = (ps.radius, 0.0);
        let start = match drawn::check(
            cx,
            line,
            &item,
            &drawn::PRE_MOVEMENT,
            ps.pre_movement.map(Drawn::Fixed).as_ref(),
            0.0,
        )? {
            drawn::Checked::Fixed(v) => v,
            _ => unreachable!("a number is checked as a number"),
        };
        if let Some(d) = &ps.desired {
            check_desired(cx, line, &item, d, (exit_count, &clear.room.room))?;
        }
        clear
            .walls(ps.position, radius)
            .map_err(|m| cx.err(line, item.clone(), m))?;
        clear
            .arena(ps.position, radius)
            .map_err(|m| cx.err(line, item.clone(), m))?;
        clear
            .obstacles(ps.position, radius)
            .map_err(|m| cx.err(line, item.clone(), m))?;
        let origin = Origin {
            item: item.clone(),
            line,
        };
        people.push(
            ps.position,
            radius,
            (speed, ps.speed),
            ps.desired.clone(),
            origin,
            (start, None, gap),
        );
        people.groups.push(item);
    }
    check_overlaps(cx, &people)?;
    Ok(people)
}

/// Explicit people must not overlap (random ones are placed clear of everybody): a spatial
/// hash of cell 2·r_max finds every overlapping pair in O(N).
fn check_overlaps(cx: &Ctx<'_>, people: &People) -> Result<(), SceneError> {
    let (positions, radii, origins) = (&people.positions, &people.radii, &people.origins);
    let rmax = radii.iter().copied().fold(0.0, f64::max);
    let mut hash = SpatialHash::new(2.0 * rmax);
    for (j, p) in positions.iter().enumerate() {
        if let Some(i) = hash.near(*p).find(|&i| {
            let d = ((p[0] - positions[i][0]).powi(2) + (p[1] - positions[i][1]).powi(2)).sqrt();
            d < radii[i] + radii[j] - TOUCHING
        }) {
            let d = ((positions[i][0] - p[0]).powi(2) + (positions[i][1] - p[1]).powi(2)).sqrt();
            return Err(cx.err(
                origins[j].line,
                format!("{} and {}", origins[i].item, origins[j].item),
                format!(
                    "the two people overlap at t = 0 (centres {} apart, radii {} + {})",
                    d, radii[i], radii[j]
                ),
            ));
        }
        hash.insert(*p, j);
    }
    Ok(())
}

/// One `[[crowds]]` entry (index `g`): checks it, bounds its count by area, then places its
/// people at random (seed `seed` or the override's `seed + g`), clear of the walls, the
/// obstacles and everybody placed before.
fn place_crowd(
    cx: &Ctx<'_>,
    g: usize,
    c: &toml::Spanned<CrowdSpec>,
    seed_override: Option<u64>,
    clear: &Clearance<'_>,
    people: &mut People,
) -> Result<(), SceneError> {
    let (room, exit_count) = (clear.room, clear.exit_count);
    let line = cx.line_of(c);
    let item = format!("[[crowds]] #{}", g + 1);
    let cs = c.get_ref();
    if cs.count == 0 {
        return Err(cx.err(
            line,
            item,
            "count = 0 places nobody: give at least 1, or drop the crowd",
        ));
    }
    let radii = check_radii(cx, line, &item, cs.radius)?;
    let gap = check_gap(cx, line, &item, cs.gap)?;
    // The disks of the constraints: each radius grown by half the gap.
    let (rmin, rmax) = {
        let (a, b) = radii.range();
        (a + gap / 2.0, b + gap / 2.0)
    };
    let speed = drawn::check(cx, line, &item, &drawn::SPEED, cs.speed.as_ref(), 1.0)?;
    let pre_movement = drawn::check(
        cx,
        line,
        &item,
        &drawn::PRE_MOVEMENT,
        cs.pre_movement.as_ref(),
        0.0,
    )?;
    if let Some(d) = &cs.desired {
        check_desired(cx, line, &item, d, (exit_count, &clear.room.room))?;
    }
    let (bx0, by0, bx1, by1) = room.bbox;
    let region = cs.region.unwrap_or([bx0, by0, bx1, by1]);
    if !(finite(&region) && region[2] > region[0] && region[3] > region[1]) {
        return Err(cx.err(line, item, format!("the region [x0, y0, x1, y1] = {region:?} needs finite numbers, x1 > x0 and y1 > y0")));
    }
    let seed = match seed_override {
        Some(s) => s.wrapping_add(g as u64),
        None => cs.seed.unwrap_or(0),
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let placed_before = people.positions.len();
    check_count(
        cx,
        line,
        &item,
        (cs.count, placed_before),
        rmin,
        region,
        room,
    )?;
    // Drawn after the count is bounded: a count far beyond the room is refused, not
    // allocated.
    let speeds = drawn::draw(
        cx,
        line,
        &item,
        &drawn::SPEED,
        speed,
        cs.count,
        &mut drawn::source(seed, 1),
    )?;
    let starts = drawn::draw(
        cx,
        line,
        &item,
        &drawn::PRE_MOVEMENT,
        pre_movement,
        cs.count,
        &mut drawn::source(seed, 2),
    )?;
    let drawn_radii = match radii {
        Radii::Placement(..) => None,
        Radii::Drawn(law) => Some(drawn::draw(
            cx,
            line,
            &item,
            &drawn::RADIUS,
            law,
            cs.count,
            &mut drawn::source(seed, drawn::RADIUS_STREAM),
        )?),
    };
    let max_attempts = cs.count.saturating_mul(2000).saturating_add(10_000);
    let mut placed = 0usize;
    let mut attempts = 0usize;
    let global_rmax = people.radii.iter().copied().fold(rmax, f64::max);
    let mut hash = SpatialHash::new(2.0 * global_rmax);
    for (i, p) in people.positions.iter().enumerate() {
        hash.insert(*p, i);
    }
    while placed < cs.count {
        attempts += 1;
        if attempts > max_attempts {
            return Err(cx.err(line, item, format!("could place only {placed} of {} people without overlap in the region {region:?} after {max_attempts} attempts; enlarge the region or lower the count", cs.count)));
        }
        let r = match &drawn_radii {
            Some(drawn) => drawn[placed] + gap / 2.0,
            None if rmax > rmin => rng.gen_range(rmin..=rmax),
            None => rmin,
        };
        let p = [
            rng.gen_range(region[0]..=region[2]),
            rng.gen_range(region[1]..=region[3]),
        ];
        if clear.check(p, r).is_err() {
            continue;
        }
        let (positions, radii) = (&people.positions, &people.radii);
        let clash = hash.near(p).any(|j| {
            let d = ((p[0] - positions[j][0]).powi(2) + (p[1] - positions[j][1]).powi(2)).sqrt();
            d < r + radii[j] + 1e-9
        });
        if clash {
            continue;
        }
        hash.insert(p, people.positions.len());
        let origin = Origin {
            item: format!("{item}, person {}", placed + 1),
            line,
        };
        // A speed the file gives, drawn or not, is checked against a constant desire.
        let given = cs.speed.map(|_| speeds[placed]);
        people.push(
            p,
            r,
            (speeds[placed], given),
            cs.desired.clone(),
            origin,
            (starts[placed], None, gap),
        );
        placed += 1;
    }
    people.groups.push(format!("{item} ({} people)", cs.count));
    Ok(())
}

/// A crowd's `count` bounded before any placement, first by packing: the disks (radius ≥
/// `rmin`) are disjoint and lie in the room and in the region grown by `rmin`, so their count
/// is at most the smaller of those areas over π rmin² (a count beyond it would only fail,
/// slowly); then by [`MAX_PEOPLE`], with the people placed `before` them.
fn check_count(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    (count, before): (usize, usize),
    rmin: f64,
    region: [f64; 4],
    room: &RoomPlan,
) -> Result<(), SceneError> {
    let room_area = polygon_area(&room.vertices).abs();
    let grown = (region[2] - region[0] + 2.0 * rmin) * (region[3] - region[1] + 2.0 * rmin);
    let fit = room_area.min(grown) / (std::f64::consts::PI * rmin * rmin);
    if count as f64 > fit {
        return Err(cx.err(line, item, format!("{} people of radius ≥ {rmin} cannot fit: the area bound allows at most {} (room area {}, region {region:?})", count, fit.floor(), display_number(room_area))));
    }
    let total = before.saturating_add(count);
    if total > MAX_PEOPLE {
        return Err(cx.err(
            line,
            item,
            format!("{total} people: a scene holds at most {MAX_PEOPLE}"),
        ));
    }
    Ok(())
}

/// Buckets of points by cell, for the random placement.
struct SpatialHash {
    cell: f64,
    map: std::collections::HashMap<(i64, i64), Vec<usize>>,
}

impl SpatialHash {
    fn new(cell: f64) -> Self {
        Self {
            cell: cell.max(1e-9),
            map: Default::default(),
        }
    }
    fn key(&self, p: [f64; 2]) -> (i64, i64) {
        (
            (p[0] / self.cell).floor() as i64,
            (p[1] / self.cell).floor() as i64,
        )
    }
    fn insert(&mut self, p: [f64; 2], i: usize) {
        let k = self.key(p);
        self.map.entry(k).or_default().push(i);
    }
    /// Everything in the 3×3 cells around `p` (all points within `cell` of it, and more).
    fn near(&self, p: [f64; 2]) -> impl Iterator<Item = usize> + '_ {
        let (kx, ky) = self.key(p);
        (-1..=1)
            .flat_map(move |dx| (-1..=1).map(move |dy| (kx + dx, ky + dy)))
            .flat_map(move |k| self.map.get(&k).into_iter().flatten().copied())
    }
}
