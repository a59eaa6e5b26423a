//! The bookkeeping of refilled slots under early exit: which lane a free slot
//! takes next, what a slot's lane does at the end of each period (its record, its
//! tangent's growth, recognition, whether it ends), and the run's result from the lanes
//! that ended. One definition for both backends: the CPU's refilled batches
//! (`cpu::run_early`) and a GPU's slot pool (`jeffcott_gpu::GpuRunner::run_pool`, driven
//! from the analysis crate), so both end the same lanes at the same periods with the
//! same records, final states and counters.

use super::early::{EarlyExit, EarlyResult, Retired, Then, Track};
use super::{EnsembleResult, EnsembleSpec, LaneResult, lane_lambda1, mask_frozen_records_from};
use crate::integrate::lane::{Counters, Status};
use crate::model::{STATE_DIM, State};

/// A lane that ended: what the run's result takes from it.
#[derive(Clone, Debug)]
pub struct Ended {
    /// Index of the lane in the ensemble.
    pub lane: usize,
    /// Its row of the result (NaN record rows for a retired lane; lambda_1 NaN without
    /// lambda_1 and for a retired or frozen lane).
    pub result: LaneResult,
    /// Whether and where it was recognised.
    pub retired: Option<Retired>,
    /// Periods before its record: the transient, or fewer when recorded early.
    pub record_from: u32,
}

/// A slot's lane and what it has gathered.
#[derive(Clone, Debug)]
pub struct SlotLane {
    /// Index of the lane in the ensemble.
    pub lane: usize,
    /// Periods integrated.
    periods: u32,
    /// Its recognition so far.
    track: Track,
    /// Its recorded points.
    points: Vec<f64>,
    /// Periods before its record: the transient, or from the period it was recognised
    /// at ([`Then::Record`]; later with lambda_1, `StepperConfig::record_early_from`).
    record_from: u32,
    /// The attractor it was recognised on ([`Then::Record`]: it is recording).
    recognised: Option<u32>,
    /// With lambda_1, the period its tangent vector starts afresh at
    /// ([`crate::integrate::lane::StepperConfig::tangent_from`] of its record): it carries
    /// none before.
    tangent_from: u32,
    /// The tangent's growth over each recorded period (with lambda_1).
    norms: Vec<f64>,
}

/// The lanes of a run (a range of the ensemble's lanes) through refilled slots.
pub struct Refill<'a> {
    spec: &'a EnsembleSpec,
    early: &'a EarlyExit<'a>,
    queue: std::ops::Range<usize>,
    lambda1: bool,
}

impl<'a> Refill<'a> {
    /// Lanes `lanes` of `spec` under `early`, with lambda_1 when `lambda1`.
    pub fn new(
        spec: &'a EnsembleSpec,
        early: &'a EarlyExit<'a>,
        lanes: std::ops::Range<usize>,
        lambda1: bool,
    ) -> Self {
        Refill {
            spec,
            early,
            queue: lanes,
            lambda1,
        }
    }

    /// The next lane for a free slot (in lane order), `None` when none is left.
    pub fn next_lane(&mut self) -> Option<SlotLane> {
        let spec = self.spec;
        self.queue.next().map(|i| SlotLane {
            lane: i,
            periods: 0,
            track: Track::default(),
            points: Vec::with_capacity(spec.recorded as usize * STATE_DIM),
            record_from: spec.transient,
            recognised: None,
            tangent_from: spec.stepper.tangent_from(spec.transient),
            norms: Vec::with_capacity(if self.lambda1 {
                spec.recorded as usize
            } else {
                0
            }),
        })
    }

    /// The end of a period of slot lane `s`: `x` its state then, `frozen` whether its
    /// status is frozen, `norm` its tangent's growth over the period (lambda_1 runs; 1
    /// for a frozen lane, as `run_lane_lambda1` has it). Returns `Some` when the lane
    /// ends here (recognised and retired, recorded to its end, or frozen), with whether
    /// it was recognised.
    pub fn period_end(
        &self,
        s: &mut SlotLane,
        x: &State,
        frozen: bool,
        norm: f64,
    ) -> Option<Option<Retired>> {
        let (spec, early) = (self.spec, self.early);
        let record_len = spec.recorded as usize * STATE_DIM;
        s.periods += 1;
        if s.periods > s.record_from {
            s.points.extend_from_slice(x);
            if self.lambda1 {
                s.norms.push(norm);
            }
        }
        // Recognised at this period: retire now, or record from here on.
        let now = (s.recognised.is_none() && !frozen && early.looks_at(s.periods, spec.transient))
            .then(|| early.recognise.observe(s.lane, &mut s.track, x))
            .flatten();
        if let (Some(a), Then::Record) = (now, early.then) {
            // With lambda_1 the record waits for the tangent to align
            // (`StepperConfig::record_early_from`), which starts afresh here if it was
            // not running yet.
            let k = s.periods;
            s.record_from = spec
                .stepper
                .record_early_from(k, spec.transient, self.lambda1);
            s.tangent_from = s.tangent_from.min(k);
            s.recognised = Some(a);
        }
        // A lane recorded early counts the periods of its whole record, also when it
        // froze during it (as the replay of a GPU's records counts it).
        let recorded_early = s.recognised.map(|a| Retired {
            attractor: a,
            periods: s.record_from + spec.recorded,
        });
        if frozen {
            // A frozen lane repeats the state it froze at in every later record, as in
            // `run_lane` (the host masks those rows afterwards).
            while s.points.len() < record_len {
                s.points.extend_from_slice(x);
            }
            Some(recorded_early)
        } else if let (Some(a), Then::Retire) = (now, early.then) {
            Some(Some(Retired {
                attractor: a,
                periods: s.periods,
            }))
        } else {
            (s.periods == s.record_from + spec.recorded).then_some(recorded_early)
        }
    }

    /// Periods slot lane `s` can run from where it stands before the first period end
    /// at which [`Refill::period_end`] could end it other than by a freeze (where it
    /// could be recognised, or its record ends): a GPU slice of at most this many
    /// periods stops no later than the CPU would stop the lane. At least 1.
    pub fn quiet_periods(&self, s: &SlotLane) -> u32 {
        // With lambda_1 a slice also stops where the lane's tangent starts, so that it
        // starts afresh there ([`Refill::tangent_starts`]).
        let end = if self.lambda1 && s.periods < s.tangent_from {
            s.tangent_from
        } else {
            s.record_from + self.spec.recorded
        };
        let looks = if s.recognised.is_some() {
            None
        } else {
            let q = (s.periods + 1).max(self.early.after);
            self.early.looks_at(q, self.spec.transient).then_some(q)
        };
        looks
            .map_or(end, |q| q.min(end))
            .saturating_sub(s.periods)
            .max(1)
    }

    /// Whether slot lane `s` needs its tangent vector over its next period (with
    /// lambda_1, from [`SlotLane`]'s `tangent_from` on); before, a batch may step it
    /// without one.
    pub fn needs_tangent(&self, s: &SlotLane) -> bool {
        self.lambda1 && s.periods >= s.tangent_from
    }

    /// Whether slot lane `s`, after a period end that did not end it, starts its
    /// tangent vector afresh now: a slot pool whose kernel carries tangents all along
    /// writes the start vector into its slot here.
    pub fn tangent_starts(&self, s: &SlotLane) -> bool {
        self.lambda1 && s.tangent_from > 0 && s.periods == s.tangent_from
    }

    /// What a lane that ended at [`Refill::period_end`] leaves: `x`, `status` and
    /// `counters` are its state, status and counters at that period's end.
    pub fn ended(
        &self,
        s: SlotLane,
        retired: Option<Retired>,
        x: State,
        status: Status,
        counters: Counters,
    ) -> Ended {
        let gone = retired.is_some() && self.early.then == Then::Retire;
        let points = if gone {
            vec![f64::NAN; self.spec.recorded as usize * STATE_DIM]
        } else {
            s.points
        };
        let lambda1 = if self.lambda1 && !gone {
            lane_lambda1(&s.norms, self.spec.lanes[s.lane].omega, status)
        } else {
            f64::NAN
        };
        Ended {
            lane: s.lane,
            result: LaneResult {
                points,
                final_state: x,
                status,
                counters,
                lambda1,
            },
            retired,
            record_from: s.record_from,
        }
    }
}

/// The run's result from every lane's [`Ended`] (in any order): lanes in index order,
/// frozen lanes' records masked from the period they froze at.
pub fn early_result(spec: &EnsembleSpec, mut ended: Vec<Ended>, lambda1: bool) -> EarlyResult {
    ended.sort_unstable_by_key(|e| e.lane);
    let n = ended.len();
    let mut res = EnsembleResult::with_capacity(n, spec.recorded, lambda1);
    let mut retired = Vec::with_capacity(n);
    let mut record_from = Vec::with_capacity(n);
    for e in ended {
        e.result.append_to(&mut res);
        retired.push(e.retired);
        record_from.push(e.record_from);
    }
    mask_frozen_records_from(spec, &mut res, |i| record_from[i]);
    EarlyResult {
        result: res,
        retired,
    }
}
