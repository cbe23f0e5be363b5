//! The convex polytope of a cell: a box cut by one plane after another, its faces sharing their
//! vertices and naming the face across each edge.

use glam::DVec3;

use super::clipping::{ClipVertices, Corner, clip_cycle, cut_point, plane_parts, side};

/// No vertex, face or site.
pub(super) const NONE: u32 = u32::MAX;

/// A face of a polytope: the plane it lies on (an index into the cell's planes) and its corners,
/// counterclockwise seen from outside, each edge labelled with the plane of the face across it.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Face {
    pub(super) plane: u32,
    pub(super) corners: Vec<Corner<u32>>,
}

/// A convex polytope whose faces share their vertices.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Polytope {
    vertices: Vec<DVec3>,
    pub(super) faces: Vec<Face>,
}

impl Polytope {
    /// The box `[lo, hi]`; its faces lie on planes 0..6 of [`Frame::planes`](super::cell_box::Frame::planes).
    pub(super) fn cuboid(lo: DVec3, hi: DVec3) -> Polytope {
        let vertices = (0..8)
            .map(|i| DVec3::new([lo.x, hi.x][i & 1], [lo.y, hi.y][(i >> 1) & 1], [lo.z, hi.z][(i >> 2) & 1]))
            .collect();
        let quads: [[u32; 4]; 6] = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
        let across = |a: u32, b: u32| {
            let shares = |q: &[u32; 4]| (0..4).any(|k| q[k] == b && q[(k + 1) % 4] == a);
            quads.iter().position(shares).map_or(NONE, |f| f as u32)
        };
        let faces = quads
            .iter()
            .enumerate()
            .map(|(f, q)| Face {
                plane: f as u32,
                corners: (0..4).map(|k| Corner { at: q[k], across: across(q[k], q[(k + 1) % 4]) }).collect(),
            })
            .collect();
        Polytope { vertices, faces }
    }

    /// Keeps the part on the inner side of `plane` (index `id`). A plane that cuts off no vertex
    /// by more than `tolerance` leaves the polytope as it is. `None` when the new face cannot be
    /// closed or nothing would remain.
    pub(super) fn clip(&mut self, id: u32, plane: &[f64; 4], tolerance: f64) -> Option<()> {
        let (normal, offset) = plane_parts(plane);
        let sides: Vec<i8> = self.vertices.iter().map(|v| side(normal.dot(*v) - offset, tolerance)).collect();
        if !sides.contains(&1) {
            return Some(());
        }
        if !sides.contains(&-1) {
            return None;
        }
        let mut made = Renumbering {
            old: &self.vertices,
            sides: &sides,
            normal,
            offset,
            renumbered: vec![NONE; self.vertices.len()],
            cuts: Vec::new(),
            vertices: Vec::with_capacity(self.vertices.len() + 8),
            on_plane: Vec::with_capacity(self.vertices.len() + 8),
        };
        let mut faces = Vec::with_capacity(self.faces.len() + 1);
        let mut cap_edges = Vec::new();
        let mut clipped = Vec::new();
        for face in &self.faces {
            let face_sides: Vec<i8> = face.corners.iter().map(|c| sides[c.at as usize]).collect();
            clip_cycle(&face.corners, &face_sides, id, &mut made, &mut clipped);
            if clipped.len() < 3 || clipped.iter().all(|c| made.on_plane[c.at as usize]) {
                continue;
            }
            for k in 0..clipped.len() {
                if clipped[k].across == id {
                    let next = clipped[(k + 1) % clipped.len()].at;
                    cap_edges.push(Corner { at: [next, clipped[k].at], across: face.plane });
                }
            }
            faces.push(Face { plane: face.plane, corners: clipped.clone() });
        }
        faces.push(Face { plane: id, corners: chain(&cap_edges)? });
        self.vertices = made.vertices;
        self.faces = faces;
        Some(())
    }

    fn position(&self, corner: &Corner<u32>) -> DVec3 {
        self.vertices[corner.at as usize]
    }

    /// Bounding box of the vertices.
    pub(super) fn bounds(&self) -> (DVec3, DVec3) {
        self.vertices.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)))
    }

    /// The positions of a face's corners.
    pub(super) fn face_loop(&self, face: &Face) -> Vec<DVec3> {
        face.corners.iter().map(|c| self.position(c)).collect()
    }
}

/// The vertices of a clipped polytope: kept ones renumbered, each cut edge's point made once.
struct Renumbering<'a> {
    old: &'a [DVec3],
    sides: &'a [i8],
    normal: DVec3,
    offset: f64,
    renumbered: Vec<u32>,
    /// (old edge, lower vertex first; new vertex)
    cuts: Vec<([u32; 2], u32)>,
    vertices: Vec<DVec3>,
    /// Per new vertex: does it lie on the cutting plane?
    on_plane: Vec<bool>,
}

impl Renumbering<'_> {
    fn add(&mut self, point: DVec3, on_plane: bool) -> u32 {
        self.vertices.push(point);
        self.on_plane.push(on_plane);
        self.vertices.len() as u32 - 1
    }
}

impl ClipVertices<u32> for Renumbering<'_> {
    fn keep(&mut self, v: u32) -> u32 {
        if self.renumbered[v as usize] == NONE {
            self.renumbered[v as usize] = self.add(self.old[v as usize], self.sides[v as usize] == 0);
        }
        self.renumbered[v as usize]
    }

    fn cut(&mut self, a: u32, b: u32) -> u32 {
        let key = [a.min(b), a.max(b)];
        if let Some(&(_, v)) = self.cuts.iter().find(|(k, _)| *k == key) {
            return v;
        }
        let [pa, pb] = key.map(|v| self.old[v as usize]);
        let offset_of = |p: DVec3| self.normal.dot(p) - self.offset;
        let v = self.add(cut_point(pa, offset_of(pa), pb, offset_of(pb)), true);
        self.cuts.push((key, v));
        v
    }
}

/// Chains directed edges `[from, to]` into one cycle of corners; `None` unless they form exactly
/// one closed loop of at least three corners.
fn chain(edges: &[Corner<[u32; 2]>]) -> Option<Vec<Corner<u32>>> {
    if edges.len() < 3 {
        return None;
    }
    let mut cycle = Vec::with_capacity(edges.len());
    let mut edge = edges[0];
    for _ in 0..edges.len() {
        cycle.push(Corner { at: edge.at[0], across: edge.across });
        let to = edge.at[1];
        let mut next = edges.iter().filter(|e| e.at[0] == to);
        edge = *next.next()?;
        if next.next().is_some() {
            return None;
        }
    }
    (edge == edges[0]).then_some(cycle)
}
