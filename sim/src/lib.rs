//! The simulation stage of shatter: bond-based peridynamics (PMB) after Levine et al. and Silling
//! and Askari, on the CPU (the reference and fallback) and on the GPU (wgpu/WGSL).
//!
//! Not built yet: the CPU backend arrives with issue #3, the GPU backend with issue #6.
