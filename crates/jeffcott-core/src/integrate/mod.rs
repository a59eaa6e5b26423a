//! Integrators: the reference RK4 step, the article's variable-step scheme (MODEL.md 4.1)
//! and the ensemble lane stepper (MODEL.md 4.2) with its trigonometry-free forcing.

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
