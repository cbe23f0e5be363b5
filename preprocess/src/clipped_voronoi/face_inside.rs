//! The part of a cell face inside the mesh as triangles: the points of its boundary (the cut
//! curve and the stretches of the face's edges inside the mesh) triangulated by spade's
//! constrained Delaunay triangulation with the boundary as constraints. Each triangle's winding
//! number is found by walking across the triangulation's edges from outside (it steps by the
//! boundary segments along each edge), never by a point test, so the triangles' edges cancel
//! exactly but for the boundary. The part may be non-convex and in several pieces.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap, HashMap, VecDeque};

use glam::{DVec2, DVec3};
use spade::handles::FixedVertexHandle;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

/// Triangles, counter-clockwise about `normal`, covering the region of their plane that
/// `boundary` bounds: segments running counter-clockwise about `normal` round the region (its
/// holes clockwise), each as many times as the region's winding number steps there. A triangle
/// comes as many times as the boundary winds round it, clockwise where the winding number is
/// negative (where a self-overlapping surface counts volume twice or negatively, its faces
/// close up with it).
///
/// The triangles' edges are exactly the boundary's segments (as a chain: each directed edge
/// comes as many more times than its reverse as the boundary runs along it) whatever the
/// rounding: the winding numbers are propagated across the triangulation's edges, and where a
/// segment cannot be an edge of the triangulation (it crosses another segment, where the surface
/// overlaps itself; or two boundary points fall on one point of the plane) the difference
/// between the segment and a path of edges joining its ends is closed by a fan of thin
/// triangles along it.
pub(super) fn region_triangles(normal: DVec3, boundary: &[(DVec3, DVec3)]) -> Vec<[DVec3; 3]> {
    let Boundary { points, segments } = Boundary::new(boundary);
    let Some(&[first, _]) = segments.first() else {
        return Vec::new();
    };
    let origin = points[first as usize];
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    let flat = |p: DVec3| DVec2::new((p - origin).dot(u), (p - origin).dot(v));
    let Some(mut face) = FaceTriangulation::new(&points, flat) else {
        return Vec::new(); // not finite: nothing to triangulate
    };
    let paths = face.constrain(&segments);
    let (steps, mut corrections) = face.winding_steps(&segments, &paths);
    let winding = face.windings(&steps);
    let triangles = face.cdt.inner_faces().flat_map(|triangle| {
        let [a, b, c] = triangle.vertices().map(|vertex| face.point_of[vertex.fix().index()]);
        let winding = winding[triangle.fix().index()].unwrap_or(0);
        let triangle = if winding < 0 { [a, c, b] } else { [a, b, c] };
        std::iter::repeat_n(triangle, winding.unsigned_abs() as usize)
    });
    if corrections.count.is_empty() {
        triangles.map(|triangle| triangle.map(|k| points[k as usize])).collect()
    } else {
        // the triangulation's triangles and the fans together, a triangle and its reverse cancelling
        for triangle in triangles {
            corrections.add_triangle(triangle, 1);
        }
        corrections.triangles(&points)
    }
}

/// A boundary's points, each once (by its bits), and its segments between them (by point id).
struct Boundary {
    points: Vec<DVec3>,
    /// Segments between two different points.
    segments: Vec<[u32; 2]>,
}

impl Boundary {
    /// The points and segments of `boundary`.
    fn new(boundary: &[(DVec3, DVec3)]) -> Boundary {
        let key = |p: DVec3| (p + DVec3::ZERO).to_array().map(f64::to_bits);
        let mut id_of: HashMap<[u64; 3], u32> = HashMap::new();
        let mut points: Vec<DVec3> = Vec::new();
        let mut id = |p: DVec3| {
            *id_of.entry(key(p)).or_insert_with(|| {
                points.push(p);
                points.len() as u32 - 1
            })
        };
        let segments: Vec<[u32; 2]> = boundary.iter().map(|&(a, b)| [id(a), id(b)]).filter(|[a, b]| a != b).collect();
        Boundary { points, segments }
    }
}

/// The constrained Delaunay triangulation of a boundary's points in their plane. Every point is
/// a vertex; points that fall on one point of the plane share it, and the vertex stands for the
/// first of them.
struct FaceTriangulation {
    cdt: ConstrainedDelaunayTriangulation<Point2<f64>>,
    /// Each point's vertex index.
    vertex_of: Vec<usize>,
    /// Each vertex's point id.
    point_of: Vec<u32>,
}

/// Each segment's path of vertices in the triangulation, by its ends' vertices (either way
/// round); None where there is none.
struct SegmentPaths(HashMap<[usize; 2], Option<Vec<usize>>>);

impl SegmentPaths {
    /// The path from vertex `from` to vertex `to`.
    fn between(&self, from: usize, to: usize) -> Vec<usize> {
        if from == to {
            return vec![from];
        }
        match (self.0.get(&[from, to]), self.0.get(&[to, from])) {
            (Some(Some(path)), _) => path.clone(),
            (_, Some(Some(path))) => path.iter().rev().copied().collect(),
            _ => Vec::new(), // no path (cannot happen: the triangulation is connected)
        }
    }
}

impl FaceTriangulation {
    /// The triangulation of `points`, placed in the plane by `flat`; None when a point is not
    /// finite.
    fn new(points: &[DVec3], flat: impl Fn(DVec3) -> DVec2) -> Option<FaceTriangulation> {
        let mut cdt: ConstrainedDelaunayTriangulation<Point2<f64>> = ConstrainedDelaunayTriangulation::new();
        let mut vertex_of = Vec::with_capacity(points.len());
        let mut point_of: Vec<u32> = Vec::new(); // by vertex index
        for (k, &p) in points.iter().enumerate() {
            let q = flat(p);
            let handle = cdt.insert(Point2::new(q.x, q.y)).ok()?;
            if handle.index() >= point_of.len() {
                point_of.resize(handle.index() + 1, k as u32);
            }
            vertex_of.push(handle.index());
        }
        Some(FaceTriangulation { cdt, vertex_of, point_of })
    }

    /// Adds `segments` as constraints: each segment's path of vertices is the constraint edge
    /// (split where it runs through other vertices), or, where it would cross a constraint, the
    /// shortest path.
    fn constrain(&mut self, segments: &[[u32; 2]]) -> SegmentPaths {
        let cdt = &mut self.cdt;
        let mut paths: HashMap<[usize; 2], Option<Vec<usize>>> = HashMap::new(); // by ends, either way
        for &[a, b] in segments {
            let (from, to) = (self.vertex_of[a as usize], self.vertex_of[b as usize]);
            if from == to || paths.contains_key(&[from, to]) || paths.contains_key(&[to, from]) {
                continue;
            }
            let edges = cdt.try_add_constraint(FixedVertexHandle::from_index(from), FixedVertexHandle::from_index(to));
            let mut path = vec![from];
            for edge in edges {
                let edge = cdt.directed_edge(edge);
                if Some(&edge.from().fix().index()) != path.last() {
                    break;
                }
                path.push(edge.to().fix().index());
            }
            paths.insert([from, to], (path.len() > 1 && path.last() == Some(&to)).then_some(path));
        }
        let refused: Vec<[usize; 2]> = paths.iter().filter(|(_, path)| path.is_none()).map(|(&ends, _)| ends).collect();
        if !refused.is_empty() {
            let mut graph: Vec<Vec<(usize, f64)>> = vec![Vec::new(); self.point_of.len()];
            for edge in cdt.directed_edges() {
                let [from, to] = [edge.from(), edge.to()].map(|vertex| vertex.position());
                graph[edge.from().fix().index()].push((edge.to().fix().index(), (from.x - to.x).hypot(from.y - to.y)));
            }
            for [from, to] in refused {
                paths.insert([from, to], shortest_path(&graph, from, to));
            }
        }
        SegmentPaths(paths)
    }

    /// How the winding number steps across each directed edge (by the paths of `segments` along
    /// it), and the fans that close what the paths miss of the segments.
    fn winding_steps(&self, segments: &[[u32; 2]], paths: &SegmentPaths) -> (HashMap<[usize; 2], i32>, TriangleChain) {
        let point_of = &self.point_of;
        let mut steps: HashMap<[usize; 2], i32> = HashMap::new();
        let mut corrections = TriangleChain::default();
        for &[a, b] in segments {
            let (va, vb) = (self.vertex_of[a as usize], self.vertex_of[b as usize]);
            let path = paths.between(va, vb);
            for pair in path.windows(2) {
                *steps.entry([pair[0], pair[1]]).or_default() += 1;
                *steps.entry([pair[1], pair[0]]).or_default() -= 1;
            }
            if path.len() != 2 || point_of[va] != a || point_of[vb] != b {
                // what the path misses of the segment: the cycle a, b, the path back from b's
                // vertex to a's, closed by a fan from a (thin triangles along the segment)
                let mut cycle = vec![a, b];
                cycle.extend(path.iter().rev().map(|&vertex| point_of[vertex]));
                corrections.add_fan(&cycle, 1);
            }
        }
        (steps, corrections)
    }

    /// The winding number of each face (by index): zero outside, stepping by `steps` across
    /// each edge.
    fn windings(&self, steps: &HashMap<[usize; 2], i32>) -> Vec<Option<i32>> {
        let cdt = &self.cdt;
        let mut across: Vec<Vec<(usize, i32)>> = vec![Vec::new(); cdt.num_all_faces()];
        for edge in cdt.directed_edges() {
            let (left, right) = (edge.face().fix().index(), edge.rev().face().fix().index());
            let step = steps.get(&[edge.from().fix().index(), edge.to().fix().index()]).copied().unwrap_or(0);
            across[left].push((right, -step));
        }
        let mut winding: Vec<Option<i32>> = vec![None; across.len()];
        let outer = cdt.outer_face().fix().index();
        winding[outer] = Some(0);
        let mut queue = VecDeque::from([outer]);
        while let Some(face) = queue.pop_front() {
            let here = winding[face].unwrap_or(0);
            for &(next, step) in &across[face] {
                if winding[next].is_none() {
                    winding[next] = Some(here + step);
                    queue.push_back(next);
                }
            }
        }
        winding
    }
}

/// Triangles on point ids with multiplicities, a triangle and its reverse cancelling.
#[derive(Default)]
struct TriangleChain {
    /// Keyed by the ids rotated to put the smallest first and the other two ascending; the count
    /// is negative for the other orientation.
    count: BTreeMap<[u32; 3], i32>,
}

impl TriangleChain {
    fn add_triangle(&mut self, [a, b, c]: [u32; 3], times: i32) {
        if a == b || b == c || c == a || times == 0 {
            return; // two corners the same: its edges cancel
        }
        let [first, second, third] = if a < b && a < c {
            [a, b, c]
        } else if b < c {
            [b, c, a]
        } else {
            [c, a, b]
        };
        let (key, sign) = if second < third { ([first, second, third], 1) } else { ([first, third, second], -1) };
        *self.count.entry(key).or_default() += sign * times;
    }

    /// The fan from the first corner over a closed polygon (its edges are the polygon's).
    fn add_fan(&mut self, polygon: &[u32], times: i32) {
        for k in 1..polygon.len().saturating_sub(1) {
            self.add_triangle([polygon[0], polygon[k], polygon[k + 1]], times);
        }
    }

    fn triangles(&self, points: &[DVec3]) -> Vec<[DVec3; 3]> {
        self.count
            .iter()
            .flat_map(|(&[a, b, c], &count)| {
                let triangle = if count > 0 { [a, b, c] } else { [a, c, b] };
                std::iter::repeat_n(triangle.map(|k| points[k as usize]), count.unsigned_abs() as usize)
            })
            .collect()
    }
}

/// The shortest path of edges from vertex `from` to `to` (Dijkstra), `None` when there is none.
fn shortest_path(graph: &[Vec<(usize, f64)>], from: usize, to: usize) -> Option<Vec<usize>> {
    let mut distance = vec![f64::INFINITY; graph.len()];
    let mut previous = vec![usize::MAX; graph.len()];
    let mut heap = BinaryHeap::new();
    distance[from] = 0.0;
    heap.push(Reverse((Ordered(0.0), from)));
    while let Some(Reverse((Ordered(d), vertex))) = heap.pop() {
        if vertex == to {
            break;
        }
        if d > distance[vertex] {
            continue;
        }
        for &(next, length) in &graph[vertex] {
            if d + length < distance[next] {
                distance[next] = d + length;
                previous[next] = vertex;
                heap.push(Reverse((Ordered(d + length), next)));
            }
        }
    }
    if previous[to] == usize::MAX {
        return None;
    }
    let mut path = vec![to];
    while let Some(&last) = path.last()
        && last != from
    {
        path.push(previous[last]);
    }
    path.reverse();
    Some(path)
}

/// An f64 ordered by `total_cmp`, for the heap.
#[derive(Clone, Copy, PartialEq)]
struct Ordered(f64);

impl Eq for Ordered {}

impl PartialOrd for Ordered {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Ordered {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
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

    /// The directed edges of `triangles` minus the segments of `boundary`, by exact bits, that
    /// do not cancel with their reverses: empty when the triangles' edges are exactly the
    /// boundary (as a chain).
    fn unmatched(triangles: &[[DVec3; 3]], boundary: &[(DVec3, DVec3)]) -> Vec<(DVec3, DVec3, i32)> {
        let key = |p: DVec3| p.to_array().map(f64::to_bits);
        type Bits = [[u64; 3]; 2];
        let mut net: HashMap<Bits, (DVec3, DVec3, i32)> = HashMap::new();
        let mut add = |a: DVec3, b: DVec3, times: i32| {
            let (ka, kb) = (key(a), key(b));
            if ka < kb {
                net.entry([ka, kb]).or_insert((a, b, 0)).2 += times;
            } else if kb < ka {
                net.entry([kb, ka]).or_insert((b, a, 0)).2 -= times;
            }
        };
        for t in triangles {
            for k in 0..3 {
                add(t[k], t[(k + 1) % 3], 1);
            }
        }
        for &(a, b) in boundary {
            add(a, b, -1);
        }
        net.into_values().filter(|edge| edge.2 != 0).collect()
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
        assert!(unmatched(&triangles, &boundary).is_empty());
        assert!(unmatched(&below, &reversed).is_empty());
    }

    #[test]
    fn a_boundary_that_crosses_itself_is_closed_up_exactly() {
        // Where the surface intersects itself, the cut curve crosses itself on the face: two
        // overlapping squares (winding number 2 where they overlap), and a long thin loop
        // crossing both. Their segments cannot all be edges of one triangulation; the triangles'
        // edges must still be exactly the boundary's (they were not when the crossing segments
        // were left out and a point test at each triangle's centre decided its winding number).
        let z = -0.25;
        let p = |x: f64, y: f64| DVec3::new(x, y, z);
        let mut boundary = closed(&[p(0.0, 0.0), p(2.0, 0.0), p(2.0, 2.0), p(0.0, 2.0)]);
        boundary.extend(closed(&[p(1.0, 1.0), p(3.0, 1.0), p(3.0, 3.0), p(1.0, 3.0)]));
        boundary.extend(closed(&[p(-0.5, 1.5), p(3.5, 1.4), p(3.5, 1.6)]));
        let triangles = region_triangles(DVec3::Z, &boundary);
        assert_eq!(unmatched(&triangles, &boundary), []);
        // the area counts the overlaps with their winding numbers: 4 + 4 + the thin loop's 0.4
        assert!((area(&triangles, DVec3::Z) - 8.4).abs() < 1e-12, "area {}", area(&triangles, DVec3::Z));
        // a figure of eight: winding number +1 in one lobe, -1 in the other
        let eight = closed(&[p(0.0, 0.0), p(1.0, 1.0), p(1.0, 0.0), p(0.0, 1.0)]);
        let triangles = region_triangles(DVec3::Z, &eight);
        assert_eq!(unmatched(&triangles, &eight), []);
        assert!(area(&triangles, DVec3::Z).abs() < 1e-12);
    }

    #[test]
    fn points_that_fall_on_one_point_of_the_plane_keep_their_own_edges() {
        // a square whose loop comes back to its first corner through a point just above it
        // (the same point once projected on the plane)
        let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let above = p(0.0, 0.0, 1e-12);
        let boundary = vec![
            (p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0)),
            (p(1.0, 0.0, 0.0), p(1.0, 1.0, 0.0)),
            (p(1.0, 1.0, 0.0), p(0.0, 1.0, 0.0)),
            (p(0.0, 1.0, 0.0), above),
            (above, p(0.0, 0.0, 0.0)),
        ];
        let triangles = region_triangles(DVec3::Z, &boundary);
        assert_eq!(unmatched(&triangles, &boundary), []);
        assert!((area(&triangles, DVec3::Z) - 1.0).abs() < 1e-12);
    }
}
