//! An independent checker of a run's `trajectory.csv`: it re-reads the file a real run wrote
//! and recomputes, by its own plain code (no library geometry), the overlaps of the people
//! written (those present), the gaps to the walls (room edges minus exits), to the obstacles
//! and to a round arena's wall, NaNs, whether anyone is written though their disk is wholly
//! outside the room, and whether anyone who left came back. A person not yet written has not
//! arrived (a scene's sources); written and then missing from a frame, they have left.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// An obstacle as the checker sees it: its shape at `t = 0` and its displacement at `t`.
pub enum Obstacle {
    /// A disk `(centre, radius)`.
    Disk([f64; 2], f64, Box<dyn Fn(f64) -> [f64; 2]>),
    /// A segment `(a, b)`.
    Segment([f64; 2], [f64; 2], Box<dyn Fn(f64) -> [f64; 2]>),
    /// A round wall `(centre, radius)` that people stay *inside* (an arena).
    Enclosure([f64; 2], f64),
}

/// The geometry the run must respect.
pub struct Geometry {
    /// Room vertices in order.
    pub room: Vec<[f64; 2]>,
    /// Exit segments (each on one room edge).
    pub exits: Vec<([f64; 2], [f64; 2])>,
    /// Obstacles.
    pub obstacles: Vec<Obstacle>,
    /// Radius of each person.
    pub radii: Vec<f64>,
}

/// The people written at one recorded time: `(id, position)`.
type State = Vec<(usize, [f64; 2])>;

/// What the checker found.
#[derive(Debug, Default)]
pub struct Findings {
    /// Rows read.
    pub rows: usize,
    /// Distinct times.
    pub times: usize,
    /// Largest overlap of two present people.
    pub max_overlap: f64,
    /// Largest penetration of a present person into a wall or obstacle.
    pub max_penetration: f64,
    /// Everything wrong beyond the tolerance (capped).
    pub problems: Vec<String>,
    /// Present people at the last time.
    pub present_at_end: usize,
}

fn dist_point_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let mut s = if l2 > 0.0 {
        ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2
    } else {
        0.0
    };
    s = s.clamp(0.0, 1.0);
    let (cx, cy) = (a[0] + s * dx, a[1] + s * dy);
    ((p[0] - cx).powi(2) + (p[1] - cy).powi(2)).sqrt()
}

/// Whether `p` lies inside the polygon `v` (even–odd rule).
fn point_in_polygon(v: &[[f64; 2]], p: [f64; 2]) -> bool {
    let mut inside = false;
    for k in 0..v.len() {
        let (a, b) = (v[k], v[(k + 1) % v.len()]);
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
        {
            inside = !inside;
        }
    }
    inside
}

/// Each person's radius, read from a run's `people.csv` (`id,radius,…`, in id order): what a
/// run with random radii is checked with.
pub fn radii_from_people(people: &Path) -> Vec<f64> {
    let text =
        std::fs::read_to_string(people).unwrap_or_else(|e| panic!("{}: {e}", people.display()));
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("id,radius,t_left,x_left,y_left"));
    lines
        .enumerate()
        .map(|(i, line)| {
            let c: Vec<&str> = line.split(',').collect();
            assert_eq!(c[0].parse::<usize>().ok(), Some(i), "{line}");
            c[1].parse().expect("radius")
        })
        .collect()
}

/// The room's edges with the exits cut out.
fn wall_pieces(g: &Geometry) -> Vec<([f64; 2], [f64; 2])> {
    let n = g.room.len();
    let mut out = Vec::new();
    for k in 0..n {
        let (a, b) = (g.room[k], g.room[(k + 1) % n]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len = (dx * dx + dy * dy).sqrt();
        let param = |p: [f64; 2]| ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / (len * len);
        let mut cuts: Vec<(f64, f64)> = g
            .exits
            .iter()
            .filter(|(e0, e1)| {
                dist_point_segment(*e0, a, b) < 1e-9 * len.max(1.0)
                    && dist_point_segment(*e1, a, b) < 1e-9 * len.max(1.0)
            })
            .map(|(e0, e1)| {
                let (s0, s1) = (param(*e0), param(*e1));
                (s0.min(s1), s0.max(s1))
            })
            .collect();
        cuts.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut s = 0.0;
        for (c0, c1) in cuts {
            if c0 > s {
                out.push((
                    [a[0] + s * dx, a[1] + s * dy],
                    [a[0] + c0 * dx, a[1] + c0 * dy],
                ));
            }
            s = s.max(c1);
        }
        if s < 1.0 {
            out.push(([a[0] + s * dx, a[1] + s * dy], b));
        }
    }
    out
}

/// Reads `csv` and checks every recorded time against `g`, with tolerance `tol`.
pub fn check_trajectory(csv: &Path, g: &Geometry, tol: f64) -> Findings {
    let text = std::fs::read_to_string(csv).unwrap_or_else(|e| panic!("{}: {e}", csv.display()));
    let mut lines = text.lines();
    let header = lines.next();
    let fields = match header {
        Some("t,id,x,y") => 4,
        Some("t,id,x,y,pressure") => 5,
        other => panic!("header of {}: {other:?}", csv.display()),
    };
    let mut by_time: BTreeMap<u64, (f64, State)> = BTreeMap::new();
    let mut f = Findings::default();
    for (ln, line) in lines.enumerate() {
        let c: Vec<&str> = line.split(',').collect();
        assert_eq!(c.len(), fields, "line {}: {line}", ln + 2);
        let t: f64 = c[0].parse().expect("t");
        let id: usize = c[1].parse().expect("id");
        let x: f64 = c[2].parse().expect("x");
        let y: f64 = c[3].parse().expect("y");
        if !(t.is_finite() && x.is_finite() && y.is_finite()) {
            f.problems
                .push(format!("line {}: non-finite value: {line}", ln + 2));
        }
        f.rows += 1;
        by_time
            .entry(t.to_bits())
            .or_insert_with(|| (t, Vec::new()))
            .1
            .push((id, [x, y]));
    }
    let mut states: Vec<(f64, State)> = by_time.into_values().collect();
    states.sort_by(|a, b| a.0.total_cmp(&b.0));
    f.times = states.len();
    let walls = wall_pieces(g);
    // Who has been written, and who has been written and then missing from a frame: left.
    let mut seen = vec![false; g.radii.len()];
    let mut left = vec![false; g.radii.len()];
    let push = |f: &mut Findings, m: String| {
        if f.problems.len() < 20 {
            f.problems.push(m);
        }
    };
    for (t, present) in &states {
        let mut written = vec![false; g.radii.len()];
        for &(id, p) in present {
            if left[id] {
                push(
                    &mut f,
                    format!("t = {t}: person {id} is written again after leaving"),
                );
            }
            written[id] = true;
            let inside = point_in_polygon(&g.room, p)
                || (0..g.room.len()).any(|k| {
                    dist_point_segment(p, g.room[k], g.room[(k + 1) % g.room.len()]) < g.radii[id]
                });
            if !inside {
                push(
                    &mut f,
                    format!("t = {t}: person {id} at {p:?} is written wholly outside the room"),
                );
            }
        }
        for id in 0..seen.len() {
            left[id] |= seen[id] && !written[id];
            seen[id] |= written[id];
        }
        for (a, &(i, p)) in present.iter().enumerate() {
            let ri = g.radii[i];
            for &(j, q) in &present[a + 1..] {
                let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
                let overlap = ri + g.radii[j] - d;
                f.max_overlap = f.max_overlap.max(overlap);
                if overlap.is_nan() || overlap > tol {
                    push(
                        &mut f,
                        format!("t = {t}: people {i} and {j} overlap by {overlap:.3e}"),
                    );
                }
            }
            for (w0, w1) in &walls {
                let pen = ri - dist_point_segment(p, *w0, *w1);
                f.max_penetration = f.max_penetration.max(pen);
                if pen.is_nan() || pen > tol {
                    push(
                        &mut f,
                        format!(
                            "t = {t}: person {i} at {p:?} is {pen:.3e} into the wall {w0:?}–{w1:?}"
                        ),
                    );
                }
            }
            for (k, o) in g.obstacles.iter().enumerate() {
                let pen = match o {
                    Obstacle::Disk(c, r, off) => {
                        let o = off(*t);
                        let d =
                            ((p[0] - c[0] - o[0]).powi(2) + (p[1] - c[1] - o[1]).powi(2)).sqrt();
                        ri + r - d
                    }
                    Obstacle::Segment(a, b, off) => {
                        let o = off(*t);
                        let a = [a[0] + o[0], a[1] + o[1]];
                        let b = [b[0] + o[0], b[1] + o[1]];
                        ri - dist_point_segment(p, a, b)
                    }
                    Obstacle::Enclosure(c, r) => {
                        ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)).sqrt() + ri - r
                    }
                };
                f.max_penetration = f.max_penetration.max(pen);
                if pen.is_nan() || pen > tol {
                    push(
                        &mut f,
                        format!("t = {t}: person {i} at {p:?} is {pen:.3e} into obstacle #{k}"),
                    );
                }
            }
        }
        f.present_at_end = present.len();
    }
    f
}

/// A fresh directory under the system's temporary directory.
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("sweeping-hard-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// No offset: a static obstacle.
pub fn still() -> Box<dyn Fn(f64) -> [f64; 2]> {
    Box::new(|_| [0.0, 0.0])
}

/// Offset `t·v`.
pub fn moving(v: [f64; 2]) -> Box<dyn Fn(f64) -> [f64; 2]> {
    Box::new(move |t| [t * v[0], t * v[1]])
}
