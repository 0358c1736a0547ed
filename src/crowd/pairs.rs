//! Pairs of people: `D_ij(q) = |qᵢ − qⱼ| − (rᵢ + rⱼ) ≥ 0`, culled by a uniform grid.

use super::verlet::{self, Anchor, ListPolicy, NeighbourSearch};
use super::Population;
use crate::constraint::{
    second_order, ConstraintFamily, ConstraintKernel, FamilyKind, LinearizedRow, SecondOrderData,
};
use num_dual::DualNum;
use std::sync::{Arc, Mutex};

/// The pair constraint on `z = (xᵢ, yᵢ, xⱼ, yⱼ)` with `params = rᵢ + rⱼ`:
/// `D = |qⱼ − qᵢ| − (rᵢ + rⱼ)`. Static, convex, `|∇D| = √2`, `|D²D| = 2/|qᵢ − qⱼ|`.
#[derive(Debug, Clone, Copy, Default)]
pub struct DiskPairKernel;

impl ConstraintKernel<4> for DiskPairKernel {
    type Params = f64;

    fn value<D: DualNum<Primitive = f64> + Copy>(&self, sum_radii: &f64, _t: D, z: [D; 4]) -> D {
        let dx = z[2] - z[0];
        let dy = z[3] - z[1];
        (dx * dx + dy * dy).sqrt() - *sum_radii
    }

    fn is_time_dependent(&self) -> bool {
        false
    }
}

impl DiskPairKernel {
    /// `D` and `∇D` at `z` without dual numbers, for the assembly's hottest loop, in the
    /// autodiff's own arithmetic: with `u = dx² + dy²`, the dual numbers carry `∂u = ±2dx,
    /// ±2dy` exactly and `√u`'s derivative factor `√u · u⁻¹ · ½`, so the same operations in
    /// the same order give the same bits (tested against [`linearize`](crate::constraint::linearize)).
    pub(crate) fn linearized(sum_radii: f64, z: [f64; 4]) -> (f64, [f64; 4]) {
        let dx = z[2] - z[0];
        let dy = z[3] - z[1];
        let u = dx * dx + dy * dy;
        let root = u.sqrt();
        let factor = root * u.recip() * 0.5;
        let (gx, gy) = ((dx + dx) * factor, (dy + dy) * factor);
        (root - sum_radii, [-gx, -gy, gx, gy])
    }
}

/// All pairs of a crowd as one family: [`count`](ConstraintFamily::count) is the `N(N−1)/2`
/// pairs, and the pair `(i, j)`, `i < j`, is member `i·N + j` ([`member`](Self::member),
/// [`pair`](Self::pair)), below [`member_bound`](ConstraintFamily::member_bound) `= N²`.
///
/// Candidates come from a uniform grid of cell size `2 r_max + cutoff`, so a pair within the
/// cutoff lies in the same or a neighbouring cell: `O(N)` work for a crowd of bounded density,
/// and no pair with `D_ij ≤ cutoff` is ever missed (the contract of
/// [`ConstraintFamily::candidates`]). The grid is searched with a wider reach and its pairs
/// kept as a neighbour list, which answers the next steps' queries for as long as the people's
/// displacements since prove it complete (a Verlet list). People who have left are in no pair.
pub struct DiskPairs {
    population: Arc<Population>,
    scratch: Mutex<BroadPhase>,
    cull: bool,
}

/// The grid, and the neighbour list built with it and reused while it provably holds.
#[derive(Debug, Default)]
struct BroadPhase {
    grid: CellGrid,
    list: NeighbourList,
}

impl DiskPairs {
    /// The pairs of `population`, culled by the grid.
    pub fn new(population: Arc<Population>) -> Self {
        Self {
            population,
            scratch: Mutex::new(BroadPhase::default()),
            cull: true,
        }
    }

    /// The same pairs without culling: every present pair is a candidate at every step
    /// (`O(N²)`; the reference against which culling is tested).
    pub fn all_pairs(population: Arc<Population>) -> Self {
        Self {
            cull: false,
            ..Self::new(population)
        }
    }

    fn n(&self) -> usize {
        self.population.len()
    }

    /// The people `(i, j)`, `i < j`, of pair `member`.
    pub fn pair(&self, member: usize) -> (usize, usize) {
        (member / self.n(), member % self.n())
    }

    /// The member index of the pair of people `i` and `j` (in either order).
    pub fn member(&self, i: usize, j: usize) -> usize {
        let (i, j) = if i < j { (i, j) } else { (j, i) };
        i * self.n() + j
    }

    fn gather(q: &[f64], i: usize, j: usize) -> [f64; 4] {
        [q[2 * i], q[2 * i + 1], q[2 * j], q[2 * j + 1]]
    }

    /// Present pairs with `D_ij ≤ cutoff`, by brute force (for tests).
    pub fn brute_force_candidates(&self, q: &[f64], cutoff: f64) -> Vec<usize> {
        let pop = &self.population;
        let n = self.n();
        let mut out = Vec::new();
        for i in 0..n {
            if !pop.is_present(q, i) {
                continue;
            }
            for j in (i + 1)..n {
                if !pop.is_present(q, j) {
                    continue;
                }
                let d = ((q[2 * i] - q[2 * j]).powi(2) + (q[2 * i + 1] - q[2 * j + 1]).powi(2))
                    .sqrt()
                    - pop.radius(i)
                    - pop.radius(j);
                if d <= cutoff {
                    out.push(self.member(i, j));
                }
            }
        }
        out
    }
}

/// The present people binned into square cells: a dense array of cells filled by counting sort
/// (`O(N)`, no allocation once warm) over the bounding box of the crowd, or, when that box is
/// sparse (fewer people than a sixteenth of its cells: people far apart, or far away), cells
/// sorted by key (`O(N log N)`, memory independent of the extent). Either way the people are
/// copied in cell order with their position and radius, so the pair tests read memory in
/// order, and only occupied cells are visited.
#[derive(Debug, Default)]
struct CellGrid {
    /// Dense: `(nx, ny)`, with `start[c]..start[c + 1]` the slice of `sorted` in cell `c`.
    dims: Option<(usize, usize)>,
    start: Vec<u32>,
    /// The present people in cell order (dense: by cell index; sparse: by `(cx, cy)`).
    sorted: Vec<Binned>,
    /// Sparse: each person's `(cx, cy)`, in the order of `sorted`.
    keys: Vec<(i64, i64)>,
    /// Scratch: the present people, the fill cursor of each cell (dense), the people before
    /// they are put in cell order, and the keys before sorting (sparse).
    people: Vec<usize>,
    next: Vec<u32>,
    unsorted: Vec<Binned>,
    keyed: Vec<(i64, i64, usize)>,
}

/// A present person in the grid.
#[derive(Debug, Clone, Copy)]
struct Binned {
    x: f64,
    y: f64,
    radius: f64,
    person: usize,
    /// The dense cell index `cx · ny + cy` (`0` on the sparse path).
    cell: usize,
}

/// Dense grids have at most this many cells per present person (plus
/// [`DENSE_EXTRA_CELLS`]). At the paper's density (1.5 people per m²) a grid of cells of 0.4 m
/// has 4.2 cells per person; each cell costs 4 bytes.
const DENSE_CELLS_PER_PERSON: usize = 16;
/// Cells a dense grid may have beyond [`DENSE_CELLS_PER_PERSON`] per person, so that a small
/// crowd in a room of ordinary size stays on the dense grid.
const DENSE_EXTRA_CELLS: usize = 4096;

/// Each pair of neighbouring cells is visited once: the cell itself and its four "forward"
/// neighbours.
const FORWARD: [(i64, i64); 4] = [(1, -1), (1, 0), (1, 1), (0, 1)];

impl Binned {
    /// Person `i` at `q` (no cell).
    fn at(pop: &Population, q: &[f64], i: usize) -> Self {
        Binned {
            x: q[2 * i],
            y: q[2 * i + 1],
            radius: pop.radius(i),
            person: i,
            cell: 0,
        }
    }

    /// `D_ab ≤ cutoff`, computed as [`DiskPairs::brute_force_candidates`] does. The squared
    /// distance first rejects pairs beyond `r_a + r_b + cutoff` with a relative margin of
    /// 1e-9, far above the rounding of either computation, so only pairs the exact test would
    /// reject are skipped without it.
    fn within(&self, other: &Binned, cutoff: f64) -> bool {
        let (dx, dy) = (self.x - other.x, self.y - other.y);
        let squared = dx * dx + dy * dy;
        let reach = self.radius + other.radius + cutoff;
        if reach >= 0.0 {
            let bound = reach * (1.0 + 1e-9) + 1e-9 * (self.radius + other.radius);
            if squared > bound * bound {
                return false;
            }
        }
        (dx.powi(2) + dy.powi(2)).sqrt() - self.radius - other.radius <= cutoff
    }
}

impl CellGrid {
    /// Fills the grid for pairs with `D_ij ≤ reach`: two disks that close have centres closer
    /// than `r_i + r_j + reach ≤` the cell's side, so they lie in the same or neighbouring
    /// cells.
    fn fill_reaching(&mut self, pop: &Population, q: &[f64], reach: f64) {
        self.fill(pop, q, 2.0 * pop.max_radius() + reach + 1e-12);
    }

    fn fill(&mut self, pop: &Population, q: &[f64], cell: f64) {
        self.people.clear();
        self.keys.clear();
        self.sorted.clear();
        let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
        for i in 0..pop.len() {
            if pop.is_present(q, i) {
                self.people.push(i);
                x0 = x0.min(q[2 * i]);
                y0 = y0.min(q[2 * i + 1]);
                x1 = x1.max(q[2 * i]);
                y1 = y1.max(q[2 * i + 1]);
            }
        }
        let present = self.people.len();
        let (nx, ny) = (
            ((x1 - x0) / cell).floor() + 1.0,
            ((y1 - y0) / cell).floor() + 1.0,
        );
        let dense =
            present > 0 && nx * ny <= (DENSE_CELLS_PER_PERSON * present + DENSE_EXTRA_CELLS) as f64;
        let binned = |i: usize, cell: usize| Binned {
            x: q[2 * i],
            y: q[2 * i + 1],
            radius: pop.radius(i),
            person: i,
            cell,
        };
        if !dense {
            self.dims = None;
            self.keyed.clear();
            self.keyed.extend(self.people.iter().map(|&i| {
                let cx = (q[2 * i] / cell).floor() as i64;
                let cy = (q[2 * i + 1] / cell).floor() as i64;
                (cx, cy, i)
            }));
            self.keyed.sort_unstable();
            for &(cx, cy, i) in &self.keyed {
                self.keys.push((cx, cy));
                self.sorted.push(binned(i, 0));
            }
            return;
        }
        let (nx, ny) = (nx as usize, ny as usize);
        self.dims = Some((nx, ny));
        self.start.clear();
        self.start.resize(nx * ny + 1, 0);
        // Each person with their cell, in the order of `people`.
        self.unsorted.clear();
        for &i in &self.people {
            let cx = (((q[2 * i] - x0) / cell) as usize).min(nx - 1);
            let cy = (((q[2 * i + 1] - y0) / cell) as usize).min(ny - 1);
            let c = cx * ny + cy;
            self.start[c + 1] += 1;
            self.unsorted.push(binned(i, c));
        }
        for c in 0..nx * ny {
            self.start[c + 1] += self.start[c];
        }
        // Scatter into cell order (stable: people keep their order within a cell).
        self.next.clear();
        self.next.extend_from_slice(&self.start[..nx * ny]);
        self.sorted.resize(
            present,
            Binned {
                x: 0.0,
                y: 0.0,
                radius: 0.0,
                person: 0,
                cell: 0,
            },
        );
        for entry in &self.unsorted {
            let slot = &mut self.next[entry.cell];
            self.sorted[*slot as usize] = *entry;
            *slot += 1;
        }
    }

    /// Calls `f(a, b)` once for every unordered pair of present people in the same or
    /// neighbouring cells with `D_ab ≤ cutoff` (see [`Binned::within`]), in cell order.
    fn for_each_pair_within(&self, cutoff: f64, mut f: impl FnMut(usize, usize)) {
        let sorted = &self.sorted;
        let mut test = |a: &Binned, b: &Binned| {
            if a.within(b, cutoff) {
                f(a.person, b.person);
            }
        };
        match self.dims {
            Some((nx, ny)) => {
                // The occupied cells are the runs of `sorted`.
                let mut begin = 0;
                while begin < sorted.len() {
                    let c = sorted[begin].cell;
                    let end = self.start[c + 1] as usize;
                    let here = &sorted[begin..end];
                    for (k, a) in here.iter().enumerate() {
                        for b in &here[k + 1..] {
                            test(a, b);
                        }
                    }
                    let (cx, cy) = ((c / ny) as i64, (c % ny) as i64);
                    for (dx, dy) in FORWARD {
                        let (ox, oy) = (cx + dx, cy + dy);
                        if ox < 0 || oy < 0 || ox >= nx as i64 || oy >= ny as i64 {
                            continue;
                        }
                        let o = ox as usize * ny + oy as usize;
                        let there = &sorted[self.start[o] as usize..self.start[o + 1] as usize];
                        for a in here {
                            for b in there {
                                test(a, b);
                            }
                        }
                    }
                    begin = end;
                }
            }
            None => {
                let keys = &self.keys;
                let find = |cx: i64, cy: i64| -> std::ops::Range<usize> {
                    let lo = keys.partition_point(|k| *k < (cx, cy));
                    let hi = lo + keys[lo..].partition_point(|k| *k <= (cx, cy));
                    lo..hi
                };
                let mut begin = 0;
                while begin < keys.len() {
                    let (cx, cy) = keys[begin];
                    let mut end = begin;
                    while end < keys.len() && keys[end] == (cx, cy) {
                        end += 1;
                    }
                    let here = &sorted[begin..end];
                    for (k, a) in here.iter().enumerate() {
                        for b in &here[k + 1..] {
                            test(a, b);
                        }
                    }
                    for (dx, dy) in FORWARD {
                        let there = &sorted[find(cx + dx, cy + dy)];
                        for b in there {
                            for a in here {
                                test(a, b);
                            }
                        }
                    }
                    begin = end;
                }
            }
        }
    }
}

/// A Verlet list: every pair of people present at the anchor with `D_ij(anchor) ≤ reach`,
/// found by the grid. It answers a query at `q` with cutoff `c` exactly as the grid would (the
/// same pairs, tested by the same [`Binned::within`]) while `c + m₁ + m₂ ≤ reach`, `m₁ ≥ m₂`
/// the two largest displacements `|qᵢ − anchorᵢ|` of people present at `q`:
/// `D_ij(q) ≥ D_ij(anchor) − |Δᵢ| − |Δⱼ|` (triangle inequality), so a pair left out of the list
/// has `D_ij(q) > reach − m₁ − m₂ ≥ c`. Every query checks this from the anchor afresh, for any
/// `q` (a trial point, a new run after [`Population::reset_departures`]); when it fails the
/// list is rebuilt at `q` with `reach = c + skin`. In a walking crowd at `h = 0.01` a list
/// lasts several steps, and a query is one pass over the people plus one over the list,
/// instead of a grid built and searched each step.
#[derive(Debug, Default)]
struct NeighbourList {
    anchor: Anchor,
    reach: f64,
    /// The pairs of people, in the grid's cell order (each pair in the grid's order too:
    /// [`DiskPairs::member`] takes either).
    pairs: Vec<(u32, u32)>,
    policy: ListPolicy,
}

impl NeighbourSearch for NeighbourList {
    fn policy_and_anchor(&mut self) -> (&mut ListPolicy, &mut Anchor) {
        (&mut self.policy, &mut self.anchor)
    }
}

impl NeighbourList {
    /// Calls `f(i, j)` for every present pair with `D_ij(q) ≤ cutoff` and returns `true`,
    /// from the current list or from one built now; or returns `false` without calling `f`
    /// when the plain grid should answer instead (see [`ListPolicy`]).
    fn answer(
        &mut self,
        grid: &mut CellGrid,
        pop: &Population,
        q: &[f64],
        cutoff: f64,
        mut f: impl FnMut(usize, usize),
    ) -> bool {
        verlet::answer(
            self,
            |list| list.select(pop, q, cutoff, &mut f),
            |list| list.rebuild(grid, pop, q, cutoff),
        )
    }

    /// Calls `f(i, j)` for every present pair with `D_ij(q) ≤ cutoff`, in the list's order,
    /// and returns `true`; or returns `false` without calling `f` when the list cannot be
    /// proven to hold them all at `q`.
    fn select(
        &mut self,
        pop: &Population,
        q: &[f64],
        cutoff: f64,
        mut f: impl FnMut(usize, usize),
    ) -> bool {
        if cutoff.is_nan() {
            return false;
        }
        let Some(moved) = self.anchor.moved(pop, q) else {
            return false;
        };
        let [m1, m2] = moved.largest;
        // Every quantity compared is a distance computed to a few ulps; the relative margin is
        // far above that, so rounding cannot hide a pair.
        let margin = 1e-9 * (self.reach + 2.0 * pop.max_radius() + m1 + m2);
        if cutoff.max(0.0) + m1 + m2 + margin > self.reach {
            return false;
        }
        let present = self.anchor.present();
        for &(i, j) in &self.pairs {
            let (i, j) = (i as usize, j as usize);
            if !(present[i] && present[j]) {
                continue;
            }
            let a = Binned::at(pop, q, i);
            if a.within(&Binned::at(pop, q, j), cutoff) {
                f(i, j);
            }
        }
        true
    }

    /// Builds the list at `q` for queries with cutoffs up to `cutoff + skin`.
    fn rebuild(&mut self, grid: &mut CellGrid, pop: &Population, q: &[f64], cutoff: f64) {
        let cutoff = cutoff.max(0.0);
        let reach = cutoff + verlet::skin(pop, cutoff);
        grid.fill_reaching(pop, q, reach);
        self.pairs.clear();
        grid.for_each_pair_within(reach, |a, b| self.pairs.push((a as u32, b as u32)));
        self.anchor.set(pop, q, grid.people.iter().copied());
        self.reach = reach;
        self.policy.built();
    }
}

impl ConstraintFamily for DiskPairs {
    fn name(&self) -> &str {
        "pairs of people"
    }

    fn kind(&self) -> FamilyKind {
        FamilyKind::Pairs
    }

    fn count(&self) -> usize {
        let n = self.n();
        n * n.saturating_sub(1) / 2
    }

    fn member_bound(&self) -> usize {
        self.n() * self.n()
    }

    fn is_time_dependent(&self) -> bool {
        false
    }

    fn is_affine(&self) -> bool {
        false
    }

    /// `D_ij` is smooth except where `qᵢ = qⱼ`; `|∇D_ij| = √2` in `R⁴`, so that set lies
    /// `(rᵢ + rⱼ)/√2` from `{D_ij ≥ 0}`: the margin is the smallest such value.
    fn a0_margin(&self) -> Option<f64> {
        // The two smallest radii.
        let (mut a, mut b) = (f64::INFINITY, f64::INFINITY);
        for &r in self.population.radii() {
            if r < a {
                b = a;
                a = r;
            } else if r < b {
                b = r;
            }
        }
        (b.is_finite()).then(|| (a + b) / std::f64::consts::SQRT_2)
    }

    fn describe(&self, index: usize) -> String {
        let (i, j) = self.pair(index);
        format!("no overlap of people {i} and {j}")
    }

    fn culls(&self) -> bool {
        self.cull
    }

    fn candidates(&self, _t: f64, q: &[f64], cutoff: f64, out: &mut Vec<usize>) {
        let pop = &self.population;
        let n = self.n();
        if !self.cull || !cutoff.is_finite() {
            let present: Vec<usize> = (0..n).filter(|&i| pop.is_present(q, i)).collect();
            for (a, &i) in present.iter().enumerate() {
                for &j in &present[a + 1..] {
                    out.push(self.member(i, j));
                }
            }
            return;
        }
        let mut broad = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        let BroadPhase { grid, list } = &mut *broad;
        let mut push = |i, j| out.push(self.member(i, j));
        if u32::try_from(n).is_ok() && list.answer(grid, pop, q, cutoff, &mut push) {
            return;
        }
        // The grid at this cutoff: while lists do not pay, or when none can answer (a cutoff
        // that is not a number).
        grid.fill_reaching(pop, q, cutoff.max(0.0));
        grid.for_each_pair_within(cutoff, push);
    }

    /// `|⟨∇D_ij, x − q⟩| = |⟨e_ij, Δⱼ − Δᵢ⟩| ≤ |Δᵢ| + |Δⱼ|`, bounded by the sum of the two
    /// largest displacements of people not seen leaving (who include the present ones).
    fn linearization_drift_bound(&self, _t: f64, q: &[f64], x: &[f64]) -> f64 {
        let mut top = [0.0f64; 2];
        for i in 0..self.n() {
            // Everyone not seen leaving: the present people and perhaps a few more (who left
            // since presence was last asked), so still a bound, without presence's geometry.
            if self.population.has_departed(i) {
                continue;
            }
            // Squared displacements; the roots of the two largest at the end (monotone and
            // correctly rounded, so the same numbers as the two largest roots).
            let d = (x[2 * i] - q[2 * i]).powi(2) + (x[2 * i + 1] - q[2 * i + 1]).powi(2);
            verlet::keep_two_largest(&mut top, d);
        }
        top[0].sqrt() + top[1].sqrt()
    }

    fn linearize(&self, index: usize, _t: f64, q: &[f64], want_dt: bool, out: &mut LinearizedRow) {
        let (i, j) = self.pair(index);
        let r = self.population.radius(i) + self.population.radius(j);
        let (value, gradient) = DiskPairKernel::linearized(r, Self::gather(q, i, j));
        out.value = value;
        out.dt = want_dt.then_some(0.0);
        out.columns.clear();
        out.columns
            .extend_from_slice(&[2 * i, 2 * i + 1, 2 * j, 2 * j + 1]);
        out.gradient.clear();
        out.gradient.extend_from_slice(&gradient);
    }

    fn value(&self, index: usize, t: f64, q: &[f64], _: &mut LinearizedRow) -> f64 {
        let (i, j) = self.pair(index);
        let r = self.population.radius(i) + self.population.radius(j);
        DiskPairKernel.value(&r, t, Self::gather(q, i, j))
    }

    fn second_order(&self, index: usize, t: f64, q: &[f64]) -> SecondOrderData {
        let (i, j) = self.pair(index);
        let r = self.population.radius(i) + self.population.radius(j);
        let so = second_order(&DiskPairKernel, &r, t, Self::gather(q, i, j));
        so.on_columns(vec![2 * i, 2 * i + 1, 2 * j, 2 * j + 1])
    }

    fn min_dimension(&self) -> usize {
        2 * self.n()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The family's numbering, one contract: `count()` pairs, each a member below
    /// `member_bound()` that `pair` decodes; the grid finds exactly the brute-force pairs.
    #[test]
    fn members_are_pairs_below_the_bound_and_the_grid_misses_none() {
        let n = 30;
        let pop = Arc::new(Population::new(vec![0.2; n]));
        let fam = DiskPairs::new(pop);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let q: Vec<f64> = (0..2 * n).map(|_| rng.gen_range(0.0..4.0)).collect();
        let mut all = Vec::new();
        fam.candidates(0.0, &q, f64::INFINITY, &mut all);
        assert_eq!(all.len(), fam.count());
        for &m in &all {
            assert!(m < fam.member_bound());
            let (i, j) = fam.pair(m);
            assert!(i < j && j < n);
            assert_eq!(fam.member(j, i), m);
        }
        for cutoff in [0.0, 0.3, 1.0] {
            let mut grid = Vec::new();
            fam.candidates(0.0, &q, cutoff, &mut grid);
            grid.sort_unstable();
            let mut brute = fam.brute_force_candidates(&q, cutoff);
            brute.sort_unstable();
            assert_eq!(grid, brute, "cutoff {cutoff}");
        }
    }

    /// People exactly touching (`D_ij = 0` up to rounding) on a lattice of spacing `2r`, at
    /// cutoffs that put lattice pairs exactly at `D_ij = cutoff`: the grid's squared-distance
    /// shortcut must not drop a pair the exact test keeps (it does with its margin made
    /// `1 − 1e-9`). Near the origin (a dense grid), far from it, and as two far-apart lattices (the
    /// sparse grid).
    #[test]
    fn touching_people_are_found_by_both_grids_as_by_brute_force() {
        let (r, side) = (0.2, 12);
        for (offset, far_copy) in [(0.0, false), (1e4 + 0.37, false), (-3.1, true)] {
            let mut q = Vec::new();
            for copy in 0..1 + usize::from(far_copy) {
                let shift = copy as f64 * 5e3;
                for i in 0..side {
                    for j in 0..side {
                        q.push(offset + shift + 2.0 * r * i as f64);
                        q.push(offset + 2.0 * r * j as f64);
                    }
                }
            }
            let n = q.len() / 2;
            let fam = DiskPairs::new(Arc::new(Population::new(vec![r; n])));
            // 0.4 = 2r and 1.2 = 6r put the pairs two and four lattice steps apart exactly at
            // D = cutoff, where the shortcut's relative margin is what keeps them.
            for cutoff in [0.0, 1e-15, 0.05, 0.4, 1.2] {
                let mut grid = Vec::new();
                fam.candidates(0.0, &q, cutoff, &mut grid);
                grid.sort_unstable();
                let mut brute = fam.brute_force_candidates(&q, cutoff);
                brute.sort_unstable();
                assert!(!brute.is_empty());
                assert_eq!(
                    grid, brute,
                    "offset {offset}, far copy {far_copy}, cutoff {cutoff}"
                );
            }
        }
    }

    fn sorted_candidates(fam: &DiskPairs, q: &[f64], cutoff: f64) -> Vec<usize> {
        let mut found = Vec::new();
        fam.candidates(0.0, q, cutoff, &mut found);
        let count = found.len();
        found.sort_unstable();
        found.dedup();
        assert_eq!(found.len(), count, "a pair was proposed twice");
        found
    }

    /// Three people of radius 0.2 in a 10 m × 10 m room, and their pairs.
    fn three_people_in_a_room() -> (Arc<Population>, DiskPairs) {
        let room = crate::crowd::Room::rectangle(0.0, 0.0, 10.0, 10.0);
        let pop = Arc::new(Population::new(vec![0.2; 3]).with_room(room));
        let fam = DiskPairs::new(Arc::clone(&pop));
        (pop, fam)
    }

    fn lists_built(fam: &DiskPairs) -> usize {
        lists_used(fam).0
    }

    /// Lists built, and queries they answered.
    fn lists_used(fam: &DiskPairs) -> (usize, usize) {
        let policy = &fam.scratch.lock().unwrap().list.policy;
        (policy.builds(), policy.answered())
    }

    /// A crowd walking in small random steps, now and then one person jumping, now and then a
    /// configuration unrelated to the last, at cutoffs that change from query to query: the
    /// neighbour list answers exactly as brute force every time, and is reused for most steps.
    #[test]
    fn the_neighbour_list_answers_as_brute_force_while_reused_and_rebuilt() {
        // Near the origin, far from it (where rounding is 1e5 times coarser), and the same
        // crowd 20 times larger (radii of 3–4: the grid's cells must grow with them).
        for (origin, scale) in [(0.0, 1.0), (1e5 + 0.37, 1.0), (0.0, 20.0)] {
            let n = 120;
            let radii: Vec<f64> = (0..n)
                .map(|i| scale * (0.15 + 0.01 * (i % 6) as f64))
                .collect();
            let fam = DiskPairs::new(Arc::new(Population::new(radii)));
            let mut rng = ChaCha8Rng::seed_from_u64(11);
            let mut scatter = |q: &mut Vec<f64>| {
                q.clear();
                q.extend((0..2 * n).map(|_| origin + scale * rng.gen_range(0.0..6.0)));
            };
            let mut q = Vec::new();
            scatter(&mut q);
            let mut rng = ChaCha8Rng::seed_from_u64(12);
            let queries = 300;
            for k in 0..queries {
                match k % 50 {
                    17 => {
                        let i = rng.gen_range(0..n);
                        q[2 * i] += scale * rng.gen_range(-2.0..2.0);
                    }
                    33 => scatter(&mut q),
                    _ => q
                        .iter_mut()
                        .for_each(|v| *v += scale * rng.gen_range(-0.01..0.01)),
                }
                let cutoff = scale * [0.0, 0.02, 0.05, 0.2][k % 4];
                assert_eq!(
                    sorted_candidates(&fam, &q, cutoff),
                    {
                        let mut brute = fam.brute_force_candidates(&q, cutoff);
                        brute.sort_unstable();
                        brute
                    },
                    "origin {origin}, query {k}, cutoff {cutoff}"
                );
            }
            let (builds, answered) = lists_used(&fam);
            assert!(
                (10..queries / 2).contains(&builds) && answered >= queries * 4 / 5,
                "origin {origin}: {builds} lists answered {answered} of {queries} queries"
            );
        }
    }

    /// The list's proof covers the people present when it was built: a person outside the
    /// room then (in no pair of the list) who is present at the query, a step away from a
    /// neighbour, makes it rebuild — here after the departures are cleared for a new run, the
    /// one way a person can come back.
    #[test]
    fn a_person_absent_when_the_list_was_built_is_found_when_present_again() {
        let (pop, fam) = three_people_in_a_room();
        // Person 0 wholly outside the left wall; 1 inside, next to the wall; 2 far away.
        let mut q = vec![-0.21, 5.0, 0.25, 5.0, 8.0, 8.0];
        // Queried a few times, so that the list has paid (`MIN_SERVED`).
        for _ in 0..crate::crowd::verlet::MIN_SERVED {
            assert!(sorted_candidates(&fam, &q, 0.1).is_empty());
        }
        assert!(pop.has_departed(0));
        pop.reset_departures();
        // 0.02 inwards: present again, 0.04 from person 1.
        q[0] = -0.19;
        assert_eq!(sorted_candidates(&fam, &q, 0.1), vec![fam.member(0, 1)]);
        assert_eq!(lists_built(&fam), 2);
    }

    /// A crowd that moves most of the skin at every query (a jam at a long step): each list
    /// fails at its second or third query, so the plain grid answers most queries, and every
    /// answer is still exactly brute force's.
    #[test]
    fn a_crowd_too_fast_for_its_lists_is_answered_by_the_plain_grid() {
        let n = 80;
        let fam = DiskPairs::new(Arc::new(Population::new(vec![0.2; n])));
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut q: Vec<f64> = (0..2 * n).map(|_| rng.gen_range(0.0..5.0)).collect();
        let queries = 100;
        for k in 0..queries {
            q.iter_mut().for_each(|v| *v += rng.gen_range(-0.15..0.15));
            let mut brute = fam.brute_force_candidates(&q, 0.1);
            brute.sort_unstable();
            assert_eq!(sorted_candidates(&fam, &q, 0.1), brute, "query {k}");
        }
        let (builds, answered) = lists_used(&fam);
        assert!(
            (2..=queries / crate::crowd::verlet::PLAIN_SPELL).contains(&builds)
                && answered <= queries / 5,
            "{builds} lists answered {answered} of {queries} queries"
        );
    }

    /// The list answers exactly while `c + m₁ + m₂ + margin ≤ reach`, with the margin
    /// `1e-9 (reach + 2 r_max + m₁ + m₂)`: two people moved so that the slack left is 1.1 and
    /// then 0.9 times that margin, the list is kept and then rebuilt (the margin is what
    /// keeps rounding from hiding a pair; this pins it, and the bound it guards).
    #[test]
    fn the_list_holds_up_to_its_margin_and_no_further() {
        let (r, cutoff) = (10.0, 0.1);
        let reach = cutoff + r; // the skin is the largest radius here
        let base = vec![0.0, 0.0, 100.0, 0.0, 200.0, 0.0];
        for (fraction, rebuilt) in [(1.1, false), (0.9, true)] {
            let fam = DiskPairs::new(Arc::new(Population::new(vec![r; 3])));
            for _ in 0..crate::crowd::verlet::MIN_SERVED {
                sorted_candidates(&fam, &base, cutoff);
            }
            assert_eq!(lists_built(&fam), 1);
            // Person 0 moves m₁ ≈ 5.5, person 1 moves m₂ = 4.5 (and no pair comes near).
            let m2 = 4.5;
            let moved = |m1: f64| 1e-9 * (reach + 2.0 * r + m1 + m2);
            // Solve s = reach − cutoff − m₁ − m₂ = fraction · margin(m₁) for m₁.
            let mut m1 = reach - cutoff - m2;
            for _ in 0..4 {
                m1 = reach - cutoff - m2 - fraction * moved(m1);
            }
            let mut q = base.clone();
            q[0] -= m1;
            q[3] += m2;
            assert!(sorted_candidates(&fam, &q, cutoff).is_empty());
            assert_eq!(
                lists_built(&fam),
                1 + usize::from(rebuilt),
                "slack of {fraction} margins"
            );
        }
    }

    /// A person who leaves the room while the list holds (moving less than the skin) drops
    /// out of its pairs at once, without a new list.
    #[test]
    fn a_person_leaving_while_the_list_holds_drops_out_of_its_pairs() {
        let (pop, fam) = three_people_in_a_room();
        // Person 0 half out of the left wall (present), 0.04 from person 1.
        let mut q = vec![-0.19, 5.0, 0.25, 5.0, 8.0, 8.0];
        for _ in 0..crate::crowd::verlet::MIN_SERVED {
            assert_eq!(sorted_candidates(&fam, &q, 0.1), vec![fam.member(0, 1)]);
        }
        // 0.02 further out: wholly outside, so gone, though still 0.06 from person 1.
        q[0] = -0.21;
        assert!(sorted_candidates(&fam, &q, 0.1).is_empty());
        assert!(pop.has_departed(0));
        assert_eq!(lists_built(&fam), 1);
    }

    /// A list built at cutoff 0 reaches as far as its skin (the largest radius): a query at the
    /// same positions with a cutoff just below that is answered from it, and finds pairs up to
    /// that distance (the grid's cells must be `2 r_max + reach` wide to have found them).
    #[test]
    fn a_list_answers_up_to_its_reach_at_the_positions_it_was_built_at() {
        let r = 3.0;
        // Pairs (0, 1), (2, 3), (4, 5), (6, 7) at D = 0.5, 1.5, 2.5 and 2.9, far from each other.
        let mut q = Vec::new();
        for (k, d) in [0.5, 1.5, 2.5, 2.9].into_iter().enumerate() {
            let x = 100.0 * k as f64;
            q.extend([x, 0.0, x + 2.0 * r + d, 0.0]);
        }
        let fam = DiskPairs::new(Arc::new(Population::new(vec![r; 8])));
        for _ in 0..crate::crowd::verlet::MIN_SERVED {
            assert!(sorted_candidates(&fam, &q, 0.0).is_empty());
        }
        let all: Vec<usize> = (0..4).map(|k| fam.member(2 * k, 2 * k + 1)).collect();
        assert_eq!(sorted_candidates(&fam, &q, 2.95), all);
        assert_eq!(lists_used(&fam), (1, crate::crowd::verlet::MIN_SERVED + 1));
    }

    proptest::proptest! {
        /// The closed form is the autodiff's linearization to the bit (value, gradient), at
        /// any two positions, far apart or a micrometre apart.
        #[test]
        fn the_closed_form_linearization_is_the_autodiffs_to_the_bit(
            z in proptest::array::uniform4(-50.0f64..50.0),
            near in proptest::array::uniform2(-1e-6f64..1e-6),
            sum_radii in 0.0f64..1.0,
        ) {
            let close = [z[0], z[1], z[0] + near[0], z[1] + near[1]];
            for z in [z, close] {
                let autodiff = crate::constraint::linearize(&DiskPairKernel, &sum_radii, 0.0, z, true);
                let (value, gradient) = DiskPairKernel::linearized(sum_radii, z);
                proptest::prop_assert_eq!(value.to_bits(), autodiff.value.to_bits());
                for (ours, theirs) in gradient.iter().zip(&autodiff.gradient) {
                    proptest::prop_assert_eq!(ours.to_bits(), theirs.to_bits());
                }
            }
        }
    }

    #[test]
    fn the_familys_row_of_a_pair_is_the_kernels_linearization_on_its_columns() {
        let pop = Arc::new(Population::new(vec![0.2, 0.25, 0.3, 0.35]));
        let fam = DiskPairs::new(pop);
        let q = [0.0, 0.0, 3.0, -1.0, 1.0, 2.0, 5.0, 4.0];
        let mut row = LinearizedRow::default();
        for want_dt in [false, true] {
            // People 0 and 3: `2·i` and `2·j` differ from `2 + i`, `2 / i` and the like.
            fam.linearize(fam.member(0, 3), 0.5, &q, want_dt, &mut row);
            let autodiff = crate::constraint::linearize(
                &DiskPairKernel,
                &(0.2 + 0.35),
                0.5,
                [q[0], q[1], q[6], q[7]],
                want_dt,
            );
            assert_eq!(row.columns, vec![0, 1, 6, 7]);
            assert_eq!(row.value, autodiff.value);
            assert_eq!(row.gradient, autodiff.gradient.to_vec());
            assert_eq!(row.dt, want_dt.then_some(0.0));
        }
    }

    #[test]
    fn all_pairs_are_candidates_whatever_the_cutoff() {
        let pop = Arc::new(Population::new(vec![0.2; 3]));
        let fam = DiskPairs::all_pairs(pop);
        assert!(!fam.culls());
        let far_apart = [0.0, 0.0, 50.0, 0.0, 0.0, 80.0];
        let mut found = Vec::new();
        fam.candidates(0.0, &far_apart, 0.1, &mut found);
        assert_eq!(found.len(), 3);
    }

    #[test]
    fn coincident_people_have_no_finite_gradient_either_way() {
        let z = [1.5, -2.0, 1.5, -2.0];
        let autodiff = crate::constraint::linearize(&DiskPairKernel, &0.4, 0.0, z, false);
        let (value, gradient) = DiskPairKernel::linearized(0.4, z);
        assert_eq!(value, autodiff.value);
        assert!(gradient.iter().all(|g| !g.is_finite()));
        assert!(autodiff.gradient.iter().all(|g| !g.is_finite()));
    }
}
