//! The forcing phasor, the contact force and its partials, the right-hand side
//! (forcing.wgsl, model.wgsl).

use super::*;

fn check_rhs_frozen<R: GpuReal>(runner: &GpuRunner) {
    let mut rows: Vec<Row<R>> = random_rhs_inputs::<R>(50_000)
        .into_iter()
        .map(|(c, x, cos, sin, contact, _)| {
            Row::new()
                .coeffs(&c)
                .state(&x)
                .real(cos)
                .real(sin)
                .flag(contact)
                .expect(&rhs_frozen(&c, &x, cos, sin, contact))
        })
        .collect();
    for (i, c) in cases::<R>().iter().enumerate() {
        let (cos, sin) = forcing_phasor(&c.lc, c.k, R::lit(unit(i, 50).abs()));
        for contact in [c.contact, !c.contact] {
            rows.push(
                Row::new()
                    .coeffs(&c.lc.c)
                    .state(&c.x)
                    .real(cos)
                    .real(sin)
                    .flag(contact)
                    .expect(&rhs_frozen(&c.lc.c, &c.x, cos, sin, contact)),
            );
        }
    }
    assert_mirrors(runner, "rhs_frozen", &rows);
}

/// Where Mesa's add-chain reassociation bit before `keep` (the stator's y row).
#[test]
fn rhs_frozen_on_the_gpu_equals_the_rust_function_bit_for_bit() {
    both_precisions!(check_rhs_frozen);
}

fn check_phasor_turns<R: GpuReal>(runner: &GpuRunner) {
    let mut rows: Vec<Row<R>> = random_rhs_inputs::<R>(50_000)
        .into_iter()
        .map(|(.., turns)| {
            let (c, s) = phasor_turns(turns);
            Row::new().real(turns).expect(&[c, s])
        })
        .collect();
    // Quadrant boundaries and their neighbours, exactly representable turns.
    for q in -8..=8 {
        let t = R::lit(q as f64 / 8.0);
        let (c, s) = phasor_turns(t);
        rows.push(Row::new().real(t).expect(&[c, s]));
    }
    assert_mirrors(runner, "phasor_turns", &rows);
}

#[test]
fn phasor_turns_on_the_gpu_equals_the_rust_function_bit_for_bit() {
    both_precisions!(check_phasor_turns);
}

fn check_forcing_phasor<R: GpuReal>(runner: &GpuRunner) {
    let mut rows = Vec::new();
    for (i, c) in cases::<R>().iter().enumerate() {
        // The stage fractions rk4_substep asks for, and a random one.
        let t = trial(i, c);
        let half = R::lit(0.5);
        for sigma in [
            t.s0,
            t.s0 + half * t.ds,
            t.s0 + t.ds,
            R::lit(unit(i, 51).abs()),
        ] {
            let (cs, sn) = forcing_phasor(&c.lc, c.k, sigma);
            rows.push(
                Row::new()
                    .consts(&c.lc)
                    .int(c.k)
                    .real(sigma)
                    .expect(&[cs, sn]),
            );
        }
    }
    assert_mirrors(runner, "forcing_phasor", &rows);
}

#[test]
fn forcing_phasor_on_the_gpu_equals_the_rust_function_bit_for_bit() {
    both_precisions!(check_forcing_phasor);
}

fn check_penetration_and_contact_force<R: GpuReal>(runner: &GpuRunner) {
    let (mut law, mut lane, mut law_partials, mut powers) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut blocks = Vec::new();
    let mut motion = Vec::new();
    let mut pen = Vec::new();
    let mut force = Vec::new();
    let mut partials = Vec::new();
    for (i, c) in cases::<R>().iter().enumerate() {
        // The macro step's start and the end of its trial sub-step.
        for x in [c.x, trial(i, c).x1] {
            let cc = &c.lc.c;
            pen.push(
                Row::new()
                    .real(cc.delta)
                    .state(&x)
                    .expect(&[penetration(cc.delta, &x)]),
            );
            let d = relative_motion(&x);
            motion.push(Row::new().state(&x).expect(&d));
            let (fx, fy) = contact_force_per_kc(cc.delta, cc.mu, cc.tau_c, d[0], d[1], d[2], d[3]);
            force.push(
                Row::new()
                    .real(cc.delta)
                    .real(cc.mu)
                    .real(cc.tau_c)
                    .state(&d)
                    .expect(&[fx, fy]),
            );
            partials.push(
                Row::new()
                    .coeffs(cc)
                    .state(&x)
                    .expect(&contact_partials(cc, &x)),
            );
            let (lx, ly) = contact_force_per_kc_law(cc, d[0], d[1], d[2], d[3]);
            law.push(Row::new().coeffs(cc).state(&d).expect(&[lx, ly]));
            let (lx, ly) = contact_force_lane(cc, d[0], d[1], d[2], d[3]);
            lane.push(Row::new().coeffs(cc).state(&d).expect(&[lx, ly]));
            law_partials.push(
                Row::new()
                    .coeffs(cc)
                    .state(&x)
                    .expect(&contact_partials_law_off_centre(cc, &x)),
            );
            // The block of any normal force's partials (of about the contact's scales).
            let v = tangent::<R>(i, 1.0);
            let n = NormalPartials(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]);
            blocks.push(
                Row::new()
                    .real(d[0])
                    .real(d[1])
                    .real(cc.mu)
                    .state(&v)
                    .expect(&contact_block(d[0], d[1], cc.mu, &n)),
            );
            // Every exponent at this row's gap, either sign (the held contact mode's
            // continuation takes |g|).
            let g = penetration(cc.delta, &x);
            for m in [0.0, 0.5, 1.0, 1.5, 2.0] {
                let (a, m) = (g.abs(), R::lit(m));
                powers.push(Row::new().real(a).real(m).expect(&[pow_half(a, m)]));
            }
        }
    }
    // Concentric bodies: no normal, no force (the r <= 0 branch).
    let z = R::lit(0.0);
    let c = lane_consts::<R>(1).1.c;
    force.push(
        Row::new()
            .real(c.delta)
            .real(c.mu)
            .real(c.tau_c)
            .state(&[z, z, R::lit(0.1), z])
            .expect(&[z, z]),
    );
    partials.push(
        Row::new()
            .coeffs(&c)
            .state(&[z; STATE_DIM])
            .expect(&contact_partials(&c, &[z; STATE_DIM])),
    );
    assert_mirrors(runner, "relative_motion", &motion);
    assert_mirrors(runner, "penetration", &pen);
    assert_mirrors(runner, "contact_force_per_kc", &force);
    assert_mirrors(runner, "contact_partials", &partials);
    assert_mirrors(runner, "contact_block", &blocks);
    assert_mirrors(runner, "pow_half", &powers);
    assert_mirrors(runner, "contact_force_per_kc_law", &law);
    assert_mirrors(runner, "contact_force_lane", &lane);
    assert_mirrors(runner, "contact_partials_law_off_centre", &law_partials);
}

/// relative_motion, penetration, contact_force_per_kc and contact_partials (model.wgsl),
/// and the contact laws' pow_half, forces and partials, and the block both laws'
/// partials share (contact_block).
#[test]
fn penetration_and_contact_force_and_its_partials_on_the_gpu_equal_the_rust_functions_bit_for_bit()
{
    both_precisions!(check_penetration_and_contact_force);
}
