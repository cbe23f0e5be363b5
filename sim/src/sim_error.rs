//! [`SimError`]: what is wrong with a run's inputs (the particle file, the start state, the art
//! direction), found by the checks of [`crate::model`] and [`crate::art`] before any step runs.

/// Why a simulation cannot start or had to stop.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The particle file does not match the config's geometry.
    #[error("{0}")]
    StaleParticles(String),
    /// Something would start inside the body or below the floor.
    #[error("{0}")]
    BadStart(String),
    /// An input of the run (a seam mesh, a setting) is unusable.
    #[error("{0}")]
    BadInput(String),
}
