//! The backend resolved once: `auto`/`cpu`/`gpu` turned into the CPU path of
//! `jeffcott-core` or an open `jeffcott-gpu` runner. [`run`] resolves one per call; a study made of several
//! ensembles (the chunks of a basin, the passes of a brute-force diagram, benchmark
//! rows) keeps one, so the GPU device and pipeline are set up once.

use crate::gpu_pool::{POOL_SLOTS, run_early_gpu};
use jeffcott_core::Result;
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::early::{EarlyExit, EarlyResult};
use jeffcott_core::ensemble::{
    Backend, EnsembleResult, EnsembleSpec, Precision, RunInfo, cpu, lane_lambda1,
    mask_frozen_records,
};
use jeffcott_core::integrate::lane::{Lane, LaneConsts, StepperConfig};
use jeffcott_core::model::STATE_DIM;
use jeffcott_core::orbit::{self, CpuFlows, Flow, FlowAsk, Want};
use jeffcott_gpu::{DeviceRequest, GpuDevice, GpuRunner};

/// A resolved backend.
pub struct Engine {
    gpu: Option<GpuRunner>,
    device: String,
    reason: String,
    /// Slots of the GPU's early-exit pool at most.
    pool_slots: usize,
}

impl Engine {
    /// Resolves `backend` for lanes of `precision`: `gpu` errors without a usable adapter,
    /// `auto` takes a hardware GPU or else the CPU.
    pub fn new(backend: Backend, precision: Precision) -> Result<Engine> {
        let cpu = |reason: String| Engine {
            gpu: None,
            device: format!("{} rayon threads", rayon::current_num_threads()),
            reason,
            pool_slots: POOL_SLOTS,
        };
        match backend {
            Backend::Cpu => Ok(cpu("--backend cpu".into())),
            Backend::Gpu | Backend::Auto => {
                let req = DeviceRequest {
                    need_f64: precision == Precision::F64,
                    allow_software: backend == Backend::Gpu,
                };
                match GpuDevice::new(&req) {
                    Ok(dev) => Ok(Engine {
                        device: dev.adapter().name.clone(),
                        gpu: Some(GpuRunner::new(dev)),
                        reason: if backend == Backend::Gpu {
                            "--backend gpu".into()
                        } else {
                            "hardware GPU found".into()
                        },
                        pool_slots: POOL_SLOTS,
                    }),
                    Err(e) if backend == Backend::Gpu => Err(e),
                    Err(e) => Ok(cpu(format!("no hardware GPU ({e})"))),
                }
            }
        }
    }

    /// The device lanes run on: the GPU adapter's name, or the CPU's rayon threads.
    pub fn device(&self) -> &str {
        &self.device
    }

    /// The GPU runner, when the backend resolved to a GPU.
    pub fn runner(&self) -> Option<&GpuRunner> {
        self.gpu.as_ref()
    }

    /// Runs one ensemble on the resolved backend, with the largest Lyapunov exponent per
    /// lane when `lambda1` (`EnsembleResult::lambda1`; the same arithmetic on both
    /// backends; the plain run pays nothing for it: the tangent vector lives in a
    /// separate kernel variant and a separate monomorphisation of the CPU stepper).
    /// `ctl.progress` counts lane-periods; `ctl.cancel` stops the run between batches of
    /// lanes (CPU) or time slices (GPU) with [`jeffcott_core::Error::Interrupted`].
    pub fn run(
        &self,
        spec: &EnsembleSpec,
        lambda1: bool,
        ctl: Control,
    ) -> Result<(EnsembleResult, RunInfo)> {
        let start = std::time::Instant::now();
        let (res, backend) = match &self.gpu {
            Some(runner) => (run_on_gpu(spec, runner, lambda1, ctl)?, "gpu"),
            None => (cpu::run(spec, lambda1, ctl)?, "cpu"),
        };
        Ok((res, self.info(backend, spec.precision, start)))
    }
}

impl Engine {
    /// Runs one ensemble with early exit (`jeffcott_core::ensemble::early`). The CPU
    /// retires recognised lanes and refills their slots in its batches; a GPU does the
    /// same in a slot pool refilled between time slices (`gpu_pool`), so both backends
    /// end the same lanes at the same periods with the same records.
    pub fn run_early(
        &self,
        spec: &EnsembleSpec,
        early: &EarlyExit,
        lambda1: bool,
        ctl: Control,
    ) -> Result<(EarlyResult, RunInfo)> {
        let start = std::time::Instant::now();
        let Some(runner) = &self.gpu else {
            let r = cpu::run_early(spec, early, lambda1, ctl)?;
            return Ok((r, self.info("cpu", spec.precision, start)));
        };
        spec.validate()?;
        let slots = self.pool_slots;
        let r = match spec.precision {
            Precision::F32 => run_early_gpu::<f32>(spec, runner, early, lambda1, slots, ctl)?,
            Precision::F64 => run_early_gpu::<f64>(spec, runner, early, lambda1, slots, ctl)?,
        };
        Ok((r, self.info("gpu", spec.precision, start)))
    }

    /// This engine with a GPU slot pool of at most `slots` slots for early exit
    /// (default [`POOL_SLOTS`]): tests use a few, so that slots are refilled.
    pub fn with_pool_slots(mut self, slots: usize) -> Self {
        self.pool_slots = slots.max(1);
        self
    }

    /// How a run went: the backend, this engine's device and reason, the precision and
    /// the time since `start`.
    fn info(
        &self,
        backend: &'static str,
        precision: Precision,
        start: std::time::Instant,
    ) -> RunInfo {
        RunInfo {
            backend,
            device: self.device.clone(),
            reason: self.reason.clone(),
            precision,
            elapsed_s: start.elapsed().as_secs_f64(),
            setup_s: 0.0,
        }
    }
}

/// Lane-steps per GPU dispatch aimed at: short enough for a watchdog (docs/gpu.md),
/// long enough to amortise the dispatch.
pub(crate) const LANE_STEPS_PER_SLICE: u64 = 50_000_000;

/// Forcing periods per GPU dispatch for `lanes` lanes of `steps_per_period` macro steps
/// running `periods` periods: [`LANE_STEPS_PER_SLICE`] lane-steps, at least 1 and at
/// most the run.
pub(crate) fn periods_per_slice(lanes: usize, steps_per_period: u32, periods: u32) -> u32 {
    let per_period = lanes as u64 * steps_per_period as u64;
    (LANE_STEPS_PER_SLICE / per_period.max(1)).clamp(1, periods.max(1) as u64) as u32
}

/// The ensemble on the GPU, with each lane's lambda_1 when `lambda1`.
fn run_gpu<R: jeffcott_gpu::GpuReal>(
    spec: &EnsembleSpec,
    runner: &jeffcott_gpu::GpuRunner,
    lambda1: bool,
    ctl: Control,
) -> Result<EnsembleResult> {
    let n = spec.lanes.len();
    let consts: Vec<LaneConsts<R>> = (0..n).map(|i| spec.lane_consts(i)).collect();
    let init: Vec<Lane<R>> = (0..n).map(|i| spec.initial_lane(i)).collect();
    let slice = periods_per_slice(
        n,
        spec.stepper.steps_per_period,
        spec.transient + spec.recorded,
    );
    let schedule = jeffcott_gpu::Schedule {
        tangent_from: spec.stepper.tangent_from(spec.transient),
        ..jeffcott_gpu::Schedule::new(spec.transient, spec.recorded, slice)
    };
    let mut report = |p: jeffcott_gpu::SliceReport| {
        (ctl.progress)(p.lane_periods_done, p.lane_periods_total);
        !ctl.cancel.is_set()
    };
    let (outs, norms) = if lambda1 {
        let v = [R::lit(jeffcott_core::integrate::lane::LAMBDA1_START); STATE_DIM];
        let tangents = vec![v; n];
        let (outs, norms, _) =
            runner.run_lyapunov_with_progress(&consts, &init, &tangents, &schedule, &mut report)?;
        (outs, Some(norms))
    } else {
        (
            runner.run_with_progress(&consts, &init, &schedule, &mut report)?,
            None,
        )
    };
    let mut res = EnsembleResult {
        lambda1: norms.as_ref().map(|all| {
            all.iter()
                .zip(&outs)
                .zip(&spec.lanes)
                .map(|((nm, o), l)| lane_lambda1(nm, l.omega, o.lane.status))
                .collect()
        }),
        ..EnsembleResult::with_capacity(n, spec.recorded, false)
    };
    for o in outs {
        for p in &o.poincare {
            res.poincare.extend_from_slice(p);
        }
        res.final_state.push(o.lane.state_f64());
        res.status.push(o.lane.status);
        res.counters.push(o.lane.counters);
    }
    mask_frozen_records(spec, &mut res);
    Ok(res)
}

/// Runs an ensemble on an existing GPU runner, so repeated runs (chunks of a basin,
/// benchmark samples) pay the device and pipeline set-up once; with the largest
/// Lyapunov exponent of every lane ([`EnsembleResult::lambda1`]) by the kernel's
/// lambda_1 variant when `lambda1`.
pub fn run_on_gpu(
    spec: &EnsembleSpec,
    runner: &jeffcott_gpu::GpuRunner,
    lambda1: bool,
    ctl: Control,
) -> Result<EnsembleResult> {
    spec.validate()?;
    match spec.precision {
        Precision::F32 => run_gpu::<f32>(spec, runner, lambda1, ctl),
        Precision::F64 => run_gpu::<f64>(spec, runner, lambda1, ctl),
    }
}

/// The precision used when the user names none: f32 where the run will go to a GPU,
/// f64 on the CPU (for `auto` that depends on whether a hardware GPU is present).
pub fn default_precision(backend: Backend) -> Precision {
    let hardware = || {
        jeffcott_gpu::list_adapters()
            .iter()
            .any(|a| a.compute && !a.software)
    };
    match backend {
        Backend::Cpu => Precision::F64,
        Backend::Gpu => Precision::F32,
        Backend::Auto if hardware() => Precision::F32,
        Backend::Auto => Precision::F64,
    }
}

/// Runs an ensemble on the chosen backend (see [`Engine::run`]); the device is opened
/// for this one run, and its set-up is included in the wall time.
pub fn run(
    spec: &EnsembleSpec,
    backend: Backend,
    lambda1: bool,
    ctl: Control,
) -> Result<(EnsembleResult, RunInfo)> {
    spec.validate()?;
    let start = std::time::Instant::now();
    let engine = Engine::new(backend, spec.precision)?;
    let setup_s = start.elapsed().as_secs_f64();
    let (res, mut info) = engine.run(spec, lambda1, ctl)?;
    info.elapsed_s = start.elapsed().as_secs_f64();
    info.setup_s = setup_s;
    Ok((res, info))
}

/// Flows of periodic-orbit shooting and continuation (`jeffcott_core::orbit`) on the
/// resolved backend: the CPU's [`CpuFlows`], or one GPU run of the kernel's lambda_1
/// variant per period count, eight lanes per monodromy matrix (lane j starts its tangent
/// at e_j; its growths times its final vector are column j, as [`orbit::flow`] computes
/// it) and one lane per end state. The smallest clearance, which the kernel does not
/// track, comes from the CPU ([`orbit::min_clearance`]: the same states, the same value).
/// Both backends give the same bits in f64.
impl orbit::Flows for Engine {
    fn flows_until(
        &self,
        asks: &[FlowAsk],
        stepper: &StepperConfig,
        cancel: &jeffcott_core::control::Cancel,
    ) -> Result<Vec<Flow>> {
        match &self.gpu {
            Some(runner) => gpu_flows(runner, asks, stepper),
            None => CpuFlows.flows_until(asks, stepper, cancel),
        }
    }
}

/// [`orbit::Flows::flows`] on a GPU.
fn gpu_flows(runner: &GpuRunner, asks: &[FlowAsk], stepper: &StepperConfig) -> Result<Vec<Flow>> {
    use rayon::prelude::*;
    let mut out: Vec<Option<Flow>> = vec![None; asks.len()];
    let mut counts: Vec<u32> = asks.iter().map(|a| a.periods).collect();
    counts.sort_unstable();
    counts.dedup();
    for periods in counts {
        let mine: Vec<usize> = (0..asks.len())
            .filter(|&i| asks[i].periods == periods)
            .collect();
        let (mut consts, mut init, mut tangents, mut first) = (vec![], vec![], vec![], vec![]);
        for &i in &mine {
            let a = &asks[i];
            let lc = LaneConsts::<f64>::new(&a.params, a.omega, stepper);
            let lane = Lane::<f64>::new(&a.x0, a.params.delta);
            first.push(consts.len());
            let starts = match a.want {
                Want::Monodromy => orbit::identity().to_vec(),
                Want::End => vec![[jeffcott_core::integrate::lane::LAMBDA1_START; STATE_DIM]],
            };
            for v in starts {
                consts.push(lc);
                init.push(lane);
                tangents.push(v);
            }
        }
        // (0 periods: the runner hands back the start lanes and tangents untouched, and
        // the identity's columns with no growth are the CPU's monodromy too.)
        let slice = periods_per_slice(consts.len(), stepper.steps_per_period, periods);
        let schedule = jeffcott_gpu::Schedule::new(0, periods, slice);
        let (lanes, norms, ends) =
            runner
                .run_lyapunov_with_progress(&consts, &init, &tangents, &schedule, &mut |_| true)?;
        let clearances: Vec<f64> = mine
            .par_iter()
            .map(|&i| {
                let a = &asks[i];
                match a.want {
                    Want::Monodromy => {
                        orbit::min_clearance(&a.params, a.omega, &a.x0, periods, stepper)
                    }
                    Want::End => f64::NAN,
                }
            })
            .collect();
        for ((&i, &k), min_clearance) in mine.iter().zip(&first).zip(clearances) {
            let lane = &lanes[k].lane;
            let finite = !lane.status.is_frozen();
            let monodromy = (finite && asks[i].want == Want::Monodromy).then(|| {
                let v: [[f64; STATE_DIM]; STATE_DIM] = std::array::from_fn(|j| ends[k + j]);
                let growth: [f64; STATE_DIM] =
                    std::array::from_fn(|j| norms[k + j].iter().fold(1.0, |a, g| a * g));
                orbit::columns(&v, &growth)
            });
            out[i] = Some(Flow {
                end: lane.x,
                monodromy,
                min_clearance,
                finite,
            });
        }
    }
    Ok(out
        .into_iter()
        .map(|f| f.expect("every ask answered"))
        .collect())
}
