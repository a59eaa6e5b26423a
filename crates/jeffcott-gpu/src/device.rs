//! Adapter discovery and device creation, kept apart from the work (docs/architecture.md) so
//! that tests and the CLI can choose and share a device.
//!
//! The device is created with the adapter's own limits (so lane chunks can use all the
//! storage-buffer size it offers) and with `SHADER_F64` whenever the adapter has it.
//! wgpu's default reaction to an uncaptured error is a panic; here such errors are
//! collected instead and turned into [`Error::Gpu`] by the runner, and a lost device
//! into [`Error::DeviceLost`].

use jeffcott_core::error::{Error, Result};
use serde::Serialize;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// What `jeffcott info` shows about one adapter.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AdapterSummary {
    /// Adapter name ("llvmpipe (LLVM ...)" for Mesa's software driver).
    pub name: String,
    /// Graphics API (Vulkan, Metal, Dx12, Gl).
    pub backend: String,
    /// Discrete, integrated, virtual, CPU (software) or other.
    pub device_type: String,
    /// Driver name and version as reported.
    pub driver: String,
    /// True for software rasterisers (device type CPU).
    pub software: bool,
    /// True when the adapter can run the f64 kernel (`SHADER_F64`).
    pub f64: bool,
    /// True when the adapter can run compute shaders at all.
    pub compute: bool,
    /// Largest storage-buffer binding [bytes].
    pub max_storage_buffer_binding_size: u64,
    /// Largest buffer [bytes].
    pub max_buffer_size: u64,
    /// Workgroups per dispatch dimension.
    pub max_compute_workgroups_per_dimension: u32,
    /// Invocations per workgroup.
    pub max_compute_invocations_per_workgroup: u32,
    /// True when the adapter takes SPIR-V as it is (`PASSTHROUGH_SHADERS`, Vulkan), so
    /// the kernel can carry `NoContraction` (see [`crate::spirv`]).
    pub spirv_passthrough: bool,
}

impl AdapterSummary {
    fn of(adapter: &wgpu::Adapter) -> Self {
        let info = adapter.get_info();
        let limits = adapter.limits();
        AdapterSummary {
            name: info.name.clone(),
            backend: format!("{:?}", info.backend),
            device_type: format!("{:?}", info.device_type),
            driver: format!("{} {}", info.driver, info.driver_info)
                .trim()
                .to_string(),
            software: info.device_type == wgpu::DeviceType::Cpu,
            f64: adapter.features().contains(wgpu::Features::SHADER_F64),
            compute: adapter
                .get_downlevel_capabilities()
                .flags
                .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS),
            max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
            max_buffer_size: limits.max_buffer_size,
            max_compute_workgroups_per_dimension: limits.max_compute_workgroups_per_dimension,
            max_compute_invocations_per_workgroup: limits.max_compute_invocations_per_workgroup,
            spirv_passthrough: info.backend == wgpu::Backend::Vulkan
                && adapter
                    .features()
                    .contains(wgpu::Features::PASSTHROUGH_SHADERS),
        }
    }
}

fn instance() -> wgpu::Instance {
    wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env())
}

fn adapters() -> Vec<wgpu::Adapter> {
    pollster::block_on(instance().enumerate_adapters(wgpu::Backends::all()))
}

/// Every adapter wgpu can see (honouring `WGPU_BACKEND` and friends), in wgpu's order.
pub fn list_adapters() -> Vec<AdapterSummary> {
    adapters().iter().map(AdapterSummary::of).collect()
}

/// What a run needs from an adapter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceRequest {
    /// Only adapters with `SHADER_F64`.
    pub need_f64: bool,
    /// Accept software adapters (Mesa's llvmpipe). `--backend auto` says no; tests and
    /// `--backend gpu` say yes.
    pub allow_software: bool,
}

impl Default for DeviceRequest {
    fn default() -> Self {
        DeviceRequest {
            need_f64: false,
            allow_software: true,
        }
    }
}

/// Preference order: real GPUs first, native APIs before GL.
fn rank(s: &AdapterSummary) -> (u8, u8) {
    let kind = match s.device_type.as_str() {
        "DiscreteGpu" => 0,
        "IntegratedGpu" => 1,
        "VirtualGpu" => 2,
        "Other" => 3,
        _ => 4,
    };
    let api = u8::from(s.backend == "Gl");
    (kind, api)
}

/// How the device receives compute shaders.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ShaderPath {
    /// SPIR-V from naga with every float operation `NoContraction`, through wgpu's
    /// passthrough: the driver may not fuse or reassociate (the parity path).
    ExactSpirv,
    /// WGSL through wgpu: the driver may contract `a * b + c` into an FMA.
    Wgsl,
}

impl ShaderPath {
    /// The name `JEFFCOTT_GPU_SHADER` takes and `jeffcott info` shows.
    pub fn name(self) -> &'static str {
        match self {
            ShaderPath::ExactSpirv => "spirv",
            ShaderPath::Wgsl => "wgsl",
        }
    }
}

/// The environment variable that picks the shader path: `spirv` (the default where the
/// adapter has SPIR-V passthrough) or `wgsl` (to measure what contraction changes).
pub const SHADER_PATH_VAR: &str = "JEFFCOTT_GPU_SHADER";

/// The shader path for an adapter: `JEFFCOTT_GPU_SHADER` if set, else the exact path
/// where the adapter offers it.
fn shader_path(summary: &AdapterSummary) -> Result<ShaderPath> {
    match std::env::var(SHADER_PATH_VAR).ok().as_deref() {
        None | Some("") => Ok(if summary.spirv_passthrough {
            ShaderPath::ExactSpirv
        } else {
            ShaderPath::Wgsl
        }),
        Some("wgsl") => Ok(ShaderPath::Wgsl),
        Some("spirv") if summary.spirv_passthrough => Ok(ShaderPath::ExactSpirv),
        Some("spirv") => Err(Error::NoAdapter {
            reason: format!(
                "{SHADER_PATH_VAR}=spirv, but adapter {} ({}) has no SPIR-V passthrough",
                summary.name, summary.backend
            ),
        }),
        Some(other) => Err(Error::invalid(
            SHADER_PATH_VAR,
            other,
            "must be spirv or wgsl",
        )),
    }
}

/// The environment variable that picks the kernel's form: `once`, the software form
/// (constants and the committed lane held in registers, the default on software
/// adapters) or `each-step`, the GPU form (constants read at every sub-step, the lane
/// kept in its buffer, the default on hardware); see `shader::Variant::consts_each_step`.
/// Both give the same bits.
pub const CONSTS_VAR: &str = "JEFFCOTT_GPU_CONSTS";

/// Whether the kernel on an adapter (`software` or not) reads a lane's constants at
/// every sub-step: `JEFFCOTT_GPU_CONSTS` if set, else on hardware only.
pub fn consts_each_step(software: bool) -> Result<bool> {
    match std::env::var(CONSTS_VAR).ok().as_deref() {
        None | Some("") => Ok(!software),
        Some("once") => Ok(false),
        Some("each-step") => Ok(true),
        Some(other) => Err(Error::invalid(
            CONSTS_VAR,
            other,
            "must be once or each-step",
        )),
    }
}

/// The environment variable that picks how the GPU form's lean free-flight path gets
/// the unbalance phasor where the run's lanes share N and phi0: `table` (the default,
/// looked up; `shader::Variant::forcing_table`) or `polynomial` (evaluated, as
/// everywhere else). Both give the same bits.
pub const FORCING_VAR: &str = "JEFFCOTT_GPU_FORCING";

/// Whether the lean path may look its phasors up: `JEFFCOTT_GPU_FORCING` if set, else
/// yes.
pub fn forcing_table() -> Result<bool> {
    match std::env::var(FORCING_VAR).ok().as_deref() {
        None | Some("") | Some("table") => Ok(true),
        Some("polynomial") => Ok(false),
        Some(other) => Err(Error::invalid(
            FORCING_VAR,
            other,
            "must be table or polynomial",
        )),
    }
}

/// A wgpu device and queue with what the runner needs to know about them.
pub struct GpuDevice {
    device: wgpu::Device,
    queue: wgpu::Queue,
    summary: AdapterSummary,
    shader_path: ShaderPath,
    consts_each_step: bool,
    forcing_table: bool,
    lost: Arc<AtomicBool>,
    errors: Arc<Mutex<Vec<String>>>,
}

impl std::fmt::Debug for GpuDevice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuDevice")
            .field("adapter", &self.summary)
            .finish_non_exhaustive()
    }
}

impl GpuDevice {
    /// Picks the best adapter that satisfies `req` and opens a device on it.
    pub fn new(req: &DeviceRequest) -> Result<GpuDevice> {
        let all = adapters();
        if all.is_empty() {
            return Err(Error::NoAdapter {
                reason: "wgpu found no adapter (is a Vulkan driver installed? on Linux \
                         without a GPU: apt-get install mesa-vulkan-drivers)"
                    .into(),
            });
        }
        let mut fit: Vec<(AdapterSummary, wgpu::Adapter)> = all
            .into_iter()
            .map(|a| (AdapterSummary::of(&a), a))
            .filter(|(s, _)| s.compute && (s.f64 || !req.need_f64))
            .filter(|(s, _)| req.allow_software || !s.software)
            .collect();
        fit.sort_by_key(|(s, _)| rank(s));
        match fit.into_iter().next() {
            Some((_, adapter)) => GpuDevice::from_adapter(&adapter),
            None => Err(Error::NoAdapter {
                reason: format!(
                    "none of the adapters [{}] offers compute{}{}",
                    list_adapters()
                        .iter()
                        .map(|s| format!(
                            "{} ({}, {}, f64: {})",
                            s.name, s.backend, s.device_type, s.f64
                        ))
                        .collect::<Vec<_>>()
                        .join("; "),
                    if req.need_f64 { " with SHADER_F64" } else { "" },
                    if req.allow_software {
                        ""
                    } else {
                        " on hardware"
                    },
                ),
            }),
        }
    }

    /// Opens a device on `adapter`, with its limits and, when offered, `SHADER_F64`.
    pub fn from_adapter(adapter: &wgpu::Adapter) -> Result<GpuDevice> {
        let summary = AdapterSummary::of(adapter);
        let shader_path = shader_path(&summary)?;
        let consts_each_step = consts_each_step(summary.software)?;
        let forcing_table = forcing_table()?;
        let mut required_features = wgpu::Features::empty();
        if summary.f64 {
            required_features |= wgpu::Features::SHADER_F64;
        }
        if shader_path == ShaderPath::ExactSpirv {
            required_features |= wgpu::Features::PASSTHROUGH_SHADERS;
        }
        let desc = wgpu::DeviceDescriptor {
            label: Some("jeffcott"),
            required_features,
            required_limits: adapter.limits(),
            ..Default::default()
        };
        let (device, queue) =
            pollster::block_on(adapter.request_device(&desc)).map_err(|e| Error::Gpu {
                message: format!("cannot open a device on {}: {e}", summary.name),
            })?;
        let lost = Arc::new(AtomicBool::new(false));
        let flag = lost.clone();
        device.set_device_lost_callback(move |reason, _msg| {
            if reason != wgpu::DeviceLostReason::Destroyed {
                flag.store(true, Ordering::SeqCst);
            }
        });
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        Ok(GpuDevice {
            device,
            queue,
            summary,
            shader_path,
            consts_each_step,
            forcing_table,
            lost,
            errors,
        })
    }

    /// The wgpu device.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The wgpu queue.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// What the adapter is (name, backend, limits...).
    pub fn adapter(&self) -> &AdapterSummary {
        &self.summary
    }

    /// How this device receives the kernel.
    pub fn shader_path(&self) -> ShaderPath {
        self.shader_path
    }

    /// Whether the kernel reads a lane's constants at every sub-step ([`CONSTS_VAR`]).
    pub fn consts_each_step(&self) -> bool {
        self.consts_each_step
    }

    /// Whether the lean path may take a forcing table ([`FORCING_VAR`]).
    pub fn forcing_table(&self) -> bool {
        self.forcing_table
    }

    /// A compute pipeline for entry point `entry` (workgroup size `workgroup`) of the
    /// WGSL module `wgsl`, with an explicit layout of one bind group holding the buffer
    /// bindings `bindings`. On [`ShaderPath::ExactSpirv`] the module is validated by
    /// naga with `caps` and compiled to SPIR-V with every float operation exact
    /// ([`crate::spirv`]); on [`ShaderPath::Wgsl`] wgpu compiles it.
    pub fn compute_pipeline(
        &self,
        label: &str,
        wgsl: &str,
        caps: wgpu::naga::valid::Capabilities,
        entry: &str,
        workgroup: (u32, u32, u32),
        bindings: &[(u32, wgpu::BufferBindingType)],
    ) -> Result<(wgpu::ComputePipeline, wgpu::BindGroupLayout)> {
        let gpu_err = |what: &str, e: &dyn std::fmt::Display| Error::Gpu {
            message: format!("{label}: {what}: {e}"),
        };
        let device = &self.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = match self.shader_path {
            ShaderPath::Wgsl => device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(wgsl.into()),
            }),
            ShaderPath::ExactSpirv => {
                let module = wgpu::naga::front::wgsl::parse_str(wgsl)
                    .map_err(|e| gpu_err("WGSL", &e.emit_to_string(wgsl)))?;
                let info = wgpu::naga::valid::Validator::new(
                    wgpu::naga::valid::ValidationFlags::all(),
                    caps,
                )
                .validate(&module)
                .map_err(|e| gpu_err("validation", &e.emit_to_string(wgsl)))?;
                let numbers: Vec<u32> = bindings.iter().map(|&(b, _)| b).collect();
                let words = crate::spirv::exact_compute_words(&module, &info, entry, &numbers)
                    .map_err(|e| gpu_err("SPIR-V", &e))?;
                let entry_points = [wgpu::PassthroughShaderEntryPoint {
                    name: entry.into(),
                    workgroup_size: workgroup,
                }];
                // SAFETY: the words are naga's output for a module naga validated, with
                // decorations added where the SPIR-V layout rules put them
                // (spirv::decorate_no_contraction); wgpu's own Vulkan path hands the
                // driver the same writer's output.
                unsafe {
                    device.create_shader_module_passthrough(
                        wgpu::ShaderModuleDescriptorPassthrough {
                            label: Some(label),
                            entry_points: entry_points[..].into(),
                            spirv: Some(words.into()),
                            ..Default::default()
                        },
                    )
                }
            }
        };
        let entries: Vec<wgpu::BindGroupLayoutEntry> = bindings
            .iter()
            .map(|&(binding, ty)| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect();
        let bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries: &entries,
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(&bgl)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(label),
            layout: Some(&layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(gpu_err("cannot build the pipeline", &e));
        }
        self.check()?;
        Ok((pipeline, bgl))
    }

    /// True when the device was created with `SHADER_F64`.
    pub fn supports_f64(&self) -> bool {
        self.device.features().contains(wgpu::Features::SHADER_F64)
    }

    /// The device's limits (the adapter's).
    pub fn limits(&self) -> wgpu::Limits {
        self.device.limits()
    }

    /// Turns a lost device or an error wgpu reported asynchronously into an error.
    pub(crate) fn check(&self) -> Result<()> {
        if self.lost.load(Ordering::SeqCst) {
            return Err(Error::DeviceLost);
        }
        let mut errs = match self.errors.lock() {
            Ok(g) => g,
            Err(p) => p.into_inner(),
        };
        if errs.is_empty() {
            Ok(())
        } else {
            let message = errs.join("; ");
            errs.clear();
            Err(Error::Gpu { message })
        }
    }
}
