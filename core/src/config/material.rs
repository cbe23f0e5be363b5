//! `[material]`: density, stiffness, strength, and the material model that uses them: Levine et
//! al.'s bond-based PMB (the default) or Chen et al.'s state-based elastoplastic model.

use serde::{Deserialize, Serialize};

use super::checker::Checker;
use super::{ConfigError, lammps_terms};

/// The fracture energy used when a scene gives neither it nor a critical stretch: soda-lime glass.
pub const DEFAULT_FRACTURE_ENERGY_J_M2: f64 = 8.0;
/// The largest per-bond threshold jitter accepted, as a fraction of the mean threshold.
pub const MAX_THRESHOLD_JITTER: f64 = 0.2;

/// The material model (`material.model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MaterialModel {
    /// Bond-based prototype microelastic brittle model (Silling and Askari; Levine et al.):
    /// Poisson's ratio fixed at 1/4, brittle.
    #[default]
    Pmb,
    /// Ordinary state-based model with dilatation and deviatoric parts, per-bond plasticity and
    /// ductile fracture (Chen et al. section 4; the linear peridynamic solid of Silling et al. 2007).
    Elastoplastic,
}

impl MaterialModel {
    fn is_pmb(&self) -> bool {
        *self == MaterialModel::Pmb
    }
}

/// How the state-based model normalises its sums over a particle's family
/// (`material.normalisation`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Normalisation {
    /// Each particle's weighted volume m_i = sum of omega |xi|^2 V_j over its actual family
    /// (Silling et al. 2007; LAMMPS's `peri/lps`): exact for uniform strain at free surfaces too.
    #[default]
    WeightedVolume,
    /// The paper's constants: m = pi delta^5, the integral over a full sphere, for every particle;
    /// particles near a free surface, whose family is cut, then respond too softly.
    Analytic,
}

impl Normalisation {
    fn is_default(&self) -> bool {
        *self == Normalisation::WeightedVolume
    }
}

/// `[material]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialConfig {
    /// `"pmb"` (default) or `"elastoplastic"`.
    #[serde(default, skip_serializing_if = "MaterialModel::is_pmb")]
    pub model: MaterialModel,
    /// Mass density rho in kg/m^3.
    pub density_kg_m3: f64,
    /// Bulk modulus K in Pa. May be left out for `bond_constant_n_m6`, or (elastoplastic) for
    /// `youngs_modulus_pa` and `poisson_ratio`.
    #[serde(default = "lammps_terms::unset")]
    pub bulk_modulus_pa: f64,
    /// LAMMPS's bond constant c (`pair_coeff`'s first value), N/m^6, instead of
    /// `bulk_modulus_pa`: K = c pi delta^4 / 18.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bond_constant_n_m6: Option<f64>,
    /// Shear modulus mu in Pa (elastoplastic only; or give `youngs_modulus_pa` and
    /// `poisson_ratio`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shear_modulus_pa: Option<f64>,
    /// Young's modulus E in Pa, with `poisson_ratio` instead of the bulk and shear moduli
    /// (elastoplastic only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub youngs_modulus_pa: Option<f64>,
    /// Poisson's ratio nu, in (-1, 0.5), with `youngs_modulus_pa` (elastoplastic only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poisson_ratio: Option<f64>,
    /// The state-based sums' normalisation (elastoplastic only).
    #[serde(default, skip_serializing_if = "Normalisation::is_default")]
    pub normalisation: Normalisation,
    /// The paper's yield parameter Psi_0: a bond yields when A_dev^2 / 2 exceeds it, where
    /// A_dev = 2 t_dev is its deviatoric force density, N^2/m^12 (elastoplastic only; absent:
    /// no plasticity).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yield_psi0: Option<f64>,
    /// The uniaxial yield stress in Pa instead of `yield_psi0`: Psi_0 = 50 sigma_y^2 /
    /// (pi^2 delta^8) (see [`MaterialConfig::yield_psi0`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yield_stress_pa: Option<f64>,
    /// gamma / |xi|: the largest plastic deviatoric extension of a bond as a fraction of its rest
    /// length (elastoplastic only; absent: no cap).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plastic_cap_ratio: Option<f64>,
    /// The paper's alpha in eq. 18: a bond's threshold grows by (1 + alpha phi) with the damage
    /// phi of its particles (elastoplastic only; default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damage_strengthening: Option<f64>,
    /// Fibres: a per-particle anisotropy matrix G, omega = delta / |G xi| (elastoplastic only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub anisotropy: Option<AnisotropyConfig>,
    /// Fracture energy G in J/m^2; the mean critical stretch is sqrt(5 G / (9 K delta)).
    /// Default 8 J/m^2 (soda-lime glass) unless `critical_stretch` is given.
    #[serde(default)]
    pub fracture_energy_j_m2: Option<f64>,
    /// The mean critical stretch given directly (the paper's tau: 0.01 ... 0.0002); excludes
    /// `fracture_energy_j_m2`.
    #[serde(default)]
    pub critical_stretch: Option<f64>,
    /// Standard deviation of the per-bond threshold as a fraction of the mean (the paper: 0.02).
    #[serde(default = "default_threshold_jitter")]
    pub threshold_jitter: f64,
    /// alpha in tau' = tau - alpha min(0, s_min): compression strengthening (the paper: 0.25;
    /// PMB only).
    #[serde(default = "default_compression_alpha")]
    pub compression_alpha: f64,
}

/// `[material.anisotropy]`: fibres along one direction (wood), or a layered field whose fibre
/// direction turns from layer to layer (plywood, laminates). Each particle's matrix is
/// G = I - (1 - 1 / ratio) d d^T for its fibre direction d, so a bond along the fibres has
/// `ratio` times the influence of one across them: it is stiffer and breaks later.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnisotropyConfig {
    /// The fibre direction (any length), in the first layer where there are layers.
    pub fibre_direction: [f64; 3],
    /// Influence along the fibres over that across them, > 0 (1: isotropic).
    pub ratio: f64,
    /// The layers' normal (any length); absent: the same fibres everywhere.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layer_normal: Option<[f64; 3]>,
    /// Layer thickness, metres; layer k holds the points with k <= (x . n) / thickness < k + 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layer_thickness_m: Option<f64>,
    /// How far the fibres turn about the normal from one layer to the next, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layer_rotation_deg: Option<f64>,
}

impl AnisotropyConfig {
    /// The unit fibre direction at point `x` (metres, scene space).
    pub fn fibre_at(&self, x: [f64; 3]) -> [f64; 3] {
        let unit = |v: [f64; 3]| {
            // scaled first, so that tiny and huge vectors keep their direction
            let largest = v.iter().fold(0.0f64, |a, c| a.max(c.abs()));
            let v = v.map(|c| c / largest);
            let length = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|c| c / length)
        };
        let d = unit(self.fibre_direction);
        let (Some(normal), Some(thickness), Some(rotation)) =
            (self.layer_normal, self.layer_thickness_m, self.layer_rotation_deg)
        else {
            return d;
        };
        let n = unit(normal);
        let layer = ((x[0] * n[0] + x[1] * n[1] + x[2] * n[2]) / thickness).floor();
        let (sin, cos) = (layer * rotation.to_radians()).sin_cos();
        // Rodrigues: d cos + (n x d) sin + n (n . d)(1 - cos)
        let cross = [n[1] * d[2] - n[2] * d[1], n[2] * d[0] - n[0] * d[2], n[0] * d[1] - n[1] * d[0]];
        let along = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
        unit([0, 1, 2].map(|a| d[a] * cos + cross[a] * sin + n[a] * along * (1.0 - cos)))
    }

    fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        check.direction("material.anisotropy.fibre_direction", &self.fibre_direction)?;
        check.positive("material.anisotropy.ratio", self.ratio, "dimensionless")?;
        match (self.layer_normal, self.layer_thickness_m, self.layer_rotation_deg) {
            (None, None, None) => Ok(()),
            (Some(normal), Some(thickness), Some(rotation)) => {
                check.direction("material.anisotropy.layer_normal", &normal)?;
                check.positive("material.anisotropy.layer_thickness_m", thickness, "metres")?;
                check.that(
                    rotation.is_finite(),
                    "material.anisotropy.layer_rotation_deg",
                    &rotation.to_string(),
                    || "must be a finite angle in degrees".into(),
                )
            }
            _ => Err(check.invalid(
                "material.anisotropy.layer_normal",
                "(partly given)",
                "a layered field needs layer_normal, layer_thickness_m and layer_rotation_deg together",
            )),
        }
    }
}

fn default_compression_alpha() -> f64 {
    0.25
}

fn default_threshold_jitter() -> f64 {
    0.02
}

/// The keys only the elastoplastic model reads, with whether the scene gives each.
fn elastoplastic_keys(material: &MaterialConfig) -> [(&'static str, bool); 9] {
    [
        ("material.shear_modulus_pa", material.shear_modulus_pa.is_some()),
        ("material.youngs_modulus_pa", material.youngs_modulus_pa.is_some()),
        ("material.poisson_ratio", material.poisson_ratio.is_some()),
        ("material.normalisation", !material.normalisation.is_default()),
        ("material.yield_psi0", material.yield_psi0.is_some()),
        ("material.yield_stress_pa", material.yield_stress_pa.is_some()),
        ("material.plastic_cap_ratio", material.plastic_cap_ratio.is_some()),
        ("material.damage_strengthening", material.damage_strengthening.is_some()),
        ("material.anisotropy", material.anisotropy.is_some()),
    ]
}

impl MaterialConfig {
    /// The mean critical stretch s0 for horizon `delta_m`: the given `critical_stretch`, else
    /// Silling and Askari's sqrt(5 G / (9 K delta)). (Levine et al.'s eq. 4 omits the 9.)
    pub fn mean_critical_stretch(&self, delta_m: f64) -> f64 {
        match self.critical_stretch {
            Some(stretch) => stretch,
            None => {
                let energy = self.fracture_energy_j_m2.unwrap_or(DEFAULT_FRACTURE_ENERGY_J_M2);
                (5.0 * energy / (9.0 * self.bulk_modulus_pa * delta_m)).sqrt()
            }
        }
    }

    /// The shear modulus mu, Pa: the given one, else (PMB, and an elastoplastic scene that
    /// gives only K) 3 K / 5, PMB's own (Poisson's ratio 1/4).
    pub fn shear_modulus_pa(&self) -> f64 {
        self.shear_modulus_pa.unwrap_or(0.6 * self.bulk_modulus_pa)
    }

    /// The P-wave modulus M = K + 4 mu / 3, Pa, the stiffness of a longitudinal wave, c_p =
    /// sqrt(M / rho): 1.8 K for PMB, whose Poisson ratio is 1/4.
    pub fn p_wave_modulus_pa(&self) -> f64 {
        match self.model {
            MaterialModel::Pmb => 1.8 * self.bulk_modulus_pa,
            MaterialModel::Elastoplastic => self.bulk_modulus_pa + 4.0 / 3.0 * self.shear_modulus_pa(),
        }
    }

    /// Young's modulus E = 9 K mu / (3 K + mu), Pa.
    pub fn youngs_modulus_pa(&self) -> f64 {
        let (k, mu) = (self.bulk_modulus_pa, self.shear_modulus_pa());
        9.0 * k * mu / (3.0 * k + mu)
    }

    /// Poisson's ratio (3 K - 2 mu) / (2 (3 K + mu)).
    pub fn poisson_ratio(&self) -> f64 {
        let (k, mu) = (self.bulk_modulus_pa, self.shear_modulus_pa());
        (3.0 * k - 2.0 * mu) / (2.0 * (3.0 * k + mu))
    }

    /// The yield parameter Psi_0 for horizon `delta_m` (None: no plasticity): the given one, or
    /// from the yield stress. Under uniaxial stress sigma a bond along the load has deviatoric
    /// extension e_d = sigma |xi| / (3 mu), so t_dev = 15 mu omega e_d / m = 5 sigma delta / m
    /// with omega = delta / |xi| and m = pi delta^5; the paper's A_dev = 2 t_dev reaches
    /// sqrt(2 Psi_0) at sigma_y when Psi_0 = 50 sigma_y^2 / (pi^2 delta^8).
    pub fn yield_psi0(&self, delta_m: f64) -> Option<f64> {
        self.yield_psi0.or_else(|| {
            self.yield_stress_pa.map(|sigma| 50.0 * sigma * sigma / (std::f64::consts::PI.powi(2) * delta_m.powi(8)))
        })
    }

    /// Checks density, stiffness and strength, then the model's keys.
    pub(super) fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        check.positive("material.density_kg_m3", self.density_kg_m3, "kg/m^3")?;
        check.positive("material.bulk_modulus_pa", self.bulk_modulus_pa, "Pa")?;
        match (self.fracture_energy_j_m2, self.critical_stretch) {
            (Some(_), Some(_)) => {
                return Err(check.invalid(
                    "material.critical_stretch",
                    &format!("{}", self.critical_stretch.unwrap_or_default()),
                    "give either fracture_energy_j_m2 or critical_stretch, not both",
                ));
            }
            (Some(energy), None) => check.positive("material.fracture_energy_j_m2", energy, "J/m^2")?,
            (None, Some(stretch)) => check.that(
                stretch.is_finite() && stretch > 0.0 && stretch < 1.0,
                "material.critical_stretch",
                &stretch.to_string(),
                || "must be greater than 0 and below 1 (the paper uses 0.0002 to 0.01)".to_string(),
            )?,
            (None, None) => {}
        }
        let jitter = self.threshold_jitter;
        check.that(
            jitter.is_finite() && (0.0..=MAX_THRESHOLD_JITTER).contains(&jitter),
            "material.threshold_jitter",
            &jitter.to_string(),
            || format!("must be between 0 and {MAX_THRESHOLD_JITTER} (a fraction of the mean threshold)"),
        )?;
        check.non_negative("material.compression_alpha", self.compression_alpha, "dimensionless")?;
        self.validate_model(check)
    }

    /// Checks the model's keys: the elastoplastic keys only with that model, each in range.
    fn validate_model(&self, check: &Checker) -> Result<(), ConfigError> {
        if self.model == MaterialModel::Pmb {
            if let Some((key, _)) = elastoplastic_keys(self).into_iter().find(|(_, given)| *given) {
                return Err(check.invalid(
                    key,
                    "(given)",
                    "is read by the elastoplastic model only; set material.model = \"elastoplastic\" or remove it",
                ));
            }
            return Ok(());
        }
        // positive K and mu make Poisson's ratio lie in (-1, 0.5)
        if let Some(mu) = self.shear_modulus_pa {
            check.positive("material.shear_modulus_pa", mu, "Pa")?;
        }
        match (self.yield_psi0, self.yield_stress_pa) {
            (Some(_), Some(stress)) => {
                return Err(check.invalid(
                    "material.yield_stress_pa",
                    &stress.to_string(),
                    "give either yield_psi0 or yield_stress_pa, not both",
                ));
            }
            (Some(psi0), None) => check.positive("material.yield_psi0", psi0, "N^2/m^12")?,
            (None, Some(stress)) => check.positive("material.yield_stress_pa", stress, "Pa")?,
            (None, None) => {}
        }
        if let Some(cap) = self.plastic_cap_ratio {
            check.positive("material.plastic_cap_ratio", cap, "a fraction of the bond's rest length")?;
        }
        if let Some(alpha) = self.damage_strengthening {
            check.non_negative("material.damage_strengthening", alpha, "dimensionless")?;
        }
        if let Some(anisotropy) = &self.anisotropy {
            anisotropy.validate(check)?;
            check.that(
                self.normalisation == Normalisation::WeightedVolume,
                "material.normalisation",
                "\"analytic\"",
                || {
                    "the analytic constants hold for omega = delta / |xi| only; anisotropy needs \"weighted_volume\""
                        .into()
                },
            )?;
        }
        Ok(())
    }
}

/// Fills the bulk and shear moduli from `youngs_modulus_pa` and `poisson_ratio` (given
/// together, instead of both moduli): K = E / (3 (1 - 2 nu)), mu = E / (2 (1 + nu)).
pub(super) fn resolve_moduli(material: &mut MaterialConfig, check: &Checker) -> Result<(), ConfigError> {
    match (material.youngs_modulus_pa, material.poisson_ratio) {
        (None, None) => Ok(()),
        (Some(youngs), Some(nu)) => {
            check.positive("material.youngs_modulus_pa", youngs, "Pa")?;
            check.that(nu.is_finite() && nu > -1.0 && nu < 0.5, "material.poisson_ratio", &nu.to_string(), || {
                "must be greater than -1 and below 0.5".into()
            })?;
            for (key, given) in [
                ("material.bulk_modulus_pa", !lammps_terms::is_unset(material.bulk_modulus_pa)),
                ("material.bond_constant_n_m6", material.bond_constant_n_m6.is_some()),
                ("material.shear_modulus_pa", material.shear_modulus_pa.is_some()),
            ] {
                if given {
                    return Err(check.invalid(
                        key,
                        "(given)",
                        "give either the bulk and shear moduli or youngs_modulus_pa and poisson_ratio, not both",
                    ));
                }
            }
            material.bulk_modulus_pa = youngs / (3.0 * (1.0 - 2.0 * nu));
            material.shear_modulus_pa = Some(youngs / (2.0 * (1.0 + nu)));
            Ok(())
        }
        (Some(_), None) => {
            Err(check.invalid("material.poisson_ratio", "(missing)", "must be given with youngs_modulus_pa"))
        }
        (None, Some(_)) => {
            Err(check.invalid("material.youngs_modulus_pa", "(missing)", "must be given with poisson_ratio"))
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::PipelineConfig;

    const PLATE: &str = r#"
[scene]
name = "plate"
output_dir = "out/plate"
seed = 1
[geometry]
source = "box"
box_size_m = [0.1, 0.1, 0.01]
sampler = "grid"
spacing_m = 0.002
horizon_factor = 3.0
[material]
density_kg_m3 = 7800.0
"#;

    fn parse(extra: &str) -> Result<PipelineConfig, ConfigError> {
        PipelineConfig::from_toml_str(&format!("{PLATE}{extra}"), Path::new("plate.toml"))
    }

    #[test]
    fn youngs_modulus_and_poisson_ratio_give_both_moduli_and_back() {
        for nu in [-0.5, 0.1, 0.25, 0.4, 0.49] {
            let config =
                parse(&format!("model = \"elastoplastic\"\nyoungs_modulus_pa = 200e9\npoisson_ratio = {nu}\n"))
                    .expect("valid");
            let material = &config.material;
            assert!((material.youngs_modulus_pa() / 200e9 - 1.0).abs() < 1e-12);
            assert!((material.poisson_ratio() - nu).abs() < 1e-12);
            // the P-wave modulus from E and nu: E (1 - nu) / ((1 + nu) (1 - 2 nu))
            let p_wave = 200e9 * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu));
            assert!((material.p_wave_modulus_pa() / p_wave - 1.0).abs() < 1e-12, "nu = {nu}");
        }
        // PMB's moduli: nu = 1/4, and a P-wave modulus of K + 4 (3 K / 5) / 3 = 1.8 K
        let config = parse("bulk_modulus_pa = 1e9\n").expect("valid");
        assert!((config.material.poisson_ratio() - 0.25).abs() < 1e-12);
        let material = &config.material;
        let from_shear = material.bulk_modulus_pa + 4.0 / 3.0 * material.shear_modulus_pa();
        assert!((material.p_wave_modulus_pa() / from_shear - 1.0).abs() < 1e-12);
    }

    #[test]
    fn the_elastoplastic_keys_are_refused_by_pmb_and_checked_by_elastoplastic() {
        let error = parse("bulk_modulus_pa = 1e9\nyield_stress_pa = 1e6\n").expect_err("pmb");
        assert!(error.to_string().contains("material.yield_stress_pa") && error.to_string().contains("elastoplastic"));
        let cases = [
            ("bulk_modulus_pa = 1e9\nyoungs_modulus_pa = 1e9\npoisson_ratio = 0.3\n", "material.bulk_modulus_pa"),
            ("youngs_modulus_pa = 1e9\n", "material.poisson_ratio"),
            ("youngs_modulus_pa = 1e9\npoisson_ratio = 0.5\n", "material.poisson_ratio"),
            ("bulk_modulus_pa = 1e9\nshear_modulus_pa = -1.0\n", "material.shear_modulus_pa"),
            ("bulk_modulus_pa = 1e9\nyield_psi0 = 1.0\nyield_stress_pa = 1.0\n", "material.yield_stress_pa"),
            ("bulk_modulus_pa = 1e9\nplastic_cap_ratio = 0.0\n", "material.plastic_cap_ratio"),
            ("bulk_modulus_pa = 1e9\ndamage_strengthening = -1.0\n", "material.damage_strengthening"),
            ("bulk_modulus_pa = 1e9\nnormalisation = \"sphere\"\n", "material.normalisation"),
            (
                "bulk_modulus_pa = 1e9\nnormalisation = \"analytic\"\n[material.anisotropy]\nfibre_direction = [1, 0, 0]\nratio = 2.0\n",
                "material.normalisation",
            ),
            (
                "bulk_modulus_pa = 1e9\n[material.anisotropy]\nfibre_direction = [0, 0, 0]\nratio = 2.0\n",
                "fibre_direction",
            ),
            ("bulk_modulus_pa = 1e9\n[material.anisotropy]\nfibre_direction = [1, 0, 0]\nratio = 0.0\n", "ratio"),
            (
                "bulk_modulus_pa = 1e9\n[material.anisotropy]\nfibre_direction = [1, 0, 0]\nratio = 2.0\nlayer_normal = [0, 1, 0]\n",
                "material.anisotropy.layer_normal",
            ),
        ];
        for (keys, key) in cases {
            let error = parse(&format!("model = \"elastoplastic\"\n{keys}")).expect_err(keys);
            assert!(error.to_string().contains(key), "{keys}: {error}");
        }
    }

    #[test]
    fn layered_fibres_turn_about_the_normal_from_layer_to_layer() {
        let anisotropy = AnisotropyConfig {
            fibre_direction: [2.0, 0.0, 0.0],
            ratio: 3.0,
            layer_normal: Some([0.0, 1.0, 0.0]),
            layer_thickness_m: Some(0.01),
            layer_rotation_deg: Some(90.0),
        };
        let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12);
        assert!(close(anisotropy.fibre_at([0.3, 0.005, 0.0]), [1.0, 0.0, 0.0]));
        // one layer up: x turned 90 degrees about y is -z
        assert!(close(anisotropy.fibre_at([0.3, 0.015, 0.0]), [0.0, 0.0, -1.0]));
        assert!(close(anisotropy.fibre_at([0.3, -0.005, 0.0]), [0.0, 0.0, 1.0]));
        let uniform =
            AnisotropyConfig { layer_normal: None, layer_thickness_m: None, layer_rotation_deg: None, ..anisotropy };
        assert!(close(uniform.fibre_at([0.3, 0.015, 0.0]), [1.0, 0.0, 0.0]));
    }

    #[test]
    fn the_yield_stress_converts_to_the_papers_psi0() {
        let config = parse("model = \"elastoplastic\"\nbulk_modulus_pa = 1e9\nyield_stress_pa = 2e6\n").expect("valid");
        let delta: f64 = 0.006;
        let psi0 = config.material.yield_psi0(delta).expect("plastic");
        // A_dev = 2 t_dev = 10 sigma delta / (pi delta^5) at the yield stress
        let a_dev = 10.0 * 2e6 * delta / (std::f64::consts::PI * delta.powi(5));
        assert!((psi0 / (a_dev * a_dev / 2.0) - 1.0).abs() < 1e-12);
    }
}
