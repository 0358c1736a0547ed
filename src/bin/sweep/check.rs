//! `sweep check` (being built).

/// Arguments of `sweep check`.
#[derive(clap::Args)]
pub struct CheckArgs {
    /// The scene file.
    pub scene: std::path::PathBuf,
}

/// Entry point of `sweep check`.
pub fn main(_args: CheckArgs) -> anyhow::Result<()> {
    anyhow::bail!("`sweep check` is not built yet")
}
