//! What a Vulkan driver compiled the lane kernel into: its own statistics of each
//! kernel variant (registers per invocation, spilled bytes, local and shared memory,
//! instruction counts: whatever the driver reports), through
//! `VK_KHR_pipeline_executable_properties`.
//!
//! Why: on an H100 the kernel runs ~60x fewer lane-steps per second than a hand-written
//! CUDA RK4 of the same step count would suggest, at any lane count from 16k to 1M
//! (docs/gpu.md), which points at register spills or dynamically indexed arrays in
//! local memory; wgpu does not expose the driver's statistics, so this module asks the
//! driver directly (with `ash`, the Vulkan binding wgpu itself uses), on a device of its
//! own that enables the extension. The pipelines are built from the same SPIR-V words as
//! the runner's exact path ([`crate::spirv::exact_compute_words`]), so what is reported
//! is what runs. `jeffcott info --kernel-stats` prints it.

use crate::anatomy::Part;
use crate::shader::{self, Variant};
use ash::vk;
use jeffcott_core::real::Real;
use std::ffi::CStr;

/// One statistic of one executable of a compiled kernel.
#[derive(Clone, Debug, PartialEq)]
pub struct Statistic {
    /// The driver's name for it ("Register Count", ...).
    pub name: String,
    /// Its value as text (integers exact, booleans true/false).
    pub value: String,
    /// The driver's description.
    pub description: String,
}

/// The statistics of one kernel variant on one device.
#[derive(Clone, Debug)]
pub struct KernelStats {
    /// The device's name.
    pub device: String,
    /// Which kernel ("f64", "f32 / and sqrt through f64", ...).
    pub kernel: String,
    /// Seconds the driver took to compile the pipeline.
    pub compile_s: f64,
    /// What its SPIR-V holds that a driver may keep in local memory (a static count of
    /// the words the driver received).
    pub census: crate::spirv::LocalMemoryCensus,
    /// Each executable (usually one for a compute pipeline): its name and statistics;
    /// empty where the driver offers no statistics.
    pub executables: Executables,
}

/// What one device says: its kernels' statistics, or why there are none.
#[derive(Clone, Debug)]
pub struct DeviceStats {
    /// The device's name.
    pub device: String,
    /// False where the driver does not offer the extension: the variants are compiled
    /// (and timed) all the same, without statistics.
    pub offers_statistics: bool,
    /// Every variant the device can run, or why they could not be compiled.
    pub kernels: Result<Vec<KernelStats>, String>,
}

fn c_text(s: Result<&CStr, std::ffi::FromBytesUntilNulError>) -> String {
    s.map(|c| c.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn vk_err(what: &str) -> impl Fn(vk::Result) -> String + '_ {
    move |e| format!("{what}: {e}")
}

/// The kernel variants a device runs (see [`crate::GpuRunner`]): f32, and with f64 the
/// f64 kernel and the f32 one with the driver's own division and sqrt (what a device
/// without f64 runs), each plain and with lambda_1, with and without the exact
/// free-flight step, with the forcing table where the runner would take it
/// (`JEFFCOTT_GPU_FORCING`); an error (not a panic: the caller's Vulkan handles are live) when
/// one does not compile.
/// Then each part of the kernel's anatomy (`crate::anatomy`) in the plain kernel's
/// precisions, so that a part's registers can be set beside the whole kernel's.
fn variants(has_f64: bool, each_step: bool) -> Result<Vec<Compiled>, String> {
    fn words<R: Real>(v: Variant) -> Result<(String, Vec<u32>), String> {
        let (module, info) = shader::validate::<R>(v, shader::capabilities::<R>(v))?;
        let w = crate::spirv::exact_compute_words(
            &module,
            &info,
            shader::ENTRY_POINT,
            &binding_numbers(),
        )?;
        Ok((shader::ENTRY_POINT.to_string(), w))
    }
    fn part_words<R: Real>(v: Variant, part: Part) -> Result<(String, Vec<u32>), String> {
        let src = crate::anatomy::source::<R>(v);
        let (module, info) = shader::validate_source::<R>(v, &src, shader::capabilities::<R>(v))?;
        let w =
            crate::spirv::exact_compute_words(&module, &info, part.entry(), &binding_numbers())?;
        Ok((part.entry().to_string(), w))
    }
    let forcing = crate::device::forcing_table().map_err(|e| e.to_string())?;
    let mut out: Vec<Compiled> = Vec::new();
    for (exact, lyapunov, shared) in variant_keys() {
        // Lane constants as the runner reads them on this device (Variant).
        let device = Variant::on_device(lyapunov, has_f64)
            .with_exact_free_flight(exact)
            .with_consts_each_step(each_step)
            .with_shared_fields(shared)
            .with_forcing_table(forcing);
        let tail = format!(
            "{}{}{}{}{}",
            if lyapunov { ", lambda_1" } else { "" },
            if exact { ", exact free flight" } else { "" },
            if each_step {
                ", constants each sub-step"
            } else {
                ""
            },
            match shared {
                0 => "",
                SPEED_SWEEP => ", constants shared but the speed's",
                _ => ", constants shared",
            },
            if device.forcing_table {
                ", forcing table"
            } else {
                ""
            },
        );
        if has_f64 {
            out.push(with_label(format!("f64{tail}"), words::<f64>(device)?));
            out.push(with_label(
                format!("f32, / and sqrt through f64{tail}"),
                words::<f32>(device)?,
            ));
            // What a device without f64 runs: the same, with the driver's / and sqrt.
            let own = Variant {
                f32_through_f64: false,
                ..device
            };
            out.push(with_label(
                format!("f32, driver's / and sqrt{tail}"),
                words::<f32>(own)?,
            ));
        } else {
            out.push(with_label(format!("f32{tail}"), words::<f32>(device)?));
        }
    }
    let plain = Variant::on_device(false, has_f64);
    for part in Part::ALL {
        let label = |p: &str| format!("anatomy: {} ({p})", part.name());
        if has_f64 {
            out.push(with_label(label("f64"), part_words::<f64>(plain, part)?));
        }
        out.push(with_label(label("f32"), part_words::<f32>(plain, part)?));
    }
    Ok(out)
}

/// The kernel's binding numbers ([`crate::layout::BINDINGS`]).
fn binding_numbers() -> Vec<u32> {
    crate::layout::BINDINGS.iter().map(|&(b, _)| b).collect()
}

/// A kernel built for the statistics: its label, entry point and SPIR-V words.
type Compiled = (String, String, Vec<u32>);

/// Every variant of the lane kernel a hardware adapter with f64 may run, in the form of
/// lane constants the runner takes there (`JEFFCOTT_GPU_CONSTS`, by default read at
/// every sub-step on hardware), as (file name, label, SPIR-V words exactly as they go
/// to the driver): f64, f32 with / and sqrt through f64, f32 with the driver's own (a
/// device without f64), each plain, with lambda_1, with the exact free-flight map and
/// with both.
pub fn hardware_variants() -> Result<Vec<(String, String, Vec<u32>)>, String> {
    let each_step = crate::device::consts_each_step(false).map_err(|e| e.to_string())?;
    let kernels = variants(true, each_step)?;
    Ok(kernels
        .into_iter()
        .filter(|(label, _, _)| !label.starts_with("anatomy"))
        .map(|(label, _, words)| (file_name(&label), label, words))
        .collect())
}

/// A variant's label as a file name: `f32, / and sqrt through f64, lambda_1` ->
/// `f32-div-sqrt-through-f64-lambda1.spv`.
fn file_name(label: &str) -> String {
    let mut name = label
        .replace(", / and sqrt through f64", "-div-sqrt-through-f64")
        .replace(", driver's / and sqrt", "-driver-div-sqrt")
        .replace(", lambda_1", "-lambda1")
        .replace(", exact free flight", "-exact-free-flight")
        .replace(", constants each sub-step", "-consts-each-step")
        .replace(
            ", constants shared but the speed's",
            "-consts-shared-but-speed",
        )
        .replace(", constants shared", "-consts-shared")
        .replace(", forcing table", "-forcing-table");
    name.retain(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    name + ".spv"
}

/// (exact free flight, lambda_1, constants' fields shared) of every kernel variant the
/// statistics cover: every field per lane, then a speed sweep's mask (all but the
/// unbalance, the macro step and the exact map), then every field shared.
fn variant_keys() -> Vec<(bool, bool, u32)> {
    let mut keys = Vec::new();
    for shared in [0, SPEED_SWEEP, crate::layout::ALL_FIELDS] {
        for exact in [false, true] {
            for lyapunov in [false, true] {
                keys.push((exact, lyapunov, shared));
            }
        }
    }
    keys
}

/// The constants' fields a sweep over the rotor speed shares: all but the unbalance
/// (e omega^2), the macro step (T / N) and the exact free-flight map.
pub const SPEED_SWEEP: u32 = {
    use crate::layout::{ALL_FIELDS, field};
    ALL_FIELDS & !(1 << field("c.unbalance")) & !(1 << field("h")) & !(1 << field("ff"))
};

fn with_label(label: String, (entry, words): (String, Vec<u32>)) -> Compiled {
    (label, entry, words)
}

/// The statistics of every kernel variant on every Vulkan device; `Err` when there is
/// no Vulkan loader or instance at all.
pub fn kernel_statistics() -> Result<Vec<DeviceStats>, String> {
    // SAFETY: loading the Vulkan loader library; its entry points are only called
    // through ash's typed wrappers below.
    let entry = unsafe { ash::Entry::load() }.map_err(|e| format!("no Vulkan loader: {e}"))?;
    let app = vk::ApplicationInfo::default()
        .application_name(c"jeffcott")
        .api_version(vk::API_VERSION_1_1);
    let ici = vk::InstanceCreateInfo::default().application_info(&app);
    // SAFETY: a valid create info; the instance is destroyed before returning.
    let instance =
        unsafe { entry.create_instance(&ici, None) }.map_err(vk_err("vkCreateInstance"))?;
    // SAFETY: the instance is live.
    let result = unsafe { instance.enumerate_physical_devices() }
        .map_err(vk_err("vkEnumeratePhysicalDevices"))
        .map(|pds| {
            pds.into_iter()
                .map(|pd| {
                    // SAFETY: pd comes from this instance.
                    let props = unsafe { instance.get_physical_device_properties(pd) };
                    let device = c_text(props.device_name_as_c_str());
                    let offers_statistics = offers_statistics(&instance, pd);
                    let kernels =
                        unsafe { device_stats(&instance, pd, &device, offers_statistics) };
                    DeviceStats {
                        device,
                        offers_statistics,
                        kernels,
                    }
                })
                .collect()
        });
    // SAFETY: every device made from the instance is destroyed in device_stats.
    unsafe { instance.destroy_instance(None) };
    result
}

/// True when `pd`'s driver offers VK_KHR_pipeline_executable_properties.
fn offers_statistics(instance: &ash::Instance, pd: vk::PhysicalDevice) -> bool {
    let ext = ash::khr::pipeline_executable_properties::NAME;
    // SAFETY: `pd` comes from the live `instance`.
    unsafe { instance.enumerate_device_extension_properties(pd) }
        .map(|exts| exts.iter().any(|e| e.extension_name_as_c_str() == Ok(ext)))
        .unwrap_or(false)
}

/// Each variant compiled on physical device `pd`, with the driver's statistics where it
/// `offers` them.
///
/// # Safety
/// `pd` must belong to `instance`, which must be live.
unsafe fn device_stats(
    instance: &ash::Instance,
    pd: vk::PhysicalDevice,
    name: &str,
    offers: bool,
) -> Result<Vec<KernelStats>, String> {
    let ext = ash::khr::pipeline_executable_properties::NAME;
    // SAFETY (this block and below): `pd` belongs to the live `instance` (the caller's
    // promise); every handle made here is destroyed before returning.
    let has_f64 = unsafe { instance.get_physical_device_features(pd) }.shader_float64 == vk::TRUE;
    let software = unsafe { instance.get_physical_device_properties(pd) }.device_type
        == vk::PhysicalDeviceType::CPU;
    // The lane constants' form the runner would use here (JEFFCOTT_GPU_CONSTS honoured,
    // so that a campaign can compare both forms' statistics).
    let each_step = crate::device::consts_each_step(software).map_err(|e| e.to_string())?;
    let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
    let family = families
        .iter()
        .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
        .ok_or("no compute queue")? as u32;
    let priorities = [1.0f32];
    let queues = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(family)
        .queue_priorities(&priorities)];
    let ext_names = [ext.as_ptr()];
    let features = vk::PhysicalDeviceFeatures::default().shader_float64(has_f64);
    let mut exec_info = vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default()
        .pipeline_executable_info(true);
    let mut dci = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queues)
        .enabled_features(&features);
    if offers {
        dci = dci
            .enabled_extension_names(&ext_names)
            .push_next(&mut exec_info);
    }
    let device =
        unsafe { instance.create_device(pd, &dci, None) }.map_err(vk_err("vkCreateDevice"))?;
    let loader =
        offers.then(|| ash::khr::pipeline_executable_properties::Device::new(instance, &device));
    let result = (|| {
        // The runner's layout.
        let bindings: Vec<vk::DescriptorSetLayoutBinding> = crate::layout::BINDINGS
            .iter()
            .map(|&(b, kind)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b)
                    .descriptor_type(if kind == crate::layout::Binding::Uniform {
                        vk::DescriptorType::UNIFORM_BUFFER
                    } else {
                        vk::DescriptorType::STORAGE_BUFFER
                    })
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let dsl = unsafe {
            device.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                None,
            )
        }
        .map_err(vk_err("vkCreateDescriptorSetLayout"))?;
        let layouts = [dsl];
        let layout = unsafe {
            device.create_pipeline_layout(
                &vk::PipelineLayoutCreateInfo::default().set_layouts(&layouts),
                None,
            )
        }
        .map_err(vk_err("vkCreatePipelineLayout"));
        let out = layout.and_then(|layout| {
            let r = variants(has_f64, each_step)?
                .into_iter()
                .map(|(kernel, entry, words)| {
                    let (compile_s, executables) = unsafe {
                        pipeline_stats(&device, loader.as_ref(), layout, &entry, &words)
                    }?;
                    Ok(KernelStats {
                        device: name.to_string(),
                        kernel,
                        compile_s,
                        census: crate::spirv::local_memory_census(&words)?,
                        executables,
                    })
                })
                .collect();
            unsafe { device.destroy_pipeline_layout(layout, None) };
            r
        });
        unsafe { device.destroy_descriptor_set_layout(dsl, None) };
        out
    })();
    unsafe { device.destroy_device(None) };
    result
}

/// A pipeline's executables, each with its name and statistics.
type Executables = Vec<(String, Vec<Statistic>)>;

/// Builds the compute pipeline of `words` (timed), with its statistics captured and read
/// where there is a `loader`.
///
/// # Safety
/// `device` must be live, created with the extension `loader` wraps (if any), and
/// `layout` one of its pipeline layouts.
unsafe fn pipeline_stats(
    device: &ash::Device,
    loader: Option<&ash::khr::pipeline_executable_properties::Device>,
    layout: vk::PipelineLayout,
    entry: &str,
    words: &[u32],
) -> Result<(f64, Executables), String> {
    // SAFETY: valid create infos on a live device (the caller's promise); the module and
    // pipeline are destroyed before returning.
    let module = unsafe {
        device.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(words), None)
    }
    .map_err(vk_err("vkCreateShaderModule"))?;
    let entry = std::ffi::CString::new(entry).expect("no NUL in the entry name");
    let stage = vk::PipelineShaderStageCreateInfo::default()
        .stage(vk::ShaderStageFlags::COMPUTE)
        .module(module)
        .name(&entry);
    let flags = if loader.is_some() {
        vk::PipelineCreateFlags::CAPTURE_STATISTICS_KHR
    } else {
        vk::PipelineCreateFlags::empty()
    };
    let info = [vk::ComputePipelineCreateInfo::default()
        .flags(flags)
        .stage(stage)
        .layout(layout)];
    let t = std::time::Instant::now();
    let made = unsafe { device.create_compute_pipelines(vk::PipelineCache::null(), &info, None) };
    let compile_s = t.elapsed().as_secs_f64();
    unsafe { device.destroy_shader_module(module, None) };
    let pipeline = made.map_err(|(_, e)| format!("vkCreateComputePipelines: {e}"))?[0];
    let read = || -> Result<Executables, String> {
        let Some(loader) = loader else {
            return Ok(Vec::new());
        };
        let pinfo = vk::PipelineInfoKHR::default().pipeline(pipeline);
        let execs = unsafe { loader.get_pipeline_executable_properties(&pinfo) }
            .map_err(vk_err("vkGetPipelineExecutablePropertiesKHR"))?;
        let mut out = Vec::new();
        for (i, e) in execs.iter().enumerate() {
            let einfo = vk::PipelineExecutableInfoKHR::default()
                .pipeline(pipeline)
                .executable_index(i as u32);
            let stats = unsafe { loader.get_pipeline_executable_statistics(&einfo) }
                .map_err(vk_err("vkGetPipelineExecutableStatisticsKHR"))?;
            let stats = stats
                .iter()
                .map(|s| Statistic {
                    name: c_text(s.name_as_c_str()),
                    description: c_text(s.description_as_c_str()),
                    // SAFETY: the union member read is the one `format` names.
                    value: unsafe {
                        match s.format {
                            vk::PipelineExecutableStatisticFormatKHR::BOOL32 => {
                                (s.value.b32 == vk::TRUE).to_string()
                            }
                            vk::PipelineExecutableStatisticFormatKHR::INT64 => {
                                s.value.i64.to_string()
                            }
                            vk::PipelineExecutableStatisticFormatKHR::UINT64 => {
                                s.value.u64.to_string()
                            }
                            vk::PipelineExecutableStatisticFormatKHR::FLOAT64 => {
                                s.value.f64.to_string()
                            }
                            f => format!("(format {f:?})"),
                        }
                    },
                })
                .collect();
            out.push((c_text(e.name_as_c_str()), stats));
        }
        Ok(out)
    };
    let r = read();
    unsafe { device.destroy_pipeline(pipeline, None) };
    Ok((compile_s, r?))
}
