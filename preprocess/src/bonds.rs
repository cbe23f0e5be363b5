//! The bond network: every pair of particles within the horizon, in CSR form, with per-bond
//! critical stretches.

use glam::DVec3;
use rayon::prelude::*;
use shatter_core::Progress;
use shatter_core::particles::Bonds;
use shatter_core::random::{splitmix64, unit_interval};

use shatter_geometry::PointKdTree;

/// Pairs at distance up to `delta * (1 + HORIZON_TOLERANCE)` are bonded, so that lattice
/// neighbours at exactly delta (e.g. (3, 0, 0) lambda at N = 3) are bonded despite rounding.
pub const HORIZON_TOLERANCE: f64 = 1e-9;

/// A jittered threshold is at most this many standard deviations from the mean.
pub const JITTER_CLAMP_SIGMAS: f64 = 4.0;

/// How bonds are made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BondParams {
    /// The horizon delta, metres.
    pub delta_m: f64,
    /// The mean critical stretch s0.
    pub mean_threshold: f64,
    /// Standard deviation of a bond's threshold as a fraction of s0.
    pub jitter: f64,
    /// Seed of the per-bond jitter.
    pub seed: u64,
}

/// Particles per parallel work item.
const CHUNK: usize = 2048;

/// Bonds every pair of `points` within `params.delta_m`, using a k-d tree. `points` are exact
/// (sampling-frame) positions that decide membership; rest lengths are computed from
/// `stored_positions`, the f32 world positions the particle file holds, so that a simulation
/// recomputing |X_j - X_i| gets the same value. Thresholds are s0 * (1 + jitter * z) with z a
/// standard normal drawn from a hash of (seed, i, j), clamped to +-4: the same for (i, j) and
/// (j, i) and independent of thread count and particle order within a row.
pub fn build_bonds(
    points: &[DVec3],
    stored_positions: &[[f32; 3]],
    params: &BondParams,
    progress: &dyn Progress,
) -> Bonds {
    assert_eq!(points.len(), stored_positions.len());
    let tree = PointKdTree::new(points);
    let radius_sq = (params.delta_m * (1.0 + HORIZON_TOLERANCE)).powi(2);
    progress.start("bonds", points.len() as u64);
    let chunks: Vec<Bonds> = (0..points.len().div_ceil(CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let rows = chunk * CHUNK..((chunk + 1) * CHUNK).min(points.len());
            let mut part = Bonds { offsets: vec![0], ..Bonds::default() };
            let mut row = Vec::new();
            for i in rows.clone() {
                row.clear();
                tree.within(points[i], radius_sq, &mut row);
                row.sort_unstable();
                for &j in row.iter().filter(|j| **j as usize != i) {
                    part.neighbor.push(j);
                    part.rest_length_m.push(f32_distance(stored_positions[i], stored_positions[j as usize]));
                    part.threshold.push((params.mean_threshold * jitter_factor(params, i as u32, j)) as f32);
                }
                part.offsets.push(part.neighbor.len() as u64);
            }
            progress.advance(rows.len() as u64);
            part
        })
        .collect();
    progress.finish();
    concatenate(chunks)
}

/// Joins per-chunk CSR parts into one, freeing each part as it goes.
fn concatenate(parts: Vec<Bonds>) -> Bonds {
    let entries = parts.iter().map(|part| part.neighbor.len()).sum();
    let rows = parts.iter().map(Bonds::rows).sum::<usize>();
    let mut bonds = Bonds {
        offsets: Vec::with_capacity(rows + 1),
        neighbor: Vec::with_capacity(entries),
        rest_length_m: Vec::with_capacity(entries),
        threshold: Vec::with_capacity(entries),
    };
    bonds.offsets.push(0);
    for part in parts {
        let base = bonds.neighbor.len() as u64;
        bonds.offsets.extend(part.offsets[1..].iter().map(|offset| base + offset));
        bonds.neighbor.extend_from_slice(&part.neighbor);
        bonds.rest_length_m.extend_from_slice(&part.rest_length_m);
        bonds.threshold.extend_from_slice(&part.threshold);
    }
    bonds
}

/// |b - a| in f32, summed in a fixed order (x, y, z).
pub fn f32_distance(a: [f32; 3], b: [f32; 3]) -> f32 {
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// 1 + jitter * z for bond {i, j}, z a standard normal drawn from a hash of (seed, i, j), clamped.
fn jitter_factor(params: &BondParams, i: u32, j: u32) -> f64 {
    if params.jitter == 0.0 {
        return 1.0;
    }
    let key = (u64::from(i.min(j)) << 32) | u64::from(i.max(j));
    let bits = splitmix64(params.seed ^ splitmix64(key));
    let p = unit_interval(bits) + 0.5 / (1u64 << 53) as f64;
    1.0 + params.jitter * standard_normal_quantile(p).clamp(-JITTER_CLAMP_SIGMAS, JITTER_CLAMP_SIGMAS)
}

/// The standard normal quantile (inverse CDF) at p in (0, 1), by Peter Acklam's rational
/// approximation (relative error below 1.2e-9): no transcendental call for 0.02425 <= p <= 0.97575.
fn standard_normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.38357751867269e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] =
        [-5.447609879822406e1, 1.615858368580409e2, -1.556989798598866e2, 6.680131188771972e1, -1.328068155288572e1];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [7.784695709041462e-3, 3.224671290700398e-1, 2.445134137142996, 3.754408661907416];
    const P_LOW: f64 = 0.02425;
    let polynomial = |coefficients: &[f64], x: f64| coefficients.iter().fold(0.0, |acc, c| acc * x + c);
    let tail = |q: f64| {
        let r = (-2.0 * q.ln()).sqrt();
        polynomial(&C, r) / (polynomial(&D, r) * r + 1.0)
    };
    if p < P_LOW {
        tail(p)
    } else if p > 1.0 - P_LOW {
        -tail(1.0 - p)
    } else {
        let x = p - 0.5;
        let r = x * x;
        polynomial(&A, r) * x / (polynomial(&B, r) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use shatter_core::NoProgress;

    use super::*;

    #[test]
    fn the_normal_quantile_matches_reference_values() {
        // reference values from Python's statistics.NormalDist().inv_cdf
        for (p, z) in [
            (1e-9, -5.9978070150076865),
            (0.001, -3.090232306167813),
            (0.3, -0.5244005127080407),
            (0.5, 0.0),
            (0.9, 1.2815515655446008),
        ] {
            assert!((standard_normal_quantile(p) - z).abs() < 2e-9 * z.abs().max(1.0), "p = {p}");
        }
    }

    #[test]
    fn jitter_has_the_requested_mean_and_spread() {
        let params = BondParams { delta_m: 1.0, mean_threshold: 1.0, jitter: 0.02, seed: 9 };
        let samples: Vec<f64> = (0..200_000u32).map(|i| jitter_factor(&params, i, i + 1)).collect();
        let mean = samples.iter().sum::<f64>() / samples.len() as f64;
        let sd = (samples.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / samples.len() as f64).sqrt();
        assert!((mean - 1.0).abs() < 2e-4, "mean {mean}");
        assert!((sd - 0.02).abs() < 4e-4, "sd {sd}");
        assert_eq!(jitter_factor(&params, 3, 8), jitter_factor(&params, 8, 3));
        let reseeded = BondParams { seed: 10, ..params };
        assert_ne!(jitter_factor(&params, 3, 8), jitter_factor(&reseeded, 3, 8));
    }

    #[test]
    fn bonds_match_brute_force_on_scattered_points() {
        let mut state = 7u64;
        let points: Vec<DVec3> = (0..700)
            .map(|_| {
                let mut next = || {
                    state = splitmix64(state);
                    (state >> 11) as f64 / (1u64 << 53) as f64
                };
                DVec3::new(next(), next(), next())
            })
            .collect();
        let stored: Vec<[f32; 3]> = points.iter().map(|p| p.as_vec3().to_array()).collect();
        let params = BondParams { delta_m: 0.15, mean_threshold: 0.01, jitter: 0.02, seed: 1 };
        let bonds = build_bonds(&points, &stored, &params, &NoProgress);
        for (i, p) in points.iter().enumerate() {
            let expected: Vec<u32> = (0..points.len() as u32)
                .filter(|&j| j as usize != i && points[j as usize].distance(*p) <= 0.15)
                .collect();
            assert_eq!(&bonds.neighbor[bonds.row(i)], &expected[..]);
        }
    }
}
