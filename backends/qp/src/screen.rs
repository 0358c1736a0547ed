//! Which rows a projection's blocks see first.
//!
//! A jam's block holds every pair within the broad phase's reach, and most of them stay
//! apart: at twice the paper's density the candidate pairs connect everybody into one block,
//! while the rows that can be active form thousands of small clusters. Rows that `y`
//! satisfies with more room than a reach times their block's largest violation are left out,
//! and the rows kept split into blocks of their own
//! ([`Blocks::split_among`](sweeping_api::Blocks::split_among)); an answer that satisfies
//! every row left out is the projection onto the whole set (it is the closest point of a
//! larger set and lies in the smaller one). Rows left out that it violates join, their blocks
//! are solved again, and after [`SCREEN_ROUNDS`] rounds a block's parent is taken whole.

use sweeping_api::ProjectionProblem;

/// Rows that `y` satisfies with more room than this many times their block's largest
/// violation are left out at first.
pub(crate) const SCREEN_REACH: f64 = 0.5;

/// The widest reach a block's screening grows to ([`next_reach`]).
const SCREEN_REACH_MAX: f64 = 4.0;

/// The factor by which a block's reach shrinks back towards [`SCREEN_REACH`] at each
/// projection that missed no row.
const SCREEN_REACH_DECAY: f64 = 0.8;

/// Rows are left out of a block only when at least this fraction of its rows can be: a door
/// queue, nearly every row tight, is solved whole at once.
const SCREEN_FRACTION: f64 = 0.25;

/// Rounds of left-out rows joining before a block is taken whole.
pub(crate) const SCREEN_ROUNDS: usize = 3;

/// The screening reach of a block at the next projection: wide enough to have kept the rows
/// it missed (`needed`, with a quarter to spare; the hall's queues push along chains of
/// contacts beyond the reach that suits a jam), else shrinking back.
pub(crate) fn next_reach(reach: f64, needed: Option<f64>) -> f64 {
    match needed {
        Some(needed) => reach.max(1.25 * needed).min(SCREEN_REACH_MAX),
        None => (SCREEN_REACH_DECAY * reach).max(SCREEN_REACH),
    }
}

/// Row `i`'s slack `aᵢ·x − bᵢ` at `x`.
pub(crate) fn row_slack(p: &ProjectionProblem, i: usize, x: &[f64]) -> f64 {
    p.a().row(i).map(|(c, v)| v * x[c]).sum::<f64>() - p.b()[i]
}

/// Row `i`'s `(bᵢ − aᵢ·y)/‖aᵢ‖`: how far `y` violates it, negative for room; `0` for an
/// empty row.
fn signed_distance(p: &ProjectionProblem, i: usize) -> f64 {
    let norm = p.a().row(i).map(|(_, v)| v * v).sum::<f64>().sqrt();
    if norm > 0.0 {
        -row_slack(p, i, p.y()) / norm
    } else {
        0.0
    }
}

/// What the screening knows of one block of every row (a parent of the blocks solved).
#[derive(Debug, Clone, PartialEq)]
struct Parent {
    /// The largest violation at `y` among its rows, as a distance.
    worst: f64,
    /// Its reach this projection.
    reach: f64,
    /// Whether some of its rows are left out.
    screened: bool,
    /// The least reach that would have kept the rows it missed, when it missed any.
    needed: Option<f64>,
}

/// The rows a projection's blocks hold, and what their screening learns for the next one.
#[derive(Debug, Clone)]
pub(crate) struct Screening {
    /// Whether each row is in a block.
    keep: Vec<bool>,
    /// Each row's parent (`usize::MAX` outside every parent).
    parent_of: Vec<usize>,
    /// The violation at `y`, as a distance ([`signed_distance`]), of each row of a parent that
    /// may be screened (`0` for the others).
    distance: Vec<f64>,
    parents: Vec<Parent>,
}

impl Screening {
    /// The screening of `parents` (the rows of each block of every row of `problem`, see
    /// [`Blocks::split_violated_or_among`](sweeping_api::Blocks::split_violated_or_among)): a
    /// parent for which `reach_of` gives a reach leaves out the rows with more room at `y` than
    /// that reach times its largest violation, when at least [`SCREEN_FRACTION`] of them are;
    /// one for which it gives `None` is taken whole.
    pub(crate) fn new(
        problem: &ProjectionProblem,
        parents: &[Vec<usize>],
        reach_of: impl Fn(&[usize]) -> Option<f64>,
    ) -> Self {
        let m = problem.n_rows();
        // Distances only where a parent may be screened: most steps of a crowd have none.
        let mut distance = vec![0.0; m];
        let mut keep = vec![false; m];
        let mut parent_of = vec![usize::MAX; m];
        let parents = parents
            .iter()
            .enumerate()
            .map(|(index, rows)| {
                let reach = reach_of(rows);
                if reach.is_some() {
                    rows.iter()
                        .for_each(|&i| distance[i] = signed_distance(problem, i));
                }
                let worst = rows.iter().fold(0.0, |acc: f64, &i| acc.max(distance[i]));
                // A row whose distance is not a number stays, so that its block's solver
                // reports it.
                let kept = |i: usize| {
                    reach.is_none_or(|reach| distance[i].is_nan() || distance[i] >= -reach * worst)
                };
                let left_out = rows.iter().filter(|&&i| !kept(i)).count();
                let screened =
                    left_out > 0 && left_out as f64 >= SCREEN_FRACTION * rows.len() as f64;
                let reach = reach.unwrap_or(SCREEN_REACH);
                for &i in rows {
                    parent_of[i] = index;
                    keep[i] = !screened || kept(i);
                }
                Parent {
                    worst,
                    reach,
                    screened,
                    needed: None,
                }
            })
            .collect();
        Self {
            keep,
            parent_of,
            distance,
            parents,
        }
    }

    /// Whether any row is left out.
    pub(crate) fn any(&self) -> bool {
        self.parents.iter().any(|p| p.screened)
    }

    /// Whether each row is in a block.
    pub(crate) fn keep(&self) -> &[bool] {
        &self.keep
    }

    /// Whether row `i`'s parent leaves rows out: its blocks are a jam's clusters.
    pub(crate) fn screened(&self, i: usize) -> bool {
        self.parent_of
            .get(i)
            .and_then(|&p| self.parents.get(p))
            .is_some_and(|p| p.screened)
    }

    /// The rows left out that `x` violates (`aᵢ·x ≤ bᵢ`), which join the blocks; each parent
    /// remembers the reach that would have kept them.
    pub(crate) fn join_violated(&mut self, problem: &ProjectionProblem, x: &[f64]) -> Vec<usize> {
        let violated: Vec<usize> = (0..problem.n_rows())
            .filter(|&i| !self.keep[i] && self.screened(i))
            .filter(|&i| row_slack(problem, i, x) <= 0.0)
            .collect();
        for &i in &violated {
            self.keep[i] = true;
            let parent = &mut self.parents[self.parent_of[i]];
            if parent.worst > 0.0 {
                let reach = -self.distance[i] / parent.worst;
                parent.needed = Some(parent.needed.map_or(reach, |n: f64| n.max(reach)));
            }
        }
        violated
    }

    /// Takes row `i`'s parent whole from now on.
    pub(crate) fn unscreen(&mut self, i: usize) {
        let Some(&p) = self.parent_of.get(i) else {
            return;
        };
        if p == usize::MAX || !self.parents[p].screened {
            return;
        }
        self.parents[p].screened = false;
        for (keep, &parent) in self.keep.iter_mut().zip(&self.parent_of) {
            if parent == p {
                *keep = true;
            }
        }
    }

    /// The screening reach of row `i`'s parent at the next projection ([`next_reach`]).
    pub(crate) fn next_reach(&self, i: usize) -> f64 {
        self.parent_of
            .get(i)
            .and_then(|&p| self.parents.get(p))
            .map_or(SCREEN_REACH, |p| next_reach(p.reach, p.needed))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sweeping_api::{Blocks, SparseRows};

    /// A block whose screening missed rows keeps them the next time (with a quarter to
    /// spare, up to the widest reach); one that missed none shrinks back to the jam's reach.
    #[test]
    fn the_screening_reach_widens_after_a_miss_and_shrinks_back() {
        assert_eq!(next_reach(SCREEN_REACH, Some(0.8)), 1.0);
        assert_eq!(next_reach(2.0, Some(0.8)), 2.0);
        assert_eq!(next_reach(3.0, Some(10.0)), SCREEN_REACH_MAX);
        assert_eq!(next_reach(1.0, None), 0.8);
        assert_eq!(next_reach(0.55, None), SCREEN_REACH);
    }

    /// Unknowns 0–3 in a chain: `d₀ + d₁ ≥ 2` violated (by √2 as a distance), `d₁ + d₂ ≥ −2`
    /// with room √2, `d₂ + d₃ ≥ 1` violated by 1/√2, `d₃ ≥ −10` with room 10. At reach 0.5
    /// the two rows with room are left out and the violated ones fall apart into two blocks.
    fn chain() -> ProjectionProblem {
        let a = SparseRows::from_rows(
            4,
            &[
                vec![(0, 1.0), (1, 1.0)],
                vec![(1, 1.0), (2, 1.0)],
                vec![(2, 1.0), (3, 1.0)],
                vec![(3, 1.0)],
            ],
        );
        ProjectionProblem::new(vec![0.0; 4], a, vec![2.0, -2.0, 1.0, -10.0]).unwrap()
    }

    #[test]
    fn rows_with_room_beyond_the_reach_are_left_out_and_the_rest_split() {
        let p = chain();
        let parents = vec![vec![0, 1, 2, 3]];
        assert_eq!(Blocks::split_violated(&p).blocks()[0].rows, parents[0]);
        let screening = Screening::new(&p, &parents, |_| Some(SCREEN_REACH));
        assert!(screening.any() && screening.screened(0));
        assert_eq!(screening.keep(), &[true, false, true, false]);
        assert_eq!(Blocks::split_among(&p, screening.keep()).blocks().len(), 2);
        // A remembered reach of 2 keeps row 1 (room √2 against √2), not row 3.
        let wider = Screening::new(&p, &parents, |_| Some(2.0));
        assert_eq!(wider.keep(), &[true, true, true, false]);
        // A parent without a reach, or with too few rows beyond it, is taken whole.
        let whole = Screening::new(&p, &parents, |_| None);
        assert!(!whole.any() && !whole.screened(0));
        assert_eq!(whole.keep(), &[true; 4]);
        let few = Screening::new(&p, &parents, |_| Some(8.0));
        assert!(!few.any());
    }

    /// Room and violation are distances: `x₀ ≥ 1` is violated by 1 at `y = 0`, and `3 x₁ ≥ −3.3`
    /// has room 3.3 in its own units but 1.1 as a distance, so a reach of 1.2 keeps it and one
    /// of 1 leaves it out.
    #[test]
    fn room_is_measured_as_a_distance() {
        let a = SparseRows::from_rows(2, &[vec![(0, 1.0)], vec![(1, 3.0)]]);
        let p = ProjectionProblem::new(vec![0.0; 2], a, vec![1.0, -3.3]).unwrap();
        let parents = vec![vec![0, 1]];
        assert_eq!(
            Screening::new(&p, &parents, |_| Some(1.2)).keep(),
            &[true; 2]
        );
        assert_eq!(
            Screening::new(&p, &parents, |_| Some(1.0)).keep(),
            &[true, false]
        );
    }

    /// A row whose violation at `y` overflows (`∞ − ∞`) is not left out: its block's solver
    /// sees it and reports it.
    #[test]
    fn a_row_whose_violation_is_not_a_number_stays() {
        let a = SparseRows::from_rows(
            4,
            &[vec![(0, 1.0)], vec![(1, 1e10), (2, 1e10)], vec![(3, 1.0)]],
        );
        let y = vec![0.0, 1e300, -1e300, 0.0];
        let p = ProjectionProblem::new(y, a, vec![1.0, 0.0, -100.0]).unwrap();
        let screening = Screening::new(&p, &[vec![0, 1, 2]], |_| Some(SCREEN_REACH));
        assert_eq!(screening.keep(), &[true, true, false]);
    }

    /// A point that satisfies the rows left out lets none join; one that violates row 1 makes
    /// it join, and the parent remembers the reach that would have kept it (its room √2
    /// against the largest violation √2: 1, and a quarter to spare).
    #[test]
    fn a_violated_row_left_out_joins_and_widens_the_next_reach() {
        let p = chain();
        let parents = vec![vec![0, 1, 2, 3]];
        let mut screening = Screening::new(&p, &parents, |_| Some(SCREEN_REACH));
        let satisfied = [1.0, 1.0, 0.5, 0.5];
        assert!(screening.join_violated(&p, &satisfied).is_empty());
        assert_eq!(screening.next_reach(0), SCREEN_REACH);
        let violating = [1.0, 1.0, -3.5, 4.5];
        assert_eq!(screening.join_violated(&p, &violating), vec![1]);
        assert_eq!(screening.keep(), &[true, true, true, false]);
        assert!((screening.next_reach(2) - 1.25).abs() < 1e-12);
        screening.unscreen(0);
        assert!(!screening.any());
        assert_eq!(screening.keep(), &[true; 4]);
        // A row outside every parent has none to take whole.
        let mut partial = Screening::new(&p, &[vec![0, 1, 2]], |_| Some(SCREEN_REACH));
        partial.unscreen(3);
        assert_eq!(partial.keep(), &[true, false, true, false]);
    }
}
