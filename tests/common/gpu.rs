//! The GPU runner shared by the tests of one test binary, or `None` where there is no
//! adapter; with `JEFFCOTT_REQUIRE_GPU=1` (CI with Mesa's lavapipe) a missing adapter
//! fails the test instead.

use super::require_gpu;
use jeffcott_gpu::{DeviceRequest, GpuDevice, GpuReal, GpuRunner};
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
