//! The package's functions, one file per family of studies. Each builds the study's
//! specification from its keywords ([`crate::args`]), runs it with the GIL released
//! ([`crate::run`]) and returns the command line's files as numpy arrays and
//! dictionaries ([`crate::convert`]).

pub mod basins;
pub mod lanes;
pub mod maps;
pub mod trajectory;
