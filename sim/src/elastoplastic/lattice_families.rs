//! The state-based model's bonds on the lattice layout, for particles on a cubic lattice (the
//! grid sampler's): the chunks, bricks and blocks of [`crate::bond_layouts::lattice_layout`],
//! each bond stored once for both its ends where both are in one chunk (once per side where it
//! crosses chunks), and each particle's values in per-slot arrays. The passes
//! ([`super::lattice_passes`]) then compute each bond once per pass for both ends, without a
//! gather, where the family table ([`super::family_table`]) computes it from each end.
//!
//! A block holds what varies from bond to bond: rest length, both ends' influences (they differ
//! with fibres), threshold and break scale (160 bytes for eight bonds, where the family table
//! stores 832 for their sixteen entries); the plastic extensions of both ends sit in an array of
//! their own, which an elastic run never touches. The passes are bound by this stream: storing
//! each bond's extension for pass 2 (32 bytes more a block) was slower than computing it again.

use rayon::prelude::*;
use shatter_core::particles::ParticleSet;

use super::StateBasedConstants;
use super::lattice_passes::{ForceSlots, SlotValues, lattice_bond_forces, lattice_dilatation};
use crate::bond_layouts::lattice_layout::{ChunkShape, LatticePlan, NO_PARTICLE, SlotArrays};
use crate::bond_layouts::row_layout::{self, PADDING};
use crate::kernels::lanes::{LANES, Lanes};
use crate::kernels::stretch;

/// Eight bonds of one brick at one lattice offset, from the brick's sites (end i) to the
/// partners (end j). Padding lanes: unit rest length, no influence, infinite threshold.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(32))]
pub struct FamilyBlock {
    /// Rest length |xi|, metres.
    pub rest_length_m: Lanes,
    /// omega_ij = delta / |G xi| at end i; 0 once broken.
    pub influence: Lanes,
    /// omega_ji at end j; 0 once broken.
    pub reverse_influence: Lanes,
    /// Critical value of the weighted elastic stretch, art direction included.
    pub threshold: Lanes,
    /// 1 / (omega_mean |xi|) (see [`super::FamilyTable::break_scale`]).
    pub break_scale: Lanes,
}

impl FamilyBlock {
    /// Eight padding lanes.
    const PADDING: FamilyBlock = FamilyBlock {
        rest_length_m: [1.0; LANES],
        influence: [0.0; LANES],
        reverse_influence: [0.0; LANES],
        threshold: [f32::INFINITY; LANES],
        break_scale: [0.0; LANES],
    };
}

/// One chunk: its shape, its blocks and their plastic extensions and bond ids.
#[derive(Debug, Clone, PartialEq)]
pub struct FamilyChunk {
    /// Where its bonds sit.
    pub shape: ChunkShape,
    /// The blocks.
    pub blocks: Vec<FamilyBlock>,
    /// Each block's plastic extensions e_p, metres: end i's, then end j's.
    pub plastic: Vec<[Lanes; 2]>,
    /// Each lane's bond id (the lower particle's file entry; [`PADDING`] for none).
    pub bond_id: Vec<u64>,
    /// Ids of bonds this chunk saw break in the last evaluation, each once (scratch).
    pub breaks: Vec<u64>,
}

/// The per-slot arrays of [`LatticeFamilies::slots`], by index. In order: displacement x, y, z
/// (metres); rest position x, y, z (metres); volume V (m^3); weighted volume m (m^5, 0 without a
/// particle); 15 mu / m; 3 K / m; the deviatoric force scalar at which the slot's bonds yield;
/// damage phi at the step's start; dilatation theta at the last evaluation; bond force x, y, z
/// (newtons). [`LatticeFamilies::evaluate`] takes them apart in this order.
pub struct FamilySlot;

impl FamilySlot {
    /// Rest position x (then y, z), metres.
    pub const REST: usize = 3;
    /// Volume V, m^3.
    pub const VOLUME: usize = 6;
    /// Weighted volume m, m^5 (0 without a particle).
    pub const WEIGHTED: usize = 7;
    /// Arrays in all.
    pub const COUNT: usize = 16;
}

/// The state-based model's bonds on the lattice layout.
#[derive(Debug, Clone)]
pub struct LatticeFamilies {
    /// The model's constants.
    pub constants: StateBasedConstants,
    /// Slots per chunk.
    pub chunk_slots: usize,
    /// The chunks, in slot order.
    pub chunks: Vec<FamilyChunk>,
    /// Each particle's slot.
    pub slot_of: Vec<u32>,
    /// Each slot's particle, or [`NO_PARTICLE`].
    pub particle_of: Vec<u32>,
    /// The per-slot arrays ([`FamilySlot`]).
    pub slots: SlotArrays,
    /// Intact bonds per slot.
    pub intact: Vec<u32>,
    /// Bonds per slot in the particle file.
    pub initial: Vec<u32>,
    /// No yield and every plastic extension zero: they stay zero, and the force pass skips them.
    pub plastic_frozen: bool,
    /// Bond entries in the particle file (both directions of every bond).
    file_entries: usize,
}

/// One end of a bond as [`LatticeFamilies::for_each_end`] presents it.
struct BondEnd<'a> {
    /// The end's slot and the other end's.
    slot: usize,
    other: usize,
    /// The end's influence and plastic extension.
    omega: f32,
    plastic: f32,
    /// The bond's block and lane.
    block: &'a FamilyBlock,
    lane: usize,
}

impl LatticeFamilies {
    /// The lattice layout of `particles`' families, or `None` when the particles are not on a
    /// cubic lattice or fill too few lanes: `threshold(k)` is the critical stretch of file entry
    /// k (jitter, material rescale and art direction included).
    pub fn new(
        particles: &ParticleSet,
        constants: StateBasedConstants,
        threshold: impl Fn(usize) -> f32 + Sync,
    ) -> Option<LatticeFamilies> {
        let plan = LatticePlan::new(particles)?;
        let (bonds, position, delta) = (&particles.bonds, &particles.rest_position_m, particles.meta.delta_m);
        let chunks: Vec<FamilyChunk> = plan
            .fill_chunks(particles, FamilyBlock::PADDING, |bonds_of, lane, i, k| {
                let j = bonds.neighbor[k] as usize;
                let xi = [0, 1, 2].map(|axis| position[j][axis] - position[i][axis]);
                let rest = bonds.rest_length_m[k];
                let omega_ij = constants.influence(delta, position[i], xi);
                let omega_ji = constants.influence(delta, position[j], xi.map(|x| -x));
                let mean = 0.5 * (f64::from(omega_ij) + f64::from(omega_ji));
                bonds_of.rest_length_m[lane] = rest;
                bonds_of.influence[lane] = omega_ij;
                bonds_of.reverse_influence[lane] = omega_ji;
                bonds_of.threshold[lane] = threshold(k);
                bonds_of.break_scale[lane] = (1.0 / (mean * f64::from(rest))) as f32;
            })
            .into_iter()
            .map(|(shape, blocks, bond_id)| {
                let plastic = vec![[[0.0; LANES]; 2]; blocks.len()];
                FamilyChunk { shape, blocks, plastic, bond_id, breaks: Vec::new() }
            })
            .collect();
        let mut slots = SlotArrays::new(plan.particle_of.len(), FamilySlot::COUNT);
        slots.set_rest(FamilySlot::REST, &plan.slot_of, particles);
        let weighted = constants.weighted_volumes(particles);
        let values = constants.particle_values(&particles.volume_m3, &weighted, delta);
        {
            let mut arrays = slots.arrays_mut().skip(FamilySlot::VOLUME);
            let mut next = || arrays.next().unwrap_or_else(|| unreachable!("sixteen arrays"));
            let [volume, m, deviatoric, dilatational, yield_force] = [next(), next(), next(), next(), next()];
            for (i, slot) in plan.slot_of.iter().enumerate() {
                let s = *slot as usize;
                let [v, dev, dil, y] = values[i];
                (volume[s], m[s], deviatoric[s], dilatational[s], yield_force[s]) = (v, weighted[i], dev, dil, y);
            }
        }
        let LatticePlan { chunk_slots, slot_of, particle_of, .. } = plan;
        let slot_count = particle_of.len();
        let mut table = LatticeFamilies {
            constants,
            chunk_slots,
            chunks,
            slot_of,
            particle_of,
            slots,
            intact: vec![0; slot_count],
            initial: Vec::new(),
            plastic_frozen: constants.yield_force_n_m6 == f64::INFINITY,
            file_entries: bonds.neighbor.len(),
        };
        table.count_intact();
        table.initial = table.intact.clone();
        Some(table)
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.slot_of.len()
    }

    /// True without particles.
    pub fn is_empty(&self) -> bool {
        self.slot_of.is_empty()
    }

    /// Bond entries in the particle file.
    pub fn bond_entries(&self) -> usize {
        self.file_entries
    }

    /// Counts each slot's intact bonds.
    fn count_intact(&mut self) {
        let mut intact = std::mem::take(&mut self.intact);
        intact.par_chunks_mut(self.chunk_slots).enumerate().for_each(|(c, intact)| {
            intact.fill(0);
            let first = self.chunks[c].shape.first_slot;
            self.for_each_end(c, |end| intact[end.slot - first] += 1);
        });
        self.intact = intact;
    }

    /// Marks bonds broken by id (sorted): both ends lose their influence, and the intact counts
    /// follow.
    pub fn mark_broken(&mut self, sorted_ids: &[u64]) {
        self.chunks.par_iter_mut().for_each(|chunk| {
            let blocks = &mut chunk.blocks;
            row_layout::mark_broken(&chunk.bond_id, sorted_ids, |block, lane| {
                blocks[block].influence[lane] = 0.0;
                blocks[block].reverse_influence[lane] = 0.0;
            });
        });
        self.count_intact();
    }

    /// Calls `f` with each bond broken in the last evaluation, chunk by chunk in the order they
    /// broke.
    pub fn for_each_break(&self, mut f: impl FnMut(u64)) {
        self.chunks.iter().flat_map(|chunk| &chunk.breaks).for_each(|id| f(*id));
    }

    /// One force evaluation at displacements `disp`: both passes, each over the chunks in
    /// parallel. Writes the bond forces into `force` (newtons), leaves the bonds broken in the
    /// chunks' `breaks` and moves the plastic extensions.
    pub fn evaluate(&mut self, disp: [&[f32]; 3], force: [&mut [f32]; 3]) {
        let size = self.chunk_slots;
        let (particle_of, intact, initial) = (&self.particle_of[..], &mut self.intact, &self.initial[..]);
        let arrays: [&mut [f32]; FamilySlot::COUNT] =
            self.slots.arrays_mut().collect::<Vec<_>>().try_into().unwrap_or_else(|_| unreachable!("sixteen arrays"));
        let [
            ux,
            uy,
            uz,
            rx,
            ry,
            rz,
            volume,
            weighted,
            deviatoric,
            dilatational,
            yield_force,
            damage,
            theta,
            fx,
            fy,
            fz,
        ] = arrays;
        // The slots' displacements and damage, from the particles.
        (ux.par_chunks_mut(size), uy.par_chunks_mut(size), uz.par_chunks_mut(size), damage.par_chunks_mut(size))
            .into_par_iter()
            .enumerate()
            .for_each(|(c, (ux, uy, uz, damage))| {
                for local in 0..ux.len() {
                    let (slot, p) = (c * size + local, particle_of[c * size + local]);
                    if p != NO_PARTICLE {
                        let p = p as usize;
                        (ux[local], uy[local], uz[local]) = (disp[0][p], disp[1][p], disp[2][p]);
                        damage[local] =
                            if initial[slot] == 0 { 0.0 } else { 1.0 - intact[slot] as f32 / initial[slot] as f32 };
                    }
                }
            });
        let values = SlotValues { disp: [&*ux, &*uy, &*uz], rest: [&*rx, &*ry, &*rz], volume: &*volume };
        (self.chunks.par_iter(), theta.par_chunks_mut(size), weighted.par_chunks(size))
            .into_par_iter()
            .for_each(|(chunk, theta, weighted)| lattice_dilatation(chunk, &values, weighted, theta));
        let inputs = ForceSlots {
            values,
            theta: &*theta,
            damage: &*damage,
            deviatoric: &*deviatoric,
            dilatational: &*dilatational,
            yield_force: &*yield_force,
            particle_of,
            damage_strengthening: self.constants.damage_strengthening as f32,
            plastic_cap_ratio: self.constants.plastic_cap_ratio as f32,
        };
        let frozen = self.plastic_frozen;
        (
            self.chunks.par_iter_mut(),
            intact.par_chunks_mut(size),
            fx.par_chunks_mut(size),
            fy.par_chunks_mut(size),
            fz.par_chunks_mut(size),
        )
            .into_par_iter()
            .for_each(|(chunk, intact, fx, fy, fz)| {
                if frozen {
                    lattice_bond_forces::<false>(chunk, &inputs, intact, [fx, fy, fz]);
                } else {
                    lattice_bond_forces::<true>(chunk, &inputs, intact, [fx, fy, fz]);
                }
            });
        let slot_of = &self.slot_of;
        let [out_x, out_y, out_z] = force;
        (out_x.par_iter_mut(), out_y.par_iter_mut(), out_z.par_iter_mut()).into_par_iter().enumerate().for_each(
            |(i, (x, y, z))| {
                let s = slot_of[i] as usize;
                (*x, *y, *z) = (fx[s], fy[s], fz[s]);
            },
        );
    }

    /// Calls `end` with both ends of every intact bond of chunk `c` that the chunk holds, each
    /// end of each bond once over all chunks (an external bond's other end is its other copy's).
    fn for_each_end(&self, c: usize, mut end: impl FnMut(BondEnd)) {
        let chunk = &self.chunks[c];
        for (brick, &own) in chunk.shape.brick_slot.iter().enumerate() {
            for (block, internal) in chunk.shape.brick_blocks(brick) {
                let partner = chunk.shape.partner_slot[block] as usize;
                let (bonds, plastic) = (&chunk.blocks[block], &chunk.plastic[block]);
                for lane in (0..LANES).filter(|&l| bonds.influence[l] > 0.0) {
                    let (own, partner) = (own as usize + lane, partner + lane);
                    let omega = bonds.influence[lane];
                    end(BondEnd { slot: own, other: partner, omega, plastic: plastic[0][lane], block: bonds, lane });
                    if internal {
                        let (omega, plastic) = (bonds.reverse_influence[lane], plastic[1][lane]);
                        end(BondEnd { slot: partner, other: own, omega, plastic, block: bonds, lane });
                    }
                }
            }
        }
    }

    /// `per_slot(c, sums)` for each chunk c in parallel, `sums` its slots' accumulators (two per
    /// slot), then `value(slot, sums)` of each particle's slot, in particle order.
    fn per_particle<T: Send>(
        &self,
        per_slot: impl Fn(usize, &mut [[f64; 2]]) + Sync,
        value: impl Fn(usize, [f64; 2]) -> T + Sync,
    ) -> Vec<T> {
        let mut sums = vec![[0.0f64; 2]; self.particle_of.len()];
        sums.par_chunks_mut(self.chunk_slots).enumerate().for_each(|(c, sums)| per_slot(c, sums));
        self.slot_of.par_iter().map(|s| value(*s as usize, sums[*s as usize])).collect()
    }

    /// The elastic energy stored at each particle, joules: V (K theta^2 / 2 + 15 mu / (2 m)
    /// sum omega (e_d - e_p)^2 V_j), theta recomputed from the displacements `disp`.
    pub fn energy_per_particle(&self, disp: [&[f32]; 3]) -> Vec<f64> {
        let rest = [0, 1, 2].map(|axis| self.slots.array(FamilySlot::REST + axis));
        let volume = self.slots.array(FamilySlot::VOLUME);
        let weighted = self.slots.array(FamilySlot::WEIGHTED);
        let particle_of = &self.particle_of;
        let extension = |end: &BondEnd| {
            let u = |slot: usize, axis: usize| disp[axis][particle_of[slot] as usize];
            let xi = [0, 1, 2].map(|axis| rest[axis][end.other] - rest[axis][end.slot]);
            let eta = [0, 1, 2].map(|axis| u(end.other, axis) - u(end.slot, axis));
            let rest_length = end.block.rest_length_m[end.lane];
            let (s, _, _) = stretch(xi, eta, rest_length);
            f64::from(s * rest_length)
        };
        let (bulk, shear) = (self.constants.bulk_modulus_pa, self.constants.shear_modulus_pa);
        let first = |c: usize| self.chunks[c].shape.first_slot;
        self.per_particle(
            |c, sums| {
                // the dilatation sums, then theta in place, then the deviatoric sums
                self.for_each_end(c, |end| {
                    let rest = f64::from(end.block.rest_length_m[end.lane]);
                    sums[end.slot - first(c)][0] +=
                        f64::from(end.omega) * rest * extension(&end) * f64::from(volume[end.other]);
                });
                for (local, sum) in sums.iter_mut().enumerate() {
                    let m = f64::from(weighted[first(c) + local]);
                    sum[0] = if m > 0.0 { 3.0 * sum[0] / m } else { 0.0 };
                }
                self.for_each_end(c, |end| {
                    let rest = f64::from(end.block.rest_length_m[end.lane]);
                    let theta = sums[end.slot - first(c)][0];
                    let elastic = extension(&end) - theta * rest / 3.0 - f64::from(end.plastic);
                    sums[end.slot - first(c)][1] +=
                        f64::from(end.omega) * elastic * elastic * f64::from(volume[end.other]);
                });
            },
            |slot, [theta, deviatoric]| {
                let m = f64::from(weighted[slot]);
                f64::from(volume[slot]) * (0.5 * bulk * theta * theta + 7.5 * shear / m * deviatoric)
            },
        )
    }

    /// The largest stable time step, seconds: min over particles of sqrt(2 m_i / k_i), k_i the
    /// stiffness of [`super::passes::stiffness_n_m`], m_i the mass at `density_kg_m3`.
    pub fn stable_dt_s(&self, density_kg_m3: f64) -> f64 {
        let volume = self.slots.array(FamilySlot::VOLUME);
        let weighted = self.slots.array(FamilySlot::WEIGHTED);
        let (bulk, shear) = (self.constants.bulk_modulus_pa, self.constants.shear_modulus_pa);
        let steps = self.per_particle(
            |c, sums| {
                let first = self.chunks[c].shape.first_slot;
                self.for_each_end(c, |end| {
                    let (v_i, v_j) = (f64::from(volume[end.slot]), f64::from(volume[end.other]));
                    let (m_i, m_j) = (f64::from(weighted[end.slot]), f64::from(weighted[end.other]));
                    let omega = f64::from(end.omega);
                    let sum = &mut sums[end.slot - first];
                    sum[0] += v_i * v_j * 15.0 * shear * omega * (1.0 / m_i + 1.0 / m_j);
                    sum[1] += omega * f64::from(end.block.rest_length_m[end.lane]) * v_j;
                });
            },
            |slot, [springs, reach]| {
                let (v, m) = (f64::from(volume[slot]), f64::from(weighted[slot]));
                let k = springs + 2.0 * v * 9.0 * bulk * reach * reach / (m * m);
                if k > 0.0 { (2.0 * density_kg_m3 * v / k).sqrt() } else { f64::INFINITY }
            },
        );
        steps.into_iter().fold(f64::INFINITY, f64::min)
    }

    /// Every bond end of every stored copy, sorted into the particle file's entry order (rows by
    /// particle, partners ascending): key (i, j) and place (chunk, lane index, end). An external
    /// bond's ends come once per copy, next to each other.
    fn ends_in_file_order(&self) -> Vec<(u64, u64)> {
        let mut ends: Vec<(u64, u64)> = (0..self.chunks.len())
            .into_par_iter()
            .flat_map_iter(|c| {
                let chunk = &self.chunks[c];
                let mut out = Vec::new();
                for (brick, &own) in chunk.shape.brick_slot.iter().enumerate() {
                    for (block, _) in chunk.shape.brick_blocks(brick) {
                        let partner = chunk.shape.partner_slot[block] as usize;
                        for lane in (0..LANES).filter(|&l| chunk.bond_id[block * LANES + l] != PADDING) {
                            let i = u64::from(self.particle_of[own as usize + lane]);
                            let j = u64::from(self.particle_of[partner + lane]);
                            let place = ((c as u64) << 32) | ((block * LANES + lane) as u64) << 1;
                            out.extend([(i << 32 | j, place), (j << 32 | i, place | 1)]);
                        }
                    }
                }
                out
            })
            .collect();
        ends.par_sort_unstable();
        ends
    }

    /// The chunk, block, end and lane of `place` (see [`LatticeFamilies::ends_in_file_order`]).
    fn unpack(place: u64) -> (usize, usize, usize, usize) {
        let lane = (place as u32 >> 1) as usize;
        ((place >> 32) as usize, lane / LANES, (place & 1) as usize, lane % LANES)
    }

    /// The plastic extensions in the particle file's entry order (for checkpoints).
    pub fn plastic_in_file_order(&self) -> Vec<f32> {
        let ends = self.ends_in_file_order();
        let mut out = Vec::with_capacity(self.file_entries);
        for group in ends.chunk_by(|a, b| a.0 == b.0) {
            let (c, block, end, lane) = Self::unpack(group[0].1);
            out.push(self.chunks[c].plastic[block][end][lane]);
        }
        out
    }

    /// Sets the plastic extensions from the particle file's entry order (a checkpoint's). Fails
    /// when `plastic` does not hold one value per file entry.
    pub fn set_plastic_from_file_order(&mut self, plastic: &[f32]) -> Result<(), String> {
        if plastic.len() != self.file_entries {
            return Err(format!("{} plastic extensions for {} bond entries", plastic.len(), self.file_entries));
        }
        let ends = self.ends_in_file_order();
        for (group, value) in ends.chunk_by(|a, b| a.0 == b.0).zip(plastic) {
            for (_, place) in group {
                let (c, block, end, lane) = Self::unpack(*place);
                self.chunks[c].plastic[block][end][lane] = *value;
            }
        }
        self.plastic_frozen = self.constants.yield_force_n_m6 == f64::INFINITY && plastic.iter().all(|p| *p == 0.0);
        Ok(())
    }
}
