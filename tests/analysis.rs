//! Attractor classification and the attractor catalogue: synthetic Poincare sequences
//! with known answers, and real runs at the article's W = 131.7 (period-1) and 132.2
//! (period-2).

use jeffcott_analysis::backend::run;
use jeffcott_analysis::catalogue::{Catalogue, CatalogueConfig, catalogue, catalogue_result};
use jeffcott_analysis::classify::Class;
use jeffcott_core::ensemble::{Backend, EnsembleSpec, LaneSpec, Precision};
use jeffcott_core::model::{Params, STATE_DIM, State, VX_R, X_R};

mod common;

const W: f64 = 133.0;

/// A deterministic hash in [-0.5, 0.5).
fn unit(i: usize, salt: u64) -> f64 {
    let mut z = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ salt.wrapping_mul(0xD1B5);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64 - 0.5
}

/// A period-n cycle of diameter ~2 mm around `centre`, started at phase `shift`, with
/// uniform noise of amplitude `noise` [m].
fn cycle(n: usize, len: usize, shift: usize, centre: f64, noise: f64, salt: u64) -> Vec<State> {
    (0..len)
        .map(|i| {
            let k = ((i + shift) % n) as f64;
            let a = std::f64::consts::TAU * k / n as f64 + 0.3;
            let mut s = [0.0; STATE_DIM];
            s[0] = centre + 1e-3 * a.cos() + noise * unit(i, salt);
            s[1] = W * 1e-3 * a.sin() + W * noise * unit(i, salt + 1);
            s[2] = 5e-4 * (2.0 * a).cos();
            s[4] = 2e-4 * k / n as f64;
            s
        })
        .collect()
}

fn flat(lanes: &[Vec<State>]) -> (Vec<f64>, usize) {
    let rec = lanes[0].len();
    (lanes.iter().flatten().flatten().copied().collect(), rec)
}

/// A quasiperiodic circle (golden rotation number) starting at angle index `start`.
fn circle(len: usize, start: usize) -> Vec<State> {
    let rho = (5f64.sqrt() - 1.0) / 2.0;
    (start..start + len)
        .map(|i| {
            let a = std::f64::consts::TAU * rho * i as f64;
            let mut s = [0.0; STATE_DIM];
            s[0] = 1e-3 * a.cos();
            s[2] = 1e-3 * a.sin();
            s
        })
        .collect()
}

/// The default catalogue at [`W`] of lanes none of which diverged, with their lambda_1.
fn catalogue_with_lambda1(pts: &[f64], rec: usize, lam: &[f64]) -> Catalogue {
    let frozen = vec![false; lam.len()];
    catalogue(W, pts, rec, &frozen, Some(lam), &CatalogueConfig::default())
}

#[test]
fn period_n_with_noise_below_tolerance_is_period_n_and_phase_shifts_share_an_id() {
    let cfg = CatalogueConfig::default();
    for n in [1, 2, 3, 5, 7, 12, 32] {
        let lanes: Vec<Vec<State>> = (0..n.min(4))
            .map(|s| cycle(n, 64.max(2 * n), s, 0.0, 2e-10, s as u64))
            .collect();
        let (pts, rec) = flat(&lanes);
        let c = catalogue(W, &pts, rec, &vec![false; lanes.len()], None, &cfg);
        assert_eq!(c.attractors.len(), 1, "n = {n}: {:?}", c.attractors);
        assert_eq!(c.attractors[0].kind(), Class::Periodic(n), "n = {n}");
        assert_eq!(c.attractors[0].points.len(), n);
        assert!(c.labels.iter().all(|&l| l == 0), "n = {n}");
        assert_eq!(c.attractors[0].basin_fraction, 1.0);
    }
}

#[test]
fn distinct_cycles_of_equal_period_get_distinct_ids() {
    let lanes = vec![
        cycle(2, 64, 0, 0.0, 0.0, 1),
        cycle(2, 64, 1, 3e-3, 0.0, 2),
        cycle(2, 64, 1, 0.0, 0.0, 3),
        cycle(3, 64, 0, 0.0, 0.0, 4),
    ];
    let (pts, rec) = flat(&lanes);
    let c = catalogue(W, &pts, rec, &[false; 4], None, &CatalogueConfig::default());
    assert_eq!(c.labels, vec![0, 1, 0, 2]);
    assert_eq!(c.attractors[0].basin_fraction, 0.5);
    assert_eq!(c.attractors[2].kind(), Class::Periodic(3));
}

#[test]
fn a_quasiperiodic_circle_is_aperiodic_and_one_attractor_whatever_the_phase() {
    let lanes = vec![circle(200, 0), circle(200, 37), circle(200, 1001)];
    let (pts, rec) = flat(&lanes);
    let c = catalogue(W, &pts, rec, &[false; 3], None, &CatalogueConfig::default());
    assert_eq!(c.attractors.len(), 1, "{:?}", c.attractors);
    assert_eq!(c.attractors[0].kind(), Class::Aperiodic);
    // The Lyapunov hook: lambda1 ~ 0 is quasiperiodic, > 0 chaotic, < 0 stays aperiodic.
    let lam = [0.01, -0.05, 0.0];
    let c = catalogue_with_lambda1(&pts, rec, &lam);
    assert_eq!(c.attractors[0].kind(), Class::Quasiperiodic);
    assert_eq!(c.labels, vec![0, 0, 0]);
    let lam = [3.0, 3.0, -2.0];
    let c = catalogue_with_lambda1(&pts, rec, &lam);
    // One cloud is one attractor whatever each lane's short-time lambda1; its class
    // follows the mean (4/3 1/s: chaotic).
    assert_eq!(c.attractors.len(), 1, "{:?}", c.attractors);
    assert_eq!(c.attractors[0].kind(), Class::Chaotic);
    assert!((c.attractors[0].lambda1.unwrap() - 4.0 / 3.0).abs() < 1e-12);
    assert_eq!(c.attractors[0].lambda1_range, Some((-2.0, 3.0)));
    assert_eq!(c.labels, vec![0, 0, 0]);
    let lam = [-3.0, -3.0, -2.0];
    let c = catalogue_with_lambda1(&pts, rec, &lam);
    assert_eq!(c.attractors[0].kind(), Class::Aperiodic);
}

#[test]
fn random_points_are_aperiodic_and_flagged_lanes_are_diverged() {
    let random: Vec<State> = (0..128)
        .map(|i| std::array::from_fn(|d| 1e-3 * unit(i, d as u64 + 7)))
        .collect();
    let lanes = vec![random, cycle(2, 128, 0, 0.0, 0.0, 1)];
    let (pts, rec) = flat(&lanes);
    let c = catalogue(
        W,
        &pts,
        rec,
        &[false, true],
        None,
        &CatalogueConfig::default(),
    );
    assert_eq!(c.labels, vec![0, -1]);
    assert_eq!(c.attractors[0].kind(), Class::Aperiodic);
    assert_eq!((c.lanes, c.diverged), (2, 1));
    assert_eq!(c.attractors[0].basin_fraction, 0.5);
}

#[test]
fn labels_are_stable_when_tolerances_change_tenfold_either_way() {
    let mut lanes = Vec::new();
    for n in [1, 2, 5, 9] {
        for s in 0..3 {
            lanes.push(cycle(n, 96, s, n as f64 * 1e-3, 5e-10, (n * 10 + s) as u64));
        }
    }
    lanes.push(circle(96, 0));
    lanes.push(circle(96, 500));
    let (pts, rec) = flat(&lanes);
    let frozen = vec![false; lanes.len()];
    let base = catalogue(W, &pts, rec, &frozen, None, &CatalogueConfig::default());
    assert_eq!(base.attractors.len(), 5);
    for f in [0.1, 10.0] {
        let c = catalogue(
            W,
            &pts,
            rec,
            &frozen,
            None,
            &CatalogueConfig::default().scaled(f),
        );
        assert_eq!(c.labels, base.labels, "tolerances x {f}");
        let classes: Vec<Class> = c.attractors.iter().map(|a| a.kind()).collect();
        let base_classes: Vec<Class> = base.attractors.iter().map(|a| a.kind()).collect();
        assert_eq!(classes, base_classes, "tolerances x {f}");
    }
}

/// Lanes near the static equilibrium at speed `omega` (f64, CPU).
fn real_run(omega: f64) -> jeffcott_core::ensemble::EnsembleResult {
    let p = Params::default();
    let lanes = (0..4)
        .map(|i| {
            let mut x0 = p.static_equilibrium();
            x0[X_R] += 2e-4 * i as f64;
            x0[VX_R] -= 0.01 * i as f64;
            LaneSpec {
                omega,
                x0,
                param_set: 0,
            }
        })
        .collect();
    let spec = EnsembleSpec {
        param_sets: vec![p],
        lanes,
        transient: 800,
        recorded: 64,
        stepper: Default::default(),
        precision: Precision::F64,
    };
    run(
        &spec,
        Backend::Cpu,
        false,
        jeffcott_core::control::Control::none(),
    )
    .unwrap()
    .0
}

#[test]
fn real_runs_are_one_period_1_attractor_at_131_7_and_one_period_2_attractor_at_132_2() {
    for (omega, n) in [(131.7, 1), (132.2, 2)] {
        let res = real_run(omega);
        for f in [0.1, 1.0, 10.0] {
            let cfg = CatalogueConfig::default().scaled(f);
            let c = catalogue_result(omega, &res, None, &cfg);
            assert_eq!(
                c.attractors.len(),
                1,
                "W = {omega}, x{f}: {:?}",
                c.attractors
            );
            assert_eq!(c.attractors[0].kind(), Class::Periodic(n), "W = {omega}");
            assert_eq!(c.labels, vec![0; 4]);
        }
    }
}

fn study(omega: &str, ics: u32) -> jeffcott_analysis::bifurcation::BifurcationSpec {
    use jeffcott_analysis::bifurcation::{BifurcationSpec, Sweep};
    BifurcationSpec {
        lane: common::cpu_f64_lane(Params::default(), false),
        omegas: jeffcott_core::ensemble::parse_range("omega", omega).unwrap(),
        sweep: Some(Sweep::Both),
        transient_first: 800,
        transient: 200,
        ics,
        brute_transient: 300,
        periods: 24,
        seed: 1,
        max_seeds: 6,
    }
}

#[test]
fn quasistatic_up_and_down_sweeps_follow_the_same_branch_where_monostable() {
    use jeffcott_analysis::bifurcation::bifurcation;
    let spec = study("131.6:131.8:5", 3);
    let res = bifurcation(&spec, jeffcott_core::control::Control::none()).unwrap();
    assert_eq!((res.up.len(), res.down.len()), (5, 5));
    for (wi, (u, d)) in res.up.iter().zip(&res.down).enumerate() {
        assert_eq!(u.omega, d.omega);
        assert_eq!(u.class.class, Class::Periodic(1), "W = {}", u.omega);
        assert_eq!(d.class.class, Class::Periodic(1), "W = {}", d.omega);
        let cat = &res.brute[wi].catalogue;
        assert_eq!(cat.attractors.len(), 1, "W = {}: monostable", u.omega);
        assert_eq!(cat.identify(&u.class), Some(0));
        assert_eq!(cat.identify(&d.class), Some(0));
        for (a, b) in u.points.iter().zip(&d.points) {
            for i in 0..STATE_DIM {
                assert!(
                    (a[i] - b[i]).abs() < 1e-6,
                    "W = {}: up and down agree",
                    u.omega
                );
            }
        }
    }
}

#[test]
fn brute_force_contains_every_attractor_the_quasistatic_sweeps_found() {
    use jeffcott_analysis::bifurcation::bifurcation;
    // Away from bifurcation points, where 300 periods settle every lane (next to one,
    // e.g. the period-4/period-5 boundary near 132.9, slow convergence leaves the
    // classification to the transient length).
    let spec = study("132.3:132.5:3", 4);
    let res = bifurcation(&spec, jeffcott_core::control::Control::none()).unwrap();
    for sw in [&res.up, &res.down] {
        for (wi, p) in sw.iter().enumerate() {
            if p.status.is_frozen() {
                continue;
            }
            assert!(
                res.brute[wi].catalogue.identify(&p.class).is_some(),
                "W = {}: sweep attractor {} missing from brute force {:?}",
                p.omega,
                p.class.class.label(),
                res.brute[wi]
                    .catalogue
                    .attractors
                    .iter()
                    .map(|a| a.name())
                    .collect::<Vec<_>>()
            );
        }
    }
}

#[test]
fn streaming_lanes_in_chunks_gives_the_labels_of_one_block() {
    use jeffcott_analysis::catalogue::CatalogueBuilder;
    let mut lanes = Vec::new();
    for k in 0..12 {
        lanes.push(cycle(
            1 + k % 4,
            48,
            k,
            (k % 3) as f64 * 2e-3,
            1e-10,
            k as u64,
        ));
    }
    lanes.push(circle(48, 0));
    lanes.push(circle(48, 77));
    let (pts, rec) = flat(&lanes);
    let frozen = vec![false; lanes.len()];
    let cfg = CatalogueConfig::default();
    let whole = catalogue(W, &pts, rec, &frozen, None, &cfg);
    let mut b = CatalogueBuilder::new(W, cfg);
    let mut labels = Vec::new();
    let lane = rec * STATE_DIM;
    for c in (0..lanes.len()).step_by(5) {
        let end = (c + 5).min(lanes.len());
        labels.extend(b.add_block(&pts[c * lane..end * lane], rec, &frozen[c..end], None));
    }
    let streamed = b.finish(labels);
    assert_eq!(streamed.labels, whole.labels);
    assert_eq!(streamed.attractors.len(), whole.attractors.len());
    for (a, w) in streamed.attractors.iter().zip(&whole.attractors) {
        assert_eq!((a.kind(), a.lanes), (w.kind(), w.lanes));
    }
}

#[test]
fn lambda1_row_is_negative_on_the_period_1_branch_and_positive_at_140() {
    use jeffcott_analysis::bifurcation::bifurcation;
    let mut spec = study("131.7:131.7:1", 2);
    // 131.7 (period-1), then a jump to 140 (chaotic, lambda_1 ~ 7.5 1/s): sweeps up and
    // down and two brute-force lanes per W, all with lambda_1.
    spec.omegas = vec![131.7, 140.0];
    spec.lane.lyapunov = true;
    spec.transient_first = 600;
    spec.transient = 300;
    spec.brute_transient = 300;
    spec.periods = 64;
    spec.max_seeds = 2;
    let r = bifurcation(&spec, jeffcott_core::control::Control::none()).unwrap();
    for sw in [&r.up, &r.down] {
        assert_eq!(sw[0].class.class, Class::Periodic(1));
        assert!(sw[0].lambda1 < -0.5, "131.7: {}", sw[0].lambda1);
        assert_eq!(
            sw[1].class.class,
            Class::Chaotic,
            "140: {:?}",
            sw[1].class.class
        );
        assert!(sw[1].lambda1 > 2.0, "140: {}", sw[1].lambda1);
    }
    let (b0, b1) = (&r.brute[0], &r.brute[1]);
    assert!(b0.lambda1.as_ref().unwrap().iter().all(|&l| l < 0.0));
    assert!(b1.lambda1.as_ref().unwrap().iter().all(|&l| l > 2.0));
    assert_eq!(b1.catalogue.attractors[0].kind(), Class::Chaotic);
    assert!(b1.catalogue.attractors[0].lambda1.unwrap() > 2.0);
}

#[test]
fn basin_lambda1_map_is_finite_and_the_catalogue_says_chaotic_at_140() {
    use jeffcott_analysis::basin::{Axis, BasinSpec, basin};
    let p = Params::default();
    let spec = BasinSpec {
        base: p.static_equilibrium(),
        lane: common::cpu_f64_lane(p, true),
        omega: 140.0,
        x: Axis {
            coord: X_R,
            lo: -0.002,
            hi: 0.002,
            n: 3,
        },
        y: Axis {
            coord: VX_R,
            lo: -0.3,
            hi: 0.3,
            n: 2,
        },
        transient: 300,
        periods: 64,
        lanes_per_unit: Some(4),
    };
    let r = basin(&spec, jeffcott_core::control::Control::none()).unwrap();
    let l1 = r.lambda1.as_ref().unwrap();
    assert_eq!(l1.len(), 6);
    assert!(l1.iter().all(|l| l.is_finite() && *l > 2.0), "{l1:?}");
    assert!(!r.catalogue.attractors.is_empty());
    for a in &r.catalogue.attractors {
        assert_eq!(a.kind(), Class::Chaotic, "{}", a.name());
        let (lo, hi) = a.lambda1_range.unwrap();
        assert!(lo <= a.lambda1.unwrap() && a.lambda1.unwrap() <= hi);
    }
    assert!(r.labels.iter().all(|&l| l >= 0));
}

/// Finite-time lambda_1 estimates of lanes on one quasiperiodic attractor scatter on
/// both sides of the threshold (as over 64 periods at W = 135); classing lane by lane
/// would cut the attractor into "chaotic" and "quasiperiodic" pieces.
#[test]
fn scattered_lambda1_estimates_on_one_cloud_give_one_quasiperiodic_attractor() {
    let lanes: Vec<Vec<State>> = (0..6).map(|k| circle(200, 13 * k)).collect();
    let (pts, rec) = flat(&lanes);
    let lam = [0.25, -0.3, 0.1, 0.35, -0.22, -0.05];
    let c = catalogue_with_lambda1(&pts, rec, &lam);
    assert_eq!(c.attractors.len(), 1, "{:?}", c.attractors);
    assert_eq!(c.attractors[0].kind(), Class::Quasiperiodic);
    assert_eq!(c.labels, vec![0; 6]);
    // A catalogued quasiperiodic attractor still identifies a new lane on it.
    let l = jeffcott_analysis::catalogue::classify_lane(
        &circle(200, 77),
        W,
        false,
        None,
        &CatalogueConfig::default(),
    );
    assert_eq!(c.identify(&l), Some(0));
}

/// A period-1 lane's point `dx` [m] along x_r from (x_r, vx_r) = (3 mm, 0.2 m/s).
fn fixed_point(dx: f64) -> State {
    let mut s = [0.0; STATE_DIM];
    s[X_R] = 3e-3 + dx;
    s[VX_R] = 0.2;
    s
}

#[test]
fn early_exit_never_recognises_a_cycle_within_four_identity_tolerances_of_another_attractor() {
    use jeffcott_analysis::catalogue::CatalogueBuilder;
    use jeffcott_core::ensemble::early::{Recognise, Track};
    // Three period-1 lanes: two fixed points 2 um apart (the catalogue's identity
    // tolerance is 1 um, so they are distinct entries, but a point near one may be as
    // near the other), and one 1 mm away.
    let at = fixed_point;
    let lanes: Vec<Vec<State>> = [0.0, 2e-6, 1e-3].iter().map(|&d| vec![at(d); 32]).collect();
    let (pts, rec) = flat(&lanes);
    let cfg = CatalogueConfig::default();
    assert!(cfg.match_abs < 2e-6 && 4.0 * cfg.match_abs > 2e-6);
    let mut b = CatalogueBuilder::new(W, cfg);
    let labels = b.add_block(&pts, rec, &[false; 3], None);
    assert_eq!(labels, vec![0, 1, 2], "three distinct entries");
    let r = b.recogniser(4);
    let recognised = |dx: f64| {
        let mut t = Track::default();
        (0..64).find_map(|_| r.observe(0, &mut t, &at(dx)))
    };
    // On either close point: never (the lane runs whole and is classified from its
    // record); on the lone one: recognised.
    assert_eq!(recognised(0.0), None);
    assert_eq!(recognised(2e-6), None);
    assert_eq!(recognised(1e-3), Some(2));
    // The basin study names that pair (and only it) for the user to check.
    let whole = catalogue(W, &pts, rec, &[false; 3], None, &cfg);
    let close: Vec<(u32, u32)> = whole.close_pairs().iter().map(|p| (p.0, p.1)).collect();
    assert_eq!(close, vec![(0, 1)]);
    assert!((whole.close_pairs()[0].2 - 2e-6).abs() < 1e-12);
}

#[test]
fn early_exit_never_recognises_a_period_2n_cycle_within_four_identity_tolerances_of_its_half_shift()
{
    use jeffcott_analysis::catalogue::CatalogueBuilder;
    use jeffcott_core::ensemble::early::{Recognise, Track};
    // Two period-2 lanes: one alternating between points 2 um apart, within four of the
    // catalogue's identity tolerances (1 um) of being period-1 (a period-1 cycle whose
    // lanes still converge near a period doubling, as the brute force's "period-18" at
    // 133.08 rad/s is the period-9 cycle), and one alternating 1 mm apart, far away.
    let at = fixed_point;
    let two = |a: f64, b: f64| -> Vec<State> {
        (0..32)
            .map(|k| at(if k % 2 == 0 { a } else { b }))
            .collect()
    };
    let lanes = vec![two(0.0, 2e-6), two(1e-2, 1.1e-2)];
    let (pts, rec) = flat(&lanes);
    let cfg = CatalogueConfig::default();
    let mut b = CatalogueBuilder::new(W, cfg);
    assert_eq!(b.add_block(&pts, rec, &[false; 2], None), vec![0, 1]);
    let classes: Vec<String> = b.attractors().iter().map(|a| a.class.clone()).collect();
    assert_eq!(classes, ["period-2", "period-2"]);
    for r in [b.recogniser(4), b.recogniser_to_record(4)] {
        let recognised = |a: f64, c: f64| {
            let mut t = Track::default();
            (0..64).find_map(|k| r.observe(0, &mut t, &at(if k % 2 == 0 { a } else { c })))
        };
        // The near-period-1 one: never (its lanes run whole); the true period-2: yes.
        assert_eq!(recognised(0.0, 2e-6), None);
        assert_eq!(recognised(1e-2, 1.1e-2), Some(1));
    }
}

#[test]
fn in_f32_early_exit_recognises_two_fixed_points_28_um_apart_but_not_2_um_apart() {
    use jeffcott_analysis::catalogue::CatalogueBuilder;
    use jeffcott_core::ensemble::Precision;
    use jeffcott_core::ensemble::early::{Recognise, Track};
    // f32's identity floor is 10 um (rounding noise): 28 um is under four of them, yet
    // two attractors that far apart are distinct (the period-5 and period-4 cycles at
    // 133 rad/s); 2 um apart they are taken for one, as in f64.
    let at = fixed_point;
    let lanes: Vec<Vec<State>> = [0.0, 28e-6, 1e-3, 1e-3 + 2e-6]
        .iter()
        .map(|&d| vec![at(d); 32])
        .collect();
    let (pts, rec) = flat(&lanes);
    let cfg = CatalogueConfig::for_precision(Precision::F32);
    assert!(4.0 * cfg.match_abs > 28e-6 && cfg.match_abs < 28e-6);
    let mut b = CatalogueBuilder::new(W, cfg);
    let labels = b.add_block(&pts, rec, &[false; 4], None);
    assert_eq!(
        labels,
        vec![0, 1, 2, 2],
        "within 10 um of each other: one entry"
    );
    let r = b.recogniser(4);
    let recognised = |dx: f64| {
        let mut t = Track::default();
        (0..64).find_map(|_| r.observe(0, &mut t, &at(dx)))
    };
    assert_eq!(recognised(0.0), Some(0));
    assert_eq!(recognised(28e-6), Some(1));
    // Within the f32 identity floor (10 um, under the cap of 0.45 of the separation,
    // 12.6 um) of a point, not beyond: no point is near both.
    assert_eq!(recognised(9e-6), Some(0));
    assert_eq!(recognised(11e-6), None);
    assert_eq!(recognised(14e-6), None);
    assert_eq!(recognised(19e-6), Some(1));
    // 21 um apart the cap (0.45 of it, 9.45 um) falls below the f32 floor and binds.
    let lanes: Vec<Vec<State>> = [0.0, 21e-6].iter().map(|&d| vec![at(d); 32]).collect();
    let (pts, rec) = flat(&lanes);
    let mut b = CatalogueBuilder::new(W, cfg);
    assert_eq!(b.add_block(&pts, rec, &[false; 2], None), vec![0, 1]);
    let r = b.recogniser(4);
    let recognised = |dx: f64| {
        let mut t = Track::default();
        (0..64).find_map(|_| r.observe(0, &mut t, &at(dx)))
    };
    assert_eq!(recognised(9e-6), Some(0));
    assert_eq!(recognised(9.8e-6), None);
    assert_eq!(recognised(12e-6), Some(1));
    // Two entries 2 um apart at the f64 floor's resolution stay unrecognised and named.
    let lanes: Vec<Vec<State>> = [0.0, 2e-6, 28e-6]
        .iter()
        .map(|&d| vec![at(d); 32])
        .collect();
    let (pts, rec) = flat(&lanes);
    let cfg64 = CatalogueConfig::default();
    let whole = catalogue(W, &pts, rec, &[false; 3], None, &cfg64);
    let close: Vec<(u32, u32)> = whole.close_pairs().iter().map(|p| (p.0, p.1)).collect();
    assert_eq!(close, vec![(0, 1)]);
    let lanes: Vec<Vec<State>> = [0.0, 28e-6].iter().map(|&d| vec![at(d); 32]).collect();
    let (pts, rec) = flat(&lanes);
    let whole = catalogue(W, &pts, rec, &[false; 2], None, &cfg);
    assert_eq!(whole.attractors.len(), 2);
    assert!(whole.close_pairs().is_empty(), "{:?}", whole.close_pairs());
}

/// An aperiodic lane: `len` points on the arc of angles [from, from + span] degrees of a
/// circle of radius 1 mm in (x_r, y_r), spread by a golden rotation.
fn arc(from: f64, span: f64, len: usize) -> Vec<State> {
    let rho = (5f64.sqrt() - 1.0) / 2.0;
    (0..len)
        .map(|i| {
            let a = (from + span * (i as f64 * rho).fract()).to_radians();
            let mut s = [0.0; STATE_DIM];
            s[X_R] = 1e-3 * a.cos();
            s[2] = 1e-3 * a.sin();
            s
        })
        .collect()
}

#[test]
fn early_exits_catalogue_is_the_one_a_pass_in_lane_order_builds_whatever_the_rounds_order() {
    use jeffcott_analysis::catalogue::{CatalogueBuilder, LaneEnd, classify_lane};
    let cfg = CatalogueConfig::default();
    let class = |pts: &[State], l1: f64| classify_lane(pts, W, false, Some(l1), &cfg);
    // Lanes 0-2: three arcs of one cloud whose entries depend on the order they join
    // (0 and 1 overlap by half, 2 covers three quarters of each and joins whatever
    // came first; an entry's cloud grows as lanes join it). Lane 3 was recognised on a
    // period-2 cycle that lane 4 ran whole onto, lane 5 is another period-2 cycle.
    let lanes = [
        arc(0.0, 180.0, 96),
        arc(90.0, 180.0, 96),
        arc(45.0, 180.0, 96),
        cycle(2, 32, 0, 4e-3, 0.0, 3),
        cycle(2, 32, 0, 4e-3, 1e-10, 4),
        cycle(2, 32, 0, -4e-3, 1e-10, 5),
    ];
    let l1 = [0.5, 0.6, 0.7, -1.0, -1.5, -2.0];
    // A pass in lane order, lane 3 given its cycle.
    let mut pass = CatalogueBuilder::new(W, cfg);
    let plain: Vec<i32> = (0..6)
        .map(|i| pass.add_at(class(&lanes[i], l1[i]), i as u64))
        .collect();
    assert_eq!(
        plain,
        vec![0, 1, 0, 2, 2, 3],
        "the arcs form two entries in lane order"
    );
    // Early exit's rounds: lanes 2 and 4 first (they run whole), then lane 3, recognised
    // on the rounds' entry of lane 4's cycle, then the rest.
    let mut rounds = CatalogueBuilder::new(W, cfg);
    let mut labels = [0i32; 6];
    let mut ends: Vec<Option<LaneEnd>> = vec![None; 6];
    for i in [2, 4, 3, 0, 1, 5] {
        if i == 3 {
            labels[i] = rounds.add_recognised(labels[4] as u32);
            ends[i] = Some(LaneEnd::Recognised(labels[4] as u32));
        } else {
            labels[i] = rounds.add_at(class(&lanes[i], l1[i]), i as u64);
            ends[i] = Some(LaneEnd::Whole(class(&lanes[i], l1[i])));
        }
    }
    assert_eq!(
        (labels[0], labels[1], labels[2]),
        (0, 0, 0),
        "in the rounds' order the arcs form one entry"
    );
    let (rebuilt, got) = rounds.rebuilt_in_lane_order(ends.into_iter().flatten().collect());
    assert_eq!(got, plain);
    let (a, b) = (rebuilt.attractors(), pass.attractors());
    assert_eq!(a.len(), b.len());
    for (a, b) in a.iter().zip(&b) {
        assert_eq!(
            (a.kind(), a.lanes, a.first_lane),
            (b.kind(), b.lanes, b.first_lane)
        );
    }
    // The recognised lane brings no lambda_1: the cycle's is lane 4's alone.
    assert_eq!(a[2].lambda1, Some(-1.5));
}
