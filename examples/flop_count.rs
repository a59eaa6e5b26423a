//! Counts the floating-point arithmetic of one lane-step of the benchmark workload
//! (`jeffcott bench`: W = 133, default stepper) by running the lane stepper itself in a
//! counting number type, then times the CPU ensemble path on the same workload and
//! reports the fraction of the machine's f64 peak it reaches.
//!
//! The count is exact for the code as written: every `+ - * /`, `sqrt`, comparison and
//! negation the scalar stepper executes (the SIMD batch path executes the same
//! operations per lane, plus the lanes it computes and discards while other lanes of its
//! batch take contact sub-steps). The f64 batch path looks the forcing phasors up
//! (`batch::ForcingTable`) instead of evaluating them: the rate of flops is computed on
//! the count without them (three phasors per RK4 sub-step; the few sub-steps located at
//! a switch, which do evaluate them, are not added back).
//!
//! Usage: flop_count [LANES] [CORES] [GHZ] [FP_PORTS]   (default 16384 2 2.6 2: two
//! 512-bit FMA ports per core, 8 f64 per register)

use jeffcott_analysis::backend::run;
use jeffcott_analysis::bench::bench_spec;
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::{Backend, Precision};
use jeffcott_core::integrate::lane::advance_period;
use jeffcott_core::model::Params;
use jeffcott_core::real::{Arith, Real};
use std::cell::Cell;
use std::cmp::Ordering;
use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

thread_local! {
    /// add/sub, mul, div, sqrt, compare, neg.
    static OPS: Cell<[u64; 6]> = const { Cell::new([0; 6]) };
}

fn tick(i: usize) {
    OPS.with(|c| {
        let mut v = c.get();
        v[i] += 1;
        c.set(v);
    });
}

/// An f64 that counts the operations done on it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Counted(f64);

impl PartialOrd for Counted {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        tick(4);
        self.0.partial_cmp(&o.0)
    }
}
impl Add for Counted {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        tick(0);
        Counted(self.0 + o.0)
    }
}
impl Sub for Counted {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        tick(0);
        Counted(self.0 - o.0)
    }
}
impl Mul for Counted {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        tick(1);
        Counted(self.0 * o.0)
    }
}
impl Div for Counted {
    type Output = Self;
    fn div(self, o: Self) -> Self {
        tick(2);
        Counted(self.0 / o.0)
    }
}
impl Neg for Counted {
    type Output = Self;
    fn neg(self) -> Self {
        tick(5);
        Counted(-self.0)
    }
}
impl AddAssign for Counted {
    fn add_assign(&mut self, o: Self) {
        tick(0);
        self.0 += o.0;
    }
}
impl Arith for Counted {
    fn splat(x: f64) -> Self {
        Counted(x)
    }
    fn root(self) -> Self {
        tick(3);
        Counted(self.0.sqrt())
    }
    fn abs(self) -> Self {
        Counted(self.0.abs())
    }
    fn pow_half(self, m: Self) -> Self {
        jeffcott_core::model::pow_half(self, m)
    }
    fn pow_whole(self, m: Self) -> Self {
        jeffcott_core::model::pow_whole(self, m)
    }
}
impl Real for Counted {
    const WGSL_NAME: &'static str = "f64";
    const EPSILON: f64 = f64::EPSILON;
    fn lit(x: f64) -> Self {
        Counted(x)
    }
    fn to_f64(self) -> f64 {
        self.0
    }
    fn sqrt(self) -> Self {
        tick(3);
        Counted(self.0.sqrt())
    }
    fn floor(self) -> Self {
        tick(0);
        Counted(self.0.floor())
    }
    fn is_finite(self) -> bool {
        self.0.is_finite()
    }
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, d: f64| args.get(i).map_or(Ok(d), |s| s.parse::<f64>());
    let lanes = arg(0, 16384.0)? as usize;
    let cores = arg(1, 2.0)?;
    let ghz = arg(2, 2.6)?;
    let ports = arg(3, 2.0)?;
    let periods = 4;

    // Count on a 512-lane sample of the workload (the same lanes `bench` starts).
    let spec = bench_spec(&Params::default(), 512, periods, Precision::F64, false);
    let (mut steps, mut subs) = (0u64, 0u64);
    for i in 0..spec.lanes.len() {
        let lc = spec.lane_consts::<Counted>(i);
        let mut lane = spec.initial_lane::<Counted>(i);
        for _ in 0..periods {
            advance_period(&lc, &mut lane);
        }
        steps += lane.counters.macro_steps;
        subs += lane.counters.macro_steps + lane.counters.extra_substeps;
    }
    let sub_per_step = subs as f64 / steps as f64;
    let ops = OPS.with(|c| c.get());
    let per = |v: u64| v as f64 / steps as f64;
    let flops = per(ops[0] + ops[1] + ops[2] + ops[3]);
    println!(
        "per lane-step (macro step, {} counted): {:.0} add/sub, {:.0} mul, {:.1} div, {:.1} sqrt = {flops:.0} flops; plus {:.0} compares, {:.0} negations",
        steps,
        per(ops[0]),
        per(ops[1]),
        per(ops[2]),
        per(ops[3]),
        per(ops[4]),
        per(ops[5])
    );

    // The forcing phasors among them: three per RK4 sub-step, which the f64 batch path
    // looks up in its table (`batch::ForcingTable`) instead.
    OPS.with(|c| c.set([0; 6]));
    let _ = jeffcott_core::integrate::forcing::phasor_turns(Counted(0.3));
    let one = OPS.with(|c| c.get());
    let per_phasor = (one[0] + one[1] + one[2] + one[3]) as f64;
    let forcing = per_phasor * 3.0 * sub_per_step;
    println!(
        "of which forcing: {forcing:.0} flops ({per_phasor:.0} per phasor, 3 per RK4 sub-step, {sub_per_step:.3} sub-steps per lane-step); the f64 batch path looks these up: {:.0} flops per lane-step",
        flops - forcing
    );
    let flops = flops - forcing;

    // Time the real CPU path (batched, rayon) on the full workload.
    let spec = bench_spec(&Params::default(), lanes, periods, Precision::F64, false);
    let t = std::time::Instant::now();
    let (res, _) = run(&spec, Backend::Cpu, false, Control::none())?;
    let wall = t.elapsed().as_secs_f64();
    let lane_steps: u64 = res.counters.iter().map(|c| c.macro_steps).sum();
    let rate = lane_steps as f64 / wall;
    let gflops = rate * flops / 1e9;
    let peak_mul_add = cores * ghz * ports * 8.0;
    println!(
        "CPU f64, {lanes} lanes x {periods} periods: {wall:.2} s, {rate:.3e} lane-steps/s, {gflops:.1} GFLOP/s"
    );
    println!(
        "peak f64 ({cores} cores x {ghz} GHz x {ports} ports x 8 lanes): {peak_mul_add:.0} GFLOP/s without FMA ({:.0} % reached), {:.0} GFLOP/s with FMA ({:.0} % reached)",
        100.0 * gflops / peak_mul_add,
        2.0 * peak_mul_add,
        50.0 * gflops / peak_mul_add
    );
    Ok(())
}
