//! The exit status of every command: one number per kind of failure, listed in
//! `--help`, so that a script (a Slurm array, a CI job) can tell bad input from a full
//! disk, a missing GPU or an interruption.

use jeffcott_core::error::Error;

/// The exit statuses, as `--help` lists them.
pub const EXIT_CODES: &str = "Exit status: 0 done; 2 bad input (an option out of range, an unreadable config or lane table, an output directory that holds another run or units of another run), also for unknown options; 3 a file could not be read or written (a full disk, a permission); 4 no usable GPU, or the GPU failed; 130 interrupted (Ctrl-C, SIGTERM; committed work units are kept); 1 anything else (an internal error: please report it).";

/// The exit status of an error ([`EXIT_CODES`]).
pub fn exit_code(e: &Error) -> u8 {
    use jeffcott_analysis::run::dir::RunDirError;
    match e {
        Error::InvalidParameter { .. } | Error::Config { .. } => 2,
        Error::Io { .. } => 3,
        Error::NoAdapter { .. } | Error::Gpu { .. } | Error::DeviceLost => 4,
        Error::Interrupted { .. } => 130,
        Error::Layer(_) => match e.layer_error::<RunDirError>() {
            Some(RunDirError::Busy { .. })
            | Some(RunDirError::Occupied { .. })
            | Some(RunDirError::ForeignUnit { .. })
            | Some(RunDirError::LockLost { .. }) => 2,
            None if e.layer_error::<crate::plot::PlotError>().is_some() => 3,
            None => 1,
        },
        _ => 1,
    }
}
