//! Pairs of people: `D_ij(q) = |qᵢ − qⱼ| − (rᵢ + rⱼ) ≥ 0`, culled by a uniform grid.

use super::Population;
use crate::constraint::{
    linearize, second_order, ConstraintFamily, ConstraintKernel, FamilyKind, LinearizedRow,
    SecondOrderData,
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

/// All pairs of a crowd as one family: [`count`](ConstraintFamily::count) is the `N(N−1)/2`
/// pairs, and the pair `(i, j)`, `i < j`, is member `i·N + j` ([`member`](Self::member),
/// [`pair`](Self::pair)), below [`member_bound`](ConstraintFamily::member_bound) `= N²`.
///
/// Candidates come from a uniform grid of cell size `2 r_max + cutoff`, so a pair within the
/// cutoff lies in the same or a neighbouring cell: `O(N)` work for a crowd of bounded density,
/// and no pair with `D_ij ≤ cutoff` is ever missed (the contract of
/// [`ConstraintFamily::candidates`]). People who have left are in no pair.
pub struct DiskPairs {
    population: Arc<Population>,
    scratch: Mutex<CellGrid>,
    cull: bool,
}

impl DiskPairs {
    /// The pairs of `population`, culled by the grid.
    pub fn new(population: Arc<Population>) -> Self {
        Self {
            population,
            scratch: Mutex::new(CellGrid::default()),
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
/// sparse (fewer people than a quarter of its cells: people far apart, or far away), cells
/// sorted by key (`O(N log N)`, memory independent of the extent).
#[derive(Debug, Default)]
struct CellGrid {
    /// Dense: `(nx, ny)`, with `start[c]..start[c + 1]` the slice of `order` in cell `c`.
    dims: Option<(usize, usize)>,
    start: Vec<usize>,
    order: Vec<usize>,
    /// Sparse: `(cx, cy, person)`, sorted.
    keys: Vec<(i64, i64, usize)>,
    /// Scratch: the present people, their cells (dense), and the fill cursor of each cell.
    people: Vec<usize>,
    cells: Vec<(usize, usize)>,
    next: Vec<usize>,
}

impl CellGrid {
    fn fill(&mut self, pop: &Population, q: &[f64], cell: f64) {
        self.people.clear();
        self.keys.clear();
        self.cells.clear();
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
        let dense = present > 0 && nx * ny <= (4 * present + 64) as f64;
        if !dense {
            self.dims = None;
            for &i in &self.people {
                let cx = (q[2 * i] / cell).floor() as i64;
                let cy = (q[2 * i + 1] / cell).floor() as i64;
                self.keys.push((cx, cy, i));
            }
            self.keys.sort_unstable();
            return;
        }
        let (nx, ny) = (nx as usize, ny as usize);
        self.dims = Some((nx, ny));
        self.start.clear();
        self.start.resize(nx * ny + 1, 0);
        for &i in &self.people {
            let cx = (((q[2 * i] - x0) / cell) as usize).min(nx - 1);
            let cy = (((q[2 * i + 1] - y0) / cell) as usize).min(ny - 1);
            self.cells.push((cx, cy));
            self.start[cx * ny + cy + 1] += 1;
        }
        for c in 0..nx * ny {
            self.start[c + 1] += self.start[c];
        }
        // Scatter the people into cell order.
        self.next.clear();
        self.next.extend_from_slice(&self.start[..nx * ny]);
        self.order.clear();
        self.order.resize(present, 0);
        for (&i, &(cx, cy)) in self.people.iter().zip(&self.cells) {
            let c = cx * ny + cy;
            self.order[self.next[c]] = i;
            self.next[c] += 1;
        }
    }

    /// Calls `f(a, b)` once for every unordered pair of present people in the same or
    /// neighbouring cells.
    fn for_each_near_pair(&self, mut f: impl FnMut(usize, usize)) {
        // Each pair of neighbouring cells is visited once: the cell itself and its four
        // "forward" neighbours.
        const FORWARD: [(i64, i64); 4] = [(1, -1), (1, 0), (1, 1), (0, 1)];
        match self.dims {
            Some((nx, ny)) => {
                let slice = |cx: usize, cy: usize| {
                    let c = cx * ny + cy;
                    &self.order[self.start[c]..self.start[c + 1]]
                };
                for cx in 0..nx {
                    for cy in 0..ny {
                        let here = slice(cx, cy);
                        if here.is_empty() {
                            continue;
                        }
                        for (k, &a) in here.iter().enumerate() {
                            for &b in &here[k + 1..] {
                                f(a, b);
                            }
                        }
                        for (dx, dy) in FORWARD {
                            let (ox, oy) = (cx as i64 + dx, cy as i64 + dy);
                            if ox < 0 || oy < 0 || ox >= nx as i64 || oy >= ny as i64 {
                                continue;
                            }
                            let there = slice(ox as usize, oy as usize);
                            for &a in here {
                                for &b in there {
                                    f(a, b);
                                }
                            }
                        }
                    }
                }
            }
            None => {
                let keys = &self.keys;
                let find = |cx: i64, cy: i64| -> std::ops::Range<usize> {
                    let lo = keys.partition_point(|k| (k.0, k.1) < (cx, cy));
                    let hi = keys.partition_point(|k| (k.0, k.1) <= (cx, cy));
                    lo..hi
                };
                let mut start = 0;
                while start < keys.len() {
                    let (cx, cy, _) = keys[start];
                    let mut end = start;
                    while end < keys.len() && keys[end].0 == cx && keys[end].1 == cy {
                        end += 1;
                    }
                    for a in start..end {
                        for b in (a + 1)..end {
                            f(keys[a].2, keys[b].2);
                        }
                    }
                    for (dx, dy) in FORWARD {
                        for b in find(cx + dx, cy + dy) {
                            for a in start..end {
                                f(keys[a].2, keys[b].2);
                            }
                        }
                    }
                    start = end;
                }
            }
        }
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
        // Two disks with D_ij ≤ cutoff have centres closer than r_i + r_j + cutoff ≤ cell, so
        // they lie in the same or neighbouring cells of a grid of that size.
        let cell = 2.0 * pop.max_radius() + cutoff.max(0.0) + 1e-12;
        let mut grid = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        grid.fill(pop, q, cell);
        let pair_within = |i: usize, j: usize| {
            let d = ((q[2 * i] - q[2 * j]).powi(2) + (q[2 * i + 1] - q[2 * j + 1]).powi(2)).sqrt()
                - pop.radius(i)
                - pop.radius(j);
            d <= cutoff
        };
        grid.for_each_near_pair(|a, b| {
            if pair_within(a, b) {
                out.push(self.member(a, b));
            }
        });
    }

    /// `|⟨∇D_ij, x − q⟩| = |⟨e_ij, Δⱼ − Δᵢ⟩| ≤ |Δᵢ| + |Δⱼ|`, bounded by the sum of the two
    /// largest displacements of present people.
    fn linearization_drift_bound(&self, _t: f64, q: &[f64], x: &[f64]) -> f64 {
        let (mut m1, mut m2) = (0.0f64, 0.0f64);
        for i in 0..self.n() {
            if !self.population.is_present(q, i) {
                continue;
            }
            let d = ((x[2 * i] - q[2 * i]).powi(2) + (x[2 * i + 1] - q[2 * i + 1]).powi(2)).sqrt();
            if d > m1 {
                m2 = m1;
                m1 = d;
            } else if d > m2 {
                m2 = d;
            }
        }
        m1 + m2
    }

    fn linearize(&self, index: usize, t: f64, q: &[f64], want_dt: bool, out: &mut LinearizedRow) {
        let (i, j) = self.pair(index);
        let r = self.population.radius(i) + self.population.radius(j);
        let lin = linearize(&DiskPairKernel, &r, t, Self::gather(q, i, j), want_dt);
        out.value = lin.value;
        out.dt = lin.dt;
        out.columns.clear();
        out.columns
            .extend_from_slice(&[2 * i, 2 * i + 1, 2 * j, 2 * j + 1]);
        out.gradient.clear();
        out.gradient.extend_from_slice(&lin.gradient);
    }

    fn second_order(&self, index: usize, t: f64, q: &[f64]) -> SecondOrderData {
        let (i, j) = self.pair(index);
        let r = self.population.radius(i) + self.population.radius(j);
        let so = second_order(&DiskPairKernel, &r, t, Self::gather(q, i, j));
        SecondOrderData {
            value: so.value,
            columns: vec![2 * i, 2 * i + 1, 2 * j, 2 * j + 1],
            gradient: so.gradient.to_vec(),
            dt: so.dt,
            hessian: so.hessian.iter().flatten().copied().collect(),
            dt_gradient: so.dt_gradient.to_vec(),
        }
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
}
