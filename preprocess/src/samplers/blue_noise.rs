//! Blue-noise points inside a closed mesh with a guaranteed minimum distance: maximal Poisson disk
//! sampling.
//!
//! # Algorithm
//!
//! Bridson's algorithm ("Fast Poisson disk sampling in arbitrary dimensions", 2007) on a
//! background grid of cubes of side `r / sqrt(3)` (`r` the minimum distance), so a cube's
//! diagonal is `r` and every point closer than `r` to a candidate lies within two cubes of it
//! along each axis. Grid cubes are classified once: cubes that a mesh triangle may meet (by a
//! conservative separating axis test) are *surface* cubes; the others form connected regions that lie wholly
//! inside or wholly outside the mesh, each decided by one exact [`MeshQuery::contains`]. A
//! candidate is rejected at once in an outside cube, then checked against the points in the
//! 5 x 5 x 5 cubes around it, and only in a surface cube tested exactly against the mesh.
//!
//! The cubes are scanned in order. A cube not yet covered by a disk (some point within `r` of all
//! its corners) is split into octants twice over; each uncovered box of the finest split gets a
//! few uniform darts, and a dart that lands is grown by Bridson's algorithm (candidates uniform in
//! the shell between `r` and `2r` around a random active point, 30 tries before the point
//! retires) until no point is active. In surface cubes, a box that no triangle meets is decided
//! inside or outside by one exact test, so darts are not wasted outside. The
//! scan seeds every connected part of the mesh and fills nearly all the gaps the growth left, so
//! the sample is close to maximal: in a unit cube at `r = 0.03`, no point of a 60^3 lattice is
//! farther than 1.012 `r` from a sample (a maximal sample would give at most `r`).
//!
//! # Guarantees
//!
//! - Every point is strictly inside the mesh by the exact test (a point on the surface is never
//!   kept).
//! - Every two points are at least `r` apart: a candidate is kept only if its floating-point
//!   squared distance to every nearby point is at least `r^2 (1 + 1e-12)`, a margin far larger
//!   than the rounding of the squared distance (a few units in the last place), so the exact
//!   distance is at least `r`.
//! - The same inputs and seed give the same points in the same order (the sampler is
//!   sequential).
//!
//! No relaxation is applied: the points are the raw maximal Poisson disk sample.
//!
//! [`thin`] keeps the same minimum distance among given points, in their order (the tet shell's
//! layers).

use glam::DVec3;
use shatter_core::random::{SplitMix64, splitmix64};

use crate::mesh_query::{MeshQuery, triangle_meets_box};

/// Bridson's tries around an active point before it retires.
const ATTEMPTS: usize = 30;

/// The scan splits an uncovered grid cube into octants this many times over.
const GAP_DEPTH: u32 = 2;

/// Darts thrown into each uncovered box of the finest split.
const DARTS_PER_BOX: usize = 4;

/// Relative margin on the squared minimum distance that covers the rounding of a squared
/// distance computed in floating point.
const DISTANCE_MARGIN: f64 = 1e-12;

/// Points per unit volume times `r^3` for this sampler away from the surface, measured in a unit
/// cube at r = 0.03 (0.69; random sequential addition jams at a packing fraction near 0.38, that
/// is 0.73 / r^3). Near the surface the density is higher, which [`poisson_disk_with_count`]
/// corrects for.
pub const POISSON_DENSITY: f64 = 0.70;

/// The most grid cubes the sampler will allocate.
pub const MAX_GRID_CUBES: usize = 1 << 28;

/// The most cells the thinning grid of [`thin`] allocates (larger grids use larger cells).
const MAX_THINNING_CELLS: f64 = (1u64 << 24) as f64;

const NONE: u32 = u32::MAX;

/// Mixed into the seed, so this sampler's stream differs from other users of the same seed.
const SEED_SALT: u64 = 0xB10E_5A3D_1D15_C000;

/// What a grid cube holds of the mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Region {
    Unknown,
    /// A triangle may meet its box: candidates need the exact test.
    Surface,
    Inside,
    Outside,
}

/// Maximal Poisson disk samples strictly inside the mesh of `query`, within the closed box
/// `bounds` = (min, max), every two at least `min_distance` apart. Deterministic for a `seed`.
/// See the [module documentation](self).
///
/// # Panics
///
/// If `min_distance` is not positive and finite, or the background grid would need more than
/// [`MAX_GRID_CUBES`] cubes.
pub fn poisson_disk(query: &MeshQuery, bounds: (DVec3, DVec3), min_distance: f64, seed: u64) -> Vec<DVec3> {
    assert!(min_distance > 0.0 && min_distance.is_finite(), "the minimum distance must be positive: {min_distance}");
    let mut sampler = Sampler::new(query, bounds, min_distance, seed);
    let mut near = Vec::new();
    for linear in 0..sampler.grid.cube_count() {
        let region = sampler.region[linear];
        if region != Region::Outside {
            let cube = sampler.grid.cube(linear);
            sampler.points_near(cube, &mut near);
            sampler.fill_gaps(cube, sampler.grid.bounds(cube), 0, region == Region::Inside, &mut near);
        }
    }
    sampler.points
}

/// The minimum distance at which [`poisson_disk`] puts about `count` points into `volume`,
/// from the density of its packings ([`POISSON_DENSITY`]), ignoring the surface.
pub fn min_distance_for_count(volume: f64, count: usize) -> f64 {
    (POISSON_DENSITY * volume / count.max(1) as f64).cbrt()
}

/// Samples about `count` points into the mesh of `query` (which encloses `volume`): a first
/// sample at [`min_distance_for_count`], then up to two more with the distance corrected by the
/// cube root of the count ratio, until the count is within 1% of `count`. Returns the minimum
/// distance used and the points.
pub fn poisson_disk_with_count(
    query: &MeshQuery,
    bounds: (DVec3, DVec3),
    volume: f64,
    count: usize,
    seed: u64,
) -> (f64, Vec<DVec3>) {
    let mut min_distance = min_distance_for_count(volume, count);
    let mut points = poisson_disk(query, bounds, min_distance, seed);
    for _ in 0..2 {
        let ratio = points.len().max(1) as f64 / count.max(1) as f64;
        if (ratio - 1.0).abs() <= 0.01 {
            break;
        }
        min_distance *= ratio.cbrt();
        points = poisson_disk(query, bounds, min_distance, seed);
    }
    (min_distance, points)
}

/// The background grid: cubes of side `side` from `origin`.
#[derive(Debug, Clone, Copy)]
struct Grid {
    origin: DVec3,
    side: f64,
    dims: [usize; 3],
}

impl Grid {
    fn new((lo, hi): (DVec3, DVec3), side: f64) -> Grid {
        let dims = ((hi - lo) / side).ceil().max(DVec3::ONE).to_array().map(|n| n as usize);
        let cubes = dims.iter().try_fold(1usize, |total, &n| total.checked_mul(n));
        assert!(
            cubes.is_some_and(|n| n <= MAX_GRID_CUBES),
            "the Poisson disk grid would have {dims:?} cubes: the minimum distance is too small for these bounds"
        );
        Grid { origin: lo, side, dims }
    }

    fn cube_count(&self) -> usize {
        self.dims.iter().product()
    }

    /// The cube index along each axis of coordinate `p` (clamped to the grid).
    fn cube_of(&self, p: DVec3) -> [usize; 3] {
        let raw = ((p - self.origin) / self.side).floor().to_array();
        std::array::from_fn(|k| (raw[k].max(0.0) as usize).min(self.dims[k] - 1))
    }

    fn linear(&self, cube: [usize; 3]) -> usize {
        cube[0] + self.dims[0] * (cube[1] + self.dims[1] * cube[2])
    }

    fn cube(&self, linear: usize) -> [usize; 3] {
        let [nx, ny, _] = self.dims;
        [linear % nx, (linear / nx) % ny, linear / (nx * ny)]
    }

    /// The closed box of a cube.
    fn bounds(&self, cube: [usize; 3]) -> (DVec3, DVec3) {
        let lo = self.origin + DVec3::from_array(cube.map(|k| k as f64)) * self.side;
        (lo, lo + DVec3::splat(self.side))
    }

    /// The cubes within `reach` cubes of `cube` along every axis, as index ranges per axis.
    fn around(&self, cube: [usize; 3], reach: usize) -> [std::ops::RangeInclusive<usize>; 3] {
        std::array::from_fn(|k| cube[k].saturating_sub(reach)..=(cube[k] + reach).min(self.dims[k] - 1))
    }

    /// Face neighbours of a cube.
    fn neighbours(&self, linear: usize) -> impl Iterator<Item = usize> + '_ {
        let cube = self.cube(linear);
        (0..3).flat_map(move |axis| {
            let below = (cube[axis] > 0).then(|| {
                let mut c = cube;
                c[axis] -= 1;
                self.linear(c)
            });
            let above = (cube[axis] + 1 < self.dims[axis]).then(|| {
                let mut c = cube;
                c[axis] += 1;
                self.linear(c)
            });
            below.into_iter().chain(above)
        })
    }
}

/// The state of one sampling run.
struct Sampler<'a> {
    query: &'a MeshQuery,
    bounds: (DVec3, DVec3),
    grid: Grid,
    region: Vec<Region>,
    /// First point in each cube, then `next` along a list (there is at most one in exact
    /// arithmetic; the lists make rounding harmless).
    head: Vec<u32>,
    next: Vec<u32>,
    points: Vec<DVec3>,
    active: Vec<u32>,
    min_distance: f64,
    /// Squared distance a candidate must keep from every point, margin included.
    keep_out_sq: f64,
    rng: SplitMix64,
}

impl<'a> Sampler<'a> {
    fn new(query: &'a MeshQuery, bounds: (DVec3, DVec3), min_distance: f64, seed: u64) -> Sampler<'a> {
        let grid = Grid::new(bounds, min_distance / 3f64.sqrt());
        let region = classify_cubes(query, &grid);
        Sampler {
            query,
            bounds,
            grid,
            head: vec![NONE; region.len()],
            region,
            next: Vec::new(),
            points: Vec::new(),
            active: Vec::new(),
            min_distance,
            keep_out_sq: min_distance * min_distance * (1.0 + DISTANCE_MARGIN),
            rng: SplitMix64::new(splitmix64(seed ^ SEED_SALT)),
        }
    }

    /// Adds `p` if it is inside the bounds and the mesh and far enough from every point.
    fn try_add(&mut self, p: DVec3) -> bool {
        self.try_add_known(p, false)
    }

    /// [`Sampler::try_add`] for a point known to be inside the mesh when `inside` is set.
    fn try_add_known(&mut self, p: DVec3, inside: bool) -> bool {
        if !(p.cmpge(self.bounds.0).all() && p.cmple(self.bounds.1).all()) {
            return false;
        }
        let cube = self.grid.cube_of(p);
        let linear = self.grid.linear(cube);
        let region = self.region[linear];
        if region == Region::Outside || self.conflicts(p, cube) {
            return false;
        }
        if region == Region::Surface && !inside && !self.query.contains(p) {
            return false;
        }
        let index = self.points.len() as u32;
        self.points.push(p);
        self.next.push(self.head[linear]);
        self.head[linear] = index;
        self.active.push(index);
        true
    }

    /// Is some point closer to `p` than the minimum distance (with the margin)?
    fn conflicts(&self, p: DVec3, cube: [usize; 3]) -> bool {
        self.any_near(cube, |q| q.distance_squared(p) < self.keep_out_sq)
    }

    /// Does some point within two cubes of `cube` satisfy `test`? (Stops at the first.)
    fn any_near(&self, cube: [usize; 3], mut test: impl FnMut(DVec3) -> bool) -> bool {
        let [xs, ys, zs] = self.grid.around(cube, 2);
        for z in zs {
            for y in ys.clone() {
                for x in xs.clone() {
                    let mut point = self.head[self.grid.linear([x, y, z])];
                    while point != NONE {
                        if test(self.points[point as usize]) {
                            return true;
                        }
                        point = self.next[point as usize];
                    }
                }
            }
        }
        false
    }

    /// The points within two cubes of `cube`, into `near`.
    fn points_near(&self, cube: [usize; 3], near: &mut Vec<DVec3>) {
        near.clear();
        self.any_near(cube, |q| {
            near.push(q);
            false
        });
    }

    /// Is every point of the box `[lo, hi]` within the minimum distance of one of the points
    /// `near`, so that no dart can land in it?
    fn covered(&self, near: &[DVec3], (lo, hi): (DVec3, DVec3)) -> bool {
        let reach_sq = self.min_distance * self.min_distance;
        near.iter().any(|q| (*q - lo).abs().max((hi - *q).abs()).length_squared() <= reach_sq)
    }

    /// Fills what is uncovered of the box `[lo, hi]` (inside grid cube `cube`): split into
    /// octants down to [`GAP_DEPTH`], then [`DARTS_PER_BOX`] uniform darts into each uncovered
    /// box; a dart that lands is grown by Bridson's algorithm. `inside` says the box is known to
    /// lie inside the mesh; a box that no triangle meets is decided by one exact
    /// test of its centre (and dropped when outside). `near` holds the points within two cubes of
    /// `cube` (refreshed whenever points are added).
    fn fill_gaps(
        &mut self,
        cube: [usize; 3],
        (lo, hi): (DVec3, DVec3),
        depth: u32,
        mut inside: bool,
        near: &mut Vec<DVec3>,
    ) {
        if self.covered(near, (lo, hi)) {
            return;
        }
        if !inside && !self.query.touches_box(lo, hi) {
            // No surface in the box: one test decides all of it.
            if !self.query.contains((lo + hi) * 0.5) {
                return;
            }
            inside = true;
        }
        if depth < GAP_DEPTH {
            let half = (hi - lo) * 0.5;
            for octant in 0..8 {
                let corner =
                    lo + half * DVec3::new((octant & 1) as f64, ((octant >> 1) & 1) as f64, (octant >> 2) as f64);
                self.fill_gaps(cube, (corner, corner + half), depth + 1, inside, near);
            }
            return;
        }
        let landed = (0..DARTS_PER_BOX).any(|_| {
            let u = DVec3::new(self.rng.next_f64(), self.rng.next_f64(), self.rng.next_f64());
            self.try_add_known(lo + (hi - lo) * u, inside)
        });
        if landed {
            self.grow();
            self.points_near(cube, near);
        }
    }

    /// Bridson's growth until no point is active.
    fn grow(&mut self) {
        while !self.active.is_empty() {
            let slot = (self.rng.next_u64() % self.active.len() as u64) as usize;
            let centre = self.points[self.active[slot] as usize];
            let added = (0..ATTEMPTS).any(|_| {
                let candidate = centre + self.shell_offset();
                self.try_add(candidate)
            });
            if !added {
                self.active.swap_remove(slot);
            }
        }
    }

    /// A uniform random offset in the shell between the minimum distance and twice it.
    fn shell_offset(&mut self) -> DVec3 {
        let z = 2.0 * self.rng.next_f64() - 1.0;
        let phi = std::f64::consts::TAU * self.rng.next_f64();
        let radius = self.min_distance * (1.0 + 7.0 * self.rng.next_f64()).cbrt();
        let ring = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(ring * phi.cos(), ring * phi.sin(), z) * radius
    }
}

/// Classifies every grid cube: surface cubes (that a triangle may meet, by the conservative
/// [`triangle_meets_box`]), and connected regions of the rest, each inside or outside as one
/// exact test of its first cube's centre says.
fn classify_cubes(query: &MeshQuery, grid: &Grid) -> Vec<Region> {
    let mut region = vec![Region::Unknown; grid.cube_count()];
    // Rounding of the cube indices is covered by a pad far below a cube's side.
    let pad = DVec3::splat(grid.side * 1e-9);
    for (_, corners) in query.triangles() {
        let lo = corners[0].min(corners[1]).min(corners[2]) - pad;
        let hi = corners[0].max(corners[1]).max(corners[2]) + pad;
        let end = grid.origin + DVec3::from_array(grid.dims.map(|n| n as f64)) * grid.side;
        if lo.cmpgt(end).any() || hi.cmplt(grid.origin).any() {
            continue;
        }
        let (first, last) = (grid.cube_of(lo), grid.cube_of(hi));
        for z in first[2]..=last[2] {
            for y in first[1]..=last[1] {
                for x in first[0]..=last[0] {
                    let (cube_lo, cube_hi) = grid.bounds([x, y, z]);
                    if triangle_meets_box(&corners, cube_lo - pad, cube_hi + pad) {
                        region[grid.linear([x, y, z])] = Region::Surface;
                    }
                }
            }
        }
    }
    let mut queue = Vec::new();
    for start in 0..region.len() {
        if region[start] != Region::Unknown {
            continue;
        }
        let (lo, hi) = grid.bounds(grid.cube(start));
        let fill = if query.contains((lo + hi) * 0.5) { Region::Inside } else { Region::Outside };
        region[start] = fill;
        queue.push(start);
        while let Some(cube) = queue.pop() {
            for neighbour in grid.neighbours(cube) {
                if region[neighbour] == Region::Unknown {
                    region[neighbour] = fill;
                    queue.push(neighbour);
                }
            }
        }
    }
    region
}

/// Poisson disk thinning: keeps each point (in the given order) that is at least `r` from every
/// point kept before it. `None` when the grid would be too large.
pub fn thin(points: &[DVec3], r: f64) -> Option<Vec<DVec3>> {
    if points.is_empty() {
        return Some(Vec::new());
    }
    let (lo, hi) = points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let extent = (hi - lo).max(DVec3::splat(r));
    let side = r.max((extent.x * extent.y * extent.z / MAX_THINNING_CELLS).cbrt());
    let dims = (extent / side).floor().to_array().map(|n| n as usize + 1);
    let cells = dims.iter().try_fold(1usize, |total, &n| total.checked_mul(n))?;
    if cells > 2 * MAX_THINNING_CELLS as usize {
        return None;
    }
    let cell_of = |p: DVec3| -> [usize; 3] {
        let q = ((p - lo) / side).floor().to_array();
        std::array::from_fn(|k| (q[k].max(0.0) as usize).min(dims[k] - 1))
    };
    let linear = |c: [usize; 3]| c[0] + dims[0] * (c[1] + dims[1] * c[2]);
    let mut head = vec![NONE; cells];
    let mut next: Vec<u32> = Vec::new();
    let mut kept: Vec<DVec3> = Vec::new();
    let keep_out_sq = r * r * (1.0 + DISTANCE_MARGIN);
    for &p in points {
        let cell = cell_of(p);
        let range = |k: usize| cell[k].saturating_sub(1)..=(cell[k] + 1).min(dims[k] - 1);
        let mut conflict = false;
        'search: for z in range(2) {
            for y in range(1) {
                for x in range(0) {
                    let mut q = head[linear([x, y, z])];
                    while q != NONE {
                        if kept[q as usize].distance_squared(p) < keep_out_sq {
                            conflict = true;
                            break 'search;
                        }
                        q = next[q as usize];
                    }
                }
            }
        }
        if !conflict {
            let index = linear(cell);
            next.push(head[index]);
            head[index] = kept.len() as u32;
            kept.push(p);
        }
    }
    Some(kept)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_meshes::cube;
    use shatter_geometry::PointKdTree;
    use shatter_geometry::mesh::TriangleMesh;

    /// The smallest distance between two points (brute force over k-d tree neighbours).
    fn min_pair_distance(points: &[DVec3], within: f64) -> f64 {
        let tree = PointKdTree::new(points);
        let mut found = Vec::new();
        let mut best = f64::INFINITY;
        for (i, p) in points.iter().enumerate() {
            found.clear();
            tree.within(*p, within * within, &mut found);
            for &j in &found {
                if j as usize != i {
                    best = best.min(p.distance(points[j as usize]));
                }
            }
        }
        best
    }

    #[test]
    fn a_cube_is_filled_densely_and_never_too_close() {
        let mesh = cube(1.0);
        let query = MeshQuery::new(&mesh);
        let r = 0.1;
        let points = poisson_disk(&query, mesh.bounds(), r, 7);
        assert!(points.iter().all(|p| p.cmpgt(DVec3::ZERO).all() && p.cmplt(DVec3::ONE).all()));
        assert!(min_pair_distance(&points, 2.0 * r) >= r);
        // Maximal: every point of the cube is within r of a sample (checked on a fine lattice).
        let tree = PointKdTree::new(&points);
        let mut found = Vec::new();
        let steps = 40;
        for i in 0..steps * steps * steps {
            let p = (DVec3::new((i % steps) as f64, ((i / steps) % steps) as f64, (i / steps / steps) as f64) + 0.5)
                / steps as f64;
            found.clear();
            tree.within(p, r * r * 1.05 * 1.05, &mut found);
            assert!(!found.is_empty(), "{p} is far from every sample");
        }
        let density = points.len() as f64 * r * r * r;
        assert!(density > 0.65 && density < 0.85, "density {density}");
    }

    #[test]
    fn sampling_is_deterministic_and_seeded() {
        let mesh = cube(1.0);
        let query = MeshQuery::new(&mesh);
        let a = poisson_disk(&query, mesh.bounds(), 0.15, 1);
        assert_eq!(a, poisson_disk(&query, mesh.bounds(), 0.15, 1));
        assert_ne!(a, poisson_disk(&query, mesh.bounds(), 0.15, 2));
    }

    #[test]
    fn separate_bodies_are_all_seeded() {
        let mut mesh = cube(1.0);
        let mut far = cube(0.5);
        far.map_positions(|p| p + DVec3::new(3.0, 0.0, 0.0));
        let offset = mesh.positions.len() as u32;
        mesh.positions.extend(far.positions);
        mesh.triangles.extend(far.triangles.iter().map(|t| t.map(|v| v + offset)));
        let query = MeshQuery::new(&mesh);
        let points = poisson_disk(&query, mesh.bounds(), 0.1, 3);
        assert!(points.iter().any(|p| p.x > 2.0));
        assert!(points.iter().all(|p| query.contains(*p)));
        assert!(points.iter().all(|p| p.x < 1.0 || (p.x > 3.0 && p.x < 3.5)));
    }

    #[test]
    fn a_target_count_is_met_within_a_few_percent() {
        let mesh: TriangleMesh = cube(1.0);
        let query = MeshQuery::new(&mesh);
        let (r, points) = poisson_disk_with_count(&query, mesh.bounds(), 1.0, 2000, 5);
        let error = (points.len() as f64 / 2000.0 - 1.0).abs();
        assert!(error < 0.03, "{} points at r = {r}", points.len());
        assert!(min_pair_distance(&points, 2.0 * r) >= r);
    }

    #[test]
    fn thinning_keeps_the_first_of_close_points() {
        let points = [DVec3::ZERO, DVec3::new(0.5, 0.0, 0.0), DVec3::new(1.0, 0.5, 0.0), DVec3::new(1.0, 1.0, 1.0)];
        assert_eq!(thin(&points, 1.0).expect("small"), [points[0], points[2], points[3]]);
    }
}
