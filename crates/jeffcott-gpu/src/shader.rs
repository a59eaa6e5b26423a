//! Assembles the lane kernel: a header generated from the Rust constants, then the
//! kernel's parts (`integrate::lane::WGSL_FILES`, each beside the Rust module it mirrors,
//! concatenated in a fixed order). docs/architecture.md: constants shared with the kernel are
//! defined once, here and in `integrate::lane` / `model`, and written into the source
//! when the pipeline is built.
//!
//! Floating constants are written as abstract-float literals holding the exact `f64`
//! value that the CPU lane passes to `Real::lit` (Rust's `{:e}` formatting is the
//! shortest text that parses back to the same `f64`, and naga parses with Rust's
//! `str::parse::<f64>`). naga then converts each one to `Real` with `value as f32` /
//! exactly, which is `Real::lit`; the test `header_constants_are_real_lit_of_the_rust_values`
//! checks the outcome in the parsed module.

use jeffcott_core::integrate::lane::{
    GRAZE_SAMPLES, LaneConsts, ROOT_MAX_ITERS, Status, WGSL_FILES,
};
use jeffcott_core::model::{STATE_DIM, Terms, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S};
use jeffcott_core::real::Real;
use std::fmt::Write;
use wgpu::naga;

/// Invocations per workgroup of the lane kernel (one lane per invocation). 64 is a
/// multiple of every vendor's SIMD width and well inside the default limit of 256.
pub const WORKGROUP_SIZE: u32 = 64;

/// Name of the kernel's entry point.
pub const ENTRY_POINT: &str = "advance_lanes";

/// The kernel body: the WGSL mirror of `jeffcott_core::integrate::lane` (and of the
/// `model` and `integrate::forcing` functions it calls), its parts kept beside the Rust
/// modules they mirror in that crate.
pub const KERNEL: &str = jeffcott_core::integrate::lane::WGSL;

pub use jeffcott_core::integrate::forcing::phasor_coefficients;

/// The largest finite value of the precision, as `f64`.
fn real_max<R: Real>() -> f64 {
    if R::WGSL_NAME == "f64" {
        f64::MAX
    } else {
        f32::MAX as f64
    }
}

/// An abstract-float WGSL literal with exactly the value `x` (finite).
fn float_lit(x: f64) -> String {
    debug_assert!(x.is_finite());
    format!("{x:e}")
}

/// Every floating constant of the header, as (name, exact f64 value before rounding to
/// `Real`).
pub fn float_constants<R: Real>() -> Vec<(String, f64)> {
    let (sin, cos) = phasor_coefficients();
    let mut v = vec![
        ("REAL_MAX".to_string(), real_max::<R>()),
        ("TAU".to_string(), std::f64::consts::TAU),
        ("SIXTH".to_string(), 1.0 / 6.0),
        (
            "CERTIFICATE_SAFETY".to_string(),
            jeffcott_core::integrate::lane::certificate_safety::<R>(),
        ),
    ];
    for n in 0..9 {
        v.push((format!("SIN_C{n}"), sin[n]));
        v.push((format!("COS_C{n}"), cos[n]));
    }
    v
}

/// Which lane kernel, beside its precision (the type parameter).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Variant {
    /// One tangent vector per lane for lambda_1 (`false`: the plain kernel).
    pub lyapunov: bool,
    /// f32 only: divide and take square roots through f64 (`div_rn`, `sqrt_rn` in the
    /// header). Each is then correctly rounded to f32 whatever the driver's own f32
    /// division and sqrt do (Vulkan allows 2.5 ulp, and NVIDIA's differ from the CPU's,
    /// docs/gpu.md): the exact quotient or root rounded to f64 and then to f32 is the
    /// exact value rounded to f32 once, because double rounding is innocuous for / and
    /// sqrt when the wider format has at least 2p + 2 significand bits (53 >= 2 x 24 + 2;
    /// S. A. Figueroa, "When is double rounding innocuous?", SIGNUM Newsl. 30(3), 1995).
    /// It needs SHADER_F64 and f64 division and sqrt correctly rounded, as the f64
    /// kernel's bit-identity already does. Without f64 the f32 kernel uses the driver's
    /// own, equal to the CPU's only where those round correctly (lavapipe).
    pub f32_through_f64: bool,
    /// Macro steps begun in free flight may take the exact free-flight map (lanes whose
    /// constants carry one; `EXACT_FREE_FLIGHT` in the header). Off, that code is dead
    /// and removed: llvmpipe would otherwise run it at every sub-step (it executes both
    /// arms of an `if`).
    pub exact_free_flight: bool,
    /// The optional terms of the equations some lane uses (docs/model.md 7), each a
    /// constant of the header. `STATOR_OFFSET`: the stator's springs pull towards its
    /// rest centre; off, the subtraction of a zero centre is not in the kernel (the same
    /// bits). `ANISOTROPIC`: the y coefficients are read; off, the x ones serve both
    /// directions (an isotropic lane's are the same bits), four coefficients fewer read
    /// per evaluation. `CONTACT_LAW`: a lane whose contact is a power law or has
    /// Hunt-Crossley damping takes that law; off, only the linear spring is in the kernel.
    /// So the article's model keeps its speed.
    pub terms: Terms,
    /// The GPU form of the entry point (`CONSTS_EACH_STEP` in the header:
    /// `advance_buffered` in lane_entry.wgsl, docs/gpu.md): the lane's constants read at
    /// every sub-step, the committed lane and its tangent kept in their buffers, the
    /// switch search's samples evaluated as its scan reaches them, so that few values
    /// are live across the loop (a SIMT GPU holds them all in registers; RADV's
    /// statistics for a virtual RDNA3 GPU: the f64 kernel's spilled VGPRs 151 -> 23 with
    /// per-lane constants). Off, the software form (`advance_held`): constants and lane
    /// held in registers, the samples hoisted, what lavapipe needs (its loads are 8-lane
    /// gathers, and it runs every arm of every `if`). The arithmetic is the same.
    pub consts_each_step: bool,
    /// The fields of the lane constants ([`crate::layout::CONST_FIELDS`], bit `k` for
    /// field `k`) that every lane of the run has equal, read from the buffer's first
    /// element (`lane_consts` in the header): one address for the whole dispatch, which
    /// a GPU reads once per wave into scalar registers or its constant cache instead of
    /// holding a copy per invocation in vector registers (RADV, the f64 kernel's GPU
    /// form: 23 spilled VGPRs with every field per lane, 0 with all shared, 0 for a
    /// speed sweep's mask; docs/gpu.md). The runner sets the fields equal byte for byte
    /// across the run's lanes ([`crate::layout::shared_fields`]): all of them in a
    /// basin or the standard job, all but the speed's in a speed sweep.
    pub shared_fields: u32,
    /// The GPU form's lean free-flight path looks the unbalance phasor up in a table
    /// (`FORCING_TABLE` in the header; the binding `forcing_table`, written by the
    /// runner from [`crate::layout::forcing_table`]) instead of evaluating its polynomial
    /// three times a macro step: for runs whose lanes share N and phi0
    /// ([`crate::layout::FORCING_FIELDS`]). The same bits either way.
    pub forcing_table: bool,
}

impl Variant {
    /// The kernel a device runs: `lyapunov` or not, f32's division and sqrt through f64
    /// where the device has SHADER_F64.
    pub fn on_device(lyapunov: bool, device_has_f64: bool) -> Self {
        Self {
            lyapunov,
            f32_through_f64: device_has_f64,
            exact_free_flight: false,
            terms: Terms::NONE,
            consts_each_step: false,
            shared_fields: 0,
            forcing_table: false,
        }
    }

    /// This variant reading the lane constants at every sub-step, or once.
    pub fn with_consts_each_step(self, on: bool) -> Self {
        Self {
            consts_each_step: on,
            ..self
        }
    }

    /// This variant reading the fields of `mask` at one address for every lane, the
    /// others each lane's own.
    pub fn with_shared_fields(self, mask: u32) -> Self {
        Self {
            shared_fields: mask,
            ..self
        }
    }

    /// This variant with the lean path's forcing table on or off: on only in the GPU
    /// form without lambda_1 (which have the lean path) and where the shared fields
    /// cover [`crate::layout::FORCING_FIELDS`] (the lanes share N and phi0), so set the
    /// form and the shared fields first.
    pub fn with_forcing_table(self, on: bool) -> Self {
        let table = crate::layout::FORCING_FIELDS;
        Self {
            forcing_table: on
                && self.consts_each_step
                && !self.lyapunov
                && self.shared_fields & table == table,
            ..self
        }
    }

    /// This variant with the exact free-flight step on or off.
    pub fn with_exact_free_flight(self, on: bool) -> Self {
        Self {
            exact_free_flight: on,
            ..self
        }
    }

    /// This variant with the code that the lanes' `features` need, and no other.
    pub fn with_features(self, features: Features) -> Self {
        Self {
            exact_free_flight: features.exact,
            terms: features.terms,
            ..self
        }
    }

    /// The plain kernel, f32 with the driver's own division and sqrt (no f64 needed).
    pub const PLAIN: Self = Self {
        lyapunov: false,
        f32_through_f64: false,
        exact_free_flight: false,
        terms: Terms::NONE,
        consts_each_step: false,
        shared_fields: 0,
        forcing_table: false,
    };

    /// True when precision `R`'s kernel uses f64 arithmetic (and needs FLOAT64).
    fn uses_f64<R: Real>(self) -> bool {
        R::WGSL_NAME == "f64" || self.f32_through_f64
    }
}

/// What a run's lanes need of the kernel beyond the article's model, decided from their
/// constants when the kernel is built: code no lane needs is not in the kernel at all
/// (llvmpipe runs both arms of every `if`, and a GPU holds registers for them).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Features {
    /// Some lane takes the exact free-flight map ([`Variant::exact_free_flight`]).
    pub exact: bool,
    /// The optional terms some lane's equations use ([`Variant::terms`]).
    pub terms: Terms,
}

impl Features {
    /// The features lanes with constants `consts` need.
    pub fn of<R: Real>(consts: &[LaneConsts<R>]) -> Self {
        consts
            .iter()
            .fold(Features::default(), |f, lc| f.or(Features::lane(lc)))
    }

    /// The features one lane needs: the terms its constructor decided, which the CPU
    /// batch also uses.
    pub fn lane<R: Real>(lc: &LaneConsts<R>) -> Self {
        Features {
            exact: lc.exact.is_some(),
            terms: lc.terms,
        }
    }

    /// Both sets.
    pub fn or(self, other: Self) -> Self {
        Features {
            exact: self.exact || other.exact,
            terms: self.terms.or(other.terms),
        }
    }

    /// Whether a kernel with these features runs a lane that needs `lane`'s.
    pub fn covers(self, lane: Self) -> bool {
        self.or(lane) == self
    }
}

/// Reals per record: the state, and with `lyapunov` the tangent's growth after it.
pub fn record_dim(lyapunov: bool) -> usize {
    STATE_DIM + lyapunov as usize
}

/// The generated header for precision `R` and kernel variant `v` (see [`Variant`]).
pub fn header<R: Real>(v: Variant) -> String {
    let lyapunov = v.lyapunov;
    let mut h = String::new();
    let mut line = |s: String| {
        h.push_str(&s);
        h.push('\n');
    };
    line("// Generated by jeffcott-gpu's shader.rs from the Rust constants; do not edit.".into());
    line(format!("alias Real = {};", R::WGSL_NAME));
    let u = [
        ("WORKGROUP_SIZE", WORKGROUP_SIZE),
        ("STATE_DIM", STATE_DIM as u32),
        ("X_R", X_R as u32),
        ("VX_R", VX_R as u32),
        ("Y_R", Y_R as u32),
        ("VY_R", VY_R as u32),
        ("X_S", X_S as u32),
        ("VX_S", VX_S as u32),
        ("Y_S", Y_S as u32),
        ("VY_S", VY_S as u32),
        ("GRAZE_SAMPLES", GRAZE_SAMPLES),
        ("ROOT_MAX_ITERS", ROOT_MAX_ITERS),
        ("STATUS_OK", Status::Ok.code()),
        ("STATUS_REFINEMENT_CAP", Status::RefinementCap.code()),
        ("STATUS_DIVERGED", Status::Diverged.code()),
        ("STATUS_NON_FINITE", Status::NonFinite.code()),
        ("RECORD_DIM", record_dim(lyapunov) as u32),
    ];
    for (name, value) in u {
        line(format!("const {name}: u32 = {value}u;"));
    }
    line(format!("const LYAPUNOV: bool = {lyapunov};"));
    line(format!(
        "const EXACT_FREE_FLIGHT: bool = {};",
        v.exact_free_flight
    ));
    line(format!("const STATOR_OFFSET: bool = {};", v.terms.offset));
    line(format!(
        "const ANISOTROPIC: bool = {};",
        v.terms.anisotropic
    ));
    line(format!(
        "const CONTACT_LAW: bool = {};",
        v.terms.contact_law
    ));
    line(format!(
        "const CONSTS_EACH_STEP: bool = {};",
        v.consts_each_step
    ));
    line(format!("const FORCING_TABLE: bool = {};", v.forcing_table));
    for (name, value) in float_constants::<R>() {
        line(format!("const {name}: Real = {};", float_lit(value)));
    }
    // Every division and square root of the kernel goes through these (the names of
    // CUDA's correctly rounded intrinsics, __fdiv_rn and __fsqrt_rn); see Variant.
    if R::WGSL_NAME == "f32" && v.f32_through_f64 {
        line("fn div_rn(a: Real, b: Real) -> Real { return Real(f64(a) / f64(b)); }".into());
        line("fn sqrt_rn(x: Real) -> Real { return Real(sqrt(f64(x))); }".into());
    } else {
        line("fn div_rn(a: Real, b: Real) -> Real { return a / b; }".into());
        line("fn sqrt_rn(x: Real) -> Real { return sqrt(x); }".into());
    }
    let mut s = h;
    s.push_str(&lane_consts_fn(v.shared_fields, v.consts_each_step));
    let _ = writeln!(s);
    s
}

/// The kernel's `lane_consts(i)`: lane `i`'s constants, the fields of `mask` read from
/// the first lane's (see [`Variant::shared_fields`]): from `consts[0]` in the software
/// form, from the uniform `shared_consts` in the GPU form (`from_uniform`).
fn lane_consts_fn(mask: u32, from_uniform: bool) -> String {
    use crate::layout::{ALL_FIELDS, CONST_FIELDS};
    let mut f = String::from("fn lane_consts(i: u32) -> LaneConsts {\n");
    let all = mask & ALL_FIELDS == ALL_FIELDS;
    if all && !from_uniform {
        f.push_str("    return consts[0];\n}\n");
        return f;
    }
    f.push_str(if all {
        "    var lc: LaneConsts;\n"
    } else {
        "    var lc = consts[i];\n"
    });
    for k in (0..CONST_FIELDS.len()).filter(|k| mask & (1 << k) != 0) {
        for (path, uniform) in shared_field_parts(k) {
            let source = if from_uniform {
                uniform
            } else {
                format!("consts[0].{path}")
            };
            let _ = writeln!(f, "    lc.{path} = {source};");
        }
    }
    f.push_str("    return lc;\n}\n");
    f
}

/// The scalar parts of field `k` of [`crate::layout::CONST_FIELDS`]: each one's path in
/// `LaneConsts` and where `shared_consts` (lane_buffers.wgsl) holds it. The reals are in
/// the struct's order, so the free-flight map's reals follow the scalars.
fn shared_field_parts(k: usize) -> Vec<(String, String)> {
    use crate::layout::{CONST_FIELDS, SCALAR_FIELDS};
    let real = |r: usize| format!("shared_consts.r[{}].{}", r / 4, ["x", "y", "z", "w"][r % 4]);
    match CONST_FIELDS[k] {
        "ff" => {
            let arrays = [("phi", 16), ("off", 4), ("p", 4), ("q", 4)];
            let mut parts = Vec::new();
            for (name, len) in arrays {
                for j in 0..len {
                    parts.push((format!("ff.{name}[{j}]"), real(SCALAR_FIELDS + parts.len())));
                }
            }
            parts.push(("ff.omega".into(), real(SCALAR_FIELDS + parts.len())));
            parts
        }
        "n" => ["n", "max_segments", "exact"]
            .iter()
            .zip(["x", "y", "z"])
            .map(|(int, c)| (int.to_string(), format!("shared_consts.ints.{c}")))
            .collect(),
        path => vec![(path.into(), real(k))],
    }
}

/// The complete kernel source for precision `R` and variant `v`: the header, then
/// [`KERNEL`] with its counted loops written out ([`crate::unroll`]: every index a
/// constant, so no array goes to local memory and no loop needs a bound counter).
pub fn source<R: Real>(v: Variant) -> String {
    header::<R>(v)
        + &crate::unroll::unroll_counted_loops(KERNEL, &[("STATE_DIM", STATE_DIM as u32)])
}

/// naga capabilities the kernel needs in precision `R` and variant `v`.
pub fn capabilities<R: Real>(v: Variant) -> naga::valid::Capabilities {
    if v.uses_f64::<R>() {
        naga::valid::Capabilities::FLOAT64
    } else {
        naga::valid::Capabilities::empty()
    }
}

/// Where line `line` (1-based) of [`source`] comes from: "the generated header" or a
/// part of the kernel (`integrate::lane::WGSL_FILES`), with the line number in that file.
pub fn origin<R: Real>(v: Variant, line: usize) -> String {
    let header_lines = header::<R>(v).lines().count();
    if line <= header_lines {
        return format!("the generated header, line {line}");
    }
    let mut first = header_lines;
    for (path, text) in WGSL_FILES {
        let n = text.lines().count();
        if line <= first + n {
            return format!("{path}, line {}", line - first);
        }
        first += n;
    }
    format!("line {line}, past the end of the kernel")
}

/// naga's report on an error in [`source`], with the file and line its first location
/// comes from (the report's own line numbers count from the start of the header).
fn report<R: Real>(v: Variant, emitted: String, at: Option<naga::SourceLocation>) -> String {
    match at {
        Some(loc) => format!(
            "{emitted}(the kernel's line {} is {})",
            loc.line_number,
            origin::<R>(v, loc.line_number as usize)
        ),
        None => emitted,
    }
}

/// Parses the kernel for precision `R` and variant `v`; the error is naga's report with
/// source context.
pub fn parse<R: Real>(v: Variant) -> Result<naga::Module, String> {
    parse_source::<R>(v, &source::<R>(v))
}

/// [`parse`] for `src`, the kernel of precision `R` and variant `v` with more after it.
fn parse_source<R: Real>(v: Variant, src: &str) -> Result<naga::Module, String> {
    naga::front::wgsl::parse_str(src).map_err(|e| {
        let emitted = e.emit_to_string_with_path(src, "lane kernel");
        report::<R>(v, emitted, e.location(src))
    })
}

/// Parses and validates the kernel for precision `R` and variant `v` with the
/// capabilities `caps` (the kernel needs [`capabilities`]).
pub fn validate<R: Real>(
    v: Variant,
    caps: naga::valid::Capabilities,
) -> Result<(naga::Module, naga::valid::ModuleInfo), String> {
    validate_source::<R>(v, &source::<R>(v), caps)
}

/// [`validate`] for `src`: the kernel of precision `R` and variant `v` with more after
/// it (the anatomy's entry points, `crate::anatomy::source`); errors name the kernel's
/// file and line as [`parse`] does.
pub fn validate_source<R: Real>(
    v: Variant,
    src: &str,
    caps: naga::valid::Capabilities,
) -> Result<(naga::Module, naga::valid::ModuleInfo), String> {
    let module = parse_source::<R>(v, src)?;
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps)
        .validate(&module)
        .map_err(|e| {
            let emitted = e.emit_to_string_with_path(src, "lane kernel");
            report::<R>(v, emitted, e.location(src))
        })?;
    Ok((module, info))
}

#[cfg(test)]
mod tests {
    use super::*;
    use jeffcott_core::integrate::forcing::phasor_turns;

    /// Every variant of both precisions, and the capabilities each needs.
    fn variants() -> Vec<Variant> {
        let mut v = Vec::new();
        for lyapunov in [false, true] {
            for f32_through_f64 in [false, true] {
                for (exact, machine) in [(false, false), (true, false), (false, true), (true, true)]
                {
                    for consts_each_step in [false, true] {
                        for shared_fields in [0, 1 << 4, crate::layout::ALL_FIELDS] {
                            let v0 = Variant {
                                lyapunov,
                                f32_through_f64,
                                exact_free_flight: false,
                                terms: Terms::NONE,
                                consts_each_step,
                                shared_fields,
                                forcing_table: false,
                            }
                            .with_features(Features {
                                exact,
                                terms: if machine { Terms::ALL } else { Terms::NONE },
                            });
                            v.push(v0);
                            if v0.with_forcing_table(true).forcing_table {
                                v.push(v0.with_forcing_table(true));
                            }
                        }
                    }
                }
            }
        }
        v
    }

    #[test]
    fn f32_kernel_parses_and_validates_without_an_adapter() {
        let (module, _) = validate::<f32>(Variant::PLAIN, capabilities::<f32>(Variant::PLAIN))
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(module.entry_points.iter().any(|e| e.name == ENTRY_POINT));
        // The plain f32 kernel needs no f64 (it runs on adapters without SHADER_F64).
        assert!(capabilities::<f32>(Variant::PLAIN).is_empty());
    }

    #[test]
    fn every_variant_parses_and_validates_in_both_precisions() {
        for v in variants() {
            let (module, _) =
                validate::<f32>(v, capabilities::<f32>(v)).unwrap_or_else(|e| panic!("{e}"));
            assert!(module.entry_points.iter().any(|e| e.name == ENTRY_POINT));
            validate::<f64>(v, capabilities::<f64>(v)).unwrap_or_else(|e| panic!("{e}"));
            let lyapunov = format!("const LYAPUNOV: bool = {};", v.lyapunov);
            assert!(header::<f32>(v).contains(&lyapunov));
        }
        assert!(
            header::<f64>(Variant::on_device(true, true)).contains("const RECORD_DIM: u32 = 9u;")
        );
    }

    #[test]
    fn f64_kernel_parses_and_validates_with_float64() {
        let v = Variant::PLAIN;
        let (module, _) =
            validate::<f64>(v, capabilities::<f64>(v)).unwrap_or_else(|e| panic!("{e}"));
        assert!(module.entry_points.iter().any(|e| e.name == ENTRY_POINT));
        // And the capability is really what makes it valid: f64 is not core WGSL.
        let err = validate::<f64>(v, naga::valid::Capabilities::empty()).unwrap_err();
        assert!(err.contains("FLOAT64"), "{err}");
    }

    #[test]
    fn f32_through_f64_divides_and_takes_roots_in_f64_and_needs_float64() {
        let v = Variant::on_device(false, true);
        let h = header::<f32>(v);
        assert!(h.contains("return Real(f64(a) / f64(b));"), "{h}");
        assert!(h.contains("return Real(sqrt(f64(x)));"), "{h}");
        assert!(!header::<f32>(Variant::PLAIN).contains("f64("));
        // In f64 the two are the plain operations whatever the variant says.
        assert!(!header::<f64>(v).contains("f64("));
        // Without FLOAT64 naga refuses the widening (its first use, in div_rn).
        let err = validate::<f32>(v, naga::valid::Capabilities::empty()).unwrap_err();
        assert!(err.contains("'div_rn' is invalid"), "{err}");
        // And the kernel divides and takes square roots nowhere else at run time (naga
        // evaluates the constant quotients k / GRAZE_SAMPLES when it parses, exactly).
        for (path, text) in WGSL_FILES {
            for (i, l) in text.lines().enumerate() {
                let mut code = l.split("//").next().unwrap_or("").to_string();
                for k in 0..=GRAZE_SAMPLES {
                    code = code.replace(&format!("Real({k}u) / Real(GRAZE_SAMPLES)"), "");
                }
                assert!(
                    !code.contains(" / ") && !code.contains("sqrt("),
                    "{path}:{}: division or sqrt outside div_rn/sqrt_rn: {l}",
                    i + 1
                );
            }
        }
    }

    #[test]
    fn kernel_is_its_parts_in_order_and_errors_name_the_part() {
        let joined: String = WGSL_FILES.iter().map(|(_, text)| *text).collect();
        assert_eq!(KERNEL, joined);
        for (path, text) in WGSL_FILES {
            assert!(text.ends_with('\n'), "{path} does not end with a newline");
        }
        let v = Variant::PLAIN;
        let h = header::<f32>(v).lines().count();
        assert_eq!(origin::<f32>(v, 1), "the generated header, line 1");
        assert_eq!(
            origin::<f32>(v, h + 1),
            "integrate/lane_buffers.wgsl, line 1"
        );
        let lines = |i: usize| WGSL_FILES[i].1.lines().count();
        assert_eq!(
            origin::<f32>(v, h + lines(0) + lines(1) + 3),
            "model.wgsl, line 3"
        );
    }

    /// The rule `div_rn` and `sqrt_rn` rest on (Variant): f32 division and sqrt done in
    /// f64 and rounded to f32 give the f32 operations' own results, on random operands
    /// over the whole exponent range and on the awkward ones (halfway-looking quotients,
    /// the largest and smallest normals, subnormals, zeros, infinities, NaN).
    #[test]
    fn f32_division_and_sqrt_through_f64_equal_the_f32_operations() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            f32::from_bits((seed >> 32) as u32)
        };
        let mut special = vec![
            0.0f32,
            -0.0,
            1.0,
            3.0,
            7.0,
            10.0,
            f32::MAX,
            f32::MIN_POSITIVE,
            f32::MIN_POSITIVE / 3.0,
            f32::from_bits(1),
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1.0 + f32::EPSILON,
            2.0 - f32::EPSILON,
        ];
        special.extend(special.clone().iter().map(|x| -x));
        // Half over every bit pattern, half with exponents within 2^+-16 (the model's
        // range: metres, seconds, newtons), where no quotient overflows or underflows.
        let near_one = |x: f32| {
            let bits = x.to_bits();
            let e = 127 + ((bits >> 23) & 31) - 16;
            f32::from_bits((bits & 0x807f_ffff) | (e << 23))
        };
        let mut pairs: Vec<(f32, f32)> = (0..1_000_000).map(|_| (next(), next())).collect();
        pairs.extend((0..1_000_000).map(|_| (near_one(next()), near_one(next()))));
        for &a in &special {
            for &b in &special {
                pairs.push((a, b));
            }
        }
        let same = |x: f32, y: f32| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
        for (a, b) in pairs {
            let q = (a as f64 / b as f64) as f32;
            assert!(same(q, a / b), "{a:e} / {b:e}: {q:e} against {:e}", a / b);
            let r = (a as f64).sqrt() as f32;
            assert!(
                same(r, a.sqrt()),
                "sqrt({a:e}): {r:e} against {:e}",
                a.sqrt()
            );
        }
    }

    /// The value of a named `const` of the module, widened to f64.
    fn const_value(module: &naga::Module, name: &str) -> f64 {
        let (_, c) = module
            .constants
            .iter()
            .find(|(_, c)| c.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("constant {name} missing"));
        match module.global_expressions[c.init] {
            naga::Expression::Literal(naga::Literal::F32(v)) => v as f64,
            naga::Expression::Literal(naga::Literal::F64(v)) => v,
            ref e => panic!("{name} is not a float literal: {e:?}"),
        }
    }

    #[test]
    fn header_constants_are_real_lit_of_the_rust_values() {
        let m32 = parse::<f32>(Variant::PLAIN).unwrap_or_else(|e| panic!("{e}"));
        for (name, v) in float_constants::<f32>() {
            let got = const_value(&m32, &name);
            assert_eq!(
                got.to_bits(),
                f32::lit(v).to_f64().to_bits(),
                "{name} (f32)"
            );
        }
        let m64 = parse::<f64>(Variant::PLAIN).unwrap_or_else(|e| panic!("{e}"));
        for (name, v) in float_constants::<f64>() {
            assert_eq!(
                const_value(&m64, &name).to_bits(),
                v.to_bits(),
                "{name} (f64)"
            );
        }
        // Spot checks that the table itself is what forcing.rs and lane.rs use.
        assert_eq!(const_value(&m32, "SIXTH"), (1.0f64 / 6.0) as f32 as f64);
        assert_eq!(const_value(&m32, "REAL_MAX"), f32::MAX as f64);
        assert_eq!(const_value(&m64, "TAU"), std::f64::consts::TAU);
    }

    /// `phasor_turns` re-implemented on the header's coefficient table, in Rust.
    fn phasor_from_table<R: Real>(turns: R) -> (R, R) {
        let (sin, cos) = phasor_coefficients();
        let t = turns - turns.floor();
        let q = (t * R::lit(4.0) + R::lit(0.5)).floor();
        let f = t - q * R::lit(0.25);
        let a = f * R::lit(std::f64::consts::TAU);
        let a2 = a * a;
        let mut s = R::lit(sin[8]);
        let mut c = R::lit(cos[8]);
        for n in (0..8).rev() {
            s = R::lit(sin[n]) + a2 * s;
            c = R::lit(cos[n]) + a2 * c;
        }
        let s = a * s;
        match (q.to_f64() as i32) & 3 {
            0 => (c, s),
            1 => (-s, c),
            2 => (-c, -s),
            _ => (s, -c),
        }
    }

    #[test]
    fn header_phasor_reproduces_cpu_phasor_bit_for_bit() {
        fn same<R: Real>(turns: R) {
            let (c, s) = phasor_from_table(turns);
            let (cr, sr) = phasor_turns(turns);
            let bits = |a: R, b: R| (a.to_f64().to_bits(), b.to_f64().to_bits());
            assert_eq!(bits(c, s), bits(cr, sr), "{turns:?}");
        }
        for i in 0..50_000 {
            let turns = -2.0 + i as f64 * 9.7e-5;
            same(turns);
            same(turns as f32);
        }
    }

    /// Top-level WGSL functions of a part, in order (`fn name(` at the start of a line).
    fn wgsl_functions(text: &str) -> Vec<&str> {
        text.lines()
            .filter_map(|l| l.strip_prefix("fn "))
            .map(|l| &l[..l.find('(').expect("fn name(")])
            .collect()
    }

    /// Where `fn name` is defined in Rust source `src`.
    fn rust_position(src: &str, name: &str) -> Option<usize> {
        ["(", "<"]
            .iter()
            .filter_map(|open| src.find(&format!("fn {name}{open}")))
            .min()
    }

    #[test]
    fn kernel_mirrors_lane_rs_function_by_function_in_order() {
        // Each part of the kernel beside its Rust module: the mirrored functions (in the
        // order of the .rs file, which the .wgsl file must keep), then the kernel-only
        // functions the part may hold besides (GPU stand-ins, the resumable macro step's
        // pieces, the entry point that replaces advance_period).
        struct Mirror {
            wgsl: &'static str,
            rs: Option<(&'static str, &'static str)>,
            mirrored: &'static [&'static str],
            kernel_only: &'static [&'static str],
        }
        let lane_rs = include_str!("../../jeffcott-core/src/integrate/lane.rs");
        let mirrors = [
            Mirror {
                wgsl: "integrate/lane_buffers.wgsl",
                rs: None,
                mirrored: &[],
                kernel_only: &["rmax", "is_finite", "is_frozen", "keep", "sat_add"],
            },
            Mirror {
                wgsl: "integrate/forcing.wgsl",
                rs: Some((
                    "integrate/forcing.rs",
                    include_str!("../../jeffcott-core/src/integrate/forcing.rs"),
                )),
                mirrored: &["phasor_turns"],
                kernel_only: &[],
            },
            Mirror {
                wgsl: "model.wgsl",
                rs: Some(("model.rs", include_str!("../../jeffcott-core/src/model.rs"))),
                mirrored: &[
                    "relative_motion",
                    "penetration",
                    "contact_force_per_kc",
                    "pow_half",
                    "contact_force_per_kc_law",
                    "contact_force_lane",
                    "contact_partials",
                    "contact_block",
                    "contact_partials_law_off_centre",
                    "rhs_frozen",
                ],
                kernel_only: &["contact_law", "y_coeffs"],
            },
            Mirror {
                wgsl: "integrate/tangent.wgsl",
                rs: Some((
                    "integrate/tangent.rs",
                    include_str!("../../jeffcott-core/src/integrate/tangent.rs"),
                )),
                mirrored: &[
                    "stage_partials",
                    "tangent_rhs",
                    "rk4_tangent_substep",
                    "saltation",
                    "renormalise",
                ],
                kernel_only: &[],
            },
            Mirror {
                wgsl: "integrate/switch.wgsl",
                rs: Some((
                    "integrate/switch.rs",
                    include_str!("../../jeffcott-core/src/integrate/switch.rs"),
                )),
                mirrored: &[
                    "hermite_gap",
                    "wrong_side",
                    "control_points",
                    "hull_reach_sq",
                    "free_flight_certain",
                    "clear_of_stator",
                    "in_contact_certain",
                    "search_needless",
                    "find_switch",
                ],
                kernel_only: &["scan_sample"],
            },
            Mirror {
                wgsl: "integrate/free_flight.wgsl",
                rs: Some((
                    "integrate/free_flight.rs",
                    include_str!("../../jeffcott-core/src/integrate/free_flight.rs"),
                )),
                mirrored: &["free_flight_step", "free_flight_tangent"],
                kernel_only: &["free_flight_map"],
            },
            Mirror {
                wgsl: "integrate/lane.wgsl",
                rs: Some(("integrate/lane.rs", lane_rs)),
                mirrored: &[
                    "forcing_phasor",
                    "rk4_substep",
                    "trial_extent",
                    "macro_step",
                    "trial_tangent",
                ],
                kernel_only: &["rk4_stages", "macro_step_begin", "macro_step_end"],
            },
            Mirror {
                wgsl: "integrate/lane_entry.wgsl",
                rs: None,
                mirrored: &[],
                kernel_only: &[
                    "loop_budget_left",
                    "record",
                    "advance_lanes",
                    "advance_held",
                    "advance_buffered",
                    "lean_free_flight",
                    "lean_phasor",
                    "in_bounds",
                    "state_finite",
                    "state_reach",
                ],
            },
        ];
        assert_eq!(
            mirrors.iter().map(|m| m.wgsl).collect::<Vec<_>>(),
            WGSL_FILES.iter().map(|(p, _)| *p).collect::<Vec<_>>(),
            "the kernel's parts"
        );
        let module = parse::<f64>(Variant::on_device(true, true)).unwrap_or_else(|e| panic!("{e}"));
        let in_module: Vec<&str> = module
            .functions
            .iter()
            .filter_map(|(_, f)| f.name.as_deref())
            .chain(module.entry_points.iter().map(|e| e.name.as_str()))
            .collect();
        for (m, (_, text)) in mirrors.iter().zip(WGSL_FILES) {
            let found = wgsl_functions(text);
            // Every function of the part is accounted for, and the mirrored ones come in
            // the .rs file's order.
            let mirrored: Vec<&str> = found
                .iter()
                .copied()
                .filter(|f| !m.kernel_only.contains(f))
                .collect();
            assert_eq!(mirrored, m.mirrored, "{}: functions or their order", m.wgsl);
            for f in &found {
                assert!(
                    in_module.contains(f),
                    "{f} of {} not in the parsed kernel",
                    m.wgsl
                );
            }
            for f in m.kernel_only {
                assert!(found.contains(f), "{}: {f} missing", m.wgsl);
            }
            let file = m.wgsl.rsplit('/').next().unwrap();
            match m.rs {
                Some((rs_path, rs)) => {
                    let rs_file = rs_path.rsplit('/').next().unwrap();
                    for pair in m.mirrored.windows(2) {
                        let (a, b) = (rust_position(rs, pair[0]), rust_position(rs, pair[1]));
                        assert!(a.is_some() && b.is_some(), "{rs_path} lacks {pair:?}");
                        assert!(a < b, "{rs_path} order changed: {pair:?}");
                    }
                    if let [only] = m.mirrored {
                        assert!(rust_position(rs, only).is_some(), "{rs_path} lacks {only}");
                    }
                    // The "keep in sync" comments on both sides name the other file.
                    assert!(
                        text.contains(&format!("Keep in sync with {rs_file}")),
                        "{} does not name {rs_file}",
                        m.wgsl
                    );
                    assert!(rs.contains(file), "{rs_path} does not name {file}");
                }
                None => assert!(
                    text.contains("lane.rs") || text.contains("layout.rs"),
                    "{} names no Rust counterpart",
                    m.wgsl
                ),
            }
        }
        // advance_period is replaced by the resumable step loop of the entry point.
        assert!(rust_position(lane_rs, "advance_period").is_some());
        assert!(WGSL_FILES[6].1.contains("advance_period"));
    }
}
