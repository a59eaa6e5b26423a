// The kernel's anatomy (anatomy.rs, `jeffcott bench --anatomy`): parts of the lane
// kernel, each run alone in a tight loop over the same lanes, buffers and protocol as
// advance_lanes, so that a GPU's time per lane-step can be split between the parts and
// the kernel's own control structure (its one loop of sub-steps, the macro step's state
// kept between them, the committed lane). Appended to the assembled kernel
// (shader::source): every function called is the kernel's own, compiled the same way.
// No study uses these entry points: the trajectories are not the model's (free flight
// through the stator, or contact held throughout); anatomy.rs has their CPU references,
// which tests/gpu.rs checks bit for bit.

const PART_RK4: u32 = 0u;
const PART_RK4_SCALAR: u32 = 1u;
const PART_CERTAIN: u32 = 2u;
const PART_SEARCH: u32 = 3u;
const PART_CONTACT: u32 = 4u;

// The state without an array: the rotor (x_r, vx_r, y_r, vy_r) and the stator (x_s,
// vx_s, y_s, vy_s), the order of X_R .. VY_S.
struct Pair {
    r: vec4<Real>,
    s: vec4<Real>,
}

fn pair_of(x: array<Real, STATE_DIM>) -> Pair {
    return Pair(
        vec4<Real>(x[X_R], x[VX_R], x[Y_R], x[VY_R]),
        vec4<Real>(x[X_S], x[VX_S], x[Y_S], x[VY_S]),
    );
}

fn array_of(p: Pair) -> array<Real, STATE_DIM> {
    return array<Real, STATE_DIM>(p.r.x, p.r.y, p.r.z, p.r.w, p.s.x, p.s.y, p.s.z, p.s.w);
}

// rhs_frozen in free flight (fx = fy = 0, still added, as rhs_frozen does), on a Pair:
// the same operations in the same order.
fn rhs_pair(c: Coeffs, x: Pair, cos_phase: Real, sin_phase: Real) -> Pair {
    let fx = Real(0.0);
    let fy = Real(0.0);
    var xs = x.s.x;
    var ys = x.s.z;
    if STATOR_OFFSET {
        xs = x.s.x - c.ox;
        ys = x.s.z - c.oy;
    }
    let cy = y_coeffs(c);
    return Pair(
        vec4<Real>(
            x.r.y,
            -c.wr2x * x.r.x - c.drx * x.r.y + c.unbalance * cos_phase + c.kc_mr * fx,
            x.r.w,
            -cy.wr2 * x.r.z - cy.dr * x.r.w + c.unbalance * sin_phase - c.a_g + c.kc_mr * fy,
        ),
        vec4<Real>(
            x.s.y,
            -c.ws2x * xs - c.dsx * x.s.y - c.kc_ms * fx,
            x.s.w,
            keep(-cy.ws2 * ys - cy.ds * x.s.w) - c.a_g - c.kc_ms * fy,
        ),
    );
}

// rk4_substep in free flight on a Pair: its operations in its order, on vectors.
fn rk4_pair(lc: LaneConsts, x: Pair, k: u32, s0: Real, ds: Real) -> Pair {
    let hs = ds * lc.h;
    let half = Real(0.5);
    let p0 = forcing_phasor(lc, k, s0);
    let pm = forcing_phasor(lc, k, s0 + half * ds);
    let p1 = forcing_phasor(lc, k, s0 + ds);
    let k1 = rhs_pair(lc.c, x, p0.x, p0.y);
    var xt = Pair(x.r + half * hs * k1.r, x.s + half * hs * k1.s);
    var k23 = rhs_pair(lc.c, xt, pm.x, pm.y);
    xt = Pair(x.r + half * hs * k23.r, x.s + half * hs * k23.s);
    let k3 = rhs_pair(lc.c, xt, pm.x, pm.y);
    xt = Pair(x.r + hs * k3.r, x.s + hs * k3.s);
    k23 = Pair(k23.r + k3.r, k23.s + k3.s);
    let k4 = rhs_pair(lc.c, xt, p1.x, p1.y);
    return Pair(
        x.r + hs * SIXTH * (k1.r + Real(2.0) * k23.r + k4.r),
        x.s + hs * SIXTH * (k1.s + Real(2.0) * k23.s + k4.s),
    );
}

// One forcing period of part `part` from `x` (macro steps k = 0 .. N - 1), counting into
// `c` (anatomy.rs's cpu_period does the same on the CPU).
fn anatomy_period(lc: LaneConsts, x0: array<Real, STATE_DIM>, part: u32, c: ptr<function, Counters>)
    -> array<Real, STATE_DIM> {
    let zero = Real(0.0);
    let one = Real(1.0);
    var x = x0;
    if part == PART_RK4_SCALAR {
        var p = pair_of(x);
        for (var k = 0u; k < lc.n; k++) {
            p = rk4_pair(lc, p, k, zero, one);
        }
        x = array_of(p);
        (*c).macro_steps = sat_add((*c).macro_steps, lc.n);
    } else {
        for (var k = 0u; k < lc.n; k++) {
            if part == PART_CONTACT {
                // A macro step held in contact: its R sub-steps (trial_extent).
                var s = zero;
                var substeps = 0u;
                for (var q = 0u; q < MAX_CONTACT_SUBSTEPS && s < one; q++) {
                    let e = trial_extent(lc, s, true);
                    x = rk4_substep(lc, x, k, s, e.ds, true);
                    s = e.end;
                    substeps += 1u;
                }
                (*c).extra_substeps = sat_add((*c).extra_substeps, substeps - 1u);
            } else {
                let x1 = rk4_substep(lc, x, k, zero, one, false);
                if part == PART_CERTAIN {
                    if !free_flight_certain(lc, x, x1, one * lc.h) {
                        (*c).contact_steps = sat_add((*c).contact_steps, 1u);
                    }
                } else if part == PART_SEARCH {
                    let sw = find_switch(lc, x, x1, one * lc.h, false);
                    (*c).max_penetration = rmax((*c).max_penetration, sw.max_g);
                    if sw.theta <= one {
                        (*c).switches = sat_add((*c).switches, 1u);
                    }
                }
                x = x1;
            }
            (*c).macro_steps = sat_add((*c).macro_steps, 1u);
        }
    }
    return x;
}

// advance_lanes's protocol with part `part` in place of the macro step: lane i goes from
// the period it has completed to params.period_end, its state recorded at each period's
// end, a period committed only when the loop budget held through it.
fn anatomy_run(i: u32, part: u32) {
    if i >= params.n_lanes {
        return;
    }
    probe_n = params.probe;
    let lc = consts[i];
    var lane = lanes[i];
    var committed = false;
    loop {
        if lane.period >= params.period_end {
            break;
        }
        var c = lane.counters;
        let x = anatomy_period(lc, lane.x, part, &c);
        if !loop_budget_left() {
            break;
        }
        lane.x = x;
        lane.counters = c;
        record(lane.period, i, x, Real(1.0));
        lane.period += 1u;
        committed = true;
    }
    lanes[i] = lane;
    if lane.period < params.period_end {
        atomicAdd(&unfinished[0], 1u);
        if !committed {
            atomicAdd(&unfinished[1], 1u);
        }
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn anatomy_rk4(@builtin(global_invocation_id) gid: vec3<u32>) {
    anatomy_run(gid.x, PART_RK4);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn anatomy_rk4_scalar(@builtin(global_invocation_id) gid: vec3<u32>) {
    anatomy_run(gid.x, PART_RK4_SCALAR);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn anatomy_certain(@builtin(global_invocation_id) gid: vec3<u32>) {
    anatomy_run(gid.x, PART_CERTAIN);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn anatomy_search(@builtin(global_invocation_id) gid: vec3<u32>) {
    anatomy_run(gid.x, PART_SEARCH);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn anatomy_contact(@builtin(global_invocation_id) gid: vec3<u32>) {
    anatomy_run(gid.x, PART_CONTACT);
}
