//! # jeffcott
//!
//! Nonlinear dynamics of a rubbing rotor: a Jeffcott rotor (rigid disk on a massless
//! elastic shaft, mass eccentricity e, speed W) that intermittently hits a flexibly
//! suspended stator ring across a radial gap. The model is that of "Nonlinear Dynamics
//! and Chaos of a Nonsmooth Rotor-Stator System", Mathematical Problems in Engineering
//! (2017), with its printed equations corrected where they are dimensionally wrong
//! (see the README and `model`).
//!
//! ## Reading order
//! 1. [`model`]: parameters (Table 1 as `Default`), the state layout
//!    `[x_r, vx_r, y_r, vy_r, x_s, vx_s, y_s, vy_s]`, the right-hand side, the contact
//!    force, the Jacobian, the energy.
//! 2. [`integrate`]: the RK4 step, the article's variable-step scheme
//!    ([`integrate::article`]) and the ensemble lane stepper ([`integrate::lane`]):
//!    fixed macro steps of T/N with contact crossings located and the step split there,
//!    generic over `f32`/`f64` and written to be mirrored by the WGSL kernel.
//! 3. [`simulate`]: one trajectory from transient to classification.
//! 4. [`analysis`]: attractor classification from Poincare points; [`lyapunov`]:
//!    Lyapunov spectra with saltation matrices at the contact switches.
//! 5. [`output`], [`plot`], [`cli`]: files, pictures, the command line.

pub mod analysis;
pub mod bench;
pub mod cli;
pub mod ensemble;
pub mod error;
pub mod gpu;
pub mod integrate;
pub mod limits;
pub mod lyapunov;
pub mod model;
pub mod output;
pub mod plot;
pub mod progress;
pub mod real;
pub mod run;
pub mod simulate;

pub use error::{Error, Result};
