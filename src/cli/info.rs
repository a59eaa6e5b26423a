//! `jeffcott info`: the CPU and the GPU adapters, and with `--kernel-stats` what each
//! Vulkan driver compiled the lane kernel into; `--write-spirv` writes the kernel's
//! SPIR-V as it goes to the driver.

use clap::Args;
use jeffcott_core::error::Result;

/// Options of `jeffcott info`.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Also compile every lane-kernel variant on each Vulkan device and print what the
    /// driver reports about it (registers, spills, local memory, instructions: whatever
    /// it offers through VK_KHR_pipeline_executable_properties).
    #[arg(long)]
    pub kernel_stats: bool,
    /// Write the SPIR-V of every hardware variant of the lane kernel into DIR, one
    /// `.spv` per variant named after it, exactly as it goes to a driver (disassemble
    /// with `spirv-dis`), and print what each holds that a driver may keep in local
    /// memory. Needs no GPU.
    #[arg(long, value_name = "DIR")]
    pub write_spirv: Option<std::path::PathBuf>,
    /// Print the reference of every command and option as Markdown, generated from the
    /// definitions `--help` shows (docs/cli.md is this output), and nothing else.
    #[arg(long, conflicts_with_all = ["kernel_stats", "write_spirv"])]
    pub cli_reference: bool,
}

/// Runs `jeffcott info`.
pub fn run_info(args: &InfoArgs) -> Result<()> {
    if args.cli_reference {
        print!("{}", clap_markdown::help_markdown::<super::Cli>());
        return Ok(());
    }
    let adapters = jeffcott_gpu::list_adapters();
    println!("CPU: {} rayon threads", rayon::current_num_threads());
    if adapters.is_empty() {
        println!(
            "GPU: no adapter found (install a Vulkan driver; Mesa's lavapipe: apt-get install mesa-vulkan-drivers)"
        );
    }
    for s in adapters {
        println!(
            "GPU: {} [{} {}{}], driver {}, f64 {}, max storage binding {} MiB, max buffer {} MiB, workgroups/dim {}, invocations/workgroup {}, kernel as {}, f32 division and sqrt {}, kernel form {} (JEFFCOTT_GPU_CONSTS)",
            s.name,
            s.backend,
            s.device_type,
            if s.software { ", software" } else { "" },
            s.driver,
            if s.f64 { "yes" } else { "no" },
            s.max_storage_buffer_binding_size >> 20,
            s.max_buffer_size >> 20,
            s.max_compute_workgroups_per_dimension,
            s.max_compute_invocations_per_workgroup,
            if s.spirv_passthrough {
                "exact SPIR-V (NoContraction; JEFFCOTT_GPU_SHADER=wgsl for WGSL)"
            } else {
                "WGSL (no SPIR-V passthrough: the driver may contract a*b+c)"
            },
            if s.f64 {
                "through f64 (correctly rounded)"
            } else {
                "the driver's own"
            },
            // The runner's own choice (JEFFCOTT_GPU_CONSTS, else by adapter kind).
            match jeffcott_gpu::device::consts_each_step(s.software) {
                Ok(true) => "GPU (constants at every sub-step, the lane in its buffer)",
                Ok(false) => "software (constants and the lane held in registers)",
                Err(_) => "? (invalid value: once or each-step)",
            }
        );
    }
    if let Some(dir) = &args.write_spirv {
        write_spirv(dir)?;
    }
    if args.kernel_stats {
        print_kernel_stats()?;
    }
    Ok(())
}

/// The census of a kernel's SPIR-V, as printed.
fn census_line(c: &jeffcott_gpu::spirv::LocalMemoryCensus) -> String {
    format!(
        "{} Function-storage arrays, {} accesses into them at a run-time index, {} loops, {} loop-bound counters",
        c.array_variables, c.dynamic_accesses, c.loops, c.loop_counters
    )
}

/// Writes every hardware variant's SPIR-V into `dir` (`--write-spirv`).
fn write_spirv(dir: &std::path::Path) -> Result<()> {
    jeffcott_analysis::output::ensure_dir(dir)?;
    let variants = jeffcott_gpu::stats::hardware_variants()
        .map_err(|message| jeffcott_core::Error::Gpu { message })?;
    for (file, label, words) in variants {
        let census = jeffcott_gpu::spirv::local_memory_census(&words)
            .map_err(|message| jeffcott_core::Error::Gpu { message })?;
        // SPIR-V words in the machine's order, as a driver reads a module from memory
        // (spirv-dis takes either order: the magic number tells).
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_ne_bytes()).collect();
        jeffcott_analysis::output::write_atomically(&dir.join(&file), |w| {
            std::io::Write::write_all(w, &bytes)
        })?;
        println!("{file} ({label}): {}", census_line(&census));
    }
    Ok(())
}

/// Prints the driver's statistics of every lane-kernel variant on every Vulkan device.
fn print_kernel_stats() -> Result<()> {
    let devices = jeffcott_gpu::stats::kernel_statistics()
        .map_err(|message| jeffcott_core::Error::Gpu { message })?;
    for d in devices {
        let kernels = d.kernels.map_err(|e| jeffcott_core::Error::Gpu {
            message: format!("compiling the lane kernel on {}: {e}", d.device),
        })?;
        if !d.offers_statistics {
            println!(
                "kernel statistics on {}: none (the driver does not offer VK_KHR_pipeline_executable_properties)",
                d.device
            );
        }
        for k in kernels {
            println!(
                "kernel {} on {}: compiled in {:.2} s; SPIR-V: {}",
                k.kernel,
                k.device,
                k.compile_s,
                census_line(&k.census)
            );
            for (exe, stats) in &k.executables {
                let list: Vec<String> = stats
                    .iter()
                    .map(|s| format!("{} = {}", s.name, s.value))
                    .collect();
                println!("  [{exe}] {}", list.join("; "));
            }
        }
    }
    Ok(())
}
