//! A support's rows of `A`, merged (columns sorted, repeats summed) and stored together.

use sweeping_api::ProjectionProblem;

/// Rows of `A`, each with its columns sorted and repeats summed, stored one after another.
///
/// One vector for all of a support's rows rather than one per row: the method builds these
/// rows at every fresh factorization, and a vector each would cost two allocations per row,
/// most of a run's allocations (measured: `docs/lab/2026-11-23-targets-release-by-release.md`).
#[derive(Debug, Clone, Default)]
pub(super) struct MergedRows {
    /// Where each row starts in `entries`, and where the last ends.
    start: Vec<usize>,
    pub(super) entries: Vec<(usize, f64)>,
}

impl MergedRows {
    /// The rows `active` of `problem`'s `A`, in that order.
    pub(super) fn of(problem: &ProjectionProblem, active: &[usize]) -> Self {
        let entries = active.iter().map(|&r| problem.a().row_len(r)).sum();
        let mut rows = Self {
            start: Vec::with_capacity(active.len() + 1),
            entries: Vec::with_capacity(entries),
        };
        rows.start.push(0);
        active.iter().for_each(|&r| rows.push(problem, r));
        rows
    }

    /// Appends row `r` of `problem`'s `A`, its columns sorted (stably) and repeats summed in
    /// the order they come.
    pub(super) fn push(&mut self, problem: &ProjectionProblem, r: usize) {
        let first = self.entries.len();
        self.entries.extend(problem.a().row(r));
        let row = &mut self.entries[first..];
        if !row.is_sorted_by_key(|&(c, _)| c) {
            row.sort_by_key(|&(c, _)| c);
        }
        // Repeats summed in place: `end` is the merged row's length so far.
        let mut end = first;
        for q in first..self.entries.len() {
            let (c, v) = self.entries[q];
            if end > first && self.entries[end - 1].0 == c {
                self.entries[end - 1].1 += v;
            } else {
                self.entries[end] = (c, v);
                end += 1;
            }
        }
        self.entries.truncate(end);
        self.start.push(end);
    }

    /// How many rows.
    pub(super) fn len(&self) -> usize {
        self.start.len() - 1
    }

    /// Row `t`.
    pub(super) fn row(&self, t: usize) -> &[(usize, f64)] {
        &self.entries[self.start[t]..self.start[t + 1]]
    }

    /// The rows in order.
    pub(super) fn iter(&self) -> impl Iterator<Item = &[(usize, f64)]> {
        self.start.windows(2).map(|w| &self.entries[w[0]..w[1]])
    }

    /// Keeps the rows `t` for which `keep(t)` holds, in order.
    pub(super) fn retain(&mut self, mut keep: impl FnMut(usize) -> bool) {
        let mut end = 0;
        let mut kept = 1;
        for t in 0..self.len() {
            let (from, to) = (self.start[t], self.start[t + 1]);
            if keep(t) {
                self.entries.copy_within(from..to, end);
                end += to - from;
                self.start[kept] = end;
                kept += 1;
            }
        }
        self.entries.truncate(end);
        self.start.truncate(kept);
    }
}
#[cfg(test)]
mod tests {
    use super::*;
    use sweeping_api::SparseRows;

    #[test]
    fn merged_rows_sort_columns_sum_repeats_and_keep_rows_in_order() {
        let a = SparseRows::from_rows(
            5,
            &[
                vec![(3, 1.0), (1, 2.0), (3, 0.5)],
                vec![(0, 1.0), (4, -1.0)],
                vec![(2, 1.0), (2, 1.0), (2, 1.0)],
                vec![],
            ],
        );
        let p = ProjectionProblem::new(vec![0.0; 5], a, vec![0.0; 4]).unwrap();
        let mut rows = MergedRows::of(&p, &[2, 0, 3, 1]);
        let listed: Vec<Vec<(usize, f64)>> = rows.iter().map(<[_]>::to_vec).collect();
        assert_eq!(
            listed,
            vec![
                vec![(2, 3.0)],
                vec![(1, 2.0), (3, 1.5)],
                vec![],
                vec![(0, 1.0), (4, -1.0)],
            ]
        );
        rows.retain(|t| t != 0 && t != 2);
        assert_eq!(rows.len(), 2);
        assert_eq!(rows.row(0), &[(1, 2.0), (3, 1.5)]);
        assert_eq!(rows.row(1), &[(0, 1.0), (4, -1.0)]);
        rows.push(&p, 2);
        assert_eq!(rows.row(2), &[(2, 3.0)]);
        assert_eq!(rows.entries.len(), 5);
    }
}
