//! shatter GPU support: a headless wgpu compute context and small helpers shared by every GPU kernel
//! (simulation and ray tracer).
//!
//! Everything blocks (via `pollster`); there is no async API. The crate re-exports [`wgpu`] so callers use the
//! same version.
//!
//! # Adapter selection
//!
//! [`GpuContext::new`] enumerates adapters on the [`searched_backends`]: the `WGPU_BACKEND` environment
//! variable (comma list, e.g. `vulkan`) if set, else wgpu's primary backends (Vulkan, Metal, DX12; wgpu's GL
//! backend is not built in). It rejects the no-op backend, adapters without compute shaders, adapters whose
//! name lacks the value of [`ENV_ADAPTER_NAME`] (`SHATTER_GPU_ADAPTER`, if set), and — with
//! [`AdapterChoice::HardwareOnly`] — software adapters ([`is_software_adapter`]: wgpu's
//! [`wgpu::DeviceType::Cpu`], or a known software name such as llvmpipe/lavapipe/SwiftShader). Of the rest it
//! takes the best by device type (discrete, integrated, virtual, other, software), then backend (Vulkan/Metal,
//! DX12, GL), ties broken by wgpu's enumeration order. If none qualifies, [`GpuError::NoAdapter`] lists every
//! adapter seen with the reason it was rejected and says how to get one.
//!
//! The `--backend` flag maps onto this as follows:
//!
//! ```no_run
//! use shatter_gpu::{AdapterChoice, GpuContext};
//! # fn run() -> Result<(), shatter_gpu::GpuError> {
//! # let backend = "auto";
//! let choice = AdapterChoice::from_env(); // HardwareOnly unless SHATTER_GPU_ALLOW_SOFTWARE=1
//! let gpu: Option<GpuContext> = match backend {
//!     "cpu" => None,
//!     "gpu" => Some(GpuContext::new(choice)?), // no adapter: a clear error
//!     _ /* auto */ => GpuContext::new(choice).ok(), // no hardware GPU: the CPU path
//! };
//! # let _ = gpu; Ok(()) }
//! ```
//!
//! A software adapter (Mesa lavapipe on Linux) is used only when asked for: by tests through
//! [`GpuContext::for_tests`] / [`GpuContext::shared_for_tests`] ([`AdapterChoice::AllowSoftware`]), and by users
//! through the environment variable [`ENV_ALLOW_SOFTWARE`] (`SHATTER_GPU_ALLOW_SOFTWARE=1`), read by
//! [`AdapterChoice::from_env`].
//!
//! # Limits and features
//!
//! The device is requested with the adapter's own limits (`adapter.limits()`), not wgpu's defaults: e.g.
//! `max_storage_buffer_binding_size` is the adapter's (128 MiB on lavapipe, often 2–4 GiB on discrete GPUs)
//! rather than the 128 MiB default, and `max_buffer_size` likewise. [`GpuContext::limits`] holds what the
//! device got. No optional features are requested, so kernels are plain WebGPU compute: no `f64`, no float
//! atomics, no push constants/immediates, no timestamp queries.
//!
//! # Splitting big arrays
//!
//! A storage binding holds at most [`GpuContext::max_storage_binding_bytes`]
//! (`min(max_storage_buffer_binding_size, max_buffer_size)`). [`split_for_binding`] (or
//! [`GpuContext::binding_chunks`]) cuts `len` elements into [`BindingChunk`]s: each holds a whole number of
//! steps of `lcm(size_of::<T>(), min_storage_buffer_offset_alignment, 4)` bytes (all but the last one the same,
//! largest size under the limit), so every chunk starts on an element boundary at an offset valid for binding.
//! Callers then either bind one big buffer at each chunk's offset ([`BindingChunk::binding`]), dispatching once
//! per chunk with the chunk's first element index in a uniform, or bind several chunk buffers side by side;
//! when even `max_buffer_size` is too small, upload each chunk into its own buffer
//! ([`split_slice_for_binding`]). Readback is chunked independently through a bounded staging buffer
//! ([`READBACK_CHUNK_BYTES`]).
//!
//! # Kernels and dispatch
//!
//! [`ComputeKernel`] wraps one WGSL file with exactly one `@compute` entry point. Workgroup counts above
//! `max_compute_workgroups_per_dimension` are laid out as a 2D grid ([`DispatchGrid`]); shaders compute their
//! linear index from `workgroup_id` and `num_workgroups` and bounds-check it (see [`ComputeKernel`]).
//! Errors wgpu would otherwise raise as panics (validation, out of memory) are caught with error scopes and
//! returned as [`GpuError`]; use [`GpuContext::with_error_scope`] around your own wgpu calls for the same.
//!
//! # Readback and determinism
//!
//! [`GpuContext::read_buffer`] copies into a `MAP_READ` staging buffer, submits, calls `map_async`, waits with
//! `device.poll(wgpu::PollType::Wait { submission_index: Some(index), timeout: None })`, then copies the mapped
//! bytes out. Nothing in this crate uses atomics, so a kernel whose own code is free of order-dependent
//! reductions reads back bit-identical results run to run.

pub use wgpu;

mod buffers;
mod context;
mod error;
mod kernel;
mod split;
mod wgsl_parts;

pub use buffers::READBACK_CHUNK_BYTES;
pub use context::{
    AdapterChoice, ENV_ADAPTER_NAME, ENV_ALLOW_SOFTWARE, GpuContext, describe_adapter, enumerate_adapters,
    is_software_adapter, searched_backends,
};
pub use error::GpuError;
pub use kernel::{ComputeKernel, DispatchGrid, compile_wgsl};
pub use split::{BindingChunk, split_for_binding, split_slice_for_binding};
pub use wgsl_parts::join_wgsl;
