//! Clipped Voronoi cells: the Voronoi diagram of a set of sites, cut to the inside of a closed
//! triangle mesh (the paper's "trimtopes": a convex polytope and the surface triangles inside it).
//!
//! # Cells
//!
//! A site's Voronoi neighbours are its neighbours in the Delaunay tetrahedralization of the sites
//! ([`crate::delaunay`]; every pair of sites when there are fewer than four or all are coplanar).
//! Its cell starts as a box around the mesh and the sites (10% larger on every side) and is cut by
//! the bisector plane of each neighbour, nearest first. The polytope is kept as shared vertices
//! and faces whose edges name the face across them; a plane cuts it by Sutherland-Hodgman on each
//! face, with vertices within 1e-12 of the box's size of the plane counted as on it, and the new
//! face is chained from the cut edges. Planes that leave no face are dropped; box faces remain
//! only where the cell reaches the box (always where it would be unbounded). The bisector of two
//! sites is computed once for the pair, so the two cells see exactly opposite planes.
//!
//! # Surface
//!
//! Each triangle whose bounding box meets the cell's is clipped by the cell's face planes
//! (Sutherland-Hodgman with the exact sign of the floating-point plane offset, so two cells split a
//! triangle along their shared plane at the same points up to rounding). Every edge of a clipped
//! piece remembers the face plane it lies on, if any. The pieces of all cells tile the surface.
//!
//! # Volume
//!
//! The region R = C ∩ M (C the cell, M the mesh interior) is bounded by the clipped pieces and by
//! the parts of C's faces that lie inside M. By the divergence theorem about the site s,
//!
//! V(R) = Σ over pieces of the signed volume of the cone from s over the piece
//!      + Σ over faces f of d_f · area(f ∩ M) / 3,
//!
//! with d_f the distance from s to f's plane. The area of f ∩ M is exact by Green's theorem on the
//! face: its boundary is the cut curve (the pieces' edges on f, taken against the pieces' own
//! orientation) and the stretches of f's edges inside M. The cut curve's segments meet at
//! bit-identical points (neighbouring pieces cut a shared mesh edge at the same point), so its
//! loose ends are exactly where the surface crosses the face's edges (each is put on the nearest
//! edge of the face, in order along it): an end where more segments
//! arrive than leave is where the boundary goes on along an edge into M (the winding number
//! rises by one going round the face), and the opposite end is where it leaves M. Walking round
//! the face from corner and crossing to the next gives every stretch's winding number relative to
//! the first; one exact winding number query ([`MeshQuery::winding_number`]) at the middle of the
//! longest stretch fixes them all, and each stretch counts as many times as its winding number. A
//! cell that no piece reaches is wholly inside or outside: one query at its site decides.
//!
//! Every term is thus exact up to rounding, and so is the total: the cells' volumes add up to
//! [`TriangleMesh::signed_volume`] and their pieces to the mesh's area. Where the surface overlaps
//! itself (the repaired Welsh dragon has a few tiny inverted folds, pockets of winding number -1)
//! volume counts with its winding number, as [`TriangleMesh::signed_volume`] counts it. Where the
//! mesh has holes, the winding number is undefined and stretches count 1 inside (by
//! [`MeshQuery::contains`]'s vote) and 0 outside.

use glam::DVec3;
use rayon::prelude::*;

use crate::delaunay::{DelaunayError, tetrahedralize};
use crate::mesh_query::{MeshQuery, closest_on_segment};
use shatter_geometry::mesh::TriangleMesh;

/// The label of a piece edge that lies on an edge of the original triangle, not on a cell face.
const MESH_EDGE: u32 = u32::MAX;

/// No vertex, face or site.
const NONE: u32 = u32::MAX;

/// The box's planes come first among a cell's planes.
const BOX_PLANES: u32 = 6;

/// The box around the mesh and the sites grows by this fraction of its largest extent per side.
const BOX_MARGIN: f64 = 0.1;

/// Vertices within this fraction of the box's scale of a plane count as on it.
const ON_PLANE: f64 = 1e-12;

/// A face shares a non-zero area inside the mesh when the inside part exceeds this fraction of it.
const SHARED_AREA: f64 = 1e-10;

/// One clipped Voronoi cell.
#[derive(Debug, Clone, PartialEq)]
pub struct ClippedCell {
    /// The convex cell: planes [nx, ny, nz, d] with unit outward normal, inside where n.x <= d.
    /// Bisector planes with Voronoi neighbours, plus bounding-box planes where the cell would be unbounded.
    pub planes: Vec<[f64; 4]>,
    /// The mesh triangles clipped to the cell (polygons fan-triangulated), outward winding.
    pub triangles: Vec<[DVec3; 3]>,
    /// Volume of cell ∩ mesh interior.
    /// (Counted with the winding number where the surface overlaps itself; see the module docs.)
    pub volume: f64,
}

/// The clipped Voronoi diagram of a set of sites.
#[derive(Debug, Clone, PartialEq)]
pub struct ClippedVoronoi {
    /// One cell per site, in the sites' order.
    pub cells: Vec<ClippedCell>,
    /// pairs (a, b), a < b, sorted: cells sharing a Voronoi face with non-zero area inside the mesh
    pub adjacency: Vec<[u32; 2]>,
}

/// Why a clipped Voronoi diagram cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum VoronoiError {
    /// No site was given.
    #[error("a Voronoi diagram needs at least one site")]
    NoSites,
    /// A site has a NaN or infinite coordinate.
    #[error("site {index} has a non-finite coordinate: {site}")]
    NonFinite {
        /// The site's index.
        index: usize,
        /// The site.
        site: DVec3,
    },
    /// Two sites coincide, so their cells are not defined.
    #[error("site {index} repeats site {of}")]
    Duplicate {
        /// The later site.
        index: usize,
        /// The earlier site with the same coordinates.
        of: usize,
    },
    /// The Delaunay tetrahedralization of the sites failed.
    #[error("the Delaunay tetrahedralization of the sites failed: {0}")]
    Delaunay(DelaunayError),
    /// A cell could not be cut consistently (nearly coincident planes).
    #[error("the Voronoi cell of site {index} is degenerate: its faces could not be closed")]
    DegenerateCell {
        /// The site's index.
        index: usize,
    },
}

/// Cuts the Voronoi diagram of `sites` to the inside of `mesh`, a closed, consistently wound
/// triangle mesh; `query` must have been built from `mesh`. Cells are computed in parallel; the
/// result does not depend on the thread count. See the [module documentation](self).
pub fn clipped_voronoi(
    sites: &[DVec3],
    mesh: &TriangleMesh,
    query: &MeshQuery,
) -> Result<ClippedVoronoi, VoronoiError> {
    validate(sites)?;
    let neighbours = voronoi_neighbours(sites)?;
    let frame = Frame::new(sites, mesh);
    let cells: Vec<(ClippedCell, Vec<u32>)> = (0..sites.len())
        .into_par_iter()
        .map(|index| {
            let cell = CellInput { index, sites, neighbours: &neighbours[index], frame: &frame, mesh, query };
            cell.clip().ok_or(VoronoiError::DegenerateCell { index })
        })
        .collect::<Result<_, _>>()?;
    let adjacency =
        cells.iter().enumerate().flat_map(|(a, (_, above))| above.iter().map(move |&b| [a as u32, b])).collect();
    Ok(ClippedVoronoi { cells: cells.into_iter().map(|(cell, _)| cell).collect(), adjacency })
}

/// The bisector plane of sites `a` and `b` as seen from `a`: [n, d] with n the unit normal
/// towards `b`, so `a` is strictly inside (n.x <= d). Computed for the ordered pair (lower index
/// first) and negated for the other, so the two cells' planes are exact opposites.
pub fn bisector(sites: &[DVec3], a: u32, b: u32) -> [f64; 4] {
    let (low, high) = (a.min(b), a.max(b));
    let (p, q) = (sites[low as usize], sites[high as usize]);
    let normal = (q - p).normalize();
    let plane = [normal.x, normal.y, normal.z, normal.dot((p + q) * 0.5)];
    if a == low { plane } else { plane.map(|x| -x) }
}

fn validate(sites: &[DVec3]) -> Result<(), VoronoiError> {
    if sites.is_empty() {
        return Err(VoronoiError::NoSites);
    }
    if let Some(index) = sites.iter().position(|p| !p.is_finite()) {
        return Err(VoronoiError::NonFinite { index, site: sites[index] });
    }
    let key = |i: usize| (sites[i] + DVec3::ZERO).to_array();
    let mut order: Vec<usize> = (0..sites.len()).collect();
    order.sort_unstable_by(|&i, &j| {
        let (a, b) = (key(i), key(j));
        a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])).then(a[2].total_cmp(&b[2])).then(i.cmp(&j))
    });
    match order.windows(2).find(|pair| sites[pair[0]] == sites[pair[1]]) {
        Some(pair) => Err(VoronoiError::Duplicate { index: pair[1], of: pair[0] }),
        None => Ok(()),
    }
}

/// Each site's Voronoi neighbours (its Delaunay neighbours), ascending.
fn voronoi_neighbours(sites: &[DVec3]) -> Result<Vec<Vec<u32>>, VoronoiError> {
    let count = sites.len() as u32;
    let tets = match tetrahedralize(sites) {
        Ok(tetrahedralization) => tetrahedralization.tets,
        Err(DelaunayError::TooFewPoints { .. } | DelaunayError::Coplanar { .. }) => {
            // Every pair: a few sites, or a flat set whose cells are slabs and prisms.
            return Ok((0..count).map(|a| (0..count).filter(|&b| b != a).collect()).collect());
        }
        Err(error) => return Err(VoronoiError::Delaunay(error)),
    };
    let mut lists = vec![Vec::new(); sites.len()];
    for tet in &tets {
        for &a in tet {
            lists[a as usize].extend(tet.iter().copied().filter(|&b| b != a));
        }
    }
    for list in &mut lists {
        list.sort_unstable();
        list.dedup();
    }
    Ok(lists)
}

/// The box every cell starts from, and the on-plane tolerance at its scale.
#[derive(Debug, Clone, Copy)]
struct Frame {
    lo: DVec3,
    hi: DVec3,
    on_plane: f64,
}

impl Frame {
    fn new(sites: &[DVec3], mesh: &TriangleMesh) -> Frame {
        let (lo, hi) = sites.iter().fold(mesh.bounds(), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let extent = (hi - lo).max_element();
        let margin = BOX_MARGIN * extent + f64::EPSILON * lo.abs().max(hi.abs()).max_element().max(1.0);
        let (lo, hi) = (lo - DVec3::splat(margin), hi + DVec3::splat(margin));
        Frame { lo, hi, on_plane: ON_PLANE * lo.abs().max(hi.abs()).max_element().max((hi - lo).max_element()) }
    }

    /// The box's planes, in the order of [`Polytope::cuboid`]'s faces.
    fn planes(&self) -> [[f64; 4]; 6] {
        let (lo, hi) = (self.lo, self.hi);
        [
            [-1.0, 0.0, 0.0, -lo.x],
            [1.0, 0.0, 0.0, hi.x],
            [0.0, -1.0, 0.0, -lo.y],
            [0.0, 1.0, 0.0, hi.y],
            [0.0, 0.0, -1.0, -lo.z],
            [0.0, 0.0, 1.0, hi.z],
        ]
    }
}

/// A polygon corner: its vertex, and the label of the edge from it to the next corner (a cell
/// plane, or [`MESH_EDGE`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Corner<V> {
    at: V,
    across: u32,
}

/// How a clip makes the vertices of its result.
trait ClipVertices<V> {
    /// The result's vertex for a kept vertex.
    fn keep(&mut self, v: V) -> V;
    /// The point where the plane crosses the edge between `a` and `b`, strictly on opposite sides.
    fn cut(&mut self, a: V, b: V) -> V;
}

/// A convex polygon's part on the inner side (<= 0) of a plane, by Sutherland-Hodgman.
/// `sides` holds each corner's side (-1, 0 on the plane, +1). Edges of the result that lie in the
/// plane (both ends on it) are labelled `plane`; the others keep their labels.
fn clip_cycle<V: Copy>(
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
    if out.len() > 2 && ends.first && ends.last {
        if let Some(last) = out.last_mut() {
            last.across = plane;
        }
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
fn cut_point(a: DVec3, sa: f64, b: DVec3, sb: f64) -> DVec3 {
    let a_first = a.to_array().partial_cmp(&b.to_array()) != Some(std::cmp::Ordering::Greater);
    let ((p, sp), (q, sq)) = if a_first { ((a, sa), (b, sb)) } else { ((b, sb), (a, sa)) };
    p + (q - p) * (sp / (sp - sq))
}

fn plane_parts(plane: &[f64; 4]) -> (DVec3, f64) {
    (DVec3::new(plane[0], plane[1], plane[2]), plane[3])
}

/// Side of a plane offset: -1 inside, 0 within `tolerance` of the plane, +1 outside.
fn side(offset: f64, tolerance: f64) -> i8 {
    if offset > tolerance {
        1
    } else if offset < -tolerance {
        -1
    } else {
        0
    }
}

/// A face of a polytope: the plane it lies on (an index into the cell's planes) and its corners,
/// counterclockwise seen from outside, each edge labelled with the plane of the face across it.
#[derive(Debug, Clone, PartialEq)]
struct Face {
    plane: u32,
    corners: Vec<Corner<u32>>,
}

/// A convex polytope whose faces share their vertices.
#[derive(Debug, Clone, PartialEq)]
struct Polytope {
    vertices: Vec<DVec3>,
    faces: Vec<Face>,
}

impl Polytope {
    /// The box `[lo, hi]`; its faces lie on planes 0..6 of [`Frame::planes`].
    fn cuboid(lo: DVec3, hi: DVec3) -> Polytope {
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
    fn clip(&mut self, id: u32, plane: &[f64; 4], tolerance: f64) -> Option<()> {
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
    fn bounds(&self) -> (DVec3, DVec3) {
        self.vertices.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)))
    }

    /// The positions of a face's corners.
    fn face_loop(&self, face: &Face) -> Vec<DVec3> {
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

/// Twice the signed area that segment `a`-`b` adds by Green's theorem in a plane with unit normal
/// `normal`, about the point `origin` in it.
fn green(normal: DVec3, origin: DVec3, a: DVec3, b: DVec3) -> f64 {
    normal.dot((a - origin).cross(b - origin))
}

/// A point where the surface crosses the boundary of a face.
#[derive(Debug, Clone, Copy)]
struct Crossing {
    at: DVec3,
    /// How the winding number changes here going round the face: +1 where the boundary enters
    /// the mesh, -1 where it leaves.
    change: i32,
}

/// What one cell needs to know.
struct CellInput<'a> {
    index: usize,
    sites: &'a [DVec3],
    neighbours: &'a [u32],
    frame: &'a Frame,
    mesh: &'a TriangleMesh,
    query: &'a MeshQuery,
}

/// The surface inside a cell: clipped pieces, each a run of corners.
#[derive(Debug, Default)]
struct Pieces {
    corners: Vec<Corner<DVec3>>,
    /// Start and length of each piece in `corners`.
    spans: Vec<(usize, usize)>,
}

impl Pieces {
    fn iter(&self) -> impl Iterator<Item = &[Corner<DVec3>]> {
        self.spans.iter().map(|&(start, len)| &self.corners[start..start + len])
    }
}

impl CellInput<'_> {
    /// The clipped cell and the higher-numbered cells it shares a face with inside the mesh, or
    /// `None` when the polytope degenerates.
    fn clip(&self) -> Option<(ClippedCell, Vec<u32>)> {
        let site = self.sites[self.index];
        let (planes, across) = self.candidate_planes();
        let mut polytope = Polytope::cuboid(self.frame.lo, self.frame.hi);
        for (id, plane) in planes.iter().enumerate().skip(BOX_PLANES as usize) {
            polytope.clip(id as u32, plane, self.frame.on_plane)?;
        }
        let pieces = self.clip_surface(&polytope, &planes);
        let cut_curves = cut_curves(&pieces, &polytope, planes.len());
        let whole_cell_winding = pieces.spans.is_empty().then(|| self.winding_at(site));

        let mut volume: f64 = pieces.iter().map(|piece| cone_volume(site, piece)).sum();
        let mut shared = Vec::new();
        for (face, cut_curve) in polytope.faces.iter().zip(&cut_curves) {
            let (normal, offset) = plane_parts(&planes[face.plane as usize]);
            let face_loop = polytope.face_loop(face);
            let inside_area = match whole_cell_winding {
                Some(winding) => f64::from(winding) * polygon_area(normal, &face_loop),
                None if face.plane < BOX_PLANES => 0.0, // the box lies outside the mesh
                None => self.area_inside(normal, &face_loop, cut_curve),
            };
            volume += (offset - normal.dot(site)) * inside_area / 3.0;
            let neighbour = across[face.plane as usize];
            if neighbour != NONE
                && neighbour > self.index as u32
                && inside_area > SHARED_AREA * polygon_area(normal, &face_loop)
            {
                shared.push(neighbour);
            }
        }
        shared.sort_unstable();
        let cell = ClippedCell {
            planes: polytope.faces.iter().map(|face| planes[face.plane as usize]).collect(),
            triangles: pieces.iter().flat_map(fan).collect(),
            volume,
        };
        Some((cell, shared))
    }

    /// The box's planes, then the bisectors with the Voronoi neighbours, nearest first; and the
    /// site across each plane ([`NONE`] for the box).
    fn candidate_planes(&self) -> (Vec<[f64; 4]>, Vec<u32>) {
        let site = self.sites[self.index];
        let mut order = self.neighbours.to_vec();
        let distance = |j: u32| self.sites[j as usize].distance_squared(site);
        order.sort_by(|&a, &b| distance(a).total_cmp(&distance(b)).then(a.cmp(&b)));
        let mut planes = self.frame.planes().to_vec();
        let mut across = vec![NONE; planes.len()];
        for j in order {
            planes.push(bisector(self.sites, self.index as u32, j));
            across.push(j);
        }
        (planes, across)
    }

    /// The mesh triangles near the polytope clipped to it, in the order of their mesh index.
    fn clip_surface(&self, polytope: &Polytope, planes: &[[f64; 4]]) -> Pieces {
        let cutting: Vec<(u32, [f64; 4])> = polytope
            .faces
            .iter()
            .filter(|face| face.plane >= BOX_PLANES)
            .map(|face| (face.plane, planes[face.plane as usize]))
            .collect();
        let (lo, hi) = polytope.bounds();
        let pad = DVec3::splat(self.frame.on_plane);
        let mut near = Vec::new();
        self.query.triangles_in_box(lo - pad, hi + pad, &mut near);
        near.sort_unstable();
        let mut pieces = Pieces::default();
        let (mut piece, mut scratch) = (Vec::new(), Vec::new());
        for &t in &near {
            if clip_triangle(self.mesh.corners(t as usize), &cutting, &mut piece, &mut scratch) {
                pieces.spans.push((pieces.corners.len(), piece.len()));
                pieces.corners.extend_from_slice(&piece);
            }
        }
        pieces
    }

    /// Area of a face's part inside the mesh (counted with its winding number), by Green's
    /// theorem on its boundary: the cut curve (segments as the boundary runs) and the stretches
    /// of the face's edges, each as many times as its winding number.
    fn area_inside(&self, normal: DVec3, face_loop: &[DVec3], cut_curve: &[(DVec3, DVec3)]) -> f64 {
        let origin = face_loop[0];
        let mut twice_area: f64 = cut_curve.iter().map(|&(a, b)| green(normal, origin, a, b)).sum();
        let stretches = stretch_levels(&place_crossings(face_loop, &curve_ends(cut_curve)));
        let base = self.base_level(&stretches);
        twice_area +=
            stretches.iter().map(|&(a, b, level)| f64::from(level + base) * green(normal, origin, a, b)).sum::<f64>();
        0.5 * twice_area
    }

    /// The winding number of the stretches at level 0, from the exact winding number at the
    /// middle of the longest stretch.
    fn base_level(&self, stretches: &[(DVec3, DVec3, i32)]) -> i32 {
        let length = |s: &&(DVec3, DVec3, i32)| s.0.distance_squared(s.1);
        stretches
            .iter()
            .max_by(|x, y| length(x).total_cmp(&length(y)))
            .map_or(0, |&(a, b, level)| self.winding_at((a + b) * 0.5) - level)
    }

    /// The winding number about `p`; where the mesh's holes leave it undefined, 1 inside and 0
    /// outside.
    fn winding_at(&self, p: DVec3) -> i32 {
        self.query.winding_number(p).unwrap_or_else(|| i32::from(self.query.contains(p)))
    }
}

/// Clips a triangle to the cell planes `cutting` (id, plane); the piece goes to `piece`. False
/// when nothing of it has area inside.
fn clip_triangle(
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

/// Per polytope face: its cut curve, the piece edges on its plane taken backwards (as the
/// boundary of the face's part inside the mesh runs).
fn cut_curves(pieces: &Pieces, polytope: &Polytope, plane_count: usize) -> Vec<Vec<(DVec3, DVec3)>> {
    let mut face_of_plane = vec![NONE; plane_count];
    for (f, face) in polytope.faces.iter().enumerate() {
        face_of_plane[face.plane as usize] = f as u32;
    }
    let mut curves = vec![Vec::new(); polytope.faces.len()];
    for piece in pieces.iter() {
        for (k, corner) in piece.iter().enumerate() {
            if corner.across != MESH_EDGE {
                let next = piece[(k + 1) % piece.len()];
                curves[face_of_plane[corner.across as usize] as usize].push((next.at, corner.at));
            }
        }
    }
    curves
}

/// The loose ends of a cut curve: where the face's boundary leaves it for an edge of the face
/// (an entry: more segments end there than start) or comes back to it (an exit). Segments of
/// neighbouring pieces meet at bit-identical points, so the ends are where the surface crosses
/// the face's edges, whether inside a piece or at a mesh edge or vertex.
fn curve_ends(curve: &[(DVec3, DVec3)]) -> Vec<Crossing> {
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
fn place_crossings(face_loop: &[DVec3], crossings: &[Crossing]) -> Vec<(DVec3, i32)> {
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
fn stretch_levels(events: &[(DVec3, i32)]) -> Vec<(DVec3, DVec3, i32)> {
    let mut level = 0;
    (0..events.len())
        .map(|k| {
            level += events[k].1;
            (events[k].0, events[(k + 1) % events.len()].0, level)
        })
        .collect()
}

/// Area of a planar polygon with unit normal `normal` (positive when counterclockwise about it).
fn polygon_area(normal: DVec3, polygon: &[DVec3]) -> f64 {
    let origin = polygon[0];
    let count = polygon.len();
    0.5 * (1..count.saturating_sub(1)).map(|k| green(normal, origin, polygon[k], polygon[k + 1])).sum::<f64>()
}

/// Signed volume of the cone from `apex` over a planar piece (fan-triangulated).
fn cone_volume(apex: DVec3, piece: &[Corner<DVec3>]) -> f64 {
    fan(piece).map(|[a, b, c]| (a - apex).dot((b - apex).cross(c - apex)) / 6.0).sum()
}

/// A convex polygon's fan triangles from its first corner.
fn fan(piece: &[Corner<DVec3>]) -> impl Iterator<Item = [DVec3; 3]> + '_ {
    (1..piece.len().saturating_sub(1)).map(move |k| [piece[0].at, piece[k].at, piece[k + 1].at])
}

#[cfg(test)]
mod tests {
    use shatter_core::random::SplitMix64;

    use super::*;
    use crate::mesh_query::tests::octahedron;
    use crate::test_meshes::cube;

    /// `count` random points strictly inside the mesh.
    fn random_sites(mesh: &TriangleMesh, count: usize, seed: u64) -> Vec<DVec3> {
        let query = MeshQuery::new(mesh);
        let (lo, hi) = mesh.bounds();
        let mut rng = SplitMix64::new(seed);
        let mut sites = Vec::new();
        while sites.len() < count {
            let p = lo + (hi - lo) * DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
            if query.contains(p) {
                sites.push(p);
            }
        }
        sites
    }

    fn diagram(mesh: &TriangleMesh, sites: &[DVec3]) -> ClippedVoronoi {
        clipped_voronoi(sites, mesh, &MeshQuery::new(mesh)).expect("the diagram builds")
    }

    fn triangle_area([a, b, c]: &[DVec3; 3]) -> f64 {
        (*b - *a).cross(*c - *a).length() * 0.5
    }

    /// Relative errors of the cells' total volume and total surface area.
    fn totals_error(mesh: &TriangleMesh, voronoi: &ClippedVoronoi) -> (f64, f64) {
        let volume: f64 = voronoi.cells.iter().map(|c| c.volume).sum();
        let area: f64 = voronoi.cells.iter().flat_map(|c| &c.triangles).map(triangle_area).sum();
        ((volume / mesh.signed_volume() - 1.0).abs(), (area / mesh.area() - 1.0).abs())
    }

    #[test]
    fn a_cube_cut_among_random_sites_keeps_its_volume_and_area() {
        let mesh = cube(1.0);
        for seed in 0..5 {
            let voronoi = diagram(&mesh, &random_sites(&mesh, 4 + 3 * seed as usize, seed));
            let (volume, area) = totals_error(&mesh, &voronoi);
            assert!(volume < 1e-9 && area < 1e-12, "seed {seed}: volume {volume:e}, area {area:e}");
            assert!(voronoi.cells.iter().all(|c| c.volume > 0.0));
        }
    }

    #[test]
    fn a_sphere_cut_among_random_sites_keeps_its_volume_and_area() {
        let mesh = octahedron(12, 1.0, true);
        for seed in 0..4 {
            let voronoi = diagram(&mesh, &random_sites(&mesh, 5 + 10 * seed as usize, seed));
            let (volume, area) = totals_error(&mesh, &voronoi);
            assert!(volume < 1e-9 && area < 1e-12, "seed {seed}: volume {volume:e}, area {area:e}");
        }
    }

    #[test]
    fn sites_outside_the_mesh_get_what_their_cells_hold_inside() {
        let mesh = octahedron(6, 1.0, true);
        let mut sites = random_sites(&mesh, 10, 3);
        sites.extend([DVec3::new(1.5, 0.2, 0.1), DVec3::new(-3.0, 0.0, 0.0), DVec3::new(0.3, 0.9, 0.9)]);
        let voronoi = diagram(&mesh, &sites);
        let (volume, area) = totals_error(&mesh, &voronoi);
        assert!(volume < 1e-9 && area < 1e-12, "volume {volume:e}, area {area:e}");
        // Far away: nothing inside, no neighbours.
        let far = &voronoi.cells[11];
        assert_eq!((far.volume, far.triangles.len()), (0.0, 0));
        assert!(voronoi.adjacency.iter().all(|pair| !pair.contains(&11)));
    }

    #[test]
    fn one_site_takes_the_whole_mesh() {
        let mesh = octahedron(4, 2.0, true);
        let voronoi = diagram(&mesh, &[DVec3::new(0.1, 0.2, 0.3)]);
        let cell = &voronoi.cells[0];
        assert!((cell.volume / mesh.signed_volume() - 1.0).abs() < 1e-12);
        assert_eq!(cell.triangles.len(), mesh.triangles.len());
        assert_eq!(cell.planes.len(), 6); // the box
        assert!(voronoi.adjacency.is_empty());
    }

    #[test]
    fn a_regular_grid_of_sites_cuts_a_cube_into_equal_cubes() {
        // Cospherical sites, bisectors through the cube's face diagonals and their crossings:
        // the degenerate cases.
        for n in [2usize, 3] {
            let mesh = cube(1.0);
            let sites: Vec<DVec3> = (0..n * n * n)
                .map(|i| (DVec3::new((i % n) as f64, ((i / n) % n) as f64, (i / n / n) as f64) + 0.5) / n as f64)
                .collect();
            let voronoi = diagram(&mesh, &sites);
            let expected = 1.0 / (n * n * n) as f64;
            for cell in &voronoi.cells {
                assert!((cell.volume - expected).abs() < 1e-14, "n = {n}: volume {}", cell.volume);
                // Only the faces of a cube: 6 planes, bisectors or box planes.
                assert_eq!(cell.planes.len(), 6, "n = {n}");
            }
            let (volume, area) = totals_error(&mesh, &voronoi);
            assert!(volume < 1e-12 && area < 1e-12);
            // Face neighbours only: pairs differing by one step along one axis.
            assert_eq!(voronoi.adjacency.len(), 3 * n * n * (n - 1), "n = {n}");
            for [a, b] in &voronoi.adjacency {
                let d = sites[*a as usize] - sites[*b as usize];
                assert!((d.length() * n as f64 - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn two_separate_bodies_are_both_shared_out() {
        let mut mesh = cube(1.0);
        let mut far = octahedron(5, 0.7, true);
        far.map_positions(|p| p + DVec3::new(3.0, 0.5, 0.5));
        merge(&mut mesh, far);
        // Sites only in the cube: the octahedron goes to the cells reaching over to it.
        let voronoi = diagram(&mesh, &random_sites(&cube(1.0), 9, 4));
        let (volume, area) = totals_error(&mesh, &voronoi);
        assert!(volume < 1e-9 && area < 1e-12, "volume {volume:e}, area {area:e}");
    }

    /// Appends `other`'s triangles to `mesh`.
    fn merge(mesh: &mut TriangleMesh, other: TriangleMesh) {
        let offset = mesh.positions.len() as u32;
        mesh.positions.extend(other.positions);
        mesh.triangles.extend(other.triangles.iter().map(|t| t.map(|v| v + offset)));
    }

    #[test]
    fn overlapping_shells_and_cavities_count_with_their_winding_number() {
        // Two interpenetrating cubes: the overlap counts twice, as the signed volume counts it.
        let mut overlapping = cube(1.0);
        let mut other = cube(1.0);
        other.map_positions(|p| p + DVec3::splat(0.5));
        merge(&mut overlapping, other);
        // A cube with an inside-out cube inside it: a cavity.
        let mut hollow = cube(3.0);
        let mut cavity = cube(1.0);
        cavity.flip();
        cavity.map_positions(|p| p + DVec3::ONE);
        merge(&mut hollow, cavity);
        for (mesh, volume) in [(overlapping, 2.0), (hollow, 26.0)] {
            assert!((mesh.signed_volume() - volume).abs() < 1e-12);
            for seed in 0..3 {
                let voronoi = diagram(&mesh, &random_sites(&mesh, 25, seed));
                let (volume, area) = totals_error(&mesh, &voronoi);
                assert!(volume < 1e-9 && area < 1e-12, "seed {seed}: volume {volume:e}, area {area:e}");
            }
        }
    }

    #[test]
    fn adjacency_is_symmetric_sorted_and_between_touching_cells() {
        let mesh = octahedron(10, 1.0, true);
        let voronoi = diagram(&mesh, &random_sites(&mesh, 40, 8));
        assert!(voronoi.adjacency.windows(2).all(|w| w[0] < w[1]));
        assert!(voronoi.adjacency.iter().all(|[a, b]| a < b));
        let sites = random_sites(&mesh, 40, 8);
        for &[a, b] in &voronoi.adjacency {
            let plane = bisector(&sites, a, b);
            let opposite = plane.map(|x| -x);
            assert!(voronoi.cells[a as usize].planes.contains(&plane));
            assert!(voronoi.cells[b as usize].planes.contains(&opposite));
        }
        // Every interior cell touches several others.
        assert!(voronoi.adjacency.len() > 2 * 40);
    }

    #[test]
    fn the_diagram_does_not_depend_on_the_thread_count() {
        let mesh = octahedron(10, 1.0, true);
        let sites = random_sites(&mesh, 60, 2);
        let many = diagram(&mesh, &sites);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
        let one = pool.install(|| diagram(&mesh, &sites));
        assert_eq!(many, one);
    }

    #[test]
    fn bad_sites_are_reported() {
        let mesh = cube(1.0);
        let query = MeshQuery::new(&mesh);
        assert_eq!(clipped_voronoi(&[], &mesh, &query), Err(VoronoiError::NoSites));
        let repeated = [DVec3::splat(0.5), DVec3::splat(0.2), DVec3::splat(0.5)];
        assert_eq!(clipped_voronoi(&repeated, &mesh, &query), Err(VoronoiError::Duplicate { index: 2, of: 0 }));
        let nan = [DVec3::splat(0.5), DVec3::new(f64::NAN, 0.0, 0.0)];
        assert!(matches!(clipped_voronoi(&nan, &mesh, &query), Err(VoronoiError::NonFinite { index: 1, .. })));
        // Two or three sites, and coplanar ones, use every pair.
        for sites in
            [&[DVec3::splat(0.25), DVec3::splat(0.75)][..], &[0.2, 0.4, 0.6, 0.8].map(|x| DVec3::new(x, 1.0 - x, 0.5))]
        {
            let voronoi = clipped_voronoi(sites, &mesh, &query).expect("few sites");
            let (volume, area) = totals_error(&mesh, &voronoi);
            assert!(volume < 1e-12 && area < 1e-12);
        }
    }
}
