//! The material values of bond entries, the same in every layout: the CPU's row and lattice
//! layouts and the GPU's.

use rayon::prelude::*;
use shatter_core::config::sim::StiffnessCorrection;
use shatter_core::particles::ParticleSet;

/// The material values of bond entries, the same for both backends: the stiffness
/// k = c V_i V_j g_ij, with g_ij the mean of the two particles' stiffness factors, and the file's
/// threshold times the material's rescale and the art-direction factor of the entry.
pub(crate) struct EntryValues<'a> {
    particles: &'a ParticleSet,
    bond_constant: f64,
    threshold_scale: f64,
    factors: Option<&'a [f32]>,
    correction: Vec<f64>,
}

impl<'a> EntryValues<'a> {
    /// The values for `particles` with bond constant `c`, thresholds scaled by `threshold_scale`
    /// and by `factors` (one per file entry), and the stiffness correction.
    pub(crate) fn new(
        particles: &'a ParticleSet,
        bond_constant: f64,
        threshold_scale: f64,
        factors: Option<&'a [f32]>,
        correction: StiffnessCorrection,
    ) -> EntryValues<'a> {
        let correction = stiffness_factors(particles, correction);
        EntryValues { particles, bond_constant, threshold_scale, factors, correction }
    }

    /// Stiffness of the bond between particles i and j, N per unit stretch.
    pub(crate) fn stiffness(&self, i: usize, j: usize) -> f32 {
        let volume = &self.particles.volume_m3;
        let g = 0.5 * (self.correction[i] + self.correction[j]);
        (self.bond_constant * f64::from(volume[i]) * f64::from(volume[j]) * g) as f32
    }

    /// Critical stretch of file entry `k`.
    pub(crate) fn threshold(&self, k: usize) -> f32 {
        let factor = self.factors.map_or(1.0, |f| f64::from(f[k]));
        (f64::from(self.particles.bonds.threshold[k]) * self.threshold_scale * factor) as f32
    }
}

/// Per-particle stiffness factors g_i. `Energy`: g_i = pi delta^4 / sum_j |xi_ij| V_j, which makes
/// a uniform dilation store exactly the continuum energy density 4.5 K s^2 at particle i.
fn stiffness_factors(particles: &ParticleSet, correction: StiffnessCorrection) -> Vec<f64> {
    let n = particles.len();
    match correction {
        StiffnessCorrection::None => vec![1.0; n],
        StiffnessCorrection::Energy => {
            let bonds = &particles.bonds;
            let target = std::f64::consts::PI * particles.meta.delta_m.powi(4);
            (0..n)
                .into_par_iter()
                .map(|i| {
                    let sum: f64 = bonds
                        .row(i)
                        .map(|k| {
                            f64::from(bonds.rest_length_m[k])
                                * f64::from(particles.volume_m3[bonds.neighbor[k] as usize])
                        })
                        .sum();
                    if sum > 0.0 { target / sum } else { 1.0 }
                })
                .collect()
        }
    }
}
