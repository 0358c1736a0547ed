//! The order of convergence fitted to errors against step sizes, and when a fit is not to be
//! trusted (too few points, a poor line, errors at the round-off floor).

use super::sampling::max_of;
use super::StudyError;
use serde::{Deserialize, Serialize};

/// A least-squares fit `log e = log C + p log h`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OrderFit {
    /// The slope `p`: the fitted order.
    pub order: f64,
    /// `C` (the error the fit predicts at `h = 1`).
    pub constant: f64,
    /// Coefficient of determination of the fit in log–log coordinates (1 for an exact power
    /// law).
    pub r_squared: f64,
    /// Points used.
    pub points: usize,
    /// Why the slope is not to be read as an order of convergence, if it is not.
    #[serde(default)]
    pub caveat: Option<FitCaveat>,
}

/// Why a fitted slope cannot be trusted as an order of convergence.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
#[non_exhaustive]
pub enum FitCaveat {
    /// Fewer than two errors lie above the round-off floor: the slope is fitted to rounding.
    RoundOff {
        /// The largest round-off floor of the points ([`round_off_floor`]).
        floor: f64,
        /// The largest error.
        largest_error: f64,
    },
    /// Fewer than [`MIN_FIT_POINTS`] usable points: errors above the round-off floor, from
    /// runs with different step counts.
    TooFewPoints {
        /// Usable points.
        usable: usize,
    },
    /// Two step sizes take the same number of steps, so their runs are the same run.
    RepeatedSteps {
        /// The step count they share.
        steps: usize,
    },
    /// The points do not lie on a power law: `R²` is below [`MIN_R_SQUARED`].
    PoorFit {
        /// The fit's `R²`.
        r_squared: f64,
    },
}

impl std::fmt::Display for FitCaveat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::RoundOff {
                floor,
                largest_error,
            } => write!(
                f,
                "the errors are round-off (largest {largest_error:.2e}, floor {floor:.2e})"
            ),
            Self::TooFewPoints { usable } => write!(
                f,
                "{usable} usable point(s) above round-off, at least {MIN_FIT_POINTS} are needed"
            ),
            Self::RepeatedSteps { steps } => write!(
                f,
                "two step sizes both take {steps} step(s): their runs are the same run"
            ),
            Self::PoorFit { r_squared } => write!(
                f,
                "the errors do not follow a power law (R² = {r_squared:.3} < {MIN_R_SQUARED})"
            ),
        }
    }
}

/// Fewest usable points for a fitted order to be trusted: two points always fit exactly.
pub const MIN_FIT_POINTS: usize = 3;

/// Lowest `R²` of a trusted fit: below it the errors are not a power law of `h`.
pub const MIN_R_SQUARED: f64 = 0.9;

impl OrderFit {
    /// The error the fit predicts at `h`: `C h^p`.
    pub fn predict(&self, h: f64) -> f64 {
        self.constant * h.powf(self.order)
    }

    /// The order with its `R²` and points, or, when the fit has a caveat, the caveat in its
    /// place (the slope follows in parentheses, marked as no order).
    pub fn describe(&self) -> String {
        match self.caveat {
            None => format!(
                "{:.3} (R² = {:.3}, {} points)",
                self.order, self.r_squared, self.points
            ),
            Some(c) => format!(
                "no trustworthy order: {c} (slope {:.3} over {} points is not an order)",
                self.order, self.points
            ),
        }
    }
}

/// Least-squares slope of `log es` against `log hs`: the empirical order of convergence.
///
/// ```
/// use sweeping::study::fit_order;
/// let hs = [0.1, 0.05, 0.025];
/// let es: Vec<f64> = hs.iter().map(|h: &f64| 3.0 * h.sqrt()).collect();
/// let fit = fit_order(&hs, &es).unwrap();
/// assert!((fit.order - 0.5).abs() < 1e-12 && (fit.constant - 3.0).abs() < 1e-12);
/// ```
///
/// # Errors
/// [`StudyError::InvalidInput`] when the lengths differ, fewer than two points are given, a
/// value is not finite and positive, or all `h` are equal.
pub fn fit_order(hs: &[f64], es: &[f64]) -> Result<OrderFit, StudyError> {
    if hs.len() != es.len() {
        return Err(StudyError::InvalidInput(format!(
            "fit_order: {} step sizes but {} errors",
            hs.len(),
            es.len()
        )));
    }
    if hs.len() < 2 {
        return Err(StudyError::InvalidInput(format!(
            "fit_order needs at least two points, got {}",
            hs.len()
        )));
    }
    if let Some((h, e)) = hs
        .iter()
        .zip(es)
        .find(|(h, e)| !(h.is_finite() && **h > 0.0 && e.is_finite() && **e > 0.0))
    {
        return Err(StudyError::InvalidInput(format!(
            "fit_order needs finite positive values, got h = {h}, e = {e}"
        )));
    }
    let n = hs.len() as f64;
    let x: Vec<f64> = hs.iter().map(|h| h.ln()).collect();
    let y: Vec<f64> = es.iter().map(|e| e.ln()).collect();
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let syy: f64 = y.iter().map(|v| (v - my).powi(2)).sum();
    if sxx <= 1e-300 {
        return Err(StudyError::InvalidInput(
            "fit_order: all step sizes are equal, the slope is undefined".into(),
        ));
    }
    let order = sxy / sxx;
    let intercept = my - order * mx;
    let sse: f64 = x
        .iter()
        .zip(&y)
        .map(|(a, b)| (b - intercept - order * a).powi(2))
        .sum();
    let r_squared = if syy > 0.0 { 1.0 - sse / syy } else { 1.0 };
    Ok(OrderFit {
        order,
        constant: intercept.exp(),
        r_squared,
        points: hs.len(),
        caveat: None,
    })
}

/// The error below which a distance between two runs of `steps` steps in `dim` coordinates
/// of size up to `scale` measures rounding, not discretization: `10 √dim · steps · ε · scale`,
/// and at least [`ROUNDING_FLOOR`].
///
/// Each step rounds every coordinate by about `ε · scale`, and the rounding accumulates over
/// the steps; the factor 10 leaves room for projections that round more than once per step.
pub fn round_off_floor(steps: usize, dim: usize, scale: f64) -> f64 {
    let floor = 10.0 * (dim as f64).sqrt() * steps as f64 * f64::EPSILON * scale.abs();
    if floor.is_finite() {
        floor.max(ROUNDING_FLOOR)
    } else {
        ROUNDING_FLOOR
    }
}

/// [`fit_order`] over the usable points, with a [`FitCaveat`] when its slope cannot be
/// trusted; `None` when no slope can be fitted at all.
///
/// Point `i` has step `hs[i]`, error `es[i]`, step count `steps[i]` and round-off floor
/// `floors[i]`. It is usable when its error exceeds its floor and no earlier point has the
/// same step count. With fewer than two usable points, the slope is fitted over all positive
/// errors of distinct `h` and carries the reason ([`FitCaveat::RoundOff`] or
/// [`FitCaveat::RepeatedSteps`]); with fewer than [`MIN_FIT_POINTS`], or an `R²` below
/// [`MIN_R_SQUARED`], it carries that.
///
/// ```
/// use sweeping::study::{fit_order_checked, FitCaveat};
/// let hs = [0.1, 0.05, 0.025, 0.0125];
/// let es = [2e-11, 3e-12, 8e-11, 4e-12]; // round-off, under each run's floor
/// let fit = fit_order_checked(&hs, &es, &[100, 200, 400, 800], &[1e-10; 4]).unwrap();
/// assert!(matches!(fit.caveat, Some(FitCaveat::RoundOff { .. })));
/// ```
pub fn fit_order_checked(
    hs: &[f64],
    es: &[f64],
    steps: &[usize],
    floors: &[f64],
) -> Option<OrderFit> {
    let n = hs.len().min(es.len()).min(steps.len()).min(floors.len());
    let mut seen: Vec<usize> = Vec::new();
    let mut repeated = None;
    let (mut uh, mut ue) = (Vec::new(), Vec::new());
    for i in 0..n {
        if seen.contains(&steps[i]) {
            repeated = Some(steps[i]);
            continue;
        }
        seen.push(steps[i]);
        if es[i].is_finite() && es[i] > floors[i] {
            uh.push(hs[i]);
            ue.push(es[i]);
        }
    }
    if uh.len() >= 2 {
        let mut fit = fit_order(&uh, &ue).ok()?;
        fit.caveat = if let Some(steps) = repeated.filter(|_| uh.len() < MIN_FIT_POINTS) {
            Some(FitCaveat::RepeatedSteps { steps })
        } else if uh.len() < MIN_FIT_POINTS {
            Some(FitCaveat::TooFewPoints { usable: uh.len() })
        } else if fit.r_squared < MIN_R_SQUARED {
            Some(FitCaveat::PoorFit {
                r_squared: fit.r_squared,
            })
        } else {
            None
        };
        return Some(fit);
    }
    // Too few usable points: the slope of whatever there is, labelled with the reason.
    let (ah, ae): (Vec<f64>, Vec<f64>) = hs[..n]
        .iter()
        .zip(&es[..n])
        .filter(|(_, e)| e.is_finite() && **e > 0.0)
        .map(|(h, e)| (*h, *e))
        .unzip();
    let mut fit = fit_order(&ah, &ae).ok()?;
    fit.caveat = Some(match repeated {
        Some(steps) => FitCaveat::RepeatedSteps { steps },
        None => FitCaveat::RoundOff {
            floor: floors[..n].iter().copied().fold(0.0, f64::max),
            largest_error: max_of(&ae),
        },
    });
    Some(fit)
}

/// Errors at or below this are rounding, not discretization: [`fit_order_positive`] leaves
/// them out (the scheme can be exact at grid points, e.g. for disks on a line).
pub const ROUNDING_FLOOR: f64 = 1e-12;

/// [`fit_order`] over the points whose error exceeds [`ROUNDING_FLOOR`] (an error of zero —
/// a run that reproduces the reference — has no logarithm, and one of `1e-16` measures
/// rounding); `None` when fewer than two remain.
pub fn fit_order_positive(hs: &[f64], es: &[f64]) -> Option<OrderFit> {
    let (h, e): (Vec<f64>, Vec<f64>) = hs
        .iter()
        .zip(es)
        .filter(|(_, e)| e.is_finite() && **e > ROUNDING_FLOOR)
        .map(|(h, e)| (*h, *e))
        .unzip();
    fit_order(&h, &e).ok()
}
