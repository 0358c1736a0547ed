//! Serde helpers: `f64` values that may be infinite (`γ = ∞`, `η = ∞`) are written as the
//! string `"inf"` (JSON has no infinity), and read back.

use serde::{Deserialize, Deserializer, Serializer};

#[derive(Deserialize)]
#[serde(untagged)]
enum NumOrText {
    Num(f64),
    Text(String),
}

fn from_repr<E: serde::de::Error>(r: NumOrText) -> Result<f64, E> {
    match r {
        NumOrText::Num(v) => Ok(v),
        NumOrText::Text(s) => match s.as_str() {
            "inf" | "+inf" | "∞" => Ok(f64::INFINITY),
            "-inf" => Ok(f64::NEG_INFINITY),
            other => Err(E::custom(format!(
                "expected a number or \"inf\", got \"{other}\""
            ))),
        },
    }
}

fn write<S: Serializer>(v: f64, s: S) -> Result<S::Ok, S::Error> {
    if v.is_infinite() {
        s.serialize_str(if v > 0.0 { "inf" } else { "-inf" })
    } else {
        s.serialize_f64(v)
    }
}

/// For `f64` fields.
pub mod ext_f64 {
    use super::*;

    /// Writes infinities as `"inf"` / `"-inf"`.
    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        write(*v, s)
    }

    /// Reads a number or `"inf"` / `"-inf"`.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        from_repr(NumOrText::deserialize(d)?)
    }
}

/// For `Option<f64>` fields (`None` is `null`).
pub mod ext_opt {
    use super::*;

    /// Writes `None` as `null`, infinities as `"inf"` / `"-inf"`.
    pub fn serialize<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            None => s.serialize_none(),
            Some(x) => write(*x, s),
        }
    }

    /// Reads `null`, a number, or `"inf"` / `"-inf"`.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
        match Option::<NumOrText>::deserialize(d)? {
            None => Ok(None),
            Some(r) => from_repr(r).map(Some),
        }
    }
}
