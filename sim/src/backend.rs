//! What `shatter sim` needs of a backend, whichever runs the steps: the CPU [`Simulation`] or the
//! GPU [`GpuSimulation`]. The frame loop, checkpoints, resume and stability checks in
//! [`crate::sim_driver`] see only this trait.
//!
//! Host-side state ([`Backend::dynamics`], energy, damage) is current after
//! [`Backend::finish_frame`] (and after construction, [`Backend::restore`] and the `set_*`
//! calls): the GPU backend reads its state back only then, never inside the step loop.

use glam::DVec3;
use shatter_core::PipelineConfig;
use shatter_core::config::sim::Backend as BackendChoice;
use shatter_core::particles::ParticleSet;
use shatter_gpu::{AdapterChoice, GpuContext, GpuError};

use crate::gpu::{GpuOptions, GpuSimulation};
use crate::model::Model;
use shatter_core::frames::BreakEvent;

use crate::simulation::{Dynamics, Energy, Simulation};
use crate::{SimError, art};

/// A simulation backend.
pub trait Backend {
    /// What runs the steps, e.g. "CPU (8 threads)" or the GPU adapter's name.
    fn describe(&self) -> String;
    /// Number of particles.
    fn len(&self) -> usize;
    /// True without particles.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The model.
    fn model(&self) -> &Model;
    /// Advances `steps` steps of velocity Verlet.
    fn advance(&mut self, steps: u64) -> Result<(), GpuError>;
    /// At a frame boundary: brings the host-side state up to date and returns the bonds broken
    /// since the last call, in the order (step, bond id).
    fn finish_frame(&mut self) -> Result<Vec<BreakEvent>, GpuError>;
    /// The state (as of the last frame boundary).
    fn dynamics(&self) -> &Dynamics;
    /// Kinetic and bond energy.
    fn energy(&self) -> Energy;
    /// Each particle's share of the bond energy, joules.
    fn bond_energy_per_particle(&self) -> Vec<f64>;
    /// Current positions x = X + u, metres.
    fn positions(&self) -> [Vec<f32>; 3];
    /// Fraction of each particle's bonds that are broken.
    fn damage(&self) -> Vec<f32>;
    /// Particle masses, kg.
    fn mass(&self) -> &[f32];
    /// Rest positions, metres.
    fn rest(&self) -> [&[f32]; 3];
    /// Linear momentum (kg m/s) and angular momentum about the origin (kg m^2/s), summed in f64
    /// in particle order.
    fn momentum(&self) -> (DVec3, DVec3) {
        let (mass, rest, dynamics) = (self.mass(), self.rest(), self.dynamics());
        let mut linear = DVec3::ZERO;
        let mut angular = DVec3::ZERO;
        for (i, &m) in mass.iter().enumerate() {
            let m = f64::from(m);
            let v = DVec3::from_array([0, 1, 2].map(|a| f64::from(dynamics.vel[a][i])));
            let x = DVec3::from_array([0, 1, 2].map(|a| f64::from(rest[a][i]) + f64::from(dynamics.disp[a][i])));
            linear += m * v;
            angular += m * x.cross(v);
        }
        (linear, angular)
    }
    /// Simulated time, seconds.
    fn time_s(&self) -> f64 {
        self.dynamics().step as f64 * self.model().dt_s
    }
    /// The largest stable time step, seconds.
    fn stable_dt_s(&self) -> f64;
    /// Replaces the state with a checkpoint's; `broken_bonds` (sorted ids) are marked broken.
    fn restore(&mut self, dynamics: Dynamics, broken_bonds: &[u64]) -> Result<(), GpuError>;
    /// Sets velocities (initial conditions, tests).
    fn set_velocity(&mut self, velocity: &dyn Fn(usize, [f32; 3]) -> [f32; 3]) -> Result<(), GpuError>;
    /// Sets displacements and recomputes the forces (bonds may break, at the current step).
    fn set_displacement(&mut self, displacement: &dyn Fn(usize, [f32; 3]) -> [f32; 3]) -> Result<(), GpuError>;
}

impl Backend for Simulation {
    fn describe(&self) -> String {
        format!("CPU ({} threads)", rayon::current_num_threads())
    }

    fn len(&self) -> usize {
        Simulation::len(self)
    }

    fn model(&self) -> &Model {
        Simulation::model(self)
    }

    fn advance(&mut self, steps: u64) -> Result<(), GpuError> {
        for _ in 0..steps {
            self.step();
        }
        Ok(())
    }

    fn finish_frame(&mut self) -> Result<Vec<BreakEvent>, GpuError> {
        Ok(self.take_breaks())
    }

    fn dynamics(&self) -> &Dynamics {
        Simulation::dynamics(self)
    }

    fn energy(&self) -> Energy {
        Simulation::energy(self)
    }

    fn bond_energy_per_particle(&self) -> Vec<f64> {
        Simulation::bond_energy_per_particle(self)
    }

    fn positions(&self) -> [Vec<f32>; 3] {
        Simulation::positions(self)
    }

    fn damage(&self) -> Vec<f32> {
        Simulation::damage(self)
    }

    fn mass(&self) -> &[f32] {
        Simulation::mass(self)
    }

    fn rest(&self) -> [&[f32]; 3] {
        Simulation::rest(self)
    }

    fn time_s(&self) -> f64 {
        Simulation::time_s(self)
    }

    fn stable_dt_s(&self) -> f64 {
        Simulation::stable_dt_s(self)
    }

    fn restore(&mut self, dynamics: Dynamics, broken_bonds: &[u64]) -> Result<(), GpuError> {
        Simulation::restore(self, dynamics, broken_bonds);
        Ok(())
    }

    fn set_velocity(&mut self, velocity: &dyn Fn(usize, [f32; 3]) -> [f32; 3]) -> Result<(), GpuError> {
        Simulation::set_velocity(self, velocity);
        Ok(())
    }

    fn set_displacement(&mut self, displacement: &dyn Fn(usize, [f32; 3]) -> [f32; 3]) -> Result<(), GpuError> {
        Simulation::set_displacement(self, displacement);
        Ok(())
    }
}

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
    let gpu = match choice {
        BackendChoice::Cpu => None,
        BackendChoice::Gpu => Some(GpuContext::new(AdapterChoice::from_env())?),
        BackendChoice::Auto => GpuContext::new(AdapterChoice::from_env()).ok(),
    };
    let Some(ctx) = gpu else {
        return Ok((Box::new(Simulation::from_config(config, particles)?), None));
    };
    let model = Model::new(config, particles)?;
    let factors = art::threshold_factors(&config.sim, particles, config.scene.seed)?;
    let correction = config.sim.stiffness_correction;
    match GpuSimulation::new(ctx.into(), particles, model, factors.as_deref(), correction, &GpuOptions::default()) {
        Ok(simulation) => Ok((Box::new(simulation), None)),
        Err(error) if choice == BackendChoice::Auto => {
            let warning = format!("the GPU could not run this scene ({error}); running on the CPU");
            Ok((Box::new(Simulation::from_config(config, particles)?), Some(warning)))
        }
        Err(error) => Err(error.into()),
    }
}
