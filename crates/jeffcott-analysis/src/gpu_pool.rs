//! Early exit on a GPU: a slot pool (`jeffcott_gpu::pool`) driven by the
//! same per-slot bookkeeping as the CPU's refilled batches
//! (`jeffcott_core::ensemble::refill`). Each time slice runs until the first period end
//! at which some slot's lane could be recognised or end its record
//! (`Refill::quiet_periods`), so no lane runs past the period where the CPU stops it;
//! the host then reads every slot's points and lane, ends the lanes the rule ends and
//! refills their slots. Each lane's arithmetic is the kernel's (the CPU's to the bit in
//! f64), so a GPU ends the same lanes at the same periods with the same records, final
//! states, statuses and counters as the CPU (`tests/early_exit.rs`).

use jeffcott_core::control::Control;
use jeffcott_core::ensemble::EnsembleSpec;
use jeffcott_core::ensemble::early::{EarlyExit, EarlyResult};
use jeffcott_core::ensemble::refill::{Ended, Refill, SlotLane, early_result};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::{LAMBDA1_START, Lane, LaneConsts};
use jeffcott_core::model::{STATE_DIM, State};
use jeffcott_gpu::pool::{PoolHost, PoolLane};
use jeffcott_gpu::{GpuReal, GpuRunner, Schedule};
use rayon::prelude::*;

/// Slots of a GPU's early-exit pool at most: enough lanes to fill a large GPU
/// (an H100 runs 132 x 2048 threads at once), few enough that the lanes waiting for a
/// slot keep the pool full while most of a run retires.
pub const POOL_SLOTS: usize = 1 << 18;

/// The host side of the pool: the run's lanes through [`Refill`].
struct EarlyPool<'a> {
    spec: &'a EnsembleSpec,
    refill: Refill<'a>,
    slots: Vec<Option<SlotLane>>,
    ended: Vec<Ended>,
    lambda1: bool,
    ctl: Control<'a>,
    /// Lane-periods of the lanes that ended (progress counts a lane's full periods).
    done: u64,
    /// Slots whose lanes start their tangent afresh after the last slice
    /// (`Refill::tangent_starts`).
    restarts: Vec<usize>,
}

impl<R: GpuReal> PoolHost<R> for EarlyPool<'_> {
    fn fill(&mut self, slot: usize) -> Option<PoolLane<R>> {
        self.slots[slot] = self.refill.next_lane();
        self.slots[slot].as_ref().map(|s| PoolLane {
            consts: self.spec.lane_consts(s.lane),
            lane: self.spec.initial_lane(s.lane),
            tangent: self.lambda1.then_some([R::lit(LAMBDA1_START); STATE_DIM]),
        })
    }

    fn next_slice(&mut self) -> Result<u32> {
        if self.ctl.cancel.is_set() {
            return Err(Error::Interrupted {
                committed: 0,
                total: 1,
            });
        }
        Ok(self
            .slots
            .iter()
            .flatten()
            .map(|s| self.refill.quiet_periods(s))
            .min()
            .unwrap_or(0))
    }

    fn after_slice(
        &mut self,
        periods: u32,
        records: &[R],
        lanes: &[Lane<R>],
    ) -> Result<Vec<usize>> {
        // The slots the slice ran (the pool dispatches the lowest ones only).
        let n = lanes.len();
        let dim = STATE_DIM + self.lambda1 as usize;
        let refill = &self.refill;
        // Slots are independent: their rows are read in parallel (a large pool's
        // recognition is most of the host's work per slice).
        let ended: Vec<(usize, Ended)> = self.slots[..n]
            .par_iter_mut()
            .enumerate()
            .filter_map(|(i, slot)| {
                let s = slot.as_mut()?;
                let lane = &lanes[i];
                for p in 0..periods as usize {
                    let row = &records[(p * n + i) * dim..][..dim];
                    let x: State = std::array::from_fn(|j| row[j].to_f64());
                    let last = p + 1 == periods as usize;
                    // The status is known at the slice's end only; a lane that froze
                    // earlier in the slice records its frozen state from then on (as the
                    // CPU pads its record), and no period before the last can end a lane
                    // but a freeze (`Refill::quiet_periods`), so only the last row needs
                    // it.
                    let frozen = last && lane.status.is_frozen();
                    let norm = if dim > STATE_DIM {
                        row[STATE_DIM].to_f64()
                    } else {
                        1.0
                    };
                    if let Some(retired) = refill.period_end(s, &x, frozen, norm) {
                        if !last {
                            return Some(Err(Error::Gpu {
                                message: format!(
                                    "pool slot {i}: its lane ended at period {} of a \
                                     {periods}-period slice (the slice should have stopped there)",
                                    p + 1
                                ),
                            }));
                        }
                        let s = slot.take().expect("occupied slot");
                        let e = refill.ended(s, retired, x, lane.status, lane.counters);
                        return Some(Ok((i, e)));
                    }
                }
                None
            })
            .collect::<Result<_>>()?;
        let per_lane = (self.spec.transient + self.spec.recorded) as u64;
        self.done += ended.len() as u64 * per_lane;
        (self.ctl.progress)(self.done, self.spec.lanes.len() as u64 * per_lane);
        self.restarts = self.slots[..n]
            .iter()
            .enumerate()
            .filter(|(_, s)| s.as_ref().is_some_and(|s| refill.tangent_starts(s)))
            .map(|(i, _)| i)
            .collect();
        let freed = ended.iter().map(|(i, _)| *i).collect();
        self.ended.extend(ended.into_iter().map(|(_, e)| e));
        Ok(freed)
    }

    fn moved(&mut self, from: usize, to: usize) {
        self.slots.swap(from, to);
    }

    fn tangent_restarts(&mut self) -> Vec<(usize, [R; STATE_DIM])> {
        let fresh = [R::lit(LAMBDA1_START); STATE_DIM];
        std::mem::take(&mut self.restarts)
            .into_iter()
            .map(|s| (s, fresh))
            .collect()
    }
}

/// Runs `spec` with early exit on `runner` in a slot pool of at most `max_slots` slots:
/// the result is the CPU's `cpu::run_early` result.
pub fn run_early_gpu<R: GpuReal>(
    spec: &EnsembleSpec,
    runner: &GpuRunner,
    early: &EarlyExit,
    lambda1: bool,
    max_slots: usize,
    ctl: Control,
) -> Result<EarlyResult> {
    let n = spec.lanes.len();
    if n == 0 {
        return Ok(early_result(spec, Vec::new(), lambda1));
    }
    let full = spec.transient + spec.recorded;
    let mut slots = n.min(max_slots.max(1));
    // Slices of about `LANE_STEPS_PER_SLICE` lane-steps, as plain runs take.
    let per_period = slots as u64 * spec.stepper.steps_per_period.max(1) as u64;
    let max_periods = (super::backend::LANE_STEPS_PER_SLICE / per_period.max(1))
        .clamp(1, full.max(1) as u64) as u32;
    let schedule = Schedule::new(0, max_periods, max_periods);
    slots = slots.min(runner.plan::<R>(slots, &schedule, lambda1)?.lanes_per_chunk);
    let mut host = EarlyPool {
        spec,
        refill: Refill::new(spec, early, 0..n, lambda1),
        slots: (0..slots).map(|_| None).collect(),
        ended: Vec::with_capacity(n),
        lambda1,
        ctl,
        done: 0,
        restarts: Vec::new(),
    };
    let (shared, features) = kernel_shape::<R>(spec);
    let n_steps = spec.stepper.steps_per_period;
    let kernel = (lambda1, features, shared, n_steps);
    runner.run_pool::<R>(slots, kernel, max_periods, &mut host)?;
    Ok(early_result(spec, host.ended, lambda1))
}

/// The constants' fields every lane of `spec` has equal (the GPU's kernel reads those at
/// one address for every slot: `jeffcott_gpu::layout::shared_fields`) and the kernel code
/// its lanes need (the exact free-flight step, the machine variants' terms), found over the lanes'
/// distinct parameter sets and speeds, which alone decide a lane's constants.
fn kernel_shape<R: GpuReal>(spec: &EnsembleSpec) -> (u32, jeffcott_gpu::shader::Features) {
    let mut seen = std::collections::HashSet::new();
    let distinct: Vec<LaneConsts<R>> = (0..spec.lanes.len())
        .filter(|&i| seen.insert((spec.lanes[i].param_set, spec.lanes[i].omega.to_bits())))
        .map(|i| spec.lane_consts(i))
        .collect();
    (
        jeffcott_gpu::layout::shared_fields(&distinct),
        jeffcott_gpu::shader::Features::of(&distinct),
    )
}
