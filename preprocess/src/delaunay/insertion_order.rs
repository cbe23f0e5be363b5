//! The biased randomized insertion order (BRIO): a deterministic shuffle split into rounds of
//! doubling size, each round sorted along a Z-order (Morton) curve.

use glam::DVec3;

use super::splitmix::SplitMix64;

/// Seed of the insertion-order shuffle (any constant: it only has to be fixed).
const BRIO_SEED: u64 = 0x5EED_DE1A_0BA7_0001;

/// BRIO rounds halve in size until one is at most this big.
const FIRST_ROUND_MAX: usize = 64;

/// The biased randomized insertion order: shuffled, split into rounds of doubling size, each
/// round sorted along a Morton curve.
pub(super) fn insertion_order(points: &[DVec3], mut ids: Vec<u32>) -> Vec<u32> {
    let mut rng = SplitMix64::new(BRIO_SEED);
    for i in (1..ids.len()).rev() {
        ids.swap(i, rng.below(i + 1));
    }
    let morton = MortonFrame::new(ids.iter().map(|&i| points[i as usize]));
    let mut keyed: Vec<(u64, u32)> = ids.iter().map(|&i| (morton.code(points[i as usize]), i)).collect();
    let mut end = keyed.len();
    while end > 0 {
        let start = if end <= FIRST_ROUND_MAX { 0 } else { end / 2 };
        keyed[start..end].sort_unstable();
        end = start;
    }
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// Maps points into a cube of 2^21 cells a side for Morton codes (the same scale on every axis,
/// so flat inputs are not stretched).
pub(super) struct MortonFrame {
    low: DVec3,
    scale: f64,
}

impl MortonFrame {
    const CELLS: f64 = ((1u32 << 21) - 1) as f64;

    pub(super) fn new(points: impl Iterator<Item = DVec3>) -> MortonFrame {
        let (low, high) = points.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)));
        let extent = (high - low).max_element();
        let scale = if extent > 0.0 { Self::CELLS / extent } else { 0.0 };
        MortonFrame { low, scale }
    }

    pub(super) fn code(&self, p: DVec3) -> u64 {
        let cell = ((p - self.low) * self.scale).clamp(DVec3::ZERO, DVec3::splat(Self::CELLS));
        spread_bits(cell.x as u64) | (spread_bits(cell.y as u64) << 1) | (spread_bits(cell.z as u64) << 2)
    }
}

/// Spreads the low 21 bits of `v` so that bit `i` lands on bit `3 i`.
pub(super) fn spread_bits(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}
