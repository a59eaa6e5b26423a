//! Integrators: the reference RK4 step, the article's variable-step scheme (docs/numerics.md, the article's scheme)
//! and the ensemble lane stepper (docs/numerics.md) with its trigonometry-free forcing.

pub mod article;
pub mod batch;
pub mod forcing;
pub mod free_flight;
pub mod lane;
pub mod rk4;
pub mod switch;
pub mod tangent;
pub(crate) mod transpose;
pub mod wide;
