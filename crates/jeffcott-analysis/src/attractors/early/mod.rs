//! Early exit for the attractor-labelling studies: lanes that are recognised
//! on an attractor already catalogued retire, the rest run their whole transient and
//! record and are classified as without it (`jeffcott_core::ensemble::early`).
//!
//! **The rule** ([`Recogniser`]): from period `early_exit_after` on, a lane's Poincare
//! point at the end of every period is compared with the catalogue. A periodic attractor
//! is recognised when `early_exit_streak` points in a row, and at least two whole cycles,
//! each lie within the recognition tolerance
//! ([`CatalogueBuilder::recogniser`](crate::catalogue::CatalogueBuilder::recogniser): a tenth of the cycle's diameter, at most 0.45
//! of its distance to any other attractor, at least the identity tolerance below that
//! cap; a cycle within four identity tolerances of another attractor, the floor at most
//! 1 um in f32 too, or a period-2n cycle that close to itself shifted by n points, is not
//! recognised) of the cycle
//! point expected next, in its cyclic order (the analogue of the
//! recurrence cells of Datseris and Wagemakers, Chaos 32, 023104 (2022)). An aperiodic
//! attractor (a cloud) is recognised when `early_exit_streak` points in a row lie within
//! a tenth of its diameter of its reference cloud (at most 0.45 of its distance to any
//! other attractor), but only in studies that catalogue in rounds ([`catalogue_groups`])
//! and only once it is confirmed: lanes still in a long transient form clouds that look
//! like attractors (docs/early-exit.md), so a cloud ([`Known::Cloud`]) is first watched,
//! and recognised after three lanes (`CLOUD_CONFIRMATIONS`) that stayed in
//! it for the streak ended on it and none ended elsewhere. A miss starts the count
//! again. Only attractors are catalogued, never saddles, so a lane that lingers near an
//! unstable orbit is not matched by it; a lane that passes close to an attractor and
//! leaves it again breaks its streak.
//!
//! **Rounds** ([`catalogue_lanes`]): a unit's lanes run in rounds spread over the unit:
//! every 64th lane first (no catalogue yet: these run full length and make the first
//! catalogue), then every 8th of the others, then the rest, each round seeing the
//! attractors of the rounds before it (an attractor with a small basin missed by the
//! first rounds costs its lanes their early exit, never their label). Each round's
//! recogniser is fixed while it runs, so the labels depend on the unit's lanes alone, not
//! on threads, backends or other units: resumable and shardable as before. The labels
//! and entries then come from the catalogue rebuilt in lane order
//! (`CatalogueBuilder::rebuilt_in_lane_order`), as a pass without rounds builds it.
//!
//! The parts: [`Recogniser`] and [`ByGroup`] (the rule, `recogniser`), the rounds that
//! build a catalogue with early exit (`rounds`), lanes labelled against a finished
//! catalogue (`label`), and lanes that record from where they are recognised
//! (`records`).

mod label;
mod recogniser;
mod records;
mod rounds;

pub use label::{label_lanes, labelled_unit};
pub use recogniser::{ByGroup, Known, Recogniser, Seen, UNSEEN};
pub use records::{GroupRecognition, record_lanes, records_by_group};
pub use rounds::{EarlyLanes, MIN_GROUP, catalogue_groups, catalogue_lanes, rounds};

use jeffcott_core::ensemble::early::Retired;
use jeffcott_core::error::Result;
use serde::{Deserialize, Serialize};

/// What early exit saved, per unit or summed over a study (run.json's `early_exit`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct EarlySaved {
    /// Lanes run.
    pub lanes: u64,
    /// Lanes that retired early.
    pub retired: u64,
    /// Periods integrated by all lanes.
    pub periods_run: u64,
    /// Periods the same lanes integrate without early exit.
    pub periods_full: u64,
}

impl EarlySaved {
    /// The count of lanes that ran `full` periods each unless `retired` says otherwise.
    pub fn of(retired: &[Option<Retired>], full: u32) -> EarlySaved {
        EarlySaved {
            lanes: retired.len() as u64,
            retired: retired.iter().filter(|r| r.is_some()).count() as u64,
            periods_run: jeffcott_core::ensemble::early::periods_run(retired, full),
            periods_full: retired.len() as u64 * full as u64,
        }
    }

    /// Adds `more` to `total` (`None`: nothing ran with early exit yet).
    pub fn accumulate(total: &mut Option<EarlySaved>, more: Option<EarlySaved>) {
        if let Some(m) = more {
            total.get_or_insert_with(EarlySaved::default).add(&m);
        }
    }

    /// Adds another count.
    pub fn add(&mut self, o: &EarlySaved) {
        self.lanes += o.lanes;
        self.retired += o.retired;
        self.periods_run += o.periods_run;
        self.periods_full += o.periods_full;
    }

    /// As four numbers (a unit's `early` array).
    pub fn to_array(self) -> Vec<f64> {
        [
            self.lanes,
            self.retired,
            self.periods_run,
            self.periods_full,
        ]
        .map(|v| v as f64)
        .to_vec()
    }

    /// From a unit's `early` array.
    pub fn from_array(a: &[f64]) -> EarlySaved {
        let v = |i: usize| a.get(i).copied().unwrap_or(0.0) as u64;
        EarlySaved {
            lanes: v(0),
            retired: v(1),
            periods_run: v(2),
            periods_full: v(3),
        }
    }
}

/// What early exit saved in a committed unit (nothing when it ran without: no `early`).
pub fn unit_saved(unit: &crate::run::Unit) -> Result<Option<EarlySaved>> {
    if !unit.has("early") {
        return Ok(None);
    }
    Ok(Some(EarlySaved::from_array(unit.f64s("early")?)))
}
