//! The state-based model's bonds in the layout a CPU simulation runs on: the lattice layout
//! ([`LatticeFamilies`]) where the particles sit on a cubic lattice, else the family table
//! ([`FamilyTable`]), which takes any particle set. Both give the same model; they add the
//! family sums in different orders, so their results agree to rounding.

use shatter_core::particles::ParticleSet;

use super::{FamilyTable, LatticeFamilies, StateBasedConstants};
use crate::SimError;

/// The state-based model's bonds on the CPU.
#[derive(Debug, Clone)]
pub enum FamilyBonds {
    /// Any particle set: each bond stored and computed at both ends.
    Rows(Box<FamilyTable>),
    /// Particles on a cubic lattice: each bond computed once for both ends, without gathers.
    Lattice(Box<LatticeFamilies>),
}

impl FamilyBonds {
    /// The bonds of `particles`: on the lattice layout where it applies and `lattice` allows it,
    /// else in a family table of chunks of `chunk_size` particles. `threshold(k)` is the
    /// critical stretch of file entry k.
    pub fn new(
        particles: &ParticleSet,
        constants: StateBasedConstants,
        chunk_size: usize,
        threshold: impl Fn(usize) -> f32 + Sync,
        lattice: bool,
    ) -> Result<FamilyBonds, SimError> {
        if lattice && let Some(table) = LatticeFamilies::new(particles, constants, &threshold) {
            return Ok(FamilyBonds::Lattice(Box::new(table)));
        }
        Ok(FamilyBonds::Rows(Box::new(FamilyTable::new(particles, constants, chunk_size, threshold)?)))
    }

    /// Marks bonds broken by id (sorted).
    pub fn mark_broken(&mut self, sorted_ids: &[u64]) {
        match self {
            FamilyBonds::Rows(table) => table.mark_broken(sorted_ids),
            FamilyBonds::Lattice(table) => table.mark_broken(sorted_ids),
        }
    }

    /// Calls `f` with each bond broken in the last evaluation, in a fixed order.
    pub fn for_each_break(&self, mut f: impl FnMut(u64)) {
        match self {
            FamilyBonds::Rows(table) => table.breaks.iter().flatten().for_each(|id| f(*id)),
            FamilyBonds::Lattice(table) => table.for_each_break(f),
        }
    }

    /// One force evaluation at displacements `disp`, into `force` (newtons).
    pub fn evaluate(&mut self, disp: [&[f32]; 3], force: [&mut [f32]; 3]) {
        match self {
            FamilyBonds::Rows(table) => table.evaluate(disp, force),
            FamilyBonds::Lattice(table) => table.evaluate(disp, force),
        }
    }

    /// The elastic energy stored at each particle, joules.
    pub fn energy_per_particle(&self, disp: [&[f32]; 3]) -> Vec<f64> {
        match self {
            FamilyBonds::Rows(table) => table.energy_per_particle(disp),
            FamilyBonds::Lattice(table) => table.energy_per_particle(disp),
        }
    }

    /// The largest stable time step, seconds, at `density_kg_m3`.
    pub fn stable_dt_s(&self, density_kg_m3: f64) -> f64 {
        match self {
            FamilyBonds::Rows(table) => table.stable_dt_s(density_kg_m3),
            FamilyBonds::Lattice(table) => table.stable_dt_s(density_kg_m3),
        }
    }

    /// The plastic extensions in the particle file's entry order.
    pub fn plastic_in_file_order(&self) -> Vec<f32> {
        match self {
            FamilyBonds::Rows(table) => table.plastic_in_file_order(),
            FamilyBonds::Lattice(table) => table.plastic_in_file_order(),
        }
    }

    /// Sets the plastic extensions from the particle file's entry order.
    pub fn set_plastic_from_file_order(&mut self, plastic: &[f32]) -> Result<(), String> {
        match self {
            FamilyBonds::Rows(table) => table.set_plastic_from_file_order(plastic),
            FamilyBonds::Lattice(table) => table.set_plastic_from_file_order(plastic),
        }
    }

    /// Bond entries in the particle file (each bond once from each end).
    pub fn bond_entries(&self) -> usize {
        match self {
            FamilyBonds::Rows(table) => table.initial.iter().map(|c| *c as usize).sum(),
            FamilyBonds::Lattice(table) => table.bond_entries(),
        }
    }

    /// True on the lattice layout.
    pub fn on_lattice(&self) -> bool {
        matches!(self, FamilyBonds::Lattice(_))
    }
}
