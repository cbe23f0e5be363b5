//! The row layout of the CPU's bonds: particles in fixed chunks, each chunk owning its bonds;
//! any particle set.
//!
//! A bond whose two particles share a chunk is stored once, in the row of the lower index, and
//! its force is applied to both ends (Newton's third law within the chunk: half the work). A bond
//! that crosses chunks is stored in both rows and each side computes it. A row is stored in
//! blocks of eight entries ([`BondBlock`]), its internal entries first. Chunks depend only on
//! the particle count, never on the thread count, and each chunk is processed in a fixed order,
//! so every sum happens in the same order on 1 thread or 64.

use rayon::prelude::*;
use shatter_core::particles::ParticleSet;

use super::EntryValues;

/// Particles per chunk for `n` particles: large enough that most bonds stay inside a chunk, small
/// enough for 8 or more chunks to share out among threads; a power of two, so that chunks of the
/// Z-curve order are compact.
pub fn chunk_size(n: usize) -> usize {
    (n / 16).next_power_of_two().clamp(1024, 16384)
}

/// Entries per [`BondBlock`]: one 256-bit register of f32.
pub const LANES: usize = 8;

/// The bond id of a padding lane.
pub const PADDING: u64 = u64::MAX;

/// Eight consecutive entries of one particle's row, all internal or all external, stored together
/// so that the spring kernel reads a block as one contiguous 128 bytes (16 a bond entry). A row's
/// last internal and last external block are padded with inert lanes: a bond of no stiffness and
/// infinite threshold to the particle itself, with bond id [`PADDING`]; its force and stretch are
/// zero. The rest vector xi = X_j - X_i is not stored: the kernels compute it in f32 from the
/// partners' [`RestPosition`]s, which they gather beside the displacements, as the layout would
/// have (the same bits; docs/DECISIONS.md#row-layout).
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(32))]
pub struct BondBlock {
    /// Partner particle (global index).
    pub neighbor: [u32; LANES],
    /// Rest length, metres: the file's (stored: a square root per bond and step saved, and a
    /// file's lengths need not be |xi| in f32).
    pub rest_length_m: [f32; LANES],
    /// Critical stretch; infinite once broken.
    pub threshold: [f32; LANES],
    /// k = c V_i V_j g_ij (N per unit stretch); 0 once broken.
    pub stiffness: [f32; LANES],
}

impl BondBlock {
    /// A block of padding lanes of particle `i`.
    pub fn padding(i: usize) -> BondBlock {
        BondBlock {
            neighbor: [i as u32; LANES],
            rest_length_m: [1.0; LANES],
            threshold: [f32::INFINITY; LANES],
            stiffness: [0.0; LANES],
        }
    }

    /// Puts `entry` into lane `lane` (all but its rest vector, see [`BondBlock`]).
    pub fn set_lane(&mut self, lane: usize, entry: &BondEntry) {
        self.neighbor[lane] = entry.neighbor;
        self.rest_length_m[lane] = entry.rest_length_m;
        self.threshold[lane] = entry.threshold;
        self.stiffness[lane] = entry.stiffness;
    }
}

/// A particle's rest position padded to 16 bytes, so that a row kernel loads a partner's whole.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(16))]
pub struct RestPosition {
    /// Rest position X, metres (x, y, z).
    pub position_m: [f32; 3],
    /// Unused (zero).
    pub padding: f32,
}

impl RestPosition {
    /// The rest positions of `positions` (metres).
    pub fn all(positions: &[[f32; 3]]) -> Vec<RestPosition> {
        positions.iter().map(|&position_m| RestPosition { position_m, padding: 0.0 }).collect()
    }

    /// The [`rest_vector`] from this particle (i) to `partner` (j): what every row kernel
    /// computes lane by lane.
    #[inline(always)]
    pub fn to(self, partner: RestPosition) -> [f32; 3] {
        rest_vector(self.position_m, partner.position_m)
    }
}

/// The rest vector xi = X_j - X_i from rest position `from` (X_i) to `to` (X_j), metres, in f32:
/// the one formula every layout and kernel uses, so that their rest vectors are the same bits.
#[inline(always)]
pub fn rest_vector(from: [f32; 3], to: [f32; 3]) -> [f32; 3] {
    [0, 1, 2].map(|axis| to[axis] - from[axis])
}

/// One chunk's bonds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BondChunk {
    /// First particle of the chunk.
    pub first: usize,
    /// Particles in the chunk.
    pub len: usize,
    /// Block offsets per local particle (len + 1).
    pub row_start: Vec<u32>,
    /// End of each row's internal blocks (partners in this chunk with a higher index); the rest
    /// of the row holds external blocks.
    pub internal_end: Vec<u32>,
    /// The blocks of all rows.
    pub blocks: Vec<BondBlock>,
    /// Each lane's bond id (block * 8 + lane): the bond's entry index in the particle file's CSR,
    /// in the lower particle's row; [`PADDING`] for padding.
    pub bond_id: Vec<u64>,
    /// Ids of bonds this chunk saw break in the current step (scratch, reused).
    pub breaks: Vec<u64>,
    /// Per-particle force and smallest-stretch sums of the current step (scratch, reused).
    pub totals: Vec<[f32; 4]>,
}

/// One bond as seen from one of its particles, before it is packed into a block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BondEntry {
    /// Partner particle (global index).
    pub neighbor: u32,
    /// Rest vector xi = X_j - X_i, metres (the lattice layout keeps it per block; the row layout
    /// computes it from the rest positions, [`BondBlock`]).
    pub rest_vector: [f32; 3],
    /// Rest length |xi|, metres.
    pub rest_length_m: f32,
    /// Critical stretch.
    pub threshold: f32,
    /// Stiffness k, N per unit stretch.
    pub stiffness: f32,
    /// The bond's id (see [`BondChunk::bond_id`]).
    pub bond_id: u64,
}

/// The id of the bond that is particle i's file entry k: the lower particle's entry for it,
/// the same from either end.
pub fn bond_id(particles: &ParticleSet, i: usize, k: usize) -> u64 {
    let bonds = &particles.bonds;
    let j = bonds.neighbor[k] as usize;
    let id = if i < j {
        k
    } else {
        bonds.find(j, i as u32).unwrap_or_else(|| unreachable!("validated: bonds are symmetric"))
    };
    id as u64
}

impl BondEntry {
    /// Particle i's file entry k (a bond of i's row) with the values of `values`.
    pub(crate) fn new(particles: &ParticleSet, values: &EntryValues, i: usize, k: usize) -> BondEntry {
        let bonds = &particles.bonds;
        let j = bonds.neighbor[k] as usize;
        BondEntry {
            neighbor: j as u32,
            rest_vector: rest_vector(particles.rest_position_m[i], particles.rest_position_m[j]),
            rest_length_m: bonds.rest_length_m[k],
            threshold: values.threshold(k),
            stiffness: values.stiffness(i, j, bonds.rest_length_m[k]),
            bond_id: bond_id(particles, i, k),
        }
    }
}

impl BondChunk {
    /// An empty chunk of particles `first..first + len`, to be filled row by row.
    pub fn new(first: usize, len: usize) -> BondChunk {
        BondChunk { first, len, row_start: vec![0], ..BondChunk::default() }
    }

    /// Appends the row of the chunk's next particle: its internal entries, then its external
    /// ones, each packed into padded blocks.
    pub fn push_row(&mut self, internal: &[BondEntry], external: &[BondEntry]) {
        let i = self.first + self.internal_end.len();
        self.push_blocks(i, internal);
        self.internal_end.push(self.blocks.len() as u32);
        self.push_blocks(i, external);
        self.row_start.push(self.blocks.len() as u32);
    }

    fn push_blocks(&mut self, i: usize, entries: &[BondEntry]) {
        for group in entries.chunks(LANES) {
            let mut block = BondBlock::padding(i);
            let mut ids = [PADDING; LANES];
            for (lane, entry) in group.iter().enumerate() {
                block.set_lane(lane, entry);
                ids[lane] = entry.bond_id;
            }
            self.blocks.push(block);
            self.bond_id.extend(ids);
        }
    }

    /// Particle `local`'s blocks (indices into [`BondChunk::blocks`]), each with whether it is
    /// internal.
    pub fn row(&self, local: usize) -> impl Iterator<Item = (usize, bool)> + use<> {
        let (start, middle) = (self.row_start[local] as usize, self.internal_end[local] as usize);
        (start..self.row_start[local + 1] as usize).map(move |block| (block, block < middle))
    }

    /// Particle `local`'s bonds (padding skipped): (block, lane, internal).
    pub fn row_bonds(&self, local: usize) -> impl Iterator<Item = (usize, usize, bool)> + '_ {
        self.row(local).flat_map(move |(block, internal)| {
            (0..LANES)
                .filter(move |lane| self.bond_id[block * LANES + lane] != PADDING)
                .map(move |lane| (block, lane, internal))
        })
    }
}

/// All chunks.
#[derive(Debug, Clone, PartialEq)]
pub struct BondTable {
    /// Particles per chunk.
    pub chunk_size: usize,
    /// The chunks, in particle order.
    pub chunks: Vec<BondChunk>,
    /// Every particle's rest position, which the kernels gather for the bonds' rest vectors.
    pub rest_position: Vec<RestPosition>,
}

impl BondTable {
    /// Builds the table for `particles` with the bond values of `values`.
    pub(crate) fn new(particles: &ParticleSet, values: &EntryValues) -> BondTable {
        let n = particles.len();
        let size = chunk_size(n);
        let bonds = &particles.bonds;
        let chunks = (0..n.div_ceil(size))
            .into_par_iter()
            .map(|c| {
                let first = c * size;
                let end = (first + size).min(n);
                let mut chunk = BondChunk::new(first, end - first);
                let (mut internal, mut external) = (Vec::new(), Vec::new());
                for i in first..end {
                    internal.clear();
                    external.clear();
                    for k in bonds.row(i) {
                        let j = bonds.neighbor[k] as usize;
                        let inside = (first..end).contains(&j);
                        if inside && j < i {
                            continue; // stored in j's row
                        }
                        let entry = BondEntry::new(particles, values, i, k);
                        if inside { internal.push(entry) } else { external.push(entry) }
                    }
                    chunk.push_row(&internal, &external);
                }
                chunk
            })
            .collect();
        BondTable { chunk_size: size, chunks, rest_position: RestPosition::all(&particles.rest_position_m) }
    }

    /// Marks the bonds with the given ids (sorted) broken; returns how many entries changed.
    pub fn mark_broken(&mut self, sorted_ids: &[u64]) -> usize {
        self.chunks
            .par_iter_mut()
            .map(|chunk| {
                let blocks = &mut chunk.blocks;
                mark_broken(&chunk.bond_id, sorted_ids, |block, lane| {
                    blocks[block].threshold[lane] = f32::INFINITY;
                    blocks[block].stiffness[lane] = 0.0;
                })
            })
            .sum()
    }
}

/// Calls `breaks(block, lane)` for each lane whose id (`bond_id`, one per lane) is among
/// `sorted_ids`, to mark it broken (zero stiffness, infinite threshold). Returns how many.
pub(crate) fn mark_broken(bond_id: &[u64], sorted_ids: &[u64], mut breaks: impl FnMut(usize, usize)) -> usize {
    let mut marked = 0;
    for (k, id) in bond_id.iter().enumerate() {
        if *id != PADDING && sorted_ids.binary_search(id).is_ok() {
            breaks(k / LANES, k % LANES);
            marked += 1;
        }
    }
    marked
}
