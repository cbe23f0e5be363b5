//! Which backend runs a simulation: the one place that knows both, the CPU
//! [`CpuSimulation`] and the GPU [`GpuSimulation`], and picks one for `sim.backend` (or
//! `--backend`).

use shatter_core::PipelineConfig;
use shatter_core::config::material::MaterialModel;
use shatter_core::config::sim::BackendChoice;
use shatter_core::particles::ParticleSet;
use shatter_gpu::{AdapterChoice, GpuContext, GpuError};

use crate::backend::Backend;
use crate::cpu_simulation::CpuSimulation;
use crate::gpu::{GpuOptions, GpuSimulation};
use crate::model::Model;
use crate::{SimError, art};

/// Why no backend could be made.
#[derive(Debug, thiserror::Error)]
pub enum BackendError {
    /// The config or particle file cannot make a sound run.
    #[error(transparent)]
    Input(#[from] SimError),
    /// `--backend gpu` without a usable GPU, or a GPU failure while setting up.
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// The backend `choice` asks for, for a config and its particles: `Cpu` the CPU path; `Gpu` the
/// GPU (an error naming what was found when there is none); `Auto` a hardware GPU when wgpu
/// finds one, else the CPU. Software adapters (Mesa lavapipe) count only with
/// `SHATTER_GPU_ALLOW_SOFTWARE=1` (see [`AdapterChoice::from_env`]). Also returns a warning when
/// `Auto` found a GPU but could not use it and fell back to the CPU.
pub fn create_backend(
    config: &PipelineConfig,
    particles: &ParticleSet,
    choice: BackendChoice,
) -> Result<(Box<dyn Backend>, Option<String>), BackendError> {
    // grips on the GPU are written for the elastoplastic model's force pass only
    if !config.sim.grip.is_empty() && config.material.model == MaterialModel::Pmb {
        if choice == BackendChoice::Gpu {
            return Err(SimError::BadInput(
                "[[sim.grip]] with material.model = \"pmb\" runs on the CPU backend only; set sim.backend = \"cpu\" \
                 or \"auto\""
                    .into(),
            )
            .into());
        }
        return Ok((Box::new(CpuSimulation::from_config(config, particles)?), None));
    }
    let gpu = match choice {
        BackendChoice::Cpu => None,
        BackendChoice::Gpu => Some(GpuContext::new(AdapterChoice::from_env())?),
        BackendChoice::Auto => GpuContext::new(AdapterChoice::from_env()).ok(),
    };
    let Some(ctx) = gpu else {
        return Ok((Box::new(CpuSimulation::from_config(config, particles)?), None));
    };
    let model = Model::new(config, particles)?;
    let factors = art::threshold_factors(&config.sim, particles, config.scene.seed)?;
    let correction = config.sim.stiffness_correction;
    match GpuSimulation::new(ctx.into(), particles, model, factors.as_deref(), correction, &GpuOptions::default()) {
        Ok(simulation) => Ok((Box::new(simulation), None)),
        Err(error) if choice == BackendChoice::Auto => {
            let warning = format!("the GPU could not run this scene ({error}); running on the CPU");
            Ok((Box::new(CpuSimulation::from_config(config, particles)?), Some(warning)))
        }
        Err(error) => Err(error.into()),
    }
}
