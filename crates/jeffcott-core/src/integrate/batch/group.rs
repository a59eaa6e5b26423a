//! Groups of batches stepped together ([`group_macro_step_tangent`]): after every
//! batch's first pass, the lanes still in their macro step are packed into full batches
//! for each further pass, each lane's arithmetic that of the single-batch stepper.

use super::{
    BATCH, BatchConsts, batch_finish, batch_k, batch_macro_step_tangent, batch_pass, lanes,
};
use crate::integrate::lane::{Lane, LaneConsts, MacroStep, macro_step_begin};
use crate::integrate::tangent::Tangent;
use crate::model::STATE_DIM;
use crate::real::Real;

/// What [`group_macro_step_tangent`] keeps between macro steps so that it allocates
/// nothing per step: each batch's macro step in progress and lock-step index, and the
/// queues of lanes still in their macro step.
pub struct GroupScratch<R> {
    ks: Vec<Option<u32>>,
    parts: Vec<[MacroStep<R>; BATCH]>,
    /// Each batch's trial sub-steps of the lanes handed to the scalar stepper.
    trials: Vec<[[R; STATE_DIM]; BATCH]>,
    /// (k, batch, lane) of the lanes still in their macro step after a pass.
    queue: Vec<(u32, usize, usize)>,
    next: Vec<(u32, usize, usize)>,
}

impl<R> Default for GroupScratch<R> {
    fn default() -> Self {
        GroupScratch {
            ks: Vec::new(),
            parts: Vec::new(),
            trials: Vec::new(),
            queue: Vec::new(),
            next: Vec::new(),
        }
    }
}

/// [`batch_macro_step_tangent`] for a group of batches at once, with full batches for
/// the sub-steps after the first: every batch takes its first pass,
/// then the lanes still in their macro step (in contact: R sub-steps; the rest are done)
/// are packed into batches of [`BATCH`] for each further pass, so a pass never computes
/// 8 lanes for one. Each lane's arithmetic is that of the single-batch stepper (lanes
/// never mix in a SIMD operation), so the result is the same to the bit
/// (tests/ensemble_cpu.rs compares with the scalar stepper). Inlined, like the batch
/// stepper, into the caller compiled for the CPU's instruction set.
#[inline(always)]
pub fn group_macro_step_tangent<R: Real, const M: usize, const AVX512: bool>(
    bcs: &[BatchConsts<R>],
    lcs: &[[LaneConsts<R>; BATCH]],
    lane: &mut [[Lane<R>; BATCH]],
    tan: &mut [[Tangent<R, M>; BATCH]],
    scratch: &mut GroupScratch<R>,
) {
    if let ([bc], [lc], [lane], [tan]) = (bcs, lcs, &mut *lane, &mut *tan) {
        // One batch: nothing to pack across, and no gathering.
        batch_macro_step_tangent::<R, M, AVX512>(bc, lc, lane, tan);
        return;
    }
    let (g, Some(first)) = (lane.len(), lane.first()) else {
        return;
    };
    let filler = [macro_step_begin(&first[0]); BATCH];
    let GroupScratch {
        ks,
        parts,
        trials,
        queue,
        next,
    } = scratch;
    // Plain loops, not `extend` over an iterator adapter (`Map::fold`, compiled out of
    // line without the batch's instruction set: 5 % of the f64 bench in perf). Each
    // batch's macro steps are written in place (the scratch only resized), not built on
    // the stack and pushed.
    ks.clear();
    parts.resize(g, filler);
    for (b, part) in lane.iter().zip(parts.iter_mut()) {
        ks.push(batch_k(b));
        for l in 0..BATCH {
            part[l] = macro_step_begin(&b[l]);
        }
    }
    // Read only where a pass wrote them (lanes handed over), so never cleared.
    trials.resize(g, [[R::lit(0.0); STATE_DIM]; BATCH]);
    queue.clear();
    for b in 0..g {
        let Some(k) = ks[b] else { continue };
        let mut active: [bool; BATCH] =
            lanes(|l| !lane[b][l].status.is_frozen() && lane[b][l].k == k);
        batch_pass::<R, M, AVX512>(
            &bcs[b],
            &lanes(|l| &lcs[b][l]),
            k,
            &mut parts[b],
            &mut active,
            &mut tan[b],
            &mut trials[b],
        );
        queue.extend((0..BATCH).filter(|&l| active[l]).map(|l| (k, b, l)));
    }
    while !queue.is_empty() {
        // Same k together (live lanes share one; this only guards the packing).
        if queue.iter().any(|q| q.0 != queue[0].0) {
            queue.sort_unstable();
        }
        next.clear();
        let mut at = 0;
        while at < queue.len() {
            let k = queue[at].0;
            let end = at
                + queue[at..]
                    .iter()
                    .take(BATCH)
                    .take_while(|q| q.0 == k)
                    .count();
            pack_pass::<R, M, AVX512>(bcs, lcs, tan, parts, trials, &queue[at..end], k, next);
            at = end;
        }
        std::mem::swap(queue, next);
    }
    for b in 0..g {
        if let Some(k) = ks[b] {
            batch_finish(&lcs[b], &mut lane[b], &mut tan[b], k, &parts[b], &trials[b]);
        }
    }
}

/// One pass of a pack of up to [`BATCH`] queued lanes `pack` (batch and lane of each, all
/// at index `k`) of [`group_macro_step_tangent`]: the lanes gathered into one batch,
/// passed, and scattered back; those still in their macro step go to `next`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn pack_pass<R: Real, const M: usize, const AVX512: bool>(
    bcs: &[BatchConsts<R>],
    lcs: &[[LaneConsts<R>; BATCH]],
    tan: &mut [[Tangent<R, M>; BATCH]],
    parts: &mut [[MacroStep<R>; BATCH]],
    trials: &mut [[[R; STATE_DIM]; BATCH]],
    pack: &[(u32, usize, usize)],
    k: u32,
    next: &mut Vec<(u32, usize, usize)>,
) {
    // Slots past the pack repeat its last lane, inactive (computed, not kept).
    let slot = |i: usize| pack[i.min(pack.len() - 1)];
    // The slots' constants by reference, and their batch constants picked
    // from their batches' rows: copying each slot's `LaneConsts` (392 bytes in
    // f64) and transposing them held 6 % of the f64 bench's samples (perf).
    let lc: [&LaneConsts<R>; BATCH] = lanes(|i| {
        let (_, b, l) = slot(i);
        &lcs[b][l]
    });
    let mut part: [MacroStep<R>; BATCH] = lanes(|i| {
        let (_, b, l) = slot(i);
        parts[b][l]
    });
    let mut tn: [Tangent<R, M>; BATCH] = lanes(|i| {
        let (_, b, l) = slot(i);
        tan[b][l]
    });
    let mut active: [bool; BATCH] = lanes(|i| i < pack.len());
    let mut tr = [[R::lit(0.0); STATE_DIM]; BATCH];
    batch_pass::<R, M, AVX512>(
        &BatchConsts::pick(bcs, &lanes(|i| (slot(i).1, slot(i).2)), &lc),
        &lc,
        k,
        &mut part,
        &mut active,
        &mut tn,
        &mut tr,
    );
    for (i, &(_, b, l)) in pack.iter().enumerate() {
        parts[b][l] = part[i];
        tan[b][l] = tn[i];
        if active[i] {
            next.push((k, b, l));
        } else if part[i].s < R::lit(1.0) {
            // Handed over to the scalar stepper.
            trials[b][l] = tr[i];
        }
    }
}
