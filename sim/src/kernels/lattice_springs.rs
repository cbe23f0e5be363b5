//! The spring kernel for the lattice layout ([`crate::bond_layouts::lattice_layout`]): the same
//! bond force and break test as the row kernel, eight sites at a time, their partners eight
//! consecutive slots, their rest vector and length one for all eight.
//! Plain lane arithmetic ([`super::lanes`]) that the compiler turns into vector instructions:
//! with no gathers, there is nothing for explicit intrinsics to add.

use shatter_core::config::sim::BreakRule;

use super::lanes::{BondLanes, LANES, Lanes, add, any_greater, bond_lanes, load, min, mul, neg, sub};
use super::springs::{ChunkForces, break_bound, effective_threshold};
use crate::bond_layouts::lattice_layout::{ChunkShape, LatticeBlock, LatticeChunk, SlotInputs};

/// Spring forces (the paper's `springforces`) of one chunk of the lattice layout: for every
/// intact bond, the stretch, the break test against the effective threshold, and the PMB force.
/// Internal blocks are applied to both ends, external ones to this end only; bonds that break
/// are recorded once in `chunk.breaks` (external ones by their lower particle). Each slot sums
/// its own bonds block by block, in block order, into a running total per lane, then adds that
/// total to the reactions its slot has received; a fixed order, whatever the thread count.
pub fn lattice_spring_forces(
    chunk: &mut LatticeChunk,
    inputs: &SlotInputs<'_>,
    particle_of: &[u32],
    rule: BreakRule,
    out: &mut ChunkForces,
) {
    let LatticeChunk {
        shape: ChunkShape { first_slot: first, slots, brick_slot, brick_start, internal_end, partner_slot },
        blocks,
        rest,
        bond_id,
        breaks,
    } = chunk;
    let (first, slots) = (*first, *slots);
    breaks.clear();
    // Slots past the chunk's rows are never read.
    for axis in 0..3 {
        out.force[axis][..slots].fill(0.0);
    }
    out.min_stretch[..slots].fill(0.0);
    // Slices of one length, so that one bounds check covers a load from all of them.
    let len = particle_of.len();
    let disp = inputs.disp.map(|values| &values[..len]);
    let context = LatticeContext { boost: &inputs.boost[..len], particle_of, rule };
    let mut totals = ChunkTotals::new(out, slots);
    for (brick, &own) in brick_slot.iter().enumerate() {
        let own = own as usize;
        let bound = match rule {
            BreakRule::Max => load(context.boost, own),
            BreakRule::Min => [break_bound(rule, 0.0); LANES],
        };
        let mut force_sum = [[0.0f32; LANES]; 3];
        let mut smallest = [0.0f32; LANES];
        let (start, middle, end) =
            (brick_start[brick] as usize, internal_end[brick] as usize, brick_start[brick + 1] as usize);
        let brick_blocks = blocks[start..end].iter_mut().zip(&partner_slot[start..end]).zip(&rest[start..end]);
        for (k, ((bonds, &partner), shared)) in brick_blocks.enumerate() {
            let (block, partner) = (start + k, partner as usize);
            let internal = block < middle;
            // u_i is loaded again for every block rather than kept: the registers it would hold
            // keep the lane sums out of the stack.
            let eta = [
                sub(load(disp[0], partner), load(disp[0], own)),
                sub(load(disp[1], partner), load(disp[1], own)),
                sub(load(disp[2], partner), load(disp[2], own)),
            ];
            let xi = shared.vector_m.map(|axis| [axis; LANES]);
            let length = [shared.length_m; LANES];
            let BondLanes { y, mut stretch, mut scale } = bond_lanes(&xi, &eta, length, bonds.stiffness);
            if any_greater(stretch, add(bonds.threshold, bound)) {
                let place = BlockPlace { own, partner, internal, ids: &bond_id[block * LANES..(block + 1) * LANES] };
                break_lanes(&context, bonds, &place, breaks, [&mut stretch, &mut scale]);
            }
            let force = [mul(y[0], scale), mul(y[1], scale), mul(y[2], scale)];
            for axis in 0..3 {
                force_sum[axis] = add(force_sum[axis], force[axis]);
            }
            smallest = min(smallest, stretch);
            if internal {
                // The reaction: x - f is x + (-f), bit for bit.
                let reaction = [neg(force[0]), neg(force[1]), neg(force[2])];
                totals.add(partner - first, &reaction, stretch);
            }
        }
        totals.add(own - first, &force_sum, smallest);
    }
}

/// A chunk's force and smallest-stretch totals, each the chunk's slots long.
struct ChunkTotals<'a> {
    force: [&'a mut [f32]; 3],
    min_stretch: &'a mut [f32],
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
    fn add(&mut self, at: usize, force: &[Lanes; 3], stretch: Lanes) {
        for axis in 0..3 {
            let total = &mut self.force[axis][at..at + LANES];
            let updated = add(load(total, 0), force[axis]);
            total.copy_from_slice(&updated);
        }
        let total = &mut self.min_stretch[at..at + LANES];
        let updated = min(load(total, 0), stretch);
        total.copy_from_slice(&updated);
    }
}

/// What the break test reads besides the block.
struct LatticeContext<'a> {
    boost: &'a [f32],
    particle_of: &'a [u32],
    rule: BreakRule,
}

/// A block's place: its brick's first slot, its partners' first slot, whether it is internal,
/// and its lanes' bond ids.
struct BlockPlace<'a> {
    own: usize,
    partner: usize,
    internal: bool,
    ids: &'a [u64],
}

/// Breaks the bonds of a block whose stretches passed the cheap bound where they exceed their
/// effective threshold (zero stiffness, infinite threshold, logged once in `breaks`) and zeroes
/// their lanes' stretch and force scale.
fn break_lanes(
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
