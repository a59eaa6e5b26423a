//! The studies: each turns a specification into arrays and a record, in work units the
//! run engine ([`crate::run`]) commits. Sweeps over the speed or a parameter
//! ([`bifurcation`], [`continuation`], [`cascade`], [`stability`], [`lyapunov`]), grids
//! of start states or parameters ([`basin`], [`refine`], [`map`], [`uncertainty`]) and
//! the measures of a basin grid ([`measures`]), single trajectories and plain ensembles
//! ([`simulate`], [`ensemble`]), and the figures read off an orbit ([`spectrum`],
//! [`rub`]). The crate re-exports each at its root (`jeffcott_analysis::basin`), the
//! path front ends use.

pub mod basin;
pub mod bifurcation;
pub mod cascade;
pub mod continuation;
pub mod ensemble;
pub mod lyapunov;
pub mod map;
pub mod measures;
pub mod refine;
pub mod rub;
pub mod simulate;
pub mod spectrum;
pub mod stability;
pub mod uncertainty;
