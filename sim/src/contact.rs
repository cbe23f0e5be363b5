//! Contact between particles that are not bonded, by the paper's quadratic repulsion (eq. 6).
//!
//! Candidate pairs come from Verlet lists: every particle within the contact distance plus a
//! skin, found with a spatial hash (binned by a stable counting sort). Each particle's list is
//! searched again only when that particle has moved more than a quarter of the skin
//! ([`ContactList`] says why that is enough). Each particle's candidates are sorted by index,
//! so forces are summed in the same order however often the lists were searched (a resumed run
//! matches an uninterrupted one bit for bit). In intact material the lists are empty: particles
//! sit a lattice spacing apart, farther than distance plus skin.

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
        // About a bucket for every two particles: a cell holds several particles, so buckets
        // still rarely share cells, and a rebuild's serial passes over the table (counts,
        // prefix sums) are a quarter of a table of 2n buckets. The bucket count changes nothing
        // a search finds, nor its order: a bucket's particles are filtered by cell.
        let table = (n / 2).next_power_of_two().max(16);
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

/// The bond of a pair that has none.
pub const NO_BOND: u64 = u64::MAX;

/// Which pairs are bonded: contact pushes only pairs that are not joined by an intact bond.
pub trait BondLookup: Sync {
    /// The id of the bond joining particles i and j, or [`NO_BOND`].
    fn bond_between(&self, i: usize, j: usize) -> u64;
    /// True when `bond` (an id from [`BondLookup::bond_between`], or [`NO_BOND`]) is a bond that
    /// has not broken.
    fn intact(&self, bond: u64) -> bool;
}

/// One of a particle's contact candidates: the other particle, and the bond joining the two
/// ([`NO_BOND`] for none), looked up once when the pair is listed rather than in every step's
/// collision pass (a search of the particle's bonds, which a tet shell's close pairs paid for in
/// a fifth of each step).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Candidate {
    /// The other particle.
    pub particle: u32,
    /// The bond joining the pair, or [`NO_BOND`].
    pub bond: u64,
}

/// Candidate contact pairs: each particle's list holds every particle within the contact
/// distance, and more.
///
/// Each particle's list is rebuilt on its own, when the particle has moved more than a quarter
/// of the skin since its last rebuild; a rebuild also enters the particle in (or takes it out
/// of) the lists of the particles it finds (or no longer finds), so a pair is listed in both
/// lists or in neither. Why that suffices: take a pair and the later of its two last rebuilds,
/// at time t. Then the pair is listed if and only if it was closer than the contact distance plus
/// the skin at t. Since t, the particle rebuilt at t has moved at most a quarter of the skin, and
/// the other at most half (a quarter since its own rebuild, and a quarter from then to t, else
/// it would have been rebuilt at t too). A pair closer than the contact distance now was
/// therefore closer than the distance plus three quarters of the skin at t, and is listed.
///
/// Only the particles that moved are searched again: in a shot where a few fragments fly fast
/// and the rest barely move, a rebuild costs the movers' searches, not every particle's. The
/// spatial hash the searches use is not rebuilt for every search either: a search looks
/// [`HASH_MARGIN`] further than the lists reach, so the hash serves until some particle has
/// moved most of that margin from where it was binned.
///
/// Lists differ from lists built from scratch only in pairs farther apart than the contact
/// distance, which add no force; forces are summed in increasing index, so they come out bit for
/// bit the same however the lists were built (a resumed run, which starts from empty lists,
/// matches an uninterrupted one).
#[derive(Debug, Clone, Default)]
pub struct ContactList {
    distance: f32,
    skin: f32,
    hash: SpatialHash,
    /// Where each particle was when the hash was built (infinite before the first build).
    hashed_at: [Vec<f32>; 3],
    /// Where each particle was when its list was last searched (infinite before).
    built_at: [Vec<f32>; 3],
    lists: Vec<Vec<Candidate>>,
    /// Whether each particle is searched in the current update (all false between updates).
    searched_now: Vec<bool>,
    searches: u64,
    hash_builds: u64,
}

/// How much further than the lists reach (contact distance plus skin) a search looks, as a
/// fraction of that reach. The hash is rebuilt when some particle has moved 80% of the margin
/// since it was binned; the other 20% covers the rounding of distances in f32.
pub const HASH_MARGIN: f32 = 0.5;

/// Particles per work item of the scan for particles due a search.
const SCAN_CHUNK: usize = 4096;

impl ContactList {
    /// An empty list for `n` particles and contact distance `distance` (built on first use).
    pub fn new(n: usize, distance: f32) -> ContactList {
        let skin = SKIN_FRACTION * distance;
        ContactList {
            distance,
            skin,
            hash: SpatialHash::new(n, (1.0 + HASH_MARGIN) * (distance + skin)),
            hashed_at: [vec![f32::INFINITY; n], vec![f32::INFINITY; n], vec![f32::INFINITY; n]],
            built_at: [vec![f32::INFINITY; n], vec![f32::INFINITY; n], vec![f32::INFINITY; n]],
            lists: vec![Vec::new(); n],
            searched_now: vec![false; n],
            searches: 0,
            hash_builds: 0,
        }
    }

    /// How many particle lists have been searched, and how many times the hash was built, over
    /// all updates.
    pub fn work(&self) -> (u64, u64) {
        (self.searches, self.hash_builds)
    }

    /// Searches again the lists of the particles at `x` that have moved more than a quarter of
    /// the skin since their last search (all of them at first); `bonds` names the bond of each
    /// pair listed.
    pub fn update(&mut self, x: [&[f32]; 3], bonds: &impl BondLookup) {
        let n = x[0].len();
        let reach = self.distance + self.skin;
        let limit = (0.25 * self.skin).powi(2);
        let drift_limit = (0.8 * HASH_MARGIN * reach).powi(2);
        let (built_at, hashed_at) = (&self.built_at, &self.hashed_at);
        // One pass in chunks (a parallel pass per particle costs more to share out than to do):
        // the particles due a search, and whether any has drifted from where the hash has it.
        // (A NaN distance counts as moved.)
        let scans: Vec<(Vec<usize>, bool)> = (0..n.div_ceil(SCAN_CHUNK))
            .into_par_iter()
            .map(|chunk| {
                let range = chunk * SCAN_CHUNK..n.min((chunk + 1) * SCAN_CHUNK);
                let mut d2 = [0.0f32; SCAN_CHUNK];
                let d2 = &mut d2[..range.len()];
                squared_moves(x, hashed_at, range.clone(), d2);
                let drifted = d2.iter().fold(false, |any, &d| any | (d > drift_limit) | d.is_nan());
                squared_moves(x, built_at, range.clone(), d2);
                let moved =
                    (range.start..).zip(&*d2).filter(|(_, d)| **d > limit || d.is_nan()).map(|(i, _)| i).collect();
                (moved, drifted)
            })
            .collect();
        let stale_hash = scans.iter().any(|(_, drifted)| *drifted);
        let moved: Vec<usize> = scans.into_iter().flat_map(|(moved, _)| moved).collect();
        if moved.is_empty() {
            return;
        }
        if stale_hash {
            self.hash.rebuild(x);
            for (axis, hashed_at) in self.hashed_at.iter_mut().enumerate() {
                hashed_at.copy_from_slice(x[axis]);
            }
            self.hash_builds += 1;
        }
        let hash = &self.hash;
        let look = (1.0 + HASH_MARGIN) * reach;
        let found: Vec<Vec<Candidate>> = moved
            .par_iter()
            .map(|&i| {
                let p = [x[0][i], x[1][i], x[2][i]];
                let mut near = Vec::new();
                hash.for_each_candidate(p, look, |j| {
                    let d2: f32 = (0..3).map(|a| (p[a] - x[a][j]).powi(2)).sum();
                    if j != i && d2 < reach * reach {
                        near.push(Candidate { particle: j as u32, bond: bonds.bond_between(i, j) });
                    }
                });
                near.sort_unstable_by_key(|candidate| candidate.particle);
                near
            })
            .collect();
        // The others' lists, in a fixed order: a pair of two movers was decided alike from both
        // ends (the same squared distance), and each mover's own list is replaced below.
        for &i in &moved {
            self.searched_now[i] = true;
        }
        let find = |list: &[Candidate], particle: u32| list.binary_search_by_key(&particle, |c| c.particle);
        for (&i, near) in moved.iter().zip(&found) {
            let me = i as u32;
            let old = std::mem::take(&mut self.lists[i]);
            for other in old.iter().filter(|c| !self.searched_now[c.particle as usize]) {
                if find(near, other.particle).is_err() {
                    let list = &mut self.lists[other.particle as usize];
                    if let Ok(at) = find(list, me) {
                        list.remove(at);
                    }
                }
            }
            for other in near.iter().filter(|c| !self.searched_now[c.particle as usize]) {
                let list = &mut self.lists[other.particle as usize];
                if let Err(at) = find(list, me) {
                    list.insert(at, Candidate { particle: me, bond: other.bond });
                }
            }
        }
        for (i, near) in moved.iter().zip(found) {
            self.searched_now[*i] = false;
            self.lists[*i] = near;
            for (built_at, x) in self.built_at.iter_mut().zip(x) {
                built_at[*i] = x[*i];
            }
        }
        self.searches += moved.len() as u64;
    }

    /// Particle i's candidates, in increasing index.
    pub fn candidates(&self, i: usize) -> &[Candidate] {
        &self.lists[i]
    }
}

/// Into `out`, the squared distance of each particle in `range` from `x` to `from`; lane by lane.
fn squared_moves(x: [&[f32]; 3], from: &[Vec<f32>; 3], range: std::ops::Range<usize>, out: &mut [f32]) {
    let [(x0, f0), (x1, f1), (x2, f2)] = [0, 1, 2].map(|a| (&x[a][range.clone()], &from[a][range.clone()]));
    let axes = x0.iter().zip(f0).zip(x1.iter().zip(f1)).zip(x2.iter().zip(f2));
    for (d2, (((a, p), (b, q)), (c, r))) in out.iter_mut().zip(axes) {
        *d2 = (a - p) * (a - p) + (b - q) * (b - q) + (c - r) * (c - r);
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

    /// No pair is bonded.
    struct Unbonded;

    impl BondLookup for Unbonded {
        fn bond_between(&self, _: usize, _: usize) -> u64 {
            NO_BOND
        }

        fn intact(&self, _: u64) -> bool {
            false
        }
    }

    /// Pairs whose indices sum to a multiple of 3 are bonded, with id lo * n + hi.
    struct EveryThirdPair {
        n: usize,
    }

    impl BondLookup for EveryThirdPair {
        fn bond_between(&self, i: usize, j: usize) -> u64 {
            if (i + j).is_multiple_of(3) { (i.min(j) * self.n + i.max(j)) as u64 } else { NO_BOND }
        }

        fn intact(&self, bond: u64) -> bool {
            bond != NO_BOND
        }
    }

    /// Particle i's candidates' particles.
    fn listed(list: &ContactList, i: usize) -> Vec<u32> {
        list.candidates(i).iter().map(|c| c.particle).collect()
    }

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
    fn lists_keep_every_close_pair_while_a_few_particles_fly() {
        let mut state = 5u64;
        let mut next = || {
            state = shatter_core::random::splitmix64(state);
            (state >> 40) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let (n, distance) = (1500, 0.01f32);
        let mut x: [Vec<f32>; 3] = [0, 1, 2].map(|_| (0..n).map(|_| next() * 0.1).collect());
        let mut list = ContactList::new(n, distance);
        let bonds = EveryThirdPair { n };
        for step in 0..300 {
            // One particle in ten jumps about at random, up to 3 mm a step along each axis; the
            // others creep steadily, up to 20 um a step.
            for (a, axis) in x.iter_mut().enumerate() {
                for (i, value) in axis.iter_mut().enumerate() {
                    *value += if i % 10 == 0 { 6e-3 * next() } else { 4e-5 * (((i * 3 + a) % 7) as f32 / 7.0 - 0.5) };
                }
            }
            list.update([&x[0], &x[1], &x[2]], &bonds);
            for i in 0..n {
                let near = listed(&list, i);
                assert!(near.windows(2).all(|pair| pair[0] < pair[1]), "sorted, no repeats");
                for j in 0..n {
                    let r2: f32 = (0..3).map(|a| (x[a][i] - x[a][j]).powi(2)).sum();
                    if j != i && r2 < distance * distance {
                        assert!(near.contains(&(j as u32)), "step {step}: {j} missing near {i}");
                    }
                }
                for candidate in list.candidates(i) {
                    let j = candidate.particle as usize;
                    assert!(listed(&list, j).contains(&(i as u32)), "pairs are listed both ways");
                    assert_eq!(candidate.bond, bonds.bond_between(i, j), "{i}-{j}: the pair's bond");
                }
            }
        }
        // A creeping particle is searched again every few dozen updates, not whenever a
        // jumping one has moved a quarter of the skin.
        let (searches, hash_builds) = list.work();
        assert!(searches < (n * 300 / 5) as u64, "{searches} searches");
        assert!(hash_builds > 1 && hash_builds < 300, "{hash_builds} hash builds");
    }

    #[test]
    fn a_pair_searched_at_different_times_is_not_lost() {
        // The worst case of the argument on `ContactList`: particle 0 moves away, particle 1 is
        // searched (and drops 0, now beyond its reach), then both close in, 0 by twice what it
        // moved away. Under a limit of half the skin instead of a quarter, neither would be
        // searched again and the pair, now within the contact distance, would be lost.
        let (distance, skin) = (0.01f32, SKIN_FRACTION * 0.01);
        let (reach, half) = (distance + skin, 0.5 * skin);
        let mut x = [vec![0.0, reach - half + 2e-4], vec![0.0, 0.0], vec![0.0, 0.0]];
        let mut list = ContactList::new(2, distance);
        list.update([&x[0], &x[1], &x[2]], &Unbonded);
        assert_eq!(listed(&list, 0), [1]);
        x[0][0] = -(half - 1e-4);
        x[1][1] = half + 1e-4;
        list.update([&x[0], &x[1], &x[2]], &Unbonded);
        x[0][0] = half - 1e-4;
        x[0][1] -= half - 1e-4;
        let r = ((x[0][1] - x[0][0]).powi(2) + x[1][1].powi(2)).sqrt();
        assert!(r < distance, "{r}: the pair has come within the contact distance");
        list.update([&x[0], &x[1], &x[2]], &Unbonded);
        assert_eq!((listed(&list, 0), listed(&list, 1)), (vec![1], vec![0]));
    }

    #[test]
    fn repulsion_follows_eq_6() {
        let f = repulsion(1e8, 0.5e-3, [0.3e-3, 0.0, 0.0], 0.3e-3);
        assert!((f[0] - 1e8 * 0.2e-3 * 0.2e-3).abs() < 1e-3);
        assert_eq!(f[1], 0.0);
    }
}
