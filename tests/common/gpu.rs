//! The GPU runner shared by the tests of one test binary, or `None` where there is no
//! adapter; with `JEFFCOTT_REQUIRE_GPU=1` (CI with Mesa's lavapipe) a missing adapter
//! fails the test instead.

use super::require_gpu;
use jeffcott_gpu::shader::Variant;
use jeffcott_gpu::{DeviceRequest, GpuDevice, GpuReal, GpuRunner, ShaderPath};
use std::sync::OnceLock;

/// The shared runner, or `None` (after saying so) when there is no adapter and none is
/// required. Panics when `JEFFCOTT_REQUIRE_GPU=1` and there is no adapter.
pub fn runner() -> Option<&'static GpuRunner> {
    static RUNNER: OnceLock<Result<GpuRunner, String>> = OnceLock::new();
    let r = RUNNER.get_or_init(|| match GpuDevice::new(&DeviceRequest::default()) {
        Ok(gpu) => {
            eprintln!("GPU tests on {:?}", gpu.adapter());
            Ok(GpuRunner::new(gpu))
        }
        Err(e) => Err(e.to_string()),
    });
    match r {
        Ok(runner) => Some(runner),
        Err(e) => {
            assert!(
                !require_gpu(),
                "JEFFCOTT_REQUIRE_GPU=1 but no GPU adapter could be opened: {e}"
            );
            eprintln!("skipped: no Vulkan adapter ({e})");
            None
        }
    }
}

/// The runner if it can run precision `R` (f64 needs SHADER_F64).
pub fn runner_for<R: GpuReal>() -> Option<&'static GpuRunner> {
    let r = runner()?;
    if R::WGSL_NAME == "f64" && !r.gpu().supports_f64() {
        assert!(
            !require_gpu(),
            "JEFFCOTT_REQUIRE_GPU=1 but adapter {} has no SHADER_F64",
            r.gpu().adapter().name
        );
        eprintln!(
            "skipped: adapter {} has no SHADER_F64",
            r.gpu().adapter().name
        );
        return None;
    }
    Some(r)
}

/// Runs `check64` on the f64 runner and `check32` on the f32 runner, each where the
/// adapter allows.
pub fn in_both_precisions(check32: fn(&GpuRunner), check64: fn(&GpuRunner)) {
    if let Some(r) = runner_for::<f64>() {
        check64(r);
    }
    if let Some(r) = runner_for::<f32>() {
        check32(r);
    }
}

/// `in_both_precisions(check::<f32>, check::<f64>)` for a check generic over the precision.
#[macro_export]
macro_rules! both_precisions {
    ($check:ident) => {
        common::gpu::in_both_precisions($check::<f32>, $check::<f64>)
    };
}

/// The lane kernel `runner`'s device runs in precision `R` (f32 divides and takes square
/// roots through f64 where the device has SHADER_F64), `lyapunov` or not.
pub fn device_variant(runner: &GpuRunner, lyapunov: bool) -> Variant {
    runner.kernel_variant(lyapunov, jeffcott_gpu::shader::Features::default(), 0)
}

/// True where kernel variant `v` in precision `R` is promised to equal the CPU to the bit
/// on `runner`'s device: on a software adapter (lavapipe: every operation correctly
/// rounded, nothing fused), and on hardware that takes the kernel as exact SPIR-V (no
/// fused or reassociated operations) when every division and sqrt is an f64 one (the f64
/// kernel, or f32 through f64): the H100 rounds f64 division and sqrt correctly, its own
/// f32 ones not (docs/gpu.md). Says which regime it found.
pub fn identity_promised<R: GpuReal>(runner: &GpuRunner, v: Variant) -> bool {
    let gpu = runner.gpu();
    let f64_ops = R::WGSL_NAME == "f64" || v.f32_through_f64;
    let promised =
        gpu.adapter().software || (gpu.shader_path() == ShaderPath::ExactSpirv && f64_ops);
    eprintln!(
        "regime ({}{}): {} ({}, kernel as {})",
        R::WGSL_NAME,
        if R::WGSL_NAME == "f32" && !v.f32_through_f64 {
            ", driver's own division and sqrt"
        } else {
            ""
        },
        if promised {
            "bit-identical"
        } else {
            "tolerance"
        },
        gpu.adapter().name,
        gpu.shader_path().name()
    );
    promised
}
