//! The dense path of small supports: the Cholesky factor of the Schur complement
//! `A_P A_Pᵀ + δI` and solves through it.

use super::merged_rows::MergedRows;
use super::system::DELTA;

/// Relative size of the smallest Cholesky pivot accepted on the dense path.
const DENSE_PIVOT: f64 = 1e-6;

/// The dense Cholesky factor (row-major `k × k`, lower triangle) of `A_P A_Pᵀ + δI`, the rows
/// given with sorted columns; `None` when a row is nearly a combination of the ones before
/// it (its pivot below [`DENSE_PIVOT`] times its diagonal entry). Such rows (a contact loop)
/// make `S` as ill-conditioned as `1/δ`, and the sparse `LDLᵀ` of `K_δ` is used instead.
pub(super) fn schur_cholesky(rows: &MergedRows) -> Option<Vec<f64>> {
    let k = rows.len();
    let dot = |a: &[(usize, f64)], b: &[(usize, f64)]| {
        let (mut i, mut j, mut sum) = (0, 0, 0.0);
        while i < a.len() && j < b.len() {
            match a[i].0.cmp(&b[j].0) {
                std::cmp::Ordering::Less => i += 1,
                std::cmp::Ordering::Greater => j += 1,
                std::cmp::Ordering::Equal => {
                    sum += a[i].1 * b[j].1;
                    i += 1;
                    j += 1;
                }
            }
        }
        sum
    };
    let mut l = vec![0.0; k * k];
    for i in 0..k {
        for j in 0..=i {
            let diagonal = dot(rows.row(i), rows.row(j)) + if i == j { DELTA } else { 0.0 };
            let mut v = diagonal;
            for p in 0..j {
                v -= l[i * k + p] * l[j * k + p];
            }
            if i == j {
                if v.is_nan() || v <= DENSE_PIVOT * diagonal {
                    return None;
                }
                l[i * k + i] = v.sqrt();
            } else {
                l[i * k + j] = v / l[j * k + j];
            }
        }
    }
    Some(l)
}

/// `v ← K_δ⁻¹ v` through the dense factor `l` of the support's `rows`, on `n` unknowns: `[u; w]`
/// with `u + A_Pᵀw = f`, `A_P u − δw = g` gives `(A_P A_Pᵀ + δI) w = A_P f − g` and
/// `u = f − A_Pᵀw`.
pub(super) fn solve_in_place(l: &[f64], rows: &MergedRows, n: usize, v: &mut [f64]) {
    let k = rows.len();
    let (f, g) = v.split_at_mut(n);
    // w ← A f − g, then the two triangular solves with L and Lᵀ.
    for (t, row) in rows.iter().enumerate() {
        g[t] = row.iter().map(|&(c, a)| a * f[c]).sum::<f64>() - g[t];
    }
    for i in 0..k {
        let mut s = g[i];
        for p in 0..i {
            s -= l[i * k + p] * g[p];
        }
        g[i] = s / l[i * k + i];
    }
    for i in (0..k).rev() {
        let mut s = g[i];
        for p in i + 1..k {
            s -= l[p * k + i] * g[p];
        }
        g[i] = s / l[i * k + i];
    }
    for (t, row) in rows.iter().enumerate() {
        for &(c, a) in row {
            f[c] -= a * g[t];
        }
    }
}
#[cfg(test)]
mod tests {
    use super::super::system::{ActiveSystem, Factor};
    use super::super::test_problems::{random_problem, raw_solve_gap, solve_gap};
    use super::*;
    use sweeping_api::{ProjectionProblem, SparseRows};

    #[test]
    fn a_dense_factor_solves_what_the_sparse_one_solves() {
        let p = random_problem();
        let support: Vec<usize> = (0..20).collect();
        let mut dense = ActiveSystem::new(&p, &support, None).unwrap();
        assert!(matches!(dense.factor, Factor::Dense(_)));
        // Without refinement the sparse LDLᵀ of the quasi-definite K_δ is accurate to about
        // ε/δ, as in the bordered tests.
        let gap = raw_solve_gap(&p, &mut dense, &support);
        assert!(gap < 1e-6, "gap {gap:e}");
        // With refinement both solve K₀ to rounding.
        let gap = solve_gap(&p, &mut dense, &support);
        assert!(gap < 1e-11, "gap {gap:e}");
    }

    #[test]
    fn the_dense_factor_is_the_cholesky_factor_of_the_rows_gram_matrix_plus_delta() {
        let p = random_problem();
        let support: Vec<usize> = (0..20).collect();
        let rows = MergedRows::of(&p, &support);
        let l = schur_cholesky(&rows).expect("independent rows");
        let k = support.len();
        // (L Lᵀ)ᵢⱼ against aᵢ·aⱼ + δ on the diagonal, from the rows as A holds them.
        let dense: Vec<Vec<f64>> = support
            .iter()
            .map(|&i| {
                let mut row = vec![0.0; p.dim()];
                p.a().row(i).for_each(|(c, v)| row[c] += v);
                row
            })
            .collect();
        for i in 0..k {
            for j in 0..k {
                let llt: f64 = (0..k).map(|q| l[i * k + q] * l[j * k + q]).sum();
                let gram: f64 = dense[i].iter().zip(&dense[j]).map(|(a, b)| a * b).sum();
                let expected = gram + if i == j { DELTA } else { 0.0 };
                assert!(
                    (llt - expected).abs() <= 1e-13 * (1.0 + gram.abs()),
                    "({i}, {j}): {llt:e} against {expected:e}"
                );
            }
        }
        // Upper triangle untouched.
        assert!((0..k).all(|i| (i + 1..k).all(|j| l[i * k + j] == 0.0)));
    }

    #[test]
    fn a_row_repeated_in_a_small_support_is_factored_sparse_not_dense() {
        // Rows of norm about 1.4e3, the last a copy of the first: its pivot in A Aᵀ + δI is
        // about δ against a diagonal of 2e6, far below DENSE_PIVOT times it.
        let s = 1e3;
        let a = SparseRows::from_rows(
            4,
            &[
                vec![(0, -s), (1, s)],
                vec![(1, -s), (2, s)],
                vec![(2, -s), (3, s)],
                vec![(0, -s), (1, s)],
            ],
        );
        let p = ProjectionProblem::new(vec![0.0; 4], a, vec![1.0; 4]).unwrap();
        assert!(schur_cholesky(&MergedRows::of(&p, &[0, 1, 2])).is_some());
        assert!(schur_cholesky(&MergedRows::of(&p, &[0, 1, 2, 3])).is_none());
        let system = ActiveSystem::new(&p, &[0, 1, 2, 3], None).unwrap();
        assert!(matches!(system.factor, Factor::Sparse(_)));
    }
}
