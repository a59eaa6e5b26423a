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
    Coeffs, Params, STATE_DIM, Terms, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S,
    contact_force_lane, contact_force_per_kc, contact_force_per_kc_law, contact_partials,
    contact_partials_law_off_centre, penetration, pow_half, relative_motion, rhs_frozen,
};
use jeffcott_core::real::Real;
use jeffcott_gpu::shader::{Features, Variant};
use jeffcott_gpu::{GpuReal, GpuRunner};
use std::fmt::Write;

mod common;
use common::gpu::{device_variant, identity_promised};
use common::unit;

/// Buffers and readers shared by the probe entry points. Each invocation handles one
/// row: `mirror_row` points the cursors at it, `in_*` read the arguments in order,
/// `out_*` write the results in order.
const PROBE_IO: &str = r#"
// ---- test-only probes (tests/mirror.rs) ----
@group(0) @binding(10) var<storage, read> mirror_in: array<Real>;
@group(0) @binding(11) var<storage, read_write> mirror_out: array<Real>;
var<private> mirror_at: u32;
var<private> mirror_put: u32;

// Row i of `inputs` Reals in and `outputs` out; false past the last row. Reads
// params.n_lanes so that every probe binds `params` (which `keep` reads).
fn mirror_row(i: u32, inputs: u32, outputs: u32) -> bool {
    if i >= arrayLength(&mirror_in) / inputs || params.n_lanes == 0u {
        return false;
    }
    mirror_at = i * inputs;
    mirror_put = i * outputs;
    return true;
}
fn in_real() -> Real {
    let v = mirror_in[mirror_at];
    mirror_at += 1u;
    return v;
}
fn in_bool() -> bool {
    return in_real() > Real(0.5);
}
fn in_u32() -> u32 {
    return u32(in_real());
}
fn in_state() -> array<Real, STATE_DIM> {
    var x: array<Real, STATE_DIM>;
    for (var j = 0u; j < STATE_DIM; j++) {
        x[j] = in_real();
    }
    return x;
}
fn in_coeffs() -> Coeffs {
    let wr2x = in_real();
    let wr2y = in_real();
    let drx = in_real();
    let dry = in_real();
    let ws2x = in_real();
    let ws2y = in_real();
    let dsx = in_real();
    let dsy = in_real();
    let ox = in_real();
    let oy = in_real();
    let unbalance = in_real();
    let a_g = in_real();
    let kc_mr = in_real();
    let kc_ms = in_real();
    let mu = in_real();
    let delta = in_real();
    let tau_c = in_real();
    let n_c = in_real();
    let hc = in_real();
    return Coeffs(
        wr2x, wr2y, drx, dry, ws2x, ws2y,
        dsx, dsy, ox, oy, unbalance, a_g,
        kc_mr, kc_ms, mu, delta, tau_c, n_c, hc,
    );
}
fn in_consts() -> LaneConsts {
    let c = in_coeffs();
    let h = in_real();
    let inv_n = in_real();
    let phase0 = in_real();
    let bound = in_real();
    let root_tol = in_real();
    let inv_r = in_real();
    var ff: FreeFlight;
    for (var j = 0u; j < 16u; j++) {
        ff.phi[j] = in_real();
    }
    for (var j = 0u; j < 4u; j++) {
        ff.off[j] = in_real();
    }
    for (var j = 0u; j < 4u; j++) {
        ff.p[j] = in_real();
    }
    for (var j = 0u; j < 4u; j++) {
        ff.q[j] = in_real();
    }
    ff.omega = in_real();
    let n = in_u32();
    let max_segments = in_u32();
    let exact = in_u32();
    return LaneConsts(c, h, inv_n, phase0, bound, root_tol, inv_r, ff, n, max_segments, exact, 0u);
}
// A sub-step's arguments after the constants: state, macro step, start, length, mode.
struct SubStep {
    x: array<Real, STATE_DIM>,
    k: u32,
    s0: Real,
    ds: Real,
    contact: bool,
}
fn in_substep() -> SubStep {
    let x = in_state();
    let k = in_u32();
    let s0 = in_real();
    let ds = in_real();
    return SubStep(x, k, s0, ds, in_bool());
}
fn in_partials() -> Partials {
    let a = in_state();
    return Partials(vec4<Real>(a[0], a[1], a[2], a[3]), vec4<Real>(a[4], a[5], a[6], a[7]));
}
fn out_real(v: Real) {
    mirror_out[mirror_put] = v;
    mirror_put += 1u;
}
fn out_bool(b: bool) {
    out_real(select(Real(0.0), Real(1.0), b));
}
fn out_state(x: array<Real, STATE_DIM>) {
    for (var j = 0u; j < STATE_DIM; j++) {
        out_real(x[j]);
    }
}
fn out_partials(p: Partials) {
    out_real(p.a.x);
    out_real(p.a.y);
    out_real(p.a.z);
    out_real(p.a.w);
    out_real(p.b.x);
    out_real(p.b.y);
    out_real(p.b.z);
    out_real(p.b.w);
}
"#;

/// One probe: the kernel function it calls, its row widths and the WGSL that reads the
/// arguments, calls it and writes the results.
struct Probe {
    name: &'static str,
    inputs: usize,
    outputs: usize,
    body: &'static str,
}

/// Reals of a `LaneConsts` row: Coeffs (19), h, inv_n, phase0, bound, root_tol, inv_r,
/// the exact free-flight map (29), n, max_segments, exact.
const CONSTS: usize = 57;
const COEFFS: usize = 19;
const S: usize = STATE_DIM;

const PROBES: [Probe; 31] = [
    Probe {
        name: "phasor_turns",
        inputs: 1,
        outputs: 2,
        body: "let p = phasor_turns(in_real());
    out_real(p.x);
    out_real(p.y);",
    },
    Probe {
        name: "relative_motion",
        inputs: S,
        outputs: 4,
        body: "let m = relative_motion(in_state());
    out_real(m.x);
    out_real(m.y);
    out_real(m.z);
    out_real(m.w);",
    },
    Probe {
        name: "penetration",
        inputs: 1 + S,
        outputs: 1,
        body: "let delta = in_real();
    let x = in_state();
    out_real(penetration(delta, x));",
    },
    Probe {
        name: "contact_force_per_kc",
        inputs: 7,
        outputs: 2,
        body: "let delta = in_real();
    let mu = in_real();
    let tau_c = in_real();
    let dx = in_real();
    let dy = in_real();
    let dvx = in_real();
    let dvy = in_real();
    let f = contact_force_per_kc(delta, mu, tau_c, dx, dy, dvx, dvy);
    out_real(f.x);
    out_real(f.y);",
    },
    Probe {
        name: "pow_half",
        inputs: 2,
        outputs: 1,
        body: "let a = in_real();
    let m = in_real();
    out_real(pow_half(a, m));",
    },
    Probe {
        name: "contact_force_per_kc_law",
        inputs: COEFFS + 4,
        outputs: 2,
        body: "let c = in_coeffs();
    let dx = in_real();
    let dy = in_real();
    let dvx = in_real();
    let dvy = in_real();
    let f = contact_force_per_kc_law(c, dx, dy, dvx, dvy);
    out_real(f.x);
    out_real(f.y);",
    },
    Probe {
        name: "contact_force_lane",
        inputs: COEFFS + 4,
        outputs: 2,
        body: "let c = in_coeffs();
    let dx = in_real();
    let dy = in_real();
    let dvx = in_real();
    let dvy = in_real();
    let f = contact_force_lane(c, dx, dy, dvx, dvy);
    out_real(f.x);
    out_real(f.y);",
    },
    Probe {
        name: "contact_partials_law_off_centre",
        inputs: COEFFS + S,
        outputs: 8,
        body: "let c = in_coeffs();
    let x = in_state();
    out_partials(contact_partials_law_off_centre(c, relative_motion(x)));",
    },
    Probe {
        name: "contact_partials",
        inputs: COEFFS + S,
        outputs: 8,
        body: "let c = in_coeffs();
    let x = in_state();
    out_partials(contact_partials(c, x));",
    },
    Probe {
        name: "rhs_frozen",
        inputs: COEFFS + S + 3,
        outputs: S,
        body: "let c = in_coeffs();
    let x = in_state();
    let cos_phase = in_real();
    let sin_phase = in_real();
    let contact = in_bool();
    out_state(rhs_frozen(c, x, cos_phase, sin_phase, contact));",
    },
    Probe {
        name: "forcing_phasor",
        inputs: CONSTS + 2,
        outputs: 2,
        body: "let lc = in_consts();
    let k = in_u32();
    let sigma = in_real();
    let p = forcing_phasor(lc, k, sigma);
    out_real(p.x);
    out_real(p.y);",
    },
    Probe {
        name: "free_flight_step",
        inputs: CONSTS + S + 1,
        outputs: S,
        body: "let lc = in_consts();
    let x = in_state();
    let k = in_u32();
    out_state(free_flight_step(lc, x, k));",
    },
    Probe {
        name: "free_flight_tangent",
        inputs: CONSTS + S,
        outputs: S,
        body: "let lc = in_consts();
    var v = in_state();
    free_flight_tangent(lc, &v);
    out_state(v);",
    },
    Probe {
        name: "trial_tangent",
        inputs: CONSTS + 1 + S + 4 + S,
        outputs: S,
        body: "let lc = in_consts();
    let exact = in_bool();
    let a = in_substep();
    var v = in_state();
    trial_tangent(lc, exact, a.x, a.k, a.s0, a.ds, a.contact, &v);
    out_state(v);",
    },
    Probe {
        name: "rk4_substep",
        inputs: CONSTS + S + 4,
        outputs: S,
        body: "let lc = in_consts();
    let a = in_substep();
    out_state(rk4_substep(lc, a.x, a.k, a.s0, a.ds, a.contact));",
    },
    Probe {
        name: "stage_partials",
        inputs: COEFFS + S + 1,
        outputs: 8,
        body: "let c = in_coeffs();
    let x = in_state();
    let contact = in_bool();
    out_partials(stage_partials(c, x, contact));",
    },
    Probe {
        name: "tangent_rhs",
        inputs: COEFFS + 8 + S,
        outputs: S,
        body: "let c = in_coeffs();
    let pc = in_partials();
    let v = in_state();
    out_state(tangent_rhs(c, pc, v));",
    },
    Probe {
        name: "rk4_tangent_substep",
        inputs: CONSTS + S + 4 + S,
        outputs: S,
        body: "let lc = in_consts();
    let a = in_substep();
    var v = in_state();
    rk4_tangent_substep(lc, a.x, a.k, a.s0, a.ds, a.contact, &v);
    out_state(v);",
    },
    Probe {
        name: "saltation",
        inputs: CONSTS + S + 3 + S,
        outputs: S,
        body: "let lc = in_consts();
    let x = in_state();
    let k = in_u32();
    let s = in_real();
    let from_contact = in_bool();
    var v = in_state();
    saltation(lc, x, k, s, from_contact, &v);
    out_state(v);",
    },
    Probe {
        name: "renormalise",
        inputs: S,
        outputs: 1 + S,
        body: "var v = in_state();
    let n = renormalise(&v);
    out_real(n);
    out_state(v);",
    },
    Probe {
        name: "hermite_gap",
        inputs: 1 + 2 * S + 2,
        outputs: 2,
        body: "let delta = in_real();
    let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    let theta = in_real();
    let g = hermite_gap(delta, x0, x1, hs, theta);
    out_real(g.x);
    out_real(g.y);",
    },
    Probe {
        name: "wrong_side",
        inputs: 2,
        outputs: 1,
        body: "let g = in_real();
    let contact = in_bool();
    out_bool(wrong_side(g, contact));",
    },
    Probe {
        name: "control_points",
        inputs: 2 * S + 1,
        outputs: 8,
        body: "let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    let p = control_points(x0, x1, hs);
    out_real(p[0].x);
    out_real(p[0].y);
    out_real(p[1].x);
    out_real(p[1].y);
    out_real(p[2].x);
    out_real(p[2].y);
    out_real(p[3].x);
    out_real(p[3].y);",
    },
    Probe {
        name: "hull_reach_sq",
        inputs: 8,
        outputs: 1,
        body: "let a = in_real();
    let b = in_real();
    let c = in_real();
    let d = in_real();
    let e = in_real();
    let f = in_real();
    let g = in_real();
    let h = in_real();
    let p = array<vec2<Real>, 4>(vec2<Real>(a, b), vec2<Real>(c, d), vec2<Real>(e, f), vec2<Real>(g, h));
    out_real(hull_reach_sq(p));",
    },
    Probe {
        name: "free_flight_certain",
        inputs: CONSTS + 2 * S + 1,
        outputs: 1,
        body: "let lc = in_consts();
    let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    out_bool(free_flight_certain(lc, x0, x1, hs));",
    },
    Probe {
        name: "clear_of_stator",
        inputs: 1 + 2 * S + 1,
        outputs: 1,
        body: "let delta = in_real();
    let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    out_bool(clear_of_stator(delta, x0, x1, hs));",
    },
    Probe {
        name: "in_contact_certain",
        inputs: 1 + 2 * S + 2,
        outputs: 1,
        body: "let delta = in_real();
    let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    let max_pen = in_real();
    out_bool(in_contact_certain(delta, x0, x1, hs, max_pen));",
    },
    Probe {
        name: "search_needless",
        inputs: 1 + 2 * S + 3,
        outputs: 1,
        body: "let delta = in_real();
    let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    let contact = in_bool();
    let max_pen = in_real();
    out_bool(search_needless(delta, x0, x1, hs, contact, max_pen));",
    },
    Probe {
        name: "find_switch",
        inputs: CONSTS + 2 * S + 2,
        outputs: 2,
        body: "let lc = in_consts();
    let x0 = in_state();
    let x1 = in_state();
    let hs = in_real();
    let contact = in_bool();
    let sw = find_switch(lc, x0, x1, hs, contact);
    out_real(sw.theta);
    out_real(sw.max_g);",
    },
    Probe {
        name: "trial_extent",
        inputs: CONSTS + 2,
        outputs: 2,
        body: "let lc = in_consts();
    let s = in_real();
    let contact = in_bool();
    let e = trial_extent(lc, s, contact);
    out_real(e.ds);
    out_real(e.end);",
    },
    // lane.rs's macro_step(_tangent) is the kernel's macro_step_begin, macro_step until
    // done, macro_step_end (what advance_lanes runs, without the slicing).
    Probe {
        name: "macro_step",
        inputs: CONSTS + S + 2 + S,
        outputs: S + 3 + 5 + S,
        body: "let lc = in_consts();
    let x = in_state();
    let contact = in_u32();
    let k = in_u32();
    var v = in_state();
    let lane = Lane(x, contact, k, STATUS_OK, 0u, Counters(0u, 0u, 0u, 0u, Real(0.0)));
    var ms = macro_step_begin(lc, lane);
    for (var it = 0u; it < 4096u; it++) {
        macro_step(lc, k, &ms, &v);
        if ms.done {
            break;
        }
    }
    var next = lane;
    macro_step_end(lc, &next, ms);
    out_state(next.x);
    out_real(Real(next.contact));
    out_real(Real(next.k));
    out_real(Real(next.status));
    out_real(Real(next.counters.macro_steps));
    out_real(Real(next.counters.contact_steps));
    out_real(Real(next.counters.switches));
    out_real(Real(next.counters.extra_substeps));
    out_real(next.counters.max_penetration);
    out_state(v);",
    },
];

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

// ---- the functions, one test each ------------------------------------------------------

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
    assert_mirrors(runner, "pow_half", &powers);
    assert_mirrors(runner, "contact_force_per_kc_law", &law);
    assert_mirrors(runner, "contact_force_lane", &lane);
    assert_mirrors(runner, "contact_partials_law_off_centre", &law_partials);
}

/// relative_motion, penetration, contact_force_per_kc and contact_partials (model.wgsl),
/// and the contact laws' pow_half, forces and partials.
#[test]
fn penetration_and_contact_force_and_its_partials_on_the_gpu_equal_the_rust_functions_bit_for_bit()
{
    both_precisions!(check_penetration_and_contact_force);
}

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

/// find_switch's rows: (lane constants, x0, x1, hs, mode) of trial sub-steps.
type SwitchArgs<R> = (LaneConsts<R>, [R; STATE_DIM], [R; STATE_DIM], R, bool);

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
    let this = include_str!("mirror.rs");
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
