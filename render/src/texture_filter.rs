//! The floor texture filtered over each ray's footprint: a mip chain of the texture (2 x 2 box
//! filtered down to one texel), and anisotropic lookups along the footprint's long axis, each
//! trilinear. A ray's footprint is its ray cone's: the pixel's angle times the distance the path
//! has travelled, stretched by the grazing angle at which it meets the floor. The twin of
//! `shaders/texture_filter.wgsl`.

use crate::materials::FloorLook;

/// Most lookups along a footprint's long axis.
pub const MAX_TAPS: u32 = 8;

/// A texture's mip chain: level 0 the texture itself (linear), each next level half its size
/// (rounded down, at least 1), each texel the mean of the 2 x 2 (or fewer, at an odd edge) texels
/// under it.
#[derive(Debug, Clone, PartialEq)]
pub struct MipChain {
    /// Each level's first texel in `texels`, width and height.
    pub levels: Vec<[usize; 3]>,
    /// Every level's texels, row-major, one level after the other.
    pub texels: Vec<[f32; 3]>,
}

impl MipChain {
    /// The chain of `floor`'s texture.
    pub fn of(floor: &FloorLook) -> MipChain {
        let [mut width, mut height] = floor.size;
        let mut texels: Vec<[f32; 3]> = (0..width * height).map(|i| floor.texels.linear_at(i)).collect();
        let mut levels = vec![[0, width, height]];
        while width > 1 || height > 1 {
            let (w, h) = ((width / 2).max(1), (height / 2).max(1));
            let above = levels.last().map_or(0, |level| level[0]);
            let start = texels.len();
            for y in 0..h {
                for x in 0..w {
                    let mut sum = [0.0f32; 3];
                    let mut count = 0.0f32;
                    for (sx, sy) in [(2 * x, 2 * y), (2 * x + 1, 2 * y), (2 * x, 2 * y + 1), (2 * x + 1, 2 * y + 1)] {
                        if sx < width && sy < height {
                            let t = texels[above + sy * width + sx];
                            (0..3).for_each(|k| sum[k] += t[k]);
                            count += 1.0;
                        }
                    }
                    texels.push(sum.map(|v| v / count));
                }
            }
            levels.push([start, w, h]);
            (width, height) = (w, h);
        }
        MipChain { levels, texels }
    }

    /// Level `level`'s bilinear lookup at (u, v) in [0, 1)^2, the texture tiled.
    fn bilinear(&self, level: usize, u: f32, v: f32) -> [f32; 3] {
        let [start, width, height] = self.levels[level];
        let (x, y) = (u * width as f32 - 0.5, v * height as f32 - 0.5);
        let (fx, fy) = (x - x.floor(), y - y.floor());
        let (x0, y0) = (wrap(x.floor() as i64, width), wrap(y.floor() as i64, height));
        let (x1, y1) = (wrap(x0 as i64 + 1, width), wrap(y0 as i64 + 1, height));
        let at = |x: usize, y: usize| self.texels[start + y * width + x];
        let (a, b, c, d) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
        std::array::from_fn(|k| (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy)
    }

    /// The trilinear lookup at (u, v) of level of detail `lod` (0: level 0's texels).
    fn trilinear(&self, lod: f32, u: f32, v: f32) -> [f32; 3] {
        let top = (self.levels.len() - 1) as f32;
        let lod = lod.clamp(0.0, top);
        let level = lod.floor();
        let blend = lod - level;
        let below = self.bilinear(level as usize, u, v);
        if blend == 0.0 {
            return below;
        }
        let above = self.bilinear((level as usize + 1).min(self.levels.len() - 1), u, v);
        std::array::from_fn(|k| below[k] * (1.0 - blend) + above[k] * blend)
    }
}

/// Texel index `i` wrapped onto a row or column of `n` texels, `i` modulo `n`: a lookup at (u, v)
/// in [0, 1] reads indices from -1 to `n`, wrapped without a division.
fn wrap(i: i64, n: usize) -> usize {
    let n = n as i64;
    let wrapped = if i < 0 {
        i + n
    } else if i >= n {
        i - n
    } else {
        i
    };
    if (0..n).contains(&wrapped) { wrapped as usize } else { i.rem_euclid(n) as usize }
}

/// Where a ray meets the floor, and how wide its cone is there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    /// The ray's unit direction.
    pub direction: [f32; 3],
    /// The cone's width across the ray where it meets the floor, metres.
    pub width_m: f32,
}

/// The floor's albedo at `p` averaged over `footprint`, through `mips` (its texture's chain): an
/// ellipse on the floor whose short axis is the cone's width and whose long axis, along the
/// ray's way across the floor, is that over the sine of the grazing angle; up to
/// [`MAX_TAPS`] trilinear lookups spaced along the long axis, at the level of detail of the
/// longer of the short axis and the long axis's share per lookup.
pub fn filtered_albedo(floor: &FloorLook, mips: &MipChain, p: [f32; 3], footprint: Footprint) -> [f32; 3] {
    let fraction = |x: f32| x - x.floor();
    let (u, v) = (fraction(p[0] / floor.tile), fraction(p[2] / floor.tile));
    let [_, width, height] = mips.levels[0];
    // the axes in level-0 texels (the texture may not be square: x and z scale apart)
    let texels = |metres: f32| metres / floor.tile * width.max(height) as f32;
    let d = footprint.direction;
    let sine = d[1].abs().max(1e-4);
    let across = (d[0] * d[0] + d[2] * d[2]).sqrt();
    let (ax, az) = if across > 0.0 { (d[0] / across, d[2] / across) } else { (1.0, 0.0) };
    let minor = texels(footprint.width_m).max(1e-6);
    let major = minor / sine;
    // one lookup per texel-wide share of the long axis: none more where it is under a texel
    let taps = ((major / minor.max(1.0)).ceil() as u32).clamp(1, MAX_TAPS);
    let lod = (minor.max(major / taps as f32)).log2();
    // the long axis in (u, v) units
    let (du, dv) = (ax * footprint.width_m / sine / floor.tile, az * footprint.width_m / sine / floor.tile);
    let mut sum = [0.0f32; 3];
    for i in 0..taps {
        let s = (i as f32 + 0.5) / taps as f32 - 0.5;
        let texel = mips.trilinear(lod, fraction(u + s * du), fraction(v + s * dv));
        (0..3).for_each(|k| sum[k] += texel[k]);
    }
    sum.map(|c| c / taps as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::FloorTexels;

    fn checker(size: usize) -> FloorLook {
        let texels = (0..size * size)
            .map(|i| if (i % size + i / size).is_multiple_of(2) { [1.0; 3] } else { [0.0; 3] })
            .collect();
        FloorLook { height: 0.0, tile: 1.0, size: [size, size], texels: FloorTexels::Linear(texels), mips: None }
    }

    #[test]
    fn wrapping_is_the_remainder_of_a_division() {
        for n in 1..6usize {
            for i in -13..13i64 {
                assert_eq!(wrap(i, n), i.rem_euclid(n as i64) as usize, "{i} mod {n}");
            }
        }
    }

    #[test]
    fn the_chain_halves_down_to_one_texel_keeping_the_mean() {
        let floor = checker(8);
        let mips = MipChain::of(&floor);
        assert_eq!(mips.levels.iter().map(|l| (l[1], l[2])).collect::<Vec<_>>(), [(8, 8), (4, 4), (2, 2), (1, 1)]);
        assert_eq!(mips.texels.last(), Some(&[0.5; 3]), "the 1 x 1 level is the mean");
        assert_eq!(mips.texels[64], [0.5; 3], "a checker averages out at level 1");
        // an odd size keeps its edge texels
        let odd = MipChain::of(&FloorLook {
            size: [3, 1],
            texels: FloorTexels::Linear(vec![[0.0; 3], [1.0; 3], [1.0; 3]]),
            ..checker(1)
        });
        assert_eq!(odd.levels, vec![[0, 3, 1], [3, 1, 1]]);
        assert_eq!(odd.texels[3], [0.5; 3]);
    }

    #[test]
    fn a_small_footprint_reads_the_texel_and_a_wide_one_the_mean() {
        let floor = checker(64);
        let mips = MipChain::of(&floor);
        // straight down, a footprint of a tenth of a texel at a texel's centre: that texel
        let p = [(5.5) / 64.0, 0.0, (9.5) / 64.0];
        let down = [0.0, -1.0, 0.0];
        let texel = filtered_albedo(&floor, &mips, p, Footprint { direction: down, width_m: 0.1 / 64.0 });
        assert_eq!(texel, floor.texels.linear_at(9 * 64 + 5));
        // a footprint of the whole tile: the mean
        let wide = filtered_albedo(&floor, &mips, p, Footprint { direction: down, width_m: 2.0 });
        assert!(wide.iter().all(|c| (c - 0.5).abs() < 1e-6), "{wide:?}");
        // grazing along x: blurred along x, so a checker averages out though the footprint is
        // a texel wide across
        let grazing = [0.999, -0.0447, 0.0];
        let along = filtered_albedo(&floor, &mips, p, Footprint { direction: grazing, width_m: 1.0 / 64.0 });
        assert!((along[0] - 0.5).abs() < 0.1, "{along:?}");
    }
}
