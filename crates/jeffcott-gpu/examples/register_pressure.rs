//! One line per lane-kernel variant and Vulkan device that offers the driver's
//! statistics: VGPRs before scheduling and allocated, spilled VGPRs, scratch bytes,
//! instructions and the static latency estimate. The loop for editing the kernel: after
//! a change to a `.wgsl` file a debug build of this example takes seconds where the
//! release binary's `jeffcott info --kernel-stats` takes minutes, e.g. on RADV's null
//! device (docs/gpu.md):
//!
//! ```text
//! RADV_FORCE_FAMILY=gfx1100 VK_DRIVER_FILES=/usr/share/vulkan/icd.d/radeon_icd.x86_64.json \
//!     cargo run -p jeffcott-gpu --example register_pressure
//! ```
fn main() {
    let devices = match jeffcott_gpu::stats::kernel_statistics() {
        Ok(d) => d,
        Err(e) => {
            eprintln!("register_pressure: {e}");
            std::process::exit(1);
        }
    };
    for d in devices {
        if !d.offers_statistics {
            eprintln!("{}: no pipeline statistics", d.device);
            continue;
        }
        let kernels = match d.kernels {
            Ok(k) => k,
            Err(e) => {
                eprintln!("{}: the kernel does not compile: {e}", d.device);
                std::process::exit(1);
            }
        };
        for k in kernels {
            for (_, stats) in &k.executables {
                let get = |name: &str| {
                    stats
                        .iter()
                        .find(|s| s.name == name)
                        .map(|s| s.value.to_string())
                        .unwrap_or_default()
                };
                println!(
                    "{}: {}: VGPRs {} / {}, spilled {}, scratch {} B, instructions {}, latency {}",
                    k.device,
                    k.kernel,
                    get("Pre-Sched VGPRs"),
                    get("VGPRs"),
                    get("Spilled VGPRs"),
                    get("Scratch size"),
                    get("Instructions"),
                    get("Latency")
                );
            }
        }
    }
}
