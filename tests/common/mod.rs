//! Helpers shared by the integration tests.
#![allow(dead_code)]

use sweeping::api::Projector;
use sweeping::backends::{make_projector, BackendChoice};

/// The real backends compiled in (Clarabel, OSQP, their cross-check, native and its
/// cross-check with Clarabel), each freshly built;
/// the ones whose cargo feature is off are skipped (and named on stderr).
pub fn real_backends() -> Vec<(BackendChoice, Box<dyn Projector>)> {
    let mut out = Vec::new();
    for c in [
        BackendChoice::Clarabel,
        BackendChoice::Osqp,
        BackendChoice::Cross,
        BackendChoice::Native,
        BackendChoice::CrossNative,
    ] {
        match make_projector(c) {
            Ok(p) => out.push((c, p)),
            Err(why) => eprintln!("skipping backend {c}: {why}"),
        }
    }
    out
}

/// Least-squares slope of `log e` against `log h`.
pub fn fitted_order(hs: &[f64], errs: &[f64]) -> f64 {
    let xs: Vec<f64> = hs.iter().map(|h| h.ln()).collect();
    let ys: Vec<f64> = errs.iter().map(|e| e.ln()).collect();
    let n = xs.len() as f64;
    let mx = xs.iter().sum::<f64>() / n;
    let my = ys.iter().sum::<f64>() / n;
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    sxy / sxx
}

/// `h₀, h₀/2, …` (`levels` values).
pub fn halvings(h0: f64, levels: usize) -> Vec<f64> {
    (0..levels).map(|i| h0 / f64::powi(2.0, i as i32)).collect()
}

/// `[1.234e-3, …]`.
pub fn sci(values: &[f64]) -> String {
    let v: Vec<String> = values.iter().map(|e| format!("{e:.3e}")).collect();
    format!("[{}]", v.join(", "))
}

pub mod checker;
