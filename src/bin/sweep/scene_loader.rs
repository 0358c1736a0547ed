//! Loading a scene file for the study commands.
//!
//! MERGE SEAM: `load_scene` below is the one temporary stand-in of this branch. Scene files
//! (module `sweeping::scene`) are being built on another branch; when they are merged,
//! replace the body of `load_scene` with
//!
//! ```text
//! let built = sweeping::scene::Scene::from_file(path)?
//!     .build(&sweeping::scene::Overrides { h, t_end, ..Default::default() })?;
//! Ok(LoadedScene { problem: built.problem, settings: built.settings, backend: built.backend })
//! ```
//!
//! Everything else in `converge` and `work-precision` goes through this function.

use std::path::Path;
use sweeping::backends::BackendChoice;
use sweeping::problem::Problem;
use sweeping::stepper::StepperSettings;

/// A scene ready to run: the process, the stepper settings (with any override of `h` and
/// `T` applied) and the backend the scene asks for.
pub struct LoadedScene {
    /// The process.
    pub problem: Problem,
    /// The settings.
    pub settings: StepperSettings,
    /// The scene's backend.
    pub backend: BackendChoice,
}

/// Loads `path`, overriding the scene's time step and horizon when given.
///
/// # Errors
/// Always, on this branch: scene files are not merged yet (see the module docs).
pub fn load_scene(path: &Path, h: Option<f64>, t_end: Option<f64>) -> anyhow::Result<LoadedScene> {
    // MERGE SEAM: replace with `sweeping::scene` once it is merged (module docs).
    let _ = (h, t_end);
    anyhow::bail!(
        "cannot load {}: scene support (`sweeping::scene`) is not merged into this build yet",
        path.display()
    )
}
