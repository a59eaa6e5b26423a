//! Parity of the WGSL lane kernel (`integrate/lane.wgsl` through `jeffcott_gpu`) with the
//! CPU lane stepper (`integrate::lane`), which is the reference.
//!
//! These tests need a Vulkan (or other wgpu) adapter. Without one they print
//! "skipped: no Vulkan adapter" and return, unless `JEFFCOTT_REQUIRE_GPU=1` is set (CI
//! with Mesa's lavapipe), in which case they fail. The kernel's functions one by one
//! against their Rust functions: tests/mirror.

use jeffcott_core::control::Control;
use jeffcott_core::integrate::lane::{Lane, LaneConsts, Status, StepperConfig, advance_period};
use jeffcott_core::model::{Params, STATE_DIM, VX_R, X_R};
use jeffcott_gpu::{GpuReal, GpuRunner, LaneOutcome, Schedule};
use rayon::prelude::*;

mod common;
use common::gpu::{device_variant, identity_promised, runner_for};
use common::unit;

/// Macro steps per period in these tests: small enough for lavapipe on two cores,
/// large enough that contact steps are refined (located crossings, several segments).
const N: u32 = 200;
/// Periods integrated before recording, and recorded periods (50 in all).
const TRANSIENT: u32 = 40;
const RECORDED: u32 = 10;

/// The kinds of lanes in the parity ensemble.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// Static equilibrium (docs/model.md 4).
    Equilibrium,
    /// Thrown against the stator: x_r = 5.8 mm, vx_r = +0.8 m/s.
    ThrownOut,
    /// x_r = 5.8 mm, vx_r = -0.8 m/s.
    ThrownBack,
    /// Gap of 5 cm: never touches.
    FreeFlight,
    /// A deterministic scatter of the whole state inside the gap.
    Scatter,
    /// Thrown out as `ThrownOut`, with contact damping c_c = 3e4 N s/m (the force jumps
    /// at g = 0).
    Damped,
}

const KINDS: [Kind; 6] = [
    Kind::Equilibrium,
    Kind::ThrownOut,
    Kind::ThrownBack,
    Kind::FreeFlight,
    Kind::Scatter,
    Kind::Damped,
];

/// One lane of the parity ensemble: (params, W, initial state, kind).
fn lane_spec(i: usize, n: usize) -> (Params, f64, [f64; STATE_DIM], Kind) {
    let omega = 130.0 + 11.0 * i as f64 / (n - 1) as f64;
    let kind = KINDS[i % KINDS.len()];
    let mut p = Params::default();
    let mut x = p.static_equilibrium();
    match kind {
        Kind::Equilibrium => {}
        Kind::ThrownOut | Kind::ThrownBack => {
            x[X_R] = 0.0058;
            x[VX_R] = if kind == Kind::ThrownOut { 0.8 } else { -0.8 };
        }
        Kind::FreeFlight => p.delta = 0.05,
        Kind::Damped => {
            p.c_c = 3e4;
            x[X_R] = 0.0058;
            x[VX_R] = 0.8;
        }
        Kind::Scatter => {
            for (d, v) in x.iter_mut().enumerate() {
                let scale = if d % 2 == 0 { 0.004 } else { 0.5 };
                *v += scale * unit(i, d as u64 + 1);
            }
        }
    }
    (p, omega, x, kind)
}

fn config() -> StepperConfig {
    StepperConfig {
        steps_per_period: N,
        ..StepperConfig::default()
    }
}

/// Lane constants and initial lanes of the parity ensemble in precision `R`.
fn ensemble<R: GpuReal>(n: usize) -> (Vec<LaneConsts<R>>, Vec<Lane<R>>, Vec<Kind>) {
    ensemble_with::<R>(n, &config())
}

/// [`ensemble`] with stepper settings `cfg`.
fn ensemble_with<R: GpuReal>(
    n: usize,
    cfg: &StepperConfig,
) -> (Vec<LaneConsts<R>>, Vec<Lane<R>>, Vec<Kind>) {
    let cfg = *cfg;
    let mut consts = Vec::with_capacity(n);
    let mut lanes = Vec::with_capacity(n);
    let mut kinds = Vec::with_capacity(n);
    for i in 0..n {
        let (p, omega, x, kind) = lane_spec(i, n);
        consts.push(LaneConsts::<R>::new(&p, omega, &cfg));
        lanes.push(Lane::<R>::new(&x, p.delta));
        kinds.push(kind);
    }
    (consts, lanes, kinds)
}

/// The CPU reference: the same lanes through `advance_period`, recording the state at
/// the end of each period from `transient` on (rayon over lanes; lanes are independent).
fn cpu_run<R: GpuReal>(
    consts: &[LaneConsts<R>],
    init: &[Lane<R>],
    transient: u32,
    recorded: u32,
) -> Vec<LaneOutcome<R>> {
    consts
        .par_iter()
        .zip(init.par_iter())
        .map(|(lc, lane0)| {
            let mut lane = *lane0;
            let mut poincare = Vec::new();
            for p in 0..transient + recorded {
                advance_period(lc, &mut lane);
                if p >= transient {
                    poincare.push(lane.state_f64());
                }
            }
            LaneOutcome { poincare, lane }
        })
        .collect()
}

fn bits(p: &[[f64; STATE_DIM]]) -> Vec<u64> {
    p.iter().flatten().map(|v| v.to_bits()).collect()
}

/// True when two outcomes are identical to the bit (points, state, mode, k, status,
/// counters).
fn identical<R: GpuReal>(a: &LaneOutcome<R>, b: &LaneOutcome<R>) -> bool {
    bits(&a.poincare) == bits(&b.poincare)
        && a.lane.state_f64().map(f64::to_bits) == b.lane.state_f64().map(f64::to_bits)
        && a.lane.contact == b.lane.contact
        && a.lane.k == b.lane.k
        && a.lane.status == b.lane.status
        && a.lane.counters == b.lane.counters
}

/// How many lanes of `a` and `b` are [`identical`], pairwise.
fn count_identical<R: GpuReal>(a: &[LaneOutcome<R>], b: &[LaneOutcome<R>]) -> usize {
    a.iter().zip(b).filter(|(x, y)| identical(x, y)).count()
}

/// Largest difference between GPU and CPU Poincare points of one lane, relative to the
/// lane's extent in that coordinate (its largest |value| over the CPU records).
fn worst_relative(gpu: &[[f64; STATE_DIM]], cpu: &[[f64; STATE_DIM]]) -> f64 {
    let mut worst: f64 = 0.0;
    for d in 0..STATE_DIM {
        let scale = cpu.iter().map(|p| p[d].abs()).fold(0.0, f64::max);
        for (g, c) in gpu.iter().zip(cpu) {
            let diff = (g[d] - c[d]).abs();
            if diff > 0.0 {
                worst = worst.max(if scale > 0.0 {
                    diff / scale
                } else {
                    f64::INFINITY
                });
            }
        }
    }
    worst
}

fn timed<T>(what: &str, f: impl FnOnce() -> T) -> T {
    let t = std::time::Instant::now();
    let out = f();
    eprintln!("{what}: {:.2} s", t.elapsed().as_secs_f64());
    out
}

/// Checks that the ensemble exercises what it claims: hard rubbing with located
/// switches, and lanes that never touch.
fn assert_ensemble_is_varied<R: GpuReal>(cpu: &[LaneOutcome<R>], kinds: &[Kind]) {
    let rubbing = cpu.iter().filter(|o| o.lane.counters.switches > 10).count();
    assert!(
        rubbing >= cpu.len() / 4,
        "only {rubbing} lanes rub repeatedly"
    );
    for (o, k) in cpu.iter().zip(kinds) {
        if *k == Kind::FreeFlight {
            assert_eq!(o.lane.counters.contact_steps, 0, "free-flight lane touched");
        }
        if matches!(k, Kind::ThrownOut | Kind::ThrownBack | Kind::Damped) {
            assert!(o.lane.counters.switches > 0, "a thrown lane never switched");
        }
        assert!(!o.lane.status.is_frozen(), "{:?}", o.lane.status);
    }
}

/// The outcomes of both runs and the lanes' kinds, with the runner.
type BothRuns<R> = (
    &'static GpuRunner,
    Vec<LaneOutcome<R>>,
    Vec<LaneOutcome<R>>,
    Vec<Kind>,
);

/// True where the f64 kernel is promised to equal the CPU to the bit (common::gpu's
/// `identity_promised`). Through WGSL a hardware driver may fuse a*b+c, so only a
/// short-horizon tolerance holds there (4.4e-14 m after one period on the H100).
fn f64_bit_identity_promised(runner: &GpuRunner) -> bool {
    identity_promised::<f64>(runner, device_variant(runner, false))
}

/// The varied ensemble of `n` lanes over 50 periods in precision `R`, run on the GPU and
/// on the CPU (its variety checked): the runner, the GPU's outcomes, the CPU's and the
/// lanes' kinds; `None` without a runner for `R`.
fn gpu_and_cpu_runs<R: GpuReal>(n: usize) -> Option<BothRuns<R>> {
    let runner = runner_for::<R>()?;
    let (consts, init, kinds) = ensemble::<R>(n);
    let schedule = Schedule::new(TRANSIENT, RECORDED, 10);
    let gpu = timed(
        &format!("GPU {}, {n} lanes x 50 periods", R::WGSL_NAME),
        || runner.run(&consts, &init, &schedule),
    )
    .expect("GPU run");
    let cpu = timed(
        &format!("CPU {}, {n} lanes x 50 periods", R::WGSL_NAME),
        || cpu_run(&consts, &init, TRANSIENT, RECORDED),
    );
    assert_ensemble_is_varied(&cpu, &kinds);
    Some((runner, gpu, cpu, kinds))
}

#[test]
fn f64_kernel_reproduces_cpu_f64_lanes_to_the_bit() {
    let n = 260;
    let Some((runner, gpu, cpu, kinds)) = gpu_and_cpu_runs::<f64>(n) else {
        return;
    };
    let promised = f64_bit_identity_promised(runner);
    let mut exact = 0;
    let mut worst: f64 = 0.0;
    for (i, (g, c)) in gpu.iter().zip(&cpu).enumerate() {
        assert_eq!(g.poincare.len(), RECORDED as usize);
        let w = worst_relative(&g.poincare, &c.poincare);
        worst = worst.max(w);
        assert!(
            w <= 1e-10,
            "lane {i} ({:?}, W = {}): GPU and CPU differ by {w:e} relative",
            kinds[i],
            lane_spec(i, n).1
        );
        assert_eq!(g.lane.status, c.lane.status, "lane {i} status");
        assert_eq!(g.lane.k, c.lane.k, "lane {i} k");
        if identical(g, c) {
            exact += 1;
        }
    }
    eprintln!("f64: {exact}/{n} lanes bit-identical, worst relative difference {worst:e}");
    // Same operations, same order, correctly rounded on both sides: nothing less than
    // identity is expected (a difference would mean the mirror or the driver deviates).
    if promised {
        assert_eq!(exact, n, "lanes not bit-identical (worst {worst:e})");
    }
}

/// Contact refinement (R sub-steps of 1/R for macro steps in contact, `trial_extent`)
/// is mirrored too: for R = 1 (off), 4 and 16 the f64 kernel equals the CPU lane to the
/// bit, and the refinement really ran (more extra sub-steps than located switches can
/// explain).
#[test]
fn f64_kernel_with_contact_refinement_reproduces_cpu_to_the_bit_for_every_r() {
    let Some(runner) = runner_for::<f64>() else {
        return;
    };
    let n = 96;
    let mut extra_by_r = Vec::new();
    for r in [1u32, 4, 16] {
        let cfg = StepperConfig {
            contact_substeps: r,
            ..config()
        };
        let (consts, init, _) = ensemble_with::<f64>(n, &cfg);
        let schedule = Schedule::new(10, 10, 10);
        let gpu = runner.run(&consts, &init, &schedule).expect("GPU run");
        let cpu = cpu_run(&consts, &init, 10, 10);
        let promised = f64_bit_identity_promised(runner);
        for (i, (g, c)) in gpu.iter().zip(&cpu).enumerate() {
            if promised {
                assert!(identical(g, c), "R = {r}, lane {i} differs");
                assert_eq!(
                    g.lane.counters, c.lane.counters,
                    "R = {r}, lane {i} counters"
                );
            } else {
                let w = worst_relative(&g.poincare, &c.poincare);
                assert!(w <= 1e-10, "R = {r}, lane {i}: {w:e} relative");
            }
        }
        let extra: u64 = cpu.iter().map(|o| o.lane.counters.extra_substeps).sum();
        let contact: u64 = cpu.iter().map(|o| o.lane.counters.contact_steps).sum();
        assert!(
            contact > 1000,
            "the lanes must rub: {contact} contact steps"
        );
        extra_by_r.push(extra);
    }
    // Each macro step begun in contact costs up to R - 1 more sub-steps.
    assert!(
        extra_by_r[0] < extra_by_r[1] && extra_by_r[1] < extra_by_r[2],
        "extra sub-steps for R = 1, 4, 16: {extra_by_r:?}"
    );
}

/// The f32 bound. The kernel performs the same IEEE binary32 operations in the same
/// order as the CPU f32 lane: + - * / and sqrt are correctly rounded on both sides
/// (x86 SSE on the host; LLVM on lavapipe, which does not fuse a*b+c into an fma),
/// the one reassociation Mesa's NIR would apply is blocked by `keep` in the kernel
/// (checked function by function in tests/mirror), constants are
/// the same f32 values (checked in `gpu::shader`), and floor and small-integer
/// conversions are exact. Each operation therefore rounds the same exact value to the
/// same f32, by induction over the whole run: the bound is zero, and the test demands
/// identity on a software adapter.
///
/// A hardware GPU may implement f32 division and sqrt to 2-3 ulp (Vulkan's precision
/// rules; fused multiply-adds are ruled out where the kernel goes as exact SPIR-V, see
/// jeffcott-gpu's spirv.rs). On an H100 (driver 580.159) the f32 lanes left the CPU's
/// in the first periods while the f64 lanes stayed identical (docs/gpu.md), so where
/// the device has f64 the f32 kernel divides and takes square roots through f64
/// (`shader::Variant`), correctly rounded: identity is then promised wherever it is for
/// f64 (`identity_promised`). Where it is not (no f64, or WGSL on hardware), each
/// macro step can differ by a few ulp of the state (|x| <= 1e-2 m, ulp 1e-9 m), and
/// chaotic lanes amplify that to the attractor's size within tens of periods; only a
/// statistical comparison makes sense there, so on hardware the test checks that the
/// same lanes froze (diverged or non-finite), that the points stay inside the gap-sized
/// region the dynamics allow (2 delta), and that most lanes' largest refinement status
/// agrees: a lane whose trajectory moved may hit the refinement cap on one side only
/// (seen: 1 of 260 lanes on the H100).
#[test]
fn f32_kernel_matches_cpu_f32_lanes_within_derived_bound() {
    let n = 260;
    let Some((runner, gpu, cpu, _)) = gpu_and_cpu_runs::<f32>(n) else {
        return;
    };
    let promised = identity_promised::<f32>(runner, device_variant(runner, false));
    let mut exact = 0;
    let mut worst: f64 = 0.0;
    let mut status_differs = 0;
    for (i, (g, c)) in gpu.iter().zip(&cpu).enumerate() {
        if promised {
            assert_eq!(g.lane.status, c.lane.status, "lane {i} status");
        } else {
            assert_eq!(
                g.lane.status.is_frozen(),
                c.lane.status.is_frozen(),
                "lane {i}: GPU {:?}, CPU {:?}",
                g.lane.status,
                c.lane.status
            );
            status_differs += usize::from(g.lane.status != c.lane.status);
        }
        worst = worst.max(worst_relative(&g.poincare, &c.poincare));
        if identical(g, c) {
            exact += 1;
        } else if !promised {
            for (pg, pc) in g.poincare.iter().zip(&c.poincare) {
                for d in [0, 2, 4, 6] {
                    assert!(
                        (pg[d] - pc[d]).abs() <= 2.0 * 0.006,
                        "lane {i}: {pg:?} vs {pc:?}"
                    );
                }
            }
        }
    }
    eprintln!(
        "f32: {exact}/{n} lanes bit-identical, worst relative difference {worst:e}, \
         {status_differs} statuses differ (refinement cap)"
    );
    if promised {
        assert_eq!(exact, n, "f32 lanes not bit-identical (worst {worst:e})");
    }
    assert!(
        status_differs * 20 <= n,
        "{status_differs} of {n} lanes differ in refinement status"
    );
}

/// Runs the ensemble under several schedules and demands identical results.
fn slicing_does_not_change_results<R: GpuReal>(runner: &GpuRunner) {
    let n = 150;
    let (consts, init, _) = ensemble::<R>(n);
    let (transient, recorded) = (93, 7);
    let total = transient + recorded;
    let one_dispatch = Schedule::new(transient, recorded, total);
    let mut dispatches = 0;
    let big = runner
        .run_with_progress(&consts, &init, &one_dispatch, &mut |p| {
            dispatches = p.dispatches;
            true
        })
        .expect("one dispatch");
    eprintln!(
        "{}: the one-slice schedule took {dispatches} dispatches",
        R::WGSL_NAME
    );
    if runner.gpu().adapter().software {
        // 100 periods of 200 macro steps (at least 4 loop iterations each in the
        // kernel: the step loop, macro_step's and find_switch's loops, the budget probe)
        // exceed llvmpipe's 65535 loop iterations per invocation, so the resume path of
        // the kernel is part of this comparison.
        assert!(
            dispatches > 1,
            "llvmpipe finished 20000 macro steps in one dispatch"
        );
    }
    // Slices that straddle the end of the transient, chunks that are not multiples of
    // the workgroup size, and a chunk of a single lane at the end.
    for (pps, chunk) in [(1, None), (4, Some(37)), (9, Some(149)), (total, Some(64))] {
        let schedule = Schedule {
            max_lanes_per_chunk: chunk,
            ..Schedule::new(transient, recorded, pps)
        };
        let mut reports = Vec::new();
        let small = runner
            .run_with_progress(&consts, &init, &schedule, &mut |p| {
                reports.push(p);
                true
            })
            .expect("sliced run");
        for (i, (a, b)) in big.iter().zip(&small).enumerate() {
            assert!(
                identical(a, b),
                "{}: lane {i} differs with {pps} periods per slice, chunk {chunk:?}",
                R::WGSL_NAME
            );
        }
        let done: Vec<u64> = reports.iter().map(|p| p.lane_periods_done).collect();
        assert!(
            done.windows(2).all(|w| w[0] < w[1]),
            "progress not increasing"
        );
        assert_eq!(done.last().copied(), Some(n as u64 * total as u64));
        let chunks = n.div_ceil(chunk.unwrap_or(n));
        assert!(reports.len() >= chunks * (total as usize).div_ceil(pps as usize));
    }
}

#[test]
fn one_dispatch_and_many_slices_and_chunks_are_bit_identical() {
    both_precisions!(slicing_does_not_change_results);
}

/// Scale: a device whose limits admit only a few lanes per dispatch and per
/// buffer (2 workgroups of 64, 4 KiB bindings: 10 f64 lanes, whose constants of 384
/// bytes bind before their 4-period slices of records, 20 f32) runs a 700-lane ensemble
/// in 70 or 35 chunks one after the other, bit-identical to the
/// device's own plan. The same planning cuts 10M lanes on an H100 (plan.rs tests).
fn small_device_limits_plan_many_chunks_with_identical_results<R: GpuReal>(runner: &GpuRunner) {
    let n = 700;
    let (consts, init, _) = ensemble::<R>(n);
    let schedule = Schedule::new(6, 6, 4);
    let full = runner
        .run(&consts, &init, &schedule)
        .expect("full-size run");
    // A second device on the adapter the shared runner uses (the best one).
    let gpu = jeffcott_gpu::GpuDevice::new(&jeffcott_gpu::DeviceRequest::default())
        .expect("a second device");
    assert_eq!(gpu.adapter().name, runner.gpu().adapter().name);
    let small = jeffcott_gpu::plan::PlanLimits {
        max_storage_buffer_binding_size: 4096,
        max_buffer_size: 4096,
        max_compute_workgroups_per_dimension: 2,
    };
    let tiny = GpuRunner::with_limits(gpu, small);
    let plan = tiny.plan::<R>(n, &schedule, false).expect("plan");
    let lane_bytes = (4 * 8 * std::mem::size_of::<R>()).max(std::mem::size_of::<R::Consts>());
    assert_eq!(plan.lanes_per_chunk, 4096 / lane_bytes, "{plan:?}");
    assert_eq!(plan.chunks, n.div_ceil(4096 / lane_bytes), "{plan:?}");
    let mut reports = 0;
    let cut = tiny
        .run_with_progress(&consts, &init, &schedule, &mut |_| {
            reports += 1;
            true
        })
        .expect("run on small limits");
    assert!(reports >= plan.chunks * 3, "{reports} slices for {plan:?}");
    for (i, (a, b)) in full.iter().zip(&cut).enumerate() {
        assert!(identical(a, b), "{}: lane {i} differs", R::WGSL_NAME);
    }
}

#[test]
fn small_device_limits_cut_a_run_into_many_chunks_without_changing_a_bit() {
    both_precisions!(small_device_limits_plan_many_chunks_with_identical_results);
}

/// Poisons lanes 3, 4, 5 and 6 of a small ensemble and checks they are flagged as the CPU
/// flags them while every other lane is identical to the clean run.
fn poisoned_lanes_are_frozen_and_isolated<R: GpuReal>(runner: &GpuRunner) {
    let (consts, init, _) = ensemble::<R>(70);
    let schedule = Schedule::new(5, 5, 3);
    let clean = runner.run(&consts, &init, &schedule).expect("clean run");

    let p = Params::default();
    let cfg = config();
    let mut bad_consts = consts.clone();
    let mut bad_init = init.clone();
    // NaN initial state: frozen from the start.
    let mut x = p.static_equilibrium();
    x[X_R] = f64::NAN;
    bad_init[3] = Lane::new(&x, p.delta);
    // Absurd speed: e W^2 overflows, the first step is not finite.
    bad_consts[4] = LaneConsts::new(&p, 1e200, &cfg);
    // Absurd launch speed: the rotor leaves the 1 m bound in the first step.
    let mut x = p.static_equilibrium();
    x[VX_R] = 1e5;
    bad_init[5] = Lane::new(&x, p.delta);
    // A NaN coefficient: finite start, non-finite after the first step.
    bad_consts[6].c.wr2x = R::lit(f64::NAN);
    bad_consts[6].c.wr2y = R::lit(f64::NAN);

    let poisoned = runner
        .run(&bad_consts, &bad_init, &schedule)
        .expect("poisoned run");
    let cpu = cpu_run(&bad_consts[3..7], &bad_init[3..7], 5, 5);
    let expect = [
        Status::NonFinite,
        Status::NonFinite,
        Status::Diverged,
        Status::NonFinite,
    ];
    for (j, i) in (3..7).enumerate() {
        let g = &poisoned[i];
        assert_eq!(g.lane.status, expect[j], "{}: lane {i}", R::WGSL_NAME);
        assert_eq!(
            g.lane.status, cpu[j].lane.status,
            "lane {i} GPU vs CPU status"
        );
        assert_eq!(g.lane.counters.macro_steps, 0, "lane {i} advanced");
        // Frozen at the last good state, which the records repeat.
        assert_eq!(
            g.lane.state_f64().map(f64::to_bits),
            cpu[j].lane.state_f64().map(f64::to_bits)
        );
        assert_eq!(bits(&g.poincare), bits(&cpu[j].poincare));
    }
    for i in (0..consts.len()).filter(|i| !(3..7).contains(i)) {
        assert!(
            identical(&clean[i], &poisoned[i]),
            "{}: neighbour lane {i} changed",
            R::WGSL_NAME
        );
        assert_eq!(clean[i].lane.status, Status::Ok);
    }
}

#[test]
fn poisoned_lanes_are_flagged_and_do_not_touch_their_neighbours() {
    both_precisions!(poisoned_lanes_are_frozen_and_isolated);
}

/// f32 on the GPU against the f64 CPU reference in periodic regimes, through the public
/// ensemble API: a stable periodic orbit damps the f32 rounding (about 1e-9 m per step
/// at |x| ~ 5e-3 m) instead of amplifying it, so both must settle on the same cycle:
/// the same period detected, every Poincare point within 1e-5 m (positions) and
/// 1e-5 m x W (velocities).
#[test]
fn f32_gpu_lanes_find_the_f64_cpu_period_and_points_within_1e_5_m() {
    use jeffcott_analysis::backend::run;
    use jeffcott_analysis::classify::{Class, ClassifyConfig, classify};
    use jeffcott_core::ensemble::{Backend, EnsembleSpec, LaneSpec, Precision};
    if runner_for::<f32>().is_none() {
        return;
    }
    let p = Params::default();
    let mut lanes = Vec::new();
    // The article's period-1 and period-2 speeds and their neighbourhoods, from the
    // static equilibrium and from a throw against the stator.
    for omega in [131.5, 131.7, 132.0, 132.2, 132.3] {
        let mut thrown = p.static_equilibrium();
        thrown[X_R] = 0.0058;
        thrown[VX_R] = 0.8;
        for x0 in [p.static_equilibrium(), thrown] {
            lanes.push(LaneSpec {
                omega,
                x0,
                param_set: 0,
            });
        }
    }
    let spec = |precision| EnsembleSpec {
        param_sets: vec![p.clone()],
        lanes: lanes.clone(),
        transient: 1000,
        recorded: 64,
        stepper: StepperConfig::default(),
        precision,
    };
    let quiet = |_: u64, _: u64| {};
    let timed_run = |what: &str, precision, backend| {
        timed(what, || {
            run(&spec(precision), backend, false, Control::progress(&quiet))
        })
    };
    let (cpu, _) = timed_run(
        "CPU f64, 10 lanes x 1064 periods",
        Precision::F64,
        Backend::Cpu,
    )
    .expect("CPU run");
    let (gpu, info) = timed_run(
        "GPU f32, 10 lanes x 1064 periods",
        Precision::F32,
        Backend::Gpu,
    )
    .expect("GPU run");
    assert_eq!(info.backend, "gpu");
    let (cfg64, cfg32) = (
        ClassifyConfig::for_precision(Precision::F64),
        ClassifyConfig::for_precision(Precision::F32),
    );
    let mut periods = Vec::new();
    for (i, l) in lanes.iter().enumerate() {
        let (pc, pg) = (cpu.lane_states(i), gpu.lane_states(i));
        let cc = classify(&pc, l.omega, cpu.status[i].is_frozen(), &cfg64);
        let cg = classify(&pg, l.omega, gpu.status[i].is_frozen(), &cfg32);
        let Class::Periodic(n) = cc.class else {
            panic!(
                "lane {i} (W = {}) is not periodic on the CPU: {cc:?}",
                l.omega
            );
        };
        periods.push(n);
        let mut worst: f64 = 0.0;
        for (a, b) in pg.iter().zip(&pc) {
            for d in 0..STATE_DIM {
                let scale = if d % 2 == 0 { 1.0 } else { l.omega };
                worst = worst.max((a[d] - b[d]).abs() / scale);
            }
        }
        eprintln!(
            "W = {}: CPU f64 period-{n}, GPU f32 {}, worst difference {worst:.2e} m (size {:.1e} m, f32 repeat error {:.1e} m, tol {:.1e} m)",
            l.omega,
            cg.class.label(),
            cc.size,
            cg.repeat_error,
            cg.tol
        );
        assert_eq!(cg.class, cc.class, "lane {i} (W = {})", l.omega);
        assert!(worst <= 1e-5, "lane {i} (W = {}): {worst:e} m", l.omega);
    }
    assert!(periods.contains(&1) && periods.contains(&2), "{periods:?}");
}

/// `jeffcott info --kernel-stats` builds every lane-kernel variant through raw Vulkan
/// (jeffcott-gpu's stats.rs: its own device, descriptor layout and pipelines from the
/// runner's exact SPIR-V words): each compiles on every Vulkan device, and where the
/// driver offers VK_KHR_pipeline_executable_properties each has statistics (Mesa 22.3's
/// lavapipe offers none: that half says skipped there).
#[test]
fn every_kernel_variant_compiles_through_raw_vulkan_with_the_drivers_statistics() {
    if common::gpu::runner().is_none() {
        return;
    }
    let devices = jeffcott_gpu::stats::kernel_statistics().expect("a Vulkan instance");
    assert!(!devices.is_empty(), "no Vulkan device");
    for d in devices {
        let kernels = d
            .kernels
            .unwrap_or_else(|e| panic!("{}: the kernel does not compile: {e}", d.device));
        // f32 plain and lambda_1, and with f64 the f64 and driver's-f32 variants too;
        // each with and without the exact free-flight step, each with its constants per
        // lane, shared but the speed's and shared; then the anatomy's six parts (the
        // kernel's entry point among them) in f32, and in f64 where there is f64.
        assert!(
            kernels.len() == 12 + 6 || kernels.len() == 36 + 12,
            "{} kernels",
            kernels.len()
        );
        let parts = kernels.iter().filter(|k| k.kernel.starts_with("anatomy: "));
        assert_eq!(parts.count(), if kernels.len() == 18 { 6 } else { 12 });
        if !d.offers_statistics {
            eprintln!("skipped: {} offers no pipeline statistics", d.device);
            continue;
        }
        for k in &kernels {
            assert!(!k.executables.is_empty(), "{}: no executable", k.kernel);
            for (exe, stats) in &k.executables {
                assert!(!stats.is_empty(), "{} [{exe}]: no statistics", k.kernel);
                eprintln!("{} [{exe}]: {stats:?}", k.kernel);
            }
        }
    }
}

/// The exact free-flight step on the GPU (the kernel variant with EXACT_FREE_FLIGHT, the
/// map in each lane's constants) equals the CPU's lane stepper in both precisions, to
/// the bit where identity is promised, and it really runs: the lanes differ from RK4's.
#[test]
fn exact_free_flight_on_the_gpu_equals_the_cpu_lane_stepper_to_the_bit() {
    common::gpu::in_both_precisions(
        check_exact_free_flight::<f32>,
        check_exact_free_flight::<f64>,
    );
}

fn check_exact_free_flight<R: GpuReal>(runner: &GpuRunner) {
    let n = 130;
    let cfg = StepperConfig {
        exact_free_flight: true,
        ..config()
    };
    let (consts, init, _) = ensemble_with::<R>(n, &cfg);
    assert!(consts.iter().all(|lc| lc.exact.is_some()));
    let schedule = Schedule::new(TRANSIENT, RECORDED, 10);
    let gpu = runner.run(&consts, &init, &schedule).expect("GPU run");
    let cpu = cpu_run(&consts, &init, TRANSIENT, RECORDED);
    let same = count_identical(&gpu, &cpu);
    eprintln!(
        "{} exact free flight: {same}/{n} lanes bit-identical",
        R::WGSL_NAME
    );
    if identity_promised::<R>(runner, device_variant(runner, false)) {
        assert_eq!(same, n, "lanes not bit-identical");
    } else {
        eprintln!("skipped: bit-identity is not promised on this adapter");
    }
    let (rk4_consts, _, _) = ensemble_with::<R>(n, &config());
    let rk4 = cpu_run(&rk4_consts, &init, TRANSIENT, RECORDED);
    assert!(
        rk4.iter().zip(&cpu).any(|(a, b)| !identical(a, b)),
        "the exact step changed nothing"
    );
}

#[test]
fn the_kernel_in_either_form_with_shared_or_per_lane_constants_gives_the_cpus_bits() {
    // Variant::consts_each_step: hardware reads a lane's constants at every sub-step and
    // keeps the committed lane in its buffer (advance_buffered), lavapipe reads them once
    // and holds the lane (advance_held; its loads are gathers). Each adapter runs one
    // form by default; JEFFCOTT_GPU_CONSTS runs the other, so CI's lavapipe checks both
    // forms, with and without the exact free-flight map, in both precisions, for lanes
    // that share their constants (one speed: Variant::shared_fields) and for lanes that
    // share only some (a speed and a friction coefficient per lane). The GPU form's lean
    // path runs with its forcing table and, JEFFCOTT_GPU_FORCING=polynomial, without.
    let Some(runner) = runner_for::<f64>() else {
        return;
    };
    if !f64_bit_identity_promised(runner) {
        eprintln!("skipped: bit-identity is not promised on this adapter");
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let xr = |i: usize| -0.004 + 0.008 * i as f64 / 47.0;
    let shared = tmp.path().join("shared.csv");
    let rows: Vec<String> = (0..48).map(|i| format!("{}", xr(i))).collect();
    std::fs::write(&shared, format!("x_r\n{}\n", rows.join("\n"))).unwrap();
    let per_lane = tmp.path().join("per-lane.csv");
    let rows: Vec<String> = (0..48)
        .map(|i| {
            format!(
                "{},{},{}",
                130.0 + 0.125 * i as f64,
                0.1 + 0.002 * i as f64,
                xr(i)
            )
        })
        .collect();
    std::fs::write(&per_lane, format!("omega,mu,x_r\n{}\n", rows.join("\n"))).unwrap();
    let run = |backend: &str, precision: &str, lanes: &str, extra: &str, form: (&str, &str)| {
        let (consts, forcing) = form;
        let out = tmp.path().join(format!(
            "{backend}-{precision}-{}-{}-{consts}-{forcing}",
            lanes.len(),
            extra.len()
        ));
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_jeffcott"))
            .args(common::words(&format!(
                "ensemble {lanes} --transient 0 --periods 12 --steps-per-period 400 \
                 --backend {backend} --precision {precision} --quiet {extra} --out {}",
                out.display()
            )))
            .env(jeffcott_gpu::device::CONSTS_VAR, consts)
            .env(jeffcott_gpu::device::FORCING_VAR, forcing)
            .output()
            .unwrap();
        common::ok(&o);
        ["poincare.npy", "status.npy"].map(|f| std::fs::read(out.join(f)).unwrap())
    };
    let tables = [
        format!("--lanes {} --omega 133", shared.display()),
        format!("--lanes {}", per_lane.display()),
    ];
    for lanes in &tables {
        for precision in ["f64", "f32"] {
            for extra in ["", "--exact-free-flight --contact-substeps 4"] {
                let cpu = run("cpu", precision, lanes, extra, ("", ""));
                // The GPU form's lean path with its forcing table (both lane tables share
                // N and phi0) and with the polynomial.
                let forms = [
                    ("once", ""),
                    ("each-step", "table"),
                    ("each-step", "polynomial"),
                ];
                for form in forms {
                    let gpu = run("gpu", precision, lanes, extra, form);
                    assert!(
                        gpu == cpu,
                        "{precision} {extra} {lanes} with {form:?}: the GPU's lanes differ from the CPU's"
                    );
                }
            }
        }
    }
}

#[test]
fn every_part_of_the_kernels_anatomy_computes_its_cpu_reference_to_the_bit() {
    // The anatomy (jeffcott_gpu::anatomy) times parts of the kernel alone on a GPU; a
    // part that computed less than it claims (a loop the compiler removed, a search
    // whose result is unused) would time nothing. Each must give its CPU reference's
    // states, records and counters, through chunks and several time slices (the kernel
    // itself, run the anatomy's way, the lane stepper's).
    both_precisions!(check_anatomy);
}

fn check_anatomy<R: GpuReal>(runner: &GpuRunner) {
    use jeffcott_gpu::anatomy::{Part, cpu_period};
    let n = 66;
    let periods = 3;
    let (consts, init, _) = ensemble::<R>(n);
    let schedule = Schedule {
        max_lanes_per_chunk: Some(40),
        ..Schedule::new(0, periods, 2)
    };
    let promised = identity_promised::<R>(runner, device_variant(runner, false));
    let mut cpus = Vec::new();
    for part in Part::ALL {
        let (gpu, _) = runner
            .run_anatomy(part, &consts, &init, &schedule)
            .expect("anatomy run");
        let cpu: Vec<LaneOutcome<R>> = consts
            .iter()
            .zip(&init)
            .map(|(lc, lane0)| {
                let mut lane = *lane0;
                let poincare = (0..periods)
                    .map(|_| {
                        cpu_period(part, lc, &mut lane);
                        lane.state_f64()
                    })
                    .collect();
                LaneOutcome { poincare, lane }
            })
            .collect();
        assert!(
            cpu.iter()
                .all(|o| o.lane.state_f64().iter().all(|v| v.is_finite())),
            "{}: a lane left the finite numbers",
            part.name()
        );
        let same = count_identical(&gpu, &cpu);
        eprintln!(
            "{} anatomy {}: {same}/{n} lanes bit-identical",
            R::WGSL_NAME,
            part.name()
        );
        if promised {
            assert_eq!(same, n, "{}: lanes not bit-identical", part.name());
        }
        cpus.push(cpu);
    }
    // Each part does what it says: the vector form is the array form's arithmetic; the
    // certainty test and the search leave the state alone and find lanes near the
    // stator; contact changes the trajectories; the kernel locates switches.
    let [kernel, rk4, scalar, certain, search, contact] = &cpus[..] else {
        unreachable!()
    };
    let state_bits = |o: &LaneOutcome<R>| o.lane.state_f64().map(f64::to_bits);
    for other in [scalar, certain, search] {
        assert!(
            rk4.iter()
                .zip(other)
                .all(|(a, b)| state_bits(a) == state_bits(b))
        );
    }
    assert!(certain.iter().any(|o| o.lane.counters.contact_steps > 0));
    assert!(certain.iter().any(|o| o.lane.counters.contact_steps == 0));
    assert!(search.iter().any(|o| o.lane.counters.switches > 0));
    assert!(contact.iter().all(|o| o.lane.counters.extra_substeps > 0));
    assert!(
        rk4.iter()
            .zip(contact)
            .all(|(a, b)| state_bits(a) != state_bits(b))
    );
    assert!(kernel.iter().any(|o| o.lane.counters.switches > 0));
}

#[test]
fn bench_anatomy_rows_follow_the_kernels_row_and_bad_part_names_are_refused() {
    let bench = |extra: &str, out: &std::path::Path| {
        std::process::Command::new(env!("CARGO_BIN_EXE_jeffcott"))
            .args(common::words(&format!(
                "bench --backend gpu --lanes 128 --lane-periods 512 --precision f32 \
                 --twin-at 0 {extra} --out {}",
                out.display()
            )))
            .output()
            .unwrap()
    };
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("bench.json");
    let bad = bench("--anatomy rk4,rk5", &out);
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("anatomy") && err.contains("rk5"), "{err}");
    if common::gpu::runner().is_none() {
        return;
    }
    common::ok(&bench("--anatomy contact,rk4", &out));
    let rows: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let kernels: Vec<&str> = rows
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["kernel"].as_str().unwrap())
        .collect();
    assert_eq!(kernels, ["lane kernel", "anatomy: contact", "anatomy: rk4"]);
    for r in rows.as_array().unwrap() {
        assert!(r["lane_steps_per_s"].as_f64().unwrap() > 0.0);
        assert_eq!(r["lanes"], 128);
    }
}
