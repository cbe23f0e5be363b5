//! The dispatch from the scene's `geometry.sampler` to its sampler: the source loaded and repaired
//! (or the box taken), the sample's memory checked, the sampler run, its sample made particles.

use glam::DVec3;
use shatter_core::Progress;
use shatter_core::config::{GeometrySource, PipelineConfig, Sampler, TransformConfig};
use shatter_core::memory;
use shatter_geometry::mesh::{MeshError, TriangleMesh};

use crate::inside::FillRule;
use crate::mesh_query::MeshQuery;
use crate::preprocess_driver::{PreprocessError, Preprocessed};
use crate::repair::{MeshReport, repair};
use crate::samplers::particle_assembly::check_count;
use crate::samplers::{grid, size_estimate, tet_shell, voronoi};

/// Turns the scene's geometry into particles: loads and repairs a mesh source (or takes the box),
/// runs the configured sampler in the sampling frame and makes its sample a particle set (the body
/// of [`crate::preprocess`]).
pub(crate) fn sample_geometry(
    config: &PipelineConfig,
    progress: &dyn Progress,
) -> Result<Preprocessed, PreprocessError> {
    let geometry = &config.geometry;
    let spacing = geometry.spacing_m;
    let mut notes = Vec::new();
    let mut mesh_report = None;
    let sample = match geometry.sampler {
        Sampler::Grid => match &geometry.source {
            GeometrySource::Box => {
                let size = geometry.box_size_m.unwrap_or_else(|| unreachable!("validated: a box has a size"));
                let (sample, snapped) = grid::fill_box(size, spacing).map_err(grid::spacing_error(spacing))?;
                if size.iter().zip(&snapped).any(|(want, got)| (want - got).abs() > 1e-9 * want) {
                    notes.push(format!("box snapped to whole cubes: {snapped:?} m (asked for {size:?} m)"));
                }
                sample
            }
            GeometrySource::Mesh(path) => {
                progress.start("load mesh", 0);
                let mesh = load_repaired(path, &geometry.transform, geometry.mesh_repair.min_body_volume_fraction);
                progress.finish();
                let (mesh, report) = mesh?;
                check_sample_memory(config, &mesh)?;
                progress.start("fill", 0);
                let filled = grid::fill_mesh(&mesh, spacing, report.fill_rule);
                progress.finish();
                let (sample, inside) = filled.map_err(grid::spacing_error(spacing))?;
                if inside.voted_cells > 0 {
                    notes.push(format!(
                        "{} lattice lines passed through holes in the mesh; {} cells were decided by lines along other axes",
                        inside.leaky_lines, inside.voted_cells
                    ));
                }
                mesh_report = Some(report);
                sample
            }
        },
        Sampler::TetShell | Sampler::Voronoi => {
            let (mesh, report) = match &geometry.source {
                GeometrySource::Mesh(path) => {
                    progress.start("load mesh", 0);
                    let loaded =
                        load_repaired(path, &geometry.transform, geometry.mesh_repair.min_body_volume_fraction);
                    progress.finish();
                    let (mesh, report) = loaded?;
                    (mesh, Some(report))
                }
                GeometrySource::Box => {
                    let size = geometry.box_size_m.unwrap_or_else(|| unreachable!("validated: a box has a size"));
                    (TriangleMesh::cuboid(size), None)
                }
            };
            check_sample_memory(config, &mesh)?;
            let rule = report.as_ref().map_or(FillRule::NonZero, |report| report.fill_rule);
            let query = MeshQuery::with_fill_rule(&mesh, rule);
            let particles = if geometry.sampler == Sampler::TetShell {
                tet_shell::tet_shell_particles(config, &mesh, &query, progress, &mut notes)?
            } else {
                voronoi::voronoi_particles(config, &mesh, &query, progress, &mut notes)?
            };
            return Ok(Preprocessed { particles, mesh_report: report, notes });
        }
    };
    if sample.cells.is_empty() {
        return Err(PreprocessError::Setting {
            key: "geometry.spacing_m",
            value: spacing.to_string(),
            message: "no lattice cell centre lies inside the geometry: the spacing is too coarse for it".into(),
        });
    }
    check_count("geometry.spacing_m", spacing.to_string(), sample.cells.len())?;
    let particles = grid::grid_particles(config, &sample, progress, &mut notes);
    Ok(Preprocessed { particles, mesh_report, notes })
}

/// Refuses a mesh whose sample would not fit in memory, from the estimate of its particle count
/// and bonds ([`size_estimate`]; a box's grid fill is also checked from the config before
/// preprocessing starts).
fn check_sample_memory(config: &PipelineConfig, mesh: &TriangleMesh) -> Result<(), PreprocessError> {
    let geometry = &config.geometry;
    let triangles = mesh.triangles.len() as f64;
    let (size, scratch_bytes) = size_estimate::estimate(geometry, mesh.signed_volume().abs(), mesh.area(), triangles);
    let what = format!(
        "sampling the mesh into about {:.3e} {} particles ({} sampler)",
        size.particles,
        size.element.name(),
        geometry.sampler.name()
    );
    let mut need = memory::preprocess_need(&size, scratch_bytes, what);
    if geometry.sampler == Sampler::Voronoi && geometry.voronoi.particles.is_some() {
        need.keys = "geometry.voronoi.particles and geometry.horizon_factor";
        need.advice = "lower geometry.voronoi.particles or geometry.horizon_factor";
    }
    Ok(memory::check(&need)?)
}

/// Loads the mesh, brings it into the sampling frame (recentred, scaled to metres) and repairs it.
fn load_repaired(
    path: &std::path::Path,
    transform: &TransformConfig,
    min_body_volume_fraction: f64,
) -> Result<(TriangleMesh, MeshReport), PreprocessError> {
    let (mut mesh, stats) = TriangleMesh::load_obj(path)?;
    let (lo, hi) = mesh.bounds();
    let centre = if transform.recenter { (lo + hi) * 0.5 } else { DVec3::ZERO };
    mesh.map_positions(|p| (p - centre) * transform.scale);
    let (mesh, report) = repair(&mesh, stats, min_body_volume_fraction);
    if mesh.triangles.is_empty() {
        return Err(MeshError::NoVolume {
            path: path.to_path_buf(),
            reason: "the mesh encloses no volume (is it an open surface?)".into(),
        }
        .into());
    }
    Ok((mesh, report))
}
