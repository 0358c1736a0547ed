use sweeping_api::{conformance::*, Projector, ProjectionProblem};
use sweeping_clarabel::*;

#[test]
fn explore() {
    for tol in [1e-8, 1e-9, 1e-10, 1e-11, 1e-12] {
        let mut p = ClarabelProjector::new(ClarabelSettings { tol_gap_abs: tol, tol_gap_rel: tol, tol_feas: tol, ..Default::default() });
        let mut r = ReferenceProjector::default();
        let (mut worst, mut refgap, mut idem, mut iters, mut maxit, mut errs, mut viol) = ([0.0f64; 4], 0.0f64, 0.0f64, 0u32, 0u32, 0, 0.0f64);
        for seed in 0..400u64 {
            let n = 2 + (seed as usize * 7) % 60;
            let m = (seed as usize * 13) % 90;
            let prob = random_instance(seed, n, m);
            let s = match p.project(&prob) { Ok(s) => s, Err(e) => { errs += 1; println!("{e}"); continue } };
            let k = prob.kkt_residuals(&s.x, &s.multipliers);
            worst[0] = worst[0].max(k.primal); worst[1] = worst[1].max(k.stationarity); worst[2] = worst[2].max(k.dual); worst[3] = worst[3].max(k.complementarity);
            iters += s.stats.iterations; maxit = maxit.max(s.stats.iterations);
            viol = viol.max(prob.max_violation(&s.x));
            if let Ok(rs) = r.project(&prob) {
                let g = s.x.iter().zip(&rs.x).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                refgap = refgap.max(g);
            }
            let again = ProjectionProblem::new(s.x.clone(), prob.a().clone(), prob.b().to_vec()).unwrap();
            let s2 = p.project(&again).unwrap();
            let g = s2.x.iter().zip(&s.x).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            idem = idem.max(g);
        }
        println!("tol {tol:e}: worst kkt p/s/d/c {worst:?}, ref {refgap:.1e}, idem {idem:.1e}, viol {viol:.1e} iters total {iters} max {maxit}, errs {errs}");
    }
}
