//! CPU twins of the GPU kernels: one function per WGSL file in `sim/shaders/`, each in a file of
//! the same name (`kick_drift.wgsl`'s twin in `kick_drift.rs`, and so on; `common.rs` mirrors
//! `common.wgsl`'s helpers), with the same name and the same inputs (the shader's bindings, in
//! binding order, as slices of the same element types), written to read like the shader: a loop
//! over the invocations with the shader's body inside, the same operations in the same order.
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
#![allow(clippy::needless_range_loop, clippy::too_many_arguments, clippy::neg_cmp_op_on_partial_ord)]

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

pub use bond_energy::bond_energy;
pub use collisions::collisions;
pub use common::{I4, U4, V4, bucket_of, cell_of, dot3};
pub use contact_candidates::contact_candidates;
pub use contact_count::contact_count;
pub use contact_plan::contact_plan;
pub use contact_rank::contact_rank;
pub use contact_scatter::contact_scatter;
pub use family_dilatation::family_dilatation;
pub use family_forces::family_forces;
pub use force_common::cube_root;
pub use kick_drift::kick_drift;
pub use kick_floor::kick_floor;
pub use power_sum::power_sum;
pub use scan_add::scan_add;
pub use scan_block_sums::scan_block_sums;
pub use scan_blocks::scan_blocks;
pub use spring_forces::spring_forces;
