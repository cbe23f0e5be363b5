//! How the bonds are stored for the force pass: three layouts of the same bonds, with the same
//! per-entry values (stiffness and critical stretch) in each.
//!
//! - [`row_layout`]: the CPU's row layout, rows of bond blocks in chunks of particles; any
//!   particle set.
//! - [`lattice_layout`]: the CPU's layout for particles on a cubic lattice, whose blocks need no
//!   gathers.
//! - [`layout_choice`]: which of the two a CPU simulation runs on ([`LayoutChoice`]).
//! - [`gpu_layout`]: the GPU's layout, both directions of every bond in sliced-ELLPACK order, cut
//!   into ranges that each fit one storage binding.

mod entry_values;
pub(crate) mod gpu_layout;
pub(crate) mod lattice_layout;
pub(crate) mod layout_choice;
pub(crate) mod row_layout;

pub(crate) use entry_values::EntryValues;
pub use layout_choice::LayoutChoice;
