//! Spatial queries on a closed triangle mesh, answered by a bounding volume hierarchy (BVH) over
//! its triangles (median splits of the centroids along the widest axis, four triangles a leaf): an
//! exact point-in-mesh test and winding number, the distance to the surface (nearest-first
//! search), and the triangles near a box.
//!
//! # The inside test
//!
//! [`MeshQuery::contains`] counts the signed crossings of the mesh with the line through the point
//! parallel to an axis, like [`crate::inside`] does for lattice lines. Whether the line meets a
//! triangle is decided by exact orientation predicates ([`robust::orient2d`]) with the line
//! symbolically moved off the triangle's edges and vertices (simulation of simplicity), so a line
//! through a shared edge or vertex meets exactly one of the triangles around it; whether a
//! crossing lies before or after the point is decided exactly by [`robust::orient3d`]. On a closed
//! mesh the answer is therefore exact. A point on the surface is not inside. A line whose winding
//! does not return to zero has passed through a hole: the point is then decided by a vote of the
//! lines along the other two axes, with the same rule as [`crate::inside::inside_cells`], so the
//! two agree on lattice cell centres. [`MeshQuery::winding_number`] returns the signed count itself
//! (from the first line that does not leak).

use glam::DVec3;
use robust::{Coord, Coord3D, orient2d, orient3d};

use crate::inside::FillRule;
use shatter_geometry::mesh::TriangleMesh;

/// Triangles per leaf.
const LEAF_SIZE: usize = 4;

/// The deepest a median-split tree over `u32::MAX` triangles can be, with room to spare.
const MAX_DEPTH: usize = 64;

/// A node of the hierarchy: the box around its triangles.
#[derive(Debug, Clone, Copy)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: its first triangle (in hierarchy order). Inner node: its second child (the first is
    /// the next node).
    index: u32,
    /// Leaf: its number of triangles (at least one). Inner node: zero.
    count: u32,
}

/// A closed triangle mesh prepared for point queries. Built once, then shared by threads.
#[derive(Debug, Clone)]
pub struct MeshQuery {
    nodes: Vec<Node>,
    /// Triangle corners in hierarchy order.
    corners: Vec<[DVec3; 3]>,
    /// The mesh's index of each triangle in hierarchy order.
    ids: Vec<u32>,
    rule: FillRule,
}

/// What the line through a point along one axis says about it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct LineVerdict {
    inside: bool,
    /// The line passed through a hole: its crossings do not balance.
    leaky: bool,
    /// The winding number at the point: the signed crossings before it.
    winding: i32,
}

impl MeshQuery {
    /// Prepares `mesh` for queries, filling with the non-zero winding rule (meshes whose
    /// triangles are consistently wound, as [`crate::repair::repair`] reports them).
    pub fn new(mesh: &TriangleMesh) -> MeshQuery {
        MeshQuery::with_fill_rule(mesh, FillRule::NonZero)
    }

    /// Prepares `mesh` for queries, deciding inside by `rule`.
    pub fn with_fill_rule(mesh: &TriangleMesh, rule: FillRule) -> MeshQuery {
        assert!(u32::try_from(mesh.triangles.len()).is_ok(), "a mesh query holds at most u32::MAX triangles");
        let corners: Vec<[DVec3; 3]> = (0..mesh.triangles.len()).map(|t| mesh.corners(t)).collect();
        let centroids: Vec<DVec3> = corners.iter().map(|[a, b, c]| (*a + *b + *c) / 3.0).collect();
        let mut ids: Vec<u32> = (0..corners.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * corners.len() / LEAF_SIZE + 1);
        build(&corners, &centroids, &mut ids, 0, &mut nodes);
        let corners = ids.iter().map(|&id| corners[id as usize]).collect();
        MeshQuery { nodes, corners, ids, rule }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// True when the mesh has no triangle.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Every triangle as (its index in the mesh, its corners), in no particular order.
    pub fn triangles(&self) -> impl ExactSizeIterator<Item = (u32, [DVec3; 3])> + '_ {
        self.ids.iter().copied().zip(self.corners.iter().copied())
    }

    /// Is `p` strictly inside the mesh? Exact on a closed mesh; a point on the surface is not
    /// inside. See the [module documentation](self).
    pub fn contains(&self, p: DVec3) -> bool {
        if self.is_empty() || self.on_surface(p) {
            return false;
        }
        let along_z = self.line_verdict(p, 2);
        if !along_z.leaky {
            return along_z.inside;
        }
        vote(&[along_z, self.line_verdict(p, 0), self.line_verdict(p, 1)])
    }

    /// The winding number of the surface about `p` (how many times the surface wraps round it,
    /// counted with orientation: 1 inside a simple closed mesh, 0 outside, more where the surface
    /// overlaps itself, negative inside an inverted fold), exact on a closed mesh. Counted along
    /// the first of the lines through `p` along z, x and y that does not pass through a hole;
    /// `None` when all three do, or when `p` is on the surface.
    pub fn winding_number(&self, p: DVec3) -> Option<i32> {
        if self.on_surface(p) {
            return None;
        }
        [2, 0, 1].into_iter().map(|axis| self.line_verdict(p, axis)).find(|v| !v.leaky).map(|v| v.winding)
    }

    /// Is `p` exactly on a triangle (its closed interior, edges or corners)?
    pub fn on_surface(&self, p: DVec3) -> bool {
        let hit = std::cell::Cell::new(false);
        self.visit(
            |lo, hi| !hit.get() && p.cmpge(lo).all() && p.cmple(hi).all(),
            |k| hit.set(hit.get() || point_on_triangle(&self.corners[k], p)),
        );
        hit.get()
    }

    /// Distance from `p` to the nearest point of the surface (infinite for an empty mesh).
    pub fn distance(&self, p: DVec3) -> f64 {
        self.closest(p).map_or(f64::INFINITY, |(_, q)| q.distance(p))
    }

    /// The nearest point of the surface to `p` and the mesh index of a triangle it lies on, or
    /// `None` for an empty mesh.
    pub fn closest(&self, p: DVec3) -> Option<(u32, DVec3)> {
        if self.is_empty() {
            return None;
        }
        let mut best = (u32::MAX, DVec3::INFINITY, f64::INFINITY);
        let mut stack = [(0u32, 0.0f64); MAX_DEPTH];
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let (index, box_distance_sq) = stack[depth];
            if box_distance_sq >= best.2 {
                continue;
            }
            let node = self.nodes[index as usize];
            if node.count > 0 {
                for k in node.index as usize..(node.index + node.count) as usize {
                    let q = closest_on_triangle(&self.corners[k], p);
                    let distance_sq = q.distance_squared(p);
                    if distance_sq < best.2 {
                        best = (self.ids[k], q, distance_sq);
                    }
                }
                continue;
            }
            // Push the farther child first, so the nearer one is searched first.
            let children = [index + 1, node.index].map(|c| (c, box_distance_squared(&self.nodes[c as usize], p)));
            let (near, far) =
                if children[0].1 <= children[1].1 { (children[0], children[1]) } else { (children[1], children[0]) };
            stack[depth] = far;
            stack[depth + 1] = near;
            depth += 2;
        }
        Some((best.0, best.1))
    }

    /// Appends to `found` the mesh index of every triangle whose bounding box meets the closed box
    /// `[lo, hi]` (a superset of the triangles that meet the box), in no particular order.
    pub fn triangles_in_box(&self, lo: DVec3, hi: DVec3, found: &mut Vec<u32>) {
        let overlaps = |a: DVec3, b: DVec3| a.cmple(hi).all() && b.cmpge(lo).all();
        self.visit(overlaps, |k| {
            let (a, b) = triangle_bounds(&self.corners[k]);
            if overlaps(a, b) {
                found.push(self.ids[k]);
            }
        });
    }

    /// Might the surface meet the closed box `[lo, hi]`? Conservative: false means no point of
    /// the surface lies in the box; true is exact up to a margin of a millionth of the box's size
    /// (see [`triangle_meets_box`]).
    pub fn touches_box(&self, lo: DVec3, hi: DVec3) -> bool {
        let hit = std::cell::Cell::new(false);
        let overlaps = |a: DVec3, b: DVec3| a.cmple(hi).all() && b.cmpge(lo).all();
        self.visit(
            |a, b| !hit.get() && overlaps(a, b),
            |k| hit.set(hit.get() || triangle_meets_box(&self.corners[k], lo, hi)),
        );
        hit.get()
    }

    /// Calls `leaf` with every triangle (hierarchy order) in the leaves under nodes whose boxes
    /// `enter` accepts.
    fn visit(&self, mut enter: impl FnMut(DVec3, DVec3) -> bool, mut leaf: impl FnMut(usize)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = [0u32; MAX_DEPTH];
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let index = stack[depth];
            let node = self.nodes[index as usize];
            if !enter(node.lo, node.hi) {
                continue;
            }
            if node.count > 0 {
                (node.index..node.index + node.count).for_each(|k| leaf(k as usize));
            } else {
                stack[depth] = node.index;
                stack[depth + 1] = index + 1;
                depth += 2;
            }
        }
    }

    /// Winding along the line through `p` parallel to `axis`, and whether the line leaks.
    fn line_verdict(&self, p: DVec3, axis: usize) -> LineVerdict {
        // (u, v, axis) is a right-handed cyclic permutation of (x, y, z).
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let (mut winding_before, mut crossings_before, mut winding_total, mut crossings_total) =
            (0i32, 0u32, 0i32, 0u32);
        self.visit(
            |lo, hi| lo[u] <= p[u] && p[u] <= hi[u] && lo[v] <= p[v] && p[v] <= hi[v],
            |k| {
                if let Some((winding, before)) = line_crossing(&self.corners[k], p, (u, v)) {
                    winding_total += winding;
                    crossings_total += 1;
                    if before {
                        winding_before += winding;
                        crossings_before += 1;
                    }
                }
            },
        );
        match self.rule {
            FillRule::NonZero => {
                LineVerdict { inside: winding_before != 0, leaky: winding_total != 0, winding: winding_before }
            }
            FillRule::EvenOdd => LineVerdict {
                inside: crossings_before % 2 == 1,
                leaky: crossings_total % 2 == 1,
                winding: winding_before,
            },
        }
    }
}

/// The majority of the lines that did not leak (ties count as inside), or of all three when all
/// leaked: the rule of [`crate::inside::inside_cells`].
fn vote(verdicts: &[LineVerdict; 3]) -> bool {
    let sound = verdicts.iter().filter(|v| !v.leaky);
    let (count, inside) = sound.fold((0, 0), |(count, inside), v| (count + 1, inside + usize::from(v.inside)));
    if count == 0 { verdicts.iter().filter(|v| v.inside).count() >= 2 } else { inside * 2 >= count }
}

/// Does the line through `p` along the third axis (after `u`, `v`), moved by (eps, eps^2) in
/// (u, v), cross the triangle? If so: the winding it adds (+1 entering the mesh, -1 leaving, going
/// in the axis' direction) and whether the crossing lies before `p`.
fn line_crossing(corners: &[DVec3; 3], p: DVec3, (u, v): (usize, usize)) -> Option<(i32, bool)> {
    let flat = corners.map(|c| Coord { x: c[u], y: c[v] });
    let area = orient2d(flat[0], flat[1], flat[2]);
    if area == 0.0 {
        return None; // parallel to the line: the moved line never meets it
    }
    let q = Coord { x: p[u], y: p[v] };
    let covers =
        [(1, 2), (2, 0), (0, 1)].iter().all(|&(i, j)| (perturbed_orient(flat[i], flat[j], q) > 0.0) == (area > 0.0));
    if !covers {
        return None;
    }
    // orient3d(a, b, c, p) = (a - p) . n, with n's axis component the projected area: the
    // crossing lies after p exactly when the two have the same sign. (Zero, p on the triangle,
    // is excluded by the caller.)
    let side = orient3d(coord3(corners[0]), coord3(corners[1]), coord3(corners[2]), coord3(p));
    let after = (side > 0.0) == (area > 0.0);
    // The normal points along the axis (positive projected area): going along it, we leave.
    Some((if area > 0.0 { -1 } else { 1 }, !after))
}

/// orient2d(a, b, q) with q moved by (eps, eps^2) for an infinitesimal eps: never zero for a != b.
/// Its sign is exact.
fn perturbed_orient(a: Coord<f64>, b: Coord<f64>, q: Coord<f64>) -> f64 {
    let exact = orient2d(a, b, q);
    if exact != 0.0 {
        return exact;
    }
    // d/d(eps) of (b - a) x (q + (eps, eps^2) - a) = -(b.y - a.y) eps + (b.x - a.x) eps^2.
    let positive = if b.y != a.y { a.y > b.y } else { b.x > a.x };
    if positive { 1.0 } else { -1.0 }
}

/// Exactly: does `p` lie on the closed triangle?
fn point_on_triangle(corners: &[DVec3; 3], p: DVec3) -> bool {
    let [a, b, c] = corners.map(coord3);
    if orient3d(a, b, c, coord3(p)) != 0.0 {
        return false;
    }
    // In the triangle's plane: test in the projection where it has the largest area.
    let normal = (corners[1] - corners[0]).cross(corners[2] - corners[0]).abs();
    let axis = normal.max_position();
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let flat = |q: DVec3| Coord { x: q[u], y: q[v] };
    let [fa, fb, fc] = corners.map(flat);
    let area = orient2d(fa, fb, fc);
    if area == 0.0 {
        return false; // degenerate: its neighbours answer for it
    }
    let q = flat(p);
    [(fa, fb), (fb, fc), (fc, fa)].iter().all(|&(x, y)| orient2d(x, y, q) * area.signum() >= 0.0)
}

/// The point of the closed triangle nearest to `p` (Ericson, Real-Time Collision Detection 5.1.5:
/// by the Voronoi regions of the corners, edges and face).
fn closest_on_triangle(corners: &[DVec3; 3], p: DVec3) -> DVec3 {
    let [a, b, c] = *corners;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denominator = va + vb + vc;
    if denominator == 0.0 {
        // Degenerate (collinear) triangle: the nearest of its edges.
        return [(a, b), (b, c), (c, a)]
            .map(|(x, y)| closest_on_segment(x, y, p))
            .into_iter()
            .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
            .unwrap_or(a);
    }
    a + ab * (vb / denominator) + ac * (vc / denominator)
}

/// The point of segment `[a, b]` nearest to `p`.
pub(crate) fn closest_on_segment(a: DVec3, b: DVec3, p: DVec3) -> DVec3 {
    let ab = b - a;
    let length_sq = ab.length_squared();
    if length_sq == 0.0 {
        return a;
    }
    a + ab * ((p - a).dot(ab) / length_sq).clamp(0.0, 1.0)
}

/// Might the closed triangle meet the closed box `[lo, hi]`? The separating axis test (the box's
/// axes, the triangle's normal, and the nine cross products of their edges) on the box grown by a
/// millionth of its size and by rounding's reach at these coordinates, so a false answer is
/// certain despite rounding.
pub fn triangle_meets_box(corners: &[DVec3; 3], lo: DVec3, hi: DVec3) -> bool {
    let centre = (lo + hi) * 0.5;
    let v = corners.map(|c| c - centre);
    let reach = v.iter().fold(centre.abs(), |m, p| m.max(p.abs())).max_element();
    let half = (hi - lo) * 0.5 * (1.0 + 1e-6) + DVec3::splat(1e-12 * reach);
    let separates = |axis: DVec3| {
        let projections = v.map(|p| axis.dot(p));
        let radius = half.dot(axis.abs());
        projections.iter().all(|&x| x > radius) || projections.iter().all(|&x| x < -radius)
    };
    let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    if axes.iter().any(|&axis| separates(axis)) || separates(edges[0].cross(edges[1])) {
        return false;
    }
    !edges.iter().any(|&edge| axes.iter().any(|&axis| separates(axis.cross(edge))))
}

/// Squared distance from `p` to a node's box (zero inside it).
fn box_distance_squared(node: &Node, p: DVec3) -> f64 {
    (node.lo - p).max(p - node.hi).max(DVec3::ZERO).length_squared()
}

fn triangle_bounds(corners: &[DVec3; 3]) -> (DVec3, DVec3) {
    (corners[0].min(corners[1]).min(corners[2]), corners[0].max(corners[1]).max(corners[2]))
}

fn coord3(p: DVec3) -> Coord3D<f64> {
    Coord3D { x: p.x, y: p.y, z: p.z }
}

/// Builds the subtree over `ids` (hierarchy positions `start..`), appending nodes depth first:
/// split at the median centroid along the axis where the centroids spread most.
fn build(corners: &[[DVec3; 3]], centroids: &[DVec3], ids: &mut [u32], start: usize, nodes: &mut Vec<Node>) {
    let (lo, hi) = ids.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &id| {
        let (a, b) = triangle_bounds(&corners[id as usize]);
        (lo.min(a), hi.max(b))
    });
    if ids.len() <= LEAF_SIZE {
        nodes.push(Node { lo, hi, index: start as u32, count: ids.len() as u32 });
        return;
    }
    let (centre_lo, centre_hi) = ids.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &id| {
        (lo.min(centroids[id as usize]), hi.max(centroids[id as usize]))
    });
    let axis = (centre_hi - centre_lo).max_position();
    let middle = ids.len() / 2;
    ids.select_nth_unstable_by(middle, |a, b| centroids[*a as usize][axis].total_cmp(&centroids[*b as usize][axis]));
    let here = nodes.len();
    nodes.push(Node { lo, hi, index: 0, count: 0 }); // `index` is set once the second child exists
    let (below, above) = ids.split_at_mut(middle);
    build(corners, centroids, below, start, nodes);
    nodes[here].index = nodes.len() as u32;
    build(corners, centroids, above, start + middle, nodes);
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::inside::inside_cells;
    use crate::lattice::Lattice;
    use crate::test_meshes::{cube, octahedron};

    /// Loads a mesh from the assets folder and repairs it as the pipeline does.
    fn asset(name: &str) -> TriangleMesh {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes").join(name);
        let (mesh, stats) = TriangleMesh::load_obj(&path).expect("test mesh loads");
        crate::repair::repair(&mesh, stats, 1e-3).0
    }

    /// Checks `contains` against `inside_cells` on every lattice centre that is not on the
    /// surface, and that centres on the surface are not inside. Returns (inside, on surface).
    fn agree_on_lattice(mesh: &TriangleMesh, lattice: &Lattice) -> (usize, usize) {
        let query = MeshQuery::new(mesh);
        let reference = inside_cells(mesh, lattice, FillRule::NonZero);
        let (mut inside, mut on_surface) = (0, 0);
        for (index, &expected) in reference.inside.iter().enumerate() {
            let centre = lattice.centre(lattice.cell(index));
            if query.on_surface(centre) {
                on_surface += 1;
                assert!(!query.contains(centre), "{centre} is on the surface");
                continue;
            }
            assert_eq!(query.contains(centre), expected, "at {centre}");
            inside += usize::from(expected);
        }
        (inside, on_surface)
    }

    #[test]
    fn a_lattice_aligned_cube_agrees_with_the_lattice_test() {
        // Lines through the cube's edges, the diagonals of its faces, and its corners.
        let mut mesh = cube(4.0);
        mesh.map_positions(|p| p - DVec3::splat(0.5));
        let lattice = Lattice { origin: DVec3::splat(-1.0), spacing: 0.5, dims: [12, 12, 12] };
        let (inside, on_surface) = agree_on_lattice(&mesh, &lattice);
        assert_eq!(inside, 7 * 7 * 7);
        assert_eq!(on_surface, 9 * 9 * 9 - 7 * 7 * 7);
    }

    #[test]
    fn lines_through_the_corners_of_an_octahedron_count_once() {
        let mesh = octahedron(1, 1.0, false);
        let lattice = Lattice { origin: DVec3::splat(-1.25), spacing: 0.25, dims: [11, 11, 11] };
        let (inside, on_surface) = agree_on_lattice(&mesh, &lattice);
        let query = MeshQuery::new(&mesh);
        for index in 0..lattice.cell_count() {
            let p = lattice.centre(lattice.cell(index));
            let norm = p.x.abs() + p.y.abs() + p.z.abs();
            assert_eq!(query.contains(p), norm < 1.0, "{p}");
            assert_eq!(query.on_surface(p), norm == 1.0, "{p}");
        }
        // Lattice points with |i| + |j| + |k| < 4 and == 4.
        assert_eq!((inside, on_surface), (63, 66));
    }

    #[test]
    fn a_hole_is_voted_away_as_the_lattice_test_does() {
        let mut mesh = cube(1.0);
        mesh.triangles.remove(0); // a hole in the z = 0 face
        let lattice = Lattice::covering(DVec3::splat(0.0), DVec3::splat(1.0), 0.1);
        let (inside, _) = agree_on_lattice(&mesh, &lattice);
        assert_eq!(inside, 1000);
    }

    #[test]
    fn winding_numbers_count_nested_and_inverted_shells() {
        let mut mesh = cube(3.0);
        let mut inner = cube(1.0);
        inner.map_positions(|p| p + DVec3::ONE);
        let offset = mesh.positions.len() as u32;
        mesh.positions.extend(inner.positions);
        mesh.triangles.extend(inner.triangles.iter().map(|t| t.map(|v| v + offset)));
        let (deep, shallow, out) = (DVec3::splat(1.5), DVec3::splat(0.5), DVec3::splat(4.0));
        let query = MeshQuery::new(&mesh);
        assert_eq!([deep, shallow, out].map(|p| query.winding_number(p)), [Some(2), Some(1), Some(0)]);
        assert!(query.contains(deep));
        assert_eq!(query.winding_number(DVec3::new(1.0, 1.5, 1.5)), None); // on the inner cube
        // Turned inside out, the inner cube is a cavity.
        let start = mesh.triangles.len() - 12;
        mesh.triangles[start..].iter_mut().for_each(|t| t.swap(1, 2));
        let query = MeshQuery::new(&mesh);
        assert_eq!([deep, shallow, out].map(|p| query.winding_number(p)), [Some(0), Some(1), Some(0)]);
        assert!(!query.contains(deep) && query.contains(shallow));
    }

    #[test]
    fn bob_agrees_with_the_lattice_test() {
        let mesh = asset("bob_tri.obj");
        let (lo, hi) = mesh.bounds();
        let lattice = Lattice::covering(lo, hi, (hi - lo).max_element() / 40.0);
        let (inside, _) = agree_on_lattice(&mesh, &lattice);
        assert!(inside > 1000);
    }

    #[test]
    fn distances_and_nearest_points_match_brute_force() {
        let mesh = octahedron(6, 1.0, true);
        let query = MeshQuery::new(&mesh);
        let mut rng = shatter_core::random::SplitMix64::new(9);
        for _ in 0..500 {
            let p = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 3.0 - 1.5;
            let brute = (0..mesh.triangles.len())
                .map(|t| closest_on_triangle(&mesh.corners(t), p).distance(p))
                .fold(f64::INFINITY, f64::min);
            assert_eq!(query.distance(p), brute);
            let (t, q) = query.closest(p).expect("non-empty");
            assert_eq!(closest_on_triangle(&mesh.corners(t as usize), p), q);
        }
        // A cube's distance field, inside and out.
        let query = MeshQuery::new(&cube(1.0));
        assert!((query.distance(DVec3::splat(0.5)) - 0.5).abs() < 1e-15);
        assert!((query.distance(DVec3::new(0.25, 0.5, 0.5)) - 0.25).abs() < 1e-15);
        assert!((query.distance(DVec3::new(2.0, 2.0, 0.5)) - 2f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn the_triangle_box_test_is_conservative_and_tight() {
        let (lo, hi) = (DVec3::ZERO, DVec3::ONE);
        // A large triangle through the box with every corner outside it, and one just beside it.
        let through = [DVec3::new(-5.0, -5.0, 0.5), DVec3::new(5.0, -5.0, 0.5), DVec3::new(0.0, 10.0, 0.5)];
        assert!(triangle_meets_box(&through, lo, hi));
        // In the planes x + y = 2.01 (missing the box's edge at x = y = 1) and x + y = 2 (touching it).
        let beside = [DVec3::new(3.01, -1.0, 0.0), DVec3::new(-1.0, 3.01, 0.0), DVec3::new(-1.0, 3.01, 1.0)];
        assert!(!triangle_meets_box(&beside, lo, hi));
        let touching = [DVec3::new(3.0, -1.0, 0.0), DVec3::new(-1.0, 3.0, 0.0), DVec3::new(-1.0, 3.0, 1.0)];
        assert!(triangle_meets_box(&touching, lo, hi));
        // Random triangles: whenever the test says no, no point of the triangle is in the box.
        let mut rng = shatter_core::random::SplitMix64::new(4);
        let mut point = || DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 3.0 - 1.0;
        let (mut met, mut missed) = (0, 0);
        for _ in 0..2000 {
            let corners = [point(), point(), point()];
            if triangle_meets_box(&corners, lo, hi) {
                met += 1;
                continue;
            }
            missed += 1;
            for i in 0..=20 {
                for j in 0..=20 - i {
                    let (u, v) = (i as f64 / 20.0, j as f64 / 20.0);
                    let p = corners[0] + (corners[1] - corners[0]) * u + (corners[2] - corners[0]) * v;
                    assert!(p.cmplt(lo).any() || p.cmpgt(hi).any(), "{corners:?} meets the box at {p}");
                }
            }
        }
        assert!(met > 100 && missed > 100);
    }

    #[test]
    fn box_queries_find_every_overlapping_triangle() {
        let mesh = octahedron(8, 1.0, true);
        let query = MeshQuery::new(&mesh);
        let (lo, hi) = (DVec3::new(-0.3, 0.1, -1.0), DVec3::new(0.4, 0.6, 0.2));
        let mut found = Vec::new();
        query.triangles_in_box(lo, hi, &mut found);
        found.sort_unstable();
        let expected: Vec<u32> = (0..mesh.triangles.len() as u32)
            .filter(|&t| {
                let (a, b) = triangle_bounds(&mesh.corners(t as usize));
                a.cmple(hi).all() && b.cmpge(lo).all()
            })
            .collect();
        assert!(!expected.is_empty());
        assert_eq!(found, expected);
        assert_eq!(query.len(), mesh.triangles.len());
    }
}
