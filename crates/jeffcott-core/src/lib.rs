//! # jeffcott-core
//!
//! Nonlinear dynamics of a rubbing rotor: a Jeffcott rotor (rigid disk on a massless
//! elastic shaft, mass eccentricity e, speed W) that intermittently hits a flexibly
//! suspended stator ring across a radial gap. The model is that of "Nonlinear Dynamics
//! and Chaos of a Nonsmooth Rotor-Stator System", Mathematical Problems in Engineering
//! (2017), with its printed equations corrected where they are dimensionally wrong
//! (see the README and `model`).
//!
//! This crate is the numerical core: no command line, no terminal, no pictures, no GPU
//! API. The GPU backend (`jeffcott-gpu`) compiles the WGSL mirror of the lane stepper
//! that lives here beside the Rust original ([`integrate::lane::WGSL`]); the studies
//! (`jeffcott-analysis`) and the command line (`jeffcott`) build on both.
//!
//! ## Reading order
//! 1. [`model`]: parameters (Table 1 as `Default`), the state layout
//!    `[x_r, vx_r, y_r, vy_r, x_s, vx_s, y_s, vy_s]`, the right-hand side, the contact
//!    force, the Jacobian, the energy.
//! 2. [`integrate`]: the RK4 step, the article's variable-step scheme
//!    ([`integrate::article`]) and the ensemble lane stepper ([`integrate::lane`]):
//!    fixed macro steps of T/N with contact crossings located and the step split there,
//!    generic over `f32`/`f64` and mirrored by the WGSL kernel (`integrate/lane.wgsl`, with
//!    its other parts beside the modules they mirror: `integrate::lane::WGSL_FILES`).
//! 3. [`ensemble`]: many independent lanes as one specification, their result, the lane
//!    table, and the CPU backend ([`ensemble::cpu`]: rayon over SIMD batches).
//! 4. [`lyapunov`]: Lyapunov spectra with saltation matrices at the contact switches.
//! 5. [`limits`], [`error`]: input ranges and the one error type; [`control`]: the one
//!    progress callback and the cancel flag of every run.

#![warn(missing_docs)]

pub mod control;
#[macro_use]
mod dispatch;
pub mod ensemble;
pub mod error;
pub mod inputs;
pub mod integrate;
pub mod limits;
pub mod lyapunov;
pub mod model;
pub mod orbit;
pub mod params;
pub mod real;

pub use error::{Error, Result};
