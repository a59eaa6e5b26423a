//! Attractors from Poincare records: [`classify`] names one lane's attractor (fixed
//! point, period-n, quasi-periodic, chaotic), [`catalogue`] gives the lanes of one
//! speed attractor ids that every study shares, [`early`] retires lanes recognised on
//! an attractor already catalogued, and [`orbit_starts`] reads the periodic attractors
//! of an earlier result as starts for orbit continuation. The crate re-exports each at
//! its root (`jeffcott_analysis::catalogue`), the path front ends use.

pub mod catalogue;
pub mod classify;
pub mod early;
pub mod orbit_starts;
