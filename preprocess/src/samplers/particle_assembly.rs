//! What the samplers' glue shares to make a particle set: the placement from the sampling frame
//! into the world, bonds within the horizon, masses from volumes, the file's scalars, and the limit
//! on the particle count.

use glam::{DQuat, DVec3};
use shatter_core::Progress;
use shatter_core::config::{PipelineConfig, TransformConfig};
use shatter_core::particles::{Elements, ParticleMeta, ParticleSet};

use crate::bonds::{BondParams, build_bonds};
use crate::preprocess_driver::PreprocessError;

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
        self.world_f64(p).as_vec3().to_array()
    }

    /// A sampling-frame point in world coordinates.
    pub fn world_f64(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.translation
    }

    /// The particle positions the file stores for sampling-frame `points`: [`Placement::world`]
    /// of each.
    pub fn stored_positions(&self, points: &[DVec3]) -> Vec<[f32; 3]> {
        points.iter().map(|p| self.world(*p)).collect()
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

/// What a sampler made, for [`assemble`] to bond: its particles in the sampling frame and as the
/// file stores them.
pub(super) struct Sampled<'a> {
    /// The sampler's minimum distance between particles.
    pub lambda_m: f64,
    /// The particles, sampling frame.
    pub points: &'a [DVec3],
    /// The particles as the file stores them (world).
    pub rest_position_m: Vec<[f32; 3]>,
    /// The particles' volumes.
    pub volume_m3: &'a [f64],
    /// The elements, already in the world.
    pub elements: Elements,
    /// Adjacent element pairs (indices into `points`, a < b, sorted).
    pub adjacency: Vec<[u32; 2]>,
}

/// The particles of `sampled`, bonded within `lambda_m` times the horizon factor; element pairs of
/// its adjacency that are not bonds are dropped, with a note.
pub(super) fn assemble(
    config: &PipelineConfig,
    sampled: Sampled,
    progress: &dyn Progress,
    notes: &mut Vec<String>,
) -> ParticleSet {
    let Sampled { lambda_m: lambda, points, rest_position_m, volume_m3: volumes, elements, mut adjacency } = sampled;
    let delta = config.geometry.horizon_factor * lambda;
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
pub(super) fn check_count(key: &'static str, value: String, count: usize) -> Result<(), PreprocessError> {
    if u32::try_from(count).is_err() {
        return Err(PreprocessError::Setting {
            key,
            value,
            message: format!("{count} particles: at most {} are supported", u32::MAX),
        });
    }
    Ok(())
}
