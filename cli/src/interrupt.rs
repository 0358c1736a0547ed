//! Ctrl-C (SIGINT), SIGTERM and SIGHUP during `sweep run`: the run stops at the end of the
//! step during which the signal came, as a failure, so that every writer finishes its file and
//! the summary is written with the status `"interrupted"`. Killed outright, a run left
//! `trajectory.csv` cut in the middle of a row, no `summary.json`, and nothing to resume from.
//! A second signal ends the process at once (exit code 128 + the signal's number).

use crate::stdout::errln;
use std::sync::atomic::{AtomicI32, Ordering};
use std::sync::Arc;
use sweeping::error::SweepError;
use sweeping::stepper::{Observer, ObserverError, StepReport};

/// The observer that stops the run once a signal has come.
pub struct Interrupt {
    /// The number of the first signal that came; 0 while none has.
    requested: Arc<AtomicI32>,
}

impl Interrupt {
    /// Installs the handlers; `None` (and a note) where the system refuses them, in which case
    /// the signals kill the process as they would have.
    #[cfg(unix)]
    pub fn install() -> Option<Self> {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        let mut signals = vec![SIGINT, SIGTERM];
        // A run started under `nohup` goes on when its terminal closes, as the user asked.
        if !sighup_ignored() {
            signals.push(SIGHUP);
        }
        let mut iterator = match signal_hook::iterator::Signals::new(&signals) {
            Ok(iterator) => iterator,
            Err(e) => {
                errln!("note: Ctrl-C and SIGTERM will not stop the run cleanly: {e}");
                return None;
            }
        };
        let requested = Arc::new(AtomicI32::new(0));
        let flag = requested.clone();
        let spawned = std::thread::Builder::new()
            .name("signals".into())
            .spawn(move || {
                for signal in iterator.forever() {
                    if flag.swap(signal, Ordering::SeqCst) != 0 {
                        std::process::exit(128 + signal);
                    }
                    errln!(
                        "\n{}: finishing the step and writing what was computed (a second \
                         signal, or Ctrl-C, stops at once)",
                        signal_name(signal)
                    );
                }
            });
        match spawned {
            Ok(_) => Some(Self { requested }),
            Err(e) => {
                errln!("note: Ctrl-C and SIGTERM will not stop the run cleanly: {e}");
                None
            }
        }
    }

    /// Installs the handler of Ctrl-C, the one signal of these systems.
    #[cfg(not(unix))]
    pub fn install() -> Option<Self> {
        let requested = Arc::new(AtomicI32::new(0));
        let flag = requested.clone();
        let installed = ctrlc::set_handler(move || {
            if flag.swap(2, Ordering::SeqCst) != 0 {
                std::process::exit(130);
            }
            errln!("\ninterrupted: finishing the step and writing what was computed (Ctrl-C again to stop at once)");
        });
        match installed {
            Ok(()) => Some(Self { requested }),
            Err(e) => {
                errln!("note: Ctrl-C will not stop the run cleanly: {e}");
                None
            }
        }
    }
}

/// How the signal is known to the user.
#[cfg(unix)]
fn signal_name(signal: i32) -> &'static str {
    match signal {
        signal_hook::consts::SIGINT => "interrupted (Ctrl-C)",
        signal_hook::consts::SIGTERM => "terminated (SIGTERM)",
        signal_hook::consts::SIGHUP => "hung up (SIGHUP)",
        _ => "signalled",
    }
}

/// Whether this process ignores SIGHUP, as one started by `nohup` does. Read from Linux's
/// `/proc/self/status`; elsewhere taken as ignored, which leaves SIGHUP as it was.
#[cfg(unix)]
fn sighup_ignored() -> bool {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else {
        return true;
    };
    status
        .lines()
        .find_map(|line| line.strip_prefix("SigIgn:"))
        .and_then(|mask| u64::from_str_radix(mask.trim(), 16).ok())
        .is_none_or(|mask| mask & (1 << (signal_hook::consts::SIGHUP - 1)) != 0)
}

impl Interrupt {
    /// Whether a stop was asked for (`sweep batch` starts no trial after it).
    pub fn requested(&self) -> bool {
        self.requested.load(Ordering::SeqCst) != 0
    }
}

impl Observer for Interrupt {
    fn name(&self) -> &str {
        "interrupt"
    }
    fn on_step(&mut self, report: &StepReport, _: &[f64]) -> Result<(), ObserverError> {
        if self.requested.load(Ordering::SeqCst) != 0 {
            return Err(ObserverError::from(SweepError::Interrupted {
                step: report.step,
                t: report.t,
            }));
        }
        Ok(())
    }
}
