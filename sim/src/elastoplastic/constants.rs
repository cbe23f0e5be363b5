//! The elastoplastic model's constants.

use shatter_core::PipelineConfig;
use shatter_core::config::material::{AnisotropyConfig, Normalisation};

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
}
