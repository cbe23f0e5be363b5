//! Clipped Voronoi cells: the Voronoi diagram of a set of sites, cut to the inside of a closed
//! triangle mesh (the paper's "trimtopes": a convex polytope and the surface triangles inside it),
//! with the parts of their faces inside the mesh triangulated (where a crack opens, the faces of
//! the pieces on either side).
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
//!
//! # Files
//!
//! The diagram, its Voronoi neighbours and the starting box are here; one cell's construction in
//! `clipped_cell.rs`; its polytope in `polytope.rs`; Sutherland-Hodgman clipping of faces and
//! triangles in `clipping.rs`; the volume terms in `cell_volume.rs`; the faces' parts inside the
//! mesh as triangles (the boundary the area comes from, triangulated by spade's constrained
//! Delaunay triangulation) in `face_inside.rs`; the tests in `tests.rs`.

mod cell_volume;
mod clipped_cell;
mod clipping;
mod face_inside;
mod polytope;
#[cfg(test)]
mod tests;

use glam::DVec3;
use rayon::prelude::*;

use self::clipped_cell::CellInput;
use crate::delaunay::{DelaunayError, tetrahedralize};
use crate::mesh_query::MeshQuery;
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
    /// The parts of the cell's faces inside the mesh, triangulated, outward winding: where a
    /// crack separates the cell from its neighbour, these are the fracture faces.
    pub face_triangles: Vec<[DVec3; 3]>,
    /// The face (index into `planes`) of each of `face_triangles`.
    pub face_of_triangle: Vec<u32>,
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

    /// The box's planes, in the order of [`Polytope::cuboid`](polytope::Polytope::cuboid)'s faces.
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
