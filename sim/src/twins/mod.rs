//! CPU twins of the GPU kernels: one function per WGSL file in `sim/shaders/`, each in a file of
//! the same name (`kick_drift.wgsl`'s twin in `kick_drift.rs`, and so on; `common.rs` mirrors
//! `common.wgsl`'s helpers), with the same name, taking the shader's bindings as one struct
//! (`kick_drift`'s `KickDriftBindings`, and so on: a field per binding, named as the binding, in
//! binding order, a slice of the same element type; `&mut` where the shader writes), written to
//! read like the shader: a loop over the invocations with the shader's body inside, the same
//! operations in the same order.
//! The GPU may fuse a multiply and an add into one FMA and its `sqrt`, division and `pow` need not
//! round correctly, so results agree to a few ulps, not bit for bit; the parity tests of
//! [`crate::gpu`] (`sim/src/gpu/tests.rs`) compare each pair on random inputs.
//!
//! Workgroup atomics and barriers become plain sequential code: an atomic increment's return
//! value (which varies from run to run on the GPU) is taken in invocation order, which is one
//! of the orders the GPU may produce; everything the kernels compute from it is independent of
//! that order.
//!
//! "Twin" means only this: the CPU mirror of a WGSL kernel. The CPU backend's production kernels
//! are [`crate::kernels`].

// Indexed loops mirror the shaders.
// `!(a <= b)` is the shaders' NaN-aware test.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

mod bond_energy;
mod collisions;
mod common;
mod contact_candidates;
mod contact_count;
mod contact_plan;
mod contact_rank;
mod contact_scatter;
mod family_dilatation;
mod family_forces;
mod force_common;
mod kick_drift;
mod kick_floor;
mod power_sum;
mod scan_add;
mod scan_block_sums;
mod scan_blocks;
mod spring_forces;

pub use bond_energy::{BondEnergyBindings, bond_energy};
pub use collisions::{CollisionsBindings, collisions};
pub use common::{I4, U4, V4};
pub use contact_candidates::{ContactCandidatesBindings, contact_candidates};
pub use contact_count::{ContactCountBindings, contact_count};
pub use contact_plan::{ContactPlanBindings, contact_plan};
pub use contact_rank::{ContactRankBindings, contact_rank};
pub use contact_scatter::{ContactScatterBindings, contact_scatter};
pub use family_dilatation::{FamilyDilatationBindings, family_dilatation};
pub use family_forces::{FamilyForcesBindings, family_forces};
pub use kick_drift::{KickDriftBindings, kick_drift};
pub use kick_floor::{KickFloorBindings, kick_floor};
pub use power_sum::{PowerSumBindings, power_sum};
pub use scan_add::{ScanAddBindings, scan_add};
pub use scan_block_sums::{ScanBlockSumsBindings, scan_block_sums};
pub use scan_blocks::{ScanBlocksBindings, scan_blocks};
pub use spring_forces::{SpringForcesBindings, spring_forces};
