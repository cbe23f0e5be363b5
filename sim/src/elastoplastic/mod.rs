//! The elastoplastic material model (Chen et al., section 4 and 5.1): an ordinary state-based
//! peridynamic solid with a dilatation and a deviatoric part, per-bond plasticity and a ductile
//! fracture criterion. Everything the model keeps and does is in this folder; the simulation
//! reaches it through [`crate::material_bonds::MaterialBonds`].
//!
//! - [`constants`]: the model's constants, from `[material]`.
//! - [`family_table`]: the bonds in a fixed-stride layout (every particle's family padded to the
//!   same length, groups of eight particles interleaved entry by entry), their rest geometry,
//!   influence, thresholds, plastic extensions, and each particle's weighted volume.
//! - [`passes`]: the two passes of a force evaluation (dilatation; force scalars with the
//!   plastic return map, the break test and the bond forces), eight particles at a time, and the
//!   stored energy.
//! - [`lattice_families`]: the same bonds on the lattice layout, for particles on a cubic
//!   lattice: each bond stored once for both ends, and each particle's values per slot.
//! - [`lattice_passes`]: the two passes on the lattice layout, each bond computed once for both
//!   ends, eight bonds at a time without gathers.
//! - [`family_bonds`]: which of the two layouts a CPU simulation runs on.

pub(crate) mod constants;
pub(crate) mod family_bonds;
pub(crate) mod family_table;
pub(crate) mod lattice_families;
pub(crate) mod lattice_passes;
pub(crate) mod passes;

pub use constants::StateBasedConstants;
pub use family_bonds::FamilyBonds;
pub use family_table::FamilyTable;
pub use lattice_families::LatticeFamilies;
