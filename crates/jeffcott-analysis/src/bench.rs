//! Throughput measurement of the ensemble backends, shared by
//! `jeffcott bench`, `benches/ensemble.rs` (criterion) and the hand-written baseline
//! (`benches/handwritten/rk4_loop.c`, which builds the same lanes).
//!
//! The workload is a basin-like ensemble at W = 133 rad/s, a contact-heavy regime
//! (period-5 rubbing and coexisting attractors): lane i starts from the static
//! equilibrium with the rotor's (x_r, vx_r) spread over [-4, 4] mm x [-0.5, 0.5] m/s
//! by two incommensurate golden-ratio sequences, so neighbouring lanes take different
//! contact histories, as they do in a real basin or bifurcation run (identical lanes
//! would flatter a SIMD GPU, whose lanes then never diverge).

use jeffcott_core::ensemble::{Backend, EnsembleSpec, LaneSpec, Precision};

use crate::backend::{Engine, run};
use jeffcott_core::control::Control;
use jeffcott_core::error::Result;
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, STATE_DIM, State, VX_R, X_R};
use serde::Serialize;

/// The benchmark speed [rad/s].
pub const BENCH_OMEGA: f64 = 133.0;

/// Start state of lane `i` of the benchmark workload. Keep in sync with `init` in
/// `benches/handwritten/rk4_loop.c`.
pub fn bench_lane(params: &Params, i: usize) -> State {
    let u = (i as f64 * 0.618_033_988_749_894_9) % 1.0;
    let v = (i as f64 * 0.754_877_666_246_692_7) % 1.0;
    let mut x = params.static_equilibrium();
    x[X_R] = 0.008 * u - 0.004;
    x[VX_R] = v - 0.5;
    x
}

/// The benchmark ensemble: `lanes` lanes of machine `params` (the article's Table 1 for
/// the published figures) at W = 133, `periods` periods all recorded (no transient: the
/// first periods, where the lanes are thrown about, are the contact-heaviest), with the
/// default stepper. `free_flight` widens the gap to 1 m so the same lanes never touch:
/// the difference in time is the cost of contact.
pub fn bench_spec(
    params: &Params,
    lanes: usize,
    periods: u32,
    precision: Precision,
    free_flight: bool,
) -> EnsembleSpec {
    let mut params = params.clone();
    let x0: Vec<State> = (0..lanes).map(|i| bench_lane(&params, i)).collect();
    if free_flight {
        params.delta = 1.0;
    }
    EnsembleSpec {
        param_sets: vec![params],
        lanes: x0
            .into_iter()
            .map(|x0| LaneSpec {
                omega: BENCH_OMEGA,
                x0,
                param_set: 0,
            })
            .collect(),
        transient: 0,
        recorded: periods,
        stepper: StepperConfig::default(),
        precision,
    }
}

/// One measured configuration.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    /// "cpu" or "gpu".
    pub backend: &'static str,
    /// CPU thread count or GPU adapter name.
    pub device: String,
    /// What ran: "lane kernel" (the integrator), or "anatomy: PART", a part of the
    /// kernel timed alone on the same lanes (`jeffcott_gpu::anatomy`; not the model).
    pub kernel: String,
    /// Lane precision.
    pub precision: Precision,
    /// Lanes.
    pub lanes: usize,
    /// Forcing periods per lane.
    pub periods: u32,
    /// Wall time of the run [s] (GPU device and pipeline set-up excluded).
    pub wall_s: f64,
    /// Anatomy rows: seconds in the GPU's dispatches alone (uploads and readbacks
    /// excluded, which would hide a fast part's cost); their rates are per these
    /// seconds. None for the kernel's own rows, whose rates are per wall second.
    pub dispatch_s: Option<f64>,
    /// Macro steps (T/N) advanced per second, summed over lanes.
    pub lane_steps_per_s: f64,
    /// Forcing periods advanced per second, summed over lanes.
    pub lane_periods_per_s: f64,
    /// Share of RK4 sub-steps spent on refinement (sub-steps beyond one per macro
    /// step, over all sub-steps), from the lanes' counters.
    pub refinement_substep_share: f64,
    /// Share of macro steps in contact.
    pub contact_step_share: f64,
    /// Share of wall time due to contact: 1 - t(free flight) / t(W = 133), from a twin
    /// run with the gap widened so no lane touches (None when not measured).
    pub contact_time_share: Option<f64>,
    /// Lanes that ended with a status other than ok.
    pub flagged_lanes: usize,
}

/// Runs one configuration (and, when `twin` is set, its free-flight twin) on a resolved
/// backend and measures it; the engine was opened before, so GPU device set-up is not
/// timed, as in any long run it is amortised. The run itself is checked: every lane
/// must be finite, or the figures would time a broken computation.
pub fn measure(
    params: &Params,
    (lanes, periods, precision): (usize, u32, Precision),
    engine: &Engine,
    twin: bool,
) -> Result<BenchRow> {
    let quiet = |_: u64, _: u64| {};
    let spec = bench_spec(params, lanes, periods, precision, false);
    if engine.runner().is_some() {
        // Warm-up: the first run on a runner compiles the pipeline (seconds on
        // llvmpipe); a long run pays that once, so it is not timed.
        engine.run(
            &bench_spec(params, 1, 1, precision, false),
            false,
            Control::progress(&quiet),
        )?;
    }
    let (res, info) = engine.run(&spec, false, Control::progress(&quiet))?;
    let (backend, device, wall) = (info.backend, info.device, info.elapsed_s);
    let steps: u64 = res.counters.iter().map(|c| c.macro_steps).sum();
    let extra: u64 = res.counters.iter().map(|c| c.extra_substeps).sum();
    let contact: u64 = res.counters.iter().map(|c| c.contact_steps).sum();
    let flagged = res.status.iter().filter(|s| s.code() != 0).count();
    if res.final_state.iter().flatten().any(|v| !v.is_finite()) {
        return Err(jeffcott_core::Error::Gpu {
            message: format!("benchmark run on {device} produced non-finite states"),
        });
    }
    let contact_time_share = if twin {
        let free = bench_spec(params, lanes, periods, precision, true);
        let (_, free) = engine.run(&free, false, Control::progress(&quiet))?;
        Some(1.0 - free.elapsed_s / wall)
    } else {
        None
    };
    Ok(BenchRow {
        backend,
        device,
        kernel: "lane kernel".into(),
        precision,
        lanes,
        periods,
        wall_s: wall,
        dispatch_s: None,
        lane_steps_per_s: steps as f64 / wall,
        lane_periods_per_s: lanes as f64 * periods as f64 / wall,
        refinement_substep_share: extra as f64 / (steps + extra).max(1) as f64,
        contact_step_share: contact as f64 / steps.max(1) as f64,
        contact_time_share,
        flagged_lanes: flagged,
    })
}

/// Times part `part` of the kernel's anatomy (`jeffcott_gpu::anatomy`) on the
/// benchmark's lanes, as [`measure`] times the kernel (pipeline compilation excluded;
/// the same chunks and time slices, the records read back): the rate to set beside the
/// kernel's on the same GPU. Every lane must end finite.
pub fn measure_anatomy(
    part: jeffcott_gpu::anatomy::Part,
    params: &Params,
    (lanes, periods, precision): (usize, u32, Precision),
    runner: &jeffcott_gpu::GpuRunner,
) -> Result<BenchRow> {
    let spec = bench_spec(params, lanes, periods, precision, false);
    match precision {
        Precision::F64 => measure_anatomy_in::<f64>(part, &spec, runner),
        Precision::F32 => measure_anatomy_in::<f32>(part, &spec, runner),
    }
}

/// [`measure_anatomy`] of the benchmark's ensemble `spec` in precision `R`.
fn measure_anatomy_in<R: jeffcott_gpu::GpuReal>(
    part: jeffcott_gpu::anatomy::Part,
    spec: &EnsembleSpec,
    runner: &jeffcott_gpu::GpuRunner,
) -> Result<BenchRow> {
    let (lanes, periods) = (spec.lanes.len(), spec.recorded);
    let consts: Vec<_> = (0..lanes).map(|i| spec.lane_consts::<R>(i)).collect();
    let init: Vec<_> = (0..lanes).map(|i| spec.initial_lane::<R>(i)).collect();
    let slice = crate::backend::periods_per_slice(lanes, spec.stepper.steps_per_period, periods);
    let schedule = jeffcott_gpu::Schedule::new(0, periods, slice);
    let (out, times) = runner.run_anatomy(part, &consts, &init, &schedule)?;
    let device = runner.gpu().adapter().name.clone();
    if out
        .iter()
        .any(|o| o.lane.state_f64().iter().any(|v| !v.is_finite()))
    {
        return Err(jeffcott_core::Error::Gpu {
            message: format!(
                "anatomy part {} on {device} produced non-finite states",
                part.name()
            ),
        });
    }
    let steps: u64 = out.iter().map(|o| o.lane.counters.macro_steps).sum();
    let extra: u64 = out.iter().map(|o| o.lane.counters.extra_substeps).sum();
    // Only the kernel counts macro steps in contact; the parts use the counter for
    // their own tallies (anatomy::cpu_period).
    let contact: u64 = match part {
        jeffcott_gpu::anatomy::Part::Kernel => {
            out.iter().map(|o| o.lane.counters.contact_steps).sum()
        }
        _ => 0,
    };
    let gpu_s = times.dispatch_s;
    Ok(BenchRow {
        backend: "gpu",
        device,
        kernel: format!("anatomy: {}", part.name()),
        precision: spec.precision,
        lanes,
        periods,
        wall_s: times.wall_s,
        dispatch_s: Some(gpu_s),
        lane_steps_per_s: steps as f64 / gpu_s,
        lane_periods_per_s: lanes as f64 * periods as f64 / gpu_s,
        refinement_substep_share: extra as f64 / (steps + extra).max(1) as f64,
        contact_step_share: contact as f64 / steps.max(1) as f64,
        contact_time_share: None,
        flagged_lanes: 0,
    })
}

/// Fewest periods a benchmark row integrates: the lanes need about three periods to
/// be thrown against the stator (in the first period 0.1% of the steps are in
/// contact, over four 15%), and the benchmark is meant to be contact-heavy.
pub const MIN_BENCH_PERIODS: u32 = 4;

/// Periods per lane for `lanes` lanes so that every size does about the same work
/// (`lane_periods` in all), at least [`MIN_BENCH_PERIODS`].
pub fn periods_for(lanes: usize, lane_periods: u64) -> u32 {
    (lane_periods / lanes.max(1) as u64).clamp(MIN_BENCH_PERIODS as u64, u32::MAX as u64) as u32
}

/// Final states of the benchmark lanes after `periods` periods with `n` steps per
/// period on the CPU in f64 (the accuracy side of the hand-written comparison).
pub fn reference_final_states(lanes: usize, periods: u32, n: u32) -> Result<Vec<State>> {
    let mut spec = bench_spec(&Params::default(), lanes, periods, Precision::F64, false);
    spec.stepper.steps_per_period = n;
    let (res, _) = run(&spec, Backend::Cpu, false, Control::none())?;
    Ok(res.final_state)
}

/// Per-lane position error [m] (largest over the four positions) between two sets of
/// final states, sorted ascending, so quantiles can be read off.
pub fn sorted_position_errors(a: &[State], b: &[State]) -> Vec<f64> {
    let mut e: Vec<f64> = a
        .iter()
        .zip(b)
        .map(|(p, q)| {
            (0..STATE_DIM)
                .step_by(2)
                .map(|d| (p[d] - q[d]).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    e.sort_by(f64::total_cmp);
    e
}

/// The `q` quantile (0..=1) of sorted values.
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}
