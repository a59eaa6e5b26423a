//! The ensemble lane stepper (docs/numerics.md): one trajectory, advanced one macro step at
//! a time on a fixed grid of N steps per forcing period, with the contact crossings
//! located and the step split there.
//!
//! Why crossing location rather than error-controlled sub-stepping: the vector field is
//! only C0 at g = 0 (docs/model.md 2), and a kink inside an RK4 step drops the method to low
//! order. Holding the contact state fixed over each RK4 stage sequence (the contact
//! formula is continued analytically across g = 0) and splitting the step at the located
//! crossing restores fourth order; the convergence study (docs/convergence.md) measured
//! the cost and error of both choices.
//!
//! The structure is written for the GPU: no recursion, every loop bounded by a constant
//! or a lane constant, no allocation, no trigonometry. `integrate/lane.wgsl` mirrors this
//! file function by function: keep in sync with it.
//!
//! One macro step:
//! 1. trial RK4 step from the current sub-step start s to the macro step's end in free
//!    flight, or over at most 1/R of the macro step in contact (contact refinement,
//!    [`trial_extent`]: the contact stiffness's frequency makes RK4's error per step in
//!    contact ~1000 times that of free flight; the work-precision study in
//!    docs/performance.md chose R = 2), in the current contact mode;
//! 2. `find_switch`: sample the penetration g along the step on the cubic Hermite
//!    interpolant of the relative displacement (exact at both ends, O(H^4) inside) and
//!    take the first sample on the wrong side of g = 0 for the mode; this catches
//!    grazing contacts that enter and leave inside one step. Locate the crossing by the
//!    Illinois method on the interpolant;
//! 3. no crossing: accept (and go on from step 1 if the macro step is not done). Crossing
//!    at fraction theta: re-step from s to the crossing,
//!    flip the mode, continue from there. At most `max_segments` segments per macro
//!    step; a lane that needs more is finished without switching and flagged.
//!
//! Lyapunov exponents ride on the same structure ([`macro_step_tangent`]): tangent
//! vectors V of the variational equations dV/dt = J(x(t)) V are advanced over every
//! accepted sub-step by RK4 on the same stages and in the same frozen contact mode as
//! the state (so V is the derivative of the discrete sub-step map), and at every located
//! switch Mueller's saltation matrix S = I + (f+ - f-) n^T / (n^T f-), n = grad g, is
//! applied to them ([`saltation`]). With no tangent vectors (M = 0, what
//! [`macro_step`] runs) all of that compiles away and the state arithmetic is untouched.

/// The kernel body that `jeffcott-gpu` completes with a generated header (types,
/// constants) and compiles: the parts of [`WGSL_FILES`] concatenated in their order.
/// Each part lives beside the Rust module it mirrors (this module's is `lane.wgsl`), so a
/// function and its mirror are read, changed and reviewed together.
pub const WGSL: &str = concat!(
    include_str!("lane_buffers.wgsl"),
    include_str!("forcing.wgsl"),
    include_str!("../model.wgsl"),
    include_str!("tangent.wgsl"),
    include_str!("switch.wgsl"),
    include_str!("free_flight.wgsl"),
    include_str!("lane.wgsl"),
    include_str!("lane_entry.wgsl"),
);

/// The parts of [`WGSL`] in their order, as (path under `jeffcott-core/src`, text):
/// the buffers and helpers, the mirrors of `integrate::forcing`, `model`,
/// `integrate::tangent`, `integrate::switch` and this module, and the entry point (which
/// stands in for [`advance_period`]).
pub const WGSL_FILES: [(&str, &str); 8] = [
    (
        "integrate/lane_buffers.wgsl",
        include_str!("lane_buffers.wgsl"),
    ),
    ("integrate/forcing.wgsl", crate::integrate::forcing::WGSL),
    ("model.wgsl", crate::model::WGSL),
    ("integrate/tangent.wgsl", include_str!("tangent.wgsl")),
    ("integrate/switch.wgsl", include_str!("switch.wgsl")),
    (
        "integrate/free_flight.wgsl",
        include_str!("free_flight.wgsl"),
    ),
    ("integrate/lane.wgsl", include_str!("lane.wgsl")),
    ("integrate/lane_entry.wgsl", include_str!("lane_entry.wgsl")),
];

use crate::integrate::batch::ForcingTable;
use crate::integrate::forcing::phasor_turns;
use crate::integrate::free_flight::{ExactFreeFlight, free_flight_step, free_flight_tangent};
use crate::model::{Coeffs, STATE_DIM, X_R, X_S, Y_R, Y_S, penetration, rhs_frozen};
use crate::real::Real;
use serde::Serialize;

pub use super::switch::{
    GRAZE_SAMPLES, ROOT_MAX_ITERS, Switch, certificate_safety, clear_of_stator, control_points,
    find_switch, free_flight_certain, hermite_gap, hull_reach_sq, in_contact_certain,
    search_needless, wrong_side,
};
pub use super::tangent::{
    LAMBDA1_START, Tangent, renormalise, rk4_tangent_substep, saltation, stage_partials,
    tangent_rhs,
};

/// Per-lane outcome (docs/architecture.md). Ordered by severity: a worse status replaces a
/// milder one, never the reverse.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
#[repr(u32)]
pub enum Status {
    /// Integrated as specified.
    Ok = 0,
    /// Some macro step needed more than `max_segments` contact switches; those steps
    /// were finished without switching, so the result is less accurate than specified.
    RefinementCap = 1,
    /// The state left the divergence bound; the lane is frozen at the last good state.
    Diverged = 2,
    /// The state became NaN or infinite; the lane is frozen at the last finite state.
    NonFinite = 3,
}

impl Status {
    /// True when the lane no longer advances.
    pub fn is_frozen(self) -> bool {
        matches!(self, Status::Diverged | Status::NonFinite)
    }

    /// The status code stored in files (`status.npy`) and on the GPU.
    pub fn code(self) -> u32 {
        self as u32
    }

    /// The status for a code (`None` for an unknown code, e.g. a corrupt GPU buffer).
    pub fn from_code(code: u32) -> Option<Status> {
        [
            Status::Ok,
            Status::RefinementCap,
            Status::Diverged,
            Status::NonFinite,
        ]
        .into_iter()
        .find(|s| s.code() == code)
    }
}

/// Constants of one lane, in the lane's precision.
#[derive(Clone, Copy, Debug)]
pub struct LaneConsts<R: 'static> {
    /// Equation coefficients for this lane's parameters and speed.
    pub c: Coeffs<R>,
    /// Macro step h = T/N [s].
    pub h: R,
    /// 1/N.
    pub inv_n: R,
    /// phi0 / (2 pi) [turns].
    pub phase0: R,
    /// Divergence bound on every position coordinate [m].
    pub bound: R,
    /// Width at which the crossing search stops, as a fraction of the sub-step.
    pub root_tol: R,
    /// Macro steps per forcing period N.
    pub n: u32,
    /// Cap on segments (contact switches + 1) per macro step.
    pub max_segments: u32,
    /// 1/R: the longest sub-step taken in contact, as a fraction of the macro step.
    pub inv_r: R,
    /// The exact flow map for macro steps begun in free flight
    /// ([`StepperConfig::exact_free_flight`]); `None`: RK4 throughout.
    pub exact: Option<ExactFreeFlight<R>>,
    /// The unbalance phasor at the fractions sub-steps usually start and end at, for
    /// this lane's N, phi0 and R (`batch::ForcingTable::interned`; the polynomial's own
    /// values, so a lookup changes no bit): [`forcing_phasor`] looks there first.
    /// `None` where there is none (host only: the GPU kernel evaluates the polynomial).
    pub forcing: Option<&'static ForcingTable<R>>,
    /// The optional terms of the equations `c` uses, decided once here (`c.terms()`), so
    /// a batch picks its code without comparing coefficients at every step.
    pub terms: crate::model::Terms,
}

/// Settings of the lane stepper that are not model parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct StepperConfig {
    /// Macro steps per forcing period N.
    pub steps_per_period: u32,
    /// Cap on segments per macro step.
    pub max_segments: u32,
    /// Divergence bound on every position coordinate [m].
    pub divergence_bound: f64,
    /// Contact refinement R: a sub-step taken in contact covers at most 1/R of the macro
    /// step (see the module docs). Runs recorded before R existed used R = 1.
    #[serde(default = "no_contact_refinement")]
    pub contact_substeps: u32,
    /// Early exit (`ensemble::early`): periods a lane integrates before it may retire
    /// on a known attractor. Only the attractor-labelling studies use it. Default 30
    /// (against 100): the same labels at 133, 137.25 and 166 rad/s
    /// (k_c = 1e6) and 9.5 % less time at 133 (docs/early-exit.md).
    #[serde(default)]
    pub early_exit_after: u32,
    /// Early exit: Poincare points in a row on a known attractor (at least two of its
    /// cycles) that retire a lane; 0 turns early exit off. Runs recorded before early
    /// exit existed had it off (0).
    #[serde(default)]
    pub early_exit_streak: u32,
    /// A macro step begun in free flight takes the exact flow map of the free motion
    /// (`integrate::free_flight`) as its trial step instead of RK4; crossings, contact
    /// sub-steps and partial steps stay RK4. Its error is then all contact's, so N can
    /// halve where R doubles (docs/performance.md). Both backends, the same bits. A lane
    /// whose free motion has no such map (an oscillator not underdamped, or undamped at
    /// its resonance: `ExactFreeFlight::new`) takes RK4 throughout. Runs recorded before
    /// it existed used RK4 (false).
    #[serde(default)]
    pub exact_free_flight: bool,
    /// lambda_1: forcing periods the tangent vector aligns before a lane's record. It
    /// starts afresh `lyapunov_align` periods before the record (at period 0 when the
    /// transient is shorter), and until then the lanes carry none, so a lambda_1 study
    /// costs a tangent step only over these periods and the record: an estimate needs
    /// a few 1/(lambda_1 - lambda_2) of alignment (Benettin et al., Meccanica 15 (1980)),
    /// not the whole transient (docs/performance.md). 0: over the whole transient, as
    /// runs recorded before it existed did.
    #[serde(default)]
    pub lyapunov_align: u32,
}

fn no_contact_refinement() -> u32 {
    1
}

/// The stepper options one trajectory reads, as its run records them
/// ([`StepperConfig::serialize_flow`]).
#[derive(Serialize)]
struct FlowStepper {
    steps_per_period: u32,
    max_segments: u32,
    divergence_bound: f64,
    contact_substeps: u32,
    exact_free_flight: bool,
}

impl StepperConfig {
    /// Writes the options a single trajectory or orbit reads (for `serialize_with`):
    /// early exit and lambda_1's alignment belong to the studies of many lanes, so the
    /// record of a run that never reads them leaves them out, and a re-run that
    /// changes them is the same run.
    pub fn serialize_flow<S: serde::Serializer>(
        c: &StepperConfig,
        s: S,
    ) -> std::result::Result<S::Ok, S::Error> {
        FlowStepper {
            steps_per_period: c.steps_per_period,
            max_segments: c.max_segments,
            divergence_bound: c.divergence_bound,
            contact_substeps: c.contact_substeps,
            exact_free_flight: c.exact_free_flight,
        }
        .serialize(s)
    }

    /// The period at which a lane whose record starts at period `record_from` starts
    /// its tangent vector afresh ([`StepperConfig::lyapunov_align`]; 0 with 0).
    pub fn tangent_from(&self, record_from: u32) -> u32 {
        if self.lyapunov_align == 0 {
            0
        } else {
            record_from.saturating_sub(self.lyapunov_align)
        }
    }

    /// The period a lane's record starts at when it is recognised on an attractor at
    /// period `k` of its transient `transient` and recorded from there
    /// (`ensemble::early::Then::Record`): at `k` itself without lambda_1 or with
    /// `lyapunov_align` 0, else after its tangent has aligned over `lyapunov_align`
    /// periods (restarted at `k` if it was not running yet), at `transient` at the
    /// latest.
    pub fn record_early_from(&self, k: u32, transient: u32, lambda1: bool) -> u32 {
        if !lambda1 || self.lyapunov_align == 0 {
            k
        } else {
            k.saturating_add(self.lyapunov_align).min(transient)
        }
    }

    /// The defaults, in one place: the command line's option defaults and the Python
    /// package's keyword defaults are these fields.
    pub const DEFAULT: StepperConfig = StepperConfig {
        steps_per_period: DEFAULT_STEPS_PER_PERIOD,
        max_segments: 16,
        divergence_bound: 1.0,
        contact_substeps: DEFAULT_CONTACT_SUBSTEPS,
        early_exit_after: 30,
        early_exit_streak: 16,
        exact_free_flight: false,
        lyapunov_align: 100,
    };
}

impl Default for StepperConfig {
    fn default() -> Self {
        StepperConfig::DEFAULT
    }
}

/// Default N, fixed by the convergence study (docs/convergence.md).
pub const DEFAULT_STEPS_PER_PERIOD: u32 = 500;

/// Default contact refinement R, fixed by the work-precision study (docs/performance.md).
pub const DEFAULT_CONTACT_SUBSTEPS: u32 = 2;

/// The largest contact refinement R accepted.
pub const MAX_CONTACT_SUBSTEPS: u32 = 16;

impl StepperConfig {
    /// Checks the settings; errors name the option and the allowed range.
    pub fn validate(&self) -> crate::Result<()> {
        use crate::Error;
        if !(8..=1_000_000).contains(&self.steps_per_period) {
            return Err(Error::invalid(
                "steps-per-period",
                self.steps_per_period,
                "must be in 8..=1000000",
            ));
        }
        // The GPU kernel runs a macro step within one invocation; Mesa's llvmpipe stops
        // loops after 65535 iterations in total (~130 per segment), so the cap stays well
        // inside that.
        if !(2..=256).contains(&self.max_segments) {
            return Err(Error::invalid(
                "max-segments",
                self.max_segments,
                "must be in 2..=256",
            ));
        }
        crate::inputs::check_positive("divergence-bound", self.divergence_bound, "m")?;
        // Powers of two only: then 1/R and every sum of it from 0 are exact in binary
        // floating point, so R sub-steps of 1/R end exactly at the macro step's end and
        // no sliver of a sub-step is left over from rounding.
        if !(self.contact_substeps.is_power_of_two()
            && self.contact_substeps <= MAX_CONTACT_SUBSTEPS)
        {
            return Err(Error::invalid(
                "contact-substeps",
                self.contact_substeps,
                "must be one of 1, 2, 4, 8, 16",
            ));
        }
        crate::limits::check_periods("early-exit-after", self.early_exit_after, 0)?;
        crate::limits::check_periods("lyapunov-align", self.lyapunov_align, 0)?;
        if self.early_exit_streak > 100_000 {
            return Err(Error::invalid(
                "early-exit-streak",
                self.early_exit_streak,
                "must be in 0..=100000 (0 turns early exit off)",
            ));
        }
        Ok(())
    }
}

impl<R: Real> LaneConsts<R> {
    /// Builds the constants for one lane from `f64` inputs (rounded once, here).
    pub fn new(p: &crate::model::Params, omega: f64, cfg: &StepperConfig) -> Self {
        let period = std::f64::consts::TAU / omega;
        let n = cfg.steps_per_period;
        // The search stops near the precision's resolution of a fraction in [0, 1].
        let root_tol = if R::WGSL_NAME == "f64" { 1e-13 } else { 2e-6 };
        let c = Coeffs::new(p, omega);
        let mut lc = LaneConsts {
            c,
            terms: c.terms(),
            h: R::lit(period / n as f64),
            inv_n: R::lit(1.0 / n as f64),
            phase0: R::lit(p.phi0 / std::f64::consts::TAU),
            bound: R::lit(cfg.divergence_bound),
            root_tol: R::lit(root_tol),
            n,
            max_segments: cfg.max_segments,
            inv_r: R::lit(1.0 / cfg.contact_substeps as f64),
            exact: if cfg.exact_free_flight {
                ExactFreeFlight::new(p, omega, n)
            } else {
                None
            },
            forcing: None,
        };
        lc.forcing = ForcingTable::interned(&lc);
        lc
    }
}

/// Counters of one lane (summed over everything it integrated).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Counters {
    /// Macro steps integrated.
    pub macro_steps: u64,
    /// Macro steps in which the rotor touched the stator.
    pub contact_steps: u64,
    /// Located contact switches (entries plus exits).
    pub switches: u64,
    /// RK4 sub-steps beyond one per macro step (the cost of refinement).
    pub extra_substeps: u64,
    /// Largest penetration g seen at the sampled points [m] (0 if never in contact).
    pub max_penetration: f64,
}

/// The state of one lane between macro steps.
#[derive(Clone, Copy, Debug)]
pub struct Lane<R> {
    /// The state vector.
    pub x: [R; STATE_DIM],
    /// The contact mode carried across steps (not recomputed from the sign of g, which
    /// roundoff could flip at a located crossing).
    pub contact: bool,
    /// Index of the next macro step within the current period, 0..N.
    pub k: u32,
    /// Outcome so far.
    pub status: Status,
    /// Counters.
    pub counters: Counters,
}

impl<R: Real> Lane<R> {
    /// A lane starting at `x0` (f64, rounded to the lane's precision) at t = 0.
    pub fn new(x0: &[f64; STATE_DIM], delta: f64) -> Self {
        let x = x0.map(R::lit);
        let finite = x.iter().all(|v| v.is_finite());
        Lane {
            x,
            contact: finite && penetration(R::lit(delta), &x) > R::lit(0.0),
            k: 0,
            status: if finite {
                Status::Ok
            } else {
                Status::NonFinite
            },
            counters: Counters::default(),
        }
    }

    /// The state widened to f64.
    pub fn state_f64(&self) -> [f64; STATE_DIM] {
        self.x.map(|v| v.to_f64())
    }
}

/// Unbalance phasor at fraction `sigma` of macro step `k`.
#[inline(always)]
pub fn forcing_phasor<R: Real>(lc: &LaneConsts<R>, k: u32, sigma: R) -> (R, R) {
    // The table holds this function's own values at the fractions j / (2R), so a
    // lookup gives the polynomial's bits; a sub-step of a macro step untouched by a
    // switch starts and ends at such fractions (the WGSL mirror always evaluates).
    if let Some(v) = lc.forcing.and_then(|t| t.get(k, sigma)) {
        return v;
    }
    phasor_turns((R::lit(k as f64) + sigma) * lc.inv_n - lc.phase0)
}

/// One classical RK4 step over the fraction [s0, s0 + ds] of macro step k, contact mode
/// held fixed.
#[inline(always)]
pub fn rk4_substep<R: Real>(
    lc: &LaneConsts<R>,
    x: &[R; STATE_DIM],
    k: u32,
    s0: R,
    ds: R,
    contact: bool,
) -> [R; STATE_DIM] {
    let hs = ds * lc.h;
    let half = R::lit(0.5);
    let (c0, s0p) = forcing_phasor(lc, k, s0);
    let (cm, sm) = forcing_phasor(lc, k, s0 + half * ds);
    let (c1, s1) = forcing_phasor(lc, k, s0 + ds);
    let k1 = rhs_frozen(&lc.c, x, c0, s0p, contact);
    let mut xt = [R::lit(0.0); STATE_DIM];
    for i in 0..STATE_DIM {
        xt[i] = x[i] + half * hs * k1[i];
    }
    let k2 = rhs_frozen(&lc.c, &xt, cm, sm, contact);
    for i in 0..STATE_DIM {
        xt[i] = x[i] + half * hs * k2[i];
    }
    let k3 = rhs_frozen(&lc.c, &xt, cm, sm, contact);
    for i in 0..STATE_DIM {
        xt[i] = x[i] + hs * k3[i];
    }
    let k4 = rhs_frozen(&lc.c, &xt, c1, s1, contact);
    let sixth = R::lit(1.0 / 6.0);
    let mut out = [R::lit(0.0); STATE_DIM];
    for i in 0..STATE_DIM {
        out[i] = x[i] + hs * sixth * (k1[i] + R::lit(2.0) * (k2[i] + k3[i]) + k4[i]);
    }
    out
}

/// Length `ds` and end of the next trial sub-step from fraction `s` of the macro step:
/// to the macro step's end (exactly 1) in free flight; in contact at most 1/R of the
/// macro step (contact refinement: the contact stiffness adds a frequency about 40 times
/// the forcing's, docs/performance.md, so RK4's error there dominates at a step that
/// suits free flight). With R a power of two a macro step begun in contact is R exact
/// sub-steps. Keep in sync with `trial_extent` in `integrate/lane.wgsl`.
#[inline(always)]
pub fn trial_extent<R: Real>(lc: &LaneConsts<R>, s: R, contact: bool) -> (R, R) {
    let one = R::lit(1.0);
    if contact && one - s > lc.inv_r {
        (lc.inv_r, s + lc.inv_r)
    } else {
        (one - s, one)
    }
}

/// The exact free-flight map the trial sub-step from fraction `s` in mode `contact`
/// takes: the lane's, where it has one and the sub-step begins a macro step in free
/// flight (s = 0, so the step is the whole macro step); else `None`, RK4. The scalar
/// and batch steppers decide by this; the kernel's `macro_step` tests the same.
#[inline(always)]
pub fn exact_trial<R: Real>(
    lc: &LaneConsts<R>,
    s: R,
    contact: bool,
) -> Option<&ExactFreeFlight<R>> {
    lc.exact.as_ref().filter(|_| !contact && s == R::lit(0.0))
}

/// Advances the lane by one macro step (1/N of a forcing period). Frozen lanes do not
/// move. Keep in sync with `macro_step` in `integrate/lane.wgsl`.
pub fn macro_step<R: Real>(lc: &LaneConsts<R>, lane: &mut Lane<R>) {
    macro_step_tangent::<R, 0>(lc, lane, &mut Tangent::new([]));
}

/// [`macro_step`] carrying `M` tangent vectors (see the module docs): advanced over
/// every accepted sub-step, saltation applied at every located switch. The state
/// arithmetic is that of `macro_step` whatever `M`.
pub fn macro_step_tangent<R: Real, const M: usize>(
    lc: &LaneConsts<R>,
    lane: &mut Lane<R>,
    tan: &mut Tangent<R, M>,
) {
    if lane.status.is_frozen() {
        return;
    }
    let ms = macro_step_begin(lane);
    finish_macro_step(lc, lane, tan, ms, None);
}

/// A macro step in progress: the local variables of [`finish_macro_step`]'s segment
/// loop, so that the batch stepper can hand over a lane in the middle of a macro step
/// (after contact sub-steps it took itself) and the scalar stepper carries on exactly
/// where it stands. The kernel's `MacroStep` (lane.wgsl) holds the same, for the same
/// reason: it resumes a macro step between sub-steps.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MacroStep<R> {
    /// State at the sub-step start `s`.
    pub x: [R; STATE_DIM],
    /// Fraction of the macro step done.
    pub s: R,
    /// Current contact mode.
    pub contact: bool,
    /// In contact at some point of the macro step so far.
    pub touched: bool,
    /// RK4 sub-steps taken.
    pub substeps: u64,
    /// Located switches (each begins a new segment).
    pub switches: u32,
    /// Largest g sampled so far.
    pub max_g: R,
    /// The lane's largest penetration before this macro step
    /// (`Counters::max_penetration`): a search whose samples cannot exceed it changes
    /// no bit and is skipped ([`search_needless`]).
    pub max_pen: R,
}

/// The start of `lane`'s next macro step (`macro_step_begin` in lane.wgsl).
#[inline(always)]
pub(crate) fn macro_step_begin<R: Real>(lane: &Lane<R>) -> MacroStep<R> {
    MacroStep {
        x: lane.x,
        s: R::lit(0.0),
        contact: lane.contact,
        touched: lane.contact,
        substeps: 0,
        switches: 0,
        max_g: R::lit(f64::NEG_INFINITY),
        max_pen: R::lit(lane.counters.max_penetration),
    }
}

per_instruction_set! {
    /// Runs the segment loop of `lane`'s macro step from `p`, then the refinement cap,
    /// the status checks and the counters ([`macro_step_end`]). `trial`, when given, is
    /// the trial sub-step from `p` already computed (by the batch stepper, which hands
    /// the lane over because that step meets a switch): the same bits the loop's first
    /// trial step would compute, so it is not computed again.
    ///
    /// Compiled for AVX2 where the CPU has it (VEX encoding, `roundsd` for the forcing
    /// phase's floor instead of a libm call), else as built, and for AVX-512 only on
    /// request (`JEFFCOTT_AVX512=1`; `crate::dispatch::use_avx512`): the same operations
    /// in the same order without FMA, so the bits do not depend on the CPU. Every scalar
    /// step (a quasistatic sweep's, a single trajectory's, a lane handed over by the
    /// batch) goes through here.
    pub(crate) fn finish_macro_step[R: Real, const M: usize][R, M](
        lc: &LaneConsts<R>,
        lane: &mut Lane<R>,
        tan: &mut Tangent<R, M>,
        p: MacroStep<R>,
        trial: Option<[R; STATE_DIM]>,
    ) -> () = finish_macro_step_inner, avx512_on_amd: false
}

/// The body of [`finish_macro_step`], inlined into each instruction set's copy.
#[inline(always)]
fn finish_macro_step_inner<R: Real, const M: usize>(
    lc: &LaneConsts<R>,
    lane: &mut Lane<R>,
    tan: &mut Tangent<R, M>,
    mut p: MacroStep<R>,
    mut trial: Option<[R; STATE_DIM]>,
) {
    let one = R::lit(1.0);
    let k = lane.k;
    // Each pass is one trial sub-step that ends the macro step, ends a contact sub-step
    // (at most R per segment) or locates a switch (a new segment), so the loop runs at
    // most max_segments * (R + 1) times. The macro step is done when s reaches 1 (which a
    // MacroStep the batch stepper finished itself already is).
    while p.s < one && p.switches < lc.max_segments {
        let (ds, end) = trial_extent(lc, p.s, p.contact);
        let exact = exact_trial(lc, p.s, p.contact);
        let x1 = match (trial.take(), exact) {
            (Some(x1), _) => x1,
            (None, Some(ex)) => free_flight_step(ex, lc, &p.x, k),
            (None, None) => rk4_substep(lc, &p.x, k, p.s, ds, p.contact),
        };
        p.substeps += 1;
        // Where the search certainly finds no switch and no g above the lane's largest
        // penetration so far (search_needless), it would change no output bit: in free
        // flight clear of the stator, in contact held in it.
        let sw = if search_needless(lc.c.delta, &p.x, &x1, ds * lc.h, p.contact, p.max_pen) {
            Switch {
                theta: R::lit(2.0),
                max_g: p.max_g,
            }
        } else {
            find_switch(lc, &p.x, &x1, ds * lc.h, p.contact)
        };
        p.max_g = p.max_g.max(sw.max_g);
        if sw.theta > one {
            if M > 0 {
                trial_tangent(lc, exact, &p.x, k, p.s, ds, p.contact, tan);
            }
            p.x = x1;
            p.s = end;
            continue;
        }
        if sw.theta >= one {
            if M > 0 {
                trial_tangent(lc, exact, &p.x, k, p.s, ds, p.contact, tan);
            }
            p.x = x1;
            p.s = end;
        } else if sw.theta > R::lit(0.0) {
            if M > 0 {
                rk4_tangent_substep(lc, &p.x, k, p.s, ds * sw.theta, p.contact, tan);
            }
            p.x = rk4_substep(lc, &p.x, k, p.s, ds * sw.theta, p.contact);
            p.substeps += 1;
            p.s += ds * sw.theta;
        }
        if M > 0 && tan.saltation {
            saltation(lc, &p.x, k, p.s, p.contact, tan);
        }
        p.contact = !p.contact;
        p.touched = true;
        p.switches += 1;
    }
    if p.s < one {
        // Refinement cap: finish the step in the current mode and say so.
        if M > 0 {
            rk4_tangent_substep(lc, &p.x, k, p.s, one - p.s, p.contact, tan);
        }
        p.x = rk4_substep(lc, &p.x, k, p.s, one - p.s, p.contact);
        p.substeps += 1;
        p.contact = penetration(lc.c.delta, &p.x) > R::lit(0.0);
        if lane.status < Status::RefinementCap {
            lane.status = Status::RefinementCap;
        }
    }
    macro_step_end(lc, lane, &p);
}

/// The tangent step over an accepted trial sub-step: the exact map's own (its
/// transition, `exact`) or RK4's on the state step's stages.
/// Keep in sync with `trial_tangent` in `integrate/lane.wgsl`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn trial_tangent<R: Real, const M: usize>(
    lc: &LaneConsts<R>,
    exact: Option<&ExactFreeFlight<R>>,
    x: &[R; STATE_DIM],
    k: u32,
    s: R,
    ds: R,
    contact: bool,
    tan: &mut Tangent<R, M>,
) {
    match exact {
        Some(ex) => free_flight_tangent(ex, lc, tan),
        None => rk4_tangent_substep(lc, x, k, s, ds, contact, tan),
    }
}

/// The end of a macro step whose segments are done (`p.s >= 1` or capped): status
/// checks, then the new lane state and counters (`macro_step_end` in lane.wgsl).
#[inline(always)]
pub(crate) fn macro_step_end<R: Real>(lc: &LaneConsts<R>, lane: &mut Lane<R>, p: &MacroStep<R>) {
    let (x, contact, substeps, k) = (p.x, p.contact, p.substeps, lane.k);
    // Status checks: freeze at the last good state rather than poison anything.
    // Every component tested, without short-circuit: one vector test, where `&&`
    // compiled to a compare and branch per component (the batch's profile).
    let mut finite = true;
    for v in x.iter() {
        finite &= v.is_finite();
    }
    if !finite {
        lane.status = Status::NonFinite;
        return;
    }
    let reach = x[X_R]
        .abs()
        .max(x[Y_R].abs())
        .max(x[X_S].abs())
        .max(x[Y_S].abs());
    if reach > lc.bound {
        lane.status = Status::Diverged;
        return;
    }
    lane.x = x;
    lane.contact = contact;
    lane.k = if k + 1 == lc.n { 0 } else { k + 1 };
    let ct = &mut lane.counters;
    ct.macro_steps += 1;
    ct.contact_steps += p.touched as u64;
    ct.switches += u64::from(p.switches);
    ct.extra_substeps += substeps - 1;
    if p.touched {
        ct.max_penetration = ct.max_penetration.max(p.max_g.to_f64());
    }
}

/// Advances the lane by one forcing period (N macro steps), from k = 0 to k = 0.
pub fn advance_period<R: Real>(lc: &LaneConsts<R>, lane: &mut Lane<R>) {
    for _ in 0..lc.n {
        macro_step(lc, lane);
    }
}

/// [`advance_period`] carrying tangent vectors.
pub fn advance_period_tangent<R: Real, const M: usize>(
    lc: &LaneConsts<R>,
    lane: &mut Lane<R>,
    tan: &mut Tangent<R, M>,
) {
    for _ in 0..lc.n {
        macro_step_tangent(lc, lane, tan);
    }
}
