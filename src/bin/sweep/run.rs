//! `sweep run` (being built).

/// Arguments of `sweep run`.
#[derive(clap::Args)]
pub struct RunArgs {
    /// The scene file.
    pub scene: std::path::PathBuf,
}

/// Entry point of `sweep run`.
pub fn main(_args: RunArgs) -> anyhow::Result<()> {
    anyhow::bail!("`sweep run` is not built yet")
}
