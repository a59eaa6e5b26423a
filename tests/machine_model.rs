//! The machine variants of docs/model.md 7 (supports whose stiffness and damping differ
//! by direction, a stator whose rest centre is off the bearing axis) against what
//! physics fixes independently of the integrator: the analytic steady state of each
//! uncoupled direction and its resonance peak, the static balance of forces,
//! conservation of energy, the order of convergence through rubs, the article's model
//! recovered to the bit, and the GPU kernel's bits equal to the CPU's.

mod common;

use common::{gpu_f64_device, unit};
use jeffcott_analysis::backend::Engine;
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::{Backend, EnsembleResult, EnsembleSpec, LaneSpec, Precision};
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{
    self, Coeffs, Params, STATE_DIM, State, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S,
};

/// An anisotropic machine with an offset stator and a gap too wide to close: four
/// uncoupled linear oscillators.
fn open_machine() -> Params {
    Params {
        omega_rx: Some(120.0),
        omega_ry: Some(165.0),
        xi_rx: Some(0.03),
        xi_ry: Some(0.015),
        omega_sx: Some(480.0),
        xi_sy: Some(0.08),
        o_x: 0.0021,
        o_y: -0.0013,
        delta: 0.5,
        ..Params::default()
    }
}

fn run(spec: &EnsembleSpec, backend: Backend) -> EnsembleResult {
    spec.validate().expect("a valid spec");
    Engine::new(backend, spec.precision)
        .expect("an engine")
        .run(spec, false, Control::none())
        .expect("a run")
        .0
}

fn spec(params: Vec<Params>, lanes: Vec<LaneSpec>, transient: u32, recorded: u32) -> EnsembleSpec {
    EnsembleSpec {
        lanes,
        param_sets: params,
        transient,
        recorded,
        stepper: StepperConfig::default(),
        precision: Precision::F64,
    }
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn without_contact_each_direction_settles_on_its_own_analytic_steady_state() {
    // Lanes at several unbalance phases phi0 sample the steady orbit at t = kT: about
    // the rest, x_r = A_x cos(-phi0 - lag_x), y_r = A_y sin(-phi0 - lag_y), each
    // direction with its own frequency and damping; the stator rests at its offset
    // centre, sagged by gravity through its own y stiffness.
    let omega = 140.0;
    let phases = [0.0, 0.7, 1.9, 3.3, 4.6];
    let sets: Vec<Params> = phases
        .iter()
        .map(|&phi0| Params {
            phi0,
            ..open_machine()
        })
        .collect();
    let lanes = (0..sets.len())
        .map(|i| LaneSpec {
            omega,
            x0: sets[i].static_equilibrium(),
            param_set: i as u32,
        })
        .collect();
    let r = run(&spec(sets.clone(), lanes, 400, 1), Backend::Cpu);
    for (i, p) in sets.iter().enumerate() {
        let x = &r.poincare[i * STATE_DIM..][..STATE_DIM];
        let ((ax, lag_x), (ay, lag_y)) = model::linear_unbalance_response_xy(p, omega);
        let rest = p.free_rest_state();
        let want_x = ax * (-p.phi0 - lag_x).cos();
        let want_y = rest[Y_R] + ay * (-p.phi0 - lag_y).sin();
        let scale = ax.max(ay);
        assert!(
            (x[X_R] - want_x).abs() < 1e-7 * scale,
            "phi0 {}: x_r {} vs {want_x}",
            p.phi0,
            x[X_R]
        );
        assert!(
            (x[Y_R] - want_y).abs() < 1e-7 * scale,
            "phi0 {}: y_r {} vs {want_y}",
            p.phi0,
            x[Y_R]
        );
        assert!((x[X_S] - p.o_x).abs() < 1e-12, "x_s {}", x[X_S]);
        assert!((x[Y_S] - rest[Y_S]).abs() < 1e-12, "y_s {}", x[Y_S]);
    }
    // The two directions are different oscillators: at 140 rad/s, above the x
    // critical (120) and below the y one (165), the orbit is an ellipse, not a circle.
    let ((ax, _), (ay, _)) = model::linear_unbalance_response_xy(&sets[0], omega);
    assert!(ax > 1.3 * ay, "{ax} {ay}");
    // The cascade marks both critical speeds of the rotor and both of the stator.
    let marks = jeffcott_analysis::rub::natural_frequencies(&sets[0]);
    for (name, w) in [
        ("rotor w_r in x", 120.0),
        ("rotor w_r in y", 165.0),
        ("stator w_s in x", 480.0),
        ("stator w_s in y", 540.0),
    ] {
        assert!(
            marks.iter().any(|(n, v)| n == name && *v == w),
            "{name}: {marks:?}"
        );
    }
}

#[test]
fn without_contact_each_directions_amplitude_peaks_at_its_own_natural_frequency() {
    // A run-up through both rotor criticals of the open machine (120 rad/s in x, 165 in
    // y). Per speed two lanes a quarter turn of unbalance phase apart give the steady
    // ellipse's semi-axes: from x = A cos(-phi0 - lag), A = hypot(x(0), x(pi/2)), and the
    // same for y about its rest. The unbalance response q'' + 2 xi w q' + w^2 q =
    // e W^2 cos(W t) peaks at W = w / sqrt(1 - 2 xi^2), within xi^2 of sqrt(k/m).
    let base = open_machine();
    let speeds: Vec<f64> = (0..=160).map(|i| 100.0 + 0.5 * f64::from(i)).collect();
    let sets: Vec<Params> = [0.0, std::f64::consts::FRAC_PI_2]
        .iter()
        .map(|&phi0| Params {
            phi0,
            ..base.clone()
        })
        .collect();
    let x0 = base.static_equilibrium();
    let lanes = speeds
        .iter()
        .flat_map(|&omega| {
            (0..2).map(move |s| LaneSpec {
                omega,
                x0,
                param_set: s,
            })
        })
        .collect();
    let r = run(&spec(sets, lanes, 600, 1), Backend::Cpu);
    let rest = base.free_rest_state();
    let at = |lane: usize, i: usize| r.poincare[lane * STATE_DIM + i] - rest[i];
    let (mut amp_x, mut amp_y) = (Vec::new(), Vec::new());
    for (k, &omega) in speeds.iter().enumerate() {
        let (ax, ay) = (
            at(2 * k, X_R).hypot(at(2 * k + 1, X_R)),
            at(2 * k, Y_R).hypot(at(2 * k + 1, Y_R)),
        );
        // The ellipse of every speed is the analytic one to integration accuracy.
        let ((want_x, _), (want_y, _)) = model::linear_unbalance_response_xy(&base, omega);
        let scale = want_x.max(want_y);
        assert!(
            (ax - want_x).abs() < 1e-6 * scale,
            "W {omega}: A_x {ax} vs {want_x}"
        );
        assert!(
            (ay - want_y).abs() < 1e-6 * scale,
            "W {omega}: A_y {ay} vs {want_y}"
        );
        amp_x.push(ax);
        amp_y.push(ay);
    }
    let ((wx, wy), (xx, xy)) = (base.omega_r_xy(), base.xi_r_xy());
    for (name, amp, w, xi) in [("x", &amp_x, wx, xx), ("y", &amp_y, wy, xy)] {
        let peak = parabolic_peak(&speeds, amp);
        let want = w / (1.0 - 2.0 * xi * xi).sqrt();
        eprintln!("{name}: peak at {peak:.5} rad/s, analytic {want:.5}, sqrt(k/m) {w}");
        // The grid's parabola locates the peak to about 1e-3 rad/s; damping moves it
        // 0.11 rad/s (x) and 0.04 rad/s (y) above sqrt(k/m), which the bound resolves.
        assert!(
            (peak - want).abs() < 0.01,
            "{name}: peak at {peak}, want {want}"
        );
        assert!(
            (peak / w - 1.0).abs() < 2.0 * xi * xi,
            "{name}: peak {peak} vs {w}"
        );
    }
}

/// The vertex of the parabola through the largest sample of `y` and its neighbours.
fn parabolic_peak(x: &[f64], y: &[f64]) -> f64 {
    let i = (0..y.len()).fold(0, |m, k| if y[k] > y[m] { k } else { m });
    assert!(i > 0 && i + 1 < y.len(), "the peak is inside the sweep");
    let (a, b, c) = (y[i - 1], y[i], y[i + 1]);
    x[i] + 0.5 * (x[i + 1] - x[i]) * (a - c) / (a - 2.0 * b + c)
}

#[test]
fn an_offset_anisotropic_machine_converges_at_fourth_order_through_rubs() {
    // The batch stepper's order through impacts with the offset and directional terms
    // in its field (docs/numerics.md): the worst position error over 20 Poincare points
    // of a rubbing transient against N = 64000, least-squares order over N = 1000..4000,
    // every ratio above 2^3.5 (tests/physics.rs does the same for the article's model
    // from N = 250). With the stator set off, this transient's errors approach the
    // fourth-order ratio of 16 from below: 8.4, 12.6, 14.1, 15.1 from N = 250 on.
    let p = Params {
        omega_rx: Some(125.0),
        omega_ry: Some(150.0),
        xi_ry: Some(0.03),
        omega_sy: Some(520.0),
        o_x: 0.002,
        o_y: -0.001,
        ..Params::default()
    };
    let mut x0 = p.static_equilibrium();
    x0[VX_R] = 0.9;
    let points = |n: u32| {
        let lanes = vec![LaneSpec {
            omega: 132.2,
            x0,
            param_set: 0,
        }];
        let mut s = spec(vec![p.clone()], lanes, 0, 20);
        s.stepper.steps_per_period = n;
        let r = run(&s, Backend::Cpu);
        assert!(
            r.counters[0].contact_steps > 0,
            "it must rub: {:?}",
            r.counters[0]
        );
        r.poincare
    };
    let reference = points(64000);
    let ns = [1000u32, 2000, 4000];
    let errs: Vec<f64> = ns
        .iter()
        .map(|&n| {
            let got = points(n);
            got.chunks(STATE_DIM)
                .zip(reference.chunks(STATE_DIM))
                .map(|(a, b)| common::max_abs_diff(a, b, &common::POSITIONS))
                .fold(0.0, f64::max)
        })
        .collect();
    common::assert_fourth_order(&ns, &errs);
}

/// A machine whose stator is set off-centre by more than the gap: at rest the rotor is
/// pressed against it.
fn pressed_machine() -> Params {
    Params {
        o_x: 0.0064,
        o_y: 0.0019,
        omega_ry: Some(180.0),
        omega_sx: Some(600.0),
        ..Params::default()
    }
}

#[test]
fn a_stator_set_off_by_more_than_the_gap_holds_the_rotor_in_static_balance() {
    let p = pressed_machine();
    p.validate().expect("a slight press is a valid machine");
    let x = p.rest_state().unwrap();
    let g = model::penetration(p.delta, &x);
    assert!(g > 0.0 && g < p.delta / 10.0, "penetration {g}");
    assert_eq!(x, p.static_equilibrium());
    // Every acceleration vanishes: springs, gravity and the contact force balance.
    let still = Params {
        e: 0.0,
        ..p.clone()
    };
    let f = model::rhs(&still, 1.0, 0.0, &x);
    let scale = p.a_g;
    for i in [VX_R, VY_R, VX_S, VY_S] {
        assert!(f[i].abs() < 1e-9 * scale, "acceleration {i}: {}", f[i]);
    }
    // The stator pushes the rotor towards its own centre: the rotor's x spring holds
    // the contact force, k_rx x_r = F_x, and the rotor leaves the bearing axis in +x.
    let (fx, _) = model::contact_force(&p, &x);
    let (wrx, _) = p.omega_r_xy();
    assert!(x[X_R] > 0.0 && fx > 0.0);
    assert!((p.m_r * wrx * wrx * x[X_R] - fx).abs() < 1e-9 * fx.abs());
}

#[test]
fn offsets_and_directional_parameters_out_of_range_are_refused_naming_them() {
    // A soft contact: the rotor would rest pressed some 14 mm into the stator.
    let far = Params {
        o_x: 0.05,
        k_c: 2e6,
        ..Params::default()
    };
    let text = far.validate().unwrap_err().to_string();
    assert!(
        text.contains("o_x, o_y") && text.contains("delta"),
        "{text}"
    );
    for (name, bad) in [
        ("omega_rx", 0.0),
        ("xi_sy", -0.1),
        ("o_y", f64::NAN),
        ("omega_sx", f64::INFINITY),
    ] {
        let mut p = Params::default();
        p.set(name, bad).unwrap();
        let text = p.validate().unwrap_err().to_string();
        assert!(text.contains(name), "{name}: {text}");
    }
}

#[test]
fn without_damping_or_forcing_an_offset_anisotropic_machine_conserves_energy_through_rubs() {
    // Energy with each direction's springs and the stator's stretched from its offset
    // centre: a wrong sign or a missing offset anywhere would change it by k o x.
    let p = Params {
        xi_r: 0.0,
        xi_s: 0.0,
        e: 0.0,
        c_c: 0.0,
        mu: 0.0,
        ..pressed_machine()
    };
    let mut x0 = p.free_rest_state();
    x0[VX_R] = -0.35;
    x0[VY_R] = 0.2;
    let lanes = vec![LaneSpec {
        omega: 130.0,
        x0,
        param_set: 0,
    }];
    let mut s = spec(vec![p.clone()], lanes, 0, 40);
    s.stepper.steps_per_period = 4000;
    let r = run(&s, Backend::Cpu);
    let e0 = model::energy(&p, &x0);
    for k in 0..40 {
        let x: State = r.poincare[k * STATE_DIM..][..STATE_DIM].try_into().unwrap();
        let e = model::energy(&p, &x);
        assert!((e - e0).abs() < 1e-5 * e0.abs(), "period {k}: {e} vs {e0}");
    }
    // It rubbed: the rotor crossed the gap into the stator during the run.
    assert!(r.counters[0].contact_steps > 100, "{:?}", r.counters[0]);
}

#[test]
fn directional_parameters_equal_to_the_isotropic_ones_give_the_articles_bits() {
    let article = Params::default();
    let spelled = Params {
        omega_rx: Some(article.omega_r),
        omega_ry: Some(article.omega_r),
        xi_rx: Some(article.xi_r),
        xi_ry: Some(article.xi_r),
        omega_sx: Some(article.omega_s),
        omega_sy: Some(article.omega_s),
        xi_sx: Some(article.xi_s),
        xi_sy: Some(article.xi_s),
        o_x: -0.0,
        o_y: 0.0,
        ..article.clone()
    };
    let (a, b) = (
        Coeffs::<f64>::new(&article, 133.0),
        Coeffs::<f64>::new(&spelled, 133.0),
    );
    assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
    assert!(!b.offset());
    // A rubbing speed of the article, from its static equilibrium, both ways.
    let lanes = |set| LaneSpec {
        omega: 133.0,
        x0: article.static_equilibrium(),
        param_set: set,
    };
    let r = run(
        &spec(
            vec![article.clone(), spelled],
            vec![lanes(0), lanes(1)],
            150,
            8,
        ),
        Backend::Cpu,
    );
    let per = 8 * STATE_DIM;
    assert!(r.counters[0].contact_steps > 0);
    assert_eq!(bits(&r.poincare[..per]), bits(&r.poincare[per..]));
    assert_eq!(r.counters[0], r.counters[1]);
}

/// Lanes of the machine variants in contact: each lane its own anisotropy and offset,
/// friction on some, from states near the stator.
fn rubbing_variants() -> (Vec<Params>, Vec<LaneSpec>) {
    let sets: Vec<Params> = (0..12)
        .map(|i| Params {
            omega_rx: Some(125.0 + 20.0 * unit(i, 1).abs()),
            xi_ry: Some(0.01 + 0.03 * unit(i, 2).abs()),
            omega_sy: Some(450.0 + 150.0 * unit(i, 3).abs()),
            o_x: if i % 3 == 0 { 0.0 } else { 0.004 * unit(i, 4) },
            o_y: if i % 3 == 0 { 0.0 } else { 0.004 * unit(i, 5) },
            mu: if i % 2 == 0 { 0.0 } else { 0.15 },
            ..Params::default()
        })
        .collect();
    let lanes = (0..sets.len())
        .map(|i| LaneSpec {
            omega: 128.0 + 6.0 * unit(i, 6).abs(),
            x0: sets[i].static_equilibrium(),
            param_set: i as u32,
        })
        .collect();
    (sets, lanes)
}

#[test]
fn the_gpu_kernel_runs_the_machine_variants_to_the_cpus_bits() {
    if gpu_f64_device().is_none() {
        return;
    }
    let (sets, lanes) = rubbing_variants();
    // Each variant's kernel code alone and both together (the kernel has only the code
    // its run's lanes need), with and without the exact free-flight step.
    let offset_only: Vec<Params> = sets
        .iter()
        .map(|p| Params {
            omega_rx: None,
            xi_ry: None,
            omega_sy: None,
            ..p.clone()
        })
        .collect();
    let anisotropic_only: Vec<Params> = sets
        .iter()
        .map(|p| Params {
            o_x: 0.0,
            o_y: 0.0,
            ..p.clone()
        })
        .collect();
    for (what, sets) in [
        ("both", sets),
        ("offset", offset_only),
        ("anisotropy", anisotropic_only),
    ] {
        for exact in [false, true] {
            let case = format!("{what}, exact free flight {exact}");
            let mut s = spec(sets.clone(), lanes.clone(), 60, 6);
            s.stepper.exact_free_flight = exact;
            let cpu = run(&s, Backend::Cpu);
            let gpu = run(&s, Backend::Gpu);
            assert!(
                cpu.counters.iter().any(|c| c.contact_steps > 0),
                "{case}: no rub"
            );
            assert_eq!(bits(&cpu.poincare), bits(&gpu.poincare), "{case}");
            assert_eq!(cpu.status, gpu.status, "{case}");
            assert_eq!(
                bits(&cpu.final_state.concat()),
                bits(&gpu.final_state.concat()),
                "{case}"
            );
        }
    }
}

#[test]
fn a_params_table_of_machine_variants_keeps_every_parameter_and_the_articles_keeps_14_columns() {
    use jeffcott_core::ensemble::table::{params_columns, params_table, read_params_table};
    let (mut sets, _) = rubbing_variants();
    sets[1].n_c = 2.5;
    sets[2].alpha_c = 0.25;
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, rows: usize, columns: usize, values: &[f64]| {
        let path = dir.path().join(name);
        jeffcott_analysis::output::write_npy(&path, &[rows, columns], values).unwrap();
        path
    };
    for (sets, columns) in [(vec![Params::default()], 14), (sets.clone(), 26)] {
        assert_eq!(params_columns(&sets).len(), columns);
        let table = params_table(&sets);
        let path = write(&format!("params{columns}.npy"), sets.len(), columns, &table);
        let back = read_params_table(&path).unwrap();
        assert_eq!(back.len(), sets.len());
        for (a, b) in sets.iter().zip(&back) {
            for name in Params::names() {
                assert_eq!(a.get(name), b.get(name), "{name}");
            }
        }
    }
    // A table of 24 columns, without the contact law's two, reads with the linear law.
    let (sets, _) = rubbing_variants();
    let first24: Vec<f64> = params_table(&sets)
        .chunks(26)
        .flat_map(|row| row[..24].to_vec())
        .collect();
    let back = read_params_table(&write("params24.npy", sets.len(), 24, &first24)).unwrap();
    assert_eq!(back, sets);
    // Any other width is refused, naming the widths it takes.
    let text = read_params_table(&write("params20.npy", 1, 20, &[1.0; 20]))
        .unwrap_err()
        .to_string();
    assert!(text.contains("14 columns") && text.contains("26"), "{text}");
}

#[test]
fn the_analytic_jacobian_of_the_machine_variants_matches_central_differences() {
    let p = pressed_machine();
    let mut free = p.free_rest_state();
    free[X_R] = 0.005;
    free[VX_R] = 0.3;
    let pressed = p.rest_state().unwrap();
    assert!(model::penetration(p.delta, &free) < 0.0);
    assert!(model::penetration(p.delta, &pressed) > 0.0);
    for x in [free, pressed] {
        common::assert_jacobian_matches_central_differences(&p, &x, 1e-6 * p.k_c / p.m_r * 1e-3);
    }
}
