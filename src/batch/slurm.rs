//! A plan as a Slurm job array: task `k` runs trial `k` (`sweep batch PLAN --trial k`), each
//! into its folder as on one machine; `sweep batch PLAN --collect` then builds the table.

use super::Plan;
use std::fmt::Write as _;
use std::path::Path;

/// `s` quoted for the shell.
fn quoted(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// The job-array script of `plan`, whose tasks run `sweep` (the binary's path) on `plan_file`
/// from `workdir` into `out`; its log files go to `out/slurm/` (which must exist when the job
/// is submitted: Slurm does not create it). The plan's `[slurm] options` are added as
/// `#SBATCH` lines. Paths are best given absolute: tasks run on other machines.
pub fn slurm_script(
    plan: &Plan,
    plan_file: &Path,
    out: &Path,
    sweep: &Path,
    workdir: &Path,
) -> String {
    let n = plan.trial_count();
    let mut s = String::new();
    let _ = writeln!(s, "#!/bin/bash");
    let _ = writeln!(
        s,
        "# The {n} trials of the plan `{}` as a Slurm job array: task k runs trial k.",
        plan.name
    );
    let _ = writeln!(
        s,
        "# Submit with `sbatch {}`; when the tasks have ended,",
        out.join("batch.slurm").display()
    );
    let _ = writeln!(
        s,
        "# `sweep batch {} --out {} --collect` builds the results table.",
        plan_file.display(),
        out.display()
    );
    let _ = writeln!(
        s,
        "#SBATCH --job-name=sweep-{}",
        plan.name.replace(char::is_whitespace, "-")
    );
    let limit = plan
        .slurm
        .max_parallel
        .map(|m| format!("%{m}"))
        .unwrap_or_default();
    let _ = writeln!(s, "#SBATCH --array=0-{}{limit}", n.saturating_sub(1));
    let _ = writeln!(s, "#SBATCH --ntasks=1");
    let _ = writeln!(s, "#SBATCH --cpus-per-task=1");
    let _ = writeln!(
        s,
        "#SBATCH --output={}",
        out.join("slurm").join("%A_%a.out").display()
    );
    for option in &plan.slurm.options {
        let _ = writeln!(s, "#SBATCH {option}");
    }
    let _ = writeln!(s, "set -eu");
    let _ = writeln!(s, "cd {}", quoted(&workdir.display().to_string()));
    let _ = writeln!(
        s,
        "exec {} batch {} --out {} --trial \"$SLURM_ARRAY_TASK_ID\"",
        quoted(&sweep.display().to_string()),
        quoted(&plan_file.display().to_string()),
        quoted(&out.display().to_string())
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_are_quoted_for_the_shell() {
        assert_eq!(quoted("/a b/it's"), r"'/a b/it'\''s'");
    }
}
