//! The GPU backend (wgpu, WGSL): the CPU model of [`crate::cpu_simulation`] with one particle
//! per invocation, after section 3 of Levine et al.
//!
//! # Kernels
//!
//! One entry point per file in `sim/shaders/`, each with a CPU twin of the same name in
//! `sim/src/twins/` (built for tests only). A step is, in one compute pass (and a batch of up to
//! [`BATCH`] steps in one submission):
//!
//! 1. `kick_drift` (position update; from the second step of a batch on, compiled with
//!    `LAND_FIRST`: the previous step's velocity update fused in): v += dt/2 F/m, u += dt v; packs
//!    the compression boost next to u; flags the contact lists stale when a particle moved half
//!    the skin.
//! 2. Contact (when K_c > 0): `contact_plan` turns the stale flag into indirect dispatch sizes (zero
//!    when the lists are fresh, so the rebuild costs little); the rebuild `contact_count`,
//!    `scan_blocks`, `scan_block_sums`, `scan_add`, `contact_scatter`, `contact_rank`,
//!    `contact_candidates` bins the particles by a deterministic counting sort and lists each
//!    particle's candidates in increasing index; `collisions` sums eq. 6 over them.
//! 3. `spring_forces` (fused with the body forces of `force_common.wgsl`): the bonds (stretch,
//!    break, force), the contact force, gravity, projectiles and indenters; the next boost; break
//!    events; the workgroup's external power. With the elastoplastic model instead
//!    `family_dilatation` (extensions, dilatation, damage) then `family_forces` (both ends' force
//!    scalars, the plastic return map, the break test, contact, body forces, grips), over the same
//!    sliced bond layout (`family.rs`).
//! 4. `power_sum`: the step's external power into the work done (two-float sum).
//! 5. `kick_floor` (velocity update, at the end of a batch).
//!
//! `bond_energy` runs at frame boundaries only.
//!
//! # Determinism
//!
//! No float is ever summed in an order that depends on timing: every particle sums its own
//! bonds in row order and its contact candidates in index order; the power is a fixed tree.
//! Atomics only count (bucket sizes, break events) or OR flags; the one order they do produce
//! (arrival in a hash bucket) is replaced by a ranking by index, and break events are sorted by
//! (step, bond) when read. So one GPU gives bit-identical results run to run.
//!
//! # Readback
//!
//! Nothing is read back inside the step loop. At a frame boundary the state, the events and the
//! counters are read; if a capacity (break events of the frame, contact candidates per particle)
//! overflowed, the buffers grow and the frame is replayed from a GPU-side snapshot of its start:
//! the result is the same as with large enough buffers from the start.
//!
//! # Files
//!
//! - `gpu_simulation.rs`: [`GpuSimulation`], its construction and its [`crate::Backend`] impl.
//! - `sim_buffers.rs`: its buffers, their creation and the upload of host-side state.
//! - `bind_groups.rs`: which buffers each kernel binds.
//! - `stepping.rs`: batches of steps and the force pass, recorded as dispatches.
//! - `snapshot.rs`: readback at frame boundaries, the snapshot and the replay after an overflow.
//! - `family.rs`: the elastoplastic model's buffers and the host's copy of its state.
//! - [`shaders`]: the WGSL sources and their compilation; [`wgsl_structs`]: host mirrors of the
//!   WGSL structs.
//! - The bond layout is [`crate::bond_layouts::gpu_layout`].

mod bind_groups;
mod family;
mod gpu_simulation;
pub(crate) mod shaders;
mod sim_buffers;
mod snapshot;
mod stepping;
pub(crate) mod wgsl_structs;

#[cfg(test)]
mod tests;

pub use gpu_simulation::{GpuHandle, GpuOptions, GpuSimulation};
pub use stepping::BATCH;
