//! The terms of a cell's volume by the divergence theorem: cones from the site over the surface
//! pieces, and the area of each face's part inside the mesh by Green's theorem on its boundary
//! (the cut curve, and the stretches of the face's edges counted with their winding numbers).

use glam::DVec3;

use super::clipping::Corner;
use crate::mesh_query::closest_on_segment;

/// Twice the signed area that segment `a`-`b` adds by Green's theorem in a plane with unit normal
/// `normal`, about the point `origin` in it.
pub(super) fn green(normal: DVec3, origin: DVec3, a: DVec3, b: DVec3) -> f64 {
    normal.dot((a - origin).cross(b - origin))
}

/// A point where the surface crosses the boundary of a face.
#[derive(Debug, Clone, Copy)]
pub(super) struct Crossing {
    at: DVec3,
    /// How the winding number changes here going round the face: +1 where the boundary enters
    /// the mesh, -1 where it leaves.
    change: i32,
}

/// The loose ends of a cut curve: where the face's boundary leaves it for an edge of the face
/// (an entry: more segments end there than start) or comes back to it (an exit). Segments of
/// neighbouring pieces meet at bit-identical points, so the ends are where the surface crosses
/// the face's edges, whether inside a piece or at a mesh edge or vertex.
pub(super) fn curve_ends(curve: &[(DVec3, DVec3)]) -> Vec<Crossing> {
    let key = |p: DVec3| (p + DVec3::ZERO).to_array().map(f64::to_bits);
    let mut ends: Vec<([u64; 3], DVec3, i32)> =
        curve.iter().flat_map(|&(a, b)| [(key(a), a, 1), (key(b), b, -1)]).collect();
    ends.sort_unstable_by_key(|end| end.0);
    let mut crossings = Vec::new();
    for group in ends.chunk_by(|x, y| x.0 == y.0) {
        let balance: i32 = group.iter().map(|end| end.2).sum();
        if balance != 0 {
            crossings.push(Crossing { at: group[0].1, change: -balance });
        }
    }
    crossings
}

/// The face's corners and crossings in order round the face, each with its change of winding
/// number (zero for a corner), each crossing on the edge nearest to it.
pub(super) fn place_crossings(face_loop: &[DVec3], crossings: &[Crossing]) -> Vec<(DVec3, i32)> {
    let count = face_loop.len();
    let edge = |k: usize| (face_loop[k], face_loop[(k + 1) % count]);
    let mut placed: Vec<(usize, f64, &Crossing)> = crossings
        .iter()
        .map(|crossing| {
            let distance = |k: usize| {
                let (a, b) = edge(k);
                closest_on_segment(a, b, crossing.at).distance_squared(crossing.at)
            };
            let k = (0..count).min_by(|&i, &j| distance(i).total_cmp(&distance(j))).unwrap_or(0);
            let (a, b) = edge(k);
            (k, (crossing.at - a).dot(b - a), crossing)
        })
        .collect();
    placed.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
    let mut events = Vec::with_capacity(count + placed.len());
    let mut next = placed.iter().peekable();
    for (k, &corner) in face_loop.iter().enumerate() {
        events.push((corner, 0));
        while let Some((_, _, crossing)) = next.next_if(|p| p.0 == k) {
            events.push((crossing.at, crossing.change));
        }
    }
    events
}

/// The stretches between consecutive events round a face, each with its level: the change of
/// the winding number since the first event. (The changes add up to zero round the face.)
pub(super) fn stretch_levels(events: &[(DVec3, i32)]) -> Vec<(DVec3, DVec3, i32)> {
    let mut level = 0;
    (0..events.len())
        .map(|k| {
            level += events[k].1;
            (events[k].0, events[(k + 1) % events.len()].0, level)
        })
        .collect()
}

/// Area of a planar polygon with unit normal `normal` (positive when counterclockwise about it).
pub(super) fn polygon_area(normal: DVec3, polygon: &[DVec3]) -> f64 {
    let origin = polygon[0];
    let count = polygon.len();
    0.5 * (1..count.saturating_sub(1)).map(|k| green(normal, origin, polygon[k], polygon[k + 1])).sum::<f64>()
}

/// Signed volume of the cone from `apex` over a planar piece (fan-triangulated).
pub(super) fn cone_volume(apex: DVec3, piece: &[Corner<DVec3>]) -> f64 {
    fan(piece).map(|[a, b, c]| (a - apex).dot((b - apex).cross(c - apex)) / 6.0).sum()
}

/// A convex polygon's fan triangles from its first corner.
pub(super) fn fan(piece: &[Corner<DVec3>]) -> impl Iterator<Item = [DVec3; 3]> + '_ {
    (1..piece.len().saturating_sub(1)).map(move |k| [piece[0].at, piece[k].at, piece[k + 1].at])
}
