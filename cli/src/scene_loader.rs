//! Loading a scene file for the study commands (`converge`, `work-precision`).

use anyhow::Context;
use std::path::Path;
use sweeping::backends::BackendChoice;
use sweeping::problem::Problem;
use sweeping::scene::{Overrides, Scene};
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
/// When the file cannot be read, parsed or built (the message names file, line and item).
pub fn load_scene(path: &Path, h: Option<f64>, t_end: Option<f64>) -> anyhow::Result<LoadedScene> {
    let built = Scene::from_file(path)?
        .build(&Overrides {
            h,
            t_end,
            ..Default::default()
        })
        .with_context(|| format!("building {}", path.display()))?;
    Ok(LoadedScene {
        problem: built.problem,
        settings: built.settings,
        backend: built.backend,
    })
}
