//! How a run is cut to fit a device: lanes per chunk from the buffer and dispatch
//! limits, as a pure function so that a 10M-lane run on an 80 GB GPU can be planned and
//! checked anywhere.
//!
//! A chunk's buffers are sized for its lanes: per lane the constants, the state and the
//! records of one time slice (`periods_per_slice` Poincare points); each buffer must fit
//! the device's storage-binding and buffer limits and the runner's own cap
//! ([`MAX_CHUNK_BUFFER_BYTES`], which also bounds the host's staging copies), and one
//! dispatch of a chunk may have at most `max_compute_workgroups_per_dimension`
//! workgroups. A run of any lane count is then chunks run one after the other, and the
//! GPU memory the runner holds is bounded by the cap whatever the lane count.

use jeffcott_core::error::{Error, Result};

/// Largest buffer the runner allocates, whatever the device allows: keeps host staging
/// memory sane on devices with multi-GiB limits.
pub const MAX_CHUNK_BUFFER_BYTES: u64 = 256 << 20;

/// The device limits a plan obeys (from `wgpu::Limits`, or smaller ones to test the
/// cutting on a small device).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlanLimits {
    /// Largest storage buffer binding [bytes].
    pub max_storage_buffer_binding_size: u64,
    /// Largest buffer [bytes].
    pub max_buffer_size: u64,
    /// Workgroups per dispatch dimension.
    pub max_compute_workgroups_per_dimension: u32,
}

impl PlanLimits {
    /// The limits of a wgpu device.
    pub fn of(limits: &wgpu::Limits) -> Self {
        PlanLimits {
            max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
            max_buffer_size: limits.max_buffer_size,
            max_compute_workgroups_per_dimension: limits.max_compute_workgroups_per_dimension,
        }
    }

    /// The limits with each one lowered to `other`'s where that is smaller.
    pub fn min(self, other: PlanLimits) -> Self {
        PlanLimits {
            max_storage_buffer_binding_size: self
                .max_storage_buffer_binding_size
                .min(other.max_storage_buffer_binding_size),
            max_buffer_size: self.max_buffer_size.min(other.max_buffer_size),
            max_compute_workgroups_per_dimension: self
                .max_compute_workgroups_per_dimension
                .min(other.max_compute_workgroups_per_dimension),
        }
    }
}

/// Bytes per lane of each per-lane buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LaneBytes {
    /// One lane's packed constants.
    pub consts: u64,
    /// One lane's packed state.
    pub lane: u64,
    /// One lane's records of one time slice (periods_per_slice x record length x Real).
    pub records_per_slice: u64,
    /// One lane's tangent vector (lambda_1 variant; 0 otherwise).
    pub tangent: u64,
}

/// How a run of `lanes` lanes is cut.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChunkPlan {
    /// Lanes per chunk (the last chunk may have fewer).
    pub lanes_per_chunk: usize,
    /// Chunks, run one after the other.
    pub chunks: usize,
    /// Workgroups of one full chunk's dispatch.
    pub workgroups_per_dispatch: u32,
    /// The largest per-lane buffer of a full chunk [bytes].
    pub largest_buffer_bytes: u64,
    /// GPU memory of a full chunk's buffers, staging copies included [bytes].
    pub device_bytes: u64,
}

/// Cuts a run of `lanes` lanes into chunks that fit `limits` with workgroups of
/// `workgroup` invocations; `cap` bounds the lanes per chunk further (tests and
/// schedules). Errors name what cannot fit.
pub fn chunk_plan(
    lanes: usize,
    bytes: LaneBytes,
    workgroup: u32,
    limits: PlanLimits,
    cap: Option<usize>,
) -> Result<ChunkPlan> {
    let max_bytes = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
        .min(MAX_CHUNK_BUFFER_BYTES);
    let per_lane = bytes
        .records_per_slice
        .max(bytes.consts)
        .max(bytes.lane)
        .max(bytes.tangent)
        .max(1);
    let by_bytes = (max_bytes / per_lane) as usize;
    if by_bytes == 0 {
        return Err(Error::invalid(
            "periods_per_slice",
            bytes.records_per_slice,
            format!(
                "one lane's records of a slice take {} bytes, over the device's buffer \
                 limit of {max_bytes} bytes: use shorter slices",
                bytes.records_per_slice
            ),
        ));
    }
    let by_dispatch = limits.max_compute_workgroups_per_dimension as usize * workgroup as usize;
    if by_dispatch == 0 {
        return Err(Error::invalid(
            "max_compute_workgroups_per_dimension",
            limits.max_compute_workgroups_per_dimension,
            "the device allows no workgroups",
        ));
    }
    let mut n = by_bytes.min(by_dispatch);
    if let Some(c) = cap {
        n = n.min(c.max(1));
    }
    let n = n.min(lanes.max(1));
    let lanes_u = n as u64;
    // Records and lanes have a staging copy each (read back after every slice).
    let device_bytes = lanes_u
        * (bytes.consts + 2 * bytes.lane + 2 * bytes.records_per_slice + bytes.tangent.max(1));
    Ok(ChunkPlan {
        lanes_per_chunk: n,
        chunks: lanes.div_ceil(n),
        workgroups_per_dispatch: (n as u32).div_ceil(workgroup),
        largest_buffer_bytes: lanes_u * per_lane,
        device_bytes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The H100's limits as wgpu reported them (docs/gpu.md).
    const H100: PlanLimits = PlanLimits {
        max_storage_buffer_binding_size: 2047 << 20,
        max_buffer_size: 4094 << 20,
        max_compute_workgroups_per_dimension: 65535,
    };

    /// f64 lanes: 18 constants of 8 bytes and a 104-byte state are the layout's sizes
    /// in round figures; the plan only needs upper bounds.
    fn f64_bytes(periods_per_slice: u64, lyapunov: bool) -> LaneBytes {
        let rec = if lyapunov { 9 } else { 8 };
        LaneBytes {
            consts: 160,
            lane: 112,
            records_per_slice: periods_per_slice * rec * 8,
            tangent: if lyapunov { 64 } else { 0 },
        }
    }

    #[test]
    fn ten_million_f64_lanes_fit_an_h100_in_bounded_chunks() {
        let lanes = 10_000_000;
        for (pps, lyapunov) in [(32, false), (32, true), (282, false), (1, false)] {
            let b = f64_bytes(pps, lyapunov);
            let p = chunk_plan(lanes, b, 64, H100, None).unwrap();
            assert!(p.lanes_per_chunk * p.chunks >= lanes);
            assert!(p.lanes_per_chunk * (p.chunks - 1) < lanes);
            assert!(p.workgroups_per_dispatch <= 65535, "{p:?}");
            assert!(p.largest_buffer_bytes <= MAX_CHUNK_BUFFER_BYTES, "{p:?}");
            // Every buffer of a chunk fits, and the chunk's GPU memory is bounded by
            // the cap (a handful of buffers of at most 256 MiB) whatever the lane count.
            assert!(p.device_bytes <= 8 * MAX_CHUNK_BUFFER_BYTES, "{p:?}");
            // 1M lanes x 32 recorded periods of f64 are 2 GiB of records: several chunks.
            if pps == 32 {
                assert!(p.chunks >= 10 && p.lanes_per_chunk < 1 << 20, "{p:?}");
            }
        }
    }

    #[test]
    fn dispatch_limit_cuts_chunks_when_buffers_would_allow_more() {
        // Tiny records (one period, f32), so only 65535 x 64 lanes per dispatch binds.
        let b = LaneBytes {
            consts: 16,
            lane: 16,
            records_per_slice: 32,
            tangent: 0,
        };
        let big = PlanLimits {
            max_storage_buffer_binding_size: u64::MAX,
            max_buffer_size: u64::MAX,
            max_compute_workgroups_per_dimension: 65535,
        };
        let p = chunk_plan(10_000_000, b, 64, big, None).unwrap();
        assert_eq!(p.lanes_per_chunk, 65535 * 64);
        assert_eq!(p.chunks, 3);
        assert_eq!(p.workgroups_per_dispatch, 65535);
    }

    #[test]
    fn small_limits_give_many_chunks_and_impossible_ones_name_the_field() {
        let small = PlanLimits {
            max_storage_buffer_binding_size: 4096,
            max_buffer_size: 1 << 20,
            max_compute_workgroups_per_dimension: 2,
        };
        let p = chunk_plan(1000, f64_bytes(4, false), 64, small, None).unwrap();
        // 4096 bytes / 256 bytes of records per lane = 16 lanes per chunk.
        assert_eq!((p.lanes_per_chunk, p.chunks), (16, 63));
        let p = chunk_plan(1000, f64_bytes(1, false), 64, small, Some(7)).unwrap();
        assert_eq!((p.lanes_per_chunk, p.chunks), (7, 143));
        let e = chunk_plan(1000, f64_bytes(100, false), 64, small, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("periods_per_slice"), "{e}");
        let none = PlanLimits {
            max_compute_workgroups_per_dimension: 0,
            ..small
        };
        let e = chunk_plan(10, f64_bytes(1, false), 64, none, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("max_compute_workgroups_per_dimension"), "{e}");
    }
}
