//! RK4 sub-steps, the exact free-flight map and the variational equations
//! (lane.wgsl, free_flight.wgsl, tangent.wgsl).

use super::*;

fn check_rk4_substep<R: GpuReal>(runner: &GpuRunner) {
    let mut rows = Vec::new();
    for (i, c) in cases::<R>().iter().enumerate() {
        let t = trial(i, c);
        // The trial sub-step, and a re-step to a fraction of it (as to a located switch).
        for ds in [t.ds, t.ds * R::lit(unit(i, 52).abs())] {
            rows.push(
                Row::new()
                    .consts(&c.lc)
                    .substep(&c.x, c.k, t.s0, ds, c.contact)
                    .expect(&rk4_substep(&c.lc, &c.x, c.k, t.s0, ds, c.contact)),
            );
        }
    }
    assert_mirrors(runner, "rk4_substep", &rows);
}

fn check_free_flight<R: GpuReal>(runner: &GpuRunner) {
    let (mut steps, mut tangents) = (Vec::new(), Vec::new());
    for (i, c) in cases::<R>().iter().enumerate() {
        let Some(ex) = c.lc.exact else {
            continue;
        };
        steps.push(
            Row::new()
                .consts(&c.lc)
                .state(&c.x)
                .int(c.k)
                .expect(&free_flight_step(&ex, &c.lc, &c.x, c.k)),
        );
        let v = tangent::<R>(i, 1.0);
        let mut t = Tangent::new([v]);
        free_flight_tangent(&ex, &c.lc, &mut t);
        tangents.push(Row::new().consts(&c.lc).state(&v).expect(&t.v[0]));
    }
    assert!(
        steps.len() > 100,
        "{} cases with the exact map",
        steps.len()
    );
    assert_mirrors(runner, "free_flight_step", &steps);
    assert_mirrors(runner, "free_flight_tangent", &tangents);
    // trial_tangent: the map's transition where the step was exact, else RK4's tangent
    // step over the trial sub-step.
    let mut rows = Vec::new();
    for (i, c) in cases::<R>().iter().enumerate() {
        let t = trial(i, c);
        let v = tangent::<R>(i, 1.0);
        let exact = exact_trial(&c.lc, t.s0, c.contact);
        let mut tan = Tangent::new([v]);
        trial_tangent(&c.lc, exact, &c.x, c.k, t.s0, t.ds, c.contact, &mut tan);
        rows.push(
            Row::new()
                .consts(&c.lc)
                .flag(exact.is_some())
                .substep(&c.x, c.k, t.s0, t.ds, c.contact)
                .state(&v)
                .expect(&tan.v[0]),
        );
    }
    assert!(
        rows.iter().any(|r| r.args[CONSTS] > R::lit(0.5)),
        "no exact trial step among the cases"
    );
    assert_mirrors(runner, "trial_tangent", &rows);
}

/// The exact free-flight step and its tangent map (integrate/free_flight.rs).
#[test]
fn free_flight_step_and_tangent_on_the_gpu_equal_the_rust_functions_bit_for_bit() {
    both_precisions!(check_free_flight);
}

#[test]
fn rk4_substep_on_the_gpu_equals_the_rust_function_bit_for_bit() {
    both_precisions!(check_rk4_substep);
}

fn check_tangent_functions<R: GpuReal>(runner: &GpuRunner) {
    let mut stage = Vec::new();
    let mut rhs = Vec::new();
    let mut step = Vec::new();
    for (i, c) in cases::<R>().iter().enumerate() {
        let t = trial(i, c);
        let v = tangent::<R>(i, 0.35);
        for contact in [c.contact, !c.contact] {
            let pc = stage_partials(&c.lc.c, &c.x, contact);
            stage.push(
                Row::new()
                    .coeffs(&c.lc.c)
                    .state(&c.x)
                    .flag(contact)
                    .expect(&pc),
            );
            rhs.push(
                Row::new()
                    .coeffs(&c.lc.c)
                    .state(&pc)
                    .state(&v)
                    .expect(&tangent_rhs(&c.lc.c, &pc, &v)),
            );
        }
        let mut tan = Tangent::<R, 1>::new([v]);
        rk4_tangent_substep(&c.lc, &c.x, c.k, t.s0, t.ds, c.contact, &mut tan);
        step.push(
            Row::new()
                .consts(&c.lc)
                .substep(&c.x, c.k, t.s0, t.ds, c.contact)
                .state(&v)
                .expect(&tan.v[0]),
        );
    }
    assert_mirrors(runner, "stage_partials", &stage);
    assert_mirrors(runner, "tangent_rhs", &rhs);
    assert_mirrors(runner, "rk4_tangent_substep", &step);
}

/// stage_partials, tangent_rhs and rk4_tangent_substep (the variational equations).
#[test]
fn tangent_rhs_and_rk4_tangent_substep_on_the_gpu_equal_the_rust_functions_bit_for_bit() {
    both_precisions!(check_tangent_functions);
}
