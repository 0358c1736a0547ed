//! `sweep check`: validate a scene without running it.

use anyhow::Result;
use sweeping::scene::{Overrides, Scene};

/// Arguments of `sweep check`.
#[derive(clap::Args)]
pub struct CheckArgs {
    /// The scene file.
    pub scene: std::path::PathBuf,
}

/// Entry point of `sweep check`: parses and builds the scene (placing random people, solving
/// the geodesic field) and prints what it contains and which effects are active.
pub fn main(args: CheckArgs) -> Result<()> {
    let scene = Scene::from_file(&args.scene)?;
    let built = scene.build(&Overrides::default())?;
    print!("{}", built.describe());
    println!("ok: {} is a valid scene", args.scene.display());
    Ok(())
}
