//! A pool of lane slots refilled between time slices: the GPU's side of early exit
//! (`jeffcott_core::ensemble::refill` on the host). The kernel is the same; the host keeps a fixed number of slots busy,
//! reads back every slice's Poincare points and each slot's lane, and writes the next
//! lanes into the slots whose lanes ended. What a slot's lane does at a period's end
//! (recognised, recorded, ended) is decided by a [`PoolHost`]
//! (`jeffcott_core::ensemble::refill` in the analysis crate's backend), which also picks
//! each slice's length so that no lane runs past the period at which the CPU would
//! stop it: a lane that ends is read back exactly where it ended, counters included.
//!
//! Every slot's `Lane::period` is the pool's period count at the start of each slice,
//! and the slice records every period, so a slot's records are its lane's points
//! whatever period of its own life the lane is at (the kernel only uses the count to
//! place records and to stop). Empty slots hold a frozen lane with N = 0, which the
//! kernel does not step: it only writes its record each period. Once no lane is left to fill
//! a slot with, the lanes still running move to the lowest slots and only those are
//! dispatched and read back: on a GPU a warp runs as long as its slowest lane, so the
//! few lanes that run whole would otherwise keep most warps busy to the end.

use super::*;
use bytemuck::Zeroable;
use jeffcott_core::integrate::lane::Status;

/// A lane for a slot of the pool.
#[derive(Clone, Copy, Debug)]
pub struct PoolLane<R: 'static> {
    /// Its constants.
    pub consts: LaneConsts<R>,
    /// Its start state.
    pub lane: Lane<R>,
    /// Its start tangent vector (the lambda_1 kernel variant).
    pub tangent: Option<[R; STATE_DIM]>,
}

/// The host side of a slot pool ([`GpuRunner::run_pool`]).
pub trait PoolHost<R: GpuReal> {
    /// The lane for free slot `slot`, `None` to leave it empty.
    fn fill(&mut self, slot: usize) -> Option<PoolLane<R>>;
    /// Forcing periods of the next time slice (cut to the pool's buffers), 0 when the
    /// run is done; an error (e.g. cancelled) stops the run.
    fn next_slice(&mut self) -> Result<u32>;
    /// What a slice of `periods` periods produced: the record of slot `s` at the
    /// slice's `p`-th period end is `records[(p * slots + s) * dim..][..dim]` (the state,
    /// then in the lambda_1 variant the tangent's growth over the period), and `lanes`
    /// holds each slot's lane at the slice's end, for the `slots = lanes.len()` slots
    /// the slice ran (the others are empty). Returns the slots whose lanes ended, which
    /// are then filled anew.
    fn after_slice(&mut self, periods: u32, records: &[R], lanes: &[Lane<R>])
    -> Result<Vec<usize>>;
    /// The lane in slot `from` now runs in the empty slot `to` (the pool compacts its
    /// running lanes once nothing is left to fill slots with).
    fn moved(&mut self, from: usize, to: usize);
    /// After [`PoolHost::after_slice`] (and the refills), the slots whose lanes start
    /// their tangent vector afresh here, with the vector (lambda_1 variant): the kernel
    /// carries every slot's tangent from its fill, the host counts it from here on.
    fn tangent_restarts(&mut self) -> Vec<(usize, [R; STATE_DIM])>;
}

impl GpuRunner {
    /// Runs a pool of `slots` lane slots, with the lambda_1 kernel variant when
    /// `lyapunov`, the code of `features` (every lane the host fills must need no other,
    /// or the run ends with an error) and the variant that reads
    /// the constants' fields of mask `shared` at one address for every slot
    /// ([`crate::layout::shared_fields`]; every lane the host fills must have those
    /// fields equal, or the run ends with an error), in time slices of at most
    /// `max_periods` forcing periods, until `host` says it is done (see the module docs).
    /// `n` is the lanes' macro steps per period (the forcing table's size where the
    /// kernel takes one; a lane of more is an error). Returns the number of dispatches.
    pub fn run_pool<R: GpuReal>(
        &self,
        slots: usize,
        (lyapunov, features, shared, n): (bool, crate::shader::Features, u32, u32),
        max_periods: u32,
        host: &mut dyn PoolHost<R>,
    ) -> Result<u64> {
        if slots == 0 {
            return Ok(0);
        }
        if max_periods == 0 {
            return Err(Error::invalid("max_periods", 0, "must be >= 1"));
        }
        let schedule = Schedule::new(0, max_periods, max_periods);
        let chunk = self.plan::<R>(slots, &schedule, lyapunov)?.lanes_per_chunk;
        if chunk < slots {
            return Err(Error::invalid(
                "slots",
                slots,
                format!("a slot pool must fit one chunk of this device ({chunk} lanes)"),
            ));
        }
        let key = (lyapunov, features, shared);
        let caps = (slots, max_periods, self.forcing_len(key, n));
        self.with_kernel::<R, _>(key, caps, |pipeline, bufs| {
            self.pool_slices(pipeline, bufs, slots, key, max_periods, host)
        })
    }

    /// The time slices of [`GpuRunner::run_pool`] on the kernel's buffers.
    fn pool_slices<R: GpuReal>(
        &self,
        pipeline: &wgpu::ComputePipeline,
        bufs: &Buffers,
        slots: usize,
        (lyapunov, features, shared): (bool, crate::shader::Features, u32),
        max_periods: u32,
        host: &mut dyn PoolHost<R>,
    ) -> Result<u64> {
        let w = SlotWriter::<R> {
            queue: self.gpu.queue(),
            bufs,
            lyapunov,
            features,
            _real: std::marker::PhantomData,
        };
        // The pool's period count: every slot's `Lane::period` at the next slice's start.
        let mut period = 0u32;
        let (mut consts, mut occupied) = w.fill_all(slots, host)?;
        // With shared fields the kernel reads slot 0's for every slot: each lane's must
        // equal the first lane's, and an empty slot holds the first lane's constants
        // (it is told apart by its frozen lane), so that slot 0 always holds them.
        let first = (shared != 0)
            .then(|| {
                consts
                    .iter()
                    .zip(&occupied)
                    .find(|(_, o)| **o)
                    .map(|(c, _)| *c)
            })
            .flatten();
        if first.is_some() {
            for (s, c) in consts.iter_mut().enumerate() {
                share_consts::<R>(shared, first, s, occupied[s], c)?;
            }
            w.write_consts(&consts)?;
        }
        // Slots dispatched: those below `active` (the rest are empty).
        let mut active = slots;
        let mut dispatches = 0u64;
        loop {
            let periods = host.next_slice()?.min(max_periods);
            if periods == 0 {
                return Ok(dispatches);
            }
            let end = period.checked_add(periods).ok_or_else(|| {
                Error::invalid("periods", periods, "the pool's period count overflows u32")
            })?;
            let params = Params {
                n_lanes: active as u32,
                period_begin: period,
                period_end: end,
                record_from: period,
                probe: PROBE_ITERS,
                pad: [0; 3],
            };
            w.queue
                .write_buffer(&bufs.params, 0, bytemuck::bytes_of(&params));
            dispatches += self.dispatch_slice(pipeline, bufs, active)?;
            let mut back = self.read_pool_slice::<R>(bufs, lyapunov, periods, active)?;
            period = end;
            for s in host.after_slice(periods, &back.records, &back.unpacked)? {
                check_slot(s, active)?;
                let p = host.fill(s);
                occupied[s] = p.is_some();
                let (mut c, l, t) = pack(p, period, features, s)?;
                share_consts::<R>(shared, first, s, occupied[s], &mut c)?;
                consts[s] = c;
                w.write(s, &c, &l, &t);
            }
            if lyapunov {
                for (s, t) in host.tangent_restarts() {
                    check_slot(s, active)?;
                    // Also in the copy read back, which the compaction below moves.
                    back.tangents[s * STATE_DIM..][..STATE_DIM].copy_from_slice(&t);
                    w.write_tangent(s, &t);
                }
            }
            w.compact(&mut back, &mut consts, &mut occupied, active, period, host);
            active = occupied
                .iter()
                .rposition(|&o| o)
                .map_or(0, |i| i + 1)
                .max(1);
        }
    }

    /// Copies a slice's records, lanes and (lambda_1) tangents of the first `active`
    /// slots to the host and reads them back.
    fn read_pool_slice<R: GpuReal>(
        &self,
        bufs: &Buffers,
        lyapunov: bool,
        periods: u32,
        active: usize,
    ) -> Result<SliceBack<R>> {
        let rec_bytes = periods as usize * active * shader::record_dim(lyapunov) * size_of::<R>();
        let lane_bytes = active * size_of::<R::Lane>();
        let tangent_bytes = active * STATE_DIM * size_of::<R>();
        let mut enc = self
            .gpu
            .device()
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("pool readback"),
            });
        let mut copy = |from: &wgpu::Buffer, to: &wgpu::Buffer, bytes: usize| {
            enc.copy_buffer_to_buffer(from, 0, to, 0, Some(bytes as u64));
        };
        copy(&bufs.records, &bufs.records_staging, rec_bytes);
        copy(&bufs.lanes, &bufs.lanes_staging, lane_bytes);
        if lyapunov {
            copy(&bufs.tangents, &bufs.tangents_staging, tangent_bytes);
        }
        self.gpu.queue().submit(Some(enc.finish()));
        let records: Vec<R> = self.read_back(&bufs.records_staging, rec_bytes)?;
        let lanes: Vec<R::Lane> = self.read_back(&bufs.lanes_staging, lane_bytes)?;
        let tangents: Vec<R> = if lyapunov {
            self.read_back(&bufs.tangents_staging, tangent_bytes)?
        } else {
            Vec::new()
        };
        let unpacked = lanes
            .iter()
            .enumerate()
            .map(|(s, g)| {
                R::unpack_lane(g).ok_or_else(|| Error::Gpu {
                    message: format!("pool slot {s} came back with an unknown status"),
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(SliceBack {
            records,
            lanes,
            tangents,
            unpacked,
        })
    }
}

/// What a slice left on the device, read back: the records, each slot's lane as the
/// kernel stores it and unpacked, and (lambda_1) each slot's tangent.
struct SliceBack<R: GpuReal> {
    records: Vec<R>,
    lanes: Vec<R::Lane>,
    tangents: Vec<R>,
    unpacked: Vec<Lane<R>>,
}

/// Refuses a slot the host names beyond the `active` slots the slice ran.
fn check_slot(s: usize, active: usize) -> Result<()> {
    if s >= active {
        return Err(Error::invalid("slot", s, format!("the pool runs {active}")));
    }
    Ok(())
}

/// A slot's constants, lane (its period count set to the pool's) and tangent as the
/// kernel reads them; an empty slot (`None`) holds a frozen lane with N = 0, which the
/// kernel records each period and does not step (frozen, because with shared constants
/// the kernel reads the first slot's N for every slot).
/// A lane that needs code the pool's kernel (`features`) lacks is an error naming its
/// slot `s`.
#[allow(clippy::type_complexity)]
fn pack<R: GpuReal>(
    p: Option<PoolLane<R>>,
    period: u32,
    features: crate::shader::Features,
    s: usize,
) -> Result<(R::Consts, R::Lane, [R; STATE_DIM])> {
    if let Some(p) = &p {
        let needs = crate::shader::Features::lane(&p.consts);
        if !features.covers(needs) {
            return Err(Error::invalid(
                "slot constants",
                s,
                format!(
                    "the lane needs kernel code {needs:?} that the pool's kernel ({features:?}) lacks"
                ),
            ));
        }
    }
    let (consts, mut lane, tangent) = match p {
        Some(p) => (
            R::pack_consts(&p.consts),
            R::pack_lane(&p.lane),
            p.tangent.unwrap_or([R::lit(0.0); STATE_DIM]),
        ),
        None => (
            R::Consts::zeroed(),
            R::pack_lane(&empty_lane()),
            [R::lit(0.0); STATE_DIM],
        ),
    };
    R::set_period(&mut lane, period);
    Ok((consts, lane, tangent))
}

/// The lane of an empty slot: zero, frozen (`Status::NonFinite`).
fn empty_lane<R: GpuReal>() -> Lane<R> {
    let mut lane = Lane::new(&[0.0; STATE_DIM], 0.0);
    lane.status = Status::NonFinite;
    lane
}

/// Slot `s`'s constants `c` where the pool's kernel reads the fields of mask `shared`
/// (none: `c` as it is) from slot 0: an occupied slot's must equal `first`, the first
/// lane's, in those fields (else an error); an empty slot gets `first`'s.
fn share_consts<R: GpuReal>(
    shared: u32,
    first: Option<R::Consts>,
    s: usize,
    occupied: bool,
    c: &mut R::Consts,
) -> Result<()> {
    if shared == 0 {
        return Ok(());
    }
    let first =
        first.ok_or_else(|| Error::invalid("slot constants", s, "no first lane to share with"))?;
    if occupied {
        check_shared::<R>(shared, s, c, &first)
    } else {
        *c = first;
        Ok(())
    }
}

/// An error unless constants `c` of slot `s` equal `first`, the first lane's, in every
/// field of mask `shared` (the pool runs the kernel variant that reads those at one
/// address for every slot).
fn check_shared<R: GpuReal>(shared: u32, s: usize, c: &R::Consts, first: &R::Consts) -> Result<()> {
    let differs = (0..crate::layout::CONST_FIELDS.len()).any(|k| {
        shared & (1 << k) != 0
            && crate::layout::const_field_bytes::<R>(c, k)
                != crate::layout::const_field_bytes::<R>(first, k)
    });
    if differs {
        return Err(Error::invalid(
            "slot constants",
            s,
            "differ from the first lane's in a field the pool's kernel reads as shared",
        ));
    }
    Ok(())
}

/// Writes slots into the kernel's buffers.
struct SlotWriter<'a, R> {
    queue: &'a wgpu::Queue,
    bufs: &'a Buffers,
    lyapunov: bool,
    features: crate::shader::Features,
    _real: std::marker::PhantomData<R>,
}

impl<R: GpuReal> SlotWriter<'_, R> {
    /// Fills every slot from `host` at period 0 and writes them all at once: the slots'
    /// constants and which are occupied.
    #[allow(clippy::type_complexity)]
    fn fill_all(
        &self,
        slots: usize,
        host: &mut dyn PoolHost<R>,
    ) -> Result<(Vec<R::Consts>, Vec<bool>)> {
        let mut consts = Vec::with_capacity(slots);
        let mut lanes = Vec::with_capacity(slots);
        let mut tangents = Vec::with_capacity(slots);
        let mut occupied = vec![false; slots];
        for (s, occ) in occupied.iter_mut().enumerate() {
            let p = host.fill(s);
            *occ = p.is_some();
            let (c, l, t) = pack(p, 0, self.features, s)?;
            consts.push(c);
            lanes.push(l);
            tangents.push(t);
        }
        let b = self.bufs;
        b.write_consts::<R>(self.queue, &consts)?;
        self.queue
            .write_buffer(&b.lanes, 0, bytemuck::cast_slice(&lanes));
        if self.lyapunov {
            self.queue
                .write_buffer(&b.tangents, 0, bytemuck::cast_slice(&tangents));
        }
        Ok((consts, occupied))
    }

    /// Writes every slot's constants (slot 0 holds the first lane's, also the uniform's).
    fn write_consts(&self, consts: &[R::Consts]) -> Result<()> {
        self.bufs.write_consts::<R>(self.queue, consts)
    }

    /// Writes slot `s`: its constants, lane and (lambda_1) tangent.
    fn write(&self, s: usize, c: &R::Consts, l: &R::Lane, t: &[R]) {
        let at = |size: usize| (s * size) as u64;
        let b = self.bufs;
        self.queue
            .write_buffer(&b.consts, at(size_of::<R::Consts>()), bytemuck::bytes_of(c));
        self.queue
            .write_buffer(&b.lanes, at(size_of::<R::Lane>()), bytemuck::bytes_of(l));
        if self.lyapunov {
            self.write_tangent(s, t);
        }
    }

    /// Writes slot `s`'s tangent vector.
    fn write_tangent(&self, s: usize, t: &[R]) {
        let at = (s * STATE_DIM * size_of::<R>()) as u64;
        self.queue
            .write_buffer(&self.bufs.tangents, at, bytemuck::cast_slice(t));
    }

    /// Once nothing is left to fill slots with, the running lanes move down, each from
    /// the highest occupied slot into the lowest empty one, with the state, counters
    /// and tangent the slice left it.
    fn compact(
        &self,
        back: &mut SliceBack<R>,
        consts: &mut [R::Consts],
        occupied: &mut [bool],
        active: usize,
        period: u32,
        host: &mut dyn PoolHost<R>,
    ) {
        let (mut lo, mut hi) = (0, active);
        loop {
            while lo < hi && occupied[lo] {
                lo += 1;
            }
            while hi > lo && !occupied[hi - 1] {
                hi -= 1;
            }
            if hi <= lo + 1 {
                break;
            }
            let from = hi - 1;
            R::set_period(&mut back.lanes[from], period);
            let t = if self.lyapunov {
                &back.tangents[from * STATE_DIM..][..STATE_DIM]
            } else {
                &[][..]
            };
            consts[lo] = consts[from];
            self.write(lo, &consts[from], &back.lanes[from], t);
            occupied.swap(lo, from);
            host.moved(from, lo);
        }
    }
}
