//! Spatially coherent particle order: points sorted along a Z-order (Morton) curve, so that
//! neighbours in space are mostly neighbours in memory (the simulation and the bond build rely on
//! it for speed; the grid sampler orders its cells the same way).

use glam::DVec3;

/// Cells per axis of the quantization (21 bits, the Morton code's width per axis).
const CELLS: f64 = (1u64 << 21) as f64;

/// The permutation that sorts `points` along a Z-order curve: entry `k` is the index of the point
/// that goes to position `k`. Points are quantized to 2^21 cells per axis of their bounding cube
/// (the same scale on every axis); ties keep their input order, so the result is deterministic.
pub fn z_order(points: &[DVec3]) -> Vec<u32> {
    assert!(u32::try_from(points.len()).is_ok(), "at most u32::MAX points can be ordered");
    let (lo, hi) = points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let extent = (hi - lo).max_element();
    let scale = if extent > 0.0 && extent.is_finite() { (CELLS - 1.0) / extent } else { 0.0 };
    let cell = |p: DVec3| {
        let q = ((p - lo) * scale).to_array();
        q.map(|c| if c.is_finite() { c.clamp(0.0, CELLS - 1.0) as usize } else { 0 })
    };
    let mut keyed: Vec<(u64, u32)> =
        points.iter().enumerate().map(|(i, p)| (morton_code(cell(*p)), i as u32)).collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// Interleaves the low 21 bits of each coordinate: x in bit 0, y in bit 1, z in bit 2, ...
pub(crate) fn morton_code(cell: [usize; 3]) -> u64 {
    fn spread(v: usize) -> u64 {
        let mut x = (v as u64) & 0x1f_ffff;
        x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
        x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
        x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
        x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
        (x | (x << 2)) & 0x1249_2492_4924_9249
    }
    spread(cell[0]) | (spread(cell[1]) << 1) | (spread(cell[2]) << 2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_code_interleaves_bits() {
        assert_eq!(morton_code([1, 0, 0]), 1);
        assert_eq!(morton_code([0, 1, 0]), 2);
        assert_eq!(morton_code([0, 0, 1]), 4);
        assert_eq!(morton_code([3, 3, 3]), 63);
        assert_eq!(morton_code([(1 << 21) - 1, 0, 0]), 0x1249_2492_4924_9249);
    }

    #[test]
    fn points_follow_the_z_curve_and_ties_keep_their_order() {
        let points = [
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 0.0, 0.0),
        ];
        assert_eq!(z_order(&points), [1, 4, 2, 3, 0]);
        assert_eq!(z_order(&[]), Vec::<u32>::new());
        assert_eq!(z_order(&[DVec3::ONE]), [0]);
    }
}
