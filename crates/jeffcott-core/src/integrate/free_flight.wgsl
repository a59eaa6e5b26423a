// The lane kernel, part 6 of 8 (see lane_buffers.wgsl for the whole): the exact
// free-flight step. Keep in sync with free_flight.rs, beside this file: the same
// functions, the same arithmetic in the same order (the map itself, lc.ff, is built on
// the host in f64 and rounded once).

// The state after macro step `k` of a lane in free flight throughout, from `x`.
fn free_flight_step(lc: LaneConsts, x: array<Real, STATE_DIM>, k: u32) -> array<Real, STATE_DIM> {
    return free_flight_map(lc, x, forcing_phasor(lc, k, Real(0.0)), forcing_phasor(lc, k, Real(1.0)));
}

// free_flight_step with the phasors at the macro step's start and end given (the lean
// free-flight path looks them up in a table).
fn free_flight_map(
    lc: LaneConsts,
    x: array<Real, STATE_DIM>,
    p0: vec2<Real>,
    p1: vec2<Real>,
) -> array<Real, STATE_DIM> {
    var out: array<Real, STATE_DIM>;
    for (var j = 0u; j < 4u; j++) {
        let qi = 2u * j;
        let vi = 2u * j + 1u;
        let p = lc.ff.p[j];
        let q = lc.ff.q[j];
        let qp0 = lc.ff.off[j] + p * p0.x + q * p0.y;
        let vp0 = lc.ff.omega * (q * p0.x - p * p0.y);
        let e = x[qi] - qp0;
        let ev = x[vi] - vp0;
        let e1 = lc.ff.phi[4u * j] * e + lc.ff.phi[4u * j + 1u] * ev;
        let ev1 = lc.ff.phi[4u * j + 2u] * e + lc.ff.phi[4u * j + 3u] * ev;
        out[qi] = e1 + (lc.ff.off[j] + p * p1.x + q * p1.y);
        out[vi] = ev1 + lc.ff.omega * (q * p1.x - p * p1.y);
    }
    return out;
}

// The tangent vector over the same step: the map's transition (free_flight.rs's
// trace integral has no counterpart on the GPU).
fn free_flight_tangent(lc: LaneConsts, v: ptr<function, array<Real, STATE_DIM>>) {
    for (var j = 0u; j < 4u; j++) {
        let qi = 2u * j;
        let vi = 2u * j + 1u;
        let a = (*v)[qi];
        let b = (*v)[vi];
        (*v)[qi] = lc.ff.phi[4u * j] * a + lc.ff.phi[4u * j + 1u] * b;
        (*v)[vi] = lc.ff.phi[4u * j + 2u] * a + lc.ff.phi[4u * j + 3u] * b;
    }
}
