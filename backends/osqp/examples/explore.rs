use sweeping_api::conformance::{random_instance, ReferenceProjector};
use sweeping_api::Projector;
use sweeping_osqp::{OsqpProjector, OsqpSettings};

fn main() {
    let seeds = [197u64, 917, 1615, 659, 1387, 1710];
    let variants: Vec<(&str, OsqpSettings)> = vec![
        ("default", OsqpSettings::default()),
        ("inf1e-7", OsqpSettings { eps_prim_inf: 1e-7, ..Default::default() }),
        ("eps1e-8", OsqpSettings { eps_abs: 1e-8, eps_rel: 1e-8, eps_prim_inf: 1e-7, ..Default::default() }),
        ("polish", OsqpSettings { polish: true, eps_prim_inf: 1e-7, ..Default::default() }),
        ("noscale", OsqpSettings { scaling: 0, eps_prim_inf: 1e-7, ..Default::default() }),
        ("alpha1", OsqpSettings { alpha: 1.0, eps_prim_inf: 1e-7, ..Default::default() }),
        ("rho_iv25", OsqpSettings { adaptive_rho_interval: 25, eps_prim_inf: 1e-7, ..Default::default() }),
        ("sigma1e-3", OsqpSettings { sigma: 1e-3, eps_prim_inf: 1e-7, ..Default::default() }),
        ("1e6it", OsqpSettings { max_iter: 1_000_000, eps_prim_inf: 1e-7, ..Default::default() }),
    ];
    for seed in seeds {
        let n = 2 + (seed as usize * 11) % 40;
        let m = (seed as usize * 17) % 60;
        let p = random_instance(10_000 + seed, n, m);
        let r = ReferenceProjector::default().project(&p);
        println!("seed {seed} n {n} m {m}: reference {:?}", r.as_ref().map(|r| (r.stats.iterations, r.multipliers.iter().cloned().fold(0.0, f64::max))).map_err(|e| e.to_string()));
        for (name, s) in &variants {
            let res = OsqpProjector::new(s.clone()).project(&p);
            match res {
                Ok(a) => {
                    let g = r.as_ref().map(|r| a.x.iter().zip(&r.x).map(|(u, v)| (u - v).abs()).fold(0.0, f64::max)).unwrap_or(f64::NAN);
                    println!("   {name:10} ok it {} kkt {:.1e} gap {g:.1e} t {:.3}", a.stats.iterations, p.kkt_residuals(&a.x, &a.multipliers).max(), a.stats.solve_seconds)
                }
                Err(e) => println!("   {name:10} {e}"),
            }
        }
    }
}
