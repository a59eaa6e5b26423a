//! Criterion benchmark of the ensemble backends on the W = 133 workload of
//! `jeffcott_analysis::bench` (contact-heavy: lanes thrown against the stator from spread start
//! states). Throughput is in macro steps (T/N, N = 500) summed over lanes; one forcing
//! period is 500 of them. The 128k-lane size and the contact-time share are measured by
//! `jeffcott bench`, which takes minutes per row on a 2-core CPU, too long for
//! criterion's repeated samples.
//!
//! Run: `cargo bench --bench ensemble` (GPU rows only when an adapter exists).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use jeffcott_analysis::backend::run_on_gpu;
use jeffcott_analysis::bench::bench_spec;
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::Precision;
use jeffcott_core::model::Params;
use jeffcott_gpu::{DeviceRequest, GpuDevice, GpuRunner};
use std::time::Duration;

fn ensemble(c: &mut Criterion) {
    // One runner for every GPU sample: device and pipeline set-up are not timed.
    let runner = GpuDevice::new(&DeviceRequest {
        need_f64: false,
        allow_software: true,
    })
    .ok()
    .map(GpuRunner::new);
    let mut group = c.benchmark_group("ensemble_w133");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(20));
    for (lanes, periods) in [(1024usize, 4u32), (16384, 1)] {
        let steps = lanes as u64 * periods as u64 * 500;
        group.throughput(Throughput::Elements(steps));
        for precision in [Precision::F64, Precision::F32] {
            let spec = bench_spec(&Params::default(), lanes, periods, precision, false);
            let name =
                |backend: &str| format!("{backend}_{precision:?}_{lanes}_lanes").to_lowercase();
            group.bench_function(name("cpu"), |b| {
                b.iter(|| {
                    jeffcott_core::ensemble::cpu::run(&spec, false, Control::none())
                        .expect("CPU run")
                })
            });
            if let Some(r) = runner
                .as_ref()
                .filter(|r| precision == Precision::F32 || r.gpu().supports_f64())
            {
                group.bench_function(name("gpu"), |b| {
                    b.iter(|| run_on_gpu(&spec, r, false, Control::none()).expect("GPU run"))
                });
            }
        }
    }
    group.finish();
}

criterion_group! {
    name = benches;
    // No HTML/SVG plots: criterion's plotters backend needs system fonts, which a
    // headless CI machine lacks; the figures are in the terminal and target/criterion.
    config = Criterion::default().without_plots();
    targets = ensemble
}
criterion_main!(benches);
