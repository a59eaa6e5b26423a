//! The GPU backend of the ensemble stepper: the lane kernel
//! (`jeffcott_core::integrate::lane::WGSL`, assembled by [`shader`]) through wgpu.
//!
//! One invocation advances one lane (`integrate::lane`, mirrored function by function
//! in the kernel). The host splits the work in two directions:
//!
//! - **chunks of lanes**, so that every buffer stays inside the device's
//!   `max_storage_buffer_binding_size` / `max_buffer_size` and every dispatch inside
//!   `max_compute_workgroups_per_dimension` (docs/gpu.md). Chunks run one after the
//!   other on the same (cached) buffers.
//! - **time slices** of at most `periods_per_slice` forcing periods per dispatch, so no
//!   dispatch runs long enough for a watchdog (Windows TDR: 2 s) and the host can
//!   report progress. Between slices the lane state (state, contact mode, k, status,
//!   counters, periods completed) stays in the lane buffer on the GPU; only the Poincare
//!   points of the slice, written by the kernel at the end of each recorded period, are
//!   read back, plus one counter of lanes that did not finish the slice. A driver may
//!   cut an invocation short: Mesa's llvmpipe stops every loop of an invocation after
//!   65535 loop iterations in all (a few thousand macro steps). The kernel commits a
//!   macro step only when it ran to completion, and the host dispatches the slice again
//!   until no lane is left behind; each dispatch resumes every lane where it stopped.
//!
//! Neither split changes a result: a lane's arithmetic does not depend on where the
//! host cut the work (tested bit for bit in `tests/gpu.rs`).
//!
//! The pipeline is built once per device and precision and kept, with its buffers
//! (grown when a run needs more), in the [`GpuRunner`] (docs/architecture.md).

#![warn(missing_docs)]

pub mod anatomy;
pub mod device;
pub mod layout;
pub mod plan;
pub mod pool;
pub mod shader;
pub mod spirv;
pub mod stats;
pub mod unroll;

pub use device::{
    AdapterSummary, DeviceRequest, GpuDevice, SHADER_PATH_VAR, ShaderPath, list_adapters,
};
pub use layout::GpuReal;

use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::{Lane, LaneConsts};
use jeffcott_core::model::STATE_DIM;
use layout::{PROBE_ITERS, Params};
use std::mem::size_of;
use std::sync::Mutex;

/// How the host cuts a run into dispatches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Schedule {
    /// Forcing periods integrated before the first recorded one.
    pub transient: u32,
    /// Forcing periods whose end states (Poincare points) are recorded.
    pub recorded: u32,
    /// Forcing periods per dispatch (the time slice), >= 1.
    pub periods_per_slice: u32,
    /// Upper bound on lanes per chunk on top of the device limits (`None`: limits only).
    pub max_lanes_per_chunk: Option<usize>,
    /// The lambda_1 variant's tangent vectors (re)start from the given start vectors at
    /// this period (a time slice ends there): the CPU's lanes carry none before it
    /// (`StepperConfig::tangent_from`). 0: from the start.
    pub tangent_from: u32,
}

impl Schedule {
    /// `transient` + `recorded` periods in slices of `periods_per_slice`, chunks as large
    /// as the device allows.
    pub fn new(transient: u32, recorded: u32, periods_per_slice: u32) -> Self {
        Schedule {
            transient,
            recorded,
            periods_per_slice,
            max_lanes_per_chunk: None,
            tangent_from: 0,
        }
    }
}

/// Per-lane outcomes and, with the lambda_1 variant, per-lane tangent growths over the
/// recorded periods and each lane's final (unit) tangent vector (both empty without it).
pub type LyapunovOutcomes<R> = (Vec<LaneOutcome<R>>, Vec<Vec<f64>>, Vec<[R; STATE_DIM]>);

/// What one lane produced.
#[derive(Clone, Debug)]
pub struct LaneOutcome<R> {
    /// The state at the end of each recorded period, in order (widened exactly to f64).
    /// A lane frozen by its status repeats the state it was frozen at.
    pub poincare: Vec<[f64; STATE_DIM]>,
    /// The final lane: state, contact mode, k, status, counters.
    pub lane: Lane<R>,
}

/// Progress of a run, reported after every time slice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SliceReport {
    /// Lane-periods integrated so far.
    pub lane_periods_done: u64,
    /// Lane-periods in the whole run.
    pub lane_periods_total: u64,
    /// Dispatches so far (one per time slice and chunk, more where the driver cut
    /// invocations short).
    pub dispatches: u64,
    /// Seconds so far from each dispatch's submission to its completion: the GPU's
    /// work, without the host's packing, uploads and record readbacks.
    pub dispatch_s: f64,
}

/// How long a [`GpuRunner::run_anatomy`] took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AnatomyTimes {
    /// The whole run, the pipeline's compilation excluded: uploads, dispatches and
    /// readbacks.
    pub wall_s: f64,
    /// The dispatches alone (`SliceReport::dispatch_s`): what the part costs the GPU,
    /// which the host's transfers would hide for a fast part.
    pub dispatch_s: f64,
}

/// Dispatches of one time slice before the runner gives up. A dispatch in which some
/// lane cannot commit a single macro step is an error at once; otherwise every dispatch
/// makes progress, so only a broken driver gets here.
const MAX_PASSES_PER_SLICE: u32 = 1_000_000;

/// Buffers for one chunk of up to `lanes_cap` lanes and `slots_cap` periods per slice.
struct Buffers {
    lanes_cap: usize,
    slots_cap: u32,
    params: wgpu::Buffer,
    consts: wgpu::Buffer,
    /// The first lane's constants as the uniform `shared_consts` (the GPU form reads
    /// the fields every lane shares there).
    shared_consts: wgpu::Buffer,
    lanes: wgpu::Buffer,
    records: wgpu::Buffer,
    records_staging: wgpu::Buffer,
    lanes_staging: wgpu::Buffer,
    unfinished: wgpu::Buffer,
    unfinished_staging: wgpu::Buffer,
    tangents: wgpu::Buffer,
    tangents_staging: wgpu::Buffer,
    /// The lean path's forcing table (`forcing_table`: entries of two reals; one
    /// unused entry where the kernel has none).
    forcing: wgpu::Buffer,
    forcing_cap: usize,
    bind_group: wgpu::BindGroup,
}

impl Buffers {
    /// Writes `consts` to the lane constants from slot 0 on, and the first of them to
    /// the uniform the GPU form reads shared fields from (every lane of a chunk equals
    /// it in those fields); with a forcing table (`forcing_cap` > 1), the first lane's
    /// table too (every lane of the run shares its N and phi0). An error where the table
    /// does not fit (a slot pool given one N and filled with lanes of another).
    fn write_consts<R: GpuReal>(&self, queue: &wgpu::Queue, consts: &[R::Consts]) -> Result<()> {
        queue.write_buffer(&self.consts, 0, bytemuck::cast_slice(consts));
        if let Some(first) = consts.first() {
            let bytes = layout::shared_consts_bytes::<R>(first);
            queue.write_buffer(&self.shared_consts, 0, &bytes);
            if self.forcing_cap > 1 {
                let table = layout::forcing_table::<R>(first);
                if table.len() > self.forcing_cap {
                    return Err(Error::invalid(
                        "steps-per-period",
                        (table.len() - 1) / 2,
                        format!(
                            "exceeds the {} the kernel's buffers were made for",
                            (self.forcing_cap - 1) / 2
                        ),
                    ));
                }
                queue.write_buffer(&self.forcing, 0, bytemuck::cast_slice(&table));
            }
        }
        Ok(())
    }
}

/// Where a chunk's read-back goes: its lanes' outcomes and, with the lambda_1 variant,
/// their tangent growths and final tangent vectors.
struct ChunkOut<'a, R> {
    lanes: &'a mut [LaneOutcome<R>],
    norms: Option<&'a mut [Vec<f64>]>,
    tangents: Option<&'a mut [[R; STATE_DIM]]>,
}

/// The compiled kernel of one precision and its buffers.
struct Kernel {
    pipeline: wgpu::ComputePipeline,
    buffers: Option<Buffers>,
}

/// Which lane kernel a run takes: (lambda_1, what its lanes need beyond the article's model,
/// the fields every lane shares); the device decides the rest ([`GpuRunner::kernel_variant`]).
type KernelKey = (bool, shader::Features, u32);

/// A compiled kernel and its buffers, built on first use.
type KernelSlot = std::sync::Arc<Mutex<Option<Kernel>>>;

/// Runs lanes on one device; builds each precision's pipeline (plain, or with the
/// lambda_1 tangent vector) on first use and reuses it (and its buffers) for every
/// later run.
pub struct GpuRunner {
    gpu: GpuDevice,
    /// The limits runs are planned for: the device's, or smaller ones
    /// ([`GpuRunner::with_limits`]).
    limits: plan::PlanLimits,
    /// Each precision's (`true`: f64) kernels by variant (`slot`).
    kernels: Mutex<std::collections::HashMap<(bool, KernelKey), KernelSlot>>,
}

impl std::fmt::Debug for GpuRunner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuRunner")
            .field("gpu", &self.gpu)
            .finish_non_exhaustive()
    }
}

/// Checks that `field` has as many entries (`got`) as there are `what` (`want`).
fn same_count(field: &str, want: usize, what: &str, got: usize) -> Result<()> {
    if got == want {
        return Ok(());
    }
    Err(Error::invalid(
        field,
        got,
        format!("{want} {what} but {got} {field}"),
    ))
}

/// Checks a run's lanes and schedule; returns its periods in all and the outcomes
/// before it (each lane as given, no points yet).
fn run_start<R: GpuReal>(
    consts: &[LaneConsts<R>],
    init: &[Lane<R>],
    schedule: &Schedule,
) -> Result<(u32, Vec<LaneOutcome<R>>)> {
    same_count("lanes", consts.len(), "lane constants", init.len())?;
    if schedule.periods_per_slice == 0 {
        return Err(Error::invalid("periods_per_slice", 0, "must be >= 1"));
    }
    let total = schedule
        .transient
        .checked_add(schedule.recorded)
        .ok_or_else(|| {
            Error::invalid(
                "periods",
                schedule.recorded,
                "transient + recorded overflows u32",
            )
        })?;
    let out = init
        .iter()
        .map(|lane| LaneOutcome {
            poincare: Vec::with_capacity(schedule.recorded as usize),
            lane: *lane,
        })
        .collect();
    Ok((total, out))
}

fn gpu_err(what: &str, e: impl std::fmt::Display) -> Error {
    Error::Gpu {
        message: format!("{what}: {e}"),
    }
}

impl GpuRunner {
    /// A runner on `gpu`. Nothing is compiled until the first run of each precision.
    pub fn new(gpu: GpuDevice) -> Self {
        GpuRunner {
            limits: plan::PlanLimits::of(&gpu.limits()),
            gpu,
            kernels: Default::default(),
        }
    }

    /// A runner on `gpu` that plans its chunks for `limits` where they are smaller than
    /// the device's: to run a small share of a large GPU, or to exercise the cutting of
    /// a huge run on a small device (tests/gpu.rs plans many chunks on lavapipe).
    pub fn with_limits(gpu: GpuDevice, limits: plan::PlanLimits) -> Self {
        let mut r = GpuRunner::new(gpu);
        r.limits = r.limits.min(limits);
        r
    }

    /// The limits this runner plans for.
    pub fn limits(&self) -> plan::PlanLimits {
        self.limits
    }

    /// The device this runner uses.
    pub fn gpu(&self) -> &GpuDevice {
        &self.gpu
    }

    /// The kernel this runner's device runs: `lyapunov` or not, with the code the lanes'
    /// `features` need (the exact free-flight step, an offset stator, directional
    /// supports, the contact laws), reading the constants' fields of mask `shared` at one address for every
    /// lane, f32's division and sqrt through f64 where the device has SHADER_F64, and the
    /// lean path's forcing table where the lanes share N and phi0 ([`shader::Variant`]).
    pub fn kernel_variant(
        &self,
        lyapunov: bool,
        features: shader::Features,
        shared: u32,
    ) -> shader::Variant {
        shader::Variant::on_device(lyapunov, self.gpu.supports_f64())
            .with_features(features)
            .with_consts_each_step(self.gpu.consts_each_step())
            .with_shared_fields(shared)
            .with_forcing_table(self.gpu.forcing_table())
    }

    /// Entries of the forcing table a run of kernel `key` with `n` macro steps per
    /// period needs (2N + 1; 1, an unused one, where its kernel has no table).
    fn forcing_len(&self, (lyapunov, features, shared): KernelKey, n: u32) -> usize {
        let table = self
            .kernel_variant(lyapunov, features, shared)
            .forcing_table;
        1 + 2 * n as usize * usize::from(table)
    }

    fn slot<R: GpuReal>(&self, key: KernelKey) -> Result<KernelSlot> {
        let mut kernels = self.kernels.lock().map_err(|_| Error::Gpu {
            message: "a previous GPU run panicked".into(),
        })?;
        Ok(kernels
            .entry((R::WGSL_NAME == "f64", key))
            .or_default()
            .clone())
    }

    /// An error where the device cannot run precision `R` (f64 without SHADER_F64).
    fn check_precision<R: GpuReal>(&self) -> Result<()> {
        if R::WGSL_NAME == "f64" && !self.gpu.supports_f64() {
            return Err(Error::NoAdapter {
                reason: format!(
                    "adapter {} has no SHADER_F64; use f32 precision",
                    self.gpu.adapter().name
                ),
            });
        }
        Ok(())
    }

    fn build_pipeline<R: GpuReal>(
        &self,
        (lyapunov, features, shared): KernelKey,
    ) -> Result<wgpu::ComputePipeline> {
        self.check_precision::<R>()?;
        // Fail early with naga's readable report rather than wgpu's summary.
        let v = self.kernel_variant(lyapunov, features, shared);
        shader::validate::<R>(v, shader::capabilities::<R>(v))
            .map_err(|e| gpu_err("lane kernel does not validate", e))?;
        self.pipeline_for::<R>(
            "lane kernel",
            v,
            &shader::source::<R>(v),
            shader::ENTRY_POINT,
        )
    }

    /// The compute pipeline of entry point `entry` of `source` (the kernel, or the
    /// kernel with the anatomy's entry points) for variant `v`, with the kernel's
    /// bindings.
    fn pipeline_for<R: GpuReal>(
        &self,
        label: &str,
        v: shader::Variant,
        source: &str,
        entry: &str,
    ) -> Result<wgpu::ComputePipeline> {
        // An explicit layout, the same for both variants: the plain kernel never touches
        // `tangents` (binding 5), and an automatic layout might or might not list it.
        let bindings = layout::BINDINGS.map(|(b, kind)| {
            let ty = match kind {
                layout::Binding::Uniform => wgpu::BufferBindingType::Uniform,
                layout::Binding::ReadOnly => wgpu::BufferBindingType::Storage { read_only: true },
                layout::Binding::ReadWrite => wgpu::BufferBindingType::Storage { read_only: false },
            };
            (b, ty)
        });
        let (pipeline, _) = self.gpu.compute_pipeline(
            label,
            source,
            shader::capabilities::<R>(v),
            entry,
            (shader::WORKGROUP_SIZE, 1, 1),
            &bindings,
        )?;
        Ok(pipeline)
    }

    /// How a run of `lanes` lanes of this precision is cut on this runner's limits.
    pub fn plan<R: GpuReal>(
        &self,
        lanes: usize,
        schedule: &Schedule,
        lyapunov: bool,
    ) -> Result<plan::ChunkPlan> {
        let rec_dim = shader::record_dim(lyapunov);
        let bytes = plan::LaneBytes {
            consts: size_of::<R::Consts>() as u64,
            lane: size_of::<R::Lane>() as u64,
            records_per_slice: schedule.periods_per_slice as u64
                * (rec_dim * size_of::<R>()) as u64,
            tangent: if lyapunov {
                (STATE_DIM * size_of::<R>()) as u64
            } else {
                0
            },
        };
        plan::chunk_plan(
            lanes,
            bytes,
            shader::WORKGROUP_SIZE,
            self.limits,
            schedule.max_lanes_per_chunk,
        )
    }

    fn buffers<R: GpuReal>(
        &self,
        pipeline: &wgpu::ComputePipeline,
        (lanes_cap, slots_cap, forcing_cap): (usize, u32, usize),
        rec_dim: usize,
    ) -> Buffers {
        let device = self.gpu.device();
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let staging = wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST;
        let make = |label: &str, size: usize, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size as u64,
                usage,
                mapped_at_creation: false,
            })
        };
        let record_bytes = lanes_cap * slots_cap as usize * rec_dim * size_of::<R>();
        let lane_bytes = lanes_cap * size_of::<R::Lane>();
        let params = make(
            "params",
            size_of::<Params>(),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let consts = make("consts", lanes_cap * size_of::<R::Consts>(), storage);
        let shared_consts = make(
            "shared consts",
            layout::shared_consts_bytes::<R>(&bytemuck::Zeroable::zeroed()).len(),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let lanes = make("lanes", lane_bytes, storage | wgpu::BufferUsages::COPY_SRC);
        let records = make(
            "records",
            record_bytes,
            storage | wgpu::BufferUsages::COPY_SRC,
        );
        let records_staging = make("records staging", record_bytes, staging);
        let lanes_staging = make("lanes staging", lane_bytes, staging);
        let unfinished = make(
            "unfinished",
            8,
            wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
        );
        let unfinished_staging = make("unfinished staging", 8, staging);
        // One tangent per lane in the lambda_1 variant, one unused element otherwise.
        let tangent_lanes = if rec_dim > STATE_DIM { lanes_cap } else { 1 };
        let tangent_bytes = tangent_lanes * STATE_DIM * size_of::<R>();
        let tangents = make(
            "tangents",
            tangent_bytes,
            storage | wgpu::BufferUsages::COPY_SRC,
        );
        let tangents_staging = make("tangents staging", tangent_bytes, staging);
        let forcing = make("forcing table", forcing_cap * 2 * size_of::<R>(), storage);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("lanes"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: consts.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: lanes.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: records.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: unfinished.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: tangents.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: shared_consts.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 7,
                    resource: forcing.as_entire_binding(),
                },
            ],
        });
        Buffers {
            lanes_cap,
            slots_cap,
            params,
            consts,
            shared_consts,
            lanes,
            records,
            records_staging,
            lanes_staging,
            unfinished,
            unfinished_staging,
            tangents,
            tangents_staging,
            forcing,
            forcing_cap,
            bind_group,
        }
    }

    /// Maps `len` bytes of `buf` for reading and returns them as `T`s.
    fn read_back<T: bytemuck::Pod>(&self, buf: &wgpu::Buffer, len: usize) -> Result<Vec<T>> {
        let slice = buf.slice(0..len as u64);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        // The map callback runs inside whichever thread's poll claims it: with several
        // devices in one process (parallel tests) our poll can return before the callback
        // has been delivered. Poll again until it arrives (bounded), never assume.
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(600);
        loop {
            self.gpu
                .device()
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(|e| gpu_err("waiting for the GPU", e))?;
            self.gpu.check()?;
            match rx.recv_timeout(std::time::Duration::from_millis(50)) {
                Ok(Ok(())) => break,
                Ok(Err(e)) => return Err(gpu_err("mapping a readback buffer", e)),
                Err(std::sync::mpsc::RecvTimeoutError::Timeout)
                    if std::time::Instant::now() < deadline => {}
                Err(_) => {
                    return Err(Error::Gpu {
                        message: "readback buffer was never mapped (waited 600 s)".into(),
                    });
                }
            }
        }
        let out = {
            let view = slice
                .get_mapped_range()
                .map_err(|e| gpu_err("reading a mapped buffer", e))?;
            // Copies: the mapping need not be aligned for T.
            bytemuck::pod_collect_to_vec::<u8, T>(&view)
        };
        buf.unmap();
        Ok(out)
    }

    /// Runs `consts.len()` lanes from `init` for `schedule.transient +
    /// schedule.recorded` forcing periods and returns, per lane, the Poincare points of
    /// the recorded periods and the final lane.
    pub fn run<R: GpuReal>(
        &self,
        consts: &[LaneConsts<R>],
        init: &[Lane<R>],
        schedule: &Schedule,
    ) -> Result<Vec<LaneOutcome<R>>> {
        self.run_with_progress(consts, init, schedule, &mut |_| true)
    }

    /// [`GpuRunner::run`], calling `progress` after every time slice; when it returns
    /// false the run stops there with [`Error::Interrupted`] (a cancel flag).
    pub fn run_with_progress<R: GpuReal>(
        &self,
        consts: &[LaneConsts<R>],
        init: &[Lane<R>],
        schedule: &Schedule,
        progress: &mut dyn FnMut(SliceReport) -> bool,
    ) -> Result<Vec<LaneOutcome<R>>> {
        Ok(self.run_inner(consts, init, None, schedule, progress)?.0)
    }

    /// [`GpuRunner::run_with_progress`] with the lambda_1 kernel variant: every lane
    /// carries a tangent vector from `tangents` (one per lane), advanced with the state
    /// (saltation at switches) and renormalised at the end of every forcing period. Also
    /// returns, per lane, the tangent's growth (its length before renormalisation) over
    /// each recorded period, in order: the logarithms summed and divided by the recorded
    /// time give lambda_1 ([`jeffcott_core::lyapunov::lambda1_from_norms`]); and each
    /// lane's tangent vector at the end (unit length; the growths times it are the image
    /// of the start vector: a column of a monodromy matrix, `jeffcott_core::orbit`).
    pub fn run_lyapunov_with_progress<R: GpuReal>(
        &self,
        consts: &[LaneConsts<R>],
        init: &[Lane<R>],
        tangents: &[[R; STATE_DIM]],
        schedule: &Schedule,
        progress: &mut dyn FnMut(SliceReport) -> bool,
    ) -> Result<LyapunovOutcomes<R>> {
        same_count("tangents", init.len(), "initial lanes", tangents.len())?;
        self.run_inner(consts, init, Some(tangents), schedule, progress)
    }

    /// Runs `consts.len()` lanes from `init` through part `part` of the kernel's
    /// anatomy ([`anatomy`]) for `schedule`'s periods, cut into chunks and time slices
    /// on buffers as [`GpuRunner::run`] runs the kernel; returns the outcomes and how
    /// long the run and its dispatches took, the pipeline's compilation excluded
    /// ([`AnatomyTimes`]). A timing instrument:
    /// the parts do not integrate the model ([`anatomy::cpu_period`] is what they
    /// compute).
    pub fn run_anatomy<R: GpuReal>(
        &self,
        part: anatomy::Part,
        consts: &[LaneConsts<R>],
        init: &[Lane<R>],
        schedule: &Schedule,
    ) -> Result<(Vec<LaneOutcome<R>>, AnatomyTimes)> {
        self.check_precision::<R>()?;
        let (total, mut out) = run_start(consts, init, schedule)?;
        if consts.is_empty() || total == 0 {
            return Ok((out, AnatomyTimes::default()));
        }
        let v = self.kernel_variant(false, shader::Features::of(consts), 0);
        let pipeline =
            self.pipeline_for::<R>("kernel anatomy", v, &anatomy::source::<R>(v), part.entry())?;
        let chunk = self
            .plan::<R>(consts.len(), schedule, false)?
            .lanes_per_chunk;
        let slots = schedule.periods_per_slice.min(total);
        let bufs = self.buffers::<R>(
            &pipeline,
            (chunk.min(consts.len()), slots, 1),
            shader::record_dim(false),
        );
        let start = std::time::Instant::now();
        let mut dispatch_s = 0.0;
        self.run_chunks(
            &pipeline,
            &bufs,
            (consts, init, None),
            schedule,
            (chunk, slots, total),
            (&mut out, &mut [], &mut []),
            &mut |r| {
                dispatch_s = r.dispatch_s;
                true
            },
        )?;
        let times = AnatomyTimes {
            wall_s: start.elapsed().as_secs_f64(),
            dispatch_s,
        };
        Ok((out, times))
    }

    /// Dispatches one time slice of `n` lanes until every lane has reached the slice's
    /// end (the parameters are written); returns the number of dispatches.
    fn dispatch_slice(
        &self,
        pipeline: &wgpu::ComputePipeline,
        bufs: &Buffers,
        n: usize,
    ) -> Result<u64> {
        let device = self.gpu.device();
        let queue = self.gpu.queue();
        let mut dispatches = 0u64;
        // Dispatch the slice until every lane has reached its end. Once is the
        // rule; a driver that cuts long invocations short (llvmpipe's loop
        // limit, see `loop_budget_left` in the kernel) needs more, and each
        // dispatch resumes every lane at its last committed macro step.
        for pass in 0.. {
            let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("time slice"),
            });
            enc.clear_buffer(&bufs.unfinished, 0, None);
            {
                let mut cp = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("advance_lanes"),
                    timestamp_writes: None,
                });
                cp.set_pipeline(pipeline);
                cp.set_bind_group(0, &bufs.bind_group, &[]);
                cp.dispatch_workgroups((n as u32).div_ceil(shader::WORKGROUP_SIZE), 1, 1);
            }
            enc.copy_buffer_to_buffer(&bufs.unfinished, 0, &bufs.unfinished_staging, 0, None);
            queue.submit(Some(enc.finish()));
            dispatches += 1;
            let left: Vec<u32> = self.read_back(&bufs.unfinished_staging, 8)?;
            if left.first().copied() == Some(0) {
                break;
            }
            if left.get(1).copied().unwrap_or(0) > 0 {
                return Err(Error::Gpu {
                    message: format!(
                        "{} lanes could not complete one macro step within the \
                         driver's loop limit per invocation (llvmpipe: 65535 loop \
                         iterations); lower max_segments",
                        left[1]
                    ),
                });
            }
            if pass >= MAX_PASSES_PER_SLICE {
                return Err(Error::Gpu {
                    message: format!(
                        "{} lanes made no progress in {MAX_PASSES_PER_SLICE} dispatches \
                         of one time slice",
                        left.first().copied().unwrap_or(0)
                    ),
                });
            }
        }
        Ok(dispatches)
    }

    /// Reads back what a time slice of a chunk produced: the records of slots `slots`
    /// (recorded periods) into the chunk's outcomes (and, for the lambda_1 variant, the
    /// tangent's growth into `norms`), and with `last` the final lanes. `start` is the
    /// chunk's first lane (for error messages).
    fn read_slice<R: GpuReal>(
        &self,
        bufs: &Buffers,
        slots: std::ops::Range<u32>,
        last: bool,
        chunk: ChunkOut<'_, R>,
        start: usize,
    ) -> Result<()> {
        let ChunkOut {
            lanes: out,
            norms,
            tangents,
        } = chunk;
        let n = out.len();
        let rec_dim = shader::record_dim(norms.is_some());
        let rec = rec_dim * size_of::<R>();
        let rec_bytes = slots.len() * n * rec;
        let lane_bytes = n * size_of::<R::Lane>();
        let tangent_bytes = n * STATE_DIM * size_of::<R>();
        let tangents = tangents.filter(|_| last);
        if rec_bytes > 0 || last {
            let mut enc =
                self.gpu
                    .device()
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("readback"),
                    });
            if rec_bytes > 0 {
                enc.copy_buffer_to_buffer(
                    &bufs.records,
                    (slots.start as usize * n * rec) as u64,
                    &bufs.records_staging,
                    0,
                    Some(rec_bytes as u64),
                );
            }
            if last {
                enc.copy_buffer_to_buffer(
                    &bufs.lanes,
                    0,
                    &bufs.lanes_staging,
                    0,
                    Some(lane_bytes as u64),
                );
            }
            if tangents.is_some() {
                enc.copy_buffer_to_buffer(
                    &bufs.tangents,
                    0,
                    &bufs.tangents_staging,
                    0,
                    Some(tangent_bytes as u64),
                );
            }
            self.gpu.queue().submit(Some(enc.finish()));
        }
        if rec_bytes > 0 {
            let points: Vec<R> = self.read_back(&bufs.records_staging, rec_bytes)?;
            let mut norms = norms;
            for per_slot in points.chunks_exact(n * rec_dim) {
                for (lane, x) in per_slot.chunks_exact(rec_dim).enumerate() {
                    let mut p = [0.0; STATE_DIM];
                    for (d, v) in p.iter_mut().zip(x) {
                        *d = v.to_f64();
                    }
                    out[lane].poincare.push(p);
                    if let Some(nm) = norms.as_deref_mut() {
                        nm[lane].push(x[STATE_DIM].to_f64());
                    }
                }
            }
        }
        if last {
            let gpu_lanes: Vec<R::Lane> = self.read_back(&bufs.lanes_staging, lane_bytes)?;
            for (i, g) in gpu_lanes.iter().enumerate() {
                out[i].lane = R::unpack_lane(g).ok_or_else(|| Error::Gpu {
                    message: format!("lane {} came back with an unknown status", start + i),
                })?;
            }
        }
        if let Some(t) = tangents {
            let v: Vec<R> = self.read_back(&bufs.tangents_staging, tangent_bytes)?;
            for (d, s) in t.iter_mut().zip(v.chunks_exact(STATE_DIM)) {
                d.copy_from_slice(s);
            }
        }
        Ok(())
    }

    fn run_inner<R: GpuReal>(
        &self,
        consts: &[LaneConsts<R>],
        init: &[Lane<R>],
        tangents: Option<&[[R; STATE_DIM]]>,
        schedule: &Schedule,
        progress: &mut dyn FnMut(SliceReport) -> bool,
    ) -> Result<LyapunovOutcomes<R>> {
        let lyapunov = tangents.is_some();
        // The exact free-flight step where some lane has the map, and so on.
        let features = shader::Features::of(consts);
        let shared = layout::shared_fields(consts);
        let (total, mut out) = run_start(consts, init, schedule)?;
        let n_total = consts.len();
        let mut norms: Vec<Vec<f64>> = if lyapunov {
            vec![Vec::with_capacity(schedule.recorded as usize); n_total]
        } else {
            Vec::new()
        };
        // The start vectors, overwritten by the final ones (kept when nothing runs).
        let mut ends: Vec<[R; STATE_DIM]> = tangents.map_or_else(Vec::new, <[_]>::to_vec);
        if n_total == 0 || total == 0 {
            return Ok((out, norms, ends));
        }
        let chunk = self.plan::<R>(n_total, schedule, lyapunov)?.lanes_per_chunk;
        let slots = schedule.periods_per_slice.min(total);

        let lanes_cap = chunk.min(n_total);
        let key = (lyapunov, features, shared);
        let forcing = self.forcing_len(key, consts[0].n);
        self.with_kernel::<R, _>(key, (lanes_cap, slots, forcing), |pipeline, bufs| {
            self.run_chunks(
                pipeline,
                bufs,
                (consts, init, tangents),
                schedule,
                (chunk, slots, total),
                (&mut out, &mut norms, &mut ends),
                progress,
            )
        })?;
        Ok((out, norms, ends))
    }

    /// Runs `f` with this variant's pipeline (built on first use) and buffers for at
    /// least `lanes_cap` lanes, `slots_cap` periods per slice and `forcing_cap` entries
    /// of the forcing table ([`GpuRunner::forcing_len`]; grown where smaller), holding
    /// the kernel's lock.
    fn with_kernel<R: GpuReal, T>(
        &self,
        key: KernelKey,
        (lanes_cap, slots_cap, forcing_cap): (usize, u32, usize),
        f: impl FnOnce(&wgpu::ComputePipeline, &Buffers) -> Result<T>,
    ) -> Result<T> {
        let rec_dim = shader::record_dim(key.0);
        let slot = self.slot::<R>(key)?;
        let mut guard = slot.lock().map_err(|_| Error::Gpu {
            message: "a previous GPU run panicked".into(),
        })?;
        if guard.is_none() {
            *guard = Some(Kernel {
                pipeline: self.build_pipeline::<R>(key)?,
                buffers: None,
            });
        }
        let kernel = guard.as_mut().ok_or_else(|| Error::Gpu {
            message: "pipeline cache is empty".into(),
        })?;
        let fits = kernel.buffers.as_ref().is_some_and(|b| {
            b.lanes_cap >= lanes_cap && b.slots_cap >= slots_cap && b.forcing_cap >= forcing_cap
        });
        if !fits {
            kernel.buffers = None; // free the old ones first
            let caps = (lanes_cap, slots_cap, forcing_cap);
            kernel.buffers = Some(self.buffers::<R>(&kernel.pipeline, caps, rec_dim));
        }
        match (&kernel.pipeline, &kernel.buffers) {
            (p, Some(b)) => f(p, b),
            _ => Err(Error::Gpu {
                message: "buffers missing".into(),
            }),
        }
    }

    /// The chunks of `run_inner`'s lanes through `bufs`, one after the other, each in
    /// time slices, into `out`, `norms` and `ends`.
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn run_chunks<R: GpuReal>(
        &self,
        pipeline: &wgpu::ComputePipeline,
        bufs: &Buffers,
        (consts, init, tangents): (&[LaneConsts<R>], &[Lane<R>], Option<&[[R; STATE_DIM]]>),
        schedule: &Schedule,
        (chunk, slots, total): (usize, u32, u32),
        (out, norms, ends): (
            &mut [LaneOutcome<R>],
            &mut [Vec<f64>],
            &mut [[R; STATE_DIM]],
        ),
        progress: &mut dyn FnMut(SliceReport) -> bool,
    ) -> Result<()> {
        let lyapunov = tangents.is_some();
        let n_total = consts.len();
        let queue = self.gpu.queue();
        let lane_periods_total = n_total as u64 * total as u64;
        let mut lane_periods_done = 0u64;
        let mut dispatches = 0u64;
        let mut dispatch_s = 0.0;
        for start in (0..n_total).step_by(chunk) {
            let end = (start + chunk).min(n_total);
            let n = end - start;
            let packed_consts: Vec<R::Consts> =
                consts[start..end].iter().map(R::pack_consts).collect();
            let packed_lanes: Vec<R::Lane> = init[start..end].iter().map(R::pack_lane).collect();
            if let Some(t) = tangents {
                queue.write_buffer(&bufs.tangents, 0, bytemuck::cast_slice(&t[start..end]));
            }
            bufs.write_consts::<R>(queue, &packed_consts)?;
            queue.write_buffer(&bufs.lanes, 0, bytemuck::cast_slice(&packed_lanes));
            let mut begin = 0u32;
            while begin < total {
                let mut periods = slots.min(total - begin);
                if let Some(t) = tangents {
                    let from = schedule.tangent_from;
                    if begin < from {
                        // A slice ends where the tangents start.
                        periods = periods.min(from - begin);
                    } else if begin == from && from > 0 {
                        queue.write_buffer(&bufs.tangents, 0, bytemuck::cast_slice(&t[start..end]));
                    }
                }
                let params = Params {
                    n_lanes: n as u32,
                    period_begin: begin,
                    period_end: begin + periods,
                    record_from: schedule.transient,
                    probe: PROBE_ITERS,
                    pad: [0; 3],
                };
                queue.write_buffer(&bufs.params, 0, bytemuck::bytes_of(&params));
                let t = std::time::Instant::now();
                dispatches += self.dispatch_slice(pipeline, bufs, n)?;
                dispatch_s += t.elapsed().as_secs_f64();
                // Slots [first, periods) of this slice hold recorded periods.
                let first = schedule.transient.saturating_sub(begin).min(periods);
                let last = begin + periods == total;
                let chunk_out = ChunkOut {
                    lanes: &mut out[start..end],
                    norms: lyapunov.then(|| &mut norms[start..end]),
                    tangents: lyapunov.then(|| &mut ends[start..end]),
                };
                self.read_slice(bufs, first..periods, last, chunk_out, start)?;
                lane_periods_done += n as u64 * periods as u64;
                let go_on = progress(SliceReport {
                    lane_periods_done,
                    lane_periods_total,
                    dispatches,
                    dispatch_s,
                });
                if !go_on {
                    return Err(Error::Interrupted {
                        committed: 0,
                        total: 1,
                    });
                }
                begin += periods;
            }
        }
        Ok(())
    }
}
