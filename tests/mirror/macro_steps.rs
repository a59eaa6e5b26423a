//! Renormalisation, contact refinement and whole macro steps (lane.wgsl).

use super::*;

fn check_renormalise_and_trial_extent<R: GpuReal>(runner: &GpuRunner) {
    let mut norm = Vec::new();
    for i in 0..3000 {
        let scale = 10f64.powi((i % 13) as i32 - 6);
        let mut v = tangent::<R>(i, scale);
        if i == 0 {
            v = [R::lit(0.0); STATE_DIM];
        }
        let v0 = v;
        let n = renormalise(&mut v);
        let mut out = vec![n];
        out.extend_from_slice(&v);
        norm.push(Row::new().state(&v0).expect(&out));
    }
    let mut ext = Vec::new();
    for (i, c) in cases::<R>().iter().enumerate().step_by(3) {
        let one = R::lit(1.0);
        for s in [
            R::lit(0.0),
            R::lit(0.5),
            one - c.lc.inv_r,
            R::lit(unit(i, 54).abs()),
        ] {
            for contact in [false, true] {
                let (ds, end) = trial_extent(&c.lc, s, contact);
                ext.push(
                    Row::new()
                        .consts(&c.lc)
                        .real(s)
                        .flag(contact)
                        .expect(&[ds, end]),
                );
            }
        }
    }
    assert_mirrors(runner, "renormalise", &norm);
    assert_mirrors(runner, "trial_extent", &ext);
}

/// renormalise (the tangent's growth per period) and trial_extent (contact refinement).
#[test]
fn renormalise_and_trial_extent_on_the_gpu_equal_the_rust_functions_bit_for_bit() {
    both_precisions!(check_renormalise_and_trial_extent);
}

fn check_macro_step<R: GpuReal>(runner: &GpuRunner) {
    let mut rows = Vec::new();
    let (mut switched, mut capped) = (0, 0);
    for (i, c) in cases::<R>().iter().enumerate() {
        let mut lc = c.lc;
        // Segment caps of 1 and 2 on two rows in five, so that the cap's path runs (1 is
        // below what StepperConfig accepts, but both functions take any cap).
        match i % 5 {
            0 => lc.max_segments = 1,
            1 => lc.max_segments = 2,
            _ => {}
        }
        let v = tangent::<R>(i, 0.35);
        let mut lane = Lane::<R>::new(&[0.0; STATE_DIM], 0.0);
        lane.x = c.x;
        lane.contact = c.contact;
        lane.k = c.k;
        let mut tan = Tangent::<R, 1>::new([v]);
        macro_step_tangent(&lc, &mut lane, &mut tan);
        let ct = lane.counters;
        switched += (ct.switches > 0) as usize;
        capped += (lane.status == Status::RefinementCap) as usize;
        let mut out = lane.x.to_vec();
        out.extend([
            flag(lane.contact),
            R::lit(lane.k as f64),
            R::lit(lane.status.code() as f64),
            R::lit(ct.macro_steps as f64),
            R::lit(ct.contact_steps as f64),
            R::lit(ct.switches as f64),
            R::lit(ct.extra_substeps as f64),
            R::lit(ct.max_penetration),
        ]);
        out.extend_from_slice(&tan.v[0]);
        rows.push(
            Row::new()
                .consts(&lc)
                .state(&c.x)
                .flag(c.contact)
                .int(c.k)
                .state(&v)
                .expect(&out),
        );
    }
    eprintln!(
        "macro_step ({}): {switched} rows switch, {capped} reach the segment cap",
        R::WGSL_NAME
    );
    assert!(switched > 300 && capped > 10, "{switched} / {capped}");
    assert_mirrors(runner, "macro_step", &rows);
}

/// A whole macro step with a tangent vector: the kernel's resumable macro_step
/// (macro_step_begin, one sub-step per call, macro_step_end) against lane.rs's
/// macro_step_tangent; state, mode, k, status, counters and the tangent vector.
#[test]
fn macro_step_on_the_gpu_equals_the_rust_function_bit_for_bit() {
    both_precisions!(check_macro_step);
}
