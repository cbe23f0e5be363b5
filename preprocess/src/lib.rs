//! Preprocessing: from a scene's geometry to a particle set.
//!
//! The source (a box or a closed mesh, repaired as [`mod@repair`] describes) is scaled into metres,
//! sampled into particles in that frame (cubes on a lattice by the [`grid`] sampler, the tets of a
//! layered shell by [`mod@tet_shell`], clipped Voronoi cells of blue-noise sites by
//! [`voronoi_sampler`]), ordered along a Z-curve, bonded within the horizon by k-d tree range
//! queries ([`bonds`]), and finally rotated and translated into the world.

pub mod blue_noise;
pub mod bonds;
pub mod delaunay;
pub mod grid;
pub mod inside;
pub mod lattice;
pub mod mesh_query;
pub mod order;
pub mod repair;
pub mod tet_shell;
pub mod voronoi;
pub mod voronoi_sampler;

#[cfg(test)]
mod test_meshes;

use glam::{DQuat, DVec3};
use shatter_core::Progress;
use shatter_core::config::{GeometrySource, PipelineConfig, Sampler, TransformConfig};
use shatter_core::particles::{Elements, ParticleMeta, ParticleSet};

use crate::bonds::{BondParams, build_bonds};
use crate::grid::{GridError, GridSample};
use crate::inside::FillRule;
use crate::mesh_query::MeshQuery;
use crate::repair::{MeshReport, repair};
use crate::tet_shell::{ShellError, ShellParams, TetShell, tet_shell};
use crate::voronoi_sampler::{SiteSpacing, VoronoiSample, VoronoiSamplerError, voronoi_sample};
use shatter_geometry::mesh::{MeshError, TriangleMesh};

/// Why preprocessing failed.
#[derive(Debug, thiserror::Error)]
pub enum PreprocessError {
    /// The mesh cannot be used (bad input: the CLI exits with code 2).
    #[error("geometry.source: {0}")]
    Mesh(#[from] MeshError),
    /// A setting is valid on its own but impossible for this geometry (bad input: exit code 2).
    #[error("{key} = {value}: {message}")]
    Setting {
        /// Dotted key.
        key: &'static str,
        /// The value.
        value: String,
        /// What is wrong.
        message: String,
    },
    /// The sampler's geometry failed on this mesh (bad input: exit code 2).
    #[error("geometry.sampler = \"{sampler}\": {message}")]
    Sampler {
        /// The sampler's name.
        sampler: &'static str,
        /// What failed.
        message: String,
    },
}

/// A particle set and what was learned making it.
#[derive(Debug, Clone)]
pub struct Preprocessed {
    /// The particles.
    pub particles: ParticleSet,
    /// What the mesh looked like and what was repaired (mesh sources only).
    pub mesh_report: Option<MeshReport>,
    /// Other things the user should know (snapped box sizes, voted cells).
    pub notes: Vec<String>,
}

/// Turns the scene's geometry into particles.
pub fn preprocess(config: &PipelineConfig, progress: &dyn Progress) -> Result<Preprocessed, PreprocessError> {
    let geometry = &config.geometry;
    let spacing = geometry.spacing_m;
    let mut notes = Vec::new();
    let mut mesh_report = None;
    let sample = match geometry.sampler {
        Sampler::Grid => match &geometry.source {
            GeometrySource::Box => {
                let size = geometry.box_size_m.unwrap_or_else(|| unreachable!("validated: a box has a size"));
                let (sample, snapped) = grid::fill_box(size, spacing).map_err(spacing_error(spacing))?;
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
                progress.start("fill", 0);
                let filled = grid::fill_mesh(&mesh, spacing, report.fill_rule);
                progress.finish();
                let (sample, inside) = filled.map_err(spacing_error(spacing))?;
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
            let rule = report.as_ref().map_or(FillRule::NonZero, |report| report.fill_rule);
            let query = MeshQuery::with_fill_rule(&mesh, rule);
            let particles = if geometry.sampler == Sampler::TetShell {
                tet_shell_particles(config, &mesh, &query, progress, &mut notes)?
            } else {
                voronoi_particles(config, &mesh, &query, progress, &mut notes)?
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
    if u32::try_from(sample.cells.len()).is_err() {
        return Err(PreprocessError::Setting {
            key: "geometry.spacing_m",
            value: spacing.to_string(),
            message: format!("{} particles: at most {} are supported", sample.cells.len(), u32::MAX),
        });
    }
    let particles = grid_particles(config, &sample, progress);
    Ok(Preprocessed { particles, mesh_report, notes })
}

fn spacing_error(spacing: f64) -> impl Fn(GridError) -> PreprocessError {
    move |GridError::TooLarge(message)| PreprocessError::Setting {
        key: "geometry.spacing_m",
        value: spacing.to_string(),
        message,
    }
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

/// The rigid motion from the sampling frame to the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Rotation about X, then Y, then Z.
    pub rotation: DQuat,
    /// Translation, metres.
    pub translation: DVec3,
}

impl Placement {
    /// The placement a transform table describes.
    pub fn new(transform: &TransformConfig) -> Placement {
        let [x, y, z] = transform.rotate_deg.map(f64::to_radians);
        Placement {
            rotation: DQuat::from_rotation_z(z) * DQuat::from_rotation_y(y) * DQuat::from_rotation_x(x),
            translation: DVec3::from_array(transform.translate_m),
        }
    }

    /// A sampling-frame point in world coordinates, rounded to f32.
    pub fn world(&self, p: DVec3) -> [f32; 3] {
        (self.rotation * p + self.translation).as_vec3().to_array()
    }
}

/// Cube particles on the lattice: world positions, volumes, masses, bonds and face adjacency.
fn grid_particles(config: &PipelineConfig, sample: &GridSample, progress: &dyn Progress) -> ParticleSet {
    let lambda = config.geometry.spacing_m;
    let delta = config.horizon_m();
    let placement = Placement::new(&config.geometry.transform);
    let points = sample.points();
    let rest_position_m: Vec<[f32; 3]> = points.iter().map(|p| placement.world(*p)).collect();
    let volume = lambda.powi(3);
    let mean_threshold = config.material.mean_critical_stretch(delta);
    let params = BondParams {
        delta_m: delta,
        mean_threshold,
        jitter: config.material.threshold_jitter,
        seed: config.scene.seed,
    };
    let bonds = build_bonds(&points, &rest_position_m, &params, progress);
    let n = points.len();
    ParticleSet {
        meta: particle_meta(config, lambda, delta, mean_threshold),
        rest_position_m,
        volume_m3: vec![volume as f32; n],
        mass_kg: vec![(volume * config.material.density_kg_m3) as f32; n],
        elements: Elements::Cubes {
            half_size_m: vec![(lambda * 0.5) as f32; n],
            orientation: placement.rotation.as_quat().to_array(),
        },
        bonds,
        adjacency: sample.adjacency.clone(),
    }
}

/// The particle file's scalars for a sampler with minimum distance `lambda` and horizon `delta`.
fn particle_meta(config: &PipelineConfig, lambda: f64, delta: f64, mean_threshold: f64) -> ParticleMeta {
    ParticleMeta {
        scene_name: config.scene.name.clone(),
        source: config.geometry.source.to_string(),
        sampler: config.geometry.sampler.name().to_string(),
        lambda_m: lambda,
        horizon_factor: config.geometry.horizon_factor,
        delta_m: delta,
        density_kg_m3: config.material.density_kg_m3,
        bulk_modulus_pa: config.material.bulk_modulus_pa,
        mean_critical_stretch: mean_threshold,
        threshold_jitter: config.material.threshold_jitter,
        seed: config.scene.seed,
    }
}

/// Particles at `points` (sampling frame) with `volumes` and `elements` (already in the world),
/// bonded within `lambda` times the horizon factor; element pairs in `adjacency` (indices into
/// `points`, a < b, sorted) that are not bonds are dropped, with a note.
#[allow(clippy::too_many_arguments)]
fn assemble(
    config: &PipelineConfig,
    lambda: f64,
    points: &[DVec3],
    volumes: &[f64],
    elements: Elements,
    mut adjacency: Vec<[u32; 2]>,
    progress: &dyn Progress,
    notes: &mut Vec<String>,
) -> ParticleSet {
    let delta = config.geometry.horizon_factor * lambda;
    let placement = Placement::new(&config.geometry.transform);
    let rest_position_m: Vec<[f32; 3]> = points.iter().map(|p| placement.world(*p)).collect();
    let mean_threshold = config.material.mean_critical_stretch(delta);
    let params = BondParams {
        delta_m: delta,
        mean_threshold,
        jitter: config.material.threshold_jitter,
        seed: config.scene.seed,
    };
    let bonds = build_bonds(points, &rest_position_m, &params, progress);
    let before = adjacency.len();
    adjacency.retain(|&[a, b]| bonds.find(a as usize, b).is_some());
    if adjacency.len() < before {
        notes.push(format!(
            "{} of {before} adjacent element pairs are farther apart than the horizon delta = {delta:.4e} m and are \
             not bonds: they were left out of the adjacency graph (a larger geometry.horizon_factor keeps them)",
            before - adjacency.len()
        ));
    }
    let density = config.material.density_kg_m3;
    ParticleSet {
        meta: particle_meta(config, lambda, delta, mean_threshold),
        rest_position_m,
        volume_m3: volumes.iter().map(|v| *v as f32).collect(),
        mass_kg: volumes.iter().map(|v| (v * density) as f32).collect(),
        elements,
        bonds,
        adjacency,
    }
}

/// Refuses particle counts the file cannot number.
fn check_count(key: &'static str, value: String, count: usize) -> Result<(), PreprocessError> {
    if u32::try_from(count).is_err() {
        return Err(PreprocessError::Setting {
            key,
            value,
            message: format!("{count} particles: at most {} are supported", u32::MAX),
        });
    }
    Ok(())
}

/// The tets of the layered shell as particles: barycentres, tet volumes, the tets in the world.
fn tet_shell_particles(
    config: &PipelineConfig,
    mesh: &TriangleMesh,
    query: &MeshQuery,
    progress: &dyn Progress,
    notes: &mut Vec<String>,
) -> Result<ParticleSet, PreprocessError> {
    let geometry = &config.geometry;
    let params = ShellParams {
        spacing: geometry.spacing_m,
        layers: geometry.tet_shell_layers(),
        layer_spacing: geometry.tet_shell_layer_spacing_m(),
        filled_core: geometry.tet_shell.filled_core,
        seed: config.scene.seed,
        keep_thick_surface_tets: true,
    };
    if f64::from(params.layers) <= geometry.horizon_factor {
        notes.push(format!(
            "geometry.tet_shell.layers = {} is not more than geometry.horizon_factor = {}: the shell is thinner than \
             the horizon (Levine et al. found that the layers should outnumber N)",
            params.layers, geometry.horizon_factor
        ));
    }
    let placement = Placement::new(&geometry.transform);
    let shell = tet_shell(mesh, query, &params, &|p| placement.world(p), progress);
    let shell = shell.map_err(|error| match error {
        ShellError::TooFine { .. } | ShellError::Empty => PreprocessError::Setting {
            key: "geometry.spacing_m",
            value: geometry.spacing_m.to_string(),
            message: error.to_string(),
        },
        ShellError::Delaunay(_) => PreprocessError::Sampler { sampler: "tet_shell", message: error.to_string() },
    })?;
    check_count("geometry.spacing_m", geometry.spacing_m.to_string(), shell.tets.len())?;
    notes.push(shell_note(&shell, &params));
    let TetShell { points, tets, barycentres, volumes, adjacency, .. } = shell;
    let vertices_m = tets.iter().map(|tet| tet.map(|v| placement.world(points.points[v as usize]))).collect();
    let elements = Elements::Tets { vertices_m };
    Ok(assemble(config, geometry.spacing_m, &barycentres, &volumes, elements, adjacency, progress, notes))
}

/// What the shell is made of, for the user.
fn shell_note(shell: &TetShell, params: &ShellParams) -> String {
    let removed = &shell.removed;
    let core = if params.filled_core { format!(" and {} core points", shell.points.core) } else { String::new() };
    format!(
        "tet shell: {} layers {:.4e} m apart ({} points per layer from the surface in){core}; {} of {} Delaunay \
         tets kept (left out: {} on the surface only, {} on the innermost layer only, {} outside the mesh, {} \
         deeper than the innermost layer, {} flat in f32)",
        params.layers,
        params.layer_spacing,
        shell.points.per_layer.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(", "),
        shell.tets.len(),
        shell.delaunay_tets,
        removed.outer,
        removed.inner,
        removed.outside,
        removed.deep,
        removed.flat,
    )
}

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
fn voronoi_particles(
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
    let mut plane_offsets = Vec::with_capacity(sites.len() + 1);
    let mut triangle_offsets = Vec::with_capacity(sites.len() + 1);
    plane_offsets.push(0u64);
    triangle_offsets.push(0u64);
    let mut planes = Vec::new();
    let mut triangles_m = Vec::new();
    for cell in &diagram.cells {
        for &[nx, ny, nz, d] in &cell.planes {
            let normal = placement.rotation * DVec3::new(nx, ny, nz);
            let offset = d + normal.dot(placement.translation);
            planes.push([normal.x as f32, normal.y as f32, normal.z as f32, offset as f32]);
        }
        triangles_m.extend(cell.triangles.iter().map(|triangle| triangle.map(|p| placement.world(p))));
        plane_offsets.push(planes.len() as u64);
        triangle_offsets.push(triangles_m.len() as u64);
    }
    let volumes: Vec<f64> = diagram.cells.iter().map(|cell| cell.volume).collect();
    let elements = Elements::Trimtopes { plane_offsets, planes, triangle_offsets, triangles_m };
    Ok(assemble(config, lambda, &sites, &volumes, elements, diagram.adjacency, progress, notes))
}
