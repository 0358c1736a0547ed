use sweeping_api::{conformance::*, Projector, ProjectionProblem, SparseRows};
use sweeping_clarabel::*;

fn crowd(nx: usize, ny: usize, r: f64, spacing: f64, h: f64, offset: f64) -> ProjectionProblem {
    let mut q = vec![];
    for i in 0..nx { for j in 0..ny { q.push(offset + i as f64 * spacing); q.push(offset + j as f64 * spacing + 0.01 * ((i * 7 + j * 3) % 5) as f64); } }
    let n = q.len() / 2;
    let target = (offset + nx as f64 * spacing * 1.2, offset + ny as f64 * spacing * 0.5);
    let mut y = q.clone();
    for k in 0..n {
        let (dx, dy) = (target.0 - q[2 * k], target.1 - q[2 * k + 1]);
        let d = (dx * dx + dy * dy).sqrt();
        y[2 * k] += h * dx / d; y[2 * k + 1] += h * dy / d;
    }
    let mut a = SparseRows::new(2 * n);
    let mut b = vec![];
    for i in 0..n { for j in i + 1..n {
        let (dx, dy) = (q[2 * j] - q[2 * i], q[2 * j + 1] - q[2 * i + 1]);
        let d = (dx * dx + dy * dy).sqrt();
        if d < 2.0 * r + 2.0 * h { let (ex, ey) = (dx / d, dy / d);
            a.push_row([(2 * i, -ex), (2 * i + 1, -ey), (2 * j, ex), (2 * j + 1, ey)]);
            b.push(2.0 * r - d + ex * dx + ey * dy); }
    }}
    ProjectionProblem::new(y, a, b).unwrap()
}

#[test]
fn explore() {
    for tol in [1e-8, 1e-10, 1e-11, 1e-12] {
        let mut p = ClarabelProjector::new(ClarabelSettings { tol_gap_abs: tol, tol_gap_rel: tol, tol_feas: tol, ..Default::default() });
        let mut r = ReferenceProjector::default();
        for (nx, ny, h, off) in [(10, 6, 0.1, 0.0), (10, 6, 0.5, 100.0), (30, 20, 0.3, 250.0), (10,6,0.05,1000.0)] {
            let prob = crowd(nx, ny, 0.2, 0.41, h, off);
            match p.project(&prob) {
                Err(e) => println!("tol {tol:e} {nx}x{ny} h {h}: {e}"),
                Ok(s) => {
                    let k = prob.kkt_residuals(&s.x, &s.multipliers);
                    let g = r.project(&prob).map(|rs| s.x.iter().zip(&rs.x).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max)).unwrap_or(f64::NAN);
                    println!("tol {tol:e} {nx}x{ny} h {h} m {}: kkt {:.1e} ref {g:.1e} it {} active {} t {:.1e}", prob.n_rows(), k.max(), s.stats.iterations, s.active_count(1e-6), s.stats.solve_seconds);
                }
            }
        }
    }
    let mut p = ClarabelProjector::new(ClarabelSettings { tol_gap_abs: 1e-12, tol_gap_rel: 1e-12, tol_feas: 1e-12, ..Default::default() });
    for seed in 0..400u64 {
        let n = 2 + (seed as usize * 7) % 60;
        let m = (seed as usize * 13) % 90;
        let prob = random_instance(seed, n, m);
        if let Err(e) = p.project(&prob) { println!("1e-12 seed {seed}: {e}"); }
    }
}
