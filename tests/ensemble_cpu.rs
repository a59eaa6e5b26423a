//! The CPU ensemble backend: deterministic across thread counts, lanes isolated from
//! each other, and the same arithmetic as a single `simulate` run.

use jeffcott_analysis::simulate::{Integrator, SimulateSpec, simulate};
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::{EnsembleSpec, LaneSpec, Precision, cpu};
use jeffcott_core::integrate::lane::{Counters, Status, StepperConfig, advance_period};
use jeffcott_core::model::{Params, VX_R, X_R};

fn spec(precision: Precision, lanes: usize) -> EnsembleSpec {
    let p = Params::default();
    let lanes = (0..lanes)
        .map(|i| {
            let mut x0 = p.static_equilibrium();
            x0[X_R] = 0.0058 * ((i % 5) as f64 / 4.0);
            x0[VX_R] = 0.8 * (((i * 7) % 11) as f64 / 10.0 - 0.5);
            LaneSpec {
                omega: 130.0 + 11.0 * i as f64 / lanes as f64,
                x0,
                param_set: (i % 2) as u32,
            }
        })
        .collect();
    EnsembleSpec {
        param_sets: vec![p.clone(), Params { delta: 1.0, ..p }],
        lanes,
        transient: 20,
        recorded: 5,
        stepper: StepperConfig {
            steps_per_period: 200,
            ..StepperConfig::default()
        },
        precision,
    }
}

#[test]
fn cpu_results_are_bit_identical_for_one_and_many_threads() {
    for precision in [Precision::F64, Precision::F32] {
        let s = spec(precision, 48);
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| cpu::run(&s, false, Control::none()).unwrap())
        };
        let (a, b) = (run(1), run(3));
        assert_eq!(
            a.poincare.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            b.poincare.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(a.status, b.status);
        assert_eq!(a.counters, b.counters);
        assert!(
            a.counters.iter().any(|c| c.switches > 0),
            "some lanes must rub"
        );
        assert!(
            a.counters.iter().any(|c| c.switches == 0),
            "some lanes must fly free"
        );
    }
}

#[test]
fn poisoned_lanes_are_flagged_and_leave_their_neighbours_untouched() {
    let clean = spec(Precision::F64, 8);
    let mut poisoned = clean.clone();
    poisoned.lanes[2].x0[X_R] = f64::NAN;
    poisoned.lanes[5].x0[VX_R] = 1e6; // thrown out of any bound
    let a = cpu::run(&clean, false, Control::none()).unwrap();
    let b = cpu::run(&poisoned, false, Control::none()).unwrap();
    assert_eq!(b.status[2], Status::NonFinite);
    assert!(
        b.status[5] == Status::Diverged || b.status[5] == Status::NonFinite,
        "{:?}",
        b.status[5]
    );
    for i in [0, 1, 3, 4, 6, 7] {
        assert_eq!(a.lane_points(i), b.lane_points(i), "lane {i}");
        assert_eq!(a.status[i], b.status[i]);
    }
}

#[test]
fn ensemble_lanes_reproduce_single_simulations_exactly() {
    // 13 lanes: one SIMD batch and five lanes run one by one.
    let s = spec(Precision::F64, 13);
    let r = cpu::run(&s, false, Control::none()).unwrap();
    for i in 0..s.lanes.len() {
        let l = &s.lanes[i];
        let single = simulate(&SimulateSpec {
            params: s.param_sets[l.param_set as usize].clone(),
            omega: l.omega,
            x0: l.x0,
            transient: s.transient,
            periods: s.recorded,
            timeseries_periods: 1,
            integrator: Integrator::Lane,
            stepper: s.stepper,
            article: Default::default(),
            classify: Default::default(),
        })
        .unwrap();
        assert_eq!(r.lane_states(i), single.poincare, "lane {i}");
    }
}

#[test]
fn invalid_ensembles_name_the_lane_and_field() {
    let mut s = spec(Precision::F64, 4);
    s.lanes[3].omega = -1.0;
    let e = cpu::run(&s, false, Control::none())
        .unwrap_err()
        .to_string();
    assert!(e.contains("omega (lane 3)") && e.contains("> 0"), "{e}");
    let mut s = spec(Precision::F64, 4);
    s.lanes[1].param_set = 9;
    let e = cpu::run(&s, false, Control::none())
        .unwrap_err()
        .to_string();
    assert!(e.contains("param_set (lane 1)"), "{e}");
}

/// Every lane of an ensemble through the scalar lane stepper alone, as the GPU kernel
/// mirrors it: the reference the SIMD batch path must equal (records of frozen lanes NaN
/// from the period they froze in, `ensemble::mask_frozen_records`).
fn scalar_reference<R: jeffcott_core::real::Real>(
    s: &EnsembleSpec,
) -> Vec<(Vec<u64>, Status, Counters)> {
    (0..s.lanes.len())
        .map(|i| {
            let lc = s.lane_consts::<R>(i);
            let mut lane = s.initial_lane::<R>(i);
            for _ in 0..s.transient {
                advance_period(&lc, &mut lane);
            }
            let mut bits = Vec::new();
            for _ in 0..s.recorded {
                advance_period(&lc, &mut lane);
                // A period in which the lane froze, and every later one, is NaN.
                bits.extend(lane.x.iter().map(|v| {
                    if lane.status.is_frozen() {
                        f64::NAN.to_bits()
                    } else {
                        v.to_f64().to_bits()
                    }
                }));
            }
            (bits, lane.status, lane.counters)
        })
        .collect()
}

/// Runs `s` on the CPU backend (SIMD batches) and demands every lane's points, status
/// and counters of the scalar lane stepper ([`scalar_reference`]) to the bit; returns
/// the run.
fn assert_batches_equal_the_scalar_stepper(
    s: &EnsembleSpec,
    what: &str,
) -> jeffcott_core::ensemble::EnsembleResult {
    let r = cpu::run(s, false, Control::none()).unwrap();
    let reference = match s.precision {
        Precision::F64 => scalar_reference::<f64>(s),
        Precision::F32 => scalar_reference::<f32>(s),
    };
    for (i, (bits, status, counters)) in reference.iter().enumerate() {
        let got: Vec<u64> = r.lane_points(i).iter().map(|v| v.to_bits()).collect();
        assert_eq!(&got, bits, "{what} lane {i} points");
        assert_eq!(r.status[i], *status, "{what} lane {i} status");
        assert_eq!(r.counters[i], *counters, "{what} lane {i} counters");
    }
    r
}

#[test]
fn simd_batches_equal_the_scalar_lane_stepper_to_the_bit() {
    // Every precision, and contact refinement off (R = 1), at its default and at the
    // largest R: the batch takes R passes for lanes in contact and hands a lane over to
    // the scalar stepper in the middle of a macro step. With the exact free-flight step
    // too: a batch mixes lanes taking it with lanes in contact taking RK4.
    let cases = [
        (Precision::F64, None, false),
        (Precision::F32, None, false),
        (Precision::F64, Some(1), false),
        (Precision::F64, Some(16), false),
        (Precision::F32, Some(4), false),
        (Precision::F64, None, true),
        (Precision::F32, Some(8), true),
    ];
    for (precision, refine, exact) in cases {
        // 53 lanes: six batches of 8 and five single lanes; one batch holds a NaN lane
        // and a lane thrown out of every bound, so frozen lanes share batches with live
        // ones.
        let mut s = spec(precision, 53);
        if let Some(r) = refine {
            s.stepper.contact_substeps = r;
        }
        s.stepper.exact_free_flight = exact;
        s.lanes[9].x0[X_R] = f64::NAN;
        s.lanes[12].x0[VX_R] = 1e6;
        // A third parameter set with contact damping (a velocity-dependent force that
        // jumps at g = 0) for every third lane.
        let damped = jeffcott_core::model::Params {
            c_c: 2e4,
            ..s.param_sets[0].clone()
        };
        s.param_sets.push(damped);
        for l in s.lanes.iter_mut().step_by(3) {
            l.param_set = 2;
        }
        // A fourth with another unbalance phase for every seventh lane: its batches mix
        // phases, so the forcing table serves some batches and not others (those
        // evaluate the phasor), and a packed pass may mix both kinds.
        let turned = jeffcott_core::model::Params {
            phi0: 0.9,
            ..s.param_sets[0].clone()
        };
        s.param_sets.push(turned);
        for l in s.lanes.iter_mut().skip(4).step_by(7) {
            l.param_set = 3;
        }
        let r = assert_batches_equal_the_scalar_stepper(
            &s,
            &format!("{precision:?} R {refine:?} exact {exact}"),
        );
        assert_eq!(r.status[9], Status::NonFinite);
        assert!(r.status[12].is_frozen());
        let switches: u64 = r.counters.iter().map(|c| c.switches).sum();
        assert!(switches > 100, "the lanes must rub: {switches} switches");
    }
}

/// Adds the machine variants of docs/model.md 7 to `s` (a Hertzian contact with
/// Hunt-Crossley damping, a power law of exponent 2, anisotropic supports with an
/// offset stator, and all of them at once) and spreads them over the lanes so that
/// batches mix them with the article's linear lanes; the last eight lanes, one batch,
/// are all Hertzian.
fn with_machine_variants(s: &mut EnsembleSpec) {
    let p = s.param_sets[0].clone();
    let hertz = |n: f64, alpha: f64| Params {
        n_c: n,
        alpha_c: alpha,
        k_c: p.k_c * 1e-4f64.powf(1.0 - n),
        ..p.clone()
    };
    let machine = Params {
        omega_ry: Some(150.0),
        xi_sx: Some(0.03),
        o_x: 0.001,
        o_y: -0.0005,
        ..p.clone()
    };
    let everything = Params {
        omega_ry: Some(150.0),
        o_x: 0.001,
        ..hertz(2.5, 0.1)
    };
    let first = s.param_sets.len() as u32;
    s.param_sets.extend([
        hertz(1.5, 0.2),
        hertz(2.0, 0.0),
        machine,
        everything,
        hertz(1.0, 0.3),
    ]);
    let n = s.lanes.len();
    for (i, l) in s.lanes.iter_mut().enumerate() {
        if i >= n - 8 {
            // A batch of Hertz lanes only.
            l.param_set = first;
        } else if i >= n - 16 {
            // A batch whose laws' exponents are all whole (n = 2, and the linear spring
            // with Hunt-Crossley damping): its power of the gap takes no square root.
            l.param_set = [0, first + 1, first + 4][i % 3];
        } else if i % 3 != 0 {
            l.param_set = first + (i % 4) as u32;
        }
    }
}

/// Batches mixing the machine variants (each lane its own contact law, supports and
/// stator centre; `integrate::batch` takes the variants' code for a batch where one
/// lane needs it) equal the scalar lane stepper to the bit, in both precisions, with
/// and without the exact free-flight step.
#[test]
fn simd_batches_mixing_the_machine_variants_equal_the_scalar_lane_stepper_to_the_bit() {
    for (precision, exact) in [
        (Precision::F64, false),
        (Precision::F32, false),
        (Precision::F64, true),
    ] {
        let mut s = spec(precision, 64);
        s.stepper.exact_free_flight = exact;
        with_machine_variants(&mut s);
        let r =
            assert_batches_equal_the_scalar_stepper(&s, &format!("{precision:?} exact {exact}"));
        // Every variant rubs, so each law's code runs.
        for set in 2..s.param_sets.len() as u32 {
            let switches: u64 = (0..s.lanes.len())
                .filter(|&i| s.lanes[i].param_set == set)
                .map(|i| r.counters[i].switches)
                .sum();
            assert!(switches > 20, "parameter set {set}: {switches} switches");
        }
    }
}

/// lambda_1 lanes through the SIMD batches (state batched, each tangent step the scalar
/// one) equal the scalar lane stepper carrying the tangent: points, statuses, counters
/// and lambda_1 to the bit.
#[test]
fn simd_batches_with_lambda1_equal_the_scalar_tangent_stepper_to_the_bit() {
    for exact in [false, true] {
        lambda1_batches_equal_the_scalar_tangent_stepper(exact, false);
    }
    // Each lane's contact law in the tangent step's partials too.
    lambda1_batches_equal_the_scalar_tangent_stepper(false, true);
}

/// The lambda_1 comparison, with RK4 throughout or the exact free-flight step (whose
/// tangent step is its own transition), on the article's machine or with the machine
/// variants among the lanes (`machine`).
fn lambda1_batches_equal_the_scalar_tangent_stepper(exact: bool, machine: bool) {
    use jeffcott_core::integrate::lane::{
        LAMBDA1_START, Tangent, advance_period_tangent, renormalise,
    };
    use jeffcott_core::model::STATE_DIM;
    let mut s = spec(Precision::F64, if machine { 40 } else { 21 });
    s.stepper.exact_free_flight = exact;
    if machine {
        with_machine_variants(&mut s);
    }
    s.lanes[4].x0[X_R] = f64::NAN;
    s.lanes[6].x0[VX_R] = 1e6;
    let r = cpu::run(&s, true, Control::none()).unwrap();
    let l1 = r.lambda1.as_ref().expect("lambda1");
    for (i, &got_l1) in l1.iter().enumerate() {
        let lc = s.lane_consts::<f64>(i);
        let mut lane = s.initial_lane::<f64>(i);
        let mut tan = Tangent::<f64, 1>::new([[LAMBDA1_START; STATE_DIM]]);
        let (mut bits, mut norms) = (Vec::new(), Vec::new());
        for p in 0..s.transient + s.recorded {
            if p < s.transient && lane.status.is_frozen() {
                continue;
            }
            advance_period_tangent(&lc, &mut lane, &mut tan);
            let norm = if lane.status.is_frozen() {
                1.0
            } else {
                renormalise(&mut tan.v[0])
            };
            if p >= s.transient {
                let frozen = lane.status.is_frozen();
                bits.extend(
                    lane.x
                        .iter()
                        .map(|v| if frozen { f64::NAN } else { *v }.to_bits()),
                );
                norms.push(norm);
            }
        }
        let got: Vec<u64> = r.lane_points(i).iter().map(|v| v.to_bits()).collect();
        assert_eq!(got, bits, "exact {exact} lane {i} points");
        assert_eq!(r.status[i], lane.status, "lane {i} status");
        assert_eq!(r.counters[i], lane.counters, "lane {i} counters");
        let want = if lane.status.is_frozen() {
            f64::NAN
        } else {
            jeffcott_core::lyapunov::lambda1_from_norms(&norms, s.lanes[i].omega)
        };
        assert_eq!(got_l1.to_bits(), want.to_bits(), "lane {i} lambda_1");
    }
    assert!(l1.iter().filter(|v| v.is_finite()).count() >= 18);
}

/// Groups of batches (`batch::group_macro_step_tangent`): lanes still in their macro
/// step after a first pass are packed across the group's batches into full batches, so
/// a lane shares SIMD passes with lanes of other batches. 263 lanes (32 batches and 7
/// single lanes) in one thread make groups of 4 batches, in 3 threads of 1: both equal
/// the scalar lane stepper to the bit, with and without contact refinement, and the
/// lambda_1 lanes agree between the two groupings to the bit.
#[test]
fn grouped_batches_packing_lanes_across_batches_equal_the_scalar_stepper_to_the_bit() {
    let pool = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    };
    for (precision, refine) in [
        (Precision::F64, None),
        (Precision::F32, None),
        (Precision::F64, Some(8)),
    ] {
        let mut s = spec(precision, 263);
        if let Some(r) = refine {
            s.stepper.contact_substeps = r;
        }
        s.lanes[70].x0[X_R] = f64::NAN;
        let reference = match precision {
            Precision::F64 => scalar_reference::<f64>(&s),
            Precision::F32 => scalar_reference::<f32>(&s),
        };
        for threads in [1, 3] {
            let r = pool(threads).install(|| cpu::run(&s, false, Control::none()).unwrap());
            for (i, (bits, status, counters)) in reference.iter().enumerate() {
                let got: Vec<u64> = r.lane_points(i).iter().map(|v| v.to_bits()).collect();
                let what = format!("{precision:?} R {refine:?} {threads} threads lane {i}");
                assert_eq!(&got, bits, "{what} points");
                assert_eq!(r.status[i], *status, "{what} status");
                assert_eq!(r.counters[i], *counters, "{what} counters");
            }
            let contact: u64 = r.counters.iter().map(|c| c.contact_steps).sum();
            assert!(contact > 10_000, "the lanes must rub: {contact}");
        }
    }
    let s = spec(Precision::F64, 263);
    let a = pool(1).install(|| cpu::run(&s, true, Control::none()).unwrap());
    let b = pool(3).install(|| cpu::run(&s, true, Control::none()).unwrap());
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a.poincare), bits(&b.poincare));
    assert_eq!(
        bits(a.lambda1.as_ref().unwrap()),
        bits(b.lambda1.as_ref().unwrap())
    );
}

/// The forcing table holds, for every macro step and every fraction
/// j/(2R), exactly the bits of the polynomial `forcing::phasor_turns` (what the GPU
/// kernel's `forcing_phasor` evaluates), in both precisions and for every R and phase,
/// for the batch's lookup and the scalar one (`lane::forcing_phasor`, through the table
/// every lane's constants share); it answers nothing else (a fraction off its grid, a
/// step past N), serves only lanes of its own N, phase and R, and is not built for R
/// not a power of two or beyond its size cap.
#[test]
fn the_forcing_table_holds_the_polynomial_phasors_bit_for_bit_and_nothing_else() {
    fn check<R: jeffcott_core::real::Real>(precision: Precision) {
        use jeffcott_core::integrate::batch::{BATCH, ForcingTable};
        use jeffcott_core::integrate::forcing::phasor_turns;
        use jeffcott_core::integrate::lane::forcing_phasor;
        let bits = |v: R| v.to_f64().to_bits();
        for r in [1u32, 2, 8] {
            for phi0 in [0.0, 0.7, -2.5] {
                let mut s = spec(precision, 3);
                s.stepper.contact_substeps = r;
                s.param_sets[0].phi0 = phi0;
                let lc = s.lane_consts::<R>(0);
                let table = ForcingTable::for_lane(&lc).expect("a table for R a power of two");
                // Every lane's constants share one table of the same values.
                let shared = lc.forcing.expect("the shared table");
                assert!(std::ptr::eq(shared, s.lane_consts::<R>(2).forcing.unwrap()));
                let two_r = 2 * r;
                for k in 0..lc.n {
                    // Each lane of the batch at another fraction of the grid.
                    for j0 in 0..=two_r {
                        let sigma: [R; BATCH] = std::array::from_fn(|l| {
                            R::lit(((j0 as usize + l) % (two_r as usize + 1)) as f64 / two_r as f64)
                        });
                        let (c, sn) = table.lookup(k, &sigma).expect("on the grid");
                        for l in 0..BATCH {
                            let arg = (R::lit(k as f64) + sigma[l]) * lc.inv_n - lc.phase0;
                            let (pc, ps) = phasor_turns(arg);
                            let want = (bits(pc), bits(ps));
                            let case = format!(
                                "{precision:?} R {r} phi0 {phi0} k {k} sigma {}",
                                sigma[l].to_f64()
                            );
                            assert_eq!((bits(c[l]), bits(sn[l])), want, "batch: {case}");
                            let (gc, gs) = shared.get(k, sigma[l]).expect("on the grid");
                            assert_eq!((bits(gc), bits(gs)), want, "scalar: {case}");
                            let (fc, fs) = forcing_phasor(&lc, k, sigma[l]);
                            assert_eq!((bits(fc), bits(fs)), want, "forcing_phasor: {case}");
                        }
                    }
                }
                // Off the grid, past the period: no answer.
                let mut off = [R::lit(0.5); BATCH];
                off[3] = R::lit(0.5 / two_r as f64 + 0.5);
                assert!(
                    table.lookup(0, &off).is_none(),
                    "R {r}: a fraction off the grid"
                );
                assert!(shared.get(0, off[3]).is_none());
                // Lanes at different fractions of the grid with one lane outside it (a
                // negative fraction, one past the macro step, NaN): no answer either.
                for bad in [-0.5 / two_r as f64, 1.0 + 1.0 / two_r as f64, f64::NAN] {
                    let mut mixed: [R; BATCH] = std::array::from_fn(|l| {
                        R::lit((l % (two_r as usize + 1)) as f64 / two_r as f64)
                    });
                    mixed[BATCH - 1] = R::lit(bad);
                    assert!(
                        table.lookup(0, &mixed).is_none(),
                        "R {r}: fraction {bad} beside fractions of the grid"
                    );
                }
                assert!(table.lookup(lc.n, &[R::lit(0.0); BATCH]).is_none());
                assert!(shared.get(lc.n, R::lit(0.0)).is_none());
                // Off the grid the scalar path evaluates the polynomial.
                let arg = off[3] * lc.inv_n - lc.phase0;
                let (pc, ps) = phasor_turns(arg);
                let (fc, fs) = forcing_phasor(&lc, 0, off[3]);
                assert_eq!((bits(fc), bits(fs)), (bits(pc), bits(ps)));
                // Lanes of the same N, phase and R at any speed are served; another
                // phase, N or R is not.
                assert!(
                    table.serves(&s.lane_consts::<R>(2)),
                    "another speed, same phase"
                );
                let mut other = s.clone();
                other.param_sets[0].phi0 = phi0 + 0.1;
                assert!(!table.serves(&other.lane_consts::<R>(0)));
                other = s.clone();
                other.stepper.steps_per_period += 1;
                assert!(!table.serves(&other.lane_consts::<R>(0)));
                other = s.clone();
                other.stepper.contact_substeps = 2 * r;
                assert!(!table.serves(&other.lane_consts::<R>(0)));
            }
        }
        // Not built where it cannot hold the bits or would be too large.
        let mut s = spec(precision, 1);
        let mut lc = s.lane_consts::<R>(0);
        lc.inv_r = R::lit(1.0 / 3.0);
        assert!(ForcingTable::for_lane(&lc).is_none(), "R = 3");
        s.stepper.steps_per_period = (ForcingTable::<R>::MAX_ENTRIES / 5 + 1) as u32;
        assert!(
            ForcingTable::for_lane(&s.lane_consts::<R>(0)).is_none(),
            "too large"
        );
    }
    check::<f64>(Precision::F64);
    check::<f32>(Precision::F32);
}
