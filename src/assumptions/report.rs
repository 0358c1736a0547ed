//! What [`estimate_problem`](super::estimate_problem) measured: the constants of A0–A5 with
//! their witnesses, the paper's derived constants, and how they are told.

use super::serde_ext;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

/// Where an extreme was seen: the sample, its time, the constraint(s), and the value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Witness {
    /// The value (may be `+∞` for `γ`; written `"inf"` in JSON).
    #[serde(with = "serde_ext::ext_f64")]
    pub value: f64,
    /// Time of the sample.
    pub t: f64,
    /// Index of the sample in the list given.
    pub sample: usize,
    /// The constraint (for `γ`: the constraints of the group).
    pub constraint: String,
}

/// The measured constants, the derived ones, and the failed assumptions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AssumptionReport {
    /// Samples evaluated.
    pub samples: usize,
    /// Constraint evaluations that contributed (sample × near-active constraint).
    pub evaluations: usize,
    /// `ρ` used for A5.
    pub rho: f64,
    /// The neighbourhood of activity sampled.
    pub neighbourhood: f64,
    /// A1: smallest `|∇gᵢ|`.
    pub alpha: Option<Witness>,
    /// A1: largest `|∇gᵢ|`.
    pub beta_grad: Option<Witness>,
    /// A2: largest `|∂ₜgᵢ|` (0 for static constraints).
    pub beta_dt: Option<Witness>,
    /// A4: largest spectral norm of `D²_q gᵢ`.
    pub m_hess: Option<Witness>,
    /// A3: largest Euclidean norm of `∂ₜ∇_q gᵢ`.
    pub m_dt_grad: Option<Witness>,
    /// A5 at `ρ`: largest `γ` over the samples (`None`: no constraint within `ρ` anywhere, A5
    /// holds with `γ = 1`).
    pub gamma: Option<Witness>,
    /// A5': largest `γ` over the active sets.
    pub gamma_prime: Option<Witness>,
    /// Largest `γₖ` of one coordinate group at `ρ` (the local `γ`; the global one combines
    /// the groups as `γ² = Σγₖ²`).
    pub gamma_group: Option<Witness>,
    /// The paper's `β = max(β of A1, β of A2)`.
    #[serde(with = "serde_ext::ext_opt")]
    pub beta: Option<f64>,
    /// The paper's `M = max(M of A3, M of A4)`.
    #[serde(with = "serde_ext::ext_opt")]
    pub m: Option<f64>,
    /// §2: the smallest eigenvalue of `D²gᵢ` over the samples (negative: some `gᵢ` is not
    /// convex in `q`, see [`Self::convexity_failed`]); `None` when only affine constraints
    /// were sampled.
    #[serde(default)]
    pub min_curvature: Option<Witness>,
    /// Whether some `gᵢ` was found not convex in `q` (or an affine or concave claim false): `η`, `Θ`
    /// and `r` are then not claimed (`None`).
    #[serde(default)]
    pub convexity_failed: bool,
    /// A0's margin `c` (a supremum: any smaller positive `c` works), when every family
    /// derives it; `∞` when every family is affine (smooth everywhere).
    #[serde(with = "serde_ext::ext_opt")]
    pub c: Option<f64>,
    /// `η = α/(Mγ')` (Prop 2.2); `∞` when `M = 0`.
    #[serde(with = "serde_ext::ext_opt")]
    pub eta: Option<f64>,
    /// `Θ = 2γβ/α` (Theorem 4.1).
    #[serde(with = "serde_ext::ext_opt")]
    pub theta: Option<f64>,
    /// `r = min(4ρ/(13β), α/(2Mγ))` (Theorem 4.1).
    #[serde(with = "serde_ext::ext_opt")]
    pub r: Option<f64>,
    /// `K_L` of Prop 2.3: `0` for a static problem; `None` (not derived) when constraints move.
    #[serde(with = "serde_ext::ext_opt")]
    pub k_l: Option<f64>,
    /// `c/K_L`, the step bound for well-posedness: `∞` for a static problem, else `None`.
    #[serde(with = "serde_ext::ext_opt")]
    pub h_max: Option<f64>,
    /// Failed assumptions, one sentence each.
    pub failures: Vec<String>,
    /// Remarks (constants not derivable, families without an A0 margin…).
    pub notes: Vec<String>,
}

pub(super) fn fmt_num(v: f64) -> String {
    if v.is_infinite() {
        if v > 0.0 { "∞" } else { "−∞" }.to_string()
    } else if v == 0.0 {
        "0".to_string()
    } else if (1e-3..1e4).contains(&v.abs()) {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}

impl AssumptionReport {
    /// The constants as a readable table, one line each with what it means for the user,
    /// then the failed assumptions and the notes.
    pub fn table(&self) -> String {
        let mut rows: Vec<(String, String, String, String)> = Vec::new();
        let mut w = |name: &str, wit: &Option<Witness>, meaning: &str| {
            let (v, at) = match wit {
                Some(x) => (
                    fmt_num(x.value),
                    format!("t = {}, {}", fmt_num(x.t), shorten(&x.constraint, 60)),
                ),
                None => ("—".to_string(), "no constraint sampled".to_string()),
            };
            rows.push((name.to_string(), v, at, meaning.to_string()));
        };
        w(
            "α (A1)",
            &self.alpha,
            "smallest |∇gᵢ| near contact: constraints never flatten out below it",
        );
        w("β (A1)", &self.beta_grad, "largest |∇gᵢ| near contact");
        w(
            "β (A2)",
            &self.beta_dt,
            "largest |∂ₜgᵢ|: how fast a constraint moves (0 when nothing moves)",
        );
        w(
            "M (A4)",
            &self.m_hess,
            "largest |D²gᵢ| (spectral): curvature of the constraints; 0 for straight walls",
        );
        w(
            "M (A3)",
            &self.m_dt_grad,
            "largest |∂ₜ∇gᵢ| (Euclidean): how fast the normals turn in time",
        );
        w(
            "λ_min (§2)",
            &self.min_curvature,
            if self.convexity_failed {
                "smallest eigenvalue of D²gᵢ: NEGATIVE, some gᵢ is not convex (see FAILED)"
            } else {
                "smallest eigenvalue of D²gᵢ: ≥ 0 as the theory needs (gᵢ convex in q)"
            },
        );
        w(
            "γ (A5, ρ)",
            &self.gamma,
            "how close the near-active normals come to cancelling (1: not at all, ∞: they do)",
        );
        w(
            "γ' (A5')",
            &self.gamma_prime,
            "the same over the active constraints only; ∞ means someone is wedged (MFCQ fails)",
        );
        w(
            "γ (group)",
            &self.gamma_group,
            "the worst single cluster of contacts (γ² sums over separate clusters)",
        );
        let mut d = |name: &str, v: Option<f64>, meaning: String| {
            rows.push((
                name.to_string(),
                v.map(fmt_num).unwrap_or_else(|| "—".into()),
                String::new(),
                meaning,
            ));
        };
        d("β", self.beta, "the paper's β = max(A1, A2)".into());
        d("M", self.m, "the paper's M = max(A3, A4)".into());
        d(
            "c (A0)",
            self.c,
            "constraints stay smooth this far outside the feasible set".into(),
        );
        d(
            "η",
            self.eta,
            match self.eta {
                Some(e) if e.is_infinite() => {
                    "η = α/(Mγ'): Q(t) is convex here (M = 0): the projection onto it is always unique".into()
                }
                Some(e) => format!(
                    "η = α/(Mγ'): Q(t) is η-prox-regular: the projection onto it is unique within distance {}",
                    fmt_num(e)
                ),
                None if self.convexity_failed => {
                    "η = α/(Mγ'): not claimed, convexity fails (Prop 2.2 needs convex gᵢ)".into()
                }
                None => "η = α/(Mγ'): not available".into(),
            },
        );
        d(
            "Θ",
            self.theta,
            "Θ = 2γβ/α: distance to Q̃ ≤ Θ × Σ distances to each Q̃ᵢ (Theorem 4.1)".into(),
        );
        d(
            "r",
            self.r,
            "r = min(4ρ/(13β), α/(2Mγ)): Theorem 4.1 holds within r/4 of the current state".into(),
        );
        d(
            "K_L",
            self.k_l,
            "Lipschitz constant of t ↦ Q(t) (Prop 2.3): 0 when nothing moves; not derived for \
             moving constraints (the paper gives no formula)"
                .into(),
        );
        d(
            "h_max",
            self.h_max,
            "well-posedness needs h < c/K_L: any h when nothing moves, unknown otherwise".into(),
        );
        let wn = rows.iter().map(|r| r.0.chars().count()).max().unwrap_or(0);
        let wv = rows.iter().map(|r| r.1.chars().count()).max().unwrap_or(0);
        let wa = rows.iter().map(|r| r.2.chars().count()).max().unwrap_or(0);
        let mut out = String::new();
        let _ = writeln!(
            out,
            "assumptions A0–A5 over {} sample(s), {} evaluation(s); ρ = {}, neighbourhood = {}",
            self.samples,
            self.evaluations,
            fmt_num(self.rho),
            fmt_num(self.neighbourhood)
        );
        for (n, v, a, m) in &rows {
            let _ = writeln!(
                out,
                "  {n}{}  {v}{}  {a}{}  {m}",
                " ".repeat(wn - n.chars().count()),
                " ".repeat(wv - v.chars().count()),
                " ".repeat(wa - a.chars().count()),
            );
        }
        if self.failures.is_empty() {
            let _ = writeln!(out, "no assumption failed on these samples");
        } else {
            let _ = writeln!(out, "FAILED:");
            for f in &self.failures {
                let _ = writeln!(out, "  - {f}");
            }
        }
        for n in &self.notes {
            let _ = writeln!(out, "note: {n}");
        }
        out
    }
}

fn shorten(s: &str, max: usize) -> String {
    if s.chars().count() <= max {
        s.to_string()
    } else {
        let mut t: String = s.chars().take(max.saturating_sub(1)).collect();
        t.push('…');
        t
    }
}
