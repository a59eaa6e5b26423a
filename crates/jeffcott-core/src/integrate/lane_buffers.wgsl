// The ensemble lane stepper on the GPU, part 1 of 8: the buffers and the helpers that
// stand in for the Real trait. One invocation advances one lane (one trajectory of the
// rotor-stator system, docs/numerics.md) by a time slice of whole forcing periods, with the
// state held in registers for the whole slice.
//
// The kernel is eight files, each beside the Rust module it mirrors, concatenated in this
// order by `integrate::lane::WGSL` (the list is `integrate::lane::WGSL_FILES`):
//   integrate/lane_buffers.wgsl   this file: GPU-visible structs (keep in sync with
//                                 jeffcott-gpu's layout.rs), bindings, helpers
//   integrate/forcing.wgsl        integrate/forcing.rs (phasor_turns)
//   model.wgsl                    model.rs (penetration, contact_force_per_kc,
//                                 contact_partials, rhs_frozen)
//   integrate/tangent.wgsl        integrate/tangent.rs (tangent vectors, saltation)
//   integrate/switch.wgsl         integrate/switch.rs (the switch search)
//   integrate/free_flight.wgsl    integrate/free_flight.rs (the exact free-flight step)
//   integrate/lane.wgsl           integrate/lane.rs (the macro step)
//   integrate/lane_entry.wgsl     the entry point (lane.rs's advance_period)
// The mirrored functions have the same names, in the same order as in their .rs file,
// doing the same arithmetic in the same order, so that the f64 variant reproduces the
// CPU f64 lane bit for bit on an IEEE device (and the f32 variant the CPU f32 lane);
// tests/mirror checks each of them on the GPU against its Rust function, and
// jeffcott-gpu's shader.rs checks the names and their order file by file.
//
// The concatenation is not valid WGSL on its own: jeffcott-gpu's shader.rs prepends a
// generated header that defines
//   alias Real = f32 | f64;                 the precision (docs/architecture.md)
//   WORKGROUP_SIZE, STATE_DIM, X_R .. VY_S, GRAZE_SAMPLES, ROOT_MAX_ITERS, STATUS_*
//   REAL_MAX, TAU, SIXTH, CERTIFICATE_SAFETY, SIN_C0 .. SIN_C8, COS_C0 .. COS_C8
//   LYAPUNOV (bool), RECORD_DIM                the pipeline variant (below)
//   EXACT_FREE_FLIGHT (bool)                   lanes may take the exact free-flight step
//   CONSTS_EACH_STEP (bool)                    the GPU form of the entry point
//                                              (lane_entry.wgsl)
//   lane_consts(i)                             lane i's constants, the fields every
//                                              lane of the run shares read from the
//                                              first lane's: `consts[0]` in the
//                                              software form, `shared_consts` in the
//                                              GPU form (shader.rs's Variant)
//   div_rn(a, b), sqrt_rn(x)                   every division and square root: a / b
//                                              and sqrt(x), in f32 done in f64 where
//                                              the device has f64 (correctly rounded on
//                                              any driver; shader.rs's Variant)
// from the Rust constants. Every non-dyadic floating constant lives in that header as
// an abstract-float literal holding the exact f64 value Rust uses; naga converts it to
// Real with `as f32` semantics, exactly like `Real::lit`. The literals written inline
// in the kernel (0.0, 0.25, 0.5, 1.0, 2.0, 3.0, 4.0, 6.0) are exact in both precisions.
//
// Two pipeline variants per precision. With LYAPUNOV = false (the plain kernel) every
// `if LYAPUNOV` block is dead code the compiler removes. With LYAPUNOV = true each lane
// carries one tangent vector (in `tangents`), advanced with the state over every accepted
// sub-step (rk4_tangent_substep), mapped by the saltation matrix at every located
// switch (saltation), and renormalised at the end of every forcing period; its length
// before renormalisation is written after the state in each record (RECORD_DIM = 9)
// and the host sums the logarithms (no f64 `log` on the GPU, docs/gpu.md).
//
// Rules kept in every part (docs/gpu.md): no trigonometry at all (the forcing phasor is
// a polynomial), no recursion, every loop bounded by a constant or a lane constant.
// Builtins whose NaN behaviour is implementation-defined (`max`, `min`) are not used:
// `rmax` spells out the CPU's comparison instead.

// ---- buffers ------------------------------------------------------------------------

// Equation coefficients of one lane (model::Coeffs).
struct Coeffs {
    wr2x: Real,
    wr2y: Real,
    drx: Real,
    dry: Real,
    ws2x: Real,
    ws2y: Real,
    dsx: Real,
    dsy: Real,
    ox: Real,
    oy: Real,
    unbalance: Real,
    a_g: Real,
    kc_mr: Real,
    kc_ms: Real,
    mu: Real,
    delta: Real,
    tau_c: Real,
    n_c: Real,
    hc: Real,
}

// The exact free-flight map (integrate::free_flight::ExactFreeFlight): per oscillator
// j the transition phi[4j..4j+4], the forced response's offset, cosine and sine parts,
// and the rotor speed.
struct FreeFlight {
    phi: array<Real, 16>,
    off: array<Real, 4>,
    p: array<Real, 4>,
    q: array<Real, 4>,
    omega: Real,
}

// Constants of one lane (integrate::lane::LaneConsts).
struct LaneConsts {
    c: Coeffs,
    h: Real,
    inv_n: Real,
    phase0: Real,
    bound: Real,
    root_tol: Real,
    // 1/R: the longest sub-step in contact (contact refinement).
    inv_r: Real,
    // The exact free-flight map, used where `exact` is 1 (LaneConsts::exact is Some).
    ff: FreeFlight,
    n: u32,
    max_segments: u32,
    exact: u32,
    pad: u32,
}

// integrate::lane::Counters, with u32 counts that saturate at 2^32 - 1 (the host widens
// them to u64) and the largest penetration in the lane's precision.
struct Counters {
    macro_steps: u32,
    contact_steps: u32,
    switches: u32,
    extra_substeps: u32,
    max_penetration: Real,
}

// integrate::lane::Lane: contact is 0/1, status is Status::code().
struct Lane {
    x: array<Real, STATE_DIM>,
    contact: u32,
    k: u32,
    status: u32,
    // Forcing periods completed (GPU only: where to resume after an interrupted slice).
    period: u32,
    counters: Counters,
}

// One dispatch advances lanes [0, n_lanes) of the bound chunk to the end of global
// period `period_end - 1`, from the slice start `period_begin` (or wherever an earlier
// dispatch of the same slice left them). The state after global period p is recorded
// when p >= record_from, at slot p - period_begin. `probe` is 2 (see loop_budget_left).
struct Params {
    n_lanes: u32,
    period_begin: u32,
    period_end: u32,
    record_from: u32,
    probe: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> consts: array<LaneConsts>;
@group(0) @binding(2) var<storage, read_write> lanes: array<Lane>;
// Poincare points of this slice: [slot][lane][RECORD_DIM] (the state, then with
// LYAPUNOV the tangent's growth over the period).
@group(0) @binding(3) var<storage, read_write> records: array<Real>;
// [0]: lanes that did not reach period_end in this dispatch; [1]: those of them that
// could not commit a single macro step (the host zeroes both first).
@group(0) @binding(4) var<storage, read_write> unfinished: array<atomic<u32>, 2>;
// The lambda_1 variant's tangent vector of each lane (one element, untouched, in the
// plain kernel; the host's explicit bind group layout has it in both variants).
@group(0) @binding(5) var<storage, read_write> tangents: array<array<Real, STATE_DIM>>;

// The first lane's constants, for the GPU form to read the fields every lane of the run
// shares (`lane_consts` in the header): a uniform operand costs no register on NVIDIA
// (a constant-bank operand) and lands in scalar registers on AMD, where a storage load
// at one address still takes a vector register per invocation. The reals of LaneConsts
// in their order (`r[k / 4][k % 4]` is real k), then n, max_segments, exact and a pad;
// vec4s because the uniform space wants array strides of 16 bytes. The software form
// leaves it alone (lavapipe reloads a uniform at every use).
struct SharedConsts {
    r: array<vec4<Real>, 14>,
    ints: vec4<u32>,
}

@group(0) @binding(6) var<uniform> shared_consts: SharedConsts;

// The unbalance phasor of the lean free-flight path (lane_entry.wgsl, with
// FORCING_TABLE): entry 2k + j is forcing_phasor(lc, k, j / 2) for every macro step k
// < N (entry 2N is step N - 1's end), the polynomial's own bits computed on the host
// (jeffcott-gpu's layout::forcing_table), for runs whose lanes share N and phi0. A look-up
// at one address for the lanes of a step replaces three polynomials of ~30 operations
// each. One unused element without FORCING_TABLE.
@group(0) @binding(7) var<storage, read> forcing_table: array<vec2<Real>>;

// ---- helpers standing in for the Real trait and u64 counters ----------------------

// Real::max: `if other > self { other } else { self }` (NaN keeps `a`).
fn rmax(a: Real, b: Real) -> Real {
    return select(a, b, b > a);
}

// Real::is_finite without bit tricks (WGSL has no f64 bitcast): NaN fails every ordered
// comparison and +-inf exceed REAL_MAX.
fn is_finite(v: Real) -> bool {
    return abs(v) <= REAL_MAX;
}

// Status::is_frozen.
fn is_frozen(status: u32) -> bool {
    return status == STATUS_DIVERGED || status == STATUS_NON_FINITE;
}

// `params.probe`, copied once per invocation by `advance_lanes` (see
// `loop_budget_left`): lavapipe reloads a uniform at every use inside a loop, as a
// gather of 8 scalar loads (perf: the probe's bound alone took 5% of a run). `keep`
// reads `params.n_lanes` itself: a private copy would be a known constant in any other
// entry point (tests/mirror has some), and the barrier would vanish there.
var<private> probe_n: u32;

// Returns `v`. An evaluation-order barrier: SPIR-V from naga carries no NoContraction
// decoration, so Mesa's NIR may apply inexact rewrites to + and *, among them
// "reassociate add chains for more MAD/FMA-friendly code", (p*q + r*s) + c ->
// (p*q + c) + r*s, which changes the rounding. `params.n_lanes` is never 0 in an
// invocation that computes anything (see `advance_lanes`), but the compiler cannot
// know that, so it cannot see through the select and keeps Rust's order. Used exactly
// where such a rewrite applies; tests/gpu.rs checks the CPU f64 lane bit for bit, and
// tests/mirror each function.
fn keep(v: Real) -> Real {
    return select(v, Real(0.0), params.n_lanes == 0u);
}

// Counter addition that sticks at u32::MAX instead of wrapping (CPU counters are u64).
fn sat_add(a: u32, b: u32) -> u32 {
    let s = a + b;
    return select(s, 0xffffffffu, s < a);
}
