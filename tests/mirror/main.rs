//! The WGSL mirror checked function by function: every function of the lane stepper that
//! the kernel mirrors and that can be called on its own runs on the GPU through a
//! test-only entry point appended to the kernel, on a few thousand inputs around contact
//! (grazing, entering, leaving; contact damping c_c > 0 and friction mu > 0 on some
//! rows), and must return exactly the bits of its Rust function, in f64 and in f32 (on
//! a device with f64 in both f32 variants: division and sqrt through f64, and the
//! driver's own), wherever identity is promised (`common::gpu::identity_promised`).
//! tests/gpu.rs checks the whole stepper over many periods; here a difference points at
//! one function, so a compiler rewrite (Mesa reassociates add chains, see `keep` in
//! integrate/lane_buffers.wgsl) shows up where it happens.
//!
//! The kernel's functions are compiled as they are in the real kernel: the probes are
//! entry points added to the assembled source (`jeffcott_gpu::shader::source`, the
//! lambda_1 variant so that `macro_step`'s tangent paths are live), reading their
//! arguments from rows of Reals (booleans as 0/1, small integers exactly) and writing
//! their results as rows of Reals. Needs a wgpu adapter (f64: SHADER_F64); without one
//! the tests print "skipped" and return, unless `JEFFCOTT_REQUIRE_GPU=1`.

use jeffcott_core::integrate::forcing::phasor_turns;
use jeffcott_core::integrate::free_flight::{
    ExactFreeFlight, free_flight_step, free_flight_tangent,
};
use jeffcott_core::integrate::lane::{
    Lane, LaneConsts, Status, StepperConfig, Tangent, clear_of_stator, control_points, exact_trial,
    find_switch, forcing_phasor, free_flight_certain, hermite_gap, hull_reach_sq,
    in_contact_certain, macro_step, macro_step_tangent, renormalise, rk4_substep,
    rk4_tangent_substep, saltation, search_needless, stage_partials, tangent_rhs, trial_extent,
    trial_tangent, wrong_side,
};
use jeffcott_core::model::{
    Coeffs, NormalPartials, Params, STATE_DIM, Terms, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S,
    contact_block, contact_force_lane, contact_force_per_kc, contact_force_per_kc_law,
    contact_partials, contact_partials_law_off_centre, penetration, pow_half, relative_motion,
    rhs_frozen,
};
use jeffcott_core::real::Real;
use jeffcott_gpu::shader::{Features, Variant};
use jeffcott_gpu::{GpuReal, GpuRunner};
use std::fmt::Write;

#[path = "../common/mod.rs"]
mod common;
use common::gpu::{device_variant, identity_promised};
use common::unit;

mod contact_and_rhs;
mod macro_steps;
mod probes;
mod substeps;
mod switching;
use probes::*;

/// One probe: the kernel function it calls, its row widths and the WGSL that reads the
/// arguments, calls it and writes the results.
struct Probe {
    name: &'static str,
    inputs: usize,
    outputs: usize,
    body: &'static str,
}

fn probe(name: &str) -> &'static Probe {
    PROBES
        .iter()
        .find(|p| p.name == name)
        .unwrap_or_else(|| panic!("no probe {name}"))
}

/// Kernel variant `v` with every probe appended as entry point `mirror_NAME`.
fn probe_source<R: GpuReal>(v: Variant) -> String {
    let mut src = jeffcott_gpu::shader::source::<R>(v) + PROBE_IO;
    for p in &PROBES {
        let _ = write!(
            src,
            "
@compute @workgroup_size(64)
fn mirror_{}(@builtin(global_invocation_id) gid: vec3<u32>) {{
    if !mirror_row(gid.x, {}u, {}u) {{
        return;
    }}
    {}
}}
",
            p.name, p.inputs, p.outputs, p.body
        );
    }
    src
}

/// Runs probe `name` of kernel variant `v` on `rows` (each `inputs` Reals) and returns
/// its output rows.
fn run_probe<R: GpuReal>(runner: &GpuRunner, v: Variant, name: &str, rows: &[R]) -> Vec<R> {
    use wgpu::util::DeviceExt;
    let p = probe(name);
    let dev = runner.gpu().device();
    let n = rows.len() / p.inputs;
    let src = probe_source::<R>(v);
    let entry = format!("mirror_{name}");
    // The device's shader path (exact SPIR-V where the adapter takes it): the probes
    // must see what the kernel sees.
    let (pipeline, layout) = runner
        .gpu()
        .compute_pipeline(
            "mirror probes",
            &src,
            jeffcott_gpu::shader::capabilities::<R>(v),
            &entry,
            (64, 1, 1),
            &[
                (0, wgpu::BufferBindingType::Uniform),
                (10, wgpu::BufferBindingType::Storage { read_only: true }),
                (11, wgpu::BufferBindingType::Storage { read_only: false }),
            ],
        )
        .unwrap_or_else(|e| panic!("probe {name}: {e}"));
    let scope = dev.push_error_scope(wgpu::ErrorFilter::Validation);
    // `keep` reads params.n_lanes, which is never 0 in a real dispatch.
    let params = jeffcott_gpu::layout::Params {
        n_lanes: 1,
        ..Default::default()
    };
    let pbuf = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::bytes_of(&params),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let inp = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(rows),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let out_bytes = (n * p.outputs * std::mem::size_of::<R>()) as u64;
    let make = |usage| {
        dev.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: out_bytes,
            usage,
            mapped_at_creation: false,
        })
    };
    let out = make(wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
    let staging = make(wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST);
    fn bind(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
        wgpu::BindGroupEntry {
            binding,
            resource: buffer.as_entire_binding(),
        }
    }
    let group = dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &layout,
        entries: &[bind(0, &pbuf), bind(10, &inp), bind(11, &out)],
    });
    if let Some(e) = pollster::block_on(scope.pop()) {
        panic!("probe {name}: {e}");
    }
    let mut enc = dev.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((n as u32).div_ceil(64), 1, 1);
    }
    enc.copy_buffer_to_buffer(&out, 0, &staging, 0, None);
    runner.gpu().queue().submit(Some(enc.finish()));
    staging
        .slice(..)
        .map_async(wgpu::MapMode::Read, |r| r.expect("map"));
    dev.poll(wgpu::PollType::wait_indefinitely()).expect("poll");
    let view = staging.slice(..).get_mapped_range().expect("mapped");
    bytemuck::pod_collect_to_vec(&view)
}

/// One probe row: the arguments as the probe reads them, and the Rust function's
/// results as the probe writes them.
struct Row<R> {
    args: Vec<R>,
    expect: Vec<R>,
}

impl<R: Real> Row<R> {
    fn new() -> Self {
        Row {
            args: Vec::new(),
            expect: Vec::new(),
        }
    }
    fn real(mut self, v: R) -> Self {
        self.args.push(v);
        self
    }
    fn flag(self, b: bool) -> Self {
        self.real(R::lit(b as u8 as f64))
    }
    fn int(self, u: u32) -> Self {
        self.real(R::lit(u as f64))
    }
    fn state(mut self, x: &[R]) -> Self {
        self.args.extend_from_slice(x);
        self
    }
    fn coeffs(mut self, c: &Coeffs<R>) -> Self {
        // In the struct's order, as `in_coeffs` reads them.
        c.map(|v| self.args.push(v));
        self
    }
    fn consts(self, lc: &LaneConsts<R>) -> Self {
        self.coeffs(&lc.c)
            .real(lc.h)
            .real(lc.inv_n)
            .real(lc.phase0)
            .real(lc.bound)
            .real(lc.root_tol)
            .real(lc.inv_r)
            .free_flight(lc.exact.as_ref())
            .int(lc.n)
            .int(lc.max_segments)
            .flag(lc.exact.is_some())
    }
    /// The lane's exact free-flight map, zeros where it has none (as the GPU packs it).
    fn free_flight(self, ff: Option<&ExactFreeFlight<R>>) -> Self {
        match ff {
            Some(ff) => self
                .state(&ff.phi)
                .state(&ff.off)
                .state(&ff.p)
                .state(&ff.q)
                .real(ff.omega),
            None => self.state(&[R::lit(0.0); 29]),
        }
    }
    /// A sub-step's arguments, as `in_substep` reads them.
    fn substep(self, x: &[R; STATE_DIM], k: u32, s0: R, ds: R, contact: bool) -> Self {
        self.state(x).int(k).real(s0).real(ds).flag(contact)
    }
    fn expect(mut self, out: &[R]) -> Self {
        self.expect.extend_from_slice(out);
        self
    }
}

fn flag<R: Real>(b: bool) -> R {
    R::lit(b as u8 as f64)
}

/// The kernel variants (lambda_1, so that `macro_step`'s tangent paths are live) probed
/// in precision `R`: the device's, and in f32 on a device with f64 also the f32 kernel
/// of adapters without it (the driver's own division and sqrt).
fn probed_variants<R: GpuReal>(runner: &GpuRunner) -> Vec<Variant> {
    // The exact free-flight code live (lanes whose constants carry the map take it, the
    // others RK4, as in Rust), the offset stator's and the directional supports' (a
    // centred, isotropic lane's rows give the bits of the kernel without them: x - (+0)
    // is x, and its y coefficients are its x ones) and the contact laws' (each lane takes
    // its own law, as in Rust).
    let all = Features {
        exact: true,
        terms: Terms::ALL,
    };
    let device = device_variant(runner, true).with_features(all);
    let mut v = vec![device];
    if R::WGSL_NAME == "f32" && device.f32_through_f64 {
        v.push(Variant::on_device(true, false).with_features(all));
    }
    v
}

/// Runs probe `name` on `rows` in every probed variant and demands the Rust results bit
/// for bit where that is promised (`identity_promised`; elsewhere it reports how many
/// rows agree and says the check was skipped); returns the number of rows.
fn assert_mirrors<R: GpuReal>(runner: &GpuRunner, name: &str, rows: &[Row<R>]) -> usize {
    for v in probed_variants::<R>(runner) {
        assert_mirrors_in(runner, v, name, rows);
    }
    rows.len()
}

/// [`assert_mirrors`] for one variant.
fn assert_mirrors_in<R: GpuReal>(runner: &GpuRunner, v: Variant, name: &str, rows: &[Row<R>]) {
    let p = probe(name);
    let mut flat = Vec::with_capacity(rows.len() * p.inputs);
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r.args.len(), p.inputs, "{name}: row {i} arguments");
        assert_eq!(r.expect.len(), p.outputs, "{name}: row {i} results");
        flat.extend_from_slice(&r.args);
    }
    let t = std::time::Instant::now();
    let out = run_probe(runner, v, name, &flat);
    let secs = t.elapsed().as_secs_f64();
    assert_eq!(out.len(), rows.len() * p.outputs);
    let bits = |v: &[R]| v.iter().map(|x| x.to_f64().to_bits()).collect::<Vec<_>>();
    let mut bad = 0;
    for (i, (r, gpu)) in rows.iter().zip(out.chunks_exact(p.outputs)).enumerate() {
        if bits(&r.expect) != bits(gpu) {
            bad += 1;
            if bad <= 3 {
                eprintln!(
                    "{name} ({}): row {i} differs\n args {:?}\n Rust {:?}\n GPU  {:?}",
                    R::WGSL_NAME,
                    r.args,
                    r.expect,
                    gpu
                );
            }
        }
    }
    let what = format!("{name} ({}{})", R::WGSL_NAME, ops_label::<R>(v));
    eprintln!(
        "{what}: {} of {} rows bit-identical ({secs:.2} s on the GPU)",
        rows.len() - bad,
        rows.len()
    );
    if !identity_promised::<R>(runner, v) {
        eprintln!("{what}: skipped, bit-identity is not promised on this adapter");
        return;
    }
    assert_eq!(
        bad,
        0,
        "{what}: {bad} of {} rows differ from the Rust function",
        rows.len()
    );
}

/// How the f32 kernel of variant `v` divides and takes square roots ("" in f64).
fn ops_label<R: GpuReal>(v: Variant) -> &'static str {
    match (R::WGSL_NAME, v.f32_through_f64) {
        ("f64", _) => "",
        (_, true) => ", / and sqrt through f64",
        (_, false) => ", driver's / and sqrt",
    }
}

// ---- inputs around contact ---------------------------------------------------------

/// Parameters of case `i`: friction on two rows in three, contact damping on every other
/// row, the machine variants on some ([`machine_variant`]), W over the article's range,
/// contact refinement R of 1, 2 or 4.
fn lane_consts<R: Real>(i: usize) -> (Params, LaneConsts<R>) {
    let article = Params {
        mu: if i.is_multiple_of(3) {
            0.0
        } else {
            0.3 * unit(i, 8).abs()
        },
        c_c: if i.is_multiple_of(2) {
            0.0
        } else {
            3e4 * unit(i, 13).abs()
        },
        ..Params::default()
    };
    let p = machine_variant(article, i);
    let cfg = StepperConfig {
        contact_substeps: [1, 2, 4][i % 3],
        // Every other case with the exact free-flight step (in the probes of
        // macro_step and below).
        exact_free_flight: i % 2 == 1,
        ..StepperConfig::default()
    };
    let omega = 130.0 + 11.0 * unit(i, 9).abs();
    let lc = LaneConsts::new(&p, omega, &cfg);
    (p, lc)
}

/// A lane state at the start of a macro step.
#[derive(Clone, Copy, Debug)]
struct Case<R: 'static> {
    lc: LaneConsts<R>,
    x: [R; STATE_DIM],
    contact: bool,
    k: u32,
}

/// States the stepper itself reaches near g = 0: lanes thrown against the stator (and
/// one from the static equilibrium) integrated by `macro_step` on the CPU, every macro
/// step start with |g| < 0.1 mm kept, then `n` of them spread evenly.
fn trajectory_cases<R: Real>(n: usize) -> Vec<Case<R>> {
    let mut all = Vec::new();
    for j in 0..12 {
        let (p, lc) = lane_consts::<R>(j);
        let mut x0 = p.static_equilibrium();
        if j % 4 != 3 {
            x0[X_R] = 0.0058;
            x0[VX_R] = if j % 2 == 0 { 0.8 } else { -0.8 };
            x0[VY_R] = 0.3 * unit(j, 21);
        }
        let mut lane = Lane::<R>::new(&x0, p.delta);
        for _ in 0..8 * lc.n {
            let g = penetration(lc.c.delta, &lane.x).to_f64();
            if g.abs() < 1e-4 {
                all.push(Case {
                    lc,
                    x: lane.x,
                    contact: lane.contact,
                    k: lane.k,
                });
            }
            macro_step(&lc, &mut lane);
            assert!(!lane.status.is_frozen());
        }
    }
    assert!(all.len() >= n, "only {} states near contact", all.len());
    (0..n).map(|i| all[i * all.len() / n]).collect()
}

/// States built around g = 0: the rotor at gap g0 within 30 um of the stator ring,
/// moving in, out or along it, in the mode its side says (one row in eight in the other
/// mode: a lane on the switching surface whose flow leaves it).
fn synthetic_cases<R: Real>(n: usize) -> Vec<Case<R>> {
    (0..n)
        .map(|i| {
            let (p, lc) = lane_consts::<R>(i + 1000);
            let a = std::f64::consts::PI * unit(i, 31);
            let (ca, sa) = (a.cos(), a.sin());
            let g0 = match i % 5 {
                0 => 1e-9 * unit(i, 32),
                _ => 3e-5 * unit(i, 32),
            };
            let r = p.delta + g0;
            let (vr, vt) = (0.5 * unit(i, 33), 1.0 * unit(i, 34));
            let mut x = [0.0; STATE_DIM];
            x[X_S] = 1e-4 * unit(i, 35);
            x[Y_S] = 1e-4 * unit(i, 36);
            x[VX_S] = 0.05 * unit(i, 37);
            x[VY_S] = 0.05 * unit(i, 38);
            x[X_R] = x[X_S] + r * ca;
            x[Y_R] = x[Y_S] + r * sa;
            x[VX_R] = x[VX_S] + vr * ca - vt * sa;
            x[VY_R] = x[VY_S] + vr * sa + vt * ca;
            let x = x.map(R::lit);
            let on_side = penetration(lc.c.delta, &x) > R::lit(0.0);
            Case {
                lc,
                x,
                contact: on_side != (i % 8 == 7),
                k: (i as u32 * 37) % lc.n,
            }
        })
        .collect()
}

/// Both kinds, 1500 each.
fn cases<R: Real>() -> Vec<Case<R>> {
    let mut c = trajectory_cases::<R>(1500);
    c.extend(synthetic_cases::<R>(1500));
    c
}

/// A trial sub-step of case `i` as the stepper takes it: from s0 (0, or 1/2 in every
/// fourth case), over `trial_extent`, the RK4 end state x1 and its duration hs.
struct Trial<R> {
    s0: R,
    ds: R,
    x1: [R; STATE_DIM],
    hs: R,
}

fn trial<R: Real>(i: usize, c: &Case<R>) -> Trial<R> {
    let s0 = R::lit(if i % 4 == 3 { 0.5 } else { 0.0 });
    let (ds, _) = trial_extent(&c.lc, s0, c.contact);
    let x1 = rk4_substep(&c.lc, &c.x, c.k, s0, ds, c.contact);
    Trial {
        s0,
        ds,
        x1,
        hs: ds * c.lc.h,
    }
}

/// Sub-step ends built to graze: the rotor holds g = -eps (out of contact; +eps in
/// contact) at both ends, its radial velocity heading to the other side at the start and
/// back at the end, so that g along the Hermite interpolant has one extremum, at
/// `bump` above the ends. Two rows in three put eps between the largest sample of the
/// bump and its peak, so that the extremum crosses g = 0 where no sample sees it (what
/// find_switch's extremum check is for); the rest anywhere from 0.3 to 1.2 peaks.
fn grazing_steps<R: Real>(n: usize) -> Vec<SwitchArgs<R>> {
    (0..n)
        .map(|i| {
            let (p, lc) = lane_consts::<R>(i + 5000);
            let contact = i % 2 == 1;
            let sign = if contact { -1.0 } else { 1.0 };
            let hs = lc.h.to_f64();
            let v0 = 0.05 + 0.3 * unit(i, 41).abs();
            let v1 = v0 * (0.2 + 1.8 * unit(i, 42).abs());
            // The radial displacement's Hermite bump (both ends at the same radius).
            let bump = |th: f64| hs * th * (1.0 - th) * ((1.0 - th) * v0 + th * v1);
            let peak = (0..=4096)
                .map(|j| bump(j as f64 / 4096.0))
                .fold(0.0, f64::max);
            let sampled = (0..=8).map(|j| bump(j as f64 / 8.0)).fold(0.0, f64::max);
            let eps = if i % 3 != 2 {
                sampled + (peak - sampled) * (0.05 + 0.9 * unit(i, 43).abs())
            } else {
                peak * (0.3 + 0.9 * unit(i, 43).abs())
            };
            let a = std::f64::consts::PI * unit(i, 44);
            let (ca, sa) = (a.cos(), a.sin());
            let vt = 0.01 * unit(i, 45);
            let end = |vr: f64| {
                let mut x = [0.0; STATE_DIM];
                let r = p.delta - sign * eps;
                x[X_R] = r * ca;
                x[Y_R] = r * sa;
                x[VX_R] = sign * vr * ca - vt * sa;
                x[VY_R] = sign * vr * sa + vt * ca;
                x.map(R::lit)
            };
            (lc, end(v0), end(-v1), lc.h, contact)
        })
        .collect()
}

/// A deterministic tangent vector of length about `scale`.
fn tangent<R: Real>(i: usize, scale: f64) -> [R; STATE_DIM] {
    std::array::from_fn(|d| R::lit(scale * unit(i, 60 + d as u64)))
}

/// The rows of the probe that tests/gpu.rs ran before the split (50 000 random states
/// around contact, both modes), for rhs_frozen and phasor_turns.
/// rhs_frozen's arguments (coefficients, state, cos, sin, mode) and a phasor argument.
type RhsArgs<R> = (Coeffs<R>, [R; STATE_DIM], R, R, bool, R);

/// `p` as one of the machine variants (docs/model.md 7) for row `i`: every fifth row
/// with supports that differ by direction, every fifth (another) with the stator off
/// the axis, two in five with a contact law (each exponent, Hunt-Crossley damping on
/// every other), the rest the article's machine.
fn machine_variant(mut p: Params, i: usize) -> Params {
    if i % 5 == 2 || i % 5 == 4 {
        p.n_c = [1.5, 2.0, 2.5, 3.0, 1.0][(i / 5) % 5];
        // Stiffness per m^n scaled so that a micrometre's overlap pushes as it does in the
        // linear law.
        p.k_c *= 1e-6f64.powf(1.0 - p.n_c);
        if i.is_multiple_of(2) {
            p.alpha_c = 0.5 * unit(i, 20).abs();
        }
    }
    if i % 5 == 1 {
        p.omega_rx = Some(120.0 + 40.0 * unit(i, 14).abs());
        p.xi_ry = Some(0.04 * unit(i, 15).abs());
        p.omega_sy = Some(400.0 + 300.0 * unit(i, 16).abs());
        p.xi_sx = Some(0.1 * unit(i, 17).abs());
    }
    if i % 5 == 3 {
        p.o_x = 0.003 * unit(i, 18);
        p.o_y = 0.003 * unit(i, 19);
    }
    p
}

fn random_rhs_inputs<R: Real>(n: usize) -> Vec<RhsArgs<R>> {
    (0..n)
        .map(|i| {
            let mut x = [R::lit(0.0); STATE_DIM];
            for (d, v) in x.iter_mut().enumerate() {
                let scale = if d % 2 == 0 { 0.004 } else { 0.8 };
                *v = R::lit(scale * unit(i, d as u64 + 100));
            }
            x[X_R] = R::lit(0.006 * (1.0 + 0.05 * unit(i, 7)));
            let p = Params {
                mu: if i % 3 == 0 {
                    0.0
                } else {
                    0.3 * unit(i, 8).abs()
                },
                c_c: if i % 2 == 0 {
                    0.0
                } else {
                    2e4 * unit(i, 13).abs()
                },
                ..Params::default()
            };
            let c = Coeffs::<R>::new(&machine_variant(p, i), 130.0 + 11.0 * unit(i, 9).abs());
            (
                c,
                x,
                R::lit(unit(i, 10)),
                R::lit(unit(i, 11)),
                i % 4 != 0,
                R::lit(3.0 * unit(i, 12)),
            )
        })
        .collect()
}

/// find_switch's rows: (lane constants, x0, x1, hs, mode) of trial sub-steps.
type SwitchArgs<R> = (LaneConsts<R>, [R; STATE_DIM], [R; STATE_DIM], R, bool);

/// Every function of the mirrored parts of the kernel (forcing.wgsl, model.wgsl,
/// tangent.wgsl, switch.wgsl, lane.wgsl) has a probe and a test above, but for the kernel-only pieces of
/// find_switch and macro_step, which their probes run.
#[test]
fn every_mirrored_function_has_a_probe() {
    use jeffcott_core::integrate::lane::WGSL_FILES;
    // Kernel-only pieces: free_flight_map and rk4_stages are the bodies of
    // free_flight_step and rk4_substep (whose probes run them) with the phasors given;
    // y_coeffs picks the coefficients rhs_frozen and tangent_rhs read (their probes run
    // it in the variant with ANISOTROPIC on, the tests of whole runs with it off).
    let kernel_only = [
        "scan_sample",
        "macro_step_begin",
        "macro_step_end",
        "free_flight_map",
        "rk4_stages",
        "y_coeffs",
        "contact_law",
    ];
    let this = [
        include_str!("main.rs"),
        include_str!("contact_and_rhs.rs"),
        include_str!("substeps.rs"),
        include_str!("switching.rs"),
        include_str!("macro_steps.rs"),
    ]
    .concat();
    let mut mirrored = Vec::new();
    for (path, text) in WGSL_FILES {
        if ![
            "integrate/forcing.wgsl",
            "model.wgsl",
            "integrate/tangent.wgsl",
            "integrate/switch.wgsl",
            "integrate/free_flight.wgsl",
            "integrate/lane.wgsl",
        ]
        .contains(&path)
        {
            continue;
        }
        for line in text.lines() {
            if let Some(rest) = line.strip_prefix("fn ") {
                let name = &rest[..rest.find('(').expect("fn name(")];
                if !kernel_only.contains(&name) {
                    mirrored.push(name);
                }
            }
        }
    }
    let probes: Vec<&str> = PROBES.iter().map(|p| p.name).collect();
    for name in &mirrored {
        assert!(probes.contains(name), "no probe for {name}");
        assert!(
            this.contains(&format!("assert_mirrors(runner, \"{name}\"")),
            "no test runs the {name} probe"
        );
    }
    assert_eq!(probes.len(), mirrored.len(), "{probes:?} vs {mirrored:?}");
}
