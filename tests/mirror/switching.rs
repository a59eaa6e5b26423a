//! Locating a switch, the certificates that skip the search, the Hermite gap and the
//! saltation update (switch.wgsl).

use super::*;

fn switch_inputs<R: Real>() -> Vec<SwitchArgs<R>> {
    let mut v: Vec<SwitchArgs<R>> = cases::<R>()
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let t = trial(i, c);
            (c.lc, c.x, t.x1, t.hs, c.contact)
        })
        .collect();
    v.extend(grazing_steps::<R>(1000));
    v
}

/// What find_switch found on a row, to show the inputs reach every path.
#[derive(Debug, Default)]
struct SwitchPaths {
    none: usize,
    at_start: usize,
    crossing_at_a_sample: usize,
    crossing_between_samples: usize,
}

fn check_find_switch<R: GpuReal>(runner: &GpuRunner) {
    let mut rows = Vec::new();
    let mut paths = SwitchPaths::default();
    for (lc, x0, x1, hs, contact) in switch_inputs::<R>() {
        let sw = find_switch(&lc, &x0, &x1, hs, contact);
        let theta = sw.theta.to_f64();
        if theta > 1.0 {
            paths.none += 1;
        } else if theta == 0.0 {
            paths.at_start += 1;
        } else {
            // A crossing that no sample shows: an extremum found between samples.
            let sampled = (1..=8).any(|j| {
                let (g, _) = hermite_gap(lc.c.delta, &x0, &x1, hs, R::lit(j as f64 / 8.0));
                wrong_side(g, contact)
            });
            if sampled {
                paths.crossing_at_a_sample += 1;
            } else {
                paths.crossing_between_samples += 1;
            }
        }
        rows.push(
            Row::new()
                .consts(&lc)
                .state(&x0)
                .state(&x1)
                .real(hs)
                .flag(contact)
                .expect(&[sw.theta, sw.max_g]),
        );
    }
    eprintln!("find_switch ({}): {paths:?}", R::WGSL_NAME);
    assert!(
        paths.none > 100
            && paths.at_start > 10
            && paths.crossing_at_a_sample > 100
            && paths.crossing_between_samples > 50,
        "the inputs miss a path of find_switch: {paths:?}"
    );
    assert_mirrors(runner, "find_switch", &rows);
}

/// find_switch: the samples, the extremum check between samples (grazing), the Illinois
/// root search, the flip at the start; its result theta (the switch's fraction, > 1 for
/// none) and the largest g sampled.
#[test]
fn find_switch_on_the_gpu_equals_the_rust_function_bit_for_bit() {
    both_precisions!(check_find_switch);
}

fn check_free_flight_certain<R: GpuReal>(runner: &GpuRunner) {
    let mut rows = Vec::new();
    let (mut certain, mut searched) = (0, 0);
    for (lc, x0, x1, hs, _) in switch_inputs::<R>() {
        let c = free_flight_certain(&lc, &x0, &x1, hs);
        if c {
            certain += 1;
            // The certificate's promise, on the inputs around contact.
            let sw = find_switch(&lc, &x0, &x1, hs, false);
            assert!(sw.theta.to_f64() > 1.0, "certified step switches");
        } else {
            searched += 1;
        }
        rows.push(
            Row::new()
                .consts(&lc)
                .state(&x0)
                .state(&x1)
                .real(hs)
                .expect(&[flag(c)]),
        );
    }
    eprintln!(
        "free_flight_certain ({}): {certain} certain, {searched} not",
        R::WGSL_NAME
    );
    assert!(certain > 50 && searched > 50, "{certain} {searched}");
    assert_mirrors(runner, "free_flight_certain", &rows);
}

#[test]
fn free_flight_certain_on_the_gpu_equals_the_rust_function_bit_for_bit() {
    both_precisions!(check_free_flight_certain);
}

/// The certificates' parts and the contact certificate, on the switch inputs around
/// contact, each step with several largest penetrations so far (none, the step's own
/// largest g, half and twice it, and a NaN): control_points, hull_reach_sq (also on
/// points with a NaN), clear_of_stator, in_contact_certain and search_needless, whose promise (no switch,
/// no g above max_pen) is checked against find_switch here too.
fn check_certificates<R: GpuReal>(runner: &GpuRunner) {
    let (mut points, mut hulls, mut clear, mut held, mut needless) =
        (vec![], vec![], vec![], vec![], vec![]);
    let (mut certain, mut declined) = (0, 0);
    for (lc, x0, x1, hs, contact) in switch_inputs::<R>() {
        let delta = lc.c.delta;
        let p = control_points(&x0, &x1, hs);
        points.push(
            Row::new()
                .state(&x0)
                .state(&x1)
                .real(hs)
                .expect(&p.concat()),
        );
        let mut q = p.concat();
        hulls.push(Row::new().state(&q).expect(&[hull_reach_sq(&p)]));
        q[3] = R::lit(f64::NAN);
        let with_nan = [[q[0], q[1]], [q[2], q[3]], [q[4], q[5]], [q[6], q[7]]];
        hulls.push(Row::new().state(&q).expect(&[hull_reach_sq(&with_nan)]));
        clear.push(
            Row::new()
                .real(delta)
                .state(&x0)
                .state(&x1)
                .real(hs)
                .expect(&[flag(clear_of_stator(delta, &x0, &x1, hs))]),
        );
        let sw = find_switch(&lc, &x0, &x1, hs, contact);
        let g = sw.max_g.to_f64().max(0.0);
        for max_pen in [0.0, g, 0.5 * g, 2.0 * g, f64::NAN].map(R::lit) {
            let c = in_contact_certain(delta, &x0, &x1, hs, max_pen);
            let n = search_needless(delta, &x0, &x1, hs, contact, max_pen);
            if n {
                certain += 1;
                // The promise: the search would change no bit.
                assert!(sw.theta.to_f64() > 1.0, "a needless search switches");
                assert!(
                    sw.max_g <= max_pen || !contact,
                    "a needless search raises max_pen"
                );
            } else {
                declined += 1;
            }
            let args = |r: Row<R>| r.real(delta).state(&x0).state(&x1).real(hs);
            held.push(args(Row::new()).real(max_pen).expect(&[flag(c)]));
            needless.push(
                args(Row::new())
                    .flag(contact)
                    .real(max_pen)
                    .expect(&[flag(n)]),
            );
        }
    }
    eprintln!(
        "search_needless ({}): {certain} needless, {declined} not",
        R::WGSL_NAME
    );
    assert!(certain > 50 && declined > 50, "{certain} {declined}");
    assert_mirrors(runner, "control_points", &points);
    assert_mirrors(runner, "hull_reach_sq", &hulls);
    assert_mirrors(runner, "clear_of_stator", &clear);
    assert_mirrors(runner, "in_contact_certain", &held);
    assert_mirrors(runner, "search_needless", &needless);
}

#[test]
fn the_search_certificates_on_the_gpu_equal_the_rust_functions_bit_for_bit() {
    both_precisions!(check_certificates);
}

/// hermite_gap rows: at the samples j/8 that find_switch evaluates (`samples`), or at the
/// located switch and a random fraction (the points where find_switch uses g only);
/// wrong_side rows for each g.
fn hermite_rows<R: Real>(samples: bool) -> (Vec<Row<R>>, Vec<Row<R>>) {
    let mut gap = Vec::new();
    let mut side = Vec::new();
    for (i, (lc, x0, x1, hs, contact)) in switch_inputs::<R>().into_iter().enumerate() {
        let thetas = if samples {
            vec![
                R::lit((i % 9) as f64 / 8.0),
                R::lit(((i + 4) % 9) as f64 / 8.0),
            ]
        } else {
            let sw = find_switch(&lc, &x0, &x1, hs, contact);
            let mut t = vec![R::lit(unit(i, 53).abs())];
            if sw.theta.to_f64() <= 1.0 {
                t.push(sw.theta);
            }
            t
        };
        for theta in thetas {
            let (g, rate) = hermite_gap(lc.c.delta, &x0, &x1, hs, theta);
            gap.push(
                Row::new()
                    .real(lc.c.delta)
                    .state(&x0)
                    .state(&x1)
                    .real(hs)
                    .real(theta)
                    .expect(&[g, rate]),
            );
            side.push(
                Row::new()
                    .real(g)
                    .flag(contact)
                    .expect(&[flag(wrong_side(g, contact))]),
            );
        }
    }
    (gap, side)
}

fn check_hermite_gap_and_wrong_side<R: GpuReal>(runner: &GpuRunner) {
    let (gap, mut side) = hermite_rows::<R>(true);
    let (_, between) = hermite_rows::<R>(false);
    side.extend(between);
    for g in [0.0, -0.0, 1e-12, -1e-12] {
        for contact in [false, true] {
            let g = R::lit(g);
            side.push(
                Row::new()
                    .real(g)
                    .flag(contact)
                    .expect(&[flag(wrong_side(g, contact))]),
            );
        }
    }
    assert_mirrors(runner, "hermite_gap", &gap);
    assert_mirrors(runner, "wrong_side", &side);
}

/// The Hermite samples of g and its rate along a sub-step (at the samples j/8, where
/// find_switch uses both), and the side test. g between the samples (extremum checks,
/// Illinois iterates) is checked through find_switch.
#[test]
fn hermite_gap_samples_and_wrong_side_on_the_gpu_equal_the_rust_functions_bit_for_bit() {
    both_precisions!(check_hermite_gap_and_wrong_side);
}

fn check_hermite_gap_between_samples<R: GpuReal>(runner: &GpuRunner) {
    let (gap, _) = hermite_rows::<R>(false);
    let p = probe("hermite_gap");
    let flat: Vec<R> = gap.iter().flat_map(|r| r.args.iter().copied()).collect();
    let v = device_variant(runner, true);
    let promised = identity_promised::<R>(runner, v);
    let out = run_probe(runner, v, "hermite_gap", &flat);
    let eps = if R::WGSL_NAME == "f64" {
        f64::EPSILON
    } else {
        f32::EPSILON as f64
    };
    let (mut exact, mut worst_ulps) = (0, 0.0f64);
    for (i, (r, gpu)) in gap.iter().zip(out.chunks_exact(p.outputs)).enumerate() {
        let (g_cpu, g_gpu) = (r.expect[0].to_f64(), gpu[0].to_f64());
        assert!(
            !promised || g_cpu.to_bits() == g_gpu.to_bits(),
            "hermite_gap ({}): row {i}: g differs: {g_cpu:e} against {g_gpu:e}",
            R::WGSL_NAME
        );
        let (a, b) = (r.expect[1].to_f64(), gpu[1].to_f64());
        if a.to_bits() == b.to_bits() {
            exact += 1;
        } else {
            // The rate's scale: |relative velocity| x hs (args: delta, x0, x1, hs, theta);
            // the rate itself may be near 0 (an extremum of g), where it is all
            // cancellation.
            let v = |x: &[R], d: usize| x[1 + d].to_f64();
            let rel = |o: usize| {
                (v(&r.args, o + VX_R) - v(&r.args, o + VX_S))
                    .hypot(v(&r.args, o + VY_R) - v(&r.args, o + VY_S))
            };
            let scale = rel(0).max(rel(STATE_DIM)) * r.args[1 + 2 * STATE_DIM].to_f64();
            worst_ulps = worst_ulps.max((a - b).abs() / (eps * scale));
        }
    }
    eprintln!(
        "hermite_gap between samples ({}): g bit-identical on all {} rows; rate bit-identical on {exact}, the rest within {worst_ulps:.1} ulp of |relative velocity| x hs",
        R::WGSL_NAME,
        gap.len()
    );
    assert!(
        worst_ulps <= 256.0,
        "hermite_gap ({}): the rate between samples is {worst_ulps:.0} ulp off",
        R::WGSL_NAME
    );
}

/// hermite_gap between the samples (random theta and the located switch), where
/// find_switch uses g only (extremum checks, Illinois iterates): g bit for bit on every
/// row, the rate within 256 ulp of its scale (|relative velocity| x hs). On lavapipe
/// (Mesa 22.3.6, f64) the rate differs by about 1 ulp of that scale on ~1.5 % of these
/// rows and is bit-identical at the samples j/8, where
/// the stepper uses it (`hermite_gap_samples_...` above). Not found: `keep` on the
/// division, its numerator, each product and partial sum of the derivative, and the
/// derivative basis changed not a bit; the rate is a sum with cancellation, so one bit
/// of dx or dy anywhere upstream shows as several ulp. docs/mirror.md lists it.
#[test]
fn hermite_gap_between_samples_has_the_rust_g_to_the_bit_and_the_rate_within_256_ulp() {
    both_precisions!(check_hermite_gap_between_samples);
}

fn check_saltation<R: GpuReal>(runner: &GpuRunner) {
    let mut rows = Vec::new();
    let (mut sheared, mut identity) = (0, 0);
    let norm = |v: &[R; STATE_DIM]| v.iter().map(|a| a.to_f64().powi(2)).sum::<f64>().sqrt();
    for (i, c) in cases::<R>().iter().enumerate() {
        let t = trial(i, c);
        let sw = find_switch(&c.lc, &c.x, &t.x1, t.hs, c.contact);
        // Where the stepper applies it: at the located switch (the re-step's end), or at
        // the trial step's end, or at its start.
        let theta = sw.theta.to_f64();
        let (x, s) = if theta > 0.0 && theta < 1.0 {
            let ds = t.ds * sw.theta;
            (
                rk4_substep(&c.lc, &c.x, c.k, t.s0, ds, c.contact),
                t.s0 + ds,
            )
        } else if theta >= 1.0 {
            (t.x1, t.s0 + t.ds)
        } else {
            (c.x, t.s0)
        };
        let v = tangent::<R>(i, 0.35);
        let mut tan = Tangent::<R, 1>::new([v]);
        saltation(&c.lc, &x, c.k, s, c.contact, &mut tan);
        // Sheared beyond rounding: with contact damping the force jumps at g = 0.
        let dv: [R; STATE_DIM] = std::array::from_fn(|d| tan.v[0][d] - v[d]);
        if norm(&dv) > 1e-4 * norm(&v) {
            sheared += 1;
        } else {
            identity += 1;
        }
        rows.push(
            Row::new()
                .consts(&c.lc)
                .state(&x)
                .int(c.k)
                .real(s)
                .flag(c.contact)
                .state(&v)
                .expect(&tan.v[0]),
        );
    }
    eprintln!(
        "saltation ({}): {sheared} rows shear the vector by more than 1e-4 (contact damping: S != I), {identity} leave it to rounding",
        R::WGSL_NAME
    );
    assert!(sheared > 100 && identity > 100, "{sheared} / {identity}");
    assert_mirrors(runner, "saltation", &rows);
}

/// The saltation update of the tangent vector at a switch.
#[test]
fn saltation_on_the_gpu_equals_the_rust_function_bit_for_bit() {
    both_precisions!(check_saltation);
}
