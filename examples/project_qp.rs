//! Projects recorded projection problems (the JSON of `sweeping::api::ProjectionProblem`, at
//! the top level or under the key `problem`, as `testkit/fixtures/*_qp.json` hold them) and writes
//! each answer next to its name in an output folder, with its KKT residuals and the time:
//!
//! ```text
//! cargo run --release --example project_qp -- [--backend native|clarabel] OUT_DIR QP.json...
//! ```
//!
//! `OUT_DIR/STEM_ref.json` gets `{"x", "multipliers", "backend", "kkt_max", "max_violation",
//! "seconds", "stats"}`; `scripts/qp_anchors.py` measures other solvers against these.
use anyhow::{bail, Context};
use serde_json::{json, Value};
use std::path::PathBuf;
use std::time::Instant;
use sweeping::api::ProjectionProblem;
use sweeping::backends::{make_projector, BackendChoice};

fn main() -> anyhow::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut backend = BackendChoice::Native;
    if args.first().map(String::as_str) == Some("--backend") {
        if args.len() < 2 {
            bail!("--backend needs a name");
        }
        backend = args[1]
            .parse()
            .map_err(|e| anyhow::anyhow!("--backend {}: {e}", args[1]))?;
        args.drain(..2);
    }
    let Some((out, files)) = args.split_first() else {
        bail!("usage: project_qp [--backend native|clarabel] OUT_DIR QP.json...");
    };
    let out = PathBuf::from(out);
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    for file in files {
        let text = std::fs::read_to_string(file).with_context(|| format!("reading {file}"))?;
        let value: Value =
            serde_json::from_str(&text).with_context(|| format!("parsing {file}"))?;
        let value = value.get("problem").cloned().unwrap_or(value);
        let problem: ProjectionProblem =
            serde_json::from_value(value).with_context(|| format!("{file}: not a problem"))?;
        let mut projector = make_projector(backend)?;
        let start = Instant::now();
        let answer = projector
            .project(&problem)
            .with_context(|| format!("{file}: {backend} found no answer"))?;
        let seconds = start.elapsed().as_secs_f64();
        let kkt = problem.kkt_residuals(&answer.x, &answer.multipliers);
        let stem = PathBuf::from(file)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "problem".to_string());
        let path = out.join(format!("{stem}_ref.json"));
        let record = json!({
            "x": answer.x,
            "multipliers": answer.multipliers,
            "backend": answer.stats.backend,
            "kkt_max": kkt.max(),
            "max_violation": kkt.primal,
            "seconds": seconds,
            "stats": answer.stats,
        });
        std::fs::write(&path, serde_json::to_string(&record)?)
            .with_context(|| format!("writing {}", path.display()))?;
        println!(
            "{file}: {backend} in {:.1} ms, KKT residual {:.1e} → {}",
            seconds * 1e3,
            kkt.max(),
            path.display()
        );
    }
    Ok(())
}
