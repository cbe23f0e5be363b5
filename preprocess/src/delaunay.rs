//! 3D Delaunay tetrahedralization: incremental Bowyer-Watson on exact predicates.
//!
//! [`tetrahedralize`] turns a point set into tetrahedra that tile its convex hull, each with an
//! empty circumsphere (no input point strictly inside it).
//!
//! # Algorithm
//!
//! Points are inserted one at a time into a triangulation that is closed off by *ghost* tets:
//! every convex hull face carries a ghost tet whose fourth vertex is a symbolic vertex at
//! infinity, so no bounding "super" tetrahedron (and no clean-up after one) is needed. To insert a
//! point `p`:
//!
//! 1. **Locate**: walk from the last tet created towards `p`, crossing any face whose plane has
//!    `p` strictly on its far side (a stochastic visibility walk: the first face tried is picked
//!    at random, which guarantees the walk ends). The walk stops in a tet whose closed volume holds
//!    `p`, or in a ghost tet when `p` is strictly outside the hull.
//! 2. **Cavity**: starting there, gather by breadth-first search every tet *in conflict* with
//!    `p`: a real tet whose circumsphere holds `p` strictly inside, or a ghost tet whose hull face
//!    has `p` strictly on its outer side (or, with `p` exactly in the face's plane, strictly inside
//!    the face's circumcircle).
//! 3. **Fill**: delete the cavity and join `p` to each face on its boundary. New tets reuse the
//!    deleted tets' slots; their mutual neighbours are matched through a small hash table keyed by
//!    the boundary edge they share.
//!
//! All geometric decisions use Shewchuk's adaptive exact predicates ([`robust::orient3d`],
//! [`robust::insphere`]), so every decision is exact for finite inputs (coordinates are limited to
//! ±1e30 so nothing overflows; like any floating-point exact predicate they assume that products of
//! coordinate differences do not underflow, which holds unless distinct points are closer than about
//! 1e-60).
//!
//! # Degeneracies
//!
//! Ties are broken by one consistent rule: **a point exactly on a circumsphere (insphere = 0), or
//! exactly in the plane of a hull face and on or outside its circumcircle, is not in conflict.**
//! Under this rule the triangulation stays Delaunay after every insertion (no point strictly inside
//! any circumsphere), the cavity is always star-shaped from `p` and connected, and `p` is strictly
//! on the inner side of every cavity boundary face, so every new tet has non-zero volume. Where
//! five or more points are cospherical the rule picks one of the valid Delaunay triangulations;
//! which one depends on the insertion order, which is itself deterministic, so the same input
//! always gives the same output.
//!
//! Exactly repeated points are found up front (before any geometry) and skipped; see
//! [`Tetrahedralization::duplicates`].
//!
//! # Order
//!
//! Points are inserted in a biased randomized insertion order (BRIO): a deterministic shuffle
//! split into rounds of doubling size, each round sorted along a Z-order (Morton) curve. The
//! random rounds keep the cavities small in expectation; the curve keeps each walk short and the
//! memory traffic local (points are also copied into insertion order for the same reason).

use glam::DVec3;
use robust::{Coord3D, insphere, orient3d};

/// Marks a missing neighbour in [`Tetrahedralization::neighbors`]: the face is on the convex hull.
pub const NO_NEIGHBOR: u32 = u32::MAX;

/// The symbolic vertex at infinity shared by all ghost tets (always at index 3 of a ghost).
const GHOST: u32 = u32::MAX;

/// No tet.
const NO_TET: u32 = u32::MAX;

/// Coordinates larger than this in magnitude could overflow the exact predicates.
const MAX_COORDINATE: f64 = 1e30;

/// Seed of the insertion-order shuffle (any constant: it only has to be fixed).
const BRIO_SEED: u64 = 0x5EED_DE1A_0BA7_0001;

/// Seed of the walk's choice of the first face to try.
const WALK_SEED: u64 = 0x5EED_DE1A_0BA7_0002;

/// BRIO rounds halve in size until one is at most this big.
const FIRST_ROUND_MAX: usize = 64;

/// `FACE[k]`: the positions of the face opposite vertex `k`, ordered so that
/// `(v[FACE[k][0]], v[FACE[k][1]], v[FACE[k][2]], v[k])` is an even permutation of `v`. Seen from
/// outside the tet the face's vertices then turn counterclockwise.
const FACE: [[usize; 3]; 4] = [[1, 3, 2], [0, 2, 3], [0, 3, 1], [0, 1, 2]];

/// A Delaunay tetrahedralization of a point set.
///
/// Every tet `[a, b, c, d]` (indices into the input points) is positively oriented in the sense
/// of [`robust::orient3d`]: `orient3d(a, b, c, d) > 0`, that is `d` lies below the plane through
/// `a`, `b`, `c` when they turn counterclockwise seen from above. Equivalently its volume
/// `(a - d) · ((b - d) × (c - d)) / 6` (see [`tet_volume`]) is positive. This is the orientation
/// [`robust::insphere`] expects, so `insphere(a, b, c, d, e) > 0` means `e` is strictly inside
/// the tet's circumsphere.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Tetrahedralization {
    /// Each tet's four point indices, positively oriented: `robust::orient3d(a, b, c, d) > 0`.
    pub tets: Vec<[u32; 4]>,
    /// For each tet, the tet across the face opposite vertex `k` ([`NO_NEIGHBOR`] on the convex
    /// hull).
    pub neighbors: Vec<[u32; 4]>,
    /// Points skipped because they repeat an earlier point exactly: `[skipped, kept]`, where
    /// `kept` is the lowest index with the same coordinates (`-0.0` equals `0.0`). Sorted by
    /// `skipped`. Skipped points appear in no tet.
    pub duplicates: Vec<[u32; 2]>,
}

/// Why a point set cannot be tetrahedralized.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DelaunayError {
    /// Fewer than four points were given.
    #[error("a tetrahedralization needs at least 4 points, got {count}")]
    TooFewPoints {
        /// How many points were given.
        count: usize,
    },
    /// The distinct points all lie in one plane (this includes collinear points and fewer than
    /// four distinct points), so no tet has volume.
    #[error("all {distinct} distinct points are coplanar: they span no volume")]
    Coplanar {
        /// How many distinct points there are.
        distinct: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("point {index} has a non-finite coordinate: {point}")]
    NonFinite {
        /// The point's index.
        index: usize,
        /// The point.
        point: DVec3,
    },
    /// A coordinate is so large that the exact predicates could overflow.
    #[error("point {index} = {point} has a coordinate beyond ±1e30, where the exact predicates could overflow")]
    OutOfRange {
        /// The point's index.
        index: usize,
        /// The point.
        point: DVec3,
    },
    /// More points than 32-bit indices can number.
    #[error("{count} points: at most {max} are supported")]
    TooManyPoints {
        /// How many points were given.
        count: usize,
        /// The most supported.
        max: usize,
    },
}

/// The volume of a tet of [`Tetrahedralization::tets`]: `(a - d) · ((b - d) × (c - d)) / 6`.
///
/// Computed by [`robust::orient3d`], whose sign is exact, so it is positive for every tet of a
/// [`Tetrahedralization`], slivers included (the naive floating-point formula can round a sliver's
/// volume to zero or below).
pub fn tet_volume(points: &[DVec3], tet: [u32; 4]) -> f64 {
    let [a, b, c, d] = tet.map(|i| points[i as usize]);
    orient(a, b, c, d) / 6.0
}

/// Tetrahedralizes `points`: the Delaunay tets tiling their convex hull, with face adjacency.
///
/// Exactly repeated points are skipped and listed in [`Tetrahedralization::duplicates`]; every
/// other point is a vertex of at least one tet. Deterministic: the same input always gives the
/// same output. See the [module documentation](self) for the algorithm and the tie rule.
pub fn tetrahedralize(points: &[DVec3]) -> Result<Tetrahedralization, DelaunayError> {
    validate(points)?;
    let (unique, duplicates) = split_duplicates(points);
    let order = insertion_order(points, unique);
    let ordered: Vec<DVec3> = order.iter().map(|&i| points[i as usize]).collect();
    let simplex = first_simplex(&ordered).ok_or(DelaunayError::Coplanar { distinct: ordered.len() })?;

    let mut builder = Builder::new(&ordered, simplex);
    let mut duplicates = duplicates;
    for p in 0..ordered.len() as u32 {
        if simplex.contains(&p) {
            continue;
        }
        if let Some(existing) = builder.insert(p) {
            // Unreachable after `split_duplicates`, kept as a safety net.
            duplicates.push([order[p as usize], order[existing as usize]]);
        }
    }
    duplicates.sort_unstable();
    let (tets, neighbors) = builder.finish(&order);
    Ok(Tetrahedralization { tets, neighbors, duplicates })
}

/// Checks the count and the coordinates.
fn validate(points: &[DVec3]) -> Result<(), DelaunayError> {
    if points.len() < 4 {
        return Err(DelaunayError::TooFewPoints { count: points.len() });
    }
    // u32::MAX marks "no tet" and the ghost vertex, so the last valid index is u32::MAX - 1.
    let max = u32::MAX as usize - 1;
    if points.len() > max {
        return Err(DelaunayError::TooManyPoints { count: points.len(), max });
    }
    for (index, &point) in points.iter().enumerate() {
        if !point.is_finite() {
            return Err(DelaunayError::NonFinite { index, point });
        }
        if point.abs().max_element() > MAX_COORDINATE {
            return Err(DelaunayError::OutOfRange { index, point });
        }
    }
    Ok(())
}

/// Splits the indices into the first of each group of equal points (ascending) and the
/// `[skipped, kept]` pairs for the others.
fn split_duplicates(points: &[DVec3]) -> (Vec<u32>, Vec<[u32; 2]>) {
    // `+ 0.0` turns -0.0 into 0.0, so equal coordinates compare equal under total_cmp.
    let key = |i: u32| (points[i as usize] + DVec3::ZERO).to_array();
    let mut sorted: Vec<u32> = (0..points.len() as u32).collect();
    sorted.sort_unstable_by(|&i, &j| {
        let (a, b) = (key(i), key(j));
        a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])).then(a[2].total_cmp(&b[2])).then(i.cmp(&j))
    });
    let mut unique = Vec::with_capacity(points.len());
    let mut duplicates = Vec::new();
    let mut kept = NO_TET;
    for &i in &sorted {
        if kept != NO_TET && points[i as usize] == points[kept as usize] {
            duplicates.push([i, kept]);
        } else {
            kept = i;
            unique.push(i);
        }
    }
    unique.sort_unstable();
    (unique, duplicates)
}

/// The biased randomized insertion order: shuffled, split into rounds of doubling size, each
/// round sorted along a Morton curve.
fn insertion_order(points: &[DVec3], mut ids: Vec<u32>) -> Vec<u32> {
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
struct MortonFrame {
    low: DVec3,
    scale: f64,
}

impl MortonFrame {
    const CELLS: f64 = ((1u32 << 21) - 1) as f64;

    fn new(points: impl Iterator<Item = DVec3>) -> MortonFrame {
        let (low, high) = points.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)));
        let extent = (high - low).max_element();
        let scale = if extent > 0.0 { Self::CELLS / extent } else { 0.0 };
        MortonFrame { low, scale }
    }

    fn code(&self, p: DVec3) -> u64 {
        let cell = ((p - self.low) * self.scale).clamp(DVec3::ZERO, DVec3::splat(Self::CELLS));
        spread_bits(cell.x as u64) | (spread_bits(cell.y as u64) << 1) | (spread_bits(cell.z as u64) << 2)
    }
}

/// Spreads the low 21 bits of `v` so that bit `i` lands on bit `3 i`.
fn spread_bits(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}

/// The first four affinely independent points, in order (indices into `points`), or `None` when
/// all points are coplanar.
fn first_simplex(points: &[DVec3]) -> Option<[u32; 4]> {
    let a = 0;
    let b = (1..points.len()).find(|&i| points[i] != points[a])?;
    let c = (b + 1..points.len()).find(|&i| !collinear(points[a], points[b], points[i]))?;
    let d = (c + 1..points.len()).find(|&i| orient(points[a], points[b], points[c], points[i]) != 0.0)?;
    Some([a, b, c, d].map(|i| i as u32))
}

/// Exactly: do `a`, `b`, `c` lie on one line? (All three axis-plane projections are collinear.)
fn collinear(a: DVec3, b: DVec3, c: DVec3) -> bool {
    let projected = |p: DVec3, x: usize, y: usize| robust::Coord { x: p[x], y: p[y] };
    [(0, 1), (1, 2), (2, 0)]
        .iter()
        .all(|&(x, y)| robust::orient2d(projected(a, x, y), projected(b, x, y), projected(c, x, y)) == 0.0)
}

fn coord(p: DVec3) -> Coord3D<f64> {
    Coord3D { x: p.x, y: p.y, z: p.z }
}

/// [`robust::orient3d`] on vectors.
fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    orient3d(coord(a), coord(b), coord(c), coord(d))
}

/// A tet under construction: its vertices (a ghost has [`GHOST`] at index 3) and the tets across
/// the faces opposite them.
#[derive(Debug, Clone, Copy)]
struct Tet {
    vertices: [u32; 4],
    neighbors: [u32; 4],
}

impl Tet {
    fn is_ghost(&self) -> bool {
        self.vertices[3] == GHOST
    }
}

/// A face on the boundary of the cavity, recorded before the cavity is deleted.
#[derive(Debug, Clone, Copy)]
struct BoundaryFace {
    /// The cavity tet's vertices with the new point in place of the vertex opposite the face:
    /// the new tet, already positively oriented.
    vertices: [u32; 4],
    /// The position of the new point in `vertices` (the face is opposite it).
    apex: usize,
    /// The tet outside the cavity across the face.
    outside: u32,
    /// The face's index in `outside`.
    outside_face: usize,
}

/// The incremental triangulation and the buffers reused by every insertion.
struct Builder<'a> {
    /// The points in insertion order.
    points: &'a [DVec3],
    /// Live tets, ghosts included, and dead slots (listed in `free`).
    tets: Vec<Tet>,
    /// Dead slots, reused first.
    free: Vec<u32>,
    /// Where the next walk starts: a live real tet.
    last: u32,
    /// Per tet: `epoch` if in the current cavity, `epoch + 1` if tested and not in conflict.
    marks: Vec<u32>,
    epoch: u32,
    /// Buffers of the current insertion.
    cavity: Vec<u32>,
    boundary: Vec<BoundaryFace>,
    edges: EdgeTable,
    rng: SplitMix64,
}

impl<'a> Builder<'a> {
    /// The triangulation of `simplex` (four affinely independent points) and its four ghosts.
    fn new(points: &'a [DVec3], simplex: [u32; 4]) -> Builder<'a> {
        let mut builder = Builder {
            points,
            tets: Vec::with_capacity(7 * points.len() + 16),
            free: Vec::new(),
            last: 0,
            marks: Vec::new(),
            epoch: 0,
            cavity: Vec::new(),
            boundary: Vec::new(),
            edges: EdgeTable::default(),
            rng: SplitMix64::new(WALK_SEED),
        };
        let [a, b, c, d] = simplex;
        let vertices = if builder.orient(simplex) > 0.0 { simplex } else { [b, a, c, d] };
        builder.tets.push(Tet { vertices, neighbors: [NO_TET; 4] });
        for face in FACE {
            // The ghost over the face: its vertices turned to face away from the fourth vertex.
            let [f0, f1, f2] = face.map(|i| vertices[i]);
            builder.tets.push(Tet { vertices: [f1, f0, f2, GHOST], neighbors: [NO_TET; 4] });
        }
        link_by_shared_faces(&mut builder.tets);
        builder
    }

    fn point(&self, v: u32) -> DVec3 {
        self.points[v as usize]
    }

    /// [`robust::orient3d`] of four vertices (no ghost).
    fn orient(&self, v: [u32; 4]) -> f64 {
        orient(self.point(v[0]), self.point(v[1]), self.point(v[2]), self.point(v[3]))
    }

    /// [`robust::insphere`] of a real tet's vertices and point `p`.
    fn insphere(&self, v: [u32; 4], p: u32) -> f64 {
        let [a, b, c, d] = v.map(|v| coord(self.point(v)));
        insphere(a, b, c, d, coord(self.point(p)))
    }

    /// Inserts point `p`; returns the vertex it repeats instead, if any.
    fn insert(&mut self, p: u32) -> Option<u32> {
        let start = self.locate(p);
        let tet = self.tets[start as usize];
        if !tet.is_ghost() {
            let repeated = tet.vertices.iter().find(|&&v| self.point(v) == self.point(p));
            if let Some(&existing) = repeated {
                return Some(existing);
            }
        }
        self.find_cavity(start, p);
        self.fill_cavity();
        None
    }

    /// Walks from `last` to the tet whose closed volume holds `p`, or to a ghost whose hull face
    /// has `p` strictly outside.
    fn locate(&mut self, p: u32) -> u32 {
        let mut t = self.last;
        let mut came_from = NO_TET;
        'walk: loop {
            let tet = self.tets[t as usize];
            if tet.is_ghost() {
                return t;
            }
            let first = (self.rng.next() >> 62) as usize;
            for i in 0..4 {
                let k = (first + i) & 3;
                let next = tet.neighbors[k];
                if next == came_from {
                    continue;
                }
                let mut moved = tet.vertices;
                moved[k] = p;
                if self.orient(moved) < 0.0 {
                    came_from = t;
                    t = next;
                    continue 'walk;
                }
            }
            return t;
        }
    }

    /// Is tet `t` in conflict with point `p`? (The tie rule of the module documentation.)
    fn conflicts(&self, t: u32, p: u32) -> bool {
        let tet = &self.tets[t as usize];
        let v = tet.vertices;
        if !tet.is_ghost() {
            return self.insphere(v, p) > 0.0;
        }
        let side = self.orient([v[0], v[1], v[2], p]);
        if side != 0.0 {
            return side > 0.0;
        }
        // In the hull face's plane: in conflict when strictly inside the face's circumcircle,
        // which is where the plane cuts the circumsphere of the real tet under the face.
        let under = self.tets[tet.neighbors[3] as usize].vertices;
        self.insphere(under, p) > 0.0
    }

    /// Starts a new cavity epoch, so marks from earlier insertions read as unmarked.
    fn next_epoch(&mut self) {
        if self.marks.len() < self.tets.len() {
            self.marks.resize(self.tets.len(), 0);
        }
        if self.epoch >= u32::MAX - 3 {
            self.marks.fill(0);
            self.epoch = 0;
        }
        self.epoch += 2;
    }

    /// Fills `cavity` with the tets in conflict with `p`, found by breadth-first search from
    /// `start` (in conflict, as [`Builder::locate`] returns it), and `boundary` with the faces
    /// between them and the rest.
    fn find_cavity(&mut self, start: u32, p: u32) {
        self.next_epoch();
        let (inside, outside) = (self.epoch, self.epoch + 1);
        self.cavity.clear();
        self.boundary.clear();
        self.marks[start as usize] = inside;
        self.cavity.push(start);
        let mut next = 0;
        while next < self.cavity.len() {
            let t = self.cavity[next];
            next += 1;
            let tet = self.tets[t as usize];
            for (k, &n) in tet.neighbors.iter().enumerate() {
                let mark = self.marks[n as usize];
                if mark == inside {
                    continue;
                }
                if mark != outside && self.conflicts(n, p) {
                    self.marks[n as usize] = inside;
                    self.cavity.push(n);
                    continue;
                }
                self.marks[n as usize] = outside;
                let mut vertices = tet.vertices;
                vertices[k] = p;
                let outside_face = self.face_towards(n, t);
                self.boundary.push(BoundaryFace { vertices, apex: k, outside: n, outside_face });
            }
        }
    }

    /// The index of the face of `t` shared with its neighbour `n`.
    fn face_towards(&self, t: u32, n: u32) -> usize {
        let neighbors = &self.tets[t as usize].neighbors;
        neighbors.iter().position(|&x| x == n).unwrap_or_else(|| unreachable!("neighbours are symmetric"))
    }

    /// Replaces the cavity by the tets joining the new point to its boundary faces.
    fn fill_cavity(&mut self) {
        self.free.extend_from_slice(&self.cavity);
        self.edges.reset(3 * self.boundary.len() / 2);
        for b in 0..self.boundary.len() {
            let face = self.boundary[b];
            let id = self.allocate(Tet { vertices: face.vertices, neighbors: [NO_TET; 4] });
            self.tets[id as usize].neighbors[face.apex] = face.outside;
            self.tets[face.outside as usize].neighbors[face.outside_face] = id;
            // The other three faces contain `p`: each is shared with the new tet on the
            // boundary face across the edge it has besides `p`.
            for k in (0..4).filter(|&k| k != face.apex) {
                let [e0, e1] = edge_without(face.vertices, k, face.apex);
                if let Some((other, other_face)) = self.edges.pair(e0, e1, id, k) {
                    self.tets[id as usize].neighbors[k] = other;
                    self.tets[other as usize].neighbors[other_face] = id;
                }
            }
            if face.vertices[3] != GHOST {
                self.last = id;
            }
        }
    }

    /// Stores `tet` in a dead slot, or a new one.
    fn allocate(&mut self, tet: Tet) -> u32 {
        match self.free.pop() {
            Some(id) => {
                self.tets[id as usize] = tet;
                id
            }
            None => {
                self.tets.push(tet);
                (self.tets.len() - 1) as u32
            }
        }
    }

    /// The live real tets and their neighbours, renumbered densely, with vertices mapped through
    /// `original` (internal index -> input index).
    fn finish(self, original: &[u32]) -> (Vec<[u32; 4]>, Vec<[u32; 4]>) {
        let mut renumbered = vec![NO_TET; self.tets.len()];
        let mut dead = vec![false; self.tets.len()];
        for &t in &self.free {
            dead[t as usize] = true;
        }
        let mut count = 0;
        for (t, tet) in self.tets.iter().enumerate() {
            if !dead[t] && !tet.is_ghost() {
                renumbered[t] = count;
                count += 1;
            }
        }
        let mut tets = Vec::with_capacity(count as usize);
        let mut neighbors = Vec::with_capacity(count as usize);
        for (t, tet) in self.tets.iter().enumerate() {
            if renumbered[t] != NO_TET {
                tets.push(tet.vertices.map(|v| original[v as usize]));
                // Ghosts were never renumbered, so they map to NO_NEIGHBOR.
                neighbors.push(tet.neighbors.map(|n| renumbered[n as usize]));
            }
        }
        (tets, neighbors)
    }
}

/// The two vertices of `vertices` at positions other than `a` and `b`.
fn edge_without(vertices: [u32; 4], a: usize, b: usize) -> [u32; 2] {
    let mut edge = [0; 2];
    let mut n = 0;
    for (i, &v) in vertices.iter().enumerate() {
        if i != a && i != b {
            edge[n] = v;
            n += 1;
        }
    }
    edge
}

/// Sets the neighbours of a handful of tets by comparing their faces pairwise.
fn link_by_shared_faces(tets: &mut [Tet]) {
    let sorted_face = |tet: &Tet, k: usize| {
        let mut face = FACE[k].map(|i| tet.vertices[i]);
        face.sort_unstable();
        face
    };
    for t in 0..tets.len() {
        for u in 0..tets.len() {
            for k in 0..4 {
                for j in 0..4 {
                    if t != u && sorted_face(&tets[t], k) == sorted_face(&tets[u], j) {
                        tets[t].neighbors[k] = u as u32;
                    }
                }
            }
        }
    }
}

/// Pairs up the faces of the new tets through the cavity-boundary edge each contains besides the
/// new point: open addressing on the edge, cleared in O(1) by a stamp per slot.
#[derive(Debug, Default)]
struct EdgeTable {
    slots: Vec<EdgeSlot>,
    stamp: u32,
}

#[derive(Debug, Clone, Copy, Default)]
struct EdgeSlot {
    key: u64,
    tet: u32,
    face: u32,
    stamp: u32,
}

impl EdgeTable {
    /// Empties the table, making room for `edges` entries at load factor at most one half.
    fn reset(&mut self, edges: usize) {
        let wanted = (2 * edges).next_power_of_two().max(64);
        if self.slots.len() < wanted {
            self.slots = vec![EdgeSlot::default(); wanted];
            self.stamp = 0;
        }
        if self.stamp == u32::MAX {
            self.slots.fill(EdgeSlot::default());
            self.stamp = 0;
        }
        self.stamp += 1;
    }

    /// Records that face `face` of `tet` holds edge `{a, b}`; if another face holds it already,
    /// returns that face instead (each edge is held by exactly two faces).
    fn pair(&mut self, a: u32, b: u32, tet: u32, face: usize) -> Option<(u32, usize)> {
        let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
        let mask = self.slots.len() - 1;
        let mut i = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) as usize & mask;
        loop {
            let slot = &mut self.slots[i];
            if slot.stamp != self.stamp {
                *slot = EdgeSlot { key, tet, face: face as u32, stamp: self.stamp };
                return None;
            }
            if slot.key == key {
                return Some((slot.tet, slot.face as usize));
            }
            i = (i + 1) & mask;
        }
    }
}

/// SplitMix64 (Steele, Lea and Flood): a tiny deterministic generator.
#[derive(Debug, Clone)]
struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    fn new(seed: u64) -> SplitMix64 {
        SplitMix64 { state: seed }
    }

    fn next(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Roughly uniform in `0..n` (n > 0).
    fn below(&mut self, n: usize) -> usize {
        ((u128::from(self.next()) * n as u128) >> 64) as usize
    }
}

#[cfg(test)]
mod tests {
    use std::collections::{BTreeSet, HashMap, HashSet};

    use super::*;

    /// Uniform in [0, 1).
    fn unit(rng: &mut SplitMix64) -> f64 {
        (rng.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    fn random_points(count: usize, seed: u64) -> Vec<DVec3> {
        let mut rng = SplitMix64::new(seed);
        (0..count).map(|_| DVec3::new(unit(&mut rng), unit(&mut rng), unit(&mut rng))).collect()
    }

    fn lattice(n: i32) -> Vec<DVec3> {
        let mut points = Vec::new();
        for x in 0..n {
            for y in 0..n {
                for z in 0..n {
                    points.push(DVec3::new(x as f64, y as f64, z as f64));
                }
            }
        }
        points
    }

    /// Every integer point at squared distance `r2` from the origin: exactly cospherical.
    fn integer_sphere(r2: i64) -> Vec<DVec3> {
        let r = (r2 as f64).sqrt() as i64 + 1;
        let mut points = Vec::new();
        for x in -r..=r {
            for y in -r..=r {
                for z in -r..=r {
                    if x * x + y * y + z * z == r2 {
                        points.push(DVec3::new(x as f64, y as f64, z as f64));
                    }
                }
            }
        }
        points
    }

    /// Near-uniform points on the unit sphere (Fibonacci spiral).
    fn fibonacci_sphere(count: usize) -> Vec<DVec3> {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..count)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
                let r = (1.0 - z * z).sqrt();
                let phi = golden * i as f64;
                DVec3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect()
    }

    fn orient_of(points: &[DVec3], tet: [u32; 4]) -> f64 {
        let [a, b, c, d] = tet.map(|i| points[i as usize]);
        orient(a, b, c, d)
    }

    fn insphere_of(points: &[DVec3], tet: [u32; 4], e: usize) -> f64 {
        let [a, b, c, d] = tet.map(|i| coord(points[i as usize]));
        insphere(a, b, c, d, coord(points[e]))
    }

    /// The hull faces (tet faces without a neighbour), each turned so that its normal
    /// `(b - a) × (c - a)` points away from the tet.
    fn hull_faces(points: &[DVec3], tri: &Tetrahedralization) -> Vec<[u32; 3]> {
        let mut faces = Vec::new();
        for (tet, neighbors) in tri.tets.iter().zip(&tri.neighbors) {
            for k in 0..4 {
                if neighbors[k] != NO_NEIGHBOR {
                    continue;
                }
                let others: Vec<u32> = (0..4).filter(|&i| i != k).map(|i| tet[i]).collect();
                let mut face = [others[0], others[1], others[2]];
                if orient_of(points, [face[0], face[1], face[2], tet[k]]) < 0.0 {
                    face.swap(1, 2);
                }
                faces.push(face);
            }
        }
        faces
    }

    /// The volume closed by outward faces, by the divergence theorem.
    fn enclosed_volume(points: &[DVec3], faces: &[[u32; 3]]) -> f64 {
        let o = points[faces[0][0] as usize];
        faces
            .iter()
            .map(|face| {
                let [a, b, c] = face.map(|i| points[i as usize] - o);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    fn total_volume(points: &[DVec3], tri: &Tetrahedralization) -> f64 {
        tri.tets.iter().map(|&tet| tet_volume(points, tet)).sum()
    }

    /// Everything but the Delaunay property: orientation, adjacency, a closed convex hull
    /// boundary, every point used, and tet volumes summing to the hull's volume (to
    /// `tolerance`, relative). Returns the hull volume.
    fn check_structure(points: &[DVec3], tri: &Tetrahedralization, tolerance: f64) -> f64 {
        assert_eq!(tri.tets.len(), tri.neighbors.len());
        assert!(!tri.tets.is_empty());
        let skipped: HashSet<u32> = tri.duplicates.iter().map(|&[s, _]| s).collect();
        for &[s, kept] in &tri.duplicates {
            assert!(kept < s && points[s as usize] == points[kept as usize] && !skipped.contains(&kept));
        }

        let mut used = vec![false; points.len()];
        for (t, &tet) in tri.tets.iter().enumerate() {
            for &v in &tet {
                assert!((v as usize) < points.len() && !skipped.contains(&v), "tet {t} = {tet:?}");
                used[v as usize] = true;
            }
            assert!(orient_of(points, tet) > 0.0, "tet {t} = {tet:?} is not positively oriented");
            assert!(tet_volume(points, tet) > 0.0, "tet {t} = {tet:?} has no volume");
        }
        for (i, used) in used.iter().enumerate() {
            assert_eq!(*used, !skipped.contains(&(i as u32)), "point {i}");
        }

        for (t, (tet, neighbors)) in tri.tets.iter().zip(&tri.neighbors).enumerate() {
            for (k, &u) in neighbors.iter().enumerate() {
                if u == NO_NEIGHBOR {
                    continue;
                }
                let back: Vec<usize> = (0..4).filter(|&j| tri.neighbors[u as usize][j] == t as u32).collect();
                assert_eq!(back.len(), 1, "tet {t} face {k}: neighbour {u} does not point back once");
                let j = back[0];
                let other = tri.tets[u as usize];
                let face_t: BTreeSet<u32> = (0..4).filter(|&i| i != k).map(|i| tet[i]).collect();
                let face_u: BTreeSet<u32> = (0..4).filter(|&i| i != j).map(|i| other[i]).collect();
                assert_eq!(face_t, face_u, "tets {t} and {u} do not share the face between them");
                assert!(!tet.contains(&other[j]), "tets {t} and {u} share four vertices");
            }
        }

        // The hull faces form a closed, consistently oriented surface ...
        let faces = hull_faces(points, tri);
        let mut directed = HashSet::new();
        for &[a, b, c] in &faces {
            for edge in [(a, b), (b, c), (c, a)] {
                assert!(directed.insert(edge), "hull edge {edge:?} is used twice in one direction");
            }
        }
        for &(a, b) in &directed {
            assert!(directed.contains(&(b, a)), "hull edge ({a}, {b}) is on one hull face only");
        }
        // ... convex at every edge (a closed, locally convex surface bounds a convex body) ...
        let mut face_of_edge = HashMap::new();
        for (f, &[a, b, c]) in faces.iter().enumerate() {
            for (edge, apex) in [((a, b), c), ((b, c), a), ((c, a), b)] {
                face_of_edge.insert(edge, (f, apex));
            }
        }
        for (&(a, b), &(f, apex)) in &face_of_edge {
            let [x, y, z] = faces[face_of_edge[&(b, a)].0].map(|i| points[i as usize]);
            assert!(orient(x, y, z, points[apex as usize]) >= 0.0, "hull face {f} is reflex at edge ({a}, {b})");
        }
        // ... and each face supports the point set: it is the convex hull's boundary.
        if faces.len() * points.len() <= 50_000_000 {
            for &[a, b, c] in &faces {
                for (i, &p) in points.iter().enumerate() {
                    let side = orient(points[a as usize], points[b as usize], points[c as usize], p);
                    assert!(side >= 0.0, "point {i} is outside hull face [{a}, {b}, {c}]");
                }
            }
        }

        let hull = enclosed_volume(points, &faces);
        let tets = total_volume(points, tri);
        assert!(
            (hull - tets).abs() <= tolerance * hull,
            "tet volumes sum to {tets}, the hull encloses {hull} (relative gap {:e})",
            (hull - tets).abs() / hull
        );
        hull
    }

    /// No point strictly inside any tet's circumsphere, by brute force.
    fn check_empty_spheres(points: &[DVec3], tri: &Tetrahedralization) {
        for (t, &tet) in tri.tets.iter().enumerate() {
            for e in 0..points.len() {
                assert!(insphere_of(points, tet, e) <= 0.0, "point {e} is inside the circumsphere of tet {t}");
            }
        }
    }

    /// No point strictly inside any tet's circumsphere, among the vertices of the tet's
    /// neighbours and `samples` random points per tet.
    fn check_local_and_sampled_spheres(points: &[DVec3], tri: &Tetrahedralization, samples: usize) {
        let mut rng = SplitMix64::new(99);
        for (t, (&tet, neighbors)) in tri.tets.iter().zip(&tri.neighbors).enumerate() {
            let near = neighbors.iter().filter(|&&u| u != NO_NEIGHBOR).flat_map(|&u| tri.tets[u as usize]);
            let sampled: Vec<u32> = (0..samples).map(|_| rng.below(points.len()) as u32).collect();
            for e in near.chain(sampled) {
                assert!(insphere_of(points, tet, e as usize) <= 0.0, "point {e} is inside the circumsphere of tet {t}");
            }
        }
    }

    fn sorted_tets(tri: &Tetrahedralization) -> BTreeSet<[u32; 4]> {
        tri.tets
            .iter()
            .map(|&tet| {
                let mut tet = tet;
                tet.sort_unstable();
                tet
            })
            .collect()
    }

    /// All 4-tuples with a strictly empty circumsphere (points in general position).
    fn brute_force_tets(points: &[DVec3]) -> BTreeSet<[u32; 4]> {
        let n = points.len() as u32;
        let mut tets = BTreeSet::new();
        for a in 0..n {
            for b in a + 1..n {
                for c in b + 1..n {
                    for d in c + 1..n {
                        let side = orient_of(points, [a, b, c, d]);
                        assert!(side != 0.0, "not in general position");
                        let oriented = if side > 0.0 { [a, b, c, d] } else { [b, a, c, d] };
                        let empty = (0..points.len()).filter(|&e| ![a, b, c, d].contains(&(e as u32))).all(|e| {
                            let inside = insphere_of(points, oriented, e);
                            assert!(inside != 0.0, "not in general position");
                            inside < 0.0
                        });
                        if empty {
                            tets.insert([a, b, c, d]);
                        }
                    }
                }
            }
        }
        tets
    }

    /// The convex hull volume from all supporting triangles (points in general position).
    fn brute_force_hull_volume(points: &[DVec3]) -> f64 {
        let n = points.len() as u32;
        let mut faces = Vec::new();
        for a in 0..n {
            for b in a + 1..n {
                for c in b + 1..n {
                    let sides: Vec<f64> =
                        (0..n).filter(|e| ![a, b, c].contains(e)).map(|e| orient_of(points, [a, b, c, e])).collect();
                    if sides.iter().all(|&s| s > 0.0) {
                        faces.push([a, b, c]);
                    } else if sides.iter().all(|&s| s < 0.0) {
                        faces.push([a, c, b]);
                    }
                }
            }
        }
        enclosed_volume(points, &faces)
    }

    #[test]
    fn small_random_sets_match_brute_force() {
        for (seed, count) in [(1, 5), (2, 8), (3, 13), (4, 21), (5, 30), (6, 40), (7, 40)] {
            let points = random_points(count, seed);
            let tri = tetrahedralize(&points).expect("random points triangulate");
            check_structure(&points, &tri, 1e-12);
            assert_eq!(sorted_tets(&tri), brute_force_tets(&points), "{count} points, seed {seed}");
        }
    }

    #[test]
    fn volumes_sum_to_brute_force_hull_volume() {
        for seed in 10..14 {
            let points = random_points(60, seed);
            let tri = tetrahedralize(&points).expect("random points triangulate");
            let hull = check_structure(&points, &tri, 1e-12);
            let reference = brute_force_hull_volume(&points);
            assert!((hull - reference).abs() <= 1e-12 * reference, "{hull} vs {reference}");
            let tets = total_volume(&points, &tri);
            assert!((tets - reference).abs() <= 1e-12 * reference, "{tets} vs {reference}");
        }
    }

    #[test]
    fn random_300_points_have_empty_circumspheres() {
        let points = random_points(300, 20);
        let tri = tetrahedralize(&points).expect("random points triangulate");
        check_structure(&points, &tri, 1e-12);
        check_empty_spheres(&points, &tri);
    }

    #[test]
    fn random_5000_points_have_locally_and_sampled_empty_circumspheres() {
        let points = random_points(5000, 21);
        let tri = tetrahedralize(&points).expect("random points triangulate");
        check_structure(&points, &tri, 1e-12);
        check_local_and_sampled_spheres(&points, &tri, 64);
    }

    #[test]
    fn lattice_with_cospherical_cubes() {
        let points = lattice(6);
        let tri = tetrahedralize(&points).expect("a lattice triangulates");
        let hull = check_structure(&points, &tri, 1e-12);
        assert!((hull - 125.0).abs() <= 1e-12 * 125.0);
        check_empty_spheres(&points, &tri);
        // Each unit cube's eight corners are cospherical: no Delaunay tet reaches past one cube.
        for &tet in &tri.tets {
            let [a, b, c, d] = tet.map(|i| points[i as usize]);
            let extent = a.max(b).max(c).max(d) - a.min(b).min(c).min(d);
            assert!(extent.max_element() <= 1.0, "tet {tet:?} spans more than one cube");
        }
    }

    #[test]
    fn larger_lattice_is_locally_delaunay() {
        let points = lattice(14);
        let tri = tetrahedralize(&points).expect("a lattice triangulates");
        let hull = check_structure(&points, &tri, 1e-12);
        assert!((hull - 13f64.powi(3)).abs() <= 1e-12 * hull);
        check_local_and_sampled_spheres(&points, &tri, 32);
    }

    #[test]
    fn cube_corners_are_all_cospherical() {
        let points = lattice(2);
        let tri = tetrahedralize(&points).expect("a cube triangulates");
        let hull = check_structure(&points, &tri, 1e-12);
        assert!((hull - 1.0).abs() <= 1e-12);
        assert!(tri.tets.len() == 5 || tri.tets.len() == 6, "{} tets", tri.tets.len());
        check_empty_spheres(&points, &tri);
    }

    /// The determinant of a small integer matrix, by cofactor expansion.
    fn integer_determinant(m: &[Vec<i128>]) -> i128 {
        if m.len() == 1 {
            return m[0][0];
        }
        (0..m.len())
            .map(|col| {
                let minor: Vec<Vec<i128>> = m[1..]
                    .iter()
                    .map(|row| row.iter().enumerate().filter(|&(c, _)| c != col).map(|(_, &v)| v).collect())
                    .collect();
                let sign = if col % 2 == 0 { 1 } else { -1 };
                sign * m[0][col] * integer_determinant(&minor)
            })
            .sum()
    }

    /// Shewchuk's insphere determinant in integers: rows `[q - e, |q - e|²]` for `q` in `a..d`.
    fn integer_insphere(p: [DVec3; 5]) -> i128 {
        let rows: Vec<Vec<i128>> = p[..4]
            .iter()
            .map(|&q| {
                let d = (q - p[4]).as_i64vec3();
                let (x, y, z) = (i128::from(d.x), i128::from(d.y), i128::from(d.z));
                vec![x, y, z, x * x + y * y + z * z]
            })
            .collect();
        integer_determinant(&rows)
    }

    /// The sign of the crate's predicates matters most on exactly degenerate input: check it
    /// against integer arithmetic on the cospherical and lattice points the tests use.
    #[test]
    fn exact_predicate_agrees_with_integer_arithmetic() {
        let mut points = integer_sphere(50);
        points.extend(lattice(3));
        let mut rng = SplitMix64::new(5);
        let mut zeros = 0;
        for _ in 0..20_000 {
            let five: [DVec3; 5] = std::array::from_fn(|_| points[rng.below(points.len())]);
            let [a, b, c, d, e] = five.map(coord);
            let exact = integer_insphere(five).signum();
            let inside = insphere(a, b, c, d, e);
            let sign = if inside > 0.0 {
                1
            } else if inside < 0.0 {
                -1
            } else {
                0
            };
            assert_eq!(sign, exact, "{five:?}");
            zeros += usize::from(exact == 0);
        }
        assert!(zeros > 1000, "the sample holds many cospherical 5-tuples");
    }

    #[test]
    fn exactly_cospherical_points() {
        for r2 in [50, 325] {
            let points = integer_sphere(r2);
            let tri = tetrahedralize(&points).expect("sphere points triangulate");
            check_structure(&points, &tri, 1e-12);
            check_empty_spheres(&points, &tri);

            let mut with_centre = points.clone();
            with_centre.push(DVec3::ZERO);
            let tri = tetrahedralize(&with_centre).expect("sphere points triangulate");
            check_structure(&with_centre, &tri, 1e-12);
            check_empty_spheres(&with_centre, &tri);
            let centre = (with_centre.len() - 1) as u32;
            assert!(tri.tets.iter().all(|tet| tet.contains(&centre)), "the centre is in every ball");
        }
    }

    #[test]
    fn points_on_a_sphere_and_nested_offset_shells() {
        let sphere = fibonacci_sphere(2000);
        let tri = tetrahedralize(&sphere).expect("sphere points triangulate");
        check_structure(&sphere, &tri, 1e-12);
        check_local_and_sampled_spheres(&sphere, &tri, 32);

        // Offset surfaces: the same directions on every layer, so points line up radially.
        let directions = fibonacci_sphere(600);
        let mut shells: Vec<DVec3> =
            (0..4).flat_map(|layer| directions.iter().map(move |&d| d * (1.0 - 0.1 * layer as f64))).collect();
        shells.push(DVec3::ZERO);
        let tri = tetrahedralize(&shells).expect("shells triangulate");
        check_structure(&shells, &tri, 1e-12);
        check_empty_spheres(&shells, &tri);
    }

    #[test]
    fn coplanar_subsets() {
        // A square grid in a plane and an apex on each side: the hull has flat square facets
        // made of cocircular points.
        let mut pyramid: Vec<DVec3> = lattice(8).into_iter().filter(|p| p.z == 0.0).collect();
        pyramid.push(DVec3::new(3.5, 3.5, 2.0));
        let tri = tetrahedralize(&pyramid).expect("a pyramid triangulates");
        let hull = check_structure(&pyramid, &tri, 1e-12);
        assert!((hull - 49.0 * 2.0 / 3.0).abs() <= 1e-12 * hull);
        check_empty_spheres(&pyramid, &tri);
        pyramid.push(DVec3::new(1.0, 2.0, -3.0));
        let tri = tetrahedralize(&pyramid).expect("a double pyramid triangulates");
        check_structure(&pyramid, &tri, 1e-12);
        check_empty_spheres(&pyramid, &tri);

        // The surface of a cube lattice plus a few interior points; parallel grid layers.
        let surface: Vec<DVec3> =
            lattice(7).into_iter().filter(|p| p.min_element() == 0.0 || p.max_element() == 6.0).collect();
        let mut box_shell = surface.clone();
        box_shell.extend([DVec3::new(3.0, 3.0, 3.0), DVec3::new(2.5, 3.25, 1.0), DVec3::new(1.0, 1.0, 5.0)]);
        for points in [surface, box_shell] {
            let tri = tetrahedralize(&points).expect("a box surface triangulates");
            let hull = check_structure(&points, &tri, 1e-12);
            assert!((hull - 216.0).abs() <= 1e-12 * hull);
            check_empty_spheres(&points, &tri);
        }
        let layers: Vec<DVec3> = lattice(9)
            .into_iter()
            .filter(|p| p.z % 4.0 == 0.0)
            .map(|p| if p.z == 4.0 { p + DVec3::new(0.5, 0.5, 0.0) } else { p })
            .collect();
        let tri = tetrahedralize(&layers).expect("layers triangulate");
        check_structure(&layers, &tri, 1e-12);
        check_empty_spheres(&layers, &tri);
    }

    #[test]
    fn nearly_degenerate_inputs() {
        // Nearly coplanar: a random slab 1e-9 thick.
        let mut rng = SplitMix64::new(30);
        let slab: Vec<DVec3> =
            (0..400).map(|_| DVec3::new(unit(&mut rng), unit(&mut rng), 1e-9 * unit(&mut rng))).collect();
        let tri = tetrahedralize(&slab).expect("a thin slab triangulates");
        check_structure(&slab, &tri, 1e-6);
        check_empty_spheres(&slab, &tri);

        // The moment curve: every pair of points is a Delaunay edge, many slivers.
        let curve: Vec<DVec3> = (1..=40).map(|t| DVec3::new(t as f64, (t * t) as f64, (t * t * t) as f64)).collect();
        let tri = tetrahedralize(&curve).expect("the moment curve triangulates");
        check_structure(&curve, &tri, 1e-12);
        check_empty_spheres(&curve, &tri);

        // A lattice jittered by a few ulps.
        let jittered: Vec<DVec3> = lattice(6)
            .into_iter()
            .map(|p| p + DVec3::new(unit(&mut rng), unit(&mut rng), unit(&mut rng)) * 1e-15)
            .collect();
        let tri = tetrahedralize(&jittered).expect("a jittered lattice triangulates");
        check_structure(&jittered, &tri, 1e-12);
        check_empty_spheres(&jittered, &tri);
    }

    #[test]
    fn duplicates_are_skipped_and_reported() {
        let mut points = random_points(200, 40);
        points.push(points[7]);
        points.insert(3, points[150]);
        points.push(DVec3::new(0.0, 0.5, 0.5));
        points.push(DVec3::new(-0.0, 0.5, 0.5));
        points.push(points[7]);
        let tri = tetrahedralize(&points).expect("points with repeats triangulate");
        check_structure(&points, &tri, 1e-12);
        check_empty_spheres(&points, &tri);
        assert_eq!(tri.duplicates, vec![[151, 3], [201, 8], [203, 202], [204, 7]]);
    }

    #[test]
    fn output_is_deterministic() {
        let mut points = lattice(5);
        points.extend(random_points(300, 50).into_iter().map(|p| p * 4.0));
        let first = tetrahedralize(&points).expect("triangulates");
        let second = tetrahedralize(&points).expect("triangulates");
        assert_eq!(first, second);
    }

    /// The benchmark's layouts at full size (200,000 points), checked like the small sets. Slow in
    /// debug builds: `cargo test --release -p shatter-preprocess --lib delaunay -- --ignored`.
    #[test]
    #[ignore]
    fn full_size_layouts_are_valid() {
        const COUNT: usize = 200_000;
        const LAYERS: usize = 10;
        let radius = |layer: usize| 1.0 - 0.0225 * layer as f64;
        let directions = fibonacci_sphere(COUNT / LAYERS);
        let offset: Vec<DVec3> =
            (0..LAYERS).flat_map(|layer| directions.iter().map(move |&d| d * radius(layer))).collect();
        let nested: Vec<DVec3> = (0..LAYERS)
            .flat_map(|layer| {
                let count = (COUNT as f64 * radius(layer).powi(2) / 8.2) as usize;
                fibonacci_sphere(count).into_iter().map(move |d| d * radius(layer))
            })
            .collect();
        for points in [random_points(COUNT, 70), offset, nested] {
            let tri = tetrahedralize(&points).expect("triangulates");
            check_structure(&points, &tri, 1e-11);
            check_local_and_sampled_spheres(&points, &tri, 4);
        }
    }

    #[test]
    fn morton_codes_interleave_bits() {
        assert_eq!(spread_bits(0b1011), 0b1_000_001_001);
        assert_eq!(spread_bits(0x1f_ffff), 0x1249_2492_4924_9249);
        let frame = MortonFrame::new([DVec3::ZERO, DVec3::ONE].into_iter());
        assert_eq!(frame.code(DVec3::ZERO), 0);
        assert_eq!(frame.code(DVec3::ONE), (1 << 63) - 1);
        assert_eq!(frame.code(DVec3::new(0.0, 1.0, 0.0)), 0x1249_2492_4924_9249 << 1);
    }

    #[test]
    fn rejects_bad_input() {
        let points = random_points(3, 60);
        assert_eq!(tetrahedralize(&points), Err(DelaunayError::TooFewPoints { count: 3 }));
        assert_eq!(tetrahedralize(&[]), Err(DelaunayError::TooFewPoints { count: 0 }));

        let plane: Vec<DVec3> = lattice(4).into_iter().filter(|p| p.x + p.y + p.z == 3.0).collect();
        assert_eq!(tetrahedralize(&plane), Err(DelaunayError::Coplanar { distinct: plane.len() }));
        let line: Vec<DVec3> = (0..10).map(|i| DVec3::splat(i as f64)).collect();
        assert_eq!(tetrahedralize(&line), Err(DelaunayError::Coplanar { distinct: 10 }));
        let repeated = vec![DVec3::ONE; 5];
        assert_eq!(tetrahedralize(&repeated), Err(DelaunayError::Coplanar { distinct: 1 }));

        let mut points = random_points(10, 61);
        points[4].y = f64::NAN;
        assert!(matches!(tetrahedralize(&points), Err(DelaunayError::NonFinite { index: 4, .. })));
        points[4].y = f64::INFINITY;
        assert!(matches!(tetrahedralize(&points), Err(DelaunayError::NonFinite { index: 4, .. })));
        points[4].y = 1e40;
        assert!(matches!(tetrahedralize(&points), Err(DelaunayError::OutOfRange { index: 4, .. })));
    }
}
