//! The library's enums the command line offers as choices (`--backend`, `--precision`,
//! `--start`, `--integrator`, `--article-norm`): each value's spelling and help text, and
//! a clap value parser over them.
//!
//! The library crates carry no clap (tests/layers.rs), so they cannot derive
//! `clap::ValueEnum`; the spellings are the enums' serde names, the help texts their
//! variants' documentation. Keeping clap out of the libraries also lets the Python wheel's
//! build reuse the test build's compiled library crates (crates/workspace-hack).

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use jeffcott_analysis::simulate::Integrator;
use jeffcott_core::ensemble::{Backend, Precision};
use jeffcott_core::integrate::article::ErrorNorm;
use jeffcott_core::lyapunov::SweepStart;
use std::ffi::OsStr;
use std::marker::PhantomData;

/// A library enum offered on the command line.
pub trait Choice: Copy + PartialEq + Send + Sync + 'static {
    /// Every value: its spelling, the value, and its help text.
    const VALUES: &'static [(&'static str, Self, &'static str)];
}

/// The spelling of `value` (for an argument's `default_value`).
pub fn name_of<T: Choice>(value: T) -> &'static str {
    T::VALUES
        .iter()
        .find(|v| v.1 == value)
        .map(|v| v.0)
        .expect("every value of a Choice is listed in its VALUES")
}

/// The value parser of a [`Choice`]: its spellings as possible values, with their help,
/// and clap's own error (listing them) for anything else.
pub fn choice<T: Choice>() -> ChoiceParser<T> {
    ChoiceParser(PhantomData)
}

/// See [`choice`].
#[derive(Clone)]
pub struct ChoiceParser<T>(PhantomData<T>);

impl<T: Choice> ChoiceParser<T> {
    fn possible() -> impl Iterator<Item = PossibleValue> {
        T::VALUES
            .iter()
            .map(|&(name, _, help)| PossibleValue::new(name).help(help))
    }
}

impl<T: Choice> TypedValueParser for ChoiceParser<T> {
    type Value = T;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &OsStr,
    ) -> Result<T, clap::Error> {
        let name = PossibleValuesParser::new(Self::possible()).parse_ref(cmd, arg, value)?;
        Ok(T::VALUES
            .iter()
            .find(|v| v.0 == name)
            .expect("PossibleValuesParser returns one of the names")
            .1)
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(Self::possible()))
    }
}

impl Choice for Backend {
    const VALUES: &'static [(&'static str, Self, &'static str)] = &[
        (
            "auto",
            Backend::Auto,
            "A hardware GPU if one is present, else the CPU",
        ),
        ("cpu", Backend::Cpu, "The rayon CPU path"),
        (
            "gpu",
            Backend::Gpu,
            "A GPU adapter (software ones such as Mesa's llvmpipe included); an error if none",
        ),
    ];
}

impl Choice for Precision {
    const VALUES: &'static [(&'static str, Self, &'static str)] = &[
        ("f32", Precision::F32, "Single precision (the GPU default)"),
        (
            "f64",
            Precision::F64,
            "Double precision (the CPU default; on the GPU only with `SHADER_F64`)",
        ),
    ];
}

impl Choice for SweepStart {
    const VALUES: &'static [(&'static str, Self, &'static str)] = &[
        (
            "given",
            SweepStart::Given,
            "Every speed from the given state (independent; all in parallel)",
        ),
        (
            "quasistatic",
            SweepStart::Quasistatic,
            "Quasi-statically: the transient of each speed starts from the state the previous \
             speed's transient ended in (in the order given), as in a bifurcation diagram; the \
             transients run in sequence, the spectra then in parallel",
        ),
    ];
}

impl Choice for Integrator {
    const VALUES: &'static [(&'static str, Self, &'static str)] = &[
        (
            "lane",
            Integrator::Lane,
            "The ensemble lane stepper (docs/numerics.md), the default",
        ),
        (
            "article",
            Integrator::Article,
            "The article's variable-step scheme (docs/numerics.md, the article's scheme), a \
             cross-check",
        ),
    ];
}

impl Choice for ErrorNorm {
    const VALUES: &'static [(&'static str, Self, &'static str)] = &[
        (
            "positions",
            ErrorNorm::Positions,
            "The four positions [m] (max norm)",
        ),
        (
            "all",
            ErrorNorm::All,
            "All eight components, positions in m and velocities in m/s (max norm)",
        ),
    ];
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The command line's spellings are the names run.json and the Python package use
    /// (the enums' serde names), so a value reads the same everywhere.
    fn spellings_are_serde_names<T: Choice + serde::Serialize>() {
        for &(name, value, _) in T::VALUES {
            assert_eq!(serde_json::to_value(value).unwrap(), name);
        }
    }

    #[test]
    fn every_choice_is_spelled_as_its_serde_name() {
        spellings_are_serde_names::<Backend>();
        spellings_are_serde_names::<Precision>();
        spellings_are_serde_names::<SweepStart>();
        spellings_are_serde_names::<Integrator>();
        spellings_are_serde_names::<ErrorNorm>();
    }
}
