// The lane kernel, part 7 of 8 (see lane_buffers.wgsl for the whole): the lane stepper.
//
// Keep in sync with lane.rs, beside this file: the functions below are those of lane.rs,
// with the same names, in the same order, doing the same arithmetic in the same order
// (they call penetration, contact_partials and rhs_frozen of model.wgsl and phasor_turns
// of forcing.wgsl). Where the kernel's control flow differs from lane.rs's for speed on
// lavapipe (find_switch, macro_step), the comments say how, and the points evaluated and
// their bookkeeping are lane.rs's.

// Unbalance phasor at fraction `sigma` of macro step `k`.
fn forcing_phasor(lc: LaneConsts, k: u32, sigma: Real) -> vec2<Real> {
    return phasor_turns((Real(k) + sigma) * lc.inv_n - lc.phase0);
}

// One classical RK4 step over the fraction [s0, s0 + ds] of macro step k, contact mode
// held fixed.
fn rk4_substep(
    lc: LaneConsts,
    x: array<Real, STATE_DIM>,
    k: u32,
    s0: Real,
    ds: Real,
    contact: bool,
) -> array<Real, STATE_DIM> {
    let half = Real(0.5);
    let p0 = forcing_phasor(lc, k, s0);
    let pm = forcing_phasor(lc, k, s0 + half * ds);
    let p1 = forcing_phasor(lc, k, s0 + ds);
    return rk4_stages(lc, x, ds * lc.h, p0, pm, p1, contact);
}

// rk4_substep's stages over a sub-step of length hs with the phasors at its start,
// middle and end given (lane.rs has them in one function; the lean free-flight path
// looks its phasors up in a table).
fn rk4_stages(
    lc: LaneConsts,
    x: array<Real, STATE_DIM>,
    hs: Real,
    p0: vec2<Real>,
    pm: vec2<Real>,
    p1: vec2<Real>,
    contact: bool,
) -> array<Real, STATE_DIM> {
    let half = Real(0.5);
    let k1 = rhs_frozen(lc.c, x, p0.x, p0.y, contact);
    var xt: array<Real, STATE_DIM>;
    for (var i = 0u; i < STATE_DIM; i++) {
        xt[i] = x[i] + half * hs * k1[i];
    }
    // k2 + k3 is summed as soon as k3 is known, and k2 and k3 are not kept (the same
    // operations in the same order as lane.rs's last line): 16 fewer live values, which
    // a SIMT GPU otherwise holds in registers or spills (docs/gpu.md).
    var k23 = rhs_frozen(lc.c, xt, pm.x, pm.y, contact);
    for (var i = 0u; i < STATE_DIM; i++) {
        xt[i] = x[i] + half * hs * k23[i];
    }
    let k3 = rhs_frozen(lc.c, xt, pm.x, pm.y, contact);
    for (var i = 0u; i < STATE_DIM; i++) {
        xt[i] = x[i] + hs * k3[i];
        k23[i] = k23[i] + k3[i];
    }
    let k4 = rhs_frozen(lc.c, xt, p1.x, p1.y, contact);
    var out: array<Real, STATE_DIM>;
    for (var i = 0u; i < STATE_DIM; i++) {
        out[i] = x[i] + hs * SIXTH * (k1[i] + Real(2.0) * k23[i] + k4[i]);
    }
    return out;
}

// lane.rs's trial_extent: length and end of the next trial sub-step from fraction s.
struct Extent {
    ds: Real,
    end: Real,
}

fn trial_extent(lc: LaneConsts, s: Real, contact: bool) -> Extent {
    let one = Real(1.0);
    if contact && one - s > lc.inv_r {
        return Extent(lc.inv_r, s + lc.inv_r);
    }
    return Extent(one - s, one);
}

// What the next sub-step of macro_step is.
const MS_TRIAL: u32 = 0u; // a trial step (trial_extent), then find_switch
const MS_RESTEP: u32 = 1u; // the step to the located switch
const MS_CAP: u32 = 2u; // the refinement cap's step to the end

// A macro step in progress: the local variables of lane.rs's macro_step, kept between
// the sub-steps (see macro_step).
struct MacroStep {
    x: array<Real, STATE_DIM>,
    contact: bool,
    touched: bool,
    // Sub-step start s, and this sub-step's length ds (set for a step to the switch).
    s: Real,
    ds: Real,
    done: bool,
    capped: bool,
    substeps: u32,
    switches: u32,
    max_g: Real,
    // The lane's largest penetration before this macro step (lane.rs's MacroStep).
    max_pen: Real,
    // Segments begun (lane.rs's loop counter) and the next sub-step.
    seg: u32,
    part: u32,
}

// lane.rs's macro_step up to its segment loop.
fn macro_step_begin(lc: LaneConsts, lane: Lane) -> MacroStep {
    let contact = lane.contact != 0u;
    // The CPU starts max_g from -inf; WGSL has no infinite literal. -REAL_MAX gives the
    // same result: the first `rmax` replaces it by any finite g, and a NaN g freezes
    // the lane before max_g is used.
    return MacroStep(
        lane.x,
        contact,
        contact,
        Real(0.0),
        Real(1.0),
        false,
        false,
        0u,
        0u,
        -REAL_MAX,
        lane.counters.max_penetration,
        0u,
        select(MS_TRIAL, MS_CAP, lc.max_segments == 0u),
    );
}

// Advances a macro step (1/N of a forcing period) by one sub-step. Keep in sync with
// `macro_step` in lane.rs: macro_step_begin, then this until `done`, then
// macro_step_end are lane.rs's macro_step.
//
// lane.rs's segment loop (a trial step, then perhaps the step to the switch) and the
// refinement-cap step after it are one sub-step per call here, `part` saying which
// (see the note above FS_SCAN), and the entry point calls this once per iteration of
// its one loop, starting the lane's next macro step as soon as one is done. So on
// lavapipe a SIMD group pays one RK4 step and one switch search per iteration, and a
// lane that needs more sub-steps in a macro step (a contact switch) does not hold the
// other 7 lanes of its group back: they carry on with their next macro steps. The
// sub-steps, their arguments and their order are lane.rs's for every lane.
fn macro_step(
    lc: LaneConsts,
    k: u32,
    ms: ptr<function, MacroStep>,
    v: ptr<function, array<Real, STATE_DIM>>,
) {
    // `v` is the tangent vector (lane.rs: macro_step_tangent with M = 1); every use is
    // dead code when LYAPUNOV is false.
    let one = Real(1.0);
    var x = (*ms).x;
    var s = (*ms).s;
    var ds = (*ms).ds;
    var contact = (*ms).contact;
    let part = (*ms).part;
    var end = one;
    if part == MS_TRIAL {
        let ext = trial_extent(lc, s, contact);
        ds = ext.ds;
        end = ext.end;
    } else if part == MS_CAP {
        ds = one - s;
    }
    // lane.rs: a macro step begun in free flight may take the exact map (s = 0: ds = 1).
    let exact = EXACT_FREE_FLIGHT && part == MS_TRIAL && lc.exact != 0u && !contact
        && s == Real(0.0);
    var x1: array<Real, STATE_DIM>;
    if exact {
        x1 = free_flight_step(lc, x, k);
    } else {
        x1 = rk4_substep(lc, x, k, s, ds, contact);
    }
    (*ms).substeps += 1u;
    var flip = false;
    var done = false;
    var next_part = part;
    if part == MS_TRIAL {
        // lane.rs: no search where it would change no output bit (search_needless:
        // clear of the stator in free flight, held in contact below the lane's largest
        // penetration so far).
        var sw = Switch(Real(2.0), (*ms).max_g);
        if !search_needless(lc.c.delta, x, x1, ds * lc.h, contact, (*ms).max_pen) {
            sw = find_switch(lc, x, x1, ds * lc.h, contact);
        }
        (*ms).max_g = rmax((*ms).max_g, sw.max_g);
        if sw.theta > one {
            // No switch: the macro step is done, or a contact sub-step of 1/R is (and
            // the next trial follows).
            if LYAPUNOV {
                trial_tangent(lc, exact, x, k, s, ds, contact, v);
            }
            x = x1;
            s = end;
            done = s >= one;
        } else if sw.theta >= one {
            if LYAPUNOV {
                trial_tangent(lc, exact, x, k, s, ds, contact, v);
            }
            x = x1;
            s = end;
            flip = true;
        } else if sw.theta > Real(0.0) {
            // Step to the switch in the next sub-step.
            ds = ds * sw.theta;
            next_part = MS_RESTEP;
        } else {
            flip = true;
        }
    } else if part == MS_RESTEP {
        if LYAPUNOV {
            rk4_tangent_substep(lc, x, k, s, ds, contact, v);
        }
        x = x1;
        s += ds;
        flip = true;
    } else {
        // Refinement cap: finish the step in the current mode and say so.
        if LYAPUNOV {
            rk4_tangent_substep(lc, x, k, s, ds, contact, v);
        }
        x = x1;
        contact = penetration(lc.c.delta, x) > Real(0.0);
        (*ms).capped = true;
        done = true;
    }
    if flip {
        if LYAPUNOV {
            saltation(lc, x, k, s, contact, v);
        }
        contact = !contact;
        (*ms).touched = true;
        (*ms).switches += 1u;
        if s >= one {
            done = true;
        } else {
            (*ms).seg += 1u;
            next_part = select(MS_TRIAL, MS_CAP, (*ms).seg == lc.max_segments);
        }
    }
    (*ms).x = x;
    (*ms).s = s;
    (*ms).ds = ds;
    (*ms).contact = contact;
    (*ms).part = next_part;
    (*ms).done = done;
}

// The tangent step over an accepted trial sub-step: the exact map's own or RK4's (keep
// in sync with lane.rs's trial_tangent).
fn trial_tangent(
    lc: LaneConsts,
    exact: bool,
    x: array<Real, STATE_DIM>,
    k: u32,
    s: Real,
    ds: Real,
    contact: bool,
    v: ptr<function, array<Real, STATE_DIM>>,
) {
    if exact {
        free_flight_tangent(lc, v);
    } else {
        rk4_tangent_substep(lc, x, k, s, ds, contact, v);
    }
}

// lane.rs's macro_step after its segment loop and refinement cap: status checks and
// counters of the finished macro step `ms` of `lane`.
fn macro_step_end(lc: LaneConsts, lane: ptr<function, Lane>, ms: MacroStep) {
    if ms.capped && (*lane).status < STATUS_REFINEMENT_CAP {
        (*lane).status = STATUS_REFINEMENT_CAP;
    }
    let x = ms.x;
    let k = (*lane).k;
    // Status checks: freeze at the last good state rather than poison anything.
    if !state_finite(x) {
        (*lane).status = STATUS_NON_FINITE;
        return;
    }
    if state_reach(x) > lc.bound {
        (*lane).status = STATUS_DIVERGED;
        return;
    }
    (*lane).x = x;
    (*lane).contact = select(0u, 1u, ms.contact);
    (*lane).k = select(k + 1u, 0u, k + 1u == lc.n);
    (*lane).counters.macro_steps = sat_add((*lane).counters.macro_steps, 1u);
    (*lane).counters.contact_steps = sat_add(
        (*lane).counters.contact_steps,
        select(0u, 1u, ms.touched),
    );
    (*lane).counters.switches = sat_add((*lane).counters.switches, ms.switches);
    (*lane).counters.extra_substeps = sat_add(
        (*lane).counters.extra_substeps,
        ms.substeps - 1u,
    );
    if ms.touched {
        (*lane).counters.max_penetration = rmax((*lane).counters.max_penetration, ms.max_g);
    }
}

// `advance_period` of lane.rs (N macro steps) has no counterpart here: the entry point
// (lane_entry.wgsl) runs the same N macro steps per period, but one at a time so that it
// can stop and resume between any two of them.
