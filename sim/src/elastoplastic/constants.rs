//! The elastoplastic model's constants.

use rayon::prelude::*;
use shatter_core::PipelineConfig;
use shatter_core::config::material::{AnisotropyConfig, Normalisation};
use shatter_core::particles::ParticleSet;

/// What the state-based passes need of the material besides the bonds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateBasedConstants {
    /// Bulk modulus K, Pa.
    pub bulk_modulus_pa: f64,
    /// Shear modulus mu, Pa.
    pub shear_modulus_pa: f64,
    /// The deviatoric force scalar t_dev at which a bond yields, sqrt(Psi_0 / 2) N/m^6 (the
    /// paper's yield function A_dev^2 / 2 = Psi_0 on A_dev = 2 t_dev); infinite: no plasticity.
    pub yield_force_n_m6: f64,
    /// gamma / |xi|, the cap of the plastic extension over the rest length; infinite: no cap.
    pub plastic_cap_ratio: f64,
    /// The paper's alpha of eq. 18: thresholds grow by (1 + alpha phi) with damage phi.
    pub damage_strengthening: f64,
    /// How the family sums are normalised.
    pub normalisation: Normalisation,
    /// Fibres, if any: each particle's anisotropy matrix G.
    pub anisotropy: Option<AnisotropyConfig>,
}

impl StateBasedConstants {
    /// The influence omega = delta / |G xi| of a bond with rest vector `xi` from a particle at
    /// `x` (delta / |xi| without anisotropy).
    pub fn influence(&self, delta_m: f64, x: [f32; 3], xi: [f32; 3]) -> f32 {
        let xi = xi.map(f64::from);
        let g_xi = match &self.anisotropy {
            None => xi,
            Some(anisotropy) => {
                // G = I - (1 - 1 / ratio) d d^T
                let d = anisotropy.fibre_at(x.map(f64::from));
                let along = (1.0 - 1.0 / anisotropy.ratio) * (d[0] * xi[0] + d[1] * xi[1] + d[2] * xi[2]);
                [0, 1, 2].map(|a| xi[a] - along * d[a])
            }
        };
        (delta_m / (g_xi[0] * g_xi[0] + g_xi[1] * g_xi[1] + g_xi[2] * g_xi[2]).sqrt()) as f32
    }

    /// The constants a config gives for horizon `delta_m`.
    pub fn of(config: &PipelineConfig, delta_m: f64) -> StateBasedConstants {
        let material = &config.material;
        StateBasedConstants {
            bulk_modulus_pa: material.bulk_modulus_pa,
            shear_modulus_pa: material.shear_modulus_pa(),
            yield_force_n_m6: material.yield_psi0(delta_m).map_or(f64::INFINITY, |psi0| (0.5 * psi0).sqrt()),
            plastic_cap_ratio: material.plastic_cap_ratio.unwrap_or(f64::INFINITY),
            damage_strengthening: material.damage_strengthening.unwrap_or(0.0),
            normalisation: material.normalisation,
            anisotropy: material.anisotropy,
        }
    }

    /// Each particle's weighted volume m_i, m^5: the sum of omega |xi|^2 V_j over its family in
    /// the particle file's order (or pi delta^5 with the analytic constants, and for a particle
    /// without bonds, which feels no bond force: any m does).
    pub fn weighted_volumes(&self, particles: &ParticleSet) -> Vec<f32> {
        let delta = particles.meta.delta_m;
        let analytic = (std::f64::consts::PI * delta.powi(5)) as f32;
        let (bonds, position) = (&particles.bonds, &particles.rest_position_m);
        (0..particles.len())
            .into_par_iter()
            .map(|i| match self.normalisation {
                Normalisation::Analytic => analytic,
                Normalisation::WeightedVolume => {
                    let sum: f64 = bonds
                        .row(i)
                        .map(|k| {
                            let j = bonds.neighbor[k] as usize;
                            let xi = [0, 1, 2].map(|axis| position[j][axis] - position[i][axis]);
                            let rest = f64::from(bonds.rest_length_m[k]);
                            let v = f64::from(particles.volume_m3[j]);
                            f64::from(self.influence(delta, position[i], xi)) * rest * rest * v
                        })
                        .sum();
                    if sum > 0.0 { sum as f32 } else { analytic }
                }
            })
            .collect()
    }

    /// Each particle's [V, 15 mu / m, 3 K / m, yield force] (volume m^3, the deviatoric and
    /// dilatational constants, and the deviatoric force scalar at which its bonds yield) for
    /// volumes `volume` and weighted volumes `weighted` at horizon `delta_m`.
    pub fn particle_values(&self, volume: &[f32], weighted: &[f32], delta_m: f64) -> Vec<[f32; 4]> {
        let sphere = std::f64::consts::PI * delta_m.powi(5);
        volume
            .iter()
            .zip(weighted)
            .map(|(v, m)| {
                let m = f64::from(*m);
                [
                    *v,
                    (15.0 * self.shear_modulus_pa / m) as f32,
                    (3.0 * self.bulk_modulus_pa / m) as f32,
                    // the yield force scales as the force does, so a cut family yields at the
                    // same stress
                    (self.yield_force_n_m6 * sphere / m) as f32,
                ]
            })
            .collect()
    }
}
