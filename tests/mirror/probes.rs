//! The probes: each mirrored kernel function's test-only entry point, which reads a
//! row of arguments, calls the function and writes its results.

use super::*;

/// Buffers and readers shared by the probe entry points. Each invocation handles one
/// row: `mirror_row` points the cursors at it, `in_*` read the arguments in order,
/// `out_*` write the results in order.
pub(crate) const PROBE_IO: &str = r#"
// ---- test-only probes (tests/mirror) ----
@group(0) @binding(10) var<storage, read> mirror_in: array<Real>;
@group(0) @binding(11) var<storage, read_write> mirror_out: array<Real>;
var<private> mirror_at: u32;
var<private> mirror_put: u32;

// Row i of `inputs` Reals in and `outputs` out; false past the last row. Reads
// params.n_lanes so that every probe binds `params` (which `keep` reads).
fn mirror_row(i: u32, inputs: u32, outputs: u32) -> bool {
    if i >= arrayLength(&mirror_in) / inputs || params.n_lanes == 0u {
        return false;
    }
    mirror_at = i * inputs;
    mirror_put = i * outputs;
    return true;
}
fn in_real() -> Real {
    let v = mirror_in[mirror_at];
    mirror_at += 1u;
    return v;
}
fn in_bool() -> bool {
    return in_real() > Real(0.5);
}
fn in_u32() -> u32 {
    return u32(in_real());
}
fn in_state() -> array<Real, STATE_DIM> {
    var x: array<Real, STATE_DIM>;
    for (var j = 0u; j < STATE_DIM; j++) {
        x[j] = in_real();
    }
    return x;
}
fn in_coeffs() -> Coeffs {
    let wr2x = in_real();
    let wr2y = in_real();
    let drx = in_real();
    let dry = in_real();
    let ws2x = in_real();
    let ws2y = in_real();
    let dsx = in_real();
    let dsy = in_real();
    let ox = in_real();
    let oy = in_real();
    let unbalance = in_real();
    let a_g = in_real();
    let kc_mr = in_real();
    let kc_ms = in_real();
    let mu = in_real();
    let delta = in_real();
    let tau_c = in_real();
    let n_c = in_real();
    let hc = in_real();
    return Coeffs(
        wr2x, wr2y, drx, dry, ws2x, ws2y,
        dsx, dsy, ox, oy, unbalance, a_g,
        kc_mr, kc_ms, mu, delta, tau_c, n_c, hc,
    );
}
fn in_consts() -> LaneConsts {
    let c = in_coeffs();
    let h = in_real();
    let inv_n = in_real();
    let phase0 = in_real();
    let bound = in_real();
    let root_tol = in_real();
    let inv_r = in_real();
    var ff: FreeFlight;
    for (var j = 0u; j < 16u; j++) {
        ff.phi[j] = in_real();
    }
    for (var j = 0u; j < 4u; j++) {
        ff.off[j] = in_real();
    }
    for (var j = 0u; j < 4u; j++) {
        ff.p[j] = in_real();
    }
    for (var j = 0u; j < 4u; j++) {
        ff.q[j] = in_real();
    }
    ff.omega = in_real();
    let n = in_u32();
    let max_segments = in_u32();
    let exact = in_u32();
    return LaneConsts(c, h, inv_n, phase0, bound, root_tol, inv_r, ff, n, max_segments, exact, 0u);
}
// A sub-step's arguments after the constants: state, macro step, start, length, mode.
struct SubStep {
    x: array<Real, STATE_DIM>,
    k: u32,
    s0: Real,
    ds: Real,
    contact: bool,
}
fn in_substep() -> SubStep {
    let x = in_state();
    let k = in_u32();
    let s0 = in_real();
    let ds = in_real();
    return SubStep(x, k, s0, ds, in_bool());
}
fn in_partials() -> Partials {
    let a = in_state();
    return Partials(vec4<Real>(a[0], a[1], a[2], a[3]), vec4<Real>(a[4], a[5], a[6], a[7]));
}
fn out_real(v: Real) {
    mirror_out[mirror_put] = v;
    mirror_put += 1u;
}
fn out_bool(b: bool) {
    out_real(select(Real(0.0), Real(1.0), b));
}
fn out_state(x: array<Real, STATE_DIM>) {
    for (var j = 0u; j < STATE_DIM; j++) {
        out_real(x[j]);
    }
}
fn out_partials(p: Partials) {
    out_real(p.a.x);
    out_real(p.a.y);
    out_real(p.a.z);
    out_real(p.a.w);
    out_real(p.b.x);
    out_real(p.b.y);
    out_real(p.b.z);
    out_real(p.b.w);
}
"#;

/// Reals of a `LaneConsts` row: Coeffs (19), h, inv_n, phase0, bound, root_tol, inv_r,
/// the exact free-flight map (29), n, max_segments, exact.
pub(crate) const CONSTS: usize = 57;
pub(crate) const COEFFS: usize = 19;
pub(crate) const S: usize = STATE_DIM;

pub(crate) const PROBES: [Probe; 32] = [
    Probe {
        name: "phasor_turns",
        inputs: 1,
        outputs: 2,
        body: "let p = phasor_turns(in_real());
    out_real(p.x);
    out_real(p.y);",
    },
    Probe {
        name: "relative_motion",
        inputs: S,
        outputs: 4,
        body: "let m = relative_motion(in_state());
    out_real(m.x);
    out_real(m.y);
    out_real(m.z);
    out_real(m.w);",
    },
    Probe {
        name: "penetration",
        inputs: 1 + S,
        outputs: 1,
        body: "let delta = in_real();
    let x = in_state();
    out_real(penetration(delta, x));",
    },
    Probe {
        name: "contact_force_per_kc",
        inputs: 7,
        outputs: 2,
        body: "let delta = in_real();
    let mu = in_real();
    let tau_c = in_real();
    let dx = in_real();
    let dy = in_real();
    let dvx = in_real();
    let dvy = in_real();
    let f = contact_force_per_kc(delta, mu, tau_c, dx, dy, dvx, dvy);
    out_real(f.x);
    out_real(f.y);",
    },
    Probe {
        name: "pow_half",
        inputs: 2,
        outputs: 1,
        body: "let a = in_real();
    let m = in_real();
    out_real(pow_half(a, m));",
    },
    Probe {
        name: "contact_force_per_kc_law",
        inputs: COEFFS + 4,
        outputs: 2,
        body: "let c = in_coeffs();
    let dx = in_real();
    let dy = in_real();
    let dvx = in_real();
    let dvy = in_real();
    let f = contact_force_per_kc_law(c, dx, dy, dvx, dvy);
    out_real(f.x);
    out_real(f.y);",
    },
    Probe {
        name: "contact_force_lane",
        inputs: COEFFS + 4,
        outputs: 2,
        body: "let c = in_coeffs();
    let dx = in_real();
    let dy = in_real();
    let dvx = in_real();
    let dvy = in_real();
    let f = contact_force_lane(c, dx, dy, dvx, dvy);
    out_real(f.x);
    out_real(f.y);",
    },
    Probe {
        name: "contact_partials_law_off_centre",
        inputs: COEFFS + S,
        outputs: 8,
        body: "let c = in_coeffs();
    let x = in_state();
    out_partials(contact_partials_law_off_centre(c, relative_motion(x)));",
    },
    Probe {
        name: "contact_block",
        inputs: 11,
        outputs: 8,
        body: "let dx = in_real();
    let dy = in_real();
    let mu = in_real();
    let s = in_real();
    let nrm = in_real();
    let sx = in_real();
    let sy = in_real();
    let nx = in_real();
    let ny = in_real();
    let nvx = in_real();
    let nvy = in_real();
    out_partials(contact_block(dx, dy, mu, NormalPartials(s, nrm, sx, sy, nx, ny, nvx, nvy)));",
    },
    Probe {
        name: "contact_partials",
        inputs: COEFFS + S,
        outputs: 8,
        body: "let c = in_coeffs();
    let x = in_state();
    out_partials(contact_partials(c, x));",
    },
    Probe {
        name: "rhs_frozen",
        inputs: COEFFS + S + 3,
        outputs: S,
        body: "let c = in_coeffs();
    let x = in_state();
    let cos_phase = in_real();
    let sin_phase = in_real();
    let contact = in_bool();
    out_state(rhs_frozen(c, x, cos_phase, sin_phase, contact));",
    },
    Probe {
        name: "forcing_phasor",
        inputs: CONSTS + 2,
        outputs: 2,
        body: "let lc = in_consts();
    let k = in_u32();
    let sigma = in_real();
    let p = forcing_phasor(lc, k, sigma);
    out_real(p.x);
    out_real(p.y);",
    },
    Probe {
        name: "free_flight_step",
        inputs: CONSTS + S + 1,
        outputs: S,
        body: "let lc = in_consts();
    let x = in_state();
    let k = in_u32();
    out_state(free_flight_step(lc, x, k));",
    },
    Probe {
        name: "free_flight_tangent",
        inputs: CONSTS + S,
        outputs: S,
        body: "let lc = in_consts();
    var v = in_state();
    free_flight_tangent(lc, &v);
    out_state(v);",
    },
    Probe {
        name: "trial_tangent",
        inputs: CONSTS + 1 + S + 4 + S,
        outputs: S,
        body: "let lc = in_consts();
    let exact = in_bool();
    let a = in_substep();
    var v = in_state();
    trial_tangent(lc, exact, a.x, a.k, a.s0, a.ds, a.contact, &v);
    out_state(v);",
    },
    Probe {
        name: "rk4_substep",
        inputs: CONSTS + S + 4,
        outputs: S,
        body: "let lc = in_consts();
    let a = in_substep();
    out_state(rk4_substep(lc, a.x, a.k, a.s0, a.ds, a.contact));",
    },
    Probe {
        name: "stage_partials",
        inputs: COEFFS + S + 1,
        outputs: 8,
        body: "let c = in_coeffs();
    let x = in_state();
    let contact = in_bool();
    out_partials(stage_partials(c, x, contact));",
    },
    Probe {
        name: "tangent_rhs",
        inputs: COEFFS + 8 + S,
        outputs: S,
        body: "let c = in_coeffs();
    let pc = in_partials();
    let v = in_state();
    out_state(tangent_rhs(c, pc, v));",
    },
    Probe {
        name: "rk4_tangent_substep",
        inputs: CONSTS + S + 4 + S,
        outputs: S,
        body: "let lc = in_consts();
    let a = in_substep();
    var v = in_state();
    rk4_tangent_substep(lc, a.x, a.k, a.s0, a.ds, a.contact, &v);
    out_state(v);",
    },
    Probe {
        name: "saltation",
        inputs: CONSTS + S + 3 + S,
        outputs: S,
        body: "let lc = in_consts();
    let x = in_state();
    let k = in_u32();
    let s = in_real();
    let from_contact = in_bool();
    var v = in_state();
    saltation(lc, x, k, s, from_contact, &v);
    out_state(v);",
    },
    Probe {
        name: "renormalise",
        inputs: S,
        outputs: 1 + S,
        body: "var v = in_state();
    let n = renormalise(&v);
    out_real(n);
    out_state(v);",
    },
    Probe {
        name: "hermite_gap",
        inputs: 1 + 2 * S + 2,
        outputs: 2,
        body: "let delta = in_real();
    let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    let theta = in_real();
    let g = hermite_gap(delta, x0, x1, hs, theta);
    out_real(g.x);
    out_real(g.y);",
    },
    Probe {
        name: "wrong_side",
        inputs: 2,
        outputs: 1,
        body: "let g = in_real();
    let contact = in_bool();
    out_bool(wrong_side(g, contact));",
    },
    Probe {
        name: "control_points",
        inputs: 2 * S + 1,
        outputs: 8,
        body: "let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    let p = control_points(x0, x1, hs);
    out_real(p[0].x);
    out_real(p[0].y);
    out_real(p[1].x);
    out_real(p[1].y);
    out_real(p[2].x);
    out_real(p[2].y);
    out_real(p[3].x);
    out_real(p[3].y);",
    },
    Probe {
        name: "hull_reach_sq",
        inputs: 8,
        outputs: 1,
        body: "let a = in_real();
    let b = in_real();
    let c = in_real();
    let d = in_real();
    let e = in_real();
    let f = in_real();
    let g = in_real();
    let h = in_real();
    let p = array<vec2<Real>, 4>(vec2<Real>(a, b), vec2<Real>(c, d), vec2<Real>(e, f), vec2<Real>(g, h));
    out_real(hull_reach_sq(p));",
    },
    Probe {
        name: "free_flight_certain",
        inputs: CONSTS + 2 * S + 1,
        outputs: 1,
        body: "let lc = in_consts();
    let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    out_bool(free_flight_certain(lc, x0, x1, hs));",
    },
    Probe {
        name: "clear_of_stator",
        inputs: 1 + 2 * S + 1,
        outputs: 1,
        body: "let delta = in_real();
    let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    out_bool(clear_of_stator(delta, x0, x1, hs));",
    },
    Probe {
        name: "in_contact_certain",
        inputs: 1 + 2 * S + 2,
        outputs: 1,
        body: "let delta = in_real();
    let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    let max_pen = in_real();
    out_bool(in_contact_certain(delta, x0, x1, hs, max_pen));",
    },
    Probe {
        name: "search_needless",
        inputs: 1 + 2 * S + 3,
        outputs: 1,
        body: "let delta = in_real();
    let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    let contact = in_bool();
    let max_pen = in_real();
    out_bool(search_needless(delta, x0, x1, hs, contact, max_pen));",
    },
    Probe {
        name: "find_switch",
        inputs: CONSTS + 2 * S + 2,
        outputs: 2,
        body: "let lc = in_consts();
    let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    let contact = in_bool();
    let sw = find_switch(lc, x0, x1, hs, contact);
    out_real(sw.theta);
    out_real(sw.max_g);",
    },
    Probe {
        name: "trial_extent",
        inputs: CONSTS + 2,
        outputs: 2,
        body: "let lc = in_consts();
    let s = in_real();
    let contact = in_bool();
    let e = trial_extent(lc, s, contact);
    out_real(e.ds);
    out_real(e.end);",
    },
    // lane.rs's macro_step(_tangent) is the kernel's macro_step_begin, macro_step until
    // done, macro_step_end (what advance_lanes runs, without the slicing).
    Probe {
        name: "macro_step",
        inputs: CONSTS + S + 2 + S,
        outputs: S + 3 + 5 + S,
        body: "let lc = in_consts();
    let x = in_state();
    let contact = in_u32();
    let k = in_u32();
    var v = in_state();
    let lane = Lane(x, contact, k, STATUS_OK, 0u, Counters(0u, 0u, 0u, 0u, Real(0.0)));
    var ms = macro_step_begin(lc, lane);
    for (var it = 0u; it < 4096u; it++) {
        macro_step(lc, k, &ms, &v);
        if ms.done {
            break;
        }
    }
    var next = lane;
    macro_step_end(lc, &next, ms);
    out_state(next.x);
    out_real(Real(next.contact));
    out_real(Real(next.k));
    out_real(Real(next.status));
    out_real(Real(next.counters.macro_steps));
    out_real(Real(next.counters.contact_steps));
    out_real(Real(next.counters.switches));
    out_real(Real(next.counters.extra_substeps));
    out_real(next.counters.max_penetration);
    out_state(v);",
    },
];
