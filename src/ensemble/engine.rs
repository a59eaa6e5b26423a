//! The backend resolved once: `auto`/`cpu`/`gpu` turned into the CPU or an open GPU
//! runner. [`crate::ensemble::run`] resolves one per call; a study made of several
//! ensembles (the chunks of a basin, the passes of a brute-force diagram, benchmark
//! rows) keeps one, so the GPU device and pipeline are set up once.

use super::{Backend, EnsembleResult, EnsembleSpec, Precision, RunInfo, cpu, run_on_gpu_inner};
use crate::error::Result;
use crate::gpu::{DeviceRequest, GpuDevice, GpuRunner};

/// A resolved backend.
pub struct Engine {
    gpu: Option<GpuRunner>,
    device: String,
    reason: String,
}

impl Engine {
    /// Resolves `backend` for lanes of `precision`: `gpu` errors without a usable adapter,
    /// `auto` takes a hardware GPU or else the CPU.
    pub fn new(backend: Backend, precision: Precision) -> Result<Engine> {
        let cpu = |reason: String| Engine {
            gpu: None,
            device: format!("{} rayon threads", rayon::current_num_threads()),
            reason,
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
                    }),
                    Err(e) if backend == Backend::Gpu => Err(e),
                    Err(e) => Ok(cpu(format!("no hardware GPU ({e})"))),
                }
            }
        }
    }

    /// The GPU runner, when the backend resolved to a GPU.
    pub fn runner(&self) -> Option<&GpuRunner> {
        self.gpu.as_ref()
    }

    /// Runs one ensemble on the resolved backend.
    pub fn run(
        &self,
        spec: &EnsembleSpec,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<(EnsembleResult, RunInfo)> {
        self.run_maybe_lambda1(spec, false, progress)
    }

    /// Runs one ensemble on the resolved backend, with the largest Lyapunov exponent per
    /// lane when `lambda1` (`EnsembleResult::lambda1`; the same arithmetic on both
    /// backends).
    pub fn run_maybe_lambda1(
        &self,
        spec: &EnsembleSpec,
        lambda1: bool,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<(EnsembleResult, RunInfo)> {
        let start = std::time::Instant::now();
        let (res, backend) = match &self.gpu {
            Some(runner) => (run_on_gpu_inner(spec, runner, lambda1, progress)?, "gpu"),
            None => {
                spec.validate()?;
                // The CPU reports finished lanes; progress counts lane-periods.
                let per_lane = (spec.transient + spec.recorded) as u64;
                let total = spec.lanes.len() as u64 * per_lane;
                let report = |lanes_done: usize| progress(lanes_done as u64 * per_lane, total);
                let res = if lambda1 {
                    cpu::run_with_lambda1(spec, &report)?
                } else {
                    cpu::run(spec, &report)?
                };
                (res, "cpu")
            }
        };
        Ok((
            res,
            RunInfo {
                backend,
                device: self.device.clone(),
                reason: self.reason.clone(),
                precision: spec.precision,
                elapsed_s: start.elapsed().as_secs_f64(),
            },
        ))
    }
}
