//! # jeffcott (the command line)
//!
//! The `jeffcott` binary's own code: clap arguments and commands ([`cli`]), plots
//! ([`plot`]) and terminal progress bars ([`progress`]). The numerics are the library
//! crates of the workspace: `jeffcott-core` (model, integrators, CPU backend),
//! `jeffcott-gpu` (wgpu backend) and `jeffcott-analysis` (studies, run engine); this
//! crate only turns arguments into their calls and their results into files.

pub mod cli;
pub mod plot;
pub mod progress;
