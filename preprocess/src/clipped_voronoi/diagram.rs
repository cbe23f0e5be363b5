//! The clipped Voronoi diagram: its cells and their adjacency, each site's Voronoi neighbours from
//! the Delaunay tetrahedralization, and the bisector planes the cells share.

use glam::DVec3;
use rayon::prelude::*;
use shatter_geometry::mesh::TriangleMesh;

use super::cell_box::Frame;
use super::clipped_cell::CellInput;
use crate::delaunay::{DelaunayError, tetrahedralize};
use crate::mesh_query::MeshQuery;

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
/// result does not depend on the thread count. See the [module documentation](crate::clipped_voronoi).
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
