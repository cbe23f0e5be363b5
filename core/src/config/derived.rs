//! Checks of what the settings imply rather than of each setting alone: the simulation holds
//! masses, bond forces, thresholds and positions in single precision, so a combination of valid
//! values (a bulk modulus of 1e300 Pa, a density of 1e-40 kg/m^3, a scene 1e30 m from the origin)
//! can make a particle file that no later stage can use. Such settings are refused here, naming
//! the key, before preprocessing replaces a good particle file.

use super::checker::Checker;
use super::{ConfigError, PipelineConfig};

/// The smallest mean critical stretch: the simulation computes stretches in single precision, to
/// about 1e-7.
pub const MIN_CRITICAL_STRETCH: f64 = 1e-6;

/// The finest position resolution single precision may have at the scene's distance from the
/// origin, as a fraction of the particle spacing.
const POSITION_RESOLUTION_OF_SPACING: f64 = 1e-3;

/// A value as the user would write it: plain near 1, in exponent form far from it.
fn shown(value: f64) -> String {
    if value != 0.0 && !(1e-4..1e7).contains(&value.abs()) { format!("{value:e}") } else { value.to_string() }
}

/// A number a single-precision field can hold as a normal value (not zero, not infinite).
fn fits_f32(value: f64) -> bool {
    value.is_finite() && (value as f32).is_normal()
}

pub(super) fn validate(config: &PipelineConfig, check: &Checker<'_>) -> Result<(), ConfigError> {
    let lambda = config.geometry.spacing_m;
    let delta = config.horizon_m();
    let material = &config.material;

    let volume = lambda.powi(3);
    check.that(fits_f32(volume), "geometry.spacing_m", &shown(lambda), || {
        format!("a particle's volume would be {volume:e} m^3, beyond single precision")
    })?;
    let mass = material.density_kg_m3 * volume;
    check.that(fits_f32(mass), "material.density_kg_m3", &shown(material.density_kg_m3), || {
        format!("a particle's mass would be {mass:e} kg (density x spacing^3), beyond single precision")
    })?;
    // A bond's force per unit stretch, c V_i V_j with c = 18 K / (pi delta^4).
    let bond_force = 18.0 * material.bulk_modulus_pa / (std::f64::consts::PI * delta.powi(4)) * volume * volume;
    check.that(fits_f32(bond_force), "material.bulk_modulus_pa", &shown(material.bulk_modulus_pa), || {
        format!("a bond's force per unit stretch would be {bond_force:e} N, beyond single precision")
    })?;

    let stretch = material.mean_critical_stretch(delta);
    let (key, value) = match (material.critical_stretch, material.fracture_energy_j_m2) {
        (Some(stretch), _) => ("material.critical_stretch", shown(stretch)),
        (None, Some(energy)) => ("material.fracture_energy_j_m2", shown(energy)),
        (None, None) => ("material.bulk_modulus_pa", shown(material.bulk_modulus_pa)),
    };
    check.that(stretch.is_finite() && (MIN_CRITICAL_STRETCH..1.0).contains(&stretch), key, &value, || {
        format!(
            "the mean critical stretch would be {stretch:e}; it must be at least {MIN_CRITICAL_STRETCH:e} (stretches \
             are computed in single precision) and below 1"
        )
    })?;

    let sim = &config.sim;
    let contact_reach = sim.contact.distance_m.unwrap_or(0.5 * lambda);
    let contact = ("sim.contact.stiffness_pa".to_owned(), sim.contact.stiffness_pa, contact_reach * contact_reach);
    let pushes = sim.pushing_bodies().into_iter().map(|push| (push.key, push.stiffness, push.peak_n / push.stiffness));
    for (key, stiffness, area) in std::iter::once(contact).chain(pushes) {
        if stiffness == 0.0 {
            continue; // contact switched off
        }
        let peak_n = stiffness * area;
        check.that(fits_f32(stiffness) && fits_f32(peak_n), &key, &shown(stiffness), || {
            format!("its largest force would be {peak_n:e} N, beyond single precision")
        })?;
    }

    let transform = &config.geometry.transform;
    let farthest = transform.translate_m.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let resolution = farthest * f64::from(f32::EPSILON);
    let translate = format!("[{}]", transform.translate_m.map(shown).join(", "));
    check.that(resolution <= POSITION_RESOLUTION_OF_SPACING * lambda, "geometry.transform.translate_m", &translate, || {
        format!(
            "at {farthest:e} m from the origin single-precision positions are {resolution:.3e} m apart, too coarse for \
             a spacing of {lambda} m; place the scene nearer the origin"
        )
    })
}
