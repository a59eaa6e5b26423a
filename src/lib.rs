//! # jeffcott (the command line)
//!
//! The `jeffcott` binary's own code: clap arguments and commands ([`cli`]), plots
//! ([`plot`]), terminal progress bars ([`progress`]) and the explorer's web server and page
//! ([`explore`]). The numerics are the library
//! crates of the workspace: `jeffcott-core` (model, integrators, CPU backend),
//! `jeffcott-gpu` (wgpu backend) and `jeffcott-analysis` (studies, run engine); this
//! crate only turns arguments into their calls and their results into files.

pub mod cli;
pub mod explore;
pub mod plot;
pub mod progress;
