//! The `voronoi` sampler (the paper's dragon): blue-noise sites inside the mesh
//! ([`crate::blue_noise`]), ordered along a Z-curve, cut into clipped Voronoi cells
//! ([`crate::voronoi`]). The surface keeps its own resolution: every mesh triangle survives as
//! the pieces the cells cut it into, however few the sites.

use glam::DVec3;

use crate::blue_noise::{
    MAX_GRID_CUBES, POISSON_DENSITY, min_distance_for_count, poisson_disk, poisson_disk_with_count,
};
use crate::mesh_query::MeshQuery;
use crate::order::z_order;
use crate::voronoi::{ClippedVoronoi, VoronoiError, clipped_voronoi};
use shatter_geometry::mesh::TriangleMesh;

/// How far apart the sites are.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SiteSpacing {
    /// This minimum distance between sites, metres.
    MinDistance(f64),
    /// About this many sites; the minimum distance is chosen to match.
    Count(usize),
}

/// Sites and their clipped cells.
#[derive(Debug, Clone, PartialEq)]
pub struct VoronoiSample {
    /// The distance the sites were sampled at: no two sites are closer (exactly, in f64).
    pub sample_distance: f64,
    /// The sites, sampling frame, in Z-curve order.
    pub sites: Vec<DVec3>,
    /// One clipped cell per site (same order) and the cells sharing a face inside the mesh.
    pub diagram: ClippedVoronoi,
}

/// Why the sites or their cells cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum VoronoiSamplerError {
    /// The blue-noise grid would be too large for this spacing and mesh.
    #[error(
        "the blue-noise grid would have more than {MAX_GRID_CUBES} cells: the spacing is too fine for this mesh \
         ({estimate:.3e} particles)"
    )]
    TooFine {
        /// About how many particles the spacing would give.
        estimate: f64,
    },
    /// No site fits inside the mesh.
    #[error("no site fits inside the mesh: the spacing is too coarse for it")]
    Empty,
    /// The clipped Voronoi diagram failed.
    #[error("the clipped Voronoi diagram failed: {0}")]
    Voronoi(#[from] VoronoiError),
}

/// Samples sites inside `mesh` (`query` built from it, enclosing `volume`) at `spacing` plus
/// `margin` (so that rounding the sites later by up to `margin / 2` in distance keeps them at least
/// the asked spacing apart), orders them along a Z-curve and clips their cells.
pub fn voronoi_sample(
    mesh: &TriangleMesh,
    query: &MeshQuery,
    volume: f64,
    spacing: SiteSpacing,
    margin: f64,
    seed: u64,
) -> Result<VoronoiSample, VoronoiSamplerError> {
    let bounds = mesh.bounds();
    let check_grid = |distance: f64| {
        let cubes = ((bounds.1 - bounds.0) / (distance / 3f64.sqrt())).ceil().max(DVec3::ONE);
        if cubes.x * cubes.y * cubes.z > MAX_GRID_CUBES as f64 || !distance.is_finite() {
            Err(VoronoiSamplerError::TooFine { estimate: POISSON_DENSITY * volume / distance.powi(3) })
        } else {
            Ok(())
        }
    };
    let (sample_distance, sites) = match spacing {
        SiteSpacing::MinDistance(distance) => {
            let distance = distance + margin;
            check_grid(distance)?;
            (distance, poisson_disk(query, bounds, distance, seed))
        }
        SiteSpacing::Count(count) => {
            // The count search tries distances down to about 0.97 of the first guess.
            check_grid(0.9 * min_distance_for_count(volume, count))?;
            poisson_disk_with_count(query, bounds, volume, count, seed)
        }
    };
    if sites.is_empty() {
        return Err(VoronoiSamplerError::Empty);
    }
    let sites: Vec<DVec3> = z_order(&sites).into_iter().map(|i| sites[i as usize]).collect();
    let diagram = clipped_voronoi(&sites, mesh, query)?;
    Ok(VoronoiSample { sample_distance, sites, diagram })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_meshes::cube;

    #[test]
    fn a_cube_is_cut_into_cells_in_z_order() {
        let mesh = cube(1.0);
        let query = MeshQuery::new(&mesh);
        let sample = voronoi_sample(&mesh, &query, 1.0, SiteSpacing::MinDistance(0.2), 0.0, 1).expect("sample");
        let total: f64 = sample.diagram.cells.iter().map(|cell| cell.volume).sum();
        assert!((total - 1.0).abs() < 1e-9);
        assert_eq!(sample.sites.len(), sample.diagram.cells.len());
        assert_eq!(z_order(&sample.sites), (0..sample.sites.len() as u32).collect::<Vec<_>>());
        let counted = voronoi_sample(&mesh, &query, 1.0, SiteSpacing::Count(300), 0.0, 1).expect("sample");
        assert!((counted.sites.len() as f64 / 300.0 - 1.0).abs() < 0.05);
    }

    #[test]
    fn absurd_spacings_are_errors() {
        let mesh = cube(1.0);
        let query = MeshQuery::new(&mesh);
        let fine = voronoi_sample(&mesh, &query, 1.0, SiteSpacing::MinDistance(1e-5), 0.0, 1);
        assert!(matches!(fine, Err(VoronoiSamplerError::TooFine { .. })));
        let coarse = voronoi_sample(&mesh, &query, 1.0, SiteSpacing::MinDistance(10.0), 0.0, 1);
        assert!(coarse.is_ok_and(|sample| sample.sites.len() == 1));
    }
}
