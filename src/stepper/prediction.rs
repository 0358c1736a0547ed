//! The effects stage: the prediction `y = q_k + h f(t_k, q_k)`, or its average over the step
//! by Gauss–Legendre quadrature.

use super::Stepper;
use crate::error::SweepError;
use serde::{Deserialize, Serialize};

/// How the prediction uses `f`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Prediction {
    /// `y = q_k + h f(t_k, q_k)`: the paper's scheme as stated.
    #[default]
    Explicit,
    /// `y = q_k + ∫_{t_k}^{t_{k+1}} f(s, q_k) ds`, by Gauss–Legendre quadrature with the given
    /// number of points (1 to 5): the averaged `fⁿ` of the paper's remark.
    Averaged {
        /// Quadrature points (1–5).
        points: usize,
    },
}

impl Stepper<'_> {
    /// The prediction `y = q_k + h f(t_k, q_k)` (or its averaged form) into `self.y`, its
    /// displacement `y − q_k` into `self.dy`.
    pub(super) fn predict(&mut self, t_k: f64, h: f64) -> Result<(), SweepError> {
        let pert = self.problem.perturbation();
        match self.settings.prediction {
            Prediction::Averaged { points } if pert.is_time_dependent() => {
                let (nodes, weights) = gauss_legendre(points);
                self.dy.iter_mut().for_each(|d| *d = 0.0);
                for (s, w) in nodes.iter().zip(weights) {
                    let ts = t_k + 0.5 * h * (1.0 + s);
                    pert.eval(ts, &self.q, &mut self.f);
                    for (di, fi) in self.dy.iter_mut().zip(&self.f) {
                        *di += 0.5 * h * w * fi;
                    }
                }
            }
            _ => {
                pert.eval(t_k, &self.q, &mut self.f);
                for (di, fi) in self.dy.iter_mut().zip(&self.f) {
                    *di = h * fi;
                }
            }
        }
        for ((yi, qi), di) in self.y.iter_mut().zip(&self.q).zip(&self.dy) {
            *yi = qi + di;
        }
        if let Some(i) = self.y.iter().position(|v| !v.is_finite()) {
            return Err(SweepError::NonFinite {
                step: self.k,
                t: t_k,
                what: format!(
                    "the prediction q + h f(t, q) at coordinate {i} (f = {})",
                    self.f[i]
                ),
            });
        }
        Ok(())
    }
}

/// Gauss–Legendre nodes and weights on [−1, 1].
fn gauss_legendre(points: usize) -> (Vec<f64>, Vec<f64>) {
    match points {
        1 => (vec![0.0], vec![2.0]),
        2 => {
            let a = 1.0 / 3f64.sqrt();
            (vec![-a, a], vec![1.0, 1.0])
        }
        3 => {
            let a = (3.0f64 / 5.0).sqrt();
            (vec![-a, 0.0, a], vec![5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0])
        }
        4 => {
            let a = (3.0 / 7.0 - 2.0 / 7.0 * (6.0f64 / 5.0).sqrt()).sqrt();
            let b = (3.0 / 7.0 + 2.0 / 7.0 * (6.0f64 / 5.0).sqrt()).sqrt();
            let wa = (18.0 + 30f64.sqrt()) / 36.0;
            let wb = (18.0 - 30f64.sqrt()) / 36.0;
            (vec![-b, -a, a, b], vec![wb, wa, wa, wb])
        }
        _ => {
            let a = 1.0 / 3.0 * (5.0 - 2.0 * (10.0f64 / 7.0).sqrt()).sqrt();
            let b = 1.0 / 3.0 * (5.0 + 2.0 * (10.0f64 / 7.0).sqrt()).sqrt();
            let wa = (322.0 + 13.0 * 70f64.sqrt()) / 900.0;
            let wb = (322.0 - 13.0 * 70f64.sqrt()) / 900.0;
            (vec![-b, -a, 0.0, a, b], vec![wb, wa, 128.0 / 225.0, wa, wb])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::gauss_legendre;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in 1..=5 {
            let (x, w) = gauss_legendre(n);
            for p in 0..(2 * n) {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(p as i32)).sum();
                let exact = if p % 2 == 1 {
                    0.0
                } else {
                    2.0 / (p as f64 + 1.0)
                };
                assert!(
                    (q - exact).abs() < 1e-13,
                    "n = {n}, degree {p}: {q} vs {exact}"
                );
            }
        }
    }
}
