//! The bond layout a CPU simulation runs on: the lattice layout where the particles sit on a
//! cubic lattice (it needs no gathers), else the row layout, which takes any particle set.

use rayon::prelude::*;
use shatter_core::particles::ParticleSet;

use super::EntryValues;
use super::lattice_layout::LatticeTable;
use super::row_layout::{self, BondTable, LANES, PADDING};

/// Which layouts a CPU simulation may run on: what [`SpringTable`] may choose from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LayoutChoice {
    /// The lattice layout where it applies, else the row layout.
    Fastest,
    /// The row layout always (tests compare the two).
    RowsOnly,
}

/// One stored bond entry as every layout presents it: particle i's bond to j.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StoredBond {
    /// The particle whose entry this is.
    pub i: usize,
    /// Its partner.
    pub j: usize,
    /// Rest vector xi = X_j - X_i, metres.
    pub rest_vector: [f32; 3],
    /// Rest length |xi|, metres.
    pub rest_length_m: f32,
    /// Stiffness k, N per unit stretch; 0 once broken.
    pub stiffness: f32,
    /// Stored once for both ends (else each end stores its own entry).
    pub internal: bool,
}

/// The bond layout of a CPU simulation.
#[derive(Debug, Clone)]
pub enum SpringTable {
    /// Rows of bond blocks, any particle set.
    Rows(BondTable),
    /// Bricks of lattice sites.
    Lattice(Box<LatticeTable>),
}

impl SpringTable {
    /// The layout for `particles` with the bond values of `values`.
    pub(crate) fn new(particles: &ParticleSet, values: &EntryValues, choice: LayoutChoice) -> SpringTable {
        let lattice = match choice {
            LayoutChoice::Fastest => LatticeTable::new(particles, values),
            LayoutChoice::RowsOnly => None,
        };
        match lattice {
            Some(lattice) => SpringTable::Lattice(Box::new(lattice)),
            None => SpringTable::Rows(BondTable::new(particles, values)),
        }
    }

    /// Marks the bonds with the given ids (sorted) broken.
    pub fn mark_broken(&mut self, sorted_ids: &[u64]) {
        match self {
            SpringTable::Rows(table) => {
                table.mark_broken(sorted_ids);
            }
            SpringTable::Lattice(table) => {
                for chunk in &mut table.chunks {
                    let blocks = &mut chunk.blocks;
                    row_layout::mark_broken(&chunk.bond_id, sorted_ids, |block, lane| {
                        blocks[block].threshold[lane] = f32::INFINITY;
                        blocks[block].stiffness[lane] = 0.0;
                    });
                }
            }
        }
    }

    /// Number of chunks.
    fn chunk_count(&self) -> usize {
        match self {
            SpringTable::Rows(table) => table.chunks.len(),
            SpringTable::Lattice(table) => table.chunks.len(),
        }
    }

    /// Calls `entry` with every stored bond entry of chunk `c` (padding skipped), in a fixed
    /// order.
    fn for_each_entry_of_chunk(&self, c: usize, mut entry: impl FnMut(&StoredBond)) {
        match self {
            SpringTable::Rows(table) => {
                let chunk = &table.chunks[c];
                for local in 0..chunk.len {
                    for (block, lane, internal) in chunk.row_bonds(local) {
                        let bond = &chunk.blocks[block];
                        entry(&StoredBond {
                            i: chunk.first + local,
                            j: bond.neighbor[lane] as usize,
                            rest_vector: bond.rest_vector.map(|axis| axis[lane]),
                            rest_length_m: bond.rest_length_m[lane],
                            stiffness: bond.stiffness[lane],
                            internal,
                        });
                    }
                }
            }
            SpringTable::Lattice(table) => {
                let chunk = &table.chunks[c];
                let shape = &chunk.shape;
                for brick in 0..shape.brick_slot.len() {
                    let own = shape.brick_slot[brick] as usize;
                    for (block, internal) in shape.brick_blocks(brick) {
                        let partner = shape.partner_slot[block] as usize;
                        let (bonds, rest) = (&chunk.blocks[block], &chunk.rest[block]);
                        for lane in 0..LANES {
                            if chunk.bond_id[block * LANES + lane] != PADDING {
                                entry(&StoredBond {
                                    i: table.particle_of[own + lane] as usize,
                                    j: table.particle_of[partner + lane] as usize,
                                    rest_vector: rest.vector_m,
                                    rest_length_m: rest.length_m,
                                    stiffness: bonds.stiffness[lane],
                                    internal,
                                });
                            }
                        }
                    }
                }
            }
        }
    }

    /// `for_each_entry_of_chunk` over all chunks, in chunk order: `entry` with every stored bond
    /// entry (padding skipped).
    pub fn for_each_entry(&self, mut entry: impl FnMut(&StoredBond)) {
        for c in 0..self.chunk_count() {
            self.for_each_entry_of_chunk(c, &mut entry);
        }
    }

    /// The sum of `value` over all stored entries: summed per chunk in entry order, in parallel,
    /// then over chunks in order (the same on any thread count).
    pub fn sum_entries(&self, value: impl Fn(&StoredBond) -> f64 + Sync) -> f64 {
        let sums: Vec<f64> = (0..self.chunk_count())
            .into_par_iter()
            .map(|c| {
                let mut sum = 0.0;
                self.for_each_entry_of_chunk(c, |bond| sum += value(bond));
                sum
            })
            .collect();
        sums.iter().sum()
    }

    /// Calls `f` with the id of every bond the last force pass broke, chunk by chunk in the order
    /// they broke.
    pub fn for_each_break(&self, mut f: impl FnMut(u64)) {
        match self {
            SpringTable::Rows(table) => table.chunks.iter().flat_map(|c| &c.breaks).for_each(|id| f(*id)),
            SpringTable::Lattice(table) => table.chunks.iter().flat_map(|c| &c.breaks).for_each(|id| f(*id)),
        }
    }

    /// Bond entries the force pass computes per step: (internal, stored once and applied to
    /// both ends; external, stored and computed on both sides).
    pub fn entries(&self) -> (usize, usize) {
        let mut counts = (0, 0);
        self.for_each_entry(|bond| if bond.internal { counts.0 += 1 } else { counts.1 += 1 });
        counts
    }
}
