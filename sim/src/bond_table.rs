//! The simulation's bond layout: particles in fixed chunks, each chunk owning its bonds.
//!
//! A bond whose two particles share a chunk is stored once, in the row of the lower index, and
//! its force is applied to both ends (Newton's third law within the chunk: half the work). A bond
//! that crosses chunks is stored in both rows and each side computes it. Chunks depend only on
//! the particle count, never on the thread count, and each chunk is processed in a fixed order,
//! so every sum happens in the same order on 1 thread or 64.

use rayon::prelude::*;
use shatter_core::config::sim::StiffnessCorrection;
use shatter_core::particles::ParticleSet;

/// Particles per chunk for `n` particles: large enough that most bonds stay inside a chunk,
/// small enough for 16 or more chunks to share out among threads.
pub fn chunk_size(n: usize) -> usize {
    (n / 16).next_power_of_two().clamp(1024, 16384)
}

/// One chunk's bonds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BondChunk {
    /// First particle of the chunk.
    pub first: usize,
    /// Particles in the chunk.
    pub len: usize,
    /// Entry offsets per local particle (len + 1).
    pub row_start: Vec<u32>,
    /// End of each row's internal entries (partners in this chunk with a higher index); the rest
    /// of the row holds external entries.
    pub internal_end: Vec<u32>,
    /// Partner particle (global index).
    pub neighbor: Vec<u32>,
    /// Rest vector xi = X_j - X_i, metres (x, y, z arrays), computed in f32 from the file's
    /// positions: its length is bit for bit the file's rest length.
    pub rest_vector: [Vec<f32>; 3],
    /// Rest length |xi|, metres (stored: a square root per bond and step saved).
    pub rest_length_m: Vec<f32>,
    /// Critical stretch; infinite once broken.
    pub threshold: Vec<f32>,
    /// k = c V_i V_j g_ij (N per unit stretch); 0 once broken.
    pub stiffness: Vec<f32>,
    /// The bond's id: its entry index in the particle file's CSR, in the lower particle's row.
    pub bond_id: Vec<u64>,
    /// Ids of bonds this chunk saw break in the current step (scratch, reused).
    pub breaks: Vec<u64>,
    /// Per-particle force and smallest-stretch sums of the current step (scratch, reused).
    pub totals: Vec<[f32; 4]>,
}

/// All chunks.
#[derive(Debug, Clone, PartialEq)]
pub struct BondTable {
    /// Particles per chunk.
    pub chunk_size: usize,
    /// The chunks, in particle order.
    pub chunks: Vec<BondChunk>,
}

impl BondTable {
    /// Builds the table for `particles` with bond constant `c`, thresholds scaled by
    /// `threshold_scale` and by `factors` (one per file entry, art direction), and the stiffness
    /// correction. Volumes are the file's.
    pub fn new(
        particles: &ParticleSet,
        bond_constant: f64,
        threshold_scale: f64,
        factors: Option<&[f32]>,
        correction: StiffnessCorrection,
    ) -> BondTable {
        let n = particles.len();
        let size = chunk_size(n);
        let correction = stiffness_factors(particles, correction);
        let bonds = &particles.bonds;
        let volume = &particles.volume_m3;
        let chunks = (0..n.div_ceil(size))
            .into_par_iter()
            .map(|c| {
                let first = c * size;
                let end = (first + size).min(n);
                let mut chunk = BondChunk { first, len: end - first, row_start: vec![0], ..BondChunk::default() };
                for i in first..end {
                    let row = bonds.row(i);
                    let internal = row.clone().filter(|k| {
                        let j = bonds.neighbor[*k] as usize;
                        j > i && j < end
                    });
                    let external = row.clone().filter(|k| {
                        let j = bonds.neighbor[*k] as usize;
                        j < first || j >= end
                    });
                    let push = |chunk: &mut BondChunk, k: usize| {
                        let j = bonds.neighbor[k] as usize;
                        let factor = factors.map_or(1.0, |f| f64::from(f[k]));
                        chunk.neighbor.push(j as u32);
                        let (xi, xj) = (particles.rest_position_m[i], particles.rest_position_m[j]);
                        for axis in 0..3 {
                            chunk.rest_vector[axis].push(xj[axis] - xi[axis]);
                        }
                        chunk.rest_length_m.push(bonds.rest_length_m[k]);
                        chunk.threshold.push((f64::from(bonds.threshold[k]) * threshold_scale * factor) as f32);
                        let g = 0.5 * (correction[i] + correction[j]);
                        chunk.stiffness.push((bond_constant * f64::from(volume[i]) * f64::from(volume[j]) * g) as f32);
                        let id = if i < j {
                            k
                        } else {
                            bonds.find(j, i as u32).unwrap_or_else(|| unreachable!("validated: bonds are symmetric"))
                        };
                        chunk.bond_id.push(id as u64);
                    };
                    for k in internal {
                        push(&mut chunk, k);
                    }
                    chunk.internal_end.push(chunk.neighbor.len() as u32);
                    for k in external {
                        push(&mut chunk, k);
                    }
                    chunk.row_start.push(chunk.neighbor.len() as u32);
                }
                chunk
            })
            .collect();
        BondTable { chunk_size: size, chunks }
    }

    /// Marks the bonds with the given ids (sorted) broken; returns how many entries changed.
    pub fn mark_broken(&mut self, sorted_ids: &[u64]) -> usize {
        self.chunks
            .par_iter_mut()
            .map(|chunk| {
                let mut marked = 0;
                for k in 0..chunk.bond_id.len() {
                    if sorted_ids.binary_search(&chunk.bond_id[k]).is_ok() {
                        chunk.threshold[k] = f32::INFINITY;
                        chunk.stiffness[k] = 0.0;
                        marked += 1;
                    }
                }
                marked
            })
            .sum()
    }
}

/// Per-particle stiffness factors g_i. `Energy`: g_i = pi delta^4 / sum_j |xi_ij| V_j, which makes
/// a uniform dilation store exactly the continuum energy density 4.5 K s^2 at particle i.
pub(crate) fn stiffness_factors(particles: &ParticleSet, correction: StiffnessCorrection) -> Vec<f64> {
    let n = particles.len();
    match correction {
        StiffnessCorrection::None => vec![1.0; n],
        StiffnessCorrection::Energy => {
            let bonds = &particles.bonds;
            let target = std::f64::consts::PI * particles.meta.delta_m.powi(4);
            (0..n)
                .into_par_iter()
                .map(|i| {
                    let sum: f64 = bonds
                        .row(i)
                        .map(|k| {
                            f64::from(bonds.rest_length_m[k])
                                * f64::from(particles.volume_m3[bonds.neighbor[k] as usize])
                        })
                        .sum();
                    if sum > 0.0 { target / sum } else { 1.0 }
                })
                .collect()
        }
    }
}
