//! The lattice layout of the CPU's bonds, for particles on a cubic lattice (the grid sampler's),
//! where eight bonds can be computed without a gather.
//!
//! Every lattice row (the sites of one y and z) gets a segment of slots, one per site along x,
//! with [`GHOST`] empty slots on either side. A brick is eight consecutive sites of a row; a block
//! holds, for one brick and one lattice offset d, the bond of each of its sites to the site at
//! +d. The partners of a block are then eight consecutive slots: the kernel loads their
//! displacements as one vector per axis and adds the reactions back the same way, where the row
//! layout moves every partner's record separately. Empty lanes (no site, or no bond at that
//! offset) are inert padding: no stiffness, infinite threshold.
//!
//! A block stores only what varies from bond to bond: threshold and stiffness ([`LatticeBlock`]:
//! 64 bytes for eight bonds, where a row layout block carries 128), with one rest vector and rest
//! length for all its lanes ([`BlockRest`], 16 bytes). That needs the eight bonds' f32 rest
//! vectors to be the same bits, which holds where the rest positions sit on a lattice that f32
//! holds exactly (the grid sampler puts them there); the layout is refused otherwise. The values
//! are then the ones the row layout and the GPU compute from the positions, bit for bit.
//!
//! Rows are grouped into chunks by rectangular tiles of y and z, each chunk a contiguous range of
//! slots. As in the row layout ([`super::row_layout`]), a bond whose two particles share a chunk
//! is stored once (at its positive offset) and applied to both ends; one that crosses chunks is
//! stored and computed on both sides. Chunks depend only on the particle set, never on the thread
//! count.

use std::collections::HashMap;

use rayon::prelude::*;
use shatter_core::particles::ParticleSet;

use super::EntryValues;
use super::row_layout::{BondEntry, LANES, PADDING, bond_id};

/// Empty slots on each side of a row: bonds may reach at most this many sites along x.
pub const GHOST: usize = 8;

/// Marks a slot without a particle.
pub const NO_PARTICLE: u32 = u32::MAX;

/// Chunks to share out among threads, at least (see [`tile_size`]).
const MIN_CHUNKS: usize = 16;

/// Below this fraction of bond lanes among all lanes, the lattice layout is not used: the
/// padding would cost more than the gathers it saves.
const MIN_FILL: f64 = 0.5;

/// Eight bonds of one brick at one lattice offset: what varies from bond to bond. Padding lanes
/// have zero stiffness and an infinite threshold; their force and stretch are zero.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
pub struct LatticeBlock {
    /// Critical stretch; infinite once broken.
    pub threshold: [f32; LANES],
    /// k = c V_i V_j g_ij (N per unit stretch); 0 once broken.
    pub stiffness: [f32; LANES],
}

impl LatticeBlock {
    /// Eight padding lanes.
    const PADDING: LatticeBlock = LatticeBlock { threshold: [f32::INFINITY; LANES], stiffness: [0.0; LANES] };
}

/// The rest vector and rest length that all bonds of a block share: one lattice offset on a
/// lattice that f32 holds exactly.
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(16))]
pub struct BlockRest {
    /// Rest vector xi = X_j - X_i, metres (the f32 difference of the particle file's positions).
    pub vector_m: [f32; 3],
    /// Rest length |xi|, metres (the particle file's: a square root per bond and step saved).
    pub length_m: f32,
}

/// Where one chunk's bonds sit, whatever they carry: its slots, its bricks and their blocks,
/// and each block's partners. Both material models' lattice tables are built on it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChunkShape {
    /// First slot of the chunk.
    pub first_slot: usize,
    /// Slots of the chunk's rows (from the first; the chunk owns [`LatticeTable::chunk_slots`]).
    pub slots: usize,
    /// First slot of each brick that has bonds, in slot order.
    pub brick_slot: Vec<u32>,
    /// Block offsets per brick (bricks + 1).
    pub brick_start: Vec<u32>,
    /// End of each brick's internal blocks (partners in this chunk); the rest are external.
    pub internal_end: Vec<u32>,
    /// Slot of the partner of each block's first lane; lane l's partner is this + l.
    pub partner_slot: Vec<u32>,
}

impl ChunkShape {
    /// Brick `brick`'s blocks, each with whether it is internal.
    pub fn brick_blocks(&self, brick: usize) -> impl Iterator<Item = (usize, bool)> + use<> {
        let (start, middle) = (self.brick_start[brick] as usize, self.internal_end[brick] as usize);
        (start..self.brick_start[brick + 1] as usize).map(move |block| (block, block < middle))
    }
}

/// One chunk of the PMB model's lattice layout: its shape, and its bonds in blocks.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LatticeChunk {
    /// Where its bonds sit.
    pub shape: ChunkShape,
    /// The blocks.
    pub blocks: Vec<LatticeBlock>,
    /// Each block's rest vector and length.
    pub rest: Vec<BlockRest>,
    /// Each lane's bond id (see [`super::row_layout::BondChunk::bond_id`]).
    pub bond_id: Vec<u64>,
    /// Ids of bonds this chunk saw break in the current step, each once (scratch, reused).
    pub breaks: Vec<u64>,
}

/// What the lattice kernel reads of every slot: the displacement and the compression boost,
/// filled each step from the particles (zero in empty slots).
pub struct SlotInputs<'a> {
    /// Displacement u, metres (x, y, z).
    pub disp: [&'a [f32]; 3],
    /// Compression boost of the thresholds.
    pub boost: &'a [f32],
}

/// How much further into a 4 KiB page each array of [`SlotArrays`] starts than the one before.
const SKEW_BYTES: usize = 256;

/// Per-slot arrays in one allocation. Each array starts `SKEW_BYTES` further into a 4 KiB page
/// than the one before, so that a load from one array never waits on a store to another at the
/// same slot because their addresses agree in the low 12 bits (4K aliasing), wherever the
/// allocator puts them.
///
/// The PMB kernel's eight ([`PmbSlot`]): its inputs (displacement x, y, z and boost) and its
/// outputs (force x, y, z, newtons, and the smallest stretch of the slot's intact bonds).
#[derive(Debug, Clone, PartialEq)]
pub struct SlotArrays {
    data: Vec<f32>,
    len: usize,
    stride: usize,
}

/// The PMB kernel's slot arrays, by index into [`SlotArrays`].
pub struct PmbSlot;

impl PmbSlot {
    /// Arrays in all.
    const COUNT: usize = 8;
    /// Force x (then y, z; the smallest stretch after them).
    pub const FORCE: usize = 4;
}

impl SlotArrays {
    /// `count` zeroed arrays of `len` slots.
    pub(crate) fn new(len: usize, count: usize) -> SlotArrays {
        let stride = len.next_multiple_of(1024) + SKEW_BYTES / 4;
        SlotArrays { data: vec![0.0; count * stride], len, stride }
    }

    /// Array `k`.
    pub fn array(&self, k: usize) -> &[f32] {
        &self.data[k * self.stride..k * self.stride + self.len]
    }

    /// All arrays, writable, in order.
    pub fn arrays_mut(&mut self) -> impl Iterator<Item = &mut [f32]> {
        let len = self.len;
        self.data.chunks_exact_mut(self.stride).map(move |array| &mut array[..len])
    }

    /// The PMB kernel's four per-step input arrays and four output arrays, writable.
    pub fn split_mut(&mut self) -> SlotViews<'_> {
        let mut arrays = self.arrays_mut();
        let mut next = || arrays.next().unwrap_or_else(|| unreachable!("eight arrays"));
        let (inputs, outputs) = ([next(), next(), next(), next()], [next(), next(), next(), next()]);
        SlotViews { inputs, outputs }
    }

    /// Fills arrays `first..first + 3` with the rest positions of the particles in `slot_of`'s
    /// slots.
    pub(crate) fn set_rest(&mut self, first: usize, slot_of: &[u32], particles: &ParticleSet) {
        for (axis, array) in self.arrays_mut().skip(first).take(3).enumerate() {
            for (i, slot) in slot_of.iter().enumerate() {
                array[*slot as usize] = particles.rest_position_m[i][axis];
            }
        }
    }
}

/// [`SlotArrays`] split for one force pass.
pub struct SlotViews<'a> {
    /// Displacement x, y, z and boost, to fill.
    pub inputs: [&'a mut [f32]; 4],
    /// Force x, y, z and smallest stretch, to compute.
    pub outputs: [&'a mut [f32]; 4],
}

/// The lattice layout of a particle set.
#[derive(Debug, Clone, PartialEq)]
pub struct LatticeTable {
    /// Slots per chunk: every chunk owns this many, room for its tile's rows, so that the
    /// per-slot arrays split into equal chunks.
    pub chunk_slots: usize,
    /// The chunks, in slot order.
    pub chunks: Vec<LatticeChunk>,
    /// Each particle's slot.
    pub slot_of: Vec<u32>,
    /// Each slot's particle, or [`NO_PARTICLE`].
    pub particle_of: Vec<u32>,
    /// The kernel's per-slot inputs and outputs.
    pub slots: SlotArrays,
}

/// A particle's integer lattice coordinates.
type Site = [i64; 3];

/// The lattice sites of all particles, if every particle sits (to 0.1% of the spacing) on the
/// cubic lattice of spacing lambda through the lowest corner, each site holds one particle, and
/// every bond reaches at most [`GHOST`] sites along x. Along each axis the spacing is taken from
/// the particles' extent (the whole number of lambdas nearest it), so that a lattice the grid
/// sampler made exact in f32, whose spacing differs from lambda by up to 1e-4 of it, is found
/// however many sites it spans.
fn lattice_sites(particles: &ParticleSet) -> Option<Vec<Site>> {
    let lambda = particles.meta.lambda_m;
    if particles.is_empty() || lambda.is_nan() || lambda <= 0.0 {
        return None;
    }
    let bound = |axis: usize, pick: fn(f64, f64) -> f64, start: f64| {
        particles.rest_position_m.iter().map(|p| f64::from(p[axis])).fold(start, pick)
    };
    let corner = [0, 1, 2].map(|axis| bound(axis, f64::min, f64::INFINITY));
    let spacing = [0, 1, 2].map(|axis| {
        let extent = bound(axis, f64::max, f64::NEG_INFINITY) - corner[axis];
        let cells = (extent / lambda).round();
        if cells >= 1.0 { extent / cells } else { lambda }
    });
    let mut sites = Vec::with_capacity(particles.len());
    for p in &particles.rest_position_m {
        let mut site = [0i64; 3];
        for axis in 0..3 {
            let units = (f64::from(p[axis]) - corner[axis]) / spacing[axis];
            if (units - units.round()).abs() > 1e-3 || units > 1e6 {
                return None;
            }
            site[axis] = units.round() as i64;
        }
        sites.push(site);
    }
    let mut sorted = sites.clone();
    sorted.sort_unstable();
    if sorted.windows(2).any(|pair| pair[0] == pair[1]) {
        return None;
    }
    let bonds = &particles.bonds;
    let reach_ok = (0..particles.len())
        .all(|i| bonds.row(i).all(|k| sites[bonds.neighbor[k] as usize][0].abs_diff(sites[i][0]) <= GHOST as u64));
    reach_ok.then_some(sites)
}

/// Where a particle set's sites and bonds go on the lattice, whatever a bond carries: the slots
/// and each chunk's shape, with the particle-file entry of every block lane. Both material
/// models build their lattice tables from it.
#[derive(Debug, Clone)]
pub(crate) struct LatticePlan {
    /// Slots per chunk (see [`LatticeTable::chunk_slots`]).
    pub(crate) chunk_slots: usize,
    /// Each particle's slot.
    pub(crate) slot_of: Vec<u32>,
    /// Each slot's particle, or [`NO_PARTICLE`].
    pub(crate) particle_of: Vec<u32>,
    /// The chunks in slot order: each one's shape and the file entry of each of its lanes (lane
    /// l of block b at 8 b + l; [`PADDING`] for none), a bond of the particle in slot
    /// `brick_slot + l` of the block's brick.
    pub(crate) chunks: Vec<(ChunkShape, Vec<u64>)>,
}

impl LatticePlan {
    /// The plan for `particles`, or `None` when they are not on a cubic lattice (see
    /// [`lattice_sites`]) or fill too few lanes.
    pub(crate) fn new(particles: &ParticleSet) -> Option<LatticePlan> {
        let sites = lattice_sites(particles)?;
        let width = sites.iter().map(|s| s[0]).max().unwrap_or(0) as usize + 1;
        let stride = GHOST + width.div_ceil(LANES) * LANES + GHOST;
        // Rows (y, z) in chunk order: by tile, then z, then y.
        let mut rows: Vec<[i64; 2]> = sites.iter().map(|s| [s[1], s[2]]).collect();
        rows.sort_unstable();
        rows.dedup();
        // A lane holds a bond only where its slot holds a particle: too few particles for the
        // rows' slots, and the lanes cannot fill either.
        if (sites.len() as f64) < MIN_FILL * (rows.len() * (stride - 2 * GHOST)) as f64 {
            return None;
        }
        let tile = tile_size(&rows);
        let tile_of = |row: &[i64; 2]| [row[1] / tile[1], row[0] / tile[0]];
        rows.sort_unstable_by_key(|row| (tile_of(row), row[1], row[0]));
        // Each row's chunk and place in it.
        let mut tiles: Vec<([i64; 2], usize)> = Vec::new();
        for row in &rows {
            match tiles.last_mut() {
                Some((tile, count)) if *tile == tile_of(row) => *count += 1,
                _ => tiles.push((tile_of(row), 1)),
            }
        }
        let chunk_slots = tiles.iter().map(|(_, count)| count).max().unwrap_or(&0) * stride;
        let mut origin = HashMap::with_capacity(rows.len());
        let mut row_index = 0;
        for (c, (_, count)) in tiles.iter().enumerate() {
            for r in 0..*count {
                origin.insert(rows[row_index], c * chunk_slots + r * stride + GHOST);
                row_index += 1;
            }
        }
        let slot_count = tiles.len() * chunk_slots;
        let slot_of: Vec<u32> = sites.iter().map(|s| (origin[&[s[1], s[2]]] + s[0] as usize) as u32).collect();
        let mut particle_of = vec![NO_PARTICLE; slot_count];
        for (i, slot) in slot_of.iter().enumerate() {
            particle_of[*slot as usize] = i as u32;
        }
        let chunks: Vec<(ChunkShape, Vec<u64>)> = tiles
            .par_iter()
            .enumerate()
            .map(|(c, (_, count))| {
                plan_chunk(particles, &sites, &slot_of, &particle_of, c * chunk_slots, count * stride)
            })
            .collect();
        let lanes: usize = chunks.iter().map(|(_, entries)| entries.len()).sum();
        let filled = chunks.iter().flat_map(|(_, entries)| entries).filter(|k| **k != PADDING).count();
        if lanes > 0 && (filled as f64) < MIN_FILL * lanes as f64 {
            return None;
        }
        Some(LatticePlan { chunk_slots, slot_of, particle_of, chunks })
    }

    /// Every chunk's shape, blocks and lane bond ids: the blocks start as `padding`, and
    /// `lane(block, lane, i, k)` fills each lane that holds a bond, particle i's file entry k;
    /// a lane's id is the bond's ([`bond_id`]), [`PADDING`] for none.
    pub(crate) fn fill_chunks<B: Copy + Send + Sync>(
        &self,
        particles: &ParticleSet,
        padding: B,
        lane: impl Fn(&mut B, usize, usize, usize) + Sync,
    ) -> Vec<(ChunkShape, Vec<B>, Vec<u64>)> {
        self.chunks
            .par_iter()
            .map(|(shape, entries)| {
                let mut blocks = vec![padding; entries.len() / LANES];
                let mut ids = vec![PADDING; entries.len()];
                for (brick, &own) in shape.brick_slot.iter().enumerate() {
                    for (block, _) in shape.brick_blocks(brick) {
                        for l in 0..LANES {
                            let k = entries[block * LANES + l];
                            if k != PADDING {
                                let i = self.particle_of[own as usize + l] as usize;
                                lane(&mut blocks[block], l, i, k as usize);
                                ids[block * LANES + l] = bond_id(particles, i, k as usize);
                            }
                        }
                    }
                }
                (shape.clone(), blocks, ids)
            })
            .collect()
    }
}

/// A block as it is filled: its lanes, and the rest its lanes share (`None` before the first
/// lane; `shared` false once two lanes differ).
#[derive(Debug, Clone, Copy)]
struct BlockFill {
    block: LatticeBlock,
    rest: Option<BlockRest>,
    shared: bool,
}

impl BlockFill {
    /// A lane with rest `rest`: kept if it is the block's first, compared bit for bit otherwise.
    fn share(&mut self, rest: BlockRest) {
        let bits = |r: &BlockRest| (r.vector_m.map(f32::to_bits), r.length_m.to_bits());
        match &self.rest {
            None => self.rest = Some(rest),
            Some(first) => self.shared &= bits(first) == bits(&rest),
        }
    }
}

impl LatticeTable {
    /// The lattice layout of `particles` with the bond values of `values`, or `None` when the
    /// particles are not on a cubic lattice (see [`lattice_sites`]), fill too few lanes, or a
    /// block's bonds differ in their f32 rest vectors or lengths (a lattice that f32 does not
    /// hold exactly).
    pub(crate) fn new(particles: &ParticleSet, values: &EntryValues) -> Option<LatticeTable> {
        let plan = LatticePlan::new(particles)?;
        let empty = BlockFill { block: LatticeBlock::PADDING, rest: None, shared: true };
        let filled = plan.fill_chunks(particles, empty, |fill, lane, i, k| {
            let entry = BondEntry::new(particles, values, i, k);
            fill.block.threshold[lane] = entry.threshold;
            fill.block.stiffness[lane] = entry.stiffness;
            fill.share(BlockRest { vector_m: entry.rest_vector, length_m: entry.rest_length_m });
        });
        let mut chunks = Vec::with_capacity(filled.len());
        for (shape, fills, bond_id) in filled {
            let mut rest = Vec::with_capacity(fills.len());
            for fill in &fills {
                // every block holds at least one bond
                rest.push(fill.rest.filter(|_| fill.shared)?);
            }
            let blocks = fills.iter().map(|fill| fill.block).collect();
            chunks.push(LatticeChunk { shape, blocks, rest, bond_id, breaks: Vec::new() });
        }
        let slots = SlotArrays::new(plan.particle_of.len(), PmbSlot::COUNT);
        let LatticePlan { chunk_slots, slot_of, particle_of, .. } = plan;
        Some(LatticeTable { chunk_slots, chunks, slot_of, particle_of, slots })
    }
}

/// The size (y, z) of the tiles of rows that make the chunks: of all tilings of the rows' extent
/// into at least [`MIN_CHUNKS`] tiles (or into single rows, if there are fewer), the one with the
/// shortest tile perimeter per row, so that the fewest bonds cross chunks.
fn tile_size(rows: &[[i64; 2]]) -> [i64; 2] {
    let extent = [0, 1].map(|axis| rows.iter().map(|r| r[axis] as usize).max().unwrap_or(0) + 1);
    let mut best = ([1, 1], f64::INFINITY);
    for across_y in 1..=extent[0] {
        for across_z in 1..=extent[1] {
            let size = [extent[0].div_ceil(across_y), extent[1].div_ceil(across_z)];
            let tiles = extent[0].div_ceil(size[0]) * extent[1].div_ceil(size[1]);
            if tiles < MIN_CHUNKS && size != [1, 1] {
                continue;
            }
            let crossing = 1.0 / size[0] as f64 + 1.0 / size[1] as f64;
            if crossing < best.1 {
                best = (size, crossing);
            }
        }
    }
    best.0.map(|side| side as i64)
}

/// Plans the blocks of the chunk of slots `first_slot..first_slot + slots`, brick by brick: its
/// shape and the file entry of each lane.
fn plan_chunk(
    particles: &ParticleSet,
    sites: &[Site],
    slot_of: &[u32],
    particle_of: &[u32],
    first_slot: usize,
    slots: usize,
) -> (ChunkShape, Vec<u64>) {
    let bonds = &particles.bonds;
    let inside = |slot: usize| (first_slot..first_slot + slots).contains(&slot);
    let mut shape = ChunkShape { first_slot, slots, brick_start: vec![0], ..ChunkShape::default() };
    let mut entries: Vec<u64> = Vec::new();
    // One brick's stored bonds: (external, offset (z, y, x), lane, partner, file entry).
    let mut lanes: Vec<(bool, Site, usize, usize, usize)> = Vec::new();
    for brick in (first_slot..first_slot + slots).step_by(LANES) {
        lanes.clear();
        for (lane, &i) in particle_of[brick..brick + LANES].iter().enumerate() {
            if i == NO_PARTICLE {
                continue;
            }
            let i = i as usize;
            for k in bonds.row(i) {
                let j = bonds.neighbor[k] as usize;
                let offset = [2, 1, 0].map(|axis| sites[j][axis] - sites[i][axis]);
                let internal = inside(slot_of[j] as usize);
                if internal && offset < [0; 3] {
                    continue; // stored at the opposite offset, in j's brick
                }
                lanes.push((!internal, offset, lane, j, k));
            }
        }
        if lanes.is_empty() {
            continue;
        }
        // Internal blocks first, then external; one block per offset.
        lanes.sort_unstable_by_key(|(external, offset, lane, _, _)| (*external, *offset, *lane));
        shape.brick_slot.push(brick as u32);
        let mut internal_end = None;
        for group in lanes.chunk_by(|a, b| (a.0, a.1) == (b.0, b.1)) {
            let block = shape.partner_slot.len();
            if group[0].0 && internal_end.is_none() {
                internal_end = Some(block);
            }
            let mut ids = [PADDING; LANES];
            for (_, _, lane, _, k) in group {
                ids[*lane] = *k as u64;
            }
            let (_, _, lane, j, _) = group[0];
            shape.partner_slot.push(slot_of[j] - lane as u32);
            entries.extend(ids);
        }
        let blocks = shape.partner_slot.len();
        shape.internal_end.push(internal_end.unwrap_or(blocks) as u32);
        shape.brick_start.push(blocks as u32);
    }
    (shape, entries)
}
