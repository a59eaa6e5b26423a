//! # jeffcott-analysis
//!
//! The studies of the rubbing rotor, on whichever backend runs them: [`backend`] turns
//! `auto`/`cpu`/`gpu` into the CPU path of `jeffcott-core` or a `jeffcott-gpu` runner;
//! [`run`] is the resumable run engine (work units committed atomically, output
//! directories that never lie); the rest classify Poincare records and build the
//! studies on them. Nothing here parses arguments, draws or prints.

pub mod backend;
pub mod basin;
pub mod bench;
pub mod bifurcation;
pub mod cascade;
pub mod catalogue;
pub mod classify;
pub mod continuation;
pub mod defaults;
pub mod early;
pub mod ensemble;
pub mod gpu_pool;
pub mod lyapunov;
pub mod map;
pub mod measures;
pub mod orbit_starts;
pub mod orbits;
pub mod output;
pub mod record;
pub mod refine;
pub mod reproduce;
pub mod rub;
pub mod run;
pub mod settings;
pub mod simulate;
pub mod spectrum;
pub mod stability;
pub mod uncertainty;

pub use jeffcott_core::{Error, Result};
