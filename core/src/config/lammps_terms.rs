//! A scene given in LAMMPS's terms (`pair_style peri/pmb`, `fix indent`): the bond constant c
//! instead of the bulk modulus, the horizon in metres instead of as a multiple of the spacing,
//! and an indenter's K per unit volume. Each is turned into shatter's own key right after
//! parsing, so the rest of the program sees one set of keys (docs/LAMMPS.md).
//!
//! The keys they stand in for may then be left out of the file: serde fills them with
//! [`UNSET`], a NaN with its own payload, which no TOML value parses to (a written `nan` has the
//! standard payload and is refused by the usual checks).

use super::checker::Checker;
use super::{ConfigError, PipelineConfig};

/// What a key the file left out to its LAMMPS alternative holds until [`resolve`] fills it.
const UNSET: f64 = f64::from_bits(0x7ff8_5ba7_7e20_0001);

/// [`UNSET`], for serde's `default`.
pub(super) fn unset() -> f64 {
    UNSET
}

pub(super) fn is_unset(value: f64) -> bool {
    value.to_bits() == UNSET.to_bits()
}

/// Fills each key from its LAMMPS alternative, or refuses a scene that gives both or neither:
/// `geometry.horizon_factor` from `geometry.horizon_m` (delta / lambda), then
/// `material.bulk_modulus_pa` from `material.bond_constant_n_m6` (K = c pi delta^4 / 18), and
/// each indenter's `stiffness_n_m2` from `lammps_stiffness_n_m5` (K lambda^3: LAMMPS's forces
/// are per unit volume, and lambda^3 is a grid particle's volume).
pub(super) fn resolve(config: &mut PipelineConfig, check: &Checker) -> Result<(), ConfigError> {
    let spacing = config.geometry.spacing_m;
    let geometry = &mut config.geometry;
    geometry.horizon_factor = pick(
        check,
        ("geometry.horizon_factor", geometry.horizon_factor),
        ("geometry.horizon_m", geometry.horizon_m),
        |delta| delta / spacing,
    )?;
    let delta = geometry.horizon_factor * spacing;
    let material = &mut config.material;
    material.bulk_modulus_pa = pick(
        check,
        ("material.bulk_modulus_pa", material.bulk_modulus_pa),
        ("material.bond_constant_n_m6", material.bond_constant_n_m6),
        |c| c * std::f64::consts::PI * delta.powi(4) / 18.0,
    )?;
    for (index, indenter) in config.sim.indenter.iter_mut().enumerate() {
        indenter.stiffness_n_m2 = pick(
            check,
            (&format!("sim.indenter[{index}].stiffness_n_m2"), indenter.stiffness_n_m2),
            (&format!("sim.indenter[{index}].lammps_stiffness_n_m5"), indenter.lammps_stiffness_n_m5),
            |k| k * spacing.powi(3),
        )?;
    }
    Ok(())
}

/// Our key's value, or the one its LAMMPS alternative converts to; exactly one must be given.
fn pick(
    check: &Checker,
    (ours, value): (&str, f64),
    (theirs, alternative): (&str, Option<f64>),
    convert: impl Fn(f64) -> f64,
) -> Result<f64, ConfigError> {
    match (is_unset(value), alternative) {
        (false, None) => Ok(value),
        (true, Some(given)) => {
            check.that(given.is_finite() && given > 0.0, theirs, &given.to_string(), || {
                "must be a positive number".into()
            })?;
            Ok(convert(given))
        }
        (false, Some(given)) => {
            Err(check.invalid(theirs, &given.to_string(), &format!("give either {ours} or {theirs}, not both")))
        }
        (true, None) => {
            Err(check.invalid(ours, "(missing)", &format!("must be given (or, in LAMMPS's terms, {theirs})")))
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    const SCENE: &str = "[scene]\nname = \"t\"\noutput_dir = \"out\"\nseed = 1\n[geometry]\nsource = \"box\"\n\
                         box_size_m = [0.004, 0.004, 0.004]\nsampler = \"grid\"\nspacing_m = 0.0005\n\
                         [material]\ndensity_kg_m3 = 2200.0\n";

    #[test]
    fn lammps_terms_become_our_keys() {
        let text = SCENE.replace("spacing_m = 0.0005\n", "spacing_m = 0.0005\nhorizon_m = 0.0015001\n")
            + "bond_constant_n_m6 = 1.6863e22\n[[sim.indenter]]\ncenter_m = [0.0, 0.01, 0.0]\n\
               velocity_m_s = [0.0, -20.0, 0.0]\nradius_m = 0.0015\nlammps_stiffness_n_m5 = 1e17\n";
        let config = PipelineConfig::from_toml_str(&text, Path::new("p.toml")).expect("valid");
        assert!((config.geometry.horizon_factor - 3.0002).abs() < 1e-12);
        let delta: f64 = 0.0015001;
        let c = 18.0 * config.material.bulk_modulus_pa / (std::f64::consts::PI * delta.powi(4));
        assert!((c / 1.6863e22 - 1.0).abs() < 1e-12, "c round-trips: {c:e}");
        assert!((config.sim.indenter[0].stiffness_n_m2 / 1.25e7 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn both_or_neither_is_refused_by_name() {
        let both = SCENE
            .replace("spacing_m = 0.0005\n", "spacing_m = 0.0005\nhorizon_factor = 3.0\nhorizon_m = 0.0015\n")
            + "bulk_modulus_pa = 14.9e9\n";
        let error = PipelineConfig::from_toml_str(&both, Path::new("p.toml")).expect_err("both").to_string();
        assert!(error.contains("geometry.horizon_m") && error.contains("not both"), "{error}");
        let neither = SCENE.replace("spacing_m = 0.0005\n", "spacing_m = 0.0005\nhorizon_factor = 3.0\n");
        let error = PipelineConfig::from_toml_str(&neither, Path::new("p.toml")).expect_err("neither").to_string();
        assert!(error.contains("material.bulk_modulus_pa") && error.contains("material.bond_constant_n_m6"), "{error}");
        let nan = SCENE.replace("spacing_m = 0.0005\n", "spacing_m = 0.0005\nhorizon_factor = nan\n")
            + "bulk_modulus_pa = 14.9e9\n";
        let error = PipelineConfig::from_toml_str(&nan, Path::new("p.toml")).expect_err("nan").to_string();
        assert!(
            error.contains("geometry.horizon_factor") && !error.contains("LAMMPS"),
            "a written NaN is not unset: {error}"
        );
    }
}
