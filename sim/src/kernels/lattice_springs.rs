//! The spring kernel for the lattice layout ([`crate::bond_layouts::lattice_layout`]): the same
//! bond force and break test as the row kernel, eight sites at a time, their partners eight
//! consecutive slots, their rest vector and length one for all eight.
//! Plain lane arithmetic ([`super::lanes`]) that the compiler turns into vector instructions.
//! `lattice_springs_avx512` holds the same brick kernel in explicit AVX-512 instructions, two
//! blocks to a 16-lane register; both give the same bits.

use shatter_core::config::sim::BreakRule;

use super::lanes::{
    BondLanes, LANES, Lanes, add, any_greater, any_may_have_tiny, bond_lanes, keep_min, load, min, mul, neg, sub,
};
use super::prefetch::prefetch;
use super::springs::{ChunkForces, break_bound, effective_threshold};
use crate::bond_layouts::lattice_layout::{BlockRest, ChunkShape, LatticeBlock, LatticeChunk, SlotInputs};
use crate::simd_path::SimdPath;

/// Spring forces (the paper's `springforces`) of one chunk of the lattice layout: for every
/// intact bond, the stretch, the break test against the effective threshold, and the PMB force.
/// Internal blocks are applied to both ends, external ones to this end only; bonds that break
/// are recorded once in `chunk.breaks` (external ones by their lower particle). Each slot sums
/// its own bonds block by block, in block order, into a running total per lane, then adds that
/// total to the reactions its slot has received; a fixed order, whatever the thread count and
/// the instruction set (AVX-512 where `simd` asks for it and the CPU has it, two blocks at a
/// time, else portable code; the two agree bit for bit).
pub fn lattice_spring_forces(
    chunk: &mut LatticeChunk,
    inputs: &SlotInputs<'_>,
    particle_of: &[u32],
    rule: BreakRule,
    simd: SimdPath,
    out: &mut ChunkForces,
) {
    #[cfg(target_arch = "x86_64")]
    if simd == SimdPath::Avx512
        && super::lattice_springs_avx512::lattice_spring_forces(chunk, inputs, particle_of, rule, out)
    {
        return;
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _portable_only = simd; // off x86-64 every path is the portable one
    lattice_bricks(chunk, inputs, particle_of, rule, out, brick_forces);
}

/// How many blocks ahead of the one it computes a brick kernel asks for its block (2 KiB ahead:
/// on the lattice bench's 49^3 block 16 blocks ran up to 10% slower, 64 as fast;
/// docs/DECISIONS.md#block-streams-prefetched).
pub(super) const BLOCKS_AHEAD: usize = 32;

/// One chunk's pass as a brick kernel sees it: the chunk's blocks and the slots they read and
/// write.
pub(super) struct ChunkPass<'a> {
    /// Where the blocks sit.
    pub shape: &'a ChunkShape,
    /// The blocks (a broken bond's lanes are updated in place).
    pub blocks: &'a mut [LatticeBlock],
    /// Each block's rest vector and length.
    pub rest: &'a [BlockRest],
    /// Each lane's bond id.
    pub bond_id: &'a [u64],
    /// Bonds broken in this pass.
    pub breaks: &'a mut Vec<u64>,
    /// Displacement per slot, metres (x, y, z), all `context.particle_of`'s length.
    pub disp: [&'a [f32]; 3],
    /// What the break test reads.
    pub context: LatticeContext<'a>,
    /// The chunk's force and smallest-stretch totals.
    pub totals: ChunkTotals<'a>,
}

/// The brick loop of [`lattice_spring_forces`] around a brick kernel, which computes the blocks of
/// one brick (`(pass, brick, its first slot, the break test's cheap bound)`), adds their
/// reactions, and returns the brick's own force and smallest-stretch lane sums. Inlined into each
/// caller, so that it is compiled for the caller's instruction set.
#[inline(always)]
pub(super) fn lattice_bricks(
    chunk: &mut LatticeChunk,
    inputs: &SlotInputs<'_>,
    particle_of: &[u32],
    rule: BreakRule,
    out: &mut ChunkForces,
    mut brick: impl FnMut(&mut ChunkPass, usize, usize, Lanes) -> ([Lanes; 3], Lanes),
) {
    let LatticeChunk { shape, blocks, rest, bond_id, breaks } = chunk;
    let (first, slots) = (shape.first_slot, shape.slots);
    breaks.clear();
    // Slots past the chunk's rows are never read.
    for axis in 0..3 {
        out.force[axis][..slots].fill(0.0);
    }
    out.min_stretch[..slots].fill(0.0);
    // Slices of one length, so that one bounds check covers a load from all of them.
    let len = particle_of.len();
    let mut pass = ChunkPass {
        shape,
        blocks,
        rest,
        bond_id,
        breaks,
        disp: inputs.disp.map(|values| &values[..len]),
        context: LatticeContext { boost: &inputs.boost[..len], particle_of, rule },
        totals: ChunkTotals::new(out, slots),
    };
    for (b, &own) in shape.brick_slot.iter().enumerate() {
        let own = own as usize;
        let bound = match rule {
            BreakRule::Max => load(pass.context.boost, own),
            BreakRule::Min => [break_bound(rule, 0.0); LANES],
        };
        let (force_sum, smallest) = brick(&mut pass, b, own, bound);
        pass.totals.add(own - first, &force_sum, smallest);
    }
}

/// The portable brick kernel: brick `b`'s blocks one by one, in block order.
#[inline(always)]
fn brick_forces(pass: &mut ChunkPass, b: usize, own: usize, bound: Lanes) -> ([Lanes; 3], Lanes) {
    let disp = pass.disp;
    if any_may_have_tiny(&[load(disp[0], own), load(disp[1], own), load(disp[2], own)]) {
        brick_blocks::<true>(pass, b, own, bound)
    } else {
        brick_blocks::<false>(pass, b, own, bound)
    }
}

/// [`brick_forces`] with the growth's test for tiny displacement differences (`TINY`) or
/// without it (see [`super::springs::NO_TINY_FROM_M`]).
#[inline(always)]
fn brick_blocks<const TINY: bool>(pass: &mut ChunkPass, b: usize, own: usize, bound: Lanes) -> ([Lanes; 3], Lanes) {
    let ChunkShape { first_slot: first, brick_start, internal_end, partner_slot, .. } = pass.shape;
    let disp = pass.disp;
    let mut force_sum = [[0.0f32; LANES]; 3];
    let mut smallest = [0.0f32; LANES];
    let (start, middle, end) = (brick_start[b] as usize, internal_end[b] as usize, brick_start[b + 1] as usize);
    let all_blocks = pass.blocks.as_ptr();
    let brick_blocks = pass.blocks[start..end].iter_mut().zip(&partner_slot[start..end]).zip(&pass.rest[start..end]);
    for (k, ((bonds, &partner), shared)) in brick_blocks.enumerate() {
        let (block, partner) = (start + k, partner as usize);
        let internal = block < middle;
        prefetch(all_blocks, block + BLOCKS_AHEAD);
        // u_i is loaded again for every block rather than kept: the registers it would hold
        // keep the lane sums out of the stack.
        let eta = [
            sub(load(disp[0], partner), load(disp[0], own)),
            sub(load(disp[1], partner), load(disp[1], own)),
            sub(load(disp[2], partner), load(disp[2], own)),
        ];
        let xi = shared.vector_m.map(|axis| [axis; LANES]);
        let length = [shared.length_m; LANES];
        let BondLanes { y, mut stretch, mut scale } = bond_lanes::<TINY>(&xi, &eta, length, bonds.stiffness);
        if any_greater(stretch, add(bonds.threshold, bound)) {
            let place = BlockPlace { own, partner, internal, ids: &pass.bond_id[block * LANES..(block + 1) * LANES] };
            break_lanes(&pass.context, bonds, &place, pass.breaks, [&mut stretch, &mut scale]);
        }
        let force = [mul(y[0], scale), mul(y[1], scale), mul(y[2], scale)];
        for axis in 0..3 {
            force_sum[axis] = add(force_sum[axis], force[axis]);
        }
        smallest = min(smallest, stretch);
        if internal {
            // The reaction: x - f is x + (-f), bit for bit.
            let reaction = [neg(force[0]), neg(force[1]), neg(force[2])];
            pass.totals.add(partner - first, &reaction, stretch);
        }
    }
    (force_sum, smallest)
}

/// A chunk's force and smallest-stretch totals, each the chunk's slots long.
pub(super) struct ChunkTotals<'a> {
    /// Force, newtons (x, y, z).
    pub force: [&'a mut [f32]; 3],
    /// Smallest stretch.
    pub min_stretch: &'a mut [f32],
}

impl<'a> ChunkTotals<'a> {
    /// The first `slots` of `out`'s arrays, all of one length (one bounds check covers them).
    fn new(out: &'a mut ChunkForces, slots: usize) -> ChunkTotals<'a> {
        let [x, y, z] = &mut out.force;
        ChunkTotals {
            force: [&mut x[..slots], &mut y[..slots], &mut z[..slots]],
            min_stretch: &mut out.min_stretch[..slots],
        }
    }

    /// Adds `force` to the eight slots from `at` (chunk-local) and keeps the smaller stretch.
    #[inline(always)]
    pub(super) fn add(&mut self, at: usize, force: &[Lanes; 3], stretch: Lanes) {
        for axis in 0..3 {
            let total = &mut self.force[axis][at..at + LANES];
            let updated = add(load(total, 0), force[axis]);
            total.copy_from_slice(&updated);
        }
        keep_min(&mut self.min_stretch[at..at + LANES], stretch);
    }
}

/// What the break test reads besides the block.
pub(super) struct LatticeContext<'a> {
    /// Compression boost per slot.
    pub boost: &'a [f32],
    /// Each slot's particle.
    pub particle_of: &'a [u32],
    /// Which end's boost counts.
    pub rule: BreakRule,
}

/// A block's place: its brick's first slot, its partners' first slot, whether it is internal,
/// and its lanes' bond ids.
pub(super) struct BlockPlace<'a> {
    /// The brick's first slot.
    pub own: usize,
    /// The partners' first slot.
    pub partner: usize,
    /// Whether the block is internal.
    pub internal: bool,
    /// The lanes' bond ids.
    pub ids: &'a [u64],
}

/// Breaks the bonds of a block whose stretches passed the cheap bound where they exceed their
/// effective threshold (zero stiffness, infinite threshold, logged once in `breaks`) and zeroes
/// their lanes' stretch and force scale.
pub(super) fn break_lanes(
    context: &LatticeContext,
    bonds: &mut LatticeBlock,
    place: &BlockPlace,
    breaks: &mut Vec<u64>,
    [stretch, scale]: [&mut Lanes; 2],
) {
    let boost = context.boost;
    for lane in 0..LANES {
        let (mine, theirs) = (boost[place.own + lane], boost[place.partner + lane]);
        if stretch[lane] > effective_threshold(context.rule, bonds.threshold[lane], mine, theirs) {
            bonds.threshold[lane] = f32::INFINITY;
            bonds.stiffness[lane] = 0.0;
            if place.internal || context.particle_of[place.own + lane] < context.particle_of[place.partner + lane] {
                breaks.push(place.ids[lane]);
            }
            stretch[lane] = 0.0;
            scale[lane] = 0.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bond_layouts::lattice_layout::{LatticeTable, NO_PARTICLE, SlotViews};
    use crate::bond_layouts::layout_choice::{SpringTable, grid_box_table};

    /// Everything a pass writes, chunk by chunk: forces and smallest stretches (as bits), and
    /// the chunk after the pass (its blocks and the ids of the bonds it saw break).
    type PassResult = Vec<([Vec<u32>; 3], Vec<u32>, LatticeChunk)>;

    /// One pass over every chunk of `table` on the SIMD path `simd`.
    fn run(table: &LatticeTable, disp: &[Vec<f32>; 3], boost: &[f32], rule: BreakRule, simd: SimdPath) -> PassResult {
        let inputs = SlotInputs { disp: [&disp[0], &disp[1], &disp[2]], boost };
        let bits = |values: &[f32]| values.iter().map(|v| v.to_bits()).collect::<Vec<u32>>();
        table
            .chunks
            .iter()
            .map(|chunk| {
                let mut chunk = chunk.clone();
                let slots = table.chunk_slots;
                let (mut fx, mut fy, mut fz, mut least) =
                    (vec![0.0; slots], vec![0.0; slots], vec![0.0; slots], vec![0.0; slots]);
                let mut out = ChunkForces { force: [&mut fx, &mut fy, &mut fz], min_stretch: &mut least };
                lattice_spring_forces(&mut chunk, &inputs, &table.particle_of, rule, simd, &mut out);
                ([bits(&fx), bits(&fy), bits(&fz)], bits(&least), chunk)
            })
            .collect()
    }

    /// Displacement differences under [`super::super::springs::SQUARED_FROM_M`] add no square to
    /// the growth, on every path: on a grid block whose only live bonds lie along x, with no x
    /// displacement, every bond's growth is its eta . eta alone, so the forces are all zero when
    /// the y and z differences are 2^-70 m or 2^-69 m (squares subnormal, dropped) and not when they
    /// are 2^-50 m or 2^-49 m (kept).
    #[test]
    fn tiny_displacement_differences_add_no_square_on_any_path() {
        let (_, table) = grid_box_table([0.009, 0.007, 0.005]);
        let SpringTable::Lattice(mut table) = table else { panic!("a grid block is on the lattice") };
        for chunk in &mut table.chunks {
            for (bonds, rest) in chunk.blocks.iter_mut().zip(&chunk.rest) {
                if rest.vector_m[1] != 0.0 || rest.vector_m[2] != 0.0 {
                    bonds.stiffness = [0.0; LANES];
                }
            }
        }
        for (exponent, squares_kept) in [(-70, false), (-50, true)] {
            let mut rng = shatter_core::random::SplitMix64::new(7);
            let mut component = || [0.0, 1.0, -1.0][(rng.next_u64() % 3) as usize] * f32::exp2(exponent as f32);
            let SlotViews { inputs: [ux, uy, uz, boost], .. } = table.slots.split_mut();
            for (slot, &particle) in table.particle_of.iter().enumerate() {
                if particle != NO_PARTICLE {
                    (ux[slot], uy[slot], uz[slot], boost[slot]) = (0.0, component(), component(), 0.0);
                }
            }
            let disp = [ux.to_vec(), uy.to_vec(), uz.to_vec()];
            let boost = boost.to_vec();
            let portable = run(&table, &disp, &boost, BreakRule::Max, SimdPath::Portable);
            let mut forces = portable.iter().flat_map(|(force, _, _)| force.iter().flatten());
            assert_eq!(forces.any(|f| f32::from_bits(*f) != 0.0), squares_kept, "differences of 2^{exponent} m");
            for simd in SimdPath::available() {
                let dispatched = run(&table, &disp, &boost, BreakRule::Max, simd);
                for (c, (ours, theirs)) in portable.iter().zip(&dispatched).enumerate() {
                    assert_eq!(ours.0, theirs.0, "{simd}, 2^{exponent} m, chunk {c}: forces");
                    assert_eq!(ours.1, theirs.1, "{simd}, 2^{exponent} m, chunk {c}: smallest stretches");
                }
            }
        }
    }

    /// A displacement component of seed `seed`'s set: up to 1e-5 m (stretches up to a few
    /// thresholds); from seed 6 on, most slots' components are zero or tiny (2^-40 to 2^-80 m:
    /// differences whose squares are subnormal or less, along lattice rest vectors with zero
    /// components, where the squares alone make the growth).
    fn displacement(seed: u64, rng: &mut shatter_core::random::SplitMix64) -> [f32; 3] {
        let mut random = |scale: f64| (rng.next_f64() - 0.5) as f32 * scale as f32;
        if seed < 6 || random(1.0) < -0.3 {
            return [random(2e-5), random(2e-5), random(2e-5)];
        }
        [0; 3].map(|_| {
            let draw = random(1.0);
            if draw.abs() < 0.15 { 0.0 } else { (-40.0 - 40.0 * (draw.abs() - 0.15) / 0.35).exp2().copysign(draw) }
        })
    }

    /// On every SIMD path this CPU runs (the AVX-512 one computes blocks in pairs): on random
    /// displacements and boosts of a grid block, with bonds breaking, and on zero and tiny
    /// displacements, the forces, smallest stretches, blocks and breaks are the portable
    /// kernel's, bit for bit.
    #[test]
    fn every_simd_path_gives_the_portable_lattice_kernels_bits() {
        let (_, table) = grid_box_table([0.013, 0.009, 0.007]);
        let SpringTable::Lattice(mut table) = table else { panic!("a grid block is on the lattice") };
        assert!(table.chunks.len() > 1, "bonds between chunks too");
        let mut breaks = 0;
        for seed in 0..8 {
            let mut rng = shatter_core::random::SplitMix64::new(seed);
            let SlotViews { inputs: [ux, uy, uz, boost], .. } = table.slots.split_mut();
            for (slot, &particle) in table.particle_of.iter().enumerate() {
                if particle != NO_PARTICLE {
                    // some boosts, some zero
                    [ux[slot], uy[slot], uz[slot]] = displacement(seed, &mut rng);
                    boost[slot] = if seed % 2 == 0 { ((rng.next_f64() - 0.5) * 4e-3).max(0.0) as f32 } else { 0.0 };
                }
            }
            let disp = [ux.to_vec(), uy.to_vec(), uz.to_vec()];
            let boost = boost.to_vec();
            for rule in [BreakRule::Max, BreakRule::Min] {
                let portable = run(&table, &disp, &boost, rule, SimdPath::Portable);
                for simd in SimdPath::available() {
                    let dispatched = run(&table, &disp, &boost, rule, simd);
                    for (c, (ours, theirs)) in portable.iter().zip(&dispatched).enumerate() {
                        assert_eq!(ours.0, theirs.0, "{simd}, seed {seed} chunk {c}: forces");
                        assert_eq!(ours.1, theirs.1, "{simd}, seed {seed} chunk {c}: smallest stretches");
                        assert_eq!(ours.2, theirs.2, "{simd}, seed {seed} chunk {c}: blocks and breaks");
                    }
                }
                breaks += portable.iter().map(|(_, _, chunk)| chunk.breaks.len()).sum::<usize>();
                assert!(portable.iter().any(|(force, _, _)| force[0].iter().any(|f| f32::from_bits(*f) != 0.0)));
            }
        }
        assert!(breaks > 100, "only {breaks} bonds broke: the break path is not exercised");
    }
}
