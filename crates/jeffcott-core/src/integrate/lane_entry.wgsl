// The lane kernel, part 8 of 8 (see lane_buffers.wgsl for the whole): the entry point.
// It stands in for lane.rs's advance_period (keep in sync with lane.rs): the same N
// macro steps per period, one sub-step at a time so that it can stop and resume between
// any two of them.

// True when this invocation may still run loops. Mesa's llvmpipe (lavapipe) ends every
// loop of an invocation once the loops together have iterated 65535 times
// (LP_MAX_TGSI_LOOP_ITERATIONS, shared by all loops of a shader) and carries on after
// them as if they had finished, which would corrupt a macro step silently. This loop
// runs `params.probe` (= 2, in `probe_n`) times unless that limit has been reached, so
// a failed probe right after a macro step says the step may be corrupt.
fn loop_budget_left() -> bool {
    var n = 0u;
    for (var q = 0u; q < probe_n; q++) {
        n += 1u;
    }
    return n == probe_n;
}

// Writes the Poincare point of global period `period` (the state at its end) if it is
// recorded, and with LYAPUNOV the tangent's growth `norm` over the period after it.
// Straight-line stores: no loop, so no loop-limit check can cut a record.
fn record(period: u32, i: u32, x: array<Real, STATE_DIM>, norm: Real) {
    if period < params.record_from {
        return;
    }
    let base = ((period - params.period_begin) * params.n_lanes + i) * RECORD_DIM;
    if LYAPUNOV {
        records[base + STATE_DIM] = norm;
    }
    records[base + X_R] = x[X_R];
    records[base + VX_R] = x[VX_R];
    records[base + Y_R] = x[Y_R];
    records[base + VY_R] = x[VY_R];
    records[base + X_S] = x[X_S];
    records[base + VX_S] = x[VX_S];
    records[base + Y_S] = x[Y_S];
    records[base + VY_S] = x[VY_S];
}

// One time slice: every lane of the chunk goes from the period it has completed
// (`Lane.period`) to `params.period_end`, the state in registers (`lane`) throughout,
// one sub-step of a macro step per iteration (see macro_step), a macro step committed
// only when the loop budget held after each of its sub-steps (see
// `loop_budget_left`). The Poincare point is written at the end of each recorded
// period; a frozen lane (or one with N = 0) records its frozen state for each remaining
// period, as the CPU's `advance_period` loop does. A lane that could not finish counts
// itself in `unfinished`, and the host dispatches the slice again: the lane resumes at
// its last committed macro step, so the result does not depend on where it stopped.
//
// Everything happens inside the one loop, on purpose. lavapipe runs the masked stores
// of `record` at every iteration (about 12% of a run, perf), and an inner loop over a
// period's macro steps with the record after it would run them once per period, but
// when llvmpipe's loop limit ends a loop it leaves without taking any `break`, so a
// value that only a `break` sets (such as "the period is complete") is stale after
// it: tried, and it recorded mid-period states after a cut.
@compute @workgroup_size(WORKGROUP_SIZE)
fn advance_lanes(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= params.n_lanes {
        return;
    }
    probe_n = params.probe;
    var committed: bool;
    if CONSTS_EACH_STEP {
        committed = advance_buffered(i);
    } else {
        committed = advance_held(i);
    }
    if lanes[i].period < params.period_end {
        atomicAdd(&unfinished[0], 1u);
        if !committed {
            atomicAdd(&unfinished[1], 1u);
        }
    }
}

// advance_lanes on a software adapter: the committed lane (`held`), its tangent and its
// constants in registers across the loop, written back once at the end. Returns true
// when the lane committed anything. (`lane_consts`, in the generated header, reads the
// fields every lane of the run shares from the first lane's constants.)
fn advance_held(i: u32) -> bool {
    let period_end = params.period_end;
    let lc = lane_consts(i);
    var held = lanes[i];
    var tv: array<Real, STATE_DIM>;
    if LYAPUNOV {
        tv = tangents[i];
    }
    var committed = false;
    // The lane's macro step in progress (`busy`) and its tangent vector.
    var ms = macro_step_begin(lc, held);
    var busy = false;
    var vw = tv;
    loop {
        var lane = held;
        if lane.period >= period_end {
            break;
        }
        // One call site of `record` for both cases (its stores would run twice per
        // iteration on lavapipe, which executes both arms of every `if`).
        var recorded = false;
        var norm = Real(1.0);
        if is_frozen(lane.status) || lc.n == 0u {
            recorded = true;
        } else {
            if !busy {
                ms = macro_step_begin(lc, lane);
                vw = tv;
                busy = true;
            }
            macro_step(lc, lane.k, &ms, &vw);
            if !loop_budget_left() {
                break;
            }
            if ms.done {
                var next = lane;
                macro_step_end(lc, &next, ms);
                lane = next;
                tv = vw;
                committed = true;
                busy = false;
                if lane.k == 0u && !is_frozen(lane.status) {
                    if LYAPUNOV {
                        norm = renormalise(&tv);
                    }
                    recorded = true;
                }
            }
        }
        if recorded {
            record(lane.period, i, lane.x, norm);
            lane.period += 1u;
            committed = true;
        }
        held = lane;
    }
    lanes[i] = held;
    if LYAPUNOV {
        tangents[i] = tv;
    }
    return committed;
}

// advance_lanes on a GPU (CONSTS_EACH_STEP): the committed lane and its tangent stay in
// their buffers, read where needed and written at each commit, and the constants are
// read at every sub-step, so that nothing but the macro step in progress is live across
// the loop (a SIMT GPU holds every live value of every invocation in registers; RADV's
// null device, docs/gpu.md). The buffers hold the last commit at every moment, also
// after a cut by the loop budget. The same sub-steps in the same order as advance_held.
//
// A lane in free flight at a macro step's start takes the lean path (lean_free_flight)
// until a macro step needs the full one; after that full macro step it tries the lean
// path again.
fn advance_buffered(i: u32) -> bool {
    let period_end = params.period_end;
    var committed = false;
    var ms: MacroStep;
    var busy = false;
    var vw: array<Real, STATE_DIM>;
    var lean = true;
    loop {
        let period = lanes[i].period;
        if period >= period_end {
            break;
        }
        let lc = lane_consts(i);
        var recorded = false;
        var norm = Real(1.0);
        if is_frozen(lanes[i].status) || lc.n == 0u {
            recorded = true;
        } else {
            if !LYAPUNOV && lean && !busy && lanes[i].contact == 0u {
                let r = lean_free_flight(i, period_end);
                committed = committed || r.committed;
                if r.end == LEAN_BUDGET {
                    break;
                }
                lean = r.end != LEAN_FULL;
                continue;
            }
            if !busy {
                ms = macro_step_begin(lc, lanes[i]);
                if LYAPUNOV {
                    vw = tangents[i];
                }
                busy = true;
            }
            // The lane's largest penetration, constant while its macro step runs: read
            // again rather than held across the loop.
            ms.max_pen = lanes[i].counters.max_penetration;
            macro_step(lc, lanes[i].k, &ms, &vw);
            if !loop_budget_left() {
                break;
            }
            if ms.done {
                var next = lanes[i];
                macro_step_end(lc, &next, ms);
                lanes[i] = next;
                committed = true;
                busy = false;
                lean = true;
                if next.k == 0u && !is_frozen(next.status) {
                    if LYAPUNOV {
                        norm = renormalise(&vw);
                    }
                    recorded = true;
                }
                if LYAPUNOV {
                    tangents[i] = vw;
                }
            }
        }
        if recorded {
            record(period, i, lanes[i].x, norm);
            lanes[i].period = period + 1u;
            committed = true;
        }
    }
    return committed;
}

// Why lean_free_flight stopped, and whether it committed anything.
struct Lean {
    end: u32,
    committed: bool,
}

const LEAN_FULL: u32 = 0u; // the next macro step needs the full step
const LEAN_BUDGET: u32 = 1u; // the loop budget ran out (see loop_budget_left)
const LEAN_END: u32 = 2u; // the slice's last period is complete
const LEAN_MORE: u32 = 3u; // LEAN_STEPS taken: back to the entry's loop, then on

// Macro steps lean_free_flight takes at most per call. The lanes of a SIMD group that
// need the full step wait while the others run the lean loop (a GPU's warp runs one
// branch at a time; lavapipe's 8 lanes share one loop budget, which an unbounded lean
// loop spent before a waiting lane committed anything). Bounded, a waiting lane gets
// one sub-step per LEAN_STEPS lean steps of its neighbours, and a lean step's cost is
// amortised over many.
const LEAN_STEPS: u32 = 32u;

// The GPU form's lean path (advance_buffered): the macro steps of a lane in free flight,
// one after the other with the state in registers and nothing of the switch search,
// contact or tangent code live, the lane written back once at the end. It takes a
// macro step only where the full one would do nothing else: the same sub-step over the
// whole macro step (rk4_substep from s = 0 with ds = 1, or the exact map), no search
// needed (search_needless, the same test), the state finite and within the bound
// (macro_step_end's checks), and then the same commit (one macro step more, no
// contact, switch or extra sub-step). A macro step that fails a test is not
// committed: the full step takes it from the same state and computes the same x1.
fn lean_free_flight(i: u32, period_end: u32) -> Lean {
    var x = lanes[i].x;
    var k = lanes[i].k;
    var period = lanes[i].period;
    let max_pen = lanes[i].counters.max_penetration;
    var steps = 0u;
    var end = LEAN_FULL;
    loop {
        // The constants read at every step, as in the full path, none held across the
        // loop: the index is i (k < N <= u32::MAX, so k is never u32::MAX), written so
        // that the compiler cannot hoist the loads out of the loop (RADV: the exact map
        // of a speed sweep held in registers spilled 66 VGPRs).
        let lc = lane_consts(select(i, 0u, k == 0xffffffffu));
        var x1: array<Real, STATE_DIM>;
        let p0 = lean_phasor(lc, k, 0u);
        let p1 = lean_phasor(lc, k, 2u);
        if EXACT_FREE_FLIGHT && lc.exact != 0u {
            x1 = free_flight_map(lc, x, p0, p1);
        } else {
            x1 = rk4_stages(lc, x, lc.h, p0, lean_phasor(lc, k, 1u), p1, false);
        }
        if !loop_budget_left() {
            end = LEAN_BUDGET;
            break;
        }
        if !search_needless(lc.c.delta, x, x1, lc.h, false, max_pen) || !in_bounds(lc, x1) {
            break;
        }
        x = x1;
        steps += 1u;
        k = select(k + 1u, 0u, k + 1u == lc.n);
        if k == 0u {
            record(period, i, x, Real(1.0));
            period += 1u;
            if period >= period_end {
                end = LEAN_END;
                break;
            }
        }
        if steps == LEAN_STEPS {
            end = LEAN_MORE;
            break;
        }
    }
    // After the loop whatever ended it, a cut by llvmpipe's loop limit included: x, k and
    // period are the last committed values.
    if steps > 0u {
        lanes[i].x = x;
        lanes[i].k = k;
        lanes[i].period = period;
        lanes[i].counters.macro_steps = sat_add(lanes[i].counters.macro_steps, steps);
    }
    return Lean(end, steps > 0u);
}

// The phasor at fraction j / 2 (j = 0, 1, 2) of macro step k: what rk4_substep from
// s = 0 with ds = 1 and free_flight_step evaluate (0 + 0.5 x 1 and 0 + 1 are exact), from
// the table where the run has one (FORCING_TABLE).
fn lean_phasor(lc: LaneConsts, k: u32, j: u32) -> vec2<Real> {
    if FORCING_TABLE {
        return forcing_table[2u * k + j];
    }
    return forcing_phasor(lc, k, Real(j) * Real(0.5));
}

// macro_step_end's status checks passed: every component finite and the reach within
// the divergence bound.
fn in_bounds(lc: LaneConsts, x: array<Real, STATE_DIM>) -> bool {
    return state_finite(x) && !(state_reach(x) > lc.bound);
}

// True when every component of `x` is finite (macro_step_end's first status check).
fn state_finite(x: array<Real, STATE_DIM>) -> bool {
    var finite = true;
    for (var i = 0u; i < STATE_DIM; i++) {
        finite = finite && is_finite(x[i]);
    }
    return finite;
}

// The largest displacement of rotor or stator along either axis (macro_step_end's
// divergence check compares it with the bound).
fn state_reach(x: array<Real, STATE_DIM>) -> Real {
    return rmax(rmax(rmax(abs(x[X_R]), abs(x[Y_R])), abs(x[X_S])), abs(x[Y_S]));
}
