//! Constraints written once, differentiated by num-dual.
//!
//! A constraint `g(t, q) ≥ 0` reads only a few coordinates of the configuration `q` (its
//! *support*: four for a pair of disks in the plane, two for a disk and a wall). The user
//! writes its value once, as a function generic over num-dual's [`DualNum`], on those `K`
//! coordinates ([`ConstraintKernel`]); [`linearize`] and [`second_order`] evaluate it on
//! fixed-size dual numbers on the stack to get
//!
//! * `g`, `∇_q g` (and `∂ₜg` when the constraint moves): the row of the linearized set
//!   `Q̃(t, q) = {x : g(t,q) + ⟨∇g(t,q), x − q⟩ ≥ 0}` of the scheme (paper, equation `schema`);
//! * `D²_q g` and `∂ₜ∇_q g`: the quantities bounded by assumptions A3 and A4.
//!
//! Constraints come in *families* ([`ConstraintFamily`], object-safe): all the pairs of a crowd
//! are one family that emits rows only for the candidates it is asked about, so a crowd of 10⁴
//! people is not 10⁸ boxed objects. [`KernelFamily`] is the family of an explicit list of
//! instances of one kernel; crowds ship their own families built on the same kernels.

use nalgebra::SVector;
use num_dual::{
    first_derivative, gradient, hessian, partial_hessian, Dual2SVec64, Dual64, DualNum, DualSVec64,
    HyperDualSVec64,
};
use serde::{Deserialize, Serialize};

/// The scalar a constraint is written over: a num-dual number on `f64` (plain `f64`, or any
/// dual number the library differentiates with). An alias of `DualNum<Primitive = f64> + Copy`,
/// implemented for every such type; write kernels as `fn value<D: Scalar>(…)`.
///
/// # Arithmetic with constants: the spellings that compile
/// `D` is a type parameter, and Rust lets no crate implement `f64 − D` for every `D` (the
/// orphan rule), so a constant may stand on the **right** of an operator, or be turned into a
/// `D` first. With `x, y: D`:
///
/// | maths | write | not |
/// |---|---|---|
/// | `1 − x` | `-x + 1.0` or `D::from(1.0) - x` or `x.rsub(1.0)` | `1.0 - x` |
/// | `t/2` | `t * 0.5` or `t / 2.0` | `0.5 * t` |
/// | `2/x` | `x.recip() * 2.0` or `D::from(2.0) / x` | `2.0 / x` |
/// | `x²`, `√x`, `|x|` | `x * x` or `x.powi(2)`, `x.sqrt()`, `x.abs()` | |
/// | `max(x, y)` | `if x > y { x } else { y }` (not differentiable where they tie) | |
/// | `x < 0` | `x.re() < 0.0` (compare the value) or `x < 0.0` | |
///
/// The compiler's message for the wrong spelling is `cannot subtract D from {float}` (or
/// `cannot multiply {float} by D`), followed by "the trait `Sub<D>` is not implemented for
/// `{float}`"; the fix is one of the spellings above:
///
/// ```compile_fail
/// use sweeping::prelude::*;
/// /// g(u, w) = 1 − u − w ≥ 0: below a line (affine, so convex as the theory asks).
/// fn below_the_line<D: Scalar>(u: D, w: D) -> D {
///     1.0 - u - w // error[E0277]: cannot subtract `D` from `{float}`
/// }
/// ```
///
/// ```
/// use sweeping::prelude::*;
/// /// g(u, w) = 1 − u − w ≥ 0: below a line (affine, so convex as the theory asks).
/// fn below_the_line<D: Scalar>(u: D, w: D) -> D {
///     -u - w + 1.0 // or: D::from(1.0) - u - w, or (u + w).rsub(1.0)
/// }
/// assert_eq!(below_the_line(0.25, 0.5), 0.25);
/// ```
pub trait Scalar: DualNum<Primitive = f64> + Copy {
    /// `c − self`: the constant on the left, spelled as a method.
    fn rsub(self, c: f64) -> Self {
        -self + c
    }
}

impl<D: DualNum<Primitive = f64> + Copy> Scalar for D {}

/// The curvature of `g` in `q`, which says which of the two classes of sweeping processes a
/// constraint belongs to and how each step treats it.
///
/// | `Curvature` | `g` | `{g ≥ 0}` | example | each step projects onto |
/// |---|---|---|---|---|
/// | [`Convex`](Self::Convex) (default) | convex | complement of a convex set (prox-regular) | outside a disk: `|z − c| − r` | the linearization at `q_k`, an inner approximation (the paper) |
/// | [`Concave`](Self::Concave) | concave | a convex set (Moreau) | inside a disk: `R − |z − c|` | the set itself, by linearizations refined at the iterate until certified |
///
/// An affine `g` is both; leave the default. A concave declaration is checked like convexity
/// is (the largest eigenvalue of `D²g` must not be positive beyond rounding): by the stepper at
/// the start and wherever it refines a linearization, by
/// [`crate::assumptions::BoundsMonitor`] and by [`crate::assumptions::estimate_problem`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Curvature {
    /// `g` convex in `q`: the paper's class. Its linearization at `q_k` lies inside
    /// `{g ≥ 0}`, so the step's single projection is feasible.
    #[default]
    Convex,
    /// `g` concave in `q`: `{g ≥ 0}` is convex (Moreau's sweeping process). Its linearization
    /// is an outer approximation, so the stepper refines it at each iterate (cutting planes)
    /// until the projection onto the true set is certified.
    Concave,
}

/// One kind of constraint `g(t, z) ≥ 0`, written once over dual numbers on its `K` coordinates.
///
/// # The theory's requirement: `g` convex in `z`
/// The scheme replaces `{g ≥ 0}` by its linearization at the current state; that set lies
/// inside `{g ≥ 0}` (so every step is feasible and the order-½ theorem applies) when `g` is
/// **convex** in `z` (its Hessian `D²g` has no negative eigenvalue). "Stay outside a ball"
/// (`|z − c| − r ≥ 0`) is convex; "stay inside an ellipse" written as `1 − |E(z − c)|² ≥ 0` is
/// concave, and its linearization is an outer approximation: points end slightly outside.
/// Express a convex feasible region as an intersection of convex pieces — affine ones
/// (`⟨n, z⟩ − d ≥ 0`, one per side of a polygon), or "outside a ball" — or, for a region
/// that is not convex itself, expect drift outside of order `h²·|D²g|·|velocity|²` per step
/// and no convergence guarantee. [`crate::assumptions::estimate_problem`] and
/// [`crate::assumptions::BoundsMonitor`] check the smallest eigenvalue of `D²g` and name the
/// constraint that fails.
///
/// `Params` carries what distinguishes one instance from another (two radii, a wall's
/// endpoints…); a single constraint without data is shorter as a [`Constraint`] (which is a
/// `ConstraintKernel` with `Params = ()`). Arithmetic with constants: see
/// [`Scalar`] for the spellings that compile (`t * 0.5`, `-x + 1.0`).
///
/// # Example
/// A point of the plane kept outside a ball of radius 1 whose centre moves at speed 0.5 along
/// the first axis: `g(t, z) = |z − c(t)| − 1`.
///
/// ```
/// use sweeping::prelude::*;
/// use sweeping::constraint::linearize;
///
/// struct OutsideMovingBall;
///
/// impl ConstraintKernel<2> for OutsideMovingBall {
///     type Params = ();
///     fn value<D: Scalar>(&self, _: &(), t: D, z: [D; 2]) -> D {
///         let dx = z[0] - t * 0.5;
///         (dx * dx + z[1] * z[1]).sqrt() - 1.0
///     }
/// }
///
/// let lin = linearize(&OutsideMovingBall, &(), 2.0, [4.0, 4.0], true);
/// assert!((lin.value - 4.0).abs() < 1e-12);            // |(3, 4)| − 1
/// assert!((lin.gradient[0] - 0.6).abs() < 1e-12);      // (3, 4)/5
/// assert!((lin.dt.unwrap() + 0.3).abs() < 1e-12);      // −0.5 · 0.6
/// ```
pub trait ConstraintKernel<const K: usize>: Send + Sync {
    /// Per-instance data.
    type Params: Send + Sync;

    /// `g(t, z)`, with `z` the `K` coordinates of the support, in support order.
    fn value<D: Scalar>(&self, params: &Self::Params, t: D, z: [D; K]) -> D;

    /// Whether `g` depends on `t`. When `false`, `∂ₜg` and `∂ₜ∇g` are not computed (they are
    /// zero). Default `true`.
    fn is_time_dependent(&self) -> bool {
        true
    }

    /// Whether `g` is affine in `z`. When `true`, `D²g` is not computed (it is zero), the
    /// linearization is exact and the convexity check is skipped; the claim itself is checked
    /// once by [`crate::assumptions::estimate_problem`] and
    /// [`crate::assumptions::BoundsMonitor`] (through [`ConstraintFamily::affine_check`]).
    /// Default `false`.
    fn is_affine(&self) -> bool {
        false
    }

    /// The curvature of `g` in `z` (see [`Curvature`]): [`Curvature::Concave`] declares
    /// `{g ≥ 0}` convex, and each step then projects onto it exactly instead of onto its
    /// linearization. Checked, not trusted. Default [`Curvature::Convex`] (the paper's class).
    fn curvature(&self) -> Curvature {
        Curvature::Convex
    }
}

/// A constraint without parameters, `g(t, z) ≥ 0` on `K` coordinates: the short form of
/// [`ConstraintKernel`] for a single constraint of your own (every `Constraint` is a
/// `ConstraintKernel` with `Params = ()`, so it goes wherever a kernel goes). Use
/// `ConstraintKernel` when one kernel serves many instances with their own data (radii, a
/// wall's position…).
///
/// `g` must be convex in `z` (see [`ConstraintKernel`]); constants go on the right of an
/// operator (see [`Scalar`]).
///
/// ```
/// use sweeping::prelude::*;
/// /// Stay outside the unit ball centred at (t/2, 0).
/// struct OutsideMovingBall;
/// impl Constraint<2> for OutsideMovingBall {
///     fn value<D: Scalar>(&self, t: D, z: [D; 2]) -> D {
///         let dx = z[0] - t * 0.5;
///         (dx * dx + z[1] * z[1]).sqrt() - 1.0
///     }
/// }
/// let problem = Problem::new(vec![2.0, 0.0], NoPerturbation)
///     .with_constraint("ball", OutsideMovingBall, [0, 1]);
/// let lin = sweeping::constraint::linearize(&OutsideMovingBall, &(), 0.0, [2.0, 0.0], true);
/// assert!((lin.value - 1.0).abs() < 1e-15 && (lin.dt.unwrap() + 0.5).abs() < 1e-15);
/// ```
pub trait Constraint<const K: usize>: Send + Sync {
    /// `g(t, z)`, with `z` the `K` coordinates of the support, in support order.
    fn value<D: Scalar>(&self, t: D, z: [D; K]) -> D;

    /// Whether `g` depends on `t` (see [`ConstraintKernel::is_time_dependent`]). Default
    /// `true`.
    fn is_time_dependent(&self) -> bool {
        true
    }

    /// Whether `g` is affine in `z` (see [`ConstraintKernel::is_affine`]; checked once).
    /// Default `false`.
    fn is_affine(&self) -> bool {
        false
    }

    /// The curvature of `g` in `z` (see [`ConstraintKernel::curvature`]). Default
    /// [`Curvature::Convex`].
    fn curvature(&self) -> Curvature {
        Curvature::Convex
    }
}

impl<C: Constraint<K>, const K: usize> ConstraintKernel<K> for C {
    type Params = ();
    fn value<D: Scalar>(&self, _: &(), t: D, z: [D; K]) -> D {
        Constraint::value(self, t, z)
    }
    fn is_time_dependent(&self) -> bool {
        Constraint::is_time_dependent(self)
    }
    fn is_affine(&self) -> bool {
        Constraint::is_affine(self)
    }
    fn curvature(&self) -> Curvature {
        Constraint::curvature(self)
    }
}

/// Value and first derivatives of a constraint at `(t, z)`, on its support.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KernelLinearization<const K: usize> {
    /// `g(t, z)`.
    pub value: f64,
    /// `∇_z g(t, z)`.
    pub gradient: [f64; K],
    /// `∂ₜ g(t, z)`, when asked for and the kernel is time-dependent (`Some(0.0)` for a
    /// static kernel asked for it).
    pub dt: Option<f64>,
}

/// Second derivatives of a constraint at `(t, z)`, on its support.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KernelSecondOrder<const K: usize> {
    /// `g(t, z)`.
    pub value: f64,
    /// `∇_z g`.
    pub gradient: [f64; K],
    /// `∂ₜ g`.
    pub dt: f64,
    /// `D²_z g`, row-major `K × K` (symmetric).
    pub hessian: [[f64; K]; K],
    /// `∂ₜ ∇_z g`.
    pub dt_gradient: [f64; K],
}

/// `g`, `∇g` and (if `want_dt`) `∂ₜg` of a kernel, by forward-mode duals on the stack.
pub fn linearize<C: ConstraintKernel<K> + ?Sized, const K: usize>(
    kernel: &C,
    params: &C::Params,
    t: f64,
    z: [f64; K],
    want_dt: bool,
) -> KernelLinearization<K> {
    let zv = SVector::<f64, K>::from(z);
    let (value, grad) = gradient(
        |v: SVector<DualSVec64<K>, K>| {
            kernel.value(
                params,
                DualSVec64::<K>::from_re(t),
                std::array::from_fn(|i| v[i]),
            )
        },
        &zv,
    );
    let dt = if !want_dt {
        None
    } else if kernel.is_time_dependent() {
        let (_, d) = first_derivative(
            |tt: Dual64| kernel.value(params, tt, z.map(Dual64::from_re)),
            t,
        );
        Some(d)
    } else {
        Some(0.0)
    };
    KernelLinearization {
        value,
        gradient: grad.into(),
        dt,
    }
}

impl<const K: usize> KernelSecondOrder<K> {
    /// The same derivatives as a family member's, on the coordinates `columns` of `q` the
    /// kernel's `z` gathers (`columns.len() == K`).
    pub fn on_columns(&self, columns: Vec<usize>) -> SecondOrderData {
        debug_assert_eq!(columns.len(), K);
        SecondOrderData {
            value: self.value,
            columns,
            gradient: self.gradient.to_vec(),
            dt: self.dt,
            hessian: self.hessian.iter().flatten().copied().collect(),
            dt_gradient: self.dt_gradient.to_vec(),
        }
    }
}

/// Everything A1–A4 bound: value, `∇g`, `∂ₜg`, `D²g`, `∂ₜ∇g`. Skips the Hessian of an affine
/// kernel and the time derivatives of a static one.
pub fn second_order<C: ConstraintKernel<K> + ?Sized, const K: usize>(
    kernel: &C,
    params: &C::Params,
    t: f64,
    z: [f64; K],
) -> KernelSecondOrder<K> {
    let zv = SVector::<f64, K>::from(z);
    let mut out = KernelSecondOrder {
        value: 0.0,
        gradient: [0.0; K],
        dt: 0.0,
        hessian: [[0.0; K]; K],
        dt_gradient: [0.0; K],
    };
    if kernel.is_time_dependent() {
        let tv = SVector::<f64, 1>::from([t]);
        let (value, grad, dt, dtgrad) = partial_hessian(
            |(v, s): (
                SVector<HyperDualSVec64<K, 1>, K>,
                SVector<HyperDualSVec64<K, 1>, 1>,
            )| { kernel.value(params, s[0], std::array::from_fn(|i| v[i])) },
            (&zv, &tv),
        );
        out.value = value;
        out.gradient = grad.into();
        out.dt = dt[0];
        for i in 0..K {
            out.dt_gradient[i] = dtgrad[(i, 0)];
        }
    } else {
        let lin = linearize(kernel, params, t, z, false);
        out.value = lin.value;
        out.gradient = lin.gradient;
    }
    if !kernel.is_affine() {
        out.hessian = hessian_of(kernel, params, t, z);
    }
    out
}

/// `D²_z g` at `(t, z)`, row-major, computed whatever [`ConstraintKernel::is_affine`] says
/// (to check that claim).
pub fn hessian_of<C: ConstraintKernel<K> + ?Sized, const K: usize>(
    kernel: &C,
    params: &C::Params,
    t: f64,
    z: [f64; K],
) -> [[f64; K]; K] {
    let zv = SVector::<f64, K>::from(z);
    let (_, _, h) = hessian(
        |v: SVector<Dual2SVec64<K>, K>| {
            kernel.value(
                params,
                Dual2SVec64::<K>::from_re(t),
                std::array::from_fn(|i| v[i]),
            )
        },
        &zv,
    );
    std::array::from_fn(|i| std::array::from_fn(|j| h[(i, j)]))
}

/// A linearized constraint: `value + ⟨gradient, x_support − q_support⟩ ≥ 0`, on the
/// coordinates `columns`. Reused across calls to avoid allocation.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LinearizedRow {
    /// `g(t, q)`.
    pub value: f64,
    /// `∂ₜ g(t, q)` when asked for.
    pub dt: Option<f64>,
    /// Coordinates of `q` the constraint reads.
    pub columns: Vec<usize>,
    /// `∇_q g` on those coordinates.
    pub gradient: Vec<f64>,
}

impl LinearizedRow {
    /// `|∇_q g|`.
    pub fn gradient_norm(&self) -> f64 {
        self.gradient.iter().map(|v| v * v).sum::<f64>().sqrt()
    }
}

/// Second-order data of one constraint on its support (for the assumption checks).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SecondOrderData {
    /// `g(t, q)`.
    pub value: f64,
    /// Coordinates of `q` the constraint reads.
    pub columns: Vec<usize>,
    /// `∇_q g` on those coordinates.
    pub gradient: Vec<f64>,
    /// `∂ₜ g`.
    pub dt: f64,
    /// `D²_q g`, row-major, `columns.len()` squared.
    pub hessian: Vec<f64>,
    /// `∂ₜ ∇_q g` on those coordinates.
    pub dt_gradient: Vec<f64>,
}

/// The identity of one constraint of a [`Problem`](crate::problem::Problem): the index of
/// its family in [`Problem::families`](crate::problem::Problem::families) and its member index
/// in that family. Copy and allocation-free; [`Problem::describe`](crate::problem::Problem::describe)
/// names it for people.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct ConstraintId {
    /// Index of the family in the problem.
    pub family: usize,
    /// Member index in the family (see [`ConstraintFamily::member_bound`]).
    pub member: usize,
}

impl std::fmt::Display for ConstraintId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "family {}, member {}", self.family, self.member)
    }
}

/// What a family's constraints keep apart, for reports that tell overlaps of people from
/// penetrations into walls and obstacles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[non_exhaustive]
pub enum FamilyKind {
    /// Pairs of people that may not overlap.
    Pairs,
    /// People kept out of walls or obstacles.
    PersonShapes,
    /// Anything else (user constraints).
    #[default]
    Other,
}

/// How far a moving set travels within an interval, and its largest speed there (see
/// [`ConstraintFamily::travel_within`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Travel {
    /// The length of its path in the interval.
    pub distance: f64,
    /// The largest speed along it.
    pub max_speed: f64,
}

/// A family of constraints `gᵢ(t, q) ≥ 0`, indexed by family-defined member indices.
///
/// # Members
/// A family has [`count`](Self::count) constraints, each named by a member index below
/// [`member_bound`](Self::member_bound). The two are equal for a family numbering its members
/// `0..count()` (the default); a family may number them sparsely (the pairs `(i, j)`, `i < j`,
/// of `N` people are the `N(N−1)/2` members `i·N + j`, below `N²`: see
/// [`DiskPairs::pair`](crate::crowd::DiskPairs::pair)), and must then override
/// [`candidates`](Self::candidates) and `member_bound`.
///
/// Object-safe: a problem holds `Box<dyn ConstraintFamily>`s. The generic code (the stepper,
/// the assumption checks) asks a family for *candidates* near a configuration and for the
/// linearization of each; it never enumerates a crowd's 10⁸ pairs.
///
/// # The candidate contract
/// [`candidates`](Self::candidates) must return every index `i` with `gᵢ(t, q) ≤ cutoff`
/// (it may return more). Everything else follows from it: the feasibility check of `q₀`, the
/// largest violation after a step, and — with [`linearization_drift_bound`](Self::linearization_drift_bound)
/// — the proof that culling loses nothing (see [`crate::stepper`]).
///
/// # Example
/// See [`KernelFamily`] for the family of an explicit list of kernel instances; a family of
/// one user constraint is `KernelFamily::single`.
pub trait ConstraintFamily: Send + Sync {
    /// Name of the family, for reports ("disk pairs", "walls", "user: ellipse"…).
    fn name(&self) -> &str;

    /// What the family keeps apart. Default [`FamilyKind::Other`].
    fn kind(&self) -> FamilyKind {
        FamilyKind::Other
    }

    /// Number of constraints in the family.
    fn count(&self) -> usize;

    /// Every member index is below this bound. Default [`count`](Self::count): members
    /// `0..count()`.
    fn member_bound(&self) -> usize {
        self.count()
    }

    /// Whether any member depends on `t`.
    fn is_time_dependent(&self) -> bool;

    /// Whether every member is affine in `q` (zero Hessian).
    fn is_affine(&self) -> bool;

    /// The curvature of every member in `q` (see [`Curvature`]). Default
    /// [`Curvature::Convex`]. A [`Curvature::Concave`] family is checked member by member
    /// after each solve (its culling, if any, cannot prove an omitted member satisfied).
    fn curvature(&self) -> Curvature {
        Curvature::Convex
    }

    /// A human-readable name of member `index`, for errors ("pair of people 3 and 17").
    fn describe(&self, index: usize) -> String;

    /// Pushes onto `out` every index whose value at `(t, q)` is `≤ cutoff` (and possibly
    /// more). The default pushes all `count()` indices `0..count()`.
    fn candidates(&self, t: f64, q: &[f64], cutoff: f64, out: &mut Vec<usize>) {
        let _ = (t, q, cutoff);
        out.extend(0..self.count());
    }

    /// Whether [`candidates`](Self::candidates) may omit members (then
    /// [`linearization_drift_bound`](Self::linearization_drift_bound) must be implemented).
    /// Default `false`.
    fn culls(&self) -> bool {
        false
    }

    /// An upper bound, over every member `i`, of `|⟨∇gᵢ(t, q), x − q⟩|`, computed without
    /// enumerating the members. A culling family must implement it; the stepper uses it to
    /// prove that no omitted member's linearized constraint is violated at the solution
    /// `x`. The default returns `0.0`, correct for families that never omit anything.
    fn linearization_drift_bound(&self, t: f64, q: &[f64], x: &[f64]) -> f64 {
        let _ = (t, q, x);
        0.0
    }

    /// `g`, `∇_q g` (and `∂ₜg` if `want_dt`) of member `index` at `(t, q)`, into `out`.
    fn linearize(&self, index: usize, t: f64, q: &[f64], want_dt: bool, out: &mut LinearizedRow);

    /// `gᵢ(t, q)` of member `index` alone (the check of the true constraints after each step
    /// needs nothing more). The default linearizes into `scratch` and keeps the value; the
    /// families built on a [`ConstraintKernel`] evaluate it on plain `f64`, the operations of
    /// the dual numbers' real parts, so the same number without the derivatives.
    fn value(&self, index: usize, t: f64, q: &[f64], scratch: &mut LinearizedRow) -> f64 {
        self.linearize(index, t, q, false, scratch);
        scratch.value
    }

    /// The second-order data of member `index` at `(t, q)` (A3, A4).
    fn second_order(&self, index: usize, t: f64, q: &[f64]) -> SecondOrderData;

    /// The largest coordinate index any member reads, plus one (checked against the
    /// problem's dimension before a run).
    fn min_dimension(&self) -> usize;

    /// The first member whose support reads a coordinate twice or one at or beyond `dim`, with
    /// that support: a row with a repeated column is not a valid sparse matrix for the
    /// backends. Default `None`: the family's rows are not known before they are assembled.
    fn invalid_support(&self, dim: usize) -> Option<(usize, Vec<usize>)> {
        let _ = dim;
        None
    }

    /// The margin `c` of assumption A0, where the family can derive it: the distance from
    /// every `Qᵢ(t) = {gᵢ ≥ 0}` to the set where `gᵢ` stops being twice differentiable (any
    /// smaller `c > 0` satisfies A0 with `Uᵢ(t)` the points within `c` of `Qᵢ(t)`; the
    /// A3/A4 bound `M` grows as `c` approaches it). Default `None`: not derivable.
    fn a0_margin(&self) -> Option<f64> {
        None
    }

    /// How far member `index`'s set travels during `(t0, t1)`, and the largest speed it
    /// reaches there, when its motion is not linear in that interval (a path that turns
    /// inside it): what the derivatives at the ends of a step cannot see. Default `None`:
    /// the motion is smooth, or the family does not know. `gᵢ` must be 1-Lipschitz in the
    /// set's position (a distance) for the stepper's use of it to be a bound.
    fn travel_within(&self, index: usize, t0: f64, t1: f64) -> Option<Travel> {
        let _ = (index, t0, t1);
        None
    }

    /// Pushes onto `out` the times strictly inside `(t0, t1)` at which some member's set
    /// turns (a path's waypoints), in increasing order per set: a step from `t0` to `t1` sees
    /// the set at its ends only, so the stepper checks the set's place at these times against
    /// the step's ends. Default: none (the family's motions are smooth).
    fn waypoints_within(&self, t0: f64, t1: f64, out: &mut Vec<f64>) {
        let _ = (t0, t1, out);
    }

    /// For a family that declares itself affine: `D²_q g` of member `index` at `(t, q)`
    /// (row-major on its support, as in [`SecondOrderData::hessian`]), computed although the
    /// family says it is zero, so that the checks can verify the claim once. Default `None`
    /// (the family cannot compute it; the claim is then trusted).
    fn affine_check(&self, index: usize, t: f64, q: &[f64]) -> Option<Vec<f64>> {
        let _ = (index, t, q);
        None
    }
}

/// One instance of a kernel: its support and parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct KernelInstance<P, const K: usize> {
    /// Coordinates of `q` read, in the order the kernel expects them.
    pub support: [usize; K],
    /// The instance's parameters.
    pub params: P,
    /// A name for errors and reports.
    pub label: String,
}

/// The family of an explicit list of instances of one [`ConstraintKernel`].
///
/// ```
/// use sweeping::prelude::*;
/// use sweeping::constraint::LinearizedRow;
///
/// /// x_a ≤ x_b − gap: an ordering constraint, affine and static.
/// struct Ordered;
/// impl ConstraintKernel<2> for Ordered {
///     type Params = f64;
///     fn value<D: Scalar>(&self, gap: &f64, _t: D, z: [D; 2]) -> D {
///         z[1] - z[0] - *gap
///     }
///     fn is_time_dependent(&self) -> bool { false }
///     fn is_affine(&self) -> bool { true }
/// }
///
/// let mut fam = KernelFamily::new("ordering", Ordered);
/// fam.push([0, 1], 0.5, "x0 before x1");
/// let mut row = LinearizedRow::default();
/// fam.linearize(0, 0.0, &[0.0, 2.0], false, &mut row);
/// assert_eq!(row.columns, vec![0, 1]);
/// assert!((row.value - 1.5).abs() < 1e-15);
/// assert_eq!(row.gradient, vec![-1.0, 1.0]);
/// ```
pub struct KernelFamily<C: ConstraintKernel<K>, const K: usize> {
    name: String,
    kernel: C,
    instances: Vec<KernelInstance<C::Params, K>>,
}

impl<C: ConstraintKernel<K>, const K: usize> KernelFamily<C, K> {
    /// An empty family of `kernel` instances.
    pub fn new(name: impl Into<String>, kernel: C) -> Self {
        Self {
            name: name.into(),
            kernel,
            instances: Vec::new(),
        }
    }

    /// Adds an instance reading `support` with `params`.
    pub fn push(&mut self, support: [usize; K], params: C::Params, label: impl Into<String>) {
        self.instances.push(KernelInstance {
            support,
            params,
            label: label.into(),
        });
    }

    /// The instances.
    pub fn instances(&self) -> &[KernelInstance<C::Params, K>] {
        &self.instances
    }

    /// The kernel.
    pub fn kernel(&self) -> &C {
        &self.kernel
    }

    fn gather(&self, index: usize, q: &[f64]) -> [f64; K] {
        let s = &self.instances[index].support;
        std::array::from_fn(|i| q[s[i]])
    }
}

impl<C: ConstraintKernel<K>, const K: usize> KernelFamily<C, K> {
    /// A family of one constraint reading `support`, with its parameters (for a kernel whose
    /// `Params` is `()`, [`single`](Self::single) says the same in fewer words).
    ///
    /// ```
    /// use sweeping::prelude::*;
    /// /// x ≥ wall: the wall's position is the parameter.
    /// struct RightOf;
    /// impl ConstraintKernel<1> for RightOf {
    ///     type Params = f64;
    ///     fn value<D: Scalar>(&self, wall: &f64, _t: D, z: [D; 1]) -> D { z[0] - *wall }
    ///     fn is_affine(&self) -> bool { true }
    /// }
    /// let problem = Problem::new(vec![1.0], NoPerturbation)
    ///     .with_family(KernelFamily::single_with("wall", RightOf, [0], 0.5));
    /// assert_eq!(problem.families()[0].count(), 1);
    /// ```
    pub fn single_with(
        name: impl Into<String>,
        kernel: C,
        support: [usize; K],
        params: C::Params,
    ) -> Self {
        let name = name.into();
        let mut f = Self::new(name.clone(), kernel);
        f.push(support, params, name);
        f
    }
}

impl<C: ConstraintKernel<K>, const K: usize> KernelFamily<C, K>
where
    C::Params: Default,
{
    /// A family of one constraint reading `support`, with default parameters (`()` for a
    /// kernel without any).
    pub fn single(name: impl Into<String>, kernel: C, support: [usize; K]) -> Self {
        Self::single_with(name, kernel, support, C::Params::default())
    }
}

impl<C: ConstraintKernel<K>, const K: usize> ConstraintFamily for KernelFamily<C, K> {
    fn name(&self) -> &str {
        &self.name
    }

    fn count(&self) -> usize {
        self.instances.len()
    }

    fn is_time_dependent(&self) -> bool {
        self.kernel.is_time_dependent()
    }

    fn is_affine(&self) -> bool {
        self.kernel.is_affine()
    }

    fn curvature(&self) -> Curvature {
        self.kernel.curvature()
    }

    fn describe(&self, index: usize) -> String {
        format!("{} #{index} ({})", self.name, self.instances[index].label)
    }

    fn linearize(&self, index: usize, t: f64, q: &[f64], want_dt: bool, out: &mut LinearizedRow) {
        let inst = &self.instances[index];
        let lin = linearize(
            &self.kernel,
            &inst.params,
            t,
            self.gather(index, q),
            want_dt,
        );
        out.value = lin.value;
        out.dt = lin.dt;
        out.columns.clear();
        out.columns.extend_from_slice(&inst.support);
        out.gradient.clear();
        out.gradient.extend_from_slice(&lin.gradient);
    }

    fn value(&self, index: usize, t: f64, q: &[f64], _: &mut LinearizedRow) -> f64 {
        let inst = &self.instances[index];
        self.kernel.value(&inst.params, t, self.gather(index, q))
    }

    fn second_order(&self, index: usize, t: f64, q: &[f64]) -> SecondOrderData {
        let inst = &self.instances[index];
        let so = second_order(&self.kernel, &inst.params, t, self.gather(index, q));
        so.on_columns(inst.support.to_vec())
    }

    fn affine_check(&self, index: usize, t: f64, q: &[f64]) -> Option<Vec<f64>> {
        let inst = &self.instances[index];
        let h = hessian_of(&self.kernel, &inst.params, t, self.gather(index, q));
        Some(h.iter().flatten().copied().collect())
    }

    fn min_dimension(&self) -> usize {
        self.instances
            .iter()
            .flat_map(|i| i.support.iter())
            .map(|c| c + 1)
            .max()
            .unwrap_or(0)
    }

    fn invalid_support(&self, dim: usize) -> Option<(usize, Vec<usize>)> {
        self.instances.iter().enumerate().find_map(|(m, inst)| {
            let s = &inst.support;
            let bad = s
                .iter()
                .enumerate()
                .any(|(i, c)| *c >= dim || s[..i].contains(c));
            bad.then(|| (m, s.to_vec()))
        })
    }
}
