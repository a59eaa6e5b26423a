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
    let period_end = params.period_end;
    let lc_once = consts[i];
    // The committed lane: in registers across the loop (`held`), or, in the hardware
    // form (CONSTS_EACH_STEP), in its buffer, read at each iteration and written back
    // at its end, so that its state and counters are not live across the loop beside
    // the macro step's own (RADV's null device: 159 -> 131 spilled VGPRs in f64,
    // docs/gpu.md). The buffer then always holds the last commit, as the final write
    // of the registers form leaves it, also after a cut by the loop budget.
    var held = lanes[i];
    var tv: array<Real, STATE_DIM>;
    if LYAPUNOV {
        tv = tangents[i];
    }
    var committed = false;
    // The lane's macro step in progress (`busy`) and its tangent vector.
    var ms = macro_step_begin(lc_once, held);
    var busy = false;
    var vw = tv;
    loop {
        var lane = held;
        if CONSTS_EACH_STEP {
            lane = lanes[i];
        }
        if lane.period >= period_end {
            break;
        }
        // One call site of `record` for both cases (its stores would run twice per
        // iteration on lavapipe, which executes both arms of every `if`).
        var recorded = false;
        var norm = Real(1.0);
        // The lane's constants, read once before the loop or here at every sub-step
        // (shader.rs's Variant::consts_each_step: registers on a GPU, gathers on
        // lavapipe).
        var lc = lc_once;
        if CONSTS_EACH_STEP {
            lc = consts[i];
        }
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
        if CONSTS_EACH_STEP {
            lanes[i] = lane;
        } else {
            held = lane;
        }
    }
    if !CONSTS_EACH_STEP {
        lanes[i] = held;
    }
    let lane = lanes[i];
    if LYAPUNOV {
        tangents[i] = tv;
    }
    if lane.period < period_end {
        atomicAdd(&unfinished[0], 1u);
        if !committed {
            atomicAdd(&unfinished[1], 1u);
        }
    }
}
