//! The incremental Bowyer-Watson triangulation under construction: locating a new point by a
//! visibility walk, gathering the cavity of tets in conflict with it, and filling the cavity with
//! the tets joining the point to its boundary (see the [module documentation](super)).

use glam::DVec3;
use robust::insphere;

use super::edge_table::EdgeTable;
use super::predicates::{coord, orient};
use super::splitmix::SplitMix64;
use super::tetrahedralization::NO_TET;

/// The symbolic vertex at infinity shared by all ghost tets (always at index 3 of a ghost).
const GHOST: u32 = u32::MAX;

/// Seed of the walk's choice of the first face to try.
const WALK_SEED: u64 = 0x5EED_DE1A_0BA7_0002;

/// `FACE[k]`: the positions of the face opposite vertex `k`, ordered so that
/// `(v[FACE[k][0]], v[FACE[k][1]], v[FACE[k][2]], v[k])` is an even permutation of `v`. Seen from
/// outside the tet the face's vertices then turn counterclockwise.
const FACE: [[usize; 3]; 4] = [[1, 3, 2], [0, 2, 3], [0, 3, 1], [0, 1, 2]];

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
pub(super) struct Builder<'a> {
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
    pub(super) fn new(points: &'a [DVec3], simplex: [u32; 4]) -> Builder<'a> {
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
    pub(super) fn insert(&mut self, p: u32) -> Option<u32> {
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
    pub(super) fn finish(self, original: &[u32]) -> (Vec<[u32; 4]>, Vec<[u32; 4]>) {
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
