//! Analysis of Poincare records. Never cares which backend produced them.

pub mod bifurcation;
pub mod catalogue;
pub mod classify;
