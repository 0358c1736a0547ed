//! Pivot rules: which rows leave the support (along the ray or toward the new multipliers,
//! under Bland's rule when a pass cycled) and which violated rows join it.

use super::Failure;

/// Under Bland's rule, rows whose multipliers reach zero within this fraction of the first
/// count as reaching it together.
const BLAND_TIE: f64 = 1e-9;

/// A support (row indices, increasing) and a positive multiplier per row.
pub(super) type Support = (Vec<usize>, Vec<f64>);

/// When some multiplier `μ` of the support is negative beyond rounding, the smaller support
/// and its multipliers: every such row at once (`aggressive`, before any row has joined), or
/// Lawson–Hanson's step from `λ` toward `μ` until the first entry reaches zero. `None` when
/// every `μ` is non-negative.
pub(super) fn drop_negative(
    support: &[usize],
    lambda: &[f64],
    mu: &[f64],
    tol: f64,
    aggressive: bool,
    bland: bool,
) -> Result<Option<Support>, Failure> {
    let floor = -tol * mu.iter().fold(1.0, |acc: f64, m| acc.max(m.abs()));
    if !mu.iter().any(|&m| m < floor) {
        return Ok(None);
    }
    if aggressive {
        return Ok(Some(
            support
                .iter()
                .zip(mu)
                .filter(|(_, &m)| m >= floor)
                .map(|(&i, &m)| (i, m.max(f64::MIN_POSITIVE)))
                .unzip(),
        ));
    }
    let (blocking, alpha) = blocking_row(
        lambda
            .iter()
            .zip(mu)
            .enumerate()
            .filter(|(_, (_, m))| **m < 0.0)
            .map(|(j, (l, m))| (j, l / (l - m))),
        support,
        bland,
    )
    .ok_or(Failure::Numerical("no blocking multiplier"))?;
    let step: Vec<f64> = lambda
        .iter()
        .zip(mu)
        .map(|(l, m)| l + alpha * (m - l))
        .collect();
    Ok(Some(shrink(support, &step, blocking)))
}

/// Of the rows `(position in the support, step at which its multiplier reaches zero)`, the one
/// that blocks a step, and the step: the first smallest, or under Bland's rule, of those that
/// reach zero within [`BLAND_TIE`] (relative) of the smallest, the lowest-numbered row.
pub(super) fn blocking_row(
    candidates: impl Iterator<Item = (usize, f64)>,
    support: &[usize],
    bland: bool,
) -> Option<(usize, f64)> {
    if !bland {
        return candidates.min_by(|a, b| a.1.total_cmp(&b.1));
    }
    let candidates: Vec<(usize, f64)> = candidates.collect();
    let least = candidates.iter().map(|c| c.1).fold(f64::INFINITY, f64::min);
    candidates
        .iter()
        .filter(|c| c.1 <= least * (1.0 + BLAND_TIE))
        .min_by_key(|c| support[c.0])
        .map(|c| (c.0, least))
}

/// The violated rows that join the support, with their starting multipliers: all of them
/// (or the `at_most` most violated, in the order of `violated`) from their remembered
/// multipliers, or (Lawson–Hanson `proper`) only the steepest descent direction of the dual,
/// the largest `violation`, from zero.
pub(super) fn joining_rows(
    violated: &[usize],
    violation: impl Fn(usize) -> f64,
    join: &[f64],
    proper: bool,
    at_most: Option<usize>,
) -> Result<Vec<(usize, f64)>, Failure> {
    if proper {
        let steepest = violated
            .iter()
            .copied()
            .max_by(|&a, &b| violation(a).total_cmp(&violation(b)))
            .ok_or(Failure::Numerical("no steepest row"))?;
        return Ok(vec![(steepest, f64::MIN_POSITIVE)]);
    }
    let most_violated: Vec<usize>;
    let joining = match at_most.filter(|&k| k < violated.len()) {
        Some(k) => {
            // The most violated first (ties by index), then back in the order of `violated`.
            let mut chosen = violated.to_vec();
            chosen.sort_by(|&a, &b| violation(b).total_cmp(&violation(a)).then(a.cmp(&b)));
            chosen.truncate(k);
            chosen.sort_unstable();
            most_violated = chosen;
            &most_violated[..]
        }
        None => violated,
    };
    Ok(joining
        .iter()
        .map(|&i| (i, join[i].max(f64::MIN_POSITIVE)))
        .collect())
}

/// The support without its entry `blocking` and without any entry that `lambda` leaves
/// non-positive, with the remaining multipliers.
pub(super) fn shrink(support: &[usize], lambda: &[f64], blocking: usize) -> (Vec<usize>, Vec<f64>) {
    support
        .iter()
        .zip(lambda)
        .enumerate()
        .filter(|&(j, (_, &l))| j != blocking && l > 0.0)
        .map(|(_, (&i, &l))| (i, l))
        .unzip()
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_blocking_row_is_the_first_to_reach_zero_or_under_blands_rule_the_lowest_numbered_near_it()
    {
        // Positions 0..4 of the support [7, 3, 9, 5] reach zero at these steps.
        let support = [7, 3, 9, 5];
        let steps = [(0, 2.0), (1, 1.0 + 1e-12), (2, 1.0), (3, 1.0 + 1e-6)];
        // The first smallest: position 2 (row 9).
        assert_eq!(
            blocking_row(steps.into_iter(), &support, false),
            Some((2, 1.0))
        );
        // Bland: rows 3 and 9 reach zero within 1e-9 of each other, row 5 does not: row 3
        // leaves, at the smallest step.
        assert_eq!(
            blocking_row(steps.into_iter(), &support, true),
            Some((1, 1.0))
        );
        // A tie at zero: only exact zeros are tied.
        let at_zero = [(0, 0.0), (1, 1e-300), (2, 0.0)];
        assert_eq!(
            blocking_row(at_zero.into_iter(), &support, true),
            Some((0, 0.0))
        );
        assert_eq!(blocking_row(std::iter::empty(), &support, true), None);
        assert_eq!(blocking_row(std::iter::empty(), &support, false), None);
    }

    #[test]
    fn at_most_k_violated_rows_join_the_most_violated_first_in_index_order() {
        let violated = [1, 3, 4, 7];
        let violation = |i: usize| [0.0, 0.5, 0.0, 2.0, 0.5, 0.0, 0.0, 1.0][i];
        let join: Vec<f64> = (0..8).map(|i| 0.1 * i as f64).collect();
        let rows = |at_most| -> Vec<usize> {
            joining_rows(&violated, violation, &join, false, at_most)
                .unwrap()
                .into_iter()
                .map(|(i, _)| i)
                .collect()
        };
        assert_eq!(rows(None), vec![1, 3, 4, 7]);
        assert_eq!(rows(Some(1)), vec![3]);
        assert_eq!(rows(Some(2)), vec![3, 7]);
        // Rows 1 and 4 are as violated: the lower index goes first.
        assert_eq!(rows(Some(3)), vec![1, 3, 7]);
        assert_eq!(rows(Some(4)), vec![1, 3, 4, 7]);
        assert_eq!(rows(Some(10)), vec![1, 3, 4, 7]);
        // Each starts from its remembered multiplier.
        let two = joining_rows(&violated, violation, &join, false, Some(2)).unwrap();
        assert_eq!(two, vec![(3, join[3]), (7, join[7])]);
        // Lawson–Hanson proper: the steepest alone, from zero, whatever the bound.
        let proper = joining_rows(&violated, violation, &join, true, Some(3)).unwrap();
        assert_eq!(proper, vec![(3, f64::MIN_POSITIVE)]);
    }

    #[test]
    fn shrink_drops_the_blocking_row_and_non_positive_ones() {
        let (support, lambda) = shrink(&[4, 7, 9, 12], &[0.5, 0.0, 2.0, -1e-300], 2);
        assert_eq!(support, vec![4]);
        assert_eq!(lambda, vec![0.5]);
        let (support, lambda) = shrink(&[1, 2], &[1.0, 3.0], 0);
        assert_eq!((support, lambda), (vec![2], vec![3.0]));
    }
}
