//! Numbers given per crowd as a value or a distribution (`speed`, `pre_movement`, `radius`):
//! checked,
//! then drawn person by person from a stream of the crowd's seed of their own, so that the
//! placement of a crowd does not change when a distribution is added to it.

use super::spec::{Distribution, Drawn};
use super::{Ctx, SceneError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Draws of a truncated normal that may fall outside its window before the window is called
/// too far in the tail to draw from.
const MAX_REJECTIONS: usize = 100_000;

/// What a drawn quantity is, for errors: its key and its least allowed value (itself
/// allowed unless `strict`).
pub(super) struct Quantity {
    pub key: &'static str,
    pub least: f64,
    pub strict: bool,
}

impl Quantity {
    fn allows(&self, v: f64) -> bool {
        v.is_finite() && (v > self.least || (!self.strict && v == self.least))
    }

    /// `≥ 0` or `> 0`, for messages.
    fn bound(&self) -> String {
        format!("{} {}", if self.strict { ">" } else { "≥" }, self.least)
    }

    /// `0 ≤ min ≤ max` or `0 < min ≤ max`, for messages.
    fn window(&self) -> String {
        format!(
            "{} {} min ≤ max",
            self.least,
            if self.strict { "<" } else { "≤" }
        )
    }
}

/// The desired speed: at least 0.
pub(super) const SPEED: Quantity = Quantity {
    key: "speed",
    least: 0.0,
    strict: false,
};

/// The time before a person starts walking: at least 0.
pub(super) const PRE_MOVEMENT: Quantity = Quantity {
    key: "pre_movement",
    least: 0.0,
    strict: false,
};

/// A person's radius: positive.
pub(super) const RADIUS: Quantity = Quantity {
    key: "radius",
    least: 0.0,
    strict: true,
};

/// Draws of a crowd's radii: a stream of its own (1 and 2 are the speeds' and the
/// pre-movement times').
pub(super) const RADIUS_STREAM: u64 = 3;

/// The checked form of a [`Drawn`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Checked {
    Fixed(f64),
    Uniform(f64, f64),
    Normal {
        mean: f64,
        sd: f64,
        min: f64,
        max: f64,
    },
}

/// Checks `drawn` for `quantity`, or `default` when absent.
pub(super) fn check(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    quantity: &Quantity,
    drawn: Option<&Drawn>,
    default: f64,
) -> Result<Checked, SceneError> {
    let key = quantity.key;
    let err = |m: String| Err(cx.err(line, item.to_string(), format!("{key}: {m}")));
    let allowed = |v: f64| quantity.allows(v);
    match drawn {
        None => Ok(Checked::Fixed(default)),
        Some(Drawn::Fixed(v)) if allowed(*v) => Ok(Checked::Fixed(*v)),
        Some(Drawn::Fixed(v)) => err(format!("must be {} and finite, got {v}", quantity.bound())),
        Some(Drawn::Distribution(d)) => match *d {
            Distribution {
                uniform: Some([a, b]),
                normal: None,
                within: None,
            } => {
                if allowed(a) && allowed(b) && a <= b {
                    Ok(Checked::Uniform(a, b))
                } else {
                    err(format!(
                        "uniform = [min, max] needs {}, both finite, got [{a}, {b}]",
                        quantity.window()
                    ))
                }
            }
            Distribution {
                uniform: None,
                normal: Some([mean, sd]),
                within: Some([min, max]),
            } => {
                if !(mean.is_finite() && sd.is_finite() && sd >= 0.0) {
                    err(format!(
                        "normal = [mean, sd] needs a finite mean and a finite sd ≥ 0, got [{mean}, {sd}]"
                    ))
                } else if !(allowed(min) && allowed(max) && min <= max) {
                    err(format!(
                        "within = [min, max] needs {}, both finite, got [{min}, {max}]",
                        quantity.window()
                    ))
                } else {
                    Ok(Checked::Normal { mean, sd, min, max })
                }
            }
            Distribution {
                uniform: None,
                normal: Some(_),
                within: None,
            } => err(
                "a normal distribution needs `within = [min, max]`, the values it is cut to \
                 (a normal reaches any value, and this one must stay finite and within its bounds)"
                    .to_string(),
            ),
            _ => err(
                "give exactly one of `uniform = [min, max]` or `normal = [mean, sd]` with \
                 `within = [min, max]`"
                    .to_string(),
            ),
        },
    }
}

/// A source of draws for one crowd and one quantity: the crowd's seed, a stream of its own.
pub(super) fn source(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

/// The least and the largest value `checked` can draw.
pub(super) fn range(checked: Checked) -> (f64, f64) {
    match checked {
        Checked::Fixed(v) => (v, v),
        Checked::Uniform(a, b) | Checked::Normal { min: a, max: b, .. } => (a, b),
    }
}

/// `count` values of `checked`, or an error when a truncated normal's window lies too far in
/// its tail to draw from.
pub(super) fn draw(
    cx: &Ctx<'_>,
    line: Option<usize>,
    item: &str,
    quantity: &Quantity,
    checked: Checked,
    count: usize,
    rng: &mut ChaCha8Rng,
) -> Result<Vec<f64>, SceneError> {
    (0..count)
        .map(|_| match checked {
            Checked::Fixed(v) => Ok(v),
            Checked::Uniform(a, b) => Ok(rng.gen_range(a..=b)),
            Checked::Normal { mean, sd, min, max } => (0..MAX_REJECTIONS)
                .map(|_| mean + sd * standard_normal(rng))
                .find(|v| (min..=max).contains(v))
                .ok_or_else(|| {
                    cx.err(
                        line,
                        item.to_string(),
                        format!(
                            "{}: no value of normal = [{mean}, {sd}] fell within [{min}, {max}] \
                             in {MAX_REJECTIONS} draws: the window lies too far in the tail",
                            quantity.key
                        ),
                    )
                }),
        })
        .collect()
}

/// A standard normal number by the Box–Muller transform (one formula: no crate for it).
fn standard_normal(rng: &mut ChaCha8Rng) -> f64 {
    // 1 − u lies in (0, 1], so its logarithm is finite.
    let u: f64 = 1.0 - rng.gen::<f64>();
    let v: f64 = rng.gen();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mean and standard deviation of `v`.
    fn moments(v: &[f64]) -> (f64, f64) {
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
        (mean, var.sqrt())
    }

    #[test]
    fn the_standard_normal_has_mean_0_and_deviation_1() {
        let mut rng = source(11, 1);
        let v: Vec<f64> = (0..40_000).map(|_| standard_normal(&mut rng)).collect();
        let (mean, sd) = moments(&v);
        assert!(mean.abs() < 0.02, "mean {mean}");
        assert!((sd - 1.0).abs() < 0.02, "sd {sd}");
        // Symmetric, with tails: about 4.6 % beyond two deviations.
        let beyond = v.iter().filter(|x| x.abs() > 2.0).count() as f64 / v.len() as f64;
        assert!((beyond - 0.0455).abs() < 0.006, "beyond 2: {beyond}");
    }

    #[test]
    fn draws_have_the_moments_of_their_distribution_and_stay_in_their_window() {
        let cx = Ctx::new("test.toml", None);
        let mut rng = source(3, 2);
        let normal = Checked::Normal {
            mean: 10.0,
            sd: 1.0,
            min: 0.0,
            max: 20.0,
        };
        let v = draw(&cx, None, "crowd", &SPEED, normal, 20_000, &mut rng).unwrap();
        let (mean, sd) = moments(&v);
        assert!(
            (mean - 10.0).abs() < 0.03 && (sd - 1.0).abs() < 0.03,
            "{mean} {sd}"
        );
        let cut = Checked::Normal {
            mean: 1.0,
            sd: 1.0,
            min: 0.8,
            max: 1.2,
        };
        let v = draw(&cx, None, "crowd", &SPEED, cut, 2_000, &mut rng).unwrap();
        assert!(v.iter().all(|x| (0.8..=1.2).contains(x)));
        let v = draw(
            &cx,
            None,
            "crowd",
            &SPEED,
            Checked::Uniform(2.0, 3.0),
            20_000,
            &mut rng,
        )
        .unwrap();
        let (mean, sd) = moments(&v);
        assert!(v.iter().all(|x| (2.0..=3.0).contains(x)));
        // Uniform on [2, 3]: mean 2.5, deviation 1/√12.
        assert!((mean - 2.5).abs() < 0.01 && (sd - 12f64.sqrt().recip()).abs() < 0.01);
        let v = draw(
            &cx,
            None,
            "crowd",
            &SPEED,
            Checked::Uniform(1.5, 1.5),
            3,
            &mut rng,
        )
        .unwrap();
        assert_eq!(v, vec![1.5; 3]);
    }
}
