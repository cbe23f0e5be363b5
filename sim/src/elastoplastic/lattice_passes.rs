//! The two passes of the state-based model on the lattice layout ([`super::lattice_families`]):
//! the same dilatation, force scalars, plastic return map, break test and bond force as
//! [`super::passes`], but each bond computed once per pass for both its ends, eight bonds at a
//! time, their partners eight consecutive slots (no gathers).
//!
//! The arithmetic is lane helpers (`crate::kernels::lanes`), each one vector instruction; the
//! choices between values are bit-mask blends, which the compiler cannot turn into a branch per
//! lane (it did, and computed half the lanes one at a time).
//!
//! Internal blocks (both ends in the chunk) add to both ends; external ones, stored and computed
//! on both sides, to this end only. Each slot's sums take its bonds in the chunk's block order,
//! its own bonds first summed per brick: a fixed order, whatever the thread count. Both sides of
//! an external bond compute it from the same bits (the rest vector and displacement difference
//! are exactly negated, the means and the pair's force are symmetric), so they agree.

// Indexed loops: one per operation, each a vector instruction.
#![allow(clippy::needless_range_loop)]

use super::lattice_families::FamilyChunk;
use crate::bond_layouts::lattice_layout::ChunkShape;
use crate::kernels::lanes::{
    LANES, Lanes, abs, add, any_greater, copysign, deformed_bonds, div, load, mul, neg, pick_equal, pick_greater,
    pick_less, sub,
};
use crate::kernels::prefetch::prefetch_item;

/// How many blocks ahead of the one it computes a pass asks for its block (as the spring
/// kernels do: `crate::kernels::prefetch`).
const FAMILIES_AHEAD: usize = 8;

/// The per-slot arrays both passes read, each the whole layout long.
pub struct SlotValues<'a> {
    /// Displacement x, y, z, metres.
    pub disp: [&'a [f32]; 3],
    /// Rest position x, y, z, metres.
    pub rest: [&'a [f32]; 3],
    /// Volume V, m^3.
    pub volume: &'a [f32],
}

/// Adds `value` to the eight values of `total` from `at`.
#[inline(always)]
fn add_to(total: &mut [f32], at: usize, value: Lanes) {
    let sum = add(load(total, at), value);
    total[at..at + LANES].copy_from_slice(&sum);
}

/// The deformed bonds y = xi + eta of the eight bonds from slots `own..own + 8` to
/// `partner..partner + 8` (xi the difference of the rest positions, eta of the displacements),
/// their lengths |y| and extensions e = (2 xi . eta + eta . eta) / (|y| + |xi|): |y| - |xi|
/// without its cancellation (as [`crate::kernels::stretch`]). Both passes, and both copies of an
/// external bond, compute the same bits.
#[inline(always)]
fn deformed(values: &SlotValues, own: usize, partner: usize, rest: Lanes) -> ([Lanes; 3], Lanes, Lanes) {
    let [rx, ry, rz] = values.rest;
    let [ux, uy, uz] = values.disp;
    let xi = [
        sub(load(rx, partner), load(rx, own)),
        sub(load(ry, partner), load(ry, own)),
        sub(load(rz, partner), load(rz, own)),
    ];
    let eta = [
        sub(load(ux, partner), load(ux, own)),
        sub(load(uy, partner), load(uy, own)),
        sub(load(uz, partner), load(uz, own)),
    ];
    let (y, length, growth) = deformed_bonds::<true>(&xi, &eta);
    (y, length, div(growth, add(length, rest)))
}

/// Pass 1 over one chunk: each bond's extension e = |y| - |xi| (pass 2 computes it again: that
/// costs less than storing it and reading it back) and the dilatation
/// theta = 3 / m sum omega |xi| e V_j of the chunk's slots (into `theta`, the chunk's run of
/// slots; `weighted_volume` likewise). Broken and padding lanes add nothing.
pub fn lattice_dilatation(chunk: &FamilyChunk, values: &SlotValues, weighted_volume: &[f32], theta: &mut [f32]) {
    let ChunkShape { first_slot: first, slots, brick_slot, .. } = &chunk.shape;
    let (first, slots) = (*first, *slots);
    let theta = &mut theta[..slots];
    theta.fill(0.0);
    for (brick, &own) in brick_slot.iter().enumerate() {
        let own = own as usize;
        let volume_i = load(values.volume, own);
        let mut sum = [0.0f32; LANES];
        for (block, internal) in chunk.shape.brick_blocks(brick) {
            prefetch_item(chunk.blocks.as_ptr(), block + FAMILIES_AHEAD);
            let partner = chunk.shape.partner_slot[block] as usize;
            let bonds = &chunk.blocks[block];
            let (_, _, extension) = deformed(values, own, partner, bonds.rest_length_m);
            let reach = mul(bonds.rest_length_m, extension);
            sum = add(sum, mul(mul(bonds.influence, reach), load(values.volume, partner)));
            if internal {
                add_to(theta, partner - first, mul(mul(bonds.reverse_influence, reach), volume_i));
            }
        }
        add_to(theta, own - first, sum);
    }
    for (theta, m) in theta.iter_mut().zip(&weighted_volume[..slots]) {
        // slots without a particle have m = 0 and no bonds
        *theta = if *m > 0.0 { 3.0 * *theta / *m } else { 0.0 };
    }
}

/// One end of eight bonds: its slots' dilatation, damage, volume and constants.
struct End {
    theta: Lanes,
    damage: Lanes,
    volume: Lanes,
    constants: [Lanes; 3],
}

impl End {
    /// The values of slots `at..at + 8`.
    #[inline(always)]
    fn load<const PLASTIC: bool>(inputs: &ForceSlots, at: usize) -> End {
        End {
            theta: load(inputs.theta, at),
            damage: load(inputs.damage, at),
            volume: load(inputs.values.volume, at),
            constants: [
                load(inputs.deviatoric, at),
                load(inputs.dilatational, at),
                if PLASTIC { load(inputs.yield_force, at) } else { [f32::INFINITY; LANES] },
            ],
        }
    }
}

/// One end's force scalars of eight bonds and their new plastic extensions, as
/// [`super::passes`]'s `force_scalar` computes each (the same operations in the same order), one
/// operation at a time over the lanes: `omega` the end's influences, `plastic` its old plastic
/// extensions, `cap` gamma. Without `PLASTIC` the plastic extensions are zero and stay zero.
#[inline(always)]
fn force_scalars<const PLASTIC: bool>(
    end: &End,
    omega: Lanes,
    rest: Lanes,
    extension: Lanes,
    plastic: Lanes,
    cap: Lanes,
) -> (Lanes, Lanes) {
    let [deviatoric, dilatational, yield_force] = end.constants;
    let deviatoric_extension = sub(extension, div(mul(end.theta, rest), [3.0; LANES]));
    let stiffness = mul(deviatoric, omega);
    let dilatational_part = mul(mul(mul(dilatational, end.theta), omega), rest);
    if !PLASTIC {
        return (add(dilatational_part, mul(stiffness, deviatoric_extension)), plastic);
    }
    let trial = mul(stiffness, sub(deviatoric_extension, plastic));
    // the return onto the yield surface, then the cap
    let onto_surface = sub(deviatoric_extension, div(copysign(yield_force, trial), stiffness));
    let returned = pick_greater(abs(trial), yield_force, onto_surface, plastic);
    let returned = pick_less(returned, neg(cap), neg(cap), returned);
    let returned = pick_greater(returned, cap, cap, returned);
    let moved = mul(stiffness, sub(deviatoric_extension, returned));
    (add(dilatational_part, pick_equal(returned, plastic, trial, moved)), returned)
}

/// What pass 2 reads of every slot (each array the whole layout long).
pub struct ForceSlots<'a> {
    /// Displacements, rest positions and volumes.
    pub values: SlotValues<'a>,
    /// Dilatation theta, from pass 1.
    pub theta: &'a [f32],
    /// Damage phi = 1 - intact / initial bonds at the step's start.
    pub damage: &'a [f32],
    /// 15 mu / m.
    pub deviatoric: &'a [f32],
    /// 3 K / m.
    pub dilatational: &'a [f32],
    /// The deviatoric force scalar at which the slot's bonds yield.
    pub yield_force: &'a [f32],
    /// Each slot's particle ([`crate::bond_layouts::lattice_layout::NO_PARTICLE`] for none).
    pub particle_of: &'a [u32],
    /// The thresholds' growth with damage, alpha.
    pub damage_strengthening: f32,
    /// gamma / |xi|.
    pub plastic_cap_ratio: f32,
}

/// Pass 2 over one chunk: both ends' force scalars with the plastic return map, the break test
/// and the bond forces, into `force` (the chunk's run of slots, newtons). A bond that breaks
/// loses both influences, exerts no force this step, leaves the intact counts of its ends in the
/// chunk (`intact`, the chunk's run) and is logged once in `chunk.breaks` (an external one by
/// the side of its lower particle).
///
/// `PLASTIC` false is for a model without yield whose plastic extensions are all zero: they
/// stay zero, so the pass neither reads nor writes them (the same bits).
pub fn lattice_bond_forces<const PLASTIC: bool>(
    chunk: &mut FamilyChunk,
    inputs: &ForceSlots,
    intact: &mut [u32],
    force: [&mut [f32]; 3],
) {
    let FamilyChunk { shape, blocks, plastic, bond_id, breaks } = chunk;
    let (first, slots) = (shape.first_slot, shape.slots);
    breaks.clear();
    let [fx, fy, fz] = force;
    let mut force = [&mut fx[..slots], &mut fy[..slots], &mut fz[..slots]];
    for axis in &mut force {
        axis.fill(0.0);
    }
    let (strengthening, cap_ratio) = (inputs.damage_strengthening, inputs.plastic_cap_ratio);
    for (brick, &own) in shape.brick_slot.iter().enumerate() {
        let own = own as usize;
        let mine = End::load::<PLASTIC>(inputs, own);
        let mut sum = [[0.0f32; LANES]; 3];
        for (block, internal) in shape.brick_blocks(brick) {
            prefetch_item(blocks.as_ptr(), block + FAMILIES_AHEAD);
            if PLASTIC {
                prefetch_item(plastic.as_ptr(), block + FAMILIES_AHEAD);
            }
            let partner = shape.partner_slot[block] as usize;
            let bonds = &mut blocks[block];
            if bonds.influence == [0.0; LANES] {
                continue;
            }
            let theirs = End::load::<PLASTIC>(inputs, partner);
            let rest = bonds.rest_length_m;
            let (y, length, extension) = deformed(&inputs.values, own, partner, rest);
            let old = if PLASTIC { plastic[block] } else { [[0.0; LANES]; 2] };
            let cap = mul([cap_ratio; LANES], rest);
            let (t_ij, new_ij) = force_scalars::<PLASTIC>(&mine, bonds.influence, rest, extension, old[0], cap);
            let (t_ji, new_ji) =
                force_scalars::<PLASTIC>(&theirs, bonds.reverse_influence, rest, extension, old[1], cap);
            let new = [new_ij, new_ji];
            let half = [0.5; LANES];
            let plastic_mean = mul(half, add(new_ij, new_ji));
            let damage_mean = mul(half, add(mine.damage, theirs.damage));
            let threshold = mul(bonds.threshold, add([1.0; LANES], mul([strengthening; LANES], damage_mean)));
            let weighted_stretch = mul(sub(extension, plastic_mean), bonds.break_scale);
            // the same bits at both ends, opposite signs: the pair's momentum is exact
            let pair = div(mul(add(t_ij, t_ji), mul(mine.volume, theirs.volume)), length);
            let zero = [0.0; LANES];
            let magnitude =
                pick_equal(bonds.influence, zero, zero, pick_greater(weighted_stretch, threshold, zero, pair));
            let mut broken = [false; LANES];
            if any_greater(weighted_stretch, threshold) {
                for l in 0..LANES {
                    broken[l] = bonds.influence[l] != 0.0 && weighted_stretch[l] > threshold[l];
                }
            }
            if PLASTIC {
                plastic[block] = new;
            }
            let bond_force = [mul(y[0], magnitude), mul(y[1], magnitude), mul(y[2], magnitude)];
            for axis in 0..3 {
                sum[axis] = add(sum[axis], bond_force[axis]);
            }
            if internal {
                for axis in 0..3 {
                    // the reaction: x - f is x + (-f), bit for bit
                    add_to(force[axis], partner - first, neg(bond_force[axis]));
                }
            }
            if broken != [false; LANES] {
                for l in (0..LANES).filter(|&l| broken[l]) {
                    bonds.influence[l] = 0.0;
                    bonds.reverse_influence[l] = 0.0;
                    intact[own + l - first] -= 1;
                    let (i, j) = (inputs.particle_of[own + l], inputs.particle_of[partner + l]);
                    if internal {
                        intact[partner + l - first] -= 1;
                    }
                    if internal || i < j {
                        breaks.push(bond_id[block * LANES + l]);
                    }
                }
            }
        }
        for axis in 0..3 {
            add_to(force[axis], own - first, sum[axis]);
        }
    }
}
