//! What `shatter sim` needs of a backend, whichever runs the steps: the CPU
//! [`CpuSimulation`](crate::CpuSimulation) or the GPU [`GpuSimulation`](crate::GpuSimulation). The
//! frame loop, checkpoints, resume and stability checks in [`crate::sim_driver`] see only this
//! trait; [`crate::backend_choice`] makes one.
//!
//! Host-side state ([`Backend::dynamics`], energy, damage) is current after
//! [`Backend::finish_frame`] (and after construction, [`Backend::restore`] and the `set_*`
//! calls): the GPU backend reads its state back only then, never inside the step loop.

use std::error::Error;
use std::fmt;

use glam::DVec3;
use shatter_core::frames::BreakEvent;

use crate::model::Model;
use crate::simd_path::SimdPath;
use crate::state::{Dynamics, Energy};

/// A backend failed while running (e.g. the GPU reported an error mid-run). It carries the
/// backend's own error, and reads (as text and as a source chain) exactly as that error does.
#[derive(Debug)]
pub struct DeviceError(Box<dyn Error + Send + Sync>);

impl DeviceError {
    /// Wraps a backend's error.
    pub fn new(error: impl Error + Send + Sync + 'static) -> DeviceError {
        DeviceError(Box::new(error))
    }

    /// The backend's error, e.g. to downcast it to the backend's own error type.
    pub fn inner(&self) -> &(dyn Error + Send + Sync + 'static) {
        self.0.as_ref()
    }
}

impl fmt::Display for DeviceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.0, f)
    }
}

impl Error for DeviceError {
    fn source(&self) -> Option<&(dyn Error + 'static)> {
        self.0.source()
    }
}

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
    fn advance(&mut self, steps: u64) -> Result<(), DeviceError>;
    /// At a frame boundary: brings the host-side state up to date and returns the bonds broken
    /// since the last call, in the order (step, bond id).
    fn finish_frame(&mut self) -> Result<Vec<BreakEvent>, DeviceError>;
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
    /// The instruction set of the CPU kernels (`None`: the backend is not the CPU's).
    fn simd_path(&self) -> Option<SimdPath> {
        None
    }
    /// Replaces the state with a checkpoint's; `broken_bonds` (sorted ids) are marked broken.
    fn restore(&mut self, dynamics: Dynamics, broken_bonds: &[u64]) -> Result<(), DeviceError>;
    /// The material model's per-bond state, one value per particle-file bond entry (the
    /// elastoplastic model's plastic extensions), as of the last frame boundary; empty for a
    /// model that keeps none.
    fn bond_state(&self) -> Vec<f32> {
        Vec::new()
    }
    /// Restores [`Backend::bond_state`] (after [`Backend::restore`]); fails, naming what does not
    /// fit, when `state` is not this model's.
    fn set_bond_state(&mut self, state: &[f32]) -> Result<(), String> {
        if state.is_empty() {
            Ok(())
        } else {
            Err(format!("{} per-bond values for a model that keeps none", state.len()))
        }
    }
    /// Sets velocities (initial conditions, tests).
    fn set_velocity(&mut self, velocity: &dyn Fn(usize, [f32; 3]) -> [f32; 3]) -> Result<(), DeviceError>;
    /// Sets displacements and recomputes the forces (bonds may break, at the current step).
    fn set_displacement(&mut self, displacement: &dyn Fn(usize, [f32; 3]) -> [f32; 3]) -> Result<(), DeviceError>;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An error with a source, as a backend's error may be.
    #[derive(Debug)]
    struct Outer(std::io::Error);

    impl fmt::Display for Outer {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            write!(f, "outer: {}", self.0)
        }
    }

    impl Error for Outer {
        fn source(&self) -> Option<&(dyn Error + 'static)> {
            Some(&self.0)
        }
    }

    #[test]
    fn a_device_error_reads_as_the_backends_error() {
        let error = DeviceError::new(Outer(std::io::Error::other("lost")));
        assert_eq!(error.to_string(), "outer: lost");
        assert_eq!(error.source().map(ToString::to_string), Some("lost".to_string()));
        assert!(error.inner().downcast_ref::<Outer>().is_some());
    }
}
