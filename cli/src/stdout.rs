//! Standard output that a closed pipe or a full disk cannot turn into a panic.
//!
//! `println!` panics when it cannot write ("failed printing to stdout: Broken pipe"), as in
//! `sweep run SCENE | head -3`: the run's files would be complete, but the process would end
//! with a panic and exit code 101. Here a failed write is remembered instead and the rest of the
//! output skipped; [`finish`] then tells what happened. A closed pipe means the reader had
//! seen enough, as for the shell's own tools, and is not an error; any other failure (a full
//! disk) is reported on standard error and makes the exit status 1.

use std::io::{ErrorKind, Write};
use std::sync::Mutex;

/// The first write that failed, if any: `Some(None)` for a closed pipe.
static FAILED: Mutex<Option<Option<String>>> = Mutex::new(None);

/// Writes `args` to standard output, unless an earlier write failed.
pub fn write(args: std::fmt::Arguments<'_>) {
    let mut failed = FAILED
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if failed.is_some() {
        return;
    }
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|()| out.flush()) {
        *failed = Some((e.kind() != ErrorKind::BrokenPipe).then(|| e.to_string()));
    }
}

/// What failed on standard output, if anything but a closed pipe.
pub fn finish() -> Option<String> {
    let failed = FAILED
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    failed.clone().flatten()
}

/// Writes `args` to standard error; a write that fails is dropped. `eprintln!` panics there
/// as `println!` does on standard output: `sweep run SCENE 2>&1 | head -1` ended at its first
/// progress line with a panic, exit code 101, no `summary.json` and a trajectory cut short.
/// Standard error is where a failure would be told, so there is nowhere left to tell this
/// one; the run goes on and writes its files, and the exit status still says how it ended.
pub fn write_err(args: std::fmt::Arguments<'_>) {
    let mut err = std::io::stderr().lock();
    let _ = err.write_fmt(args).and_then(|()| err.flush());
}

/// `eprintln!` to [`write_err()`].
macro_rules! errln {
    () => { $crate::stdout::write_err(format_args!("\n")) };
    ($($arg:tt)*) => { $crate::stdout::write_err(format_args!("{}\n", format_args!($($arg)*))) };
}

/// `println!` to [`write()`].
macro_rules! outln {
    () => { $crate::stdout::write(format_args!("\n")) };
    ($($arg:tt)*) => { $crate::stdout::write(format_args!("{}\n", format_args!($($arg)*))) };
}

/// `print!` to [`write()`].
macro_rules! out {
    ($($arg:tt)*) => { $crate::stdout::write(format_args!($($arg)*)) };
}

pub(crate) use {errln, out, outln};
