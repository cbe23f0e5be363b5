//! `[scene]`: the scene's name, output folder, seed and frame rate.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::checker::Checker;

/// The longest scene name: it names files (`<name>.####.exr`, and a temporary name a little
/// longer while one is written) that must stay within the 255 bytes file systems allow.
pub const MAX_SCENE_NAME_BYTES: usize = 200;
/// The highest frame rate accepted (high-speed cameras stop well below).
pub const MAX_FRAMES_PER_SECOND: f64 = 100_000.0;

/// `[scene]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneConfig {
    /// Scene name, used in output file names: letters, digits, `_`, `-` and `.`.
    pub name: String,
    /// Folder every stage writes into; relative to the config file's folder.
    pub output_dir: PathBuf,
    /// Seed for every random choice (threshold jitter, sampling): same seed, same result.
    pub seed: u64,
    /// Playback rate of the frames (USD time codes, EXR metadata).
    #[serde(default = "default_frames_per_second")]
    pub frames_per_second: f64,
}

fn default_frames_per_second() -> f64 {
    24.0
}

impl SceneConfig {
    /// Checks the name (it names files) and the frame rate.
    pub(super) fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        let name_ok = !self.name.is_empty()
            && self.name.len() <= MAX_SCENE_NAME_BYTES
            && !self.name.starts_with('.')
            && self.name.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
        check.that(name_ok, "scene.name", &format!("{:?}", self.name), || {
            format!(
                "must be 1 to {MAX_SCENE_NAME_BYTES} letters, digits, '_', '-' and '.', not starting with '.' (it \
                 names output files)"
            )
        })?;
        check.positive("scene.frames_per_second", self.frames_per_second, "frames per second")?;
        let fps = self.frames_per_second;
        check.that(fps <= MAX_FRAMES_PER_SECOND, "scene.frames_per_second", &fps.to_string(), || {
            format!("must be at most {MAX_FRAMES_PER_SECOND} frames per second")
        })?;
        Ok(())
    }
}
