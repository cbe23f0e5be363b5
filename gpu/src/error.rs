//! The one error type of this crate.

use crate::context::AdapterChoice;

/// Everything that can go wrong while setting up the GPU or running a kernel through this crate.
///
/// Every variant carries plain strings (no wgpu handles), so the error is `Clone + Send + Sync` and
/// can be cached, e.g. by [`GpuContext::shared_for_tests`](crate::GpuContext::shared_for_tests).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GpuError {
    /// No adapter that satisfies the [`AdapterChoice`] was found.
    #[error(
        "no {wanted} adapter found (wgpu backends searched: {backends}; adapters seen: {seen}). {hint}",
        wanted = choice_words(*.choice),
        seen = seen_list(.seen),
        hint = no_adapter_hint(*.choice),
    )]
    NoAdapter {
        /// What was asked for.
        choice: AdapterChoice,
        /// The wgpu backends that were searched, e.g. `VULKAN | METAL | DX12`.
        backends: String,
        /// One line per adapter that wgpu did enumerate but that was rejected, with the reason.
        seen: Vec<String>,
    },

    /// wgpu found an adapter but refused to create a device on it.
    #[error("could not create a device on GPU adapter `{adapter}`: {message}")]
    RequestDevice {
        /// The adapter's name and backend.
        adapter: String,
        /// wgpu's explanation.
        message: String,
    },

    /// A WGSL shader did not parse or validate.
    #[error("WGSL shader `{shader}` failed to compile:\n{message}")]
    ShaderCompile {
        /// The shader's name (usually its file name), as given to the compile function.
        shader: String,
        /// The compiler's diagnostics, with source lines.
        message: String,
    },

    /// A WGSL shader compiled but does not have the shape a [`ComputeKernel`](crate::ComputeKernel) needs.
    #[error("WGSL shader `{shader}` cannot be used as a compute kernel: {message}")]
    KernelShape {
        /// The shader's name.
        shader: String,
        /// What is wrong, e.g. "it has 2 compute entry points (a, b); exactly one is required".
        message: String,
    },

    /// wgpu reported a validation error (or ran out of memory) during an operation of this crate.
    #[error("GPU operation `{operation}` failed: {message}")]
    Operation {
        /// What was being done, e.g. "dispatch `saxpy.wgsl`" or "create bind group 0 of `x.wgsl`".
        operation: String,
        /// wgpu's explanation.
        message: String,
    },

    /// A buffer would exceed the device's `max_buffer_size`.
    #[error("buffer `{label}` needs {bytes} bytes, more than the device's max_buffer_size of {max} bytes")]
    BufferTooLarge {
        /// The buffer's label.
        label: String,
        /// The requested size.
        bytes: u64,
        /// The device limit.
        max: u64,
    },

    /// A dispatch needs more workgroups than fit in a 2D grid of `max_per_dimension`².
    #[error(
        "a dispatch of {workgroups} workgroups does not fit in a {max_per_dimension} x {max_per_dimension} grid; \
         split the work into several dispatches"
    )]
    DispatchTooLarge {
        /// Workgroups asked for.
        workgroups: u64,
        /// The device's `max_compute_workgroups_per_dimension`.
        max_per_dimension: u32,
    },

    /// The binding-splitting helper was given parameters it cannot satisfy.
    #[error("cannot split into binding chunks: {message}")]
    Split {
        /// Why.
        message: String,
    },

    /// Reading a buffer back to the CPU failed.
    #[error("reading back {what} failed: {message}")]
    Readback {
        /// What was read, e.g. "4096 bytes at offset 0 of a 4096-byte buffer".
        what: String,
        /// Why.
        message: String,
    },
}

fn choice_words(choice: AdapterChoice) -> &'static str {
    match choice {
        AdapterChoice::HardwareOnly => "hardware GPU",
        AdapterChoice::AllowSoftware => "GPU (hardware or software)",
    }
}

fn seen_list(seen: &[String]) -> String {
    if seen.is_empty() { "none".to_owned() } else { seen.join("; ") }
}

fn no_adapter_hint(choice: AdapterChoice) -> String {
    let mut hint = String::new();
    match choice {
        AdapterChoice::HardwareOnly => {
            hint.push_str("Install the Vulkan driver for your GPU (and the Vulkan loader, Debian: `libvulkan1`)");
            hint.push_str(&format!(
                ", or set {}=1 to accept a software adapter such as Mesa lavapipe (slow; Debian: \
                 `mesa-vulkan-drivers`)",
                crate::ENV_ALLOW_SOFTWARE
            ));
        }
        AdapterChoice::AllowSoftware => {
            hint.push_str(
                "Install a Vulkan driver: your GPU vendor's, or Mesa lavapipe for a software one (Debian: \
                 `mesa-vulkan-drivers` and `libvulkan1`)",
            );
        }
    }
    hint.push_str(&format!(
        ". `WGPU_BACKEND` selects wgpu backends (default: the primary ones, Vulkan/Metal/DX12), {} filters \
         adapters by name; `--backend cpu` runs without a GPU.",
        crate::ENV_ADAPTER_NAME
    ));
    hint
}
