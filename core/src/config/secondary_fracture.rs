//! `[rigid.secondary_fracture]`: pieces that break again. A piece of the follow-through that
//! hits the floor, a projectile, an indenter or another piece harder than its material can take
//! goes back to the simulation, and the pieces it breaks into come back as rigid bodies
//! (docs/DECISIONS.md#secondary-fracture).

use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::checker::Checker;

/// `[rigid.secondary_fracture]`. Absent, every piece stays whole after the handoff.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SecondaryFractureConfig {
    /// Pieces of fewer elements never go back (they are too small to break into anything
    /// worth the simulation).
    pub min_elements: u32,
    /// The artist's scale on the material's critical impact speed: a contact is hard when its
    /// approach speed passes `threshold_scale` times the speed at which the piece's bonds at the
    /// contact reach their critical stretch. 0: never.
    pub threshold_scale: f64,
    /// Frames of the simulation of a piece that went back (the handoff rule picks its end among
    /// them, as for the first fracture).
    pub frames: u32,
    /// Steps between two of those frames.
    pub steps_per_frame: u32,
    /// The most times pieces go back in one shot.
    pub max_reentries: u32,
}

impl Default for SecondaryFractureConfig {
    fn default() -> Self {
        SecondaryFractureConfig {
            min_elements: 64,
            threshold_scale: 1.0,
            frames: 40,
            steps_per_frame: 100,
            max_reentries: 16,
        }
    }
}

impl SecondaryFractureConfig {
    pub(super) fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        check.that(
            self.min_elements >= 2,
            "rigid.secondary_fracture.min_elements",
            &self.min_elements.to_string(),
            || "must be at least 2 (a single element has no bond to break)".into(),
        )?;
        check.non_negative("rigid.secondary_fracture.threshold_scale", self.threshold_scale, "a factor; 0: never")?;
        for (key, value) in [
            ("rigid.secondary_fracture.frames", self.frames),
            ("rigid.secondary_fracture.steps_per_frame", self.steps_per_frame),
        ] {
            check.that((2..=100_000).contains(&value), key, &value.to_string(), || "must be 2 to 100000".into())?;
        }
        let most = self.max_reentries;
        check.that(most <= 10_000, "rigid.secondary_fracture.max_reentries", &most.to_string(), || {
            "must be at most 10000".into()
        })
    }

    /// Whether any contact can be hard.
    pub fn enabled(&self) -> bool {
        self.threshold_scale > 0.0 && self.max_reentries > 0
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use crate::PipelineConfig;

    const BASE: &str = "[scene]\nname = \"t\"\noutput_dir = \"out\"\nseed = 1\n[geometry]\nsource = \"box\"\n\
                        box_size_m = [0.004, 0.004, 0.004]\nsampler = \"grid\"\nspacing_m = 0.001\n\
                        horizon_factor = 2.0\n";
    const GLASS: &str = "[material]\ndensity_kg_m3 = 2200.0\nbulk_modulus_pa = 14.9e9\n";

    fn parse(text: &str) -> Result<PipelineConfig, String> {
        PipelineConfig::from_toml_str(text, Path::new("p.toml")).map_err(|error| error.to_string())
    }

    #[test]
    fn the_table_is_optional_and_its_values_are_checked_by_name() {
        let without = parse(&format!("{BASE}{GLASS}[rigid]\n")).expect("valid");
        assert_eq!(without.rigid.and_then(|rigid| rigid.secondary_fracture), None);
        let with = parse(&format!("{BASE}{GLASS}[rigid.secondary_fracture]\nthreshold_scale = 0.0\n")).expect("valid");
        let secondary = with.rigid.and_then(|rigid| rigid.secondary_fracture).expect("the table");
        assert!(!secondary.enabled(), "a scale of 0 never re-enters");
        for (key, value, message) in [
            ("threshold_scale", "-1.0", "0 or more"),
            ("min_elements", "1", "at least 2"),
            ("frames", "1", "2 to 100000"),
            ("steps_per_frame", "0", "2 to 100000"),
        ] {
            let error = parse(&format!("{BASE}{GLASS}[rigid.secondary_fracture]\n{key} = {value}\n")).expect_err(key);
            assert!(error.contains(&format!("rigid.secondary_fracture.{key}")) && error.contains(message), "{error}");
        }
        let plastic = "[material]\nmodel = \"elastoplastic\"\ndensity_kg_m3 = 7800.0\nbulk_modulus_pa = 160e9\n\
                       yield_stress_pa = 250e6\n";
        // the elastoplastic model goes back with its plastic state
        parse(&format!("{BASE}{plastic}[rigid.secondary_fracture]\n")).expect("elastoplastic");
    }
}
