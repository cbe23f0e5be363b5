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
use shatter_core::particles::{Bonds, ParticleSet};

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
        let total = particles.bonds.neighbor.len() as u64;
        if total > u64::from(u32::MAX) {
            return Err(GpuLayoutError::TooManyEntries(total));
        }
        let slices = Slices::of(particles);
        let GroupSpans { ranges, range_of_group } = slices.group_spans(max_binding_bytes)?;
        let values = EntryValues::new(particles, bond_constant, threshold_scale, factors, correction, partial_volumes);
        let mut rows = vec![[0u32; 4]; slices.n];
        let mut layouts = Vec::with_capacity(ranges.len());
        let mut first_workgroup = 0u32;
        for &groups in &ranges {
            let layout = slices.range_layout(&values, groups, first_workgroup, &mut rows);
            first_workgroup += layout.range.workgroups;
            layouts.push(layout);
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

    #[cfg(test)]
    /// Where particle `i`'s bit for its row entry `k` lives: (range, word, bit).
    pub fn bit_of(&self, i: usize, k: usize) -> (usize, usize, u32) {
        let row = self.rows[i];
        (self.range_of(i), row[1] as usize + (k / 32) * SLICE, (k % 32) as u32)
    }
}

/// The groups of [`WG`] particles in ranges.
struct GroupSpans {
    /// Each range's groups, first and end.
    ranges: Vec<(usize, usize)>,
    /// The range of each group.
    range_of_group: Vec<u32>,
}

/// The particles in slices of [`SLICE`], and each slice's width.
struct Slices<'a> {
    bonds: &'a Bonds,
    /// Particles.
    n: usize,
    /// Each slice's width: the longest row among its particles.
    width: Vec<usize>,
}

impl Slices<'_> {
    /// The slices of `particles`.
    fn of(particles: &ParticleSet) -> Slices<'_> {
        let n = particles.len();
        let mut slices = Slices { bonds: &particles.bonds, n, width: Vec::new() };
        let width = (0..n.div_ceil(SLICE))
            .into_par_iter()
            .map(|s| (s * SLICE..(s + 1) * SLICE).map(|i| slices.degree(i)).max().unwrap_or(0))
            .collect();
        slices.width = width;
        slices
    }

    /// Particle i's row length (0 past the last particle).
    fn degree(&self, i: usize) -> usize {
        if i < self.n { self.bonds.row(i).len() } else { 0 }
    }

    /// Slice s's words of broken bits.
    fn words_of(&self, s: usize) -> usize {
        SLICE * self.width[s].div_ceil(32)
    }

    /// The slices grouped into ranges of whole workgroups, each range's arrays within
    /// `max_binding_bytes`.
    fn group_spans(&self, max_binding_bytes: u64) -> Result<GroupSpans, GpuLayoutError> {
        let (n, slices, width) = (self.n, self.width.len(), &self.width);
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
        Ok(GroupSpans { ranges, range_of_group })
    }

    /// The bond arrays of the range of groups `g0..g1`, whose first workgroup is
    /// `first_workgroup` among all ranges'; sets its particles' `rows`.
    fn range_layout(
        &self,
        values: &EntryValues,
        (g0, g1): (usize, usize),
        first_workgroup: u32,
        rows: &mut [[u32; 4]],
    ) -> RangeLayout {
        let (n, slices, per_group) = (self.n, self.width.len(), WG / SLICE);
        let (s0, s1) = (g0 * per_group, (g1 * per_group).min(slices));
        let first = s0 * SLICE;
        let end = (s1 * SLICE).min(n);
        // Slice starts within the range.
        let mut entry_start = Vec::with_capacity(s1 - s0 + 1);
        let mut word_start = Vec::with_capacity(s1 - s0 + 1);
        let (mut e, mut w) = (0usize, 0usize);
        for (s, slice_width) in self.width.iter().enumerate().take(s1).skip(s0) {
            entry_start.push(e);
            word_start.push(w);
            e += SLICE * slice_width;
            w += self.words_of(s);
        }
        let entries = e.max(1);
        let mut neighbor = vec![0u32; entries];
        let mut stiffness = vec![0.0f32; entries];
        let mut threshold = vec![f32::INFINITY; entries];
        self.fill_entries(values, s0..s1, (&mut neighbor, &mut stiffness, &mut threshold));
        for s in s0..s1 {
            for lane in 0..SLICE {
                let i = s * SLICE + lane;
                if i < n {
                    rows[i] = [
                        (entry_start[s - s0] + lane) as u32,
                        (word_start[s - s0] + lane) as u32,
                        self.degree(i) as u32,
                        self.bonds.offsets[i] as u32,
                    ];
                }
            }
        }
        let count = end - first;
        let workgroups = count.div_ceil(WG) as u32;
        RangeLayout {
            range: Range { first: first as u32, count: count as u32, first_workgroup, workgroups },
            neighbor,
            stiffness,
            threshold,
            words: w.max(1),
        }
    }

    /// Fills the entries of `slices` (the range's arrays from its first slice on): each
    /// particle's partners, stiffnesses and thresholds in row order, then its padding.
    fn fill_entries(
        &self,
        values: &EntryValues,
        slices: std::ops::Range<usize>,
        (neighbor, stiffness, threshold): (&mut [u32], &mut [f32], &mut [f32]),
    ) {
        let (n, bonds, width) = (self.n, self.bonds, &self.width);
        // Cut the arrays into per-slice pieces and fill them in parallel.
        let mut pieces = Vec::with_capacity(slices.len());
        {
            let (mut nb, mut st, mut th) = (neighbor, stiffness, threshold);
            for (s, slice_width) in width.iter().enumerate().take(slices.end).skip(slices.start) {
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
    }
}
