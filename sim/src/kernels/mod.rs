//! The step's kernels on the CPU, one function per kernel of the paper's GPU structure
//! (position update, spring forces, collisions, body forces, velocity update). Each works on one
//! chunk of particles and writes only that chunk's outputs.
//!
//! - `springs`: the spring kernel of the row layout and what the spring kernels share (the pass
//!   rules, the stretch); `springs_avx2`: its row kernel in AVX2 instructions.
//! - `lattice_springs`: the spring kernel of the lattice layout; `lattice_springs_avx512`: its
//!   brick kernel in AVX-512 instructions.
//! - `contact_forces`: collisions, and LAMMPS's short-range force.
//! - `body_forces`: gravity, projectiles and indenters.
//! - `verlet_kicks`: the halves of velocity Verlet.
//! - `lanes`: arithmetic on eight f32 lanes, shared by the kernels.
//! - `prefetch`: the cache hint that the spring kernels and the elastoplastic lattice passes give
//!   ahead of their block streams.

// Indexed loops, as in the WGSL kernels of the same passes.
#![allow(clippy::needless_range_loop)]

mod body_forces;
mod contact_forces;
pub(crate) mod lanes;
mod lattice_springs;
#[cfg(target_arch = "x86_64")]
mod lattice_springs_avx512;
pub(crate) mod prefetch;
mod springs;
#[cfg(target_arch = "x86_64")]
mod springs_avx2;
mod verlet_kicks;

pub use body_forces::{BodyForces, SphereNow, body_forces, indenter_force, projectile_force};
pub use contact_forces::{ContactChunk, collisions, short_range};
pub use lattice_springs::lattice_spring_forces;
pub use springs::{ChunkForces, Gathers, ParticleRecord, PassRules, spring_forces, stretch};
pub use verlet_kicks::{kick_drift, kick_floor, kick_floor_drift};
