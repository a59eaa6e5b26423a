//! Runs library work with the GIL released, in a worker thread, while the calling
//! (Python) thread waits in short slices: between slices it takes the GIL, lets Python
//! handle pending signals (Ctrl-C raises KeyboardInterrupt there) and calls the optional
//! progress callable with the latest `(done, total)` lane-periods. On an exception it
//! sets the run's cancel flag, which the CPU path checks before every batch of 8 lanes
//! and a GPU between time slices, waits for the worker to stop (a fraction of a second)
//! and re-raises. Errors map to Python exceptions by kind (`to_py_err`).

use jeffcott_core::Error;
use jeffcott_core::control::{Cancel, Control};
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::time::Duration;

/// How often the waiting thread looks at signals and progress.
const POLL: Duration = Duration::from_millis(50);

/// A library error as a Python exception: bad input is `ValueError` (the message names
/// the field and the allowed range), a stop asked for is `KeyboardInterrupt`, anything
/// else (no GPU adapter, a GPU error, a file) `RuntimeError` with the command line's
/// message.
pub fn to_py_err(e: Error) -> PyErr {
    match e {
        // The field as a Python keyword spells it (the library names options as the
        // command line does: `rel-tol` is the keyword `rel_tol`).
        Error::InvalidParameter {
            name,
            value,
            reason,
        } => PyValueError::new_err(
            Error::InvalidParameter {
                // The command line's `--box` is the keyword `start_box`.
                name: if name == "box" {
                    "start_box".into()
                } else {
                    name.replace('-', "_")
                },
                value,
                reason,
            }
            .to_string(),
        ),
        Error::Config { .. } => PyValueError::new_err(e.to_string()),
        Error::Interrupted { .. } => PyKeyboardInterrupt::new_err("the run was interrupted"),
        _ => PyRuntimeError::new_err(e.to_string()),
    }
}

/// Runs `work` in a worker thread with the GIL released (see the module docs).
pub fn detached<T: Send>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(Control) -> jeffcott_core::Result<T> + Send,
) -> PyResult<T> {
    let cancel = Cancel::new();
    let done = AtomicU64::new(0);
    let total = AtomicU64::new(0);
    let report = |d: u64, t: u64| {
        total.store(t, Ordering::Relaxed);
        done.fetch_max(d, Ordering::Relaxed);
    };
    std::thread::scope(|s| {
        let (tx, mut rx) = mpsc::channel();
        let ctl = Control {
            progress: &report,
            cancel: &cancel,
        };
        s.spawn(move || {
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(ctl)));
            let _ = tx.send(r);
        });
        let mut reported = (u64::MAX, u64::MAX);
        let mut failure: Option<PyErr> = None;
        loop {
            let (back, got) = py.detach(move || {
                let got = rx.recv_timeout(POLL);
                (rx, got)
            });
            rx = back;
            let outcome = match got {
                Ok(r) => Some(r),
                Err(mpsc::RecvTimeoutError::Timeout) => None,
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(PyRuntimeError::new_err(
                        "the worker thread ended without a result",
                    ));
                }
            };
            if let Some(r) = outcome {
                if let Some(e) = failure {
                    return Err(e);
                }
                // The last report, which the worker may have made after the last look.
                if let (Some(cb), Ok(Ok(_))) = (progress, &r) {
                    let now = (done.load(Ordering::Relaxed), total.load(Ordering::Relaxed));
                    if now != reported && now.1 > 0 {
                        cb.call1(now)?;
                    }
                }
                return match r {
                    Ok(res) => res.map_err(to_py_err),
                    Err(_) => Err(PyRuntimeError::new_err(
                        "the run panicked (a bug in jeffcott)",
                    )),
                };
            }
            if failure.is_some() {
                continue; // cancelled: wait for the worker to stop
            }
            let mut check = py.check_signals();
            if check.is_ok()
                && let Some(cb) = progress
            {
                let now = (done.load(Ordering::Relaxed), total.load(Ordering::Relaxed));
                if now != reported && now.1 > 0 {
                    reported = now;
                    check = cb.call1(now).map(|_| ());
                }
            }
            if let Err(e) = check {
                cancel.set();
                failure = Some(e);
            }
        }
    })
}
