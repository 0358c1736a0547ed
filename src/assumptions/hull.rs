//! `γ` of assumptions A5 and A5': the distance from the origin to the convex hull of unit
//! normals, computed by one call of a [`Projector`].
//!
//! # Why `γ = 1 / dist(0, conv{nᵢ})`
//! A5 asks for the smallest `γ` with `Σ λᵢ |∇gᵢ| ≤ γ |Σ λᵢ ∇gᵢ|` for all `λᵢ ≥ 0`. With
//! `nᵢ = ∇gᵢ/|∇gᵢ|` and `μᵢ = λᵢ|∇gᵢ| / Σⱼ λⱼ|∇gⱼ|` (a point of the simplex) it reads
//! `1 ≤ γ |Σ μᵢ nᵢ|` for every `μ` of the simplex, so `γ = 1 / minᵤ |Σ μᵢ nᵢ| = 1/dist(0, C)`
//! with `C = conv{nᵢ}`; `γ = ∞` exactly when `0 ∈ C` (the gradients are positively dependent).
//!
//! # Why it is one projection
//! For any vectors `vᵢ`, `min{|x| : ⟨vᵢ, x⟩ ≥ 1 ∀ i} = 1/dist(0, conv{vᵢ})`: the Lagrangian dual
//! of `min ½|x|²` under those rows is `max_{λ ≥ 0} Σλᵢ − ½|Σλᵢvᵢ|²`; writing `λ = sμ` with `μ`
//! in the simplex and maximizing over `s ≥ 0` gives `s = 1/|Σμᵢvᵢ|²` and the value
//! `1/(2|Σμᵢvᵢ|²)`, whose maximum over `μ` is `1/(2 dist(0, conv{vᵢ})²)`; strong duality holds
//! because the primal is a feasible convex QP when the distance is positive. The left side is
//! the norm of the projection of the origin onto the polyhedron `{x : ⟨vᵢ, x⟩ ≥ 1}`: exactly
//! what a [`Projector`] computes.
//!
//! Applied to `nᵢ` directly the polyhedron is empty when `γ = ∞`, and not every backend
//! certifies infeasibility (the reference backend cannot). So we apply it to the *lifted*
//! vectors `ṽᵢ = (nᵢ, 1)`, whose hull `C × {1}` never contains the origin: the polyhedron
//! `{(x, s) : ⟨nᵢ, x⟩ + s ≥ 1}` always contains `(0, 1)`. Its projection of the origin is
//! `x̃* = σ (p, 1)` with `p` the point of `C` nearest the origin and `σ = 1/(1 + |p|²)`
//! (the dual's minimizer `λ = σ μ*` gives `x̃* = Σ λᵢ ṽᵢ`), so `dist(0, C) = |p| = |x*|/s*`
//! with `(x*, s*) = x̃*`. Reading `|p|` from the point (not from `1/|x̃*|² − 1`) keeps its
//! absolute error at the backend's tolerance even when `p` is near the origin.

use std::collections::HashMap;
use sweeping_api::{ProjectionError, ProjectionProblem, Projector, SparseRows};

/// A sparse vector of `R^d`: values on a few coordinates.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SparseVector {
    /// Coordinates (distinct).
    pub columns: Vec<usize>,
    /// Values on those coordinates.
    pub values: Vec<f64>,
}

impl SparseVector {
    /// The Euclidean norm.
    pub fn norm(&self) -> f64 {
        self.values.iter().map(|v| v * v).sum::<f64>().sqrt()
    }
}

/// `dist(0, conv{vᵢ})` for the given vectors, by one projection (module docs). The problem is
/// posed on the coordinates the vectors touch, plus one, so it stays small.
///
/// Returns `f64::INFINITY` for an empty list (the hull is empty).
///
/// # Errors
/// The backend's [`ProjectionError`], or [`ProjectionError::InvalidInput`] for non-finite
/// vectors.
///
/// ```
/// use sweeping::assumptions::{hull_distance, SparseVector};
/// use sweeping::api::conformance::ReferenceProjector;
/// // Unit normals at 90°: the nearest point of their hull is the midpoint, at distance 1/√2.
/// let n1 = SparseVector { columns: vec![0], values: vec![1.0] };
/// let n2 = SparseVector { columns: vec![1], values: vec![1.0] };
/// let d = hull_distance(&[n1, n2], &mut ReferenceProjector::default()).unwrap();
/// assert!((d - 0.5f64.sqrt()).abs() < 1e-8);
/// ```
pub fn hull_distance(
    vectors: &[SparseVector],
    projector: &mut dyn Projector,
) -> Result<f64, ProjectionError> {
    if vectors.is_empty() {
        return Ok(f64::INFINITY);
    }
    let mut cols: Vec<usize> = vectors
        .iter()
        .flat_map(|v| v.columns.iter().copied())
        .collect();
    cols.sort_unstable();
    cols.dedup();
    let local: HashMap<usize, usize> = cols.iter().enumerate().map(|(k, &c)| (c, k)).collect();
    let m = cols.len();
    let mut rows = SparseRows::new(m + 1);
    for v in vectors {
        let mut entries: Vec<(usize, f64)> = v
            .columns
            .iter()
            .zip(&v.values)
            .map(|(c, &x)| (local[c], x))
            .collect();
        entries.push((m, 1.0));
        rows.push_row(entries);
    }
    let problem = ProjectionProblem::new(vec![0.0; m + 1], rows, vec![1.0; vectors.len()])?;
    let sol = projector.project(&problem)?;
    let s = sol.x[m];
    if !(s > 0.0 && s.is_finite()) {
        return Err(ProjectionError::Backend {
            backend: sol.stats.backend,
            message: format!(
                "the lifted min-norm problem returned a last coordinate s = {s}, expected in (0, 1]"
            ),
        });
    }
    let x_norm = sol.x[..m].iter().map(|v| v * v).sum::<f64>().sqrt();
    Ok(x_norm / s)
}

/// Splits `vectors` into groups that share no coordinate (connected components of the
/// "touch a common coordinate" relation); returns the indices of each group.
///
/// Vectors on disjoint coordinates are orthogonal, and then
/// `dist(0, conv ∪ Cₖ)⁻² = Σₖ dist(0, conv Cₖ)⁻²`, i.e. `γ² = Σₖ γₖ²` (minimize
/// `Σ θₖ² dₖ²` over the simplex): the global `γ` of A5 follows exactly from the groups' ones.
pub fn coordinate_groups(vectors: &[SparseVector]) -> Vec<Vec<usize>> {
    let n = vectors.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut owner: HashMap<usize, usize> = HashMap::new();
    for (i, v) in vectors.iter().enumerate() {
        for &c in &v.columns {
            match owner.get(&c) {
                Some(&j) => {
                    let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                    if a != b {
                        parent[a] = b;
                    }
                }
                None => {
                    owner.insert(c, i);
                }
            }
        }
    }
    let mut groups: HashMap<usize, Vec<usize>> = HashMap::new();
    for i in 0..n {
        let root = find(&mut parent, i);
        groups.entry(root).or_default().push(i);
    }
    let mut out: Vec<Vec<usize>> = groups.into_values().collect();
    out.sort_by_key(|g| g[0]);
    out
}
