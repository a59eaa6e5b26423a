//! Early exit: lanes that retire once they are recognised on a known attractor, their
//! slots refilled with the next lanes. The core knows nothing of attractors:
//! a study gives a [`Recognise`] (the analysis crate builds one from its catalogue) and
//! the runner shows it each live lane's Poincare point at the end of every period from
//! [`EarlyExit::after`] on; a lane it recognises ends there with that attractor's id.
//! A lane that is never recognised runs its whole transient and record exactly as
//! without early exit, and its record is bit-identical to that run's: lanes are
//! independent and a refilled slot starts at a period boundary, where the lane stepper
//! holds no state but the lane's own (`Lane::k` = 0).
//!
//! The rule is a function of the lane's sequence of Poincare points alone: the CPU's
//! refilled batches and a GPU's slot pool apply it through the same bookkeeping
//! (`super::refill`), and [`replay`] applies it to recorded periods (the tests check
//! the runners' decisions against it).
//!
//! Literature: Datseris and Wagemakers, "Effortless estimation of basins of attraction",
//! Chaos 32, 023104 (2022) (`AttractorsViaRecurrences`: a trajectory stops once it has
//! visited cells of a known attractor often enough in a row).

use super::EnsembleResult;
use crate::model::{STATE_DIM, State};

/// A lane's progress towards recognition, kept by the runner and updated by
/// [`Recognise::observe`] once a period.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Track {
    /// The attractor the lane's last points matched.
    pub attractor: u32,
    /// The index of the point of that attractor's cycle expected next (0 for clouds).
    pub next: u32,
    /// How many points in a row matched (0: none; the lane is looking).
    pub streak: u32,
}

/// Recognises lanes on known attractors from their Poincare points.
pub trait Recognise: Sync {
    /// Takes live lane `lane`'s (its index in the ensemble) Poincare point at the end of
    /// a period and its track so far; returns the attractor's id once the lane is
    /// recognised on it.
    fn observe(&self, lane: usize, track: &mut Track, point: &State) -> Option<u32>;
}

/// What a recognised lane does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Then {
    /// It retires: no record (NaN rows), its final state the state it was recognised at.
    /// For studies that need its label only (a basin's cells).
    Retire,
    /// It skips the rest of its transient and records its `recorded` periods from there
    /// (with lambda_1, once its tangent has aligned:
    /// `StepperConfig::record_early_from`): a record of its own on the attractor, for
    /// studies that classify or draw each lane's record (the brute force). Recognition
    /// looks at the transient only; a lane recognised at the transient's last period
    /// has the record of the run without early exit.
    Record,
}

/// Early exit for one run: the recogniser, the first period it looks at and what a
/// recognised lane does.
#[derive(Clone, Copy)]
pub struct EarlyExit<'a> {
    /// Recognises the lanes.
    pub recognise: &'a dyn Recognise,
    /// Periods a lane integrates before its points are looked at (its first point seen
    /// is the one after period `after`, counted from 1).
    pub after: u32,
    /// What a recognised lane does.
    pub then: Then,
}

impl EarlyExit<'_> {
    /// Whether a lane's point after period `period` (counted from 1) is looked at, in a
    /// run of `transient` periods of transient.
    pub fn looks_at(&self, period: u32, transient: u32) -> bool {
        period >= self.after
            && match self.then {
                Then::Retire => true,
                Then::Record => period <= transient,
            }
    }
}

/// A lane that was recognised early: retired ([`Then::Retire`]) or recorded from there
/// ([`Then::Record`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Retired {
    /// The attractor it was recognised on (the recogniser's id).
    pub attractor: u32,
    /// The periods it integrated (counted from 1; with [`Then::Record`] its record is the
    /// last `recorded` of them).
    pub periods: u32,
}

/// An ensemble run with early exit: the result in the usual shape (a retired lane's
/// record rows are NaN, its final state the state it retired at; a lane recorded early
/// has its own record and final state) and, per lane, whether and where it was
/// recognised.
#[derive(Clone, Debug)]
pub struct EarlyResult {
    /// The lanes' results.
    pub result: EnsembleResult,
    /// `Some` for each lane that retired early.
    pub retired: Vec<Option<Retired>>,
}

impl EarlyResult {
    /// Periods integrated by all lanes ([`periods_run`]).
    pub fn periods_run(&self, full: u32) -> u64 {
        periods_run(&self.retired, full)
    }
}

/// Periods integrated by lanes of `full` periods each, `retired` saying where each
/// stopped early (a frozen lane counts the periods it was run).
pub fn periods_run(retired: &[Option<Retired>], full: u32) -> u64 {
    retired
        .iter()
        .map(|r| r.map_or(full, |r| r.periods) as u64)
        .sum()
}

/// The decision of the rule over lane `lane`'s points after periods `first`,
/// `first + 1`, ... (`rows`, flat, 8 values each; NaN rows, as a frozen lane's records,
/// never match) in a run of `transient` periods of transient and `recorded` recorded:
/// the same calls of [`Recognise::observe`] as the runner makes, stopping at the first
/// recognition (`first` is `early.after`, at least 1). With [`Then::Record`] the lane's
/// record is then the `recorded` rows before the returned period's end (the runner's
/// rule without lambda_1; with it the record may start later,
/// `StepperConfig::record_early_from`).
pub fn replay(
    early: &EarlyExit,
    lane: usize,
    rows: &[f64],
    first: u32,
    (transient, recorded): (u32, u32),
) -> Option<Retired> {
    let mut track = Track::default();
    for (k, row) in rows.chunks_exact(STATE_DIM).enumerate() {
        let period = first + k as u32;
        if !early.looks_at(period, transient) {
            return None;
        }
        let x: State = row.try_into().ok()?;
        if x.iter().any(|v| !v.is_finite()) {
            // The lane froze: the runner stops looking at it.
            return None;
        }
        if let Some(a) = early.recognise.observe(lane, &mut track, &x) {
            return Some(Retired {
                attractor: a,
                periods: match early.then {
                    Then::Retire => period,
                    Then::Record => period + recorded,
                },
            });
        }
    }
    None
}
