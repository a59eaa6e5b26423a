//! Adapter discovery and device creation, kept apart from the work (DESIGN.md 2.3) so
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

/// A wgpu device and queue with what the runner needs to know about them.
pub struct GpuDevice {
    device: wgpu::Device,
    queue: wgpu::Queue,
    summary: AdapterSummary,
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
        let required_features = if summary.f64 {
            wgpu::Features::SHADER_F64
        } else {
            wgpu::Features::empty()
        };
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
