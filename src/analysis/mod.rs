//! Analysis of Poincare records. Never cares which backend produced them.

pub mod basin;
pub mod bifurcation;
pub mod cascade;
pub mod catalogue;
pub mod classify;
pub mod continuation;
pub mod map;
pub mod measures;
pub mod refine;
pub mod rub;
pub mod spectrum;
pub mod uncertainty;
