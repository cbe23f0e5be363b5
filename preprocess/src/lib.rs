//! Preprocessing: from a scene's geometry to a particle set.
//!
//! The source (a box or a closed mesh, repaired as [`repair`] describes) is scaled into metres,
//! sampled into particles in that frame (for now by the [`grid`] sampler), ordered along a
//! Z-curve, bonded within the horizon by k-d tree range queries ([`bonds`]), and finally rotated
//! and translated into the world.

pub mod blue_noise;
pub mod bonds;
pub mod delaunay;
pub mod grid;
pub mod inside;
pub mod kdtree;
pub mod lattice;
pub mod mesh;
pub mod mesh_query;
pub mod repair;
pub mod voronoi;

use glam::{DQuat, DVec3};
use shatter_core::Progress;
use shatter_core::config::{GeometrySource, PipelineConfig, Sampler, TransformConfig};
use shatter_core::particles::{Elements, ParticleMeta, ParticleSet};

use crate::bonds::{BondParams, build_bonds};
use crate::grid::{GridError, GridSample};
use crate::mesh::{MeshError, TriangleMesh};
use crate::repair::{MeshReport, repair};

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
    /// The sampler is part of the design but not built yet.
    #[error("geometry.sampler = \"{sampler}\" is not available yet: it arrives with issue #{issue}")]
    SamplerNotImplemented {
        /// The sampler's name.
        sampler: &'static str,
        /// The issue that delivers it.
        issue: u32,
    },
}

impl PreprocessError {
    /// True when the user must fix the config or the mesh; false for a sampler not built yet.
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, PreprocessError::SamplerNotImplemented { .. })
    }
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
        Sampler::TetShell => return Err(PreprocessError::SamplerNotImplemented { sampler: "tet_shell", issue: 4 }),
        Sampler::Voronoi => return Err(PreprocessError::SamplerNotImplemented { sampler: "voronoi", issue: 5 }),
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
        meta: ParticleMeta {
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
        },
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
