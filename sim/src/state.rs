//! What every backend keeps and reports alike: the state of a run ([`Dynamics`]) and its
//! energies ([`Energy`]).

use rayon::prelude::*;

/// The mutable state of a run, everything a checkpoint must hold.
#[derive(Debug, Clone, PartialEq)]
pub struct Dynamics {
    /// Steps taken.
    pub step: u64,
    /// Displacements u, metres (x, y, z arrays).
    pub disp: [Vec<f32>; 3],
    /// Velocities, m/s.
    pub vel: [Vec<f32>; 3],
    /// Forces at the current step, newtons.
    pub force: [Vec<f32>; 3],
    /// Compression boost of each particle's thresholds for the next step.
    pub boost: Vec<f32>,
    /// Work done on the body by external forces so far, joules.
    pub external_work_j: f64,
}

/// Energies of the current state, joules.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Energy {
    /// 1/2 sum m v^2.
    pub kinetic_j: f64,
    /// sum over intact bonds of 1/2 k s^2 L.
    pub bond_j: f64,
}

impl Energy {
    /// Kinetic plus bond energy.
    pub fn total_j(&self) -> f64 {
        self.kinetic_j + self.bond_j
    }
}

/// 1/2 sum m v^2 in f64, summed per chunk of `chunk_size` particles in particle order and then
/// over chunks, so that it does not depend on the thread count.
pub(crate) fn kinetic_energy_j(mass: &[f32], vel: &[Vec<f32>; 3], chunk_size: usize) -> f64 {
    mass.par_chunks(chunk_size)
        .enumerate()
        .map(|(c, masses)| {
            let first = c * chunk_size;
            masses
                .iter()
                .enumerate()
                .map(|(local, m)| {
                    let i = first + local;
                    let v2: f64 = (0..3).map(|a| f64::from(vel[a][i]).powi(2)).sum();
                    0.5 * f64::from(*m) * v2
                })
                .sum::<f64>()
        })
        .collect::<Vec<f64>>()
        .iter()
        .sum()
}
