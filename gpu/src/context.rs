//! Adapter selection and the device/queue context.

use std::sync::OnceLock;

use crate::GpuError;

/// Environment variable that lets [`AdapterChoice::from_env`] accept a software adapter
/// (Mesa lavapipe/llvmpipe, SwiftShader, WARP): `1`, `true`, `yes` or `on` (any case) enable it.
pub const ENV_ALLOW_SOFTWARE: &str = "SHATTER_GPU_ALLOW_SOFTWARE";

/// Environment variable that restricts adapter selection to adapters whose name contains its value
/// (case-insensitive), e.g. `SHATTER_GPU_ADAPTER=4090` on a machine with two GPUs. Unset or empty: no filter.
pub const ENV_ADAPTER_NAME: &str = "SHATTER_GPU_ADAPTER";

/// Which kinds of adapter [`GpuContext::new`] may pick.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AdapterChoice {
    /// Only a hardware GPU (discrete, integrated, virtual or unknown type). Software rasterisers are rejected.
    /// This is what `--backend auto|gpu` use unless [`ENV_ALLOW_SOFTWARE`] is set.
    HardwareOnly,
    /// A hardware GPU if there is one, else a software adapter such as Mesa lavapipe. Tests use this.
    AllowSoftware,
}

impl AdapterChoice {
    /// [`AdapterChoice::AllowSoftware`] when the environment variable [`ENV_ALLOW_SOFTWARE`] is set to
    /// `1`/`true`/`yes`/`on`, else [`AdapterChoice::HardwareOnly`]. Front ends should pass this to
    /// [`GpuContext::new`] for both `--backend auto` and `--backend gpu`.
    #[must_use]
    pub fn from_env() -> Self {
        let allow = std::env::var(ENV_ALLOW_SOFTWARE)
            .map(|v| matches!(v.trim().to_ascii_lowercase().as_str(), "1" | "true" | "yes" | "on"))
            .unwrap_or(false);
        if allow { AdapterChoice::AllowSoftware } else { AdapterChoice::HardwareOnly }
    }
}

/// Whether an adapter is a software implementation: wgpu reports [`wgpu::DeviceType::Cpu`], or the name is
/// one of the known software rasterisers (llvmpipe, lavapipe, SwiftShader, softpipe, Microsoft Basic Render).
#[must_use]
pub fn is_software_adapter(info: &wgpu::AdapterInfo) -> bool {
    if info.device_type == wgpu::DeviceType::Cpu {
        return true;
    }
    let name = info.name.to_ascii_lowercase();
    ["llvmpipe", "lavapipe", "swiftshader", "softpipe", "microsoft basic render"].iter().any(|s| name.contains(s))
}

/// One line describing an adapter, for logs and error messages: name, backend, device type, driver.
#[must_use]
pub fn describe_adapter(info: &wgpu::AdapterInfo) -> String {
    let mut s = format!("{} ({}, {:?}", info.name, info.backend.to_str(), info.device_type);
    let driver = format!("{} {}", info.driver, info.driver_info);
    let driver = driver.trim();
    if !driver.is_empty() {
        s.push_str(", driver ");
        s.push_str(driver);
    }
    s.push(')');
    s
}

/// The wgpu backends searched for adapters: the `WGPU_BACKEND` environment variable (a comma list such as
/// `vulkan`) if set, else [`wgpu::Backends::PRIMARY`] (Vulkan, Metal, DX12), restricted to the backends
/// compiled into this build.
#[must_use]
pub fn searched_backends() -> wgpu::Backends {
    wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY) & wgpu::Instance::enabled_backend_features()
}

fn backend_names(backends: wgpu::Backends) -> String {
    let names: Vec<&str> = wgpu::Backend::ALL
        .iter()
        .filter(|b| backends.contains(wgpu::Backends::from(**b)))
        .map(|b| b.to_str())
        .collect();
    if names.is_empty() { "none".to_owned() } else { names.join(", ") }
}

fn new_instance(backends: wgpu::Backends) -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    // Honour wgpu's own environment variables (WGPU_DEBUG, WGPU_VALIDATION, ...); they cannot widen
    // `backends` beyond what `searched_backends` already read from WGPU_BACKEND.
    let mut desc = desc.with_env();
    desc.backends = backends;
    wgpu::Instance::new(desc)
}

/// Every adapter wgpu enumerates on the [`searched_backends`], in wgpu's order, whatever its type.
/// Useful for `--list-gpus`-style diagnostics and for tests that must know what the machine has.
#[must_use]
pub fn enumerate_adapters() -> Vec<wgpu::AdapterInfo> {
    let backends = searched_backends();
    let instance = new_instance(backends);
    pollster::block_on(instance.enumerate_adapters(backends)).iter().map(wgpu::Adapter::get_info).collect()
}

/// Lower is better: discrete GPUs first, then integrated, virtual, unknown, software; Vulkan/Metal/DX12
/// before GL.
fn rank(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let software = is_software_adapter(info);
    let device = match info.device_type {
        _ if software => 4,
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    };
    let backend = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal => 0,
        wgpu::Backend::Dx12 => 1,
        _ => 2,
    };
    (device, backend)
}

fn pick_adapter(choice: AdapterChoice) -> Result<wgpu::Adapter, GpuError> {
    let backends = searched_backends();
    let instance = new_instance(backends);
    let adapters = pollster::block_on(instance.enumerate_adapters(backends));
    let name_filter = std::env::var(ENV_ADAPTER_NAME).unwrap_or_default().trim().to_ascii_lowercase();

    let mut seen = Vec::new();
    let mut best: Option<((u8, u8), wgpu::Adapter)> = None;
    for adapter in adapters {
        let info = adapter.get_info();
        let rejection = if info.backend == wgpu::Backend::Noop {
            Some("the no-op backend".to_owned())
        } else if !adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS) {
            Some("no compute shader support".to_owned())
        } else if !name_filter.is_empty() && !info.name.to_ascii_lowercase().contains(&name_filter) {
            Some(format!("name does not contain `{name_filter}` ({ENV_ADAPTER_NAME})"))
        } else if choice == AdapterChoice::HardwareOnly && is_software_adapter(&info) {
            Some(format!("software adapter, used only with {ENV_ALLOW_SOFTWARE}=1"))
        } else {
            None
        };
        match rejection {
            Some(why) => seen.push(format!("{}: {why}", describe_adapter(&info))),
            None => {
                let r = rank(&info);
                // Strictly better only: among equals, wgpu's enumeration order decides (stable run to run).
                if best.as_ref().is_none_or(|(best_rank, _)| r < *best_rank) {
                    best = Some((r, adapter));
                }
            }
        }
    }
    best.map(|(_, adapter)| adapter).ok_or_else(|| GpuError::NoAdapter {
        choice,
        backends: backend_names(backends),
        seen,
    })
}

/// A wgpu device and queue for compute work, with the adapter it came from.
///
/// Create one per process run with [`GpuContext::new`] (tests: [`GpuContext::shared_for_tests`]) and pass
/// `&GpuContext` to every kernel. All fields are `Send + Sync`; one context may be used from many threads.
#[derive(Debug)]
pub struct GpuContext {
    /// The logical device: creates buffers, shaders, pipelines.
    pub device: wgpu::Device,
    /// The device's queue: submits command buffers and writes buffers.
    pub queue: wgpu::Queue,
    /// The adapter the device was created on (its features and limits stay queryable).
    pub adapter: wgpu::Adapter,
    /// Name, vendor, backend and device type of the adapter.
    pub info: wgpu::AdapterInfo,
    /// The limits the device was created with: the adapter's own limits (see the crate docs).
    pub limits: wgpu::Limits,
}

static SHARED_FOR_TESTS: OnceLock<Result<GpuContext, GpuError>> = OnceLock::new();

impl GpuContext {
    /// Picks the best adapter allowed by `choice` (see the crate docs for the rules) and creates a device on
    /// it with the adapter's own limits and no optional features.
    ///
    /// # Errors
    /// [`GpuError::NoAdapter`] when no adapter qualifies (the message lists what was seen and how to get an
    /// adapter); [`GpuError::RequestDevice`] when wgpu refuses the device.
    pub fn new(choice: AdapterChoice) -> Result<GpuContext, GpuError> {
        Self::from_adapter(pick_adapter(choice)?)
    }

    /// A fresh context that accepts a software adapter ([`AdapterChoice::AllowSoftware`]).
    ///
    /// # Errors
    /// As [`GpuContext::new`].
    pub fn for_tests() -> Result<GpuContext, GpuError> {
        Self::new(AdapterChoice::AllowSoftware)
    }

    /// One process-wide context from [`GpuContext::for_tests`], created on first use. Tests should prefer this
    /// to creating a device each: it is cheaper, and parallel test threads share it safely. The result (also
    /// an error) is cached for the life of the process.
    ///
    /// # Errors
    /// As [`GpuContext::new`], returned to every caller.
    pub fn shared_for_tests() -> Result<&'static GpuContext, GpuError> {
        SHARED_FOR_TESTS.get_or_init(Self::for_tests).as_ref().map_err(Clone::clone)
    }

    /// Creates a device on a given adapter, with the adapter's own limits and no optional features.
    ///
    /// # Errors
    /// [`GpuError::RequestDevice`] when wgpu refuses the device.
    pub fn from_adapter(adapter: wgpu::Adapter) -> Result<GpuContext, GpuError> {
        let info = adapter.get_info();
        let desc = wgpu::DeviceDescriptor {
            label: Some("shatter-gpu"),
            required_features: wgpu::Features::empty(),
            required_limits: adapter.limits(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&desc))
            .map_err(|e| GpuError::RequestDevice { adapter: describe_adapter(&info), message: e.to_string() })?;
        let limits = device.limits();
        Ok(GpuContext { device, queue, adapter, info, limits })
    }

    /// Whether the device runs on a software adapter (see [`is_software_adapter`]).
    #[must_use]
    pub fn is_software(&self) -> bool {
        is_software_adapter(&self.info)
    }

    /// One line describing the adapter (see [`describe_adapter`]).
    #[must_use]
    pub fn describe(&self) -> String {
        describe_adapter(&self.info)
    }

    /// The largest storage-buffer binding, in bytes: `max_storage_buffer_binding_size`, capped by
    /// `max_buffer_size`. Arrays larger than this must be split, see [`crate::split_for_binding`].
    #[must_use]
    pub fn max_storage_binding_bytes(&self) -> u64 {
        self.limits.max_storage_buffer_binding_size.min(self.limits.max_buffer_size)
    }

    /// Runs `f` inside wgpu error scopes (validation, out-of-memory, internal) on this thread and turns a
    /// captured error into [`GpuError::Operation`] named by `operation`. Without a scope, wgpu's default
    /// handler panics on such errors. Use it around your own encoder/bind-group code.
    ///
    /// # Errors
    /// [`GpuError::Operation`] with wgpu's message if `f` triggered an error.
    pub fn with_error_scope<R>(
        &self,
        operation: impl FnOnce() -> String,
        f: impl FnOnce() -> R,
    ) -> Result<R, GpuError> {
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let result = f();
        // Scopes pop innermost first.
        let errors =
            [pollster::block_on(validation.pop()), pollster::block_on(oom.pop()), pollster::block_on(internal.pop())];
        match errors.into_iter().flatten().next() {
            None => Ok(result),
            Some(error) => Err(GpuError::Operation { operation: operation(), message: error_text(&error) }),
        }
    }
}

/// wgpu's error text plus its source chain (the description alone is sometimes terse).
pub(crate) fn error_text(error: &(dyn std::error::Error + 'static)) -> String {
    let mut text = error.to_string();
    let mut source = error.source();
    while let Some(s) = source {
        let more = s.to_string();
        if !more.is_empty() && !text.contains(&more) {
            text.push_str(": ");
            text.push_str(&more);
        }
        source = s.source();
    }
    text
}
