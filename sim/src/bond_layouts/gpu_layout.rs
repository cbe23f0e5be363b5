//! The GPU's bond layout: both directions of every bond stored, in sliced ELLPACK (SELL-32)
//! order, cut into ranges that each fit one storage binding.
//!
//! Particles (already in Z-curve order) form slices of [`SLICE`] = 32. A slice is as wide as the
//! longest row among its particles; entry k of the particle in lane l of a slice that starts at
//! entry E sits at E + 32 k + l. When the 32 invocations of a slice step through their rows
//! together, each array is read as consecutive words: fully coalesced, whatever the row lengths
//! (rows shorter than the slice's width leave padding that is never read). Rows keep the
//! particle file's order (neighbours ascending), so entry k of particle i is file entry
//! `offsets[i] + k`: a bond's id is found without storing it, and a row can be binary searched.
//!
//! Per entry: the partner (u32), the stiffness k_ij = c V_i V_j g_ij (f32) and the threshold
//! (f32): 12 bytes. The rest vector and length are recomputed from the rest positions the kernel
//! gathers anyway. Broken bonds are one bit per entry, in words laid out like the entries (word
//! m of the particle in lane l sits at W + 32 m + l), so each word belongs to one particle:
//! the particle's own invocation sets its bits with a plain store, no atomics needed.
//!
//! Ranges: consecutive groups of [`WG`] particles (whole workgroups, whole slices), as many as fit
//! the byte limit of one binding for each array. Each range gets its own buffers, so the largest
//! bond set is never limited by one binding or one buffer.

use rayon::prelude::*;
use shatter_core::config::sim::{PartialVolumes, StiffnessCorrection};
use shatter_core::particles::ParticleSet;

use super::EntryValues;
use crate::gpu::wgsl_structs::{Range, SLICE, WG};

/// One range's bond arrays.
#[derive(Debug, Clone, PartialEq)]
pub struct RangeLayout {
    /// Its particles and workgroups.
    pub range: Range,
    /// Partner of each entry (padding: the particle itself).
    pub neighbor: Vec<u32>,
    /// k_ij, N per unit stretch (padding: 0).
    pub stiffness: Vec<f32>,
    /// Critical stretch tau_ij (padding: infinity).
    pub threshold: Vec<f32>,
    /// Words of broken bits.
    pub words: usize,
}

/// The whole layout.
#[derive(Debug, Clone, PartialEq)]
pub struct GpuBondLayout {
    /// Per particle: first entry (within its range; add 32 per k), first bit word (within its
    /// range), row length, and the row's first entry in the particle file (bond ids).
    pub rows: Vec<[u32; 4]>,
    /// The ranges, in particle order.
    pub ranges: Vec<RangeLayout>,
    /// Index of the range holding each group of [`WG`] particles.
    pub range_of_group: Vec<u32>,
}

/// Why a layout cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GpuLayoutError {
    /// More bond entries than 32-bit indices reach.
    #[error("{0} bond entries: the GPU backend indexes bonds with 32 bits (at most 4,294,967,295 entries)")]
    TooManyEntries(u64),
    /// One group of particles needs more than one binding holds.
    #[error(
        "the bonds of particles {first}..{end} need {bytes} bytes per array, more than one storage binding of \
         this adapter holds ({limit} bytes)"
    )]
    GroupTooLarge {
        /// First particle of the group.
        first: usize,
        /// End of the group.
        end: usize,
        /// Bytes needed.
        bytes: u64,
        /// The binding limit.
        limit: u64,
    },
}

impl GpuBondLayout {
    /// Lays out the bonds of `particles` with bond constant `c`, thresholds scaled by
    /// `threshold_scale` and `factors` (one per file entry), the stiffness correction and partial
    /// volumes: the
    /// same per-entry values as the CPU's [`super::row_layout::BondTable`]. Each range's arrays
    /// hold at most `max_binding_bytes`.
    pub fn new(
        particles: &ParticleSet,
        bond_constant: f64,
        threshold_scale: f64,
        factors: Option<&[f32]>,
        correction: StiffnessCorrection,
        partial_volumes: PartialVolumes,
        max_binding_bytes: u64,
    ) -> Result<GpuBondLayout, GpuLayoutError> {
        let n = particles.len();
        let bonds = &particles.bonds;
        let total = bonds.neighbor.len() as u64;
        if total > u64::from(u32::MAX) {
            return Err(GpuLayoutError::TooManyEntries(total));
        }
        let degree = |i: usize| if i < n { bonds.row(i).len() } else { 0 };
        let slices = n.div_ceil(SLICE);
        let width: Vec<usize> =
            (0..slices).into_par_iter().map(|s| (s * SLICE..(s + 1) * SLICE).map(degree).max().unwrap_or(0)).collect();
        let words_of = |s: usize| SLICE * width[s].div_ceil(32);
        // Group the slices into ranges of whole workgroups.
        let per_group = WG / SLICE;
        let groups = slices.div_ceil(per_group);
        let group_entries = |g: usize| -> u64 {
            (g * per_group..((g + 1) * per_group).min(slices)).map(|s| (SLICE * width[s]) as u64).sum()
        };
        let mut ranges: Vec<(usize, usize)> = Vec::new(); // group spans
        let mut range_of_group = vec![0u32; groups];
        let mut start = 0;
        let mut bytes = 0u64;
        for (g, range) in range_of_group.iter_mut().enumerate() {
            let add = 4 * group_entries(g).max(1);
            if add > max_binding_bytes {
                return Err(GpuLayoutError::GroupTooLarge {
                    first: g * WG,
                    end: ((g + 1) * WG).min(n),
                    bytes: add,
                    limit: max_binding_bytes,
                });
            }
            if bytes + add > max_binding_bytes {
                ranges.push((start, g));
                start = g;
                bytes = 0;
            }
            bytes += add;
            *range = ranges.len() as u32;
        }
        if groups > start {
            ranges.push((start, groups));
        }

        let values = EntryValues::new(particles, bond_constant, threshold_scale, factors, correction, partial_volumes);
        let mut rows = vec![[0u32; 4]; n];
        let mut layouts = Vec::with_capacity(ranges.len());
        let mut first_workgroup = 0u32;
        for &(g0, g1) in &ranges {
            let (s0, s1) = (g0 * per_group, (g1 * per_group).min(slices));
            let first = s0 * SLICE;
            let end = (s1 * SLICE).min(n);
            // Slice starts within the range.
            let mut entry_start = Vec::with_capacity(s1 - s0 + 1);
            let mut word_start = Vec::with_capacity(s1 - s0 + 1);
            let (mut e, mut w) = (0usize, 0usize);
            for (s, slice_width) in width.iter().enumerate().take(s1).skip(s0) {
                entry_start.push(e);
                word_start.push(w);
                e += SLICE * slice_width;
                w += words_of(s);
            }
            let entries = e.max(1);
            let mut neighbor = vec![0u32; entries];
            let mut stiffness = vec![0.0f32; entries];
            let mut threshold = vec![f32::INFINITY; entries];
            // Cut the arrays into per-slice pieces and fill them in parallel.
            let mut pieces = Vec::with_capacity(s1 - s0);
            {
                let (mut nb, mut st, mut th) = (&mut neighbor[..], &mut stiffness[..], &mut threshold[..]);
                for (s, slice_width) in width.iter().enumerate().take(s1).skip(s0) {
                    let size = SLICE * slice_width;
                    let (a, rest_nb) = nb.split_at_mut(size);
                    let (b, rest_st) = st.split_at_mut(size);
                    let (c, rest_th) = th.split_at_mut(size);
                    pieces.push((s, a, b, c));
                    (nb, st, th) = (rest_nb, rest_st, rest_th);
                }
            }
            pieces.into_par_iter().for_each(|(s, nb, st, th)| {
                for lane in 0..SLICE {
                    let i = s * SLICE + lane;
                    if i >= n {
                        for k in 0..width[s] {
                            nb[k * SLICE + lane] = 0;
                        }
                        continue;
                    }
                    let row = bonds.row(i);
                    for k in 0..width[s] {
                        let slot = k * SLICE + lane;
                        if k >= row.len() {
                            nb[slot] = i as u32;
                            continue;
                        }
                        let entry = row.start + k;
                        let j = bonds.neighbor[entry] as usize;
                        nb[slot] = j as u32;
                        st[slot] = values.stiffness(i, j, bonds.rest_length_m[entry]);
                        th[slot] = values.threshold(entry);
                    }
                }
            });
            for s in s0..s1 {
                for lane in 0..SLICE {
                    let i = s * SLICE + lane;
                    if i < n {
                        rows[i] = [
                            (entry_start[s - s0] + lane) as u32,
                            (word_start[s - s0] + lane) as u32,
                            degree(i) as u32,
                            bonds.offsets[i] as u32,
                        ];
                    }
                }
            }
            let count = end - first;
            let workgroups = count.div_ceil(WG) as u32;
            layouts.push(RangeLayout {
                range: Range { first: first as u32, count: count as u32, first_workgroup, workgroups },
                neighbor,
                stiffness,
                threshold,
                words: w.max(1),
            });
            first_workgroup += workgroups;
        }
        Ok(GpuBondLayout { rows, ranges: layouts, range_of_group })
    }

    /// Spring-kernel workgroups over all ranges.
    pub fn workgroups(&self) -> u32 {
        self.ranges.iter().map(|r| r.range.workgroups).sum()
    }

    /// Bond entries stored, padding included.
    pub fn stored_entries(&self) -> usize {
        self.ranges.iter().map(|r| r.neighbor.len()).sum()
    }

    /// The range holding particle `i`.
    pub fn range_of(&self, i: usize) -> usize {
        self.range_of_group[i / WG] as usize
    }

    /// Where particle `i`'s bit for its row entry `k` lives: (range, word, bit).
    pub fn bit_of(&self, i: usize, k: usize) -> (usize, usize, u32) {
        let row = self.rows[i];
        (self.range_of(i), row[1] as usize + (k / 32) * SLICE, (k % 32) as u32)
    }
}
