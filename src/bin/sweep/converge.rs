//! `sweep converge` (being built).

/// Arguments of `sweep converge`.
#[derive(clap::Args)]
pub struct ConvergeArgs {
    /// The scene file.
    pub scene: std::path::PathBuf,
}

/// Entry point of `sweep converge`.
pub fn main(_args: ConvergeArgs) -> anyhow::Result<()> {
    anyhow::bail!("`sweep converge` is not built yet")
}
