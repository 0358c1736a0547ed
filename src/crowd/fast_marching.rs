//! Geodesic distance to the exits (or to a waypoint, [`Target`]) by fast marching on a grid,
//! interpolated so that the field of directions is continuous.
//!
//! The grid is used for this one computation only: walls and obstacles are rasterized to say
//! which nodes are free, the eikonal equation `|∇d| = 1` is solved once (first-order upwind
//! fast marching, Sethian 1996) from the exits, and the result is read back through bilinear
//! interpolation. Constraints never see the grid: walls stay exact segments.
//!
//! Two details make the field usable everywhere a person's centre may be:
//!
//! * blocked nodes (inside walls and obstacles, outside the room) get a value too, by a second
//!   march that extends `d` into them with slope 1, so the interpolation near a wall never
//!   reads an infinite value and the direction there points away from the wall;
//! * the direction is `−g / max(|g|, τ)`, with `g` the central-difference gradient at the nodes
//!   interpolated bilinearly. The gradient of the bilinear interpolant of `d` itself jumps
//!   across cell edges; interpolating node gradients gives a continuous (Lipschitz) field, and
//!   dividing by `max(|g|, τ)` rather than `|g|` keeps it continuous where `g` vanishes (on
//!   the ridges where two routes to an exit meet). Where `|g| ≥ τ` it is a unit vector.

use super::population::segment_distance;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Below this length the interpolated gradient is not normalized to a unit vector (see the
/// module documentation): `0.5`.
pub const GRADIENT_FLOOR: f64 = 0.5;

/// A rectangular grid of nodes `(x0 + i·cell, y0 + j·cell)`, `i < nx`, `j < ny`.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Abscissa of node `(0, 0)`.
    pub x0: f64,
    /// Ordinate of node `(0, 0)`.
    pub y0: f64,
    /// Distance between neighbouring nodes.
    pub cell: f64,
    /// Nodes along x.
    pub nx: usize,
    /// Nodes along y.
    pub ny: usize,
}

impl Grid {
    /// The smallest grid of spacing `cell` covering `[x0, x1] × [y0, y1]`.
    pub fn covering(x0: f64, y0: f64, x1: f64, y1: f64, cell: f64) -> Self {
        let nx = ((x1 - x0) / cell).ceil() as usize + 1;
        let ny = ((y1 - y0) / cell).ceil() as usize + 1;
        Self {
            x0,
            y0,
            cell,
            nx: nx.max(2),
            ny: ny.max(2),
        }
    }

    /// Position of node `(i, j)`.
    pub fn node(&self, i: usize, j: usize) -> [f64; 2] {
        [
            self.x0 + i as f64 * self.cell,
            self.y0 + j as f64 * self.cell,
        ]
    }

    fn index(&self, i: usize, j: usize) -> usize {
        j * self.nx + i
    }

    fn len(&self) -> usize {
        self.nx * self.ny
    }
}

/// The geometry the eikonal solve sees.
#[derive(Debug, Clone, Default)]
pub struct MarchingDomain {
    /// The room's boundary (closed polygon).
    pub room: Vec<[f64; 2]>,
    /// Exits: segments on the room's boundary where `d = 0`.
    pub exits: Vec<([f64; 2], [f64; 2])>,
    /// Disk obstacles `(centre, radius)`.
    pub disks: Vec<([f64; 2], f64)>,
    /// Segment obstacles (thin walls inside the room).
    pub segments: Vec<([f64; 2], [f64; 2])>,
    /// Polygon obstacles (closed).
    pub polygons: Vec<Vec<[f64; 2]>>,
    /// Places inside the room where `d = 0` too (a journey's waypoints); with none, the
    /// exits are the only targets.
    pub targets: Vec<Target>,
}

/// A place inside the room that a field leads to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    /// A point: `d` is the distance to it near it (within `max(reach, 1.5·cell)`).
    Point {
        /// The point.
        at: [f64; 2],
        /// How near counts as there.
        reach: f64,
    },
    /// An axis-aligned rectangle `[x0, y0, x1, y1]`: `d = 0` inside.
    Region([f64; 4]),
}

impl Target {
    /// The distance from `p` to the target (to the point, or to the rectangle).
    pub fn distance(&self, p: [f64; 2]) -> f64 {
        match *self {
            Target::Point { at, .. } => (p[0] - at[0]).hypot(p[1] - at[1]),
            Target::Region([x0, y0, x1, y1]) => {
                let dx = (x0 - p[0]).max(p[0] - x1).max(0.0);
                let dy = (y0 - p[1]).max(p[1] - y1).max(0.0);
                dx.hypot(dy)
            }
        }
    }

    /// Whether a person whose centre is at `p` has reached it.
    pub fn is_reached(&self, p: [f64; 2]) -> bool {
        match *self {
            Target::Point { reach, .. } => self.distance(p) <= reach,
            Target::Region(_) => self.distance(p) == 0.0,
        }
    }

    /// How far from it the seeds of the march lie.
    fn band(&self, cell: f64) -> f64 {
        match *self {
            Target::Point { reach, .. } => reach.max(1.5 * cell),
            Target::Region(_) => 1.5 * cell,
        }
    }
}

/// Why the distance field could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FastMarchingError {
    /// The grid spacing is not a positive finite number.
    #[error("the fast-marching cell size {0} must be positive and finite")]
    BadCell(f64),
    /// The grid would be too large (its node count, infinite when it overflows).
    #[error(
        "the fast-marching grid would have {0:.3e} nodes (more than 4·10⁶); use a larger cell"
    )]
    TooLarge(f64),
    /// No exit touches a free node.
    #[error("no exit is reachable on the fast-marching grid (cell {0}); is there an exit on a wall, with free space behind it?")]
    NoExit(f64),
    /// No free node lies at a target.
    #[error("no free node of the fast-marching grid (cell {0}) lies at the target: is it inside the room and clear of the obstacles?")]
    NoTarget(f64),
}

/// The geodesic distance to the nearest exit on a grid, with its interpolated gradient.
///
/// ```
/// use sweeping::crowd::fast_marching::{DistanceField, MarchingDomain};
/// // A 10 × 10 room with an exit on the right wall.
/// let domain = MarchingDomain {
///     room: vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]],
///     exits: vec![([10.0, 4.0], [10.0, 6.0])],
///     ..Default::default()
/// };
/// let field = DistanceField::compute(&domain, 0.1).unwrap();
/// let d = field.distance([5.0, 5.0]);
/// assert!((d - 5.0).abs() < 0.1);
/// let v = field.direction([5.0, 5.0]);
/// assert!((v[0] - 1.0).abs() < 1e-2 && v[1].abs() < 1e-2);
/// ```
#[derive(Debug, Clone)]
pub struct DistanceField {
    grid: Grid,
    values: Vec<f64>,
    gradients: Vec<[f64; 2]>,
    free: Vec<bool>,
    /// Free nodes from which an exit is reached through free nodes (the first march's).
    routed: Vec<bool>,
}

#[derive(PartialEq)]
struct Entry(f64, usize);
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        // Min-heap on the value.
        other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
    }
}

use super::population::point_in_polygon;

impl DistanceField {
    /// Solves `|∇d| = 1`, `d = 0` on the exits, over the free nodes of a grid of spacing
    /// `cell` covering the room (with a margin of three cells).
    ///
    /// A node is free when it lies inside the room and is not blocked by an obstacle: inside a
    /// disk or polygon, or within `0.75·cell` of a segment obstacle (so that no grid edge
    /// crosses a thin wall).
    ///
    /// # Errors
    /// A bad cell size, a grid above 4·10⁶ nodes, or no exit next to a free node.
    pub fn compute(domain: &MarchingDomain, cell: f64) -> Result<Self, FastMarchingError> {
        if !(cell.is_finite() && cell > 0.0) {
            return Err(FastMarchingError::BadCell(cell));
        }
        let (mut x0, mut y0, mut x1, mut y1) = (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        );
        for p in &domain.room {
            x0 = x0.min(p[0]);
            y0 = y0.min(p[1]);
            x1 = x1.max(p[0]);
            y1 = y1.max(p[1]);
        }
        let margin = 3.0 * cell;
        let nodes = (((x1 - x0 + 2.0 * margin) / cell).ceil() + 1.0)
            * (((y1 - y0 + 2.0 * margin) / cell).ceil() + 1.0);
        if !nodes.is_finite() || nodes > 4e6 {
            return Err(FastMarchingError::TooLarge(nodes));
        }
        let grid = Grid::covering(x0 - margin, y0 - margin, x1 + margin, y1 + margin, cell);
        let n = grid.len();
        let mut free = vec![false; n];
        for j in 0..grid.ny {
            for i in 0..grid.nx {
                let p = grid.node(i, j);
                let blocked = !point_in_polygon(&domain.room, p)
                    || domain
                        .disks
                        .iter()
                        .any(|(c, r)| (p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) < r * r)
                    || domain
                        .segments
                        .iter()
                        .any(|(a, b)| segment_distance(p, *a, *b) < 0.75 * cell)
                    || domain.polygons.iter().any(|poly| point_in_polygon(poly, p));
                free[grid.index(i, j)] = !blocked;
            }
        }
        // Seeds: free nodes within 1.5 cells of an exit, in front of its opening, get their
        // exact distance to it. Only in front: a node beside an end of the exit can lie behind
        // a thin wall that meets the room's edge there (a corridor's wall ending at its exit),
        // and a seed there would lead the people behind that wall into it.
        // Blocked nodes just outside an exit, behind its opening, get minus their distance, so
        // the field carries people through the door rather than stopping them on it. Only
        // behind the opening: a blocked node beside an end of the exit is in or behind the wall
        // that continues it, and a value below the exit's there would pull people straight
        // into that wall (a lone person can stop for good against it near a door's edge, where
        // the pull into the wall balances the pull along it towards the door).
        let mut values = vec![f64::INFINITY; n];
        let mut known = vec![false; n];
        let band = 1.5 * cell;
        let mut seeded = false;
        for j in 0..grid.ny {
            for i in 0..grid.nx {
                let p = grid.node(i, j);
                let k = grid.index(i, j);
                if free[k] {
                    // A target's seeds: its exact distance near it.
                    if let Some(d) = domain
                        .targets
                        .iter()
                        .filter(|t| t.distance(p) <= t.band(cell))
                        .map(|t| t.distance(p))
                        .reduce(f64::min)
                    {
                        values[k] = d;
                        known[k] = true;
                        seeded = true;
                        continue;
                    }
                    let d = domain
                        .exits
                        .iter()
                        .filter(|(a, b)| foot_is_on_segment(p, *a, *b))
                        .map(|(a, b)| segment_distance(p, *a, *b))
                        .fold(f64::INFINITY, f64::min);
                    if d <= band {
                        values[k] = d;
                        known[k] = true;
                        seeded = true;
                    }
                } else {
                    let behind = domain
                        .exits
                        .iter()
                        .filter(|(a, b)| foot_is_on_segment(p, *a, *b))
                        .map(|(a, b)| segment_distance(p, *a, *b))
                        .fold(f64::INFINITY, f64::min);
                    if behind <= band && !point_in_polygon(&domain.room, p) {
                        values[k] = -behind;
                        known[k] = true;
                    }
                }
            }
        }
        if !seeded {
            return Err(if domain.targets.is_empty() {
                FastMarchingError::NoExit(cell)
            } else {
                FastMarchingError::NoTarget(cell)
            });
        }
        // First march: over free nodes only.
        let allowed: Vec<bool> = free.clone();
        march(&grid, &mut values, &mut known, &allowed);
        let routed: Vec<bool> = known.iter().zip(&free).map(|(k, f)| *k && *f).collect();
        // Second march: extend into every remaining node with slope 1.
        let allowed = vec![true; n];
        march(&grid, &mut values, &mut known, &allowed);
        let gradients = node_gradients(&grid, &values);
        Ok(Self {
            grid,
            values,
            gradients,
            free,
            routed,
        })
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Whether node `(i, j)` is free (inside the room, outside every obstacle).
    pub fn is_free(&self, i: usize, j: usize) -> bool {
        self.free[self.grid.index(i, j)]
    }

    /// Whether an exit can be reached from `p` without crossing an obstacle or a wall: a free
    /// node of the grid cell holding `p` (or, when none of its four is free, of the cells
    /// around it) is joined to an exit by free nodes. Beyond the free nodes the field is
    /// extended with slope 1 through the obstacles, so a person cut off from every exit is led
    /// into what cuts them off, and stops there.
    pub fn reaches_exit(&self, p: [f64; 2]) -> bool {
        let (i, j, _, _) = self.locate(p);
        let g = &self.grid;
        let window = |reach: usize| {
            let (i0, j0) = (i.saturating_sub(reach), j.saturating_sub(reach));
            let (i1, j1) = ((i + 1 + reach).min(g.nx - 1), (j + 1 + reach).min(g.ny - 1));
            (i0..=i1).flat_map(move |a| (j0..=j1).map(move |b| g.index(a, b)))
        };
        for reach in [0, 1] {
            if window(reach).any(|k| self.free[k]) {
                return window(reach).any(|k| self.routed[k]);
            }
        }
        true
    }

    /// The value at node `(i, j)`.
    pub fn node_value(&self, i: usize, j: usize) -> f64 {
        self.values[self.grid.index(i, j)]
    }

    /// Locates `p`: the cell `(i, j)` and the local coordinates `(s, u) ∈ [0, 1]²`; points
    /// outside the grid are clamped to it.
    fn locate(&self, p: [f64; 2]) -> (usize, usize, f64, f64) {
        let g = &self.grid;
        let fx = ((p[0] - g.x0) / g.cell).clamp(0.0, (g.nx - 1) as f64);
        let fy = ((p[1] - g.y0) / g.cell).clamp(0.0, (g.ny - 1) as f64);
        let i = (fx.floor() as usize).min(g.nx - 2);
        let j = (fy.floor() as usize).min(g.ny - 2);
        (i, j, fx - i as f64, fy - j as f64)
    }

    /// The geodesic distance at `p` (bilinear interpolation of the node values; continuous).
    pub fn distance(&self, p: [f64; 2]) -> f64 {
        let (i, j, s, u) = self.locate(p);
        let g = &self.grid;
        let v = |a, b| self.values[g.index(a, b)];
        (1.0 - s) * (1.0 - u) * v(i, j)
            + s * (1.0 - u) * v(i + 1, j)
            + (1.0 - s) * u * v(i, j + 1)
            + s * u * v(i + 1, j + 1)
    }

    /// The interpolated gradient of the distance at `p` (continuous).
    pub fn gradient(&self, p: [f64; 2]) -> [f64; 2] {
        let (i, j, s, u) = self.locate(p);
        let g = &self.grid;
        let v = |a, b| self.gradients[g.index(a, b)];
        let w = [
            ((1.0 - s) * (1.0 - u), v(i, j)),
            (s * (1.0 - u), v(i + 1, j)),
            ((1.0 - s) * u, v(i, j + 1)),
            (s * u, v(i + 1, j + 1)),
        ];
        let mut out = [0.0; 2];
        for (wt, gv) in w {
            out[0] += wt * gv[0];
            out[1] += wt * gv[1];
        }
        out
    }

    /// The direction of steepest descent of the distance, `−g / max(|g|, τ)` with `g` the
    /// interpolated gradient and `τ =` [`GRADIENT_FLOOR`]: a unit vector away from ridges, and
    /// continuous everywhere.
    pub fn direction(&self, p: [f64; 2]) -> [f64; 2] {
        let g = self.gradient(p);
        let n = (g[0] * g[0] + g[1] * g[1]).sqrt().max(GRADIENT_FLOOR);
        [-g[0] / n, -g[1] / n]
    }
}

/// Whether the foot of the perpendicular from `p` to the line through `a` and `b` lies on the
/// segment `[a, b]` (ends included): `p` is level with the segment, not beside one of its ends.
fn foot_is_on_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> bool {
    let ab = [b[0] - a[0], b[1] - a[1]];
    let along = (p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1];
    (0.0..=ab[0] * ab[0] + ab[1] * ab[1]).contains(&along)
}

/// First-order fast marching: computes every `allowed`, not yet `known` node reachable from
/// the known ones.
fn march(grid: &Grid, values: &mut [f64], known: &mut [bool], allowed: &[bool]) {
    let mut heap = BinaryHeap::new();
    let neighbours = |k: usize| {
        let (i, j) = (k % grid.nx, k / grid.nx);
        let mut out = [usize::MAX; 4];
        if i > 0 {
            out[0] = k - 1;
        }
        if i + 1 < grid.nx {
            out[1] = k + 1;
        }
        if j > 0 {
            out[2] = k - grid.nx;
        }
        if j + 1 < grid.ny {
            out[3] = k + grid.nx;
        }
        out
    };
    // Lowers the trial value of each unknown, allowed neighbour of the known node `k`.
    let relax = |k: usize, values: &mut [f64], known: &[bool], heap: &mut BinaryHeap<Entry>| {
        for nb in neighbours(k) {
            if nb != usize::MAX && !known[nb] && allowed[nb] {
                let v = local_solve(grid, values, known, nb);
                if v < values[nb] {
                    values[nb] = v;
                    heap.push(Entry(v, nb));
                }
            }
        }
    };
    // Trial values of the unknown neighbours of the known nodes.
    for k in 0..values.len() {
        if known[k] {
            relax(k, values, known, &mut heap);
        }
    }
    while let Some(Entry(v, k)) = heap.pop() {
        if known[k] || v > values[k] {
            continue;
        }
        known[k] = true;
        relax(k, values, known, &mut heap);
    }
}

/// The upwind update of node `k` from its known neighbours: the largest root of
/// `(u − a)₊² + (u − b)₊² = cell²`.
fn local_solve(grid: &Grid, values: &[f64], known: &[bool], k: usize) -> f64 {
    let (i, j) = (k % grid.nx, k / grid.nx);
    let get = |kk: usize| if known[kk] { values[kk] } else { f64::INFINITY };
    let mut a = f64::INFINITY;
    if i > 0 {
        a = a.min(get(k - 1));
    }
    if i + 1 < grid.nx {
        a = a.min(get(k + 1));
    }
    let mut b = f64::INFINITY;
    if j > 0 {
        b = b.min(get(k - grid.nx));
    }
    if j + 1 < grid.ny {
        b = b.min(get(k + grid.nx));
    }
    let h = grid.cell;
    let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
    if !lo.is_finite() {
        return f64::INFINITY;
    }
    if hi - lo >= h {
        return lo + h;
    }
    // (u − a)² + (u − b)² = h²
    let sum = a + b;
    let disc = 2.0 * h * h - (a - b) * (a - b);
    0.5 * (sum + disc.max(0.0).sqrt())
}

/// Central differences (one-sided at the grid's edges) of the node values.
fn node_gradients(grid: &Grid, values: &[f64]) -> Vec<[f64; 2]> {
    let mut out = vec![[0.0; 2]; values.len()];
    let h = grid.cell;
    for j in 0..grid.ny {
        for i in 0..grid.nx {
            let k = grid.index(i, j);
            let gx = if i == 0 {
                (values[k + 1] - values[k]) / h
            } else if i + 1 == grid.nx {
                (values[k] - values[k - 1]) / h
            } else {
                (values[k + 1] - values[k - 1]) / (2.0 * h)
            };
            let gy = if j == 0 {
                (values[k + grid.nx] - values[k]) / h
            } else if j + 1 == grid.ny {
                (values[k] - values[k - grid.nx]) / h
            } else {
                (values[k + grid.nx] - values[k - grid.nx]) / (2.0 * h)
            };
            out[k] = [gx, gy];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_foot_is_on_the_segment_only_level_with_it() {
        // Away from the origin on both axes, so that every coordinate counts.
        let (a, b) = ([3.0, 5.0], [7.0, 8.0]); // along (4, 3), length 5
        let normal = [-3.0 / 5.0, 4.0 / 5.0];
        let at = |s: f64, off: f64| {
            [
                a[0] + s * 4.0 + off * normal[0],
                a[1] + s * 3.0 + off * normal[1],
            ]
        };
        for off in [-2.0, 0.0, 0.7] {
            assert!(foot_is_on_segment(at(0.5, off), a, b));
            assert!(foot_is_on_segment(at(0.001, off), a, b)); // just inside an end
            assert!(foot_is_on_segment(at(0.999, off), a, b));
            assert!(!foot_is_on_segment(at(-0.01, off), a, b)); // beside an end
            assert!(!foot_is_on_segment(at(1.01, off), a, b));
        }
        // Vertical and horizontal exits, as on the rooms' walls.
        assert!(foot_is_on_segment([5.1, 1.0], [5.0, 0.38], [5.0, 1.84]));
        assert!(!foot_is_on_segment([5.1, 1.9], [5.0, 0.38], [5.0, 1.84]));
        assert!(foot_is_on_segment([41.0, -0.1], [39.8, 0.0], [42.2, 0.0]));
        assert!(!foot_is_on_segment([39.7, -0.1], [39.8, 0.0], [42.2, 0.0]));
    }

    #[test]
    fn local_solve_is_exact_for_axis_and_diagonal_plane_waves() {
        let grid = Grid::covering(0.0, 0.0, 1.0, 1.0, 0.5);
        // Node (1, 1) = index 4 with left neighbour 0.3 and bottom 0.3.
        let mut values = vec![f64::INFINITY; grid.len()];
        let mut known = vec![false; grid.len()];
        values[3] = 0.3;
        known[3] = true;
        values[1] = 0.3;
        known[1] = true;
        let u = local_solve(&grid, &values, &known, 4);
        assert!((u - (0.3 + 0.5 / 2f64.sqrt())).abs() < 1e-12);
        known[1] = false;
        let u = local_solve(&grid, &values, &known, 4);
        assert!((u - 0.8).abs() < 1e-12);
    }
}
