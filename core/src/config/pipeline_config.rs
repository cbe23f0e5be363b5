//! The whole scene, [`PipelineConfig`]: its tables, reading and parsing a `pipeline.toml`, and
//! the checks across its tables.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::checker::Checker;
use super::relative_paths::resolve_path;
use super::{
    ConfigError, GeometryConfig, GeometrySource, LeadInConfig, MaterialConfig, PostConfig, RenderConfig, RigidConfig,
    SceneConfig, SimConfig, TimelineConfig, array_lengths, derived, lammps_terms, material,
};

/// The most frames a follow-through may add to a shot.
pub const MAX_FOLLOW_THROUGH_FRAMES: f64 = 1_000_000.0;
/// The largest config file read.
pub const MAX_CONFIG_BYTES: u64 = 1 << 20;

/// A whole scene: what to break, how it is sampled, what it is made of.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineConfig {
    /// `[scene]`: name, output folder, random seed.
    pub scene: SceneConfig,
    /// `[geometry]`: the source shape and how it becomes particles.
    pub geometry: GeometryConfig,
    /// `[material]`: density, stiffness, strength.
    pub material: MaterialConfig,
    /// `[lead_in]`: the intact body's rigid flight before its first contact; absent, the
    /// simulation starts at once.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lead_in: Option<LeadInConfig>,
    /// `[sim]`: time stepping, forces, art direction (every key has a default).
    #[serde(default)]
    pub sim: SimConfig,
    /// `[post]`: fragments and exports (every key has a default).
    #[serde(default)]
    pub post: PostConfig,
    /// `[rigid]`: the follow-through on rigid bodies; absent, the shot ends with the simulation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rigid: Option<RigidConfig>,
    /// `[timeline]`: frame rate, length and speed curve of a shot at real speed; absent, the
    /// simulation's frames are `sim.frames` of `sim.steps_per_frame` steps, and the lead-in's
    /// and follow-through's frames are at real speed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timeline: Option<TimelineConfig>,
    /// `[render]`: camera, image, lighting (every key has a default).
    #[serde(default)]
    pub render: RenderConfig,
    /// The config file this was loaded from (empty for configs parsed from a string).
    #[serde(skip)]
    pub path: PathBuf,
}

impl PipelineConfig {
    /// Reads, parses and validates a config file; relative paths in it are resolved against the
    /// file's folder.
    /// A file over [`MAX_CONFIG_BYTES`] is refused without being read whole.
    pub fn load(path: &Path) -> Result<PipelineConfig, ConfigError> {
        use std::io::Read;
        let read_error = |source| ConfigError::Read { path: path.to_path_buf(), source };
        let file = std::fs::File::open(path).map_err(read_error)?;
        let mut bytes = Vec::new();
        file.take(MAX_CONFIG_BYTES + 1).read_to_end(&mut bytes).map_err(read_error)?;
        if bytes.len() as u64 > MAX_CONFIG_BYTES {
            let message = format!("the file is over {MAX_CONFIG_BYTES} bytes; a scene's config is a few kilobytes");
            return Err(read_error(std::io::Error::new(std::io::ErrorKind::InvalidData, message)));
        }
        let text = String::from_utf8(bytes)
            .map_err(|_| read_error(std::io::Error::new(std::io::ErrorKind::InvalidData, "not UTF-8 text")))?;
        PipelineConfig::from_toml_str(&text, path)
    }

    /// Parses and validates config text as if it were read from `path` (which sets the folder that
    /// relative paths resolve against; the file itself is not read).
    pub fn from_toml_str(text: &str, path: &Path) -> Result<PipelineConfig, ConfigError> {
        let parse_error = |key: String, message: String| ConfigError::Parse {
            path: path.to_path_buf(),
            key: if key.is_empty() || key == "." { "(top level)".to_string() } else { key },
            message,
        };
        let deserializer = toml::de::Deserializer::parse(text)
            .map_err(|error| parse_error(String::new(), error.to_string().trim_end().to_string()))?;
        let mut config: PipelineConfig = serde_path_to_error::deserialize(deserializer)
            .map_err(|error| parse_error(error.path().to_string(), error.inner().to_string().trim_end().to_string()))?;
        let given = toml::from_str::<toml::Table>(text).ok().and_then(|table| serde_json::to_value(table).ok());
        let parsed = serde_json::to_value(&config).ok();
        if let Some((key, expected, found)) =
            given.zip(parsed).and_then(|(given, parsed)| array_lengths::first_mismatch(&given, &parsed, ""))
        {
            return Err(parse_error(key, format!("expected an array of {expected} entries, found {found}")));
        }
        config.path = path.to_path_buf();
        let check = Checker { path };
        if let Some(timeline) = &config.timeline {
            // the timeline decides what these would: one of them besides it is a contradiction
            let table = toml::from_str::<toml::Table>(text).unwrap_or_default();
            for (table_name, key, instead) in [
                ("scene", "frames_per_second", "timeline.fps"),
                ("sim", "frames", "timeline.duration_s and the speed curve"),
                ("sim", "steps_per_frame", "the speed curve"),
                ("rigid", "follow_through_s", "timeline.duration_s"),
            ] {
                let given = table.get(table_name).and_then(|t| t.get(key));
                if let Some(value) = given {
                    return Err(check.invalid(
                        &format!("{table_name}.{key}"),
                        &value.to_string(),
                        &format!("does not go with [timeline]: {instead} sets this; remove the key"),
                    ));
                }
            }
            config.scene.frames_per_second = timeline.fps;
        }
        check.that(!config.scene.output_dir.as_os_str().is_empty(), "scene.output_dir", "\"\"", || {
            "must name a folder (\".\" for the config file's own folder)".to_string()
        })?;
        let output_dir = config.scene.output_dir.to_string_lossy().into_owned();
        check.that(!output_dir.contains('\0'), "scene.output_dir", &format!("{output_dir:?}"), || {
            "must not contain a NUL character: no file system names a folder so".to_string()
        })?;
        material::resolve_moduli(&mut config.material, &check)?;
        lammps_terms::resolve(&mut config, &check)?;
        config.resolve_paths();
        config.validate()?;
        Ok(config)
    }

    /// The folder relative paths resolve against.
    pub fn base_dir(&self) -> &Path {
        match self.path.parent() {
            Some(parent) if !parent.as_os_str().is_empty() => parent,
            _ => Path::new("."),
        }
    }

    /// The scene's output folder.
    pub fn output_dir(&self) -> &Path {
        &self.scene.output_dir
    }

    /// The horizon delta = N * spacing in metres.
    pub fn horizon_m(&self) -> f64 {
        self.geometry.horizon_factor * self.geometry.spacing_m
    }

    /// Keys that are set but have no effect with the other settings (warn, don't fail).
    pub fn unused_keys(&self) -> Vec<String> {
        let mut unused = Vec::new();
        let transform = &self.geometry.transform;
        if self.geometry.source == GeometrySource::Box {
            if transform.scale != 1.0 {
                unused.push("geometry.transform.scale (box_size_m is already in metres)".to_string());
            }
            if transform.recenter {
                unused.push("geometry.transform.recenter (a box is centred already)".to_string());
            }
        } else if self.geometry.box_size_m.is_some() {
            unused.push("geometry.box_size_m (used only with source = \"box\")".to_string());
        }
        unused
    }

    fn resolve_paths(&mut self) {
        let base = self.base_dir().to_path_buf();
        resolve_path(&base, &mut self.scene.output_dir);
        if let GeometrySource::Mesh(mesh) = &mut self.geometry.source {
            resolve_path(&base, mesh);
        }
        self.sim.resolve_paths(&base);
        self.render.resolve_paths(&base);
    }

    fn validate(&self) -> Result<(), ConfigError> {
        let check = Checker { path: &self.path };
        self.scene.validate(&check)?;
        self.geometry.validate(&check)?;
        self.material.validate(&check)?;
        derived::validate(self, &check)?;
        if let Some(lead_in) = &self.lead_in {
            lead_in.validate(&check)?;
            check.that(
                self.sim.floor.is_some() || !self.sim.projectile.is_empty() || !self.sim.indenter.is_empty(),
                "lead_in",
                "(table)",
                || "needs something to fly into: a [sim.floor], a [[sim.projectile]] or a [[sim.indenter]]".into(),
            )?;
        }
        self.sim.validate(&check)?;
        self.post.validate(&check)?;
        if let Some(timeline) = &self.timeline {
            timeline.validate(&check)?;
        }
        if let Some(rigid) = &self.rigid {
            rigid.validate(&check)?;
            let frames = rigid.follow_through_s * self.scene.frames_per_second;
            check.that(
                frames <= MAX_FOLLOW_THROUGH_FRAMES,
                "rigid.follow_through_s",
                &rigid.follow_through_s.to_string(),
                || {
                    format!(
                        "at scene.frames_per_second it adds {frames:.0} frames, more than {MAX_FOLLOW_THROUGH_FRAMES}"
                    )
                },
            )?;
        }
        self.render.validate(&check)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{DEFAULT_FRACTURE_ENERGY_J_M2, GeometrySource, Sampler};

    const GLASS: &str = r#"
[scene]
name = "glass_plate"
output_dir = "out/glass_plate"
seed = 1
[geometry]
source = "box"
box_size_m = [0.1, 0.1, 0.005]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
"#;

    #[test]
    fn the_documented_example_parses_with_defaults() {
        let config = PipelineConfig::from_toml_str(GLASS, Path::new("/scenes/pipeline.toml"))
            .expect("the example config is valid");
        assert_eq!(config.scene.output_dir, Path::new("/scenes/out/glass_plate"));
        assert_eq!(config.geometry.source, GeometrySource::Box);
        assert_eq!(config.geometry.sampler, Sampler::Grid);
        assert_eq!(config.geometry.transform.scale, 1.0);
        assert_eq!(config.material.threshold_jitter, 0.02);
        assert!((config.horizon_m() - 0.003).abs() < 1e-15);
    }

    #[test]
    fn mean_critical_stretch_follows_silling_and_askari() {
        let config = PipelineConfig::from_toml_str(GLASS, Path::new("pipeline.toml")).expect("valid");
        let delta = 0.003;
        let expected = (5.0 * DEFAULT_FRACTURE_ENERGY_J_M2 / (9.0 * 14.9e9 * delta)).sqrt();
        assert!((config.material.mean_critical_stretch(delta) - expected).abs() < 1e-15);
        let direct = GLASS.replace("bulk_modulus_pa = 14.9e9", "bulk_modulus_pa = 14.9e9\ncritical_stretch = 0.001");
        let config = PipelineConfig::from_toml_str(&direct, Path::new("pipeline.toml")).expect("valid");
        assert_eq!(config.material.mean_critical_stretch(delta), 0.001);
    }

    #[test]
    fn nan_and_infinite_values_are_rejected() {
        let text = GLASS.replace("spacing_m = 0.001", "spacing_m = nan");
        let error = PipelineConfig::from_toml_str(&text, Path::new("p.toml")).expect_err("nan");
        assert!(error.to_string().contains("geometry.spacing_m = NaN"), "{error}");
        let text = GLASS
            .replace("rotate", "x")
            .replace("[material]", "[geometry.transform]\nrotate_deg = [0, inf, 0]\n[material]");
        let error = PipelineConfig::from_toml_str(&text, Path::new("p.toml")).expect_err("inf");
        assert!(error.to_string().contains("geometry.transform.rotate_deg"), "{error}");
    }
}
