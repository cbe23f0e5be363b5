//! The simulation stage of shatter: bond-based peridynamics (PMB) after Levine et al. and Silling
//! and Askari, on the CPU (this crate's production path and the reference for the GPU backend)
//! and on the GPU.
//!
//! - [`model`]: constants and start checks derived from the config and the particle file;
//!   [`sim_error`]: what those checks report.
//! - [`state`]: the state of a run and its energies, the same for every backend.
//! - [`bond_layouts`]: how the bonds are stored: the CPU's row and lattice layouts and the choice
//!   between them, and the GPU's sliced layout.
//! - [`material_bonds`]: the material-model seam: the run's bonds by model, PMB's spring tables
//!   or [`elastoplastic`]'s family table (Chen et al.'s state-based elastoplastic model).
//! - [`kernels`]: the CPU step's kernels (springs, collisions, body forces, Verlet halves).
//! - [`contact`]: contact between unbonded particles (Verlet lists over a spatial hash).
//! - [`cpu_simulation`]: the CPU backend, the state and the step.
//! - [`gpu`]: the GPU backend (wgpu, WGSL kernels in `shaders/`).
//! - `twins` (built for tests only): the CPU twin of each WGSL kernel, which the GPU's parity
//!   tests compare it with.
//! - [`simd_path`]: which instruction set the CPU's spring kernels use (`--simd`,
//!   `SHATTER_SIMD`).
//! - [`backend`]: what the frame loop needs of either backend; [`backend_choice`]: which one runs.
//! - [`art`]: art direction of the cracks (weakened paths, seams, shards).
//! - [`sim_driver`]: the `shatter sim` driver: frames, checkpoints, resume, stability checks;
//!   `lead_in_start`: a run from the lead-in's handoff; [`previous_run`]: a fresh run keeps its
//!   predecessor's outputs until it has a checkpoint.

pub mod art;
mod backend;
pub mod backend_choice;
mod bond_layouts;
mod contact;
mod cpu_simulation;
pub mod elastoplastic;
pub mod gpu;
pub mod kernels;
mod lead_in_start;
mod material_bonds;
mod model;
mod previous_run;
pub mod sim_driver;
mod sim_error;
mod simd_path;
mod state;
#[cfg(test)]
mod twins;

pub use backend::{Backend, DeviceError};
pub use backend_choice::{BackendError, create_backend};
pub use bond_layouts::LayoutChoice;
pub use cpu_simulation::CpuSimulation;
pub use gpu::GpuSimulation;
pub use model::Model;
pub use sim_error::SimError;
pub use simd_path::SimdPath;
pub use state::{Dynamics, Energy};
