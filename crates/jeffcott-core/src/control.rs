//! How a run reports progress and is stopped: the one progress callback of the library
//! and a cancel flag, shared by the CPU backend, the GPU runner, the run engine and the
//! Python binding (which sets the flag on Ctrl-C).

use std::sync::atomic::{AtomicBool, Ordering};

/// The one progress callback of the library: `(done, total)` lane-periods, called from
/// any thread; `done` never decreases within a run.
pub type ProgressFn<'a> = &'a (dyn Fn(u64, u64) + Sync);

/// A progress callback that ignores its reports.
pub fn no_progress(_: u64, _: u64) {}

/// A cancel flag: once set, a run stops at its next check (between batches of 8 lanes
/// on the CPU, between time slices on a GPU, between work units in the run engine),
/// keeps what is committed and returns [`crate::Error::Interrupted`].
#[derive(Debug, Default)]
pub struct Cancel(AtomicBool);

impl Cancel {
    /// A flag not set.
    pub const fn new() -> Cancel {
        Cancel(AtomicBool::new(false))
    }

    /// Asks the run to stop.
    pub fn set(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    /// Whether a stop was asked for.
    pub fn is_set(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }
}

/// A flag nobody sets, for runs that cannot be cancelled.
static NEVER: Cancel = Cancel::new();

/// How a run reports and is stopped.
#[derive(Clone, Copy)]
pub struct Control<'a> {
    /// Progress in lane-periods.
    pub progress: ProgressFn<'a>,
    /// Checked between batches (see [`Cancel`]).
    pub cancel: &'a Cancel,
}

impl Control<'static> {
    /// No progress reports, never cancelled.
    pub fn none() -> Control<'static> {
        Control {
            progress: &no_progress,
            cancel: &NEVER,
        }
    }
}

impl<'a> Control<'a> {
    /// Reports progress, never cancelled.
    pub fn progress(progress: ProgressFn<'a>) -> Control<'a> {
        Control {
            progress,
            cancel: &NEVER,
        }
    }
}
