//! The simulation stage of shatter: bond-based peridynamics (PMB) after Levine et al. and Silling
//! and Askari, on the CPU (this crate's production path and the reference for the GPU backend).
//!
//! - [`model`]: constants and start checks derived from the config and the particle file.
//! - [`bond_table`]: the chunked bond layout (rows of bond blocks, any particle set).
//! - [`lattice_table`]: the bond layout for particles on a cubic lattice (no gathers).
//! - [`spring_table`]: which of the two layouts a simulation runs on.
//! - [`kernels`]: the step's kernels (springs, collisions, body forces, Verlet halves).
//! - [`simulation`]: the state and the step.
//! - [`gpu`]: the GPU backend (wgpu, WGSL kernels in `shaders/`, their CPU twins).
//! - [`backend`]: what the frame loop needs of either backend.
//! - [`art`]: art direction of the cracks (weakened paths, seams, shards).
//! - [`sim_driver`]: the `shatter sim` driver: frames, checkpoints, resume, stability checks.

pub mod art;
pub mod backend;
pub mod bond_table;
pub mod contact;
pub mod gpu;
pub mod kernels;
pub mod lattice_table;
pub mod model;
pub mod sim_driver;
pub mod simulation;
pub mod spring_table;

pub use backend::{Backend, create_backend};
pub use gpu::GpuSimulation;
pub use model::Model;
pub use simulation::{Dynamics, Energy, Simulation};
pub use spring_table::LayoutChoice;

/// Why a simulation cannot start or had to stop.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The particle file does not match the config's geometry.
    #[error("{0}")]
    StaleParticles(String),
    /// Something would start inside the body or below the floor.
    #[error("{0}")]
    BadStart(String),
    /// An input of the run (a seam mesh, a setting) is unusable.
    #[error("{0}")]
    BadInput(String),
}
