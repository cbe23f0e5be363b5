//! The `voronoi` sampler (the paper's dragon): blue-noise sites inside the mesh
//! ([`blue_noise`](super::blue_noise)), ordered along a Z-curve, cut into clipped Voronoi cells
//! ([`crate::clipped_voronoi`]). The surface keeps its own resolution: every mesh triangle
//! survives as the pieces the cells cut it into, however few the sites.

use glam::DVec3;
use shatter_core::Progress;
use shatter_core::config::PipelineConfig;
use shatter_core::particles::{Elements, ParticleSet};

use crate::clipped_voronoi::{ClippedVoronoi, VoronoiError, clipped_voronoi};
use crate::mesh_query::MeshQuery;
use crate::order::z_order;
use crate::preprocess_driver::PreprocessError;
use crate::samplers::blue_noise::{
    MAX_GRID_CUBES, POISSON_DENSITY, min_distance_for_count, poisson_disk, poisson_disk_with_count,
};
use crate::samplers::particle_assembly::{Placement, Sampled, assemble, check_count};
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

// The sample as particles, for the dispatch in `samplers/sampler_dispatch.rs`.

/// How far apart two sampling-frame points may come once rounded to f32 world coordinates
/// (an upper bound on the change of their distance), for a mesh with these bounds.
fn f32_rounding_reach((lo, hi): (DVec3, DVec3), placement: &Placement) -> f64 {
    let largest = (0..8)
        .map(|corner| {
            let p = DVec3::new(
                if corner & 1 == 0 { lo.x } else { hi.x },
                if corner & 2 == 0 { lo.y } else { hi.y },
                if corner & 4 == 0 { lo.z } else { hi.z },
            );
            (placement.rotation * p + placement.translation).abs().max_element()
        })
        .fold(0.0, f64::max);
    // Each coordinate of each point moves by at most 2^-24 of the largest: 2 sqrt(3) 2^-24 in
    // distance, rounded up to 4 to cover the f64 arithmetic before the rounding.
    4.0 * largest * f64::from(f32::EPSILON) * 0.5
}

/// The clipped Voronoi cells of blue-noise sites as particles: sites, cell volumes, trimtopes.
pub(super) fn voronoi_particles(
    config: &PipelineConfig,
    mesh: &TriangleMesh,
    query: &MeshQuery,
    progress: &dyn Progress,
    notes: &mut Vec<String>,
) -> Result<ParticleSet, PreprocessError> {
    let geometry = &config.geometry;
    let placement = Placement::new(&geometry.transform);
    let margin = f32_rounding_reach(mesh.bounds(), &placement);
    let (spacing, key, value) = match geometry.voronoi.particles {
        Some(count) => (SiteSpacing::Count(count as usize), "geometry.voronoi.particles", count.to_string()),
        None => (SiteSpacing::MinDistance(geometry.spacing_m), "geometry.spacing_m", geometry.spacing_m.to_string()),
    };
    progress.start("voronoi cells", 0);
    let sample = voronoi_sample(mesh, query, mesh.signed_volume(), spacing, margin, config.scene.seed);
    progress.finish();
    let sample = sample.map_err(|error| match error {
        VoronoiSamplerError::TooFine { .. } | VoronoiSamplerError::Empty => {
            PreprocessError::Setting { key, value: value.clone(), message: error.to_string() }
        }
        VoronoiSamplerError::Voronoi(_) => PreprocessError::Sampler { sampler: "voronoi", message: error.to_string() },
    })?;
    check_count(key, value, sample.sites.len())?;
    let VoronoiSample { sample_distance, sites, diagram } = sample;
    if let Some(index) = diagram.cells.iter().position(|cell| {
        let volume = cell.volume as f32;
        !volume.is_finite() || volume <= 0.0
    }) {
        return Err(PreprocessError::Sampler {
            sampler: "voronoi",
            message: format!(
                "the cell of site {index} at {} has volume {:e} inside the mesh (is the mesh inside out or \
                 self-intersecting there?)",
                sites[index], diagram.cells[index].volume
            ),
        });
    }
    let lambda = sample_distance - margin;
    if geometry.voronoi.particles.is_some() {
        notes.push(format!(
            "voronoi: {} sites at least {lambda:.4e} m apart (from geometry.voronoi.particles; geometry.spacing_m is \
             not used)",
            sites.len()
        ));
    }
    let (mut plane_offsets, mut triangle_offsets, mut face_offsets) = (vec![0u64], vec![0u64], vec![0u64]);
    let (mut planes, mut triangles_m, mut face_triangles_m, mut face_planes) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for cell in &diagram.cells {
        for &[nx, ny, nz, d] in &cell.planes {
            let normal = placement.rotation * DVec3::new(nx, ny, nz);
            let offset = d + normal.dot(placement.translation);
            planes.push([normal.x as f32, normal.y as f32, normal.z as f32, offset as f32]);
        }
        triangles_m.extend(cell.triangles.iter().map(|triangle| triangle.map(|p| placement.world(p))));
        face_triangles_m.extend(cell.face_triangles.iter().map(|triangle| triangle.map(|p| placement.world(p))));
        face_planes.extend_from_slice(&cell.face_of_triangle);
        plane_offsets.push(planes.len() as u64);
        triangle_offsets.push(triangles_m.len() as u64);
        face_offsets.push(face_triangles_m.len() as u64);
    }
    let volumes: Vec<f64> = diagram.cells.iter().map(|cell| cell.volume).collect();
    let elements = Elements::Trimtopes {
        plane_offsets,
        planes,
        triangle_offsets,
        triangles_m,
        face_offsets,
        face_triangles_m,
        face_planes,
    };
    let stored = placement.stored_positions(&sites);
    let sampled = Sampled {
        lambda_m: lambda,
        points: &sites,
        rest_position_m: stored,
        volume_m3: &volumes,
        elements,
        adjacency: diagram.adjacency,
    };
    Ok(assemble(config, sampled, progress, notes))
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
