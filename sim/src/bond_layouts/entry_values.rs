//! The material values of bond entries, the same in every layout: the CPU's row and lattice
//! layouts and the GPU's.

use rayon::prelude::*;
use shatter_core::config::sim::{PartialVolumes, StiffnessCorrection};
use shatter_core::particles::ParticleSet;

/// The material values of bond entries, the same for both backends: the stiffness
/// k = c V_i V_j g_ij v_ij, with g_ij the mean of the two particles' stiffness factors and v_ij
/// the partial-volume scale (1 without partial volumes), and the file's threshold times the
/// material's rescale and the art-direction factor of the entry.
pub(crate) struct EntryValues<'a> {
    particles: &'a ParticleSet,
    bond_constant: f64,
    threshold_scale: f64,
    factors: Option<&'a [f32]>,
    correction: Vec<f64>,
    partial_volumes: PartialVolumes,
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
        partial_volumes: PartialVolumes,
    ) -> EntryValues<'a> {
        let correction = stiffness_factors(particles, correction, partial_volumes);
        EntryValues { particles, bond_constant, threshold_scale, factors, correction, partial_volumes }
    }

    /// Stiffness of the bond between particles i and j at rest length `rest_length_m`, N per
    /// unit stretch.
    pub(crate) fn stiffness(&self, i: usize, j: usize, rest_length_m: f32) -> f32 {
        let volume = &self.particles.volume_m3;
        let g = 0.5 * (self.correction[i] + self.correction[j]);
        let k = self.bond_constant * f64::from(volume[i]) * f64::from(volume[j]) * g;
        match self.partial_volumes {
            PartialVolumes::None => k as f32,
            PartialVolumes::Lammps => {
                let meta = &self.particles.meta;
                (k * partial_volume_scale(f64::from(rest_length_m), meta.delta_m, meta.lambda_m)) as f32
            }
        }
    }

    /// Critical stretch of file entry `k`.
    pub(crate) fn threshold(&self, k: usize) -> f32 {
        let factor = self.factors.map_or(1.0, |f| f64::from(f[k]));
        (f64::from(self.particles.bonds.threshold[k]) * self.threshold_scale * factor) as f32
    }
}

/// LAMMPS's partial-volume scale (`pair_style peri/pmb`): a neighbour whose rest distance `xi`
/// lies within half a lattice spacing of the horizon `delta` counts with the part of its cell
/// inside the horizon, linearly: (delta + lambda/2 - xi) / lambda; nearer ones count whole.
pub fn partial_volume_scale(xi: f64, delta: f64, lambda: f64) -> f64 {
    let half = 0.5 * lambda;
    if (xi - delta).abs() <= half { (delta + half - xi) / lambda } else { 1.0 }
}

/// Per-particle stiffness factors g_i. `Energy`: g_i = pi delta^4 / sum_j |xi_ij| V_j v_ij, which
/// makes a uniform dilation store exactly the continuum energy density 4.5 K s^2 at particle i
/// (v_ij the partial-volume scale, 1 without partial volumes).
fn stiffness_factors(
    particles: &ParticleSet,
    correction: StiffnessCorrection,
    partial_volumes: PartialVolumes,
) -> Vec<f64> {
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
                            let xi = f64::from(bonds.rest_length_m[k]);
                            let scale = match partial_volumes {
                                PartialVolumes::None => 1.0,
                                PartialVolumes::Lammps => {
                                    partial_volume_scale(xi, particles.meta.delta_m, particles.meta.lambda_m)
                                }
                            };
                            xi * f64::from(particles.volume_m3[bonds.neighbor[k] as usize]) * scale
                        })
                        .sum();
                    if sum > 0.0 { target / sum } else { 1.0 }
                })
                .collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::partial_volume_scale;

    #[test]
    fn the_partial_volume_scale_falls_linearly_across_the_horizon() {
        let (delta, lambda) = (3.0002e-3, 1e-3);
        assert_eq!(partial_volume_scale(1e-3, delta, lambda), 1.0);
        assert!((partial_volume_scale(delta - 0.5 * lambda, delta, lambda) - 1.0).abs() < 1e-12);
        assert!((partial_volume_scale(delta, delta, lambda) - 0.5).abs() < 1e-12);
        assert!((partial_volume_scale(3e-3, delta, lambda) - 0.5002).abs() < 1e-12, "LAMMPS's (3,0,0) bond");
        assert!(partial_volume_scale(delta + 0.5 * lambda, delta, lambda).abs() < 1e-12);
    }
}
