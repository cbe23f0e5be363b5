//! Contact between particles that are not bonded, by the paper's quadratic repulsion (eq. 6).
//!
//! Candidate pairs come from a Verlet list: every particle within the contact distance plus a
//! skin, found with a spatial hash (binned by a stable counting sort) and rebuilt only when some
//! particle has moved more than half the skin since the last build. Each particle's candidates
//! are sorted by index, so forces are summed in the same order however often the list was
//! rebuilt (a resumed run matches an uninterrupted one bit for bit). In intact material the
//! lists are empty: particles sit a lattice spacing apart, farther than distance plus skin.

use rayon::prelude::*;

/// A spatial hash of particle positions with cells twice the contact distance, so that the
/// particles within the contact distance of a point lie in at most 2 x 2 x 2 cells.
#[derive(Debug, Clone, Default)]
pub struct SpatialHash {
    cell_size: f32,
    mask: usize,
    cell: Vec<[i32; 3]>,
    bucket: Vec<u32>,
    bucket_start: Vec<u32>,
    sorted: Vec<u32>,
}

fn bucket_of(cell: [i32; 3], mask: usize) -> usize {
    let h = (cell[0] as u32).wrapping_mul(73_856_093)
        ^ (cell[1] as u32).wrapping_mul(19_349_663)
        ^ (cell[2] as u32).wrapping_mul(83_492_791);
    h as usize & mask
}

fn cell_coordinate(x: f32, cell_size: f32) -> i32 {
    // Saturating: particles flung absurdly far share the outermost cells, they do not overflow.
    (x / cell_size).floor().clamp(i32::MIN as f32, i32::MAX as f32) as i32
}

impl SpatialHash {
    /// A hash for `n` particles and contact distance `distance`.
    pub fn new(n: usize, distance: f32) -> SpatialHash {
        let table = (2 * n).next_power_of_two().max(16);
        SpatialHash {
            cell_size: 2.0 * distance,
            mask: table - 1,
            cell: vec![[0; 3]; n],
            bucket: vec![0; n],
            bucket_start: vec![0; table + 1],
            sorted: vec![0; n],
        }
    }

    /// Re-bins the particles at positions `x`.
    pub fn rebuild(&mut self, x: [&[f32]; 3]) {
        let (cell_size, mask) = (self.cell_size, self.mask);
        (&mut self.cell, &mut self.bucket).into_par_iter().enumerate().for_each(|(i, (cell, bucket))| {
            *cell = [0, 1, 2].map(|axis| cell_coordinate(x[axis][i], cell_size));
            *bucket = bucket_of(*cell, mask) as u32;
        });
        self.bucket_start.fill(0);
        for &bucket in &self.bucket {
            self.bucket_start[bucket as usize + 1] += 1;
        }
        for b in 0..self.mask + 1 {
            self.bucket_start[b + 1] += self.bucket_start[b];
        }
        // Scatter in particle order: buckets list their particles in increasing index.
        for (i, &bucket) in self.bucket.iter().enumerate() {
            let slot = &mut self.bucket_start[bucket as usize];
            self.sorted[*slot as usize] = i as u32;
            *slot += 1;
        }
        // The scatter advanced each start to the next bucket's start: shift back.
        for b in (1..=self.mask + 1).rev() {
            self.bucket_start[b] = self.bucket_start[b - 1];
        }
        self.bucket_start[0] = 0;
    }

    /// Calls `visit(j)` for every particle j that may be within `distance` of point `p` (a
    /// superset; the caller checks the distance), in a fixed order.
    pub fn for_each_candidate(&self, p: [f32; 3], distance: f32, mut visit: impl FnMut(usize)) {
        let lo = [0, 1, 2].map(|axis| cell_coordinate(p[axis] - distance, self.cell_size));
        let hi = [0, 1, 2].map(|axis| cell_coordinate(p[axis] + distance, self.cell_size));
        for cz in lo[2]..=hi[2] {
            for cy in lo[1]..=hi[1] {
                for cx in lo[0]..=hi[0] {
                    let cell = [cx, cy, cz];
                    let bucket = bucket_of(cell, self.mask);
                    let range = self.bucket_start[bucket] as usize..self.bucket_start[bucket + 1] as usize;
                    for &j in &self.sorted[range] {
                        if self.cell[j as usize] == cell {
                            visit(j as usize);
                        }
                    }
                }
            }
        }
    }
}

/// The skin of the contact list as a fraction of the contact distance.
pub const SKIN_FRACTION: f32 = 0.5;

/// Candidate contact pairs, valid while no particle has moved half the skin since the build.
#[derive(Debug, Clone, Default)]
pub struct ContactList {
    distance: f32,
    skin: f32,
    hash: SpatialHash,
    built_at: [Vec<f32>; 3],
    offsets: Vec<u32>,
    candidates: Vec<u32>,
    builds: u64,
}

impl ContactList {
    /// An empty list for `n` particles and contact distance `distance` (built on first use).
    pub fn new(n: usize, distance: f32) -> ContactList {
        let skin = SKIN_FRACTION * distance;
        ContactList {
            distance,
            skin,
            hash: SpatialHash::new(n, distance + skin),
            built_at: [vec![f32::INFINITY; n], vec![f32::INFINITY; n], vec![f32::INFINITY; n]],
            offsets: vec![0; n + 1],
            candidates: Vec::new(),
            builds: 0,
        }
    }

    /// How many times the list has been built.
    pub fn builds(&self) -> u64 {
        self.builds
    }

    /// Rebuilds the list if some particle at `x` has moved more than half the skin since the
    /// last build.
    pub fn update(&mut self, x: [&[f32]; 3]) {
        let limit = 0.25 * self.skin * self.skin;
        let built_at = &self.built_at;
        let stale = (0..x[0].len()).into_par_iter().any(|i| {
            let d2: f32 = (0..3).map(|a| (x[a][i] - built_at[a][i]).powi(2)).sum();
            d2 > limit || d2.is_nan()
        });
        if !stale {
            return;
        }
        self.hash.rebuild(x);
        let reach = self.distance + self.skin;
        let hash = &self.hash;
        let lists: Vec<Vec<u32>> = (0..x[0].len())
            .into_par_iter()
            .map(|i| {
                let p = [x[0][i], x[1][i], x[2][i]];
                let mut near = Vec::new();
                hash.for_each_candidate(p, reach, |j| {
                    let d2: f32 = (0..3).map(|a| (p[a] - x[a][j]).powi(2)).sum();
                    if j != i && d2 < reach * reach {
                        near.push(j as u32);
                    }
                });
                near.sort_unstable();
                near
            })
            .collect();
        self.candidates.clear();
        for (i, near) in lists.iter().enumerate() {
            self.candidates.extend_from_slice(near);
            self.offsets[i + 1] = self.candidates.len() as u32;
        }
        for (axis, built_at) in self.built_at.iter_mut().enumerate() {
            built_at.copy_from_slice(x[axis]);
        }
        self.builds += 1;
    }

    /// Particle i's candidates, in increasing index.
    pub fn candidates(&self, i: usize) -> &[u32] {
        &self.candidates[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }
}

/// The distance below which two unbonded particles repel: the contact distance d_c, or their
/// rest distance |X_i - X_j| (`rest_distance2` is its square) where that is shorter. Particles
/// that sat closer than d_c at rest (the small tets of a shell, for one) were bonded there; when
/// that bond breaks, eq. 6 with the full d_c would push them apart from where they stand and
/// make energy from nothing. Pairs that were never bonded sit farther than the horizon, beyond
/// d_c, and feel eq. 6 unchanged.
pub fn contact_reach(distance: f32, rest_distance2: f32) -> f32 {
    distance.min(rest_distance2.sqrt())
}

/// The paper's eq. 6: the force on i from j at offset `d = x_i - x_j` of length `r`, pushing
/// them apart when r < distance: K_c (distance - r)^2 d / r.
pub fn repulsion(stiffness: f32, distance: f32, d: [f32; 3], r: f32) -> [f32; 3] {
    let gap = distance - r;
    let scale = stiffness * gap * gap / r;
    d.map(|c| c * scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidates_include_every_close_particle() {
        let mut state = 11u64;
        let mut next = || {
            state = shatter_core::random::splitmix64(state);
            (state >> 40) as f32 / (1u32 << 24) as f32
        };
        let n = 2000;
        let x: Vec<[f32; 3]> = (0..n).map(|_| [next(), next(), next() * 0.1]).collect();
        let axes: [Vec<f32>; 3] = [0, 1, 2].map(|a| x.iter().map(|p| p[a]).collect());
        let distance = 0.03;
        let mut hash = SpatialHash::new(n, distance);
        hash.rebuild([&axes[0], &axes[1], &axes[2]]);
        for i in (0..n).step_by(7) {
            let mut found = Vec::new();
            hash.for_each_candidate(x[i], distance, |j| found.push(j));
            for j in 0..n {
                let r2: f32 = (0..3).map(|a| (x[i][a] - x[j][a]).powi(2)).sum();
                if r2 < distance * distance {
                    assert!(found.contains(&j), "{j} missing near {i}");
                }
            }
            let mut sorted = found.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), found.len(), "no duplicates");
        }
    }

    #[test]
    fn repulsion_follows_eq_6() {
        let f = repulsion(1e8, 0.5e-3, [0.3e-3, 0.0, 0.0], 0.3e-3);
        assert!((f[0] - 1e8 * 0.2e-3 * 0.2e-3).abs() < 1e-3);
        assert_eq!(f[1], 0.0);
    }
}
