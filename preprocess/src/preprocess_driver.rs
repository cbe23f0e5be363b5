//! The preprocessing stage's driver: [`preprocess`] turns a scene's geometry into the particle set
//! the simulation reads, by way of the [`samplers`](crate::samplers) dispatch, and says what it
//! learned on the way ([`Preprocessed`]) or why it could not ([`PreprocessError`]).

use shatter_core::Progress;
use shatter_core::config::PipelineConfig;
use shatter_core::memory::MemoryError;
use shatter_core::particles::ParticleSet;
use shatter_geometry::mesh::MeshError;

use crate::repair::MeshReport;
use crate::samplers::sample_geometry;

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
    /// The stage would not fit in memory (bad input: exit code 2).
    #[error(transparent)]
    Memory(#[from] MemoryError),
    /// The particle set these settings make would be refused by the simulation (bad input: exit
    /// code 2); nothing is written.
    #[error(
        "these settings make a particle set the simulation cannot use ({0}); check the [material] and [geometry] values"
    )]
    Unusable(String),
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

/// Turns the scene's geometry into particles: the source loaded, repaired and sampled by the
/// scene's sampler, bonded, and placed in the world (see the [crate documentation](crate)).
pub fn preprocess(config: &PipelineConfig, progress: &dyn Progress) -> Result<Preprocessed, PreprocessError> {
    let result = sample_geometry(config, progress)?;
    result.particles.validate().map_err(PreprocessError::Unusable)?;
    Ok(result)
}
