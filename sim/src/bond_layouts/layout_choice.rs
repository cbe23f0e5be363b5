//! The bond layout a CPU simulation runs on: the lattice layout where the particles sit on a
//! cubic lattice (it needs no gathers), else the row layout, which takes any particle set.

use rayon::prelude::*;
use shatter_core::particles::ParticleSet;

use super::EntryValues;
use super::lattice_layout::{LatticeTable, NO_PARTICLE};
use super::row_layout::{self, BondTable, LANES, PADDING};
use crate::kernels;
use crate::kernels::lanes::{lane_stretch, load, sub};

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

/// A stored bond entry, its stretch vector eta = u_j - u_i now (metres) and its stretch, what
/// [`SpringTable::sum_springs`] offers (on the lattice layout `bond.i` and `bond.j` are slots).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringNow {
    /// The entry.
    pub bond: StoredBond,
    /// u_j - u_i, metres.
    pub eta: [f32; 3],
    /// The stretch s ([`crate::kernels::stretch`], whatever the stiffness).
    pub stretch: f32,
}

impl SpringNow {
    /// Entry `bond` at the particles' displacements `disp` (metres; `bond.i` and `bond.j` are
    /// particles).
    pub fn at(bond: &StoredBond, disp: &[Vec<f32>; 3]) -> SpringNow {
        let eta = [0, 1, 2].map(|a| disp[a][bond.j] - disp[a][bond.i]);
        let (stretch, _, _) = kernels::stretch(bond.rest_vector, eta, bond.rest_length_m);
        SpringNow { bond: *bond, eta, stretch }
    }
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
                        let (i, j) = (chunk.first + local, bond.neighbor[lane] as usize);
                        entry(&StoredBond {
                            i,
                            j,
                            rest_vector: table.rest_position[i].to(table.rest_position[j]),
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

    /// The sum of `value` over all stored entries, each with its bond's stretch vector at the
    /// displacements `disp`: summed per chunk in entry order ([`SpringTable::for_each_entry`]'s),
    /// in parallel, then over chunks in order (the same on any thread count). The lattice
    /// layout reads the displacements by slot, eight lanes of a block at once. Entries of zero
    /// stiffness (broken bonds, and the lattice's padding lanes) are not offered: they add
    /// nothing, so `value` is taken to be +0 for them.
    pub fn sum_springs(&self, disp: &[Vec<f32>; 3], value: impl Fn(&SpringNow) -> f64 + Sync) -> f64 {
        let sums: Vec<f64> = match self {
            SpringTable::Rows(_) => {
                (0..self.chunk_count()).into_par_iter().map(|c| self.entry_sum(c, disp, &value)).collect()
            }
            SpringTable::Lattice(table) => {
                let slot_disp: [Vec<f32>; 3] = [0, 1, 2].map(|a| {
                    let by_slot = |&p: &u32| if p == NO_PARTICLE { 0.0 } else { disp[a][p as usize] };
                    table.particle_of.par_iter().map(by_slot).collect()
                });
                table
                    .chunks
                    .par_iter()
                    .map(|chunk| {
                        let shape = &chunk.shape;
                        let mut sum = 0.0;
                        for brick in 0..shape.brick_slot.len() {
                            let own = shape.brick_slot[brick] as usize;
                            for (block, internal) in shape.brick_blocks(brick) {
                                let partner = shape.partner_slot[block] as usize;
                                let (bonds, rest) = (&chunk.blocks[block], &chunk.rest[block]);
                                if bonds.stiffness == [0.0; LANES] {
                                    continue;
                                }
                                let xi = rest.vector_m.map(|axis| [axis; LANES]);
                                let eta =
                                    [0, 1, 2].map(|a| sub(load(&slot_disp[a], partner), load(&slot_disp[a], own)));
                                let stretch = lane_stretch(&xi, &eta, [rest.length_m; LANES]);
                                for lane in (0..LANES).filter(|lane| bonds.stiffness[*lane] != 0.0) {
                                    let bond = StoredBond {
                                        i: own + lane,
                                        j: partner + lane,
                                        rest_vector: rest.vector_m,
                                        rest_length_m: rest.length_m,
                                        stiffness: bonds.stiffness[lane],
                                        internal,
                                    };
                                    let eta = [eta[0][lane], eta[1][lane], eta[2][lane]];
                                    sum += value(&SpringNow { bond, eta, stretch: stretch[lane] });
                                }
                            }
                        }
                        sum
                    })
                    .collect()
            }
        };
        sums.iter().sum()
    }

    /// Chunk `c`'s part of [`SpringTable::sum_springs`], entry by entry through the particles'
    /// displacements (padding and zero stiffness skipped).
    fn entry_sum(&self, c: usize, disp: &[Vec<f32>; 3], value: &impl Fn(&SpringNow) -> f64) -> f64 {
        let mut sum = 0.0;
        self.for_each_entry_of_chunk(c, |bond| {
            if bond.stiffness != 0.0 {
                sum += value(&SpringNow::at(bond, disp));
            }
        });
        sum
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

/// The spring table of a grid-sampled box of `size_m` (1 mm spacing, N = 3) and its particles,
/// for tests of the lattice layout.
#[cfg(test)]
pub(crate) fn grid_box_table(size_m: [f64; 3]) -> (ParticleSet, SpringTable) {
    use shatter_core::config::sim::{PartialVolumes, StiffnessCorrection};
    let text = format!(
        "[scene]\nname = \"t\"\noutput_dir = \"out\"\nseed = 1\n[geometry]\nsource = \"box\"\n\
         box_size_m = [{}, {}, {}]\nsampler = \"grid\"\nspacing_m = 0.001\nhorizon_factor = 3.0\n\
         [material]\ndensity_kg_m3 = 2200.0\nbulk_modulus_pa = 1e10\n",
        size_m[0], size_m[1], size_m[2]
    );
    let path = std::path::Path::new("/nonexistent/pipeline.toml");
    let config = shatter_core::config::PipelineConfig::from_toml_str(&text, path).expect("config");
    let particles = shatter_preprocess::preprocess(&config, &shatter_core::NoProgress).expect("preprocess").particles;
    let values = EntryValues::new(&particles, 1e15, 1.0, None, StiffnessCorrection::Energy, PartialVolumes::None);
    let table = SpringTable::new(&particles, &values, LayoutChoice::Fastest);
    (particles, table)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On the lattice layout the springs' sum reads the displacements by slot and computes the
    /// stretches a block's lanes at once; it is the entry-by-entry sum over the particles (the
    /// row layout's way) to the bit.
    #[test]
    fn the_lattice_sum_of_springs_is_the_entry_sum_to_the_bit() {
        let (particles, mut table) = grid_box_table([0.011, 0.007, 0.005]);
        let SpringTable::Lattice(lattice) = &table else { panic!("a grid block is on the lattice") };
        assert!(lattice.chunks.len() > 1, "bonds between chunks too");
        // some bonds broken (zero stiffness), random displacements
        let broken: Vec<u64> =
            lattice.chunks[0].bond_id.iter().copied().filter(|&id| id != PADDING).step_by(7).collect();
        let mut broken = broken;
        broken.sort_unstable();
        table.mark_broken(&broken);
        let mut rng = shatter_core::random::SplitMix64::new(3);
        let disp: [Vec<f32>; 3] =
            [0, 1, 2].map(|_| (0..particles.len()).map(|_| (rng.next_f64() as f32 - 0.5) * 1e-5).collect());
        let energy = |spring: &SpringNow| {
            let bond = &spring.bond;
            let length = spring.eta.iter().zip(bond.rest_vector).map(|(e, x)| (e + x) * (e + x)).sum::<f32>().sqrt();
            let ends = if bond.internal { 2.0 } else { 1.0 };
            // the stretch as offered, lane by lane on the lattice, entry by entry in rows
            let stretch = f64::from(spring.stretch);
            ends * f64::from(bond.stiffness) * (f64::from(length - bond.rest_length_m).powi(2) + stretch * stretch)
        };
        let expected: f64 =
            (0..table.chunk_count()).map(|c| table.entry_sum(c, &disp, &energy)).collect::<Vec<f64>>().iter().sum();
        assert!(expected > 0.0);
        assert_eq!(table.sum_springs(&disp, energy).to_bits(), expected.to_bits());
    }
}
