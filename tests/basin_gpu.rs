//! Basin labels from the GPU f64 path equal the CPU's for a small grid.
//!
//! Needs a wgpu adapter with SHADER_F64 (Mesa's lavapipe is enough). Without one the test
//! prints "skipped" and returns, unless `JEFFCOTT_REQUIRE_GPU=1` is set, as in
//! `tests/gpu.rs`.

use jeffcott_analysis::basin::{Axis, BasinSpec, basin};
use jeffcott_analysis::settings::LaneSettings;
use jeffcott_core::ensemble::{Backend, Precision};
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, VX_R, X_R};

mod common;

#[test]
fn basin_labels_are_identical_on_cpu_and_gpu_f64() {
    if !common::gpu_f64_present() {
        return;
    }
    let p = Params::default();
    let mut spec = BasinSpec {
        base: p.static_equilibrium(),
        lane: LaneSettings {
            params: p,
            stepper: StepperConfig {
                steps_per_period: 200,
                ..StepperConfig::default()
            },
            precision: Precision::F64,
            backend: Backend::Cpu,
            catalogue: Default::default(),
            lyapunov: true,
        },
        omega: 133.0,
        x: Axis {
            coord: X_R,
            lo: -0.006,
            hi: 0.006,
            n: 5,
        },
        y: Axis {
            coord: VX_R,
            lo: -1.0,
            hi: 1.0,
            n: 4,
        },
        transient: 60,
        periods: 12,
        lanes_per_unit: Some(7),
    };
    let cpu = basin(&spec, jeffcott_core::control::Control::none()).unwrap();
    spec.lane.backend = Backend::Gpu;
    let gpu = basin(&spec, jeffcott_core::control::Control::none()).unwrap();
    assert_eq!(gpu.info.as_ref().unwrap().backend, "gpu");
    assert_eq!(cpu.labels, gpu.labels);
    assert_eq!(cpu.labels.len(), 20);
    let names = |r: &jeffcott_analysis::basin::BasinResult| -> Vec<String> {
        r.catalogue.attractors.iter().map(|a| a.name()).collect()
    };
    assert_eq!(names(&cpu), names(&gpu));
    // lambda_1 per cell: the same arithmetic on both backends (f64).
    let (lc, lg) = (cpu.lambda1.unwrap(), gpu.lambda1.unwrap());
    assert_eq!(lc.len(), 20);
    for (a, b) in lc.iter().zip(&lg) {
        assert!(
            (a.is_nan() && b.is_nan()) || (a - b).abs() < 1e-3,
            "cpu {a} gpu {b}"
        );
    }
}
