//! The part of a cell face inside the mesh as triangles: the points of its boundary (the cut
//! curve and the stretches of the face's edges inside the mesh) triangulated by spade's
//! constrained Delaunay triangulation with the boundary as constraints, keeping the triangles the
//! boundary winds round. The part may be non-convex and in several pieces.

use glam::{DVec2, DVec3};
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

/// Triangles, counter-clockwise about `normal`, covering the region of their plane that
/// `boundary` bounds: segments running counter-clockwise about `normal` round the region (its
/// holes clockwise), each as many times as the region's winding number steps there. A triangle
/// comes as many times as the boundary winds round it, clockwise where the winding number is
/// negative (where a self-overlapping surface counts volume twice or negatively, its faces
/// close up with it). Segments that would cross others are left out of the constraints; the
/// winding test still decides each triangle.
pub(super) fn region_triangles(normal: DVec3, boundary: &[(DVec3, DVec3)]) -> Vec<[DVec3; 3]> {
    let Some(&(origin, _)) = boundary.first() else {
        return Vec::new();
    };
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    let flat = |p: DVec3| DVec2::new((p - origin).dot(u), (p - origin).dot(v));
    let mut cdt: ConstrainedDelaunayTriangulation<Point2<f64>> = ConstrainedDelaunayTriangulation::new();
    let mut at = Vec::new(); // the 3D point of each CDT vertex, by handle index
    let mut constraints = Vec::with_capacity(boundary.len());
    for &(a, b) in boundary {
        let mut ends = [None, None];
        for (end, p) in ends.iter_mut().zip([a, b]) {
            let q = flat(p);
            if let Ok(handle) = cdt.insert(Point2::new(q.x, q.y)) {
                if handle.index() >= at.len() {
                    at.resize(handle.index() + 1, p);
                }
                *end = Some(handle);
            }
        }
        if let [Some(ha), Some(hb)] = ends {
            constraints.push((ha, hb));
        }
    }
    for (a, b) in constraints {
        if a != b && cdt.can_add_constraint(a, b) {
            cdt.add_constraint(a, b);
        }
    }
    let flat_boundary: Vec<(DVec2, DVec2)> = boundary.iter().map(|&(a, b)| (flat(a), flat(b))).collect();
    cdt.inner_faces()
        .flat_map(|face| {
            let vertices = face.vertices();
            let [pa, pb, pc] = vertices.map(|vertex| {
                let p = vertex.position();
                DVec2::new(p.x, p.y)
            });
            // slivers stay (dropping one would leave its edges unmatched)
            let winding = winding_number((pa + pb + pc) / 3.0, &flat_boundary);
            let [a, b, c] = vertices.map(|vertex| at[vertex.fix().index()]);
            let triangle = if winding < 0 { [a, c, b] } else { [a, b, c] };
            std::iter::repeat_n(triangle, winding.unsigned_abs() as usize)
        })
        .collect()
}

/// How many times the closed segments `boundary` wind round `p` (counter-clockwise positive).
fn winding_number(p: DVec2, boundary: &[(DVec2, DVec2)]) -> i32 {
    let mut winding = 0;
    for &(a, b) in boundary {
        let side = (b - a).perp_dot(p - a);
        if a.y <= p.y {
            if b.y > p.y && side > 0.0 {
                winding += 1;
            }
        } else if b.y <= p.y && side < 0.0 {
            winding -= 1;
        }
    }
    winding
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(triangles: &[[DVec3; 3]], normal: DVec3) -> f64 {
        triangles.iter().map(|[a, b, c]| 0.5 * normal.dot((*b - *a).cross(*c - *a))).sum()
    }

    fn closed(points: &[DVec3]) -> Vec<(DVec3, DVec3)> {
        (0..points.len()).map(|k| (points[k], points[(k + 1) % points.len()])).collect()
    }

    #[test]
    fn a_non_convex_region_with_a_hole_is_covered_exactly() {
        // an L-shaped region of area 3 in the plane z = 1 with a 0.25 x 0.25 hole, normal +z
        let z = 1.0;
        let p = |x: f64, y: f64| DVec3::new(x, y, z);
        let mut boundary = closed(&[p(0.0, 0.0), p(2.0, 0.0), p(2.0, 1.0), p(1.0, 1.0), p(1.0, 2.0), p(0.0, 2.0)]);
        // the hole runs clockwise
        boundary.extend(closed(&[p(0.25, 0.25), p(0.25, 0.5), p(0.5, 0.5), p(0.5, 0.25)]));
        let triangles = region_triangles(DVec3::Z, &boundary);
        assert!((area(&triangles, DVec3::Z) - (3.0 - 0.0625)).abs() < 1e-12);
        assert!(triangles.iter().all(|[a, b, c]| DVec3::Z.dot((*b - *a).cross(*c - *a)) > 0.0), "counter-clockwise");
        // seen from below, the same loops reversed cover the same region
        let reversed: Vec<(DVec3, DVec3)> = boundary.iter().map(|&(a, b)| (b, a)).collect();
        let below = region_triangles(-DVec3::Z, &reversed);
        assert!((area(&below, -DVec3::Z) - (3.0 - 0.0625)).abs() < 1e-12);
        assert!(region_triangles(DVec3::Z, &[]).is_empty());
    }
}
