//! Sutherland-Hodgman clipping of convex polygons by planes: the faces of a polytope cut by a
//! new plane, and mesh triangles cut to a cell. Each corner carries the label of the edge that
//! leaves it, so the clipped pieces remember which cell face each of their edges lies on.

use glam::DVec3;

/// The label of a piece edge that lies on an edge of the original triangle, not on a cell face.
pub(super) const MESH_EDGE: u32 = u32::MAX;

/// A polygon corner: its vertex, and the label of the edge from it to the next corner (a cell
/// plane, or [`MESH_EDGE`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Corner<V> {
    pub(super) at: V,
    pub(super) across: u32,
}

/// How a clip makes the vertices of its result.
pub(super) trait ClipVertices<V> {
    /// The result's vertex for a kept vertex.
    fn keep(&mut self, v: V) -> V;
    /// The point where the plane crosses the edge between `a` and `b`, strictly on opposite sides.
    fn cut(&mut self, a: V, b: V) -> V;
}

/// A convex polygon's part on the inner side (<= 0) of a plane, by Sutherland-Hodgman.
/// `sides` holds each corner's side (-1, 0 on the plane, +1). Edges of the result that lie in the
/// plane (both ends on it) are labelled `plane`; the others keep their labels.
pub(super) fn clip_cycle<V: Copy>(
    cycle: &[Corner<V>],
    sides: &[i8],
    plane: u32,
    vertices: &mut impl ClipVertices<V>,
    out: &mut Vec<Corner<V>>,
) {
    out.clear();
    let mut ends = OnPlaneEnds::default();
    for i in 0..cycle.len() {
        let j = (i + 1) % cycle.len();
        if sides[i] <= 0 {
            ends.push(out, Corner { at: vertices.keep(cycle[i].at), across: cycle[i].across }, sides[i] == 0, plane);
        }
        if sides[i] * sides[j] < 0 {
            let at = vertices.cut(cycle[i].at, cycle[j].at);
            ends.push(out, Corner { at, across: cycle[i].across }, true, plane);
        }
    }
    if out.len() > 2
        && ends.first
        && ends.last
        && let Some(last) = out.last_mut()
    {
        last.across = plane;
    }
}

/// Whether the first and the last corner pushed so far lie on the cutting plane.
#[derive(Debug, Default)]
struct OnPlaneEnds {
    first: bool,
    last: bool,
}

impl OnPlaneEnds {
    /// Appends a corner; an edge between two corners on the plane lies in it.
    fn push<V>(&mut self, out: &mut Vec<Corner<V>>, corner: Corner<V>, on: bool, plane: u32) {
        match out.last_mut() {
            Some(last) if self.last && on => last.across = plane,
            Some(_) => {}
            None => self.first = on,
        }
        out.push(corner);
        self.last = on;
    }
}

/// Where segment `a`-`b` crosses a plane, from the ends' plane offsets `sa` and `sb` of opposite
/// signs. Computed from the lexicographically smaller end, so both orders give the same bits.
pub(super) fn cut_point(a: DVec3, sa: f64, b: DVec3, sb: f64) -> DVec3 {
    let a_first = a.to_array().partial_cmp(&b.to_array()) != Some(std::cmp::Ordering::Greater);
    let ((p, sp), (q, sq)) = if a_first { ((a, sa), (b, sb)) } else { ((b, sb), (a, sa)) };
    p + (q - p) * (sp / (sp - sq))
}

pub(super) fn plane_parts(plane: &[f64; 4]) -> (DVec3, f64) {
    (DVec3::new(plane[0], plane[1], plane[2]), plane[3])
}

/// Side of a plane offset: -1 inside, 0 within `tolerance` of the plane, +1 outside.
pub(super) fn side(offset: f64, tolerance: f64) -> i8 {
    if offset > tolerance {
        1
    } else if offset < -tolerance {
        -1
    } else {
        0
    }
}

/// Points of a triangle's pieces: kept as they are, cut where the plane crosses.
struct PlaneCut {
    normal: DVec3,
    offset: f64,
}

impl PlaneCut {
    fn offset_of(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.offset
    }
}

impl ClipVertices<DVec3> for PlaneCut {
    fn keep(&mut self, v: DVec3) -> DVec3 {
        v
    }

    fn cut(&mut self, a: DVec3, b: DVec3) -> DVec3 {
        cut_point(a, self.offset_of(a), b, self.offset_of(b))
    }
}

/// Clips a triangle to the cell planes `cutting` (id, plane); the piece goes to `piece`. False
/// when nothing of it has area inside.
pub(super) fn clip_triangle(
    corners: [DVec3; 3],
    cutting: &[(u32, [f64; 4])],
    piece: &mut Vec<Corner<DVec3>>,
    scratch: &mut Vec<Corner<DVec3>>,
) -> bool {
    piece.clear();
    piece.extend(corners.map(|at| Corner { at, across: MESH_EDGE }));
    let mut sides = Vec::with_capacity(8);
    for (id, plane) in cutting {
        let (normal, offset) = plane_parts(plane);
        let mut cut = PlaneCut { normal, offset };
        sides.clear();
        sides.extend(piece.iter().map(|c| side(cut.offset_of(c.at), 0.0)));
        if sides.iter().all(|&s| s < 0) {
            continue;
        }
        if sides.iter().all(|&s| s >= 0) {
            return false;
        }
        clip_cycle(piece, &sides, *id, &mut cut, scratch);
        std::mem::swap(piece, scratch);
    }
    true
}
