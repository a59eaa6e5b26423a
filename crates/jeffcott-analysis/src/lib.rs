//! # jeffcott-analysis
//!
//! The studies of the rubbing rotor, on whichever backend runs them: [`backend`] turns
//! `auto`/`cpu`/`gpu` into the CPU path of `jeffcott-core` or a `jeffcott-gpu` runner;
//! [`run`] is the resumable run engine (work units committed atomically, output
//! directories that never lie); the rest classify Poincare records and build the
//! studies on them. Nothing here parses arguments, draws or prints.
//!
//! The source is grouped by what it holds: `studies/` (every study but [`orbits`] and
//! [`reproduce`], which keep their own folders), `attractors/` (classification, the
//! catalogue, early exit, orbit starts from earlier results), and at the top what every
//! study runs on: the backends ([`backend`], [`gpu_pool`], [`bench`]), the run engine
//! ([`run`]), the files ([`output`], [`record`]) and the settings and defaults
//! ([`settings`], [`defaults`]). Every module is reachable at the crate's root
//! (`jeffcott_analysis::basin`), whatever folder holds it.

#![warn(missing_docs)]

mod attractors;
mod studies;

pub mod backend;
pub mod bench;
pub mod defaults;
pub mod gpu_pool;
pub mod orbits;
pub mod output;
pub mod record;
pub mod reproduce;
pub mod run;
pub mod settings;

pub use attractors::{catalogue, classify, early, orbit_starts};
pub use studies::{
    basin, bifurcation, cascade, continuation, ensemble, lyapunov, map, measures, refine, rub,
    simulate, spectrum, stability, uncertainty,
};

pub use jeffcott_core::{Error, Result};

/// The git commit this build comes from (`JEFFCOTT_COMMIT` at build time, else `git
/// rev-parse --short=12 HEAD`, else `unknown`), recorded in every run.json.
pub const COMMIT: &str = env!("JEFFCOTT_COMMIT");

/// The version as `jeffcott --version` shows it: the package version and the commit.
pub const LONG_VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("JEFFCOTT_COMMIT"),
    ")"
);
