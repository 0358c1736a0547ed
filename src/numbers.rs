//! How numbers are written in messages and reports, the same way in every module.

/// A time or coordinate for messages: rounded to 1e-9 so that `t = k·h` prints as `3.78`, not
/// `3.7800000000000002`.
pub fn display_number(v: f64) -> String {
    if v.is_finite() {
        format!("{}", (v * 1e9).round() / 1e9)
    } else {
        format!("{v}")
    }
}
