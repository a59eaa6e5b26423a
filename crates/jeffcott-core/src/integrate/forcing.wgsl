// The lane kernel, part 2 of 8 (see integrate/lane_buffers.wgsl for the whole): the
// unbalance phasor. Keep in sync with forcing.rs, beside this file: the same function,
// doing the same arithmetic in the same order.

// (cos(2 pi turns), sin(2 pi turns)) from + - * and floor only. Horner in a^2 from the
// highest term, the loop of forcing.rs unrolled: SIN_Cn = (-1)^n / (2n+1)!,
// COS_Cn = (-1)^n / (2n)!.
fn phasor_turns(turns: Real) -> vec2<Real> {
    let t = turns - floor(turns); // [0, 1)
    let q = floor(t * Real(4.0) + Real(0.5)); // quadrant 0..=4
    let f = t - q * Real(0.25); // [-1/8, 1/8] turns, exact
    let a = f * TAU; // [-pi/4, pi/4]
    let a2 = a * a;
    var s = SIN_C8;
    var c = COS_C8;
    s = SIN_C7 + a2 * s;
    c = COS_C7 + a2 * c;
    s = SIN_C6 + a2 * s;
    c = COS_C6 + a2 * c;
    s = SIN_C5 + a2 * s;
    c = COS_C5 + a2 * c;
    s = SIN_C4 + a2 * s;
    c = COS_C4 + a2 * c;
    s = SIN_C3 + a2 * s;
    c = COS_C3 + a2 * c;
    s = SIN_C2 + a2 * s;
    c = COS_C2 + a2 * c;
    s = SIN_C1 + a2 * s;
    c = COS_C1 + a2 * c;
    s = SIN_C0 + a2 * s;
    c = COS_C0 + a2 * c;
    s = a * s;
    // Quadrant rotation as selects, as in forcing.rs (no divergent branch).
    let quadrant = i32(q) & 3;
    let ab = select(vec2<Real>(c, s), vec2<Real>(s, c), (quadrant & 1) == 1);
    let ra = select(ab.x, -ab.x, quadrant == 1 || quadrant == 2);
    let rb = select(ab.y, -ab.y, quadrant >= 2);
    return vec2<Real>(ra, rb);
}
