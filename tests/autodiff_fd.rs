//! Every derivative the library computes by autodiff — `g`, `∇g`, `∂ₜg`, `D²g`, `∂ₜ∇g` —
//! against central finite differences, for every shipped constraint kernel and a user-style
//! one, both through the kernel helpers (`linearize`, `second_order`) and through the family
//! API (`ConstraintFamily::linearize`, `ConstraintFamily::second_order`, and
//! `ConstraintFamily::value`, which must give the linearization's value to the bit).
//!
//! First derivatives: central differences of the `f64` value with step `1e-6`, relative
//! tolerance `1e-5`. Second derivatives: central differences (step `1e-5`) of the autodiff
//! gradient, relative tolerance `1e-4`. Points are kept away from the non-smooth places
//! (zero distance, the switch between a segment's interior and its ends, a path's
//! breakpoints) by construction or `prop_assume`.

use num_dual::DualNum;
use proptest::prelude::*;
use std::sync::Arc;
use sweeping::constraint::{
    linearize, second_order, ConstraintFamily, ConstraintKernel, KernelFamily, LinearizedRow,
};
use sweeping::crowd::{
    DiskPairKernel, DiskPairs, Motion, PersonShapeKernel, PersonShapes, Population, Shape,
    ShapeParams,
};

const H1: f64 = 1e-6;
const TOL1: f64 = 1e-5;
const H2: f64 = 1e-5;
const TOL2: f64 = 1e-4;

/// A user-style kernel that is not a crowd: a point kept outside an ellipse that translates,
/// oscillates and rotates, `g(t, z) = √((u/a)² + (w/b)²) − 1` with `(u, w) = R(−ωt)(z − c(t))`,
/// `c(t) = c₀ + t v + (0, A sin t)`. Convex in `z` (a norm of an affine map, minus 1).
struct MovingEllipse;

#[derive(Debug, Clone)]
struct EllipseParams {
    axes: [f64; 2],
    c0: [f64; 2],
    v: [f64; 2],
    wobble: f64,
    omega: f64,
}

impl ConstraintKernel<2> for MovingEllipse {
    type Params = EllipseParams;
    fn value<D: DualNum<Primitive = f64> + Copy>(&self, p: &EllipseParams, t: D, z: [D; 2]) -> D {
        let cx = t * p.v[0] + p.c0[0];
        let cy = t * p.v[1] + t.sin() * p.wobble + p.c0[1];
        let dx = z[0] - cx;
        let dy = z[1] - cy;
        let (s, c) = ((t * p.omega).sin(), (t * p.omega).cos());
        let u = dx * c + dy * s;
        let w = dy * c - dx * s;
        let u = u * (1.0 / p.axes[0]);
        let w = w * (1.0 / p.axes[1]);
        (u * u + w * w).sqrt() - 1.0
    }
}

fn rel_close(ad: f64, fd: f64, tol: f64, scale: f64) -> bool {
    (ad - fd).abs() <= tol * scale.max(1.0).max(ad.abs())
}

/// Checks all derivatives of `kernel` at `(t, z)` against finite differences. `value64` is the
/// kernel evaluated on plain `f64`.
fn check_kernel<C: ConstraintKernel<K>, const K: usize>(
    kernel: &C,
    params: &C::Params,
    t: f64,
    z: [f64; K],
) -> Result<(), TestCaseError> {
    let val = |t: f64, z: [f64; K]| kernel.value::<f64>(params, t, z);
    let grad = |t: f64, z: [f64; K]| linearize(kernel, params, t, z, false).gradient;
    let lin = linearize(kernel, params, t, z, true);
    let so = second_order(kernel, params, t, z);
    let g0 = val(t, z);

    prop_assert!(
        (lin.value - g0).abs() <= 1e-12 * g0.abs().max(1.0),
        "value {} vs {}",
        lin.value,
        g0
    );
    prop_assert!((so.value - g0).abs() <= 1e-12 * g0.abs().max(1.0));
    prop_assert!(lin.dt.is_some());
    prop_assert!(linearize(kernel, params, t, z, false).dt.is_none());

    // ∇g and ∂ₜg: central differences of the value.
    for i in 0..K {
        let mut zp = z;
        let mut zm = z;
        zp[i] += H1;
        zm[i] -= H1;
        let fd = (val(t, zp) - val(t, zm)) / (2.0 * H1);
        prop_assert!(
            rel_close(lin.gradient[i], fd, TOL1, 1.0),
            "∂g/∂z{i}: ad {} fd {fd}",
            lin.gradient[i]
        );
        prop_assert!(
            (so.gradient[i] - lin.gradient[i]).abs() <= 1e-12 * lin.gradient[i].abs().max(1.0)
        );
    }
    let fd_dt = (val(t + H1, z) - val(t - H1, z)) / (2.0 * H1);
    let dt = lin.dt.unwrap_or(f64::NAN);
    prop_assert!(rel_close(dt, fd_dt, TOL1, 1.0), "∂ₜg: ad {dt} fd {fd_dt}");
    prop_assert!(
        rel_close(so.dt, fd_dt, TOL1, 1.0),
        "∂ₜg (second_order): ad {} fd {fd_dt}",
        so.dt
    );

    // D²g and ∂ₜ∇g: central differences of the autodiff gradient.
    let hscale = so
        .hessian
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    for j in 0..K {
        let mut zp = z;
        let mut zm = z;
        zp[j] += H2;
        zm[j] -= H2;
        let (gp, gm) = (grad(t, zp), grad(t, zm));
        for i in 0..K {
            let fd = (gp[i] - gm[i]) / (2.0 * H2);
            prop_assert!(
                rel_close(so.hessian[i][j], fd, TOL2, hscale),
                "∂²g/∂z{i}∂z{j}: ad {} fd {fd}",
                so.hessian[i][j]
            );
            prop_assert!((so.hessian[i][j] - so.hessian[j][i]).abs() <= 1e-12 * hscale.max(1.0));
        }
    }
    let (gp, gm) = (grad(t + H2, z), grad(t - H2, z));
    for i in 0..K {
        let fd = (gp[i] - gm[i]) / (2.0 * H2);
        prop_assert!(
            rel_close(so.dt_gradient[i], fd, TOL2, 1.0),
            "∂ₜ∂g/∂z{i}: ad {} fd {fd}",
            so.dt_gradient[i]
        );
    }
    Ok(())
}

/// The same checks through the object-safe family API, on the full configuration `q`: the
/// finite differences run over every coordinate of `q`, so coordinates outside a member's
/// columns must have zero derivative — this also checks the support mapping.
fn check_family(
    fam: &dyn ConstraintFamily,
    index: usize,
    t: f64,
    q: &[f64],
) -> Result<(), TestCaseError> {
    let n = q.len();
    let mut row = LinearizedRow::default();
    let mut val = |t: f64, q: &[f64]| {
        fam.linearize(index, t, q, false, &mut row);
        row.value
    };
    let dense_grad = |t: f64, q: &[f64]| {
        let mut r = LinearizedRow::default();
        fam.linearize(index, t, q, false, &mut r);
        let mut g = vec![0.0; q.len()];
        for (&c, &v) in r.columns.iter().zip(&r.gradient) {
            g[c] += v;
        }
        g
    };
    let g0 = val(t, q);
    let mut lin = LinearizedRow::default();
    fam.linearize(index, t, q, true, &mut lin);
    let so = fam.second_order(index, t, q);
    prop_assert_eq!(&so.columns, &lin.columns);
    // The value alone (the check of the true constraints) is the linearization's value, to
    // the bit: the same operations on plain floats as on the dual numbers' real parts.
    let alone = fam.value(index, t, q, &mut LinearizedRow::default());
    prop_assert_eq!(
        alone.to_bits(),
        g0.to_bits(),
        "value {} against {}",
        alone,
        g0
    );
    prop_assert!((so.value - g0).abs() <= 1e-12 * g0.abs().max(1.0));
    prop_assert!(lin.columns.iter().all(|&c| c < n) && fam.min_dimension() <= n);
    let g = dense_grad(t, q);

    let mut qp = q.to_vec();
    for c in 0..n {
        qp[c] = q[c] + H1;
        let up = val(t, &qp);
        qp[c] = q[c] - H1;
        let dn = val(t, &qp);
        qp[c] = q[c];
        let fd = (up - dn) / (2.0 * H1);
        prop_assert!(
            rel_close(g[c], fd, TOL1, 1.0),
            "{}: ∂g/∂q{c}: ad {} fd {fd}",
            fam.describe(index),
            g[c]
        );
    }
    let fd_dt = (val(t + H1, q) - val(t - H1, q)) / (2.0 * H1);
    let dt = lin.dt.unwrap_or(f64::NAN);
    prop_assert!(
        rel_close(dt, fd_dt, TOL1, 1.0),
        "{}: ∂ₜg: ad {dt} fd {fd_dt}",
        fam.describe(index)
    );
    prop_assert!(rel_close(so.dt, fd_dt, TOL1, 1.0));

    let k = so.columns.len();
    prop_assert_eq!(so.hessian.len(), k * k);
    let hscale = so.hessian.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (b, &cb) in so.columns.iter().enumerate() {
        qp[cb] = q[cb] + H2;
        let gp = dense_grad(t, &qp);
        qp[cb] = q[cb] - H2;
        let gm = dense_grad(t, &qp);
        qp[cb] = q[cb];
        for (a, &ca) in so.columns.iter().enumerate() {
            let fd = (gp[ca] - gm[ca]) / (2.0 * H2);
            prop_assert!(
                rel_close(so.hessian[a * k + b], fd, TOL2, hscale),
                "D²g[{ca}][{cb}]: ad {} fd {fd}",
                so.hessian[a * k + b]
            );
        }
    }
    let (gp, gm) = (dense_grad(t + H2, q), dense_grad(t - H2, q));
    for (a, &ca) in so.columns.iter().enumerate() {
        let fd = (gp[ca] - gm[ca]) / (2.0 * H2);
        prop_assert!(
            rel_close(so.dt_gradient[a], fd, TOL2, 1.0),
            "∂ₜ∇g[{ca}]: ad {} fd {fd}",
            so.dt_gradient[a]
        );
    }
    Ok(())
}

fn point() -> impl Strategy<Value = [f64; 2]> {
    [-3.0..3.0f64, -3.0..3.0f64]
}

/// Static, a constant velocity, or a path of 2–4 waypoints at increasing times.
fn motion() -> impl Strategy<Value = Motion> {
    prop_oneof![
        Just(Motion::Static),
        [-1.5..1.5f64, -1.5..1.5f64].prop_map(Motion::Velocity),
        (
            0.0..0.8f64,
            prop::collection::vec((0.3..1.2f64, [-2.0..2.0f64, -2.0..2.0f64]), 2..=4)
        )
            .prop_map(|(t0, legs)| {
                let mut t = t0;
                Motion::Path(
                    legs.into_iter()
                        .map(|(dt, o)| {
                            let w = (t, o);
                            t += dt;
                            w
                        })
                        .collect(),
                )
            }),
    ]
}

/// Distance from `t` to the nearest breakpoint of a path (infinite for other motions).
fn breakpoint_distance(m: &Motion, t: f64) -> f64 {
    match m {
        Motion::Path(p) => p
            .iter()
            .map(|(s, _)| (s - t).abs())
            .fold(f64::INFINITY, f64::min),
        _ => f64::INFINITY,
    }
}

fn offset(m: &Motion, t: f64) -> [f64; 2] {
    m.offset::<f64>(t)
}

fn unit(phi: f64) -> [f64; 2] {
    [phi.cos(), phi.sin()]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn disk_pair_kernel(zi in point(), zj in point(), r in 0.05..1.0f64, t in -2.0..2.0f64) {
        let d = ((zi[0] - zj[0]).powi(2) + (zi[1] - zj[1]).powi(2)).sqrt();
        prop_assume!(d > 0.2);
        let z = [zi[0], zi[1], zj[0], zj[1]];
        check_kernel(&DiskPairKernel, &r, t, z)?;
        // Static: ∂ₜ vanishes identically, and the helpers say so.
        let so = second_order(&DiskPairKernel, &r, t, z);
        prop_assert!(so.dt.abs() < 1e-300 && so.dt_gradient.iter().all(|v| v.abs() < 1e-300));
    }

    /// A person against a segment, closest point in the interior of the segment.
    #[test]
    fn segment_interior(
        a in point(), len in 0.5..3.0f64, phi in 0.0..std::f64::consts::TAU,
        s in 0.02..0.98f64, side in prop_oneof![-2.0..-0.2f64, 0.2..2.0f64],
        m in motion(), t in 0.0..4.0f64, r in 0.0..0.5f64,
    ) {
        prop_assume!(breakpoint_distance(&m, t) > 1e-3);
        let u = unit(phi);
        let b = [a[0] + len * u[0], a[1] + len * u[1]];
        let o = offset(&m, t);
        let z = [a[0] + o[0] + s * len * u[0] - side * u[1], a[1] + o[1] + s * len * u[1] + side * u[0]];
        let p = ShapeParams { shape: Shape::Segment { a, b }, motion: m, person_radius: r };
        let g = PersonShapeKernel.value::<f64>(&p, t, z);
        prop_assert!((g - (side.abs() - r)).abs() < 1e-9, "value {g} vs distance {}", side.abs() - r);
        check_kernel(&PersonShapeKernel, &p, t, z)?;
    }

    /// A person against a segment, closest point at one end.
    #[test]
    fn segment_end(
        a in point(), len in 0.5..3.0f64, phi in 0.0..std::f64::consts::TAU,
        rho in 0.2..2.0f64, beta in -1.3..1.3f64, at_b in any::<bool>(),
        m in motion(), t in 0.0..4.0f64, r in 0.0..0.5f64,
    ) {
        prop_assume!(breakpoint_distance(&m, t) > 1e-3);
        let u = unit(phi);
        let b = [a[0] + len * u[0], a[1] + len * u[1]];
        let o = offset(&m, t);
        // Beyond the end: direction making an angle beta < 90° with the outward axis.
        let (end, out) = if at_b { (b, phi) } else { (a, phi + std::f64::consts::PI) };
        let dir = unit(out + beta);
        let z = [end[0] + o[0] + rho * dir[0], end[1] + o[1] + rho * dir[1]];
        let p = ShapeParams { shape: Shape::Segment { a, b }, motion: m, person_radius: r };
        let g = PersonShapeKernel.value::<f64>(&p, t, z);
        prop_assert!((g - (rho - r)).abs() < 1e-9);
        check_kernel(&PersonShapeKernel, &p, t, z)?;
    }

    #[test]
    fn disk_obstacle(
        c in point(), radius in 0.1..1.5f64, z in point(), m in motion(),
        t in 0.0..4.0f64, r in 0.0..0.5f64,
    ) {
        prop_assume!(breakpoint_distance(&m, t) > 1e-3);
        let o = offset(&m, t);
        let d = ((z[0] - c[0] - o[0]).powi(2) + (z[1] - c[1] - o[1]).powi(2)).sqrt();
        prop_assume!(d > 0.2);
        let p = ShapeParams { shape: Shape::Disk { center: c, radius }, motion: m, person_radius: r };
        check_kernel(&PersonShapeKernel, &p, t, z)?;
    }

    #[test]
    fn user_moving_ellipse(
        ax in 0.3..2.0f64, bx in 0.3..2.0f64, c0 in point(), v in [-1.0..1.0f64, -1.0..1.0f64],
        wobble in -0.5..0.5f64, omega in -2.0..2.0f64, z in point(), t in -3.0..3.0f64,
    ) {
        let p = EllipseParams { axes: [ax, bx], c0, v, wobble, omega };
        let g = MovingEllipse.value::<f64>(&p, t, z);
        // Away from the centre, where the norm is not differentiable.
        prop_assume!(g > -0.8);
        check_kernel(&MovingEllipse, &p, t, z)?;
    }

    /// The family API: a user kernel family on a permuted support, the crowd's pairs, and the
    /// crowd's walls and obstacles, on a configuration of several people.
    #[test]
    fn families(
        q in prop::collection::vec(-4.0..4.0f64, 6),
        radii in prop::collection::vec(0.05..0.4f64, 3),
        m in motion(), t in 0.0..4.0f64,
        omega in -2.0..2.0f64, v in [-1.0..1.0f64, -1.0..1.0f64],
    ) {
        prop_assume!(breakpoint_distance(&m, t) > 1e-3);

        // User family: one ellipse reading (q5, q1) of a 6-dimensional q; another reading (q0, q3).
        let p = EllipseParams { axes: [0.8, 0.4], c0: [0.5, -0.5], v, wobble: 0.3, omega };
        let mut fam = KernelFamily::new("ellipses", MovingEllipse);
        fam.push([5, 1], p.clone(), "first");
        fam.push([0, 3], p, "second");
        for i in 0..fam.count() {
            let mut row = LinearizedRow::default();
            fam.linearize(i, t, &q, false, &mut row);
            if row.value > -0.8 {
                check_family(&fam, i, t, &q)?;
            }
        }

        let pop = Population::new(radii).shared();
        let pairs = DiskPairs::new(Arc::clone(&pop));
        for (i, j) in [(0, 1), (0, 2), (1, 2)] {
            let d = ((q[2 * i] - q[2 * j]).powi(2) + (q[2 * i + 1] - q[2 * j + 1]).powi(2)).sqrt();
            if d > 0.2 {
                check_family(&pairs, i * 3 + j, t, &q)?;
            }
        }

        let shapes = PersonShapes::new(
            "walls",
            Arc::clone(&pop),
            vec![
                (Shape::Segment { a: [-1.0, -1.0], b: [1.5, 0.5] }, m.clone()),
                (Shape::Disk { center: [0.5, 1.0], radius: 0.6 }, m.clone()),
                (Shape::Segment { a: [2.0, -3.0], b: [2.0, 3.0] }, Motion::Static),
            ],
        );
        for person in 0..3 {
            for s in 0..3 {
                let z = [q[2 * person], q[2 * person + 1]];
                if smooth_against(&shapes.shapes()[s], t, z) {
                    check_family(&shapes, person * 3 + s, t, &q)?;
                }
            }
        }
    }
}

/// Whether a point is at a smooth place of its distance to a shape: not within 0.2 of it, and
/// (segments) not within 1e-3 of the interior/end switch.
fn smooth_against(shape: &(Shape, Motion), t: f64, z: [f64; 2]) -> bool {
    let o = offset(&shape.1, t);
    match &shape.0 {
        Shape::Disk { center, radius } => {
            ((z[0] - center[0] - o[0]).powi(2) + (z[1] - center[1] - o[1]).powi(2)).sqrt()
                > radius + 0.2
        }
        Shape::Segment { a, b } => {
            let p = [z[0] - o[0] - a[0], z[1] - o[1] - a[1]];
            let ab = [b[0] - a[0], b[1] - a[1]];
            let len2 = ab[0] * ab[0] + ab[1] * ab[1];
            let s = (p[0] * ab[0] + p[1] * ab[1]) / len2;
            let sc = s.clamp(0.0, 1.0);
            let d = ((p[0] - sc * ab[0]).powi(2) + (p[1] - sc * ab[1]).powi(2)).sqrt();
            d > 0.2 && s.abs() > 1e-3 && (s - 1.0).abs() > 1e-3
        }
    }
}

/// Time-independent and affine kernels skip derivatives and say so.
#[test]
fn static_and_affine_kernels_report_zeros() {
    struct Plane;
    impl ConstraintKernel<2> for Plane {
        type Params = ();
        fn value<D: DualNum<Primitive = f64> + Copy>(&self, _: &(), _t: D, z: [D; 2]) -> D {
            z[0] * 3.0 - z[1] * 4.0 + 1.0
        }
        fn is_time_dependent(&self) -> bool {
            false
        }
        fn is_affine(&self) -> bool {
            true
        }
    }
    let lin = linearize(&Plane, &(), 1.0, [0.5, 0.25], true);
    assert!((lin.value - 1.5).abs() < 1e-15);
    assert!((lin.gradient[0] - 3.0).abs() < 1e-15 && (lin.gradient[1] + 4.0).abs() < 1e-15);
    assert_eq!(lin.dt, Some(0.0));
    let so = second_order(&Plane, &(), 1.0, [0.5, 0.25]);
    assert!(so.hessian.iter().flatten().all(|v| v.abs() < 1e-300));
    assert!(so.dt.abs() < 1e-300);
}
