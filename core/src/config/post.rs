//! `[post]`: fragments, their motion and the exports of `shatter post`.

use serde::{Deserialize, Serialize};

use super::{Checker, ConfigError};

/// `[post]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PostConfig {
    /// Smoothing of sudden transform changes (the paper's PD controller): the time constant in
    /// frames with which rendered fragments follow their measured motion; 0 turns it off.
    pub smoothing_frames: f64,
    /// Write `fragments/points.####.ply`: positions with each particle's fragment id.
    pub point_caches: bool,
    /// Write `fragments/fragments.usda`: one mesh per final piece with time-sampled transforms.
    pub usd: bool,
}

impl Default for PostConfig {
    fn default() -> Self {
        PostConfig { smoothing_frames: 0.0, point_caches: true, usd: true }
    }
}

impl PostConfig {
    pub(super) fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        let tau = self.smoothing_frames;
        check.that(tau == 0.0 || (tau.is_finite() && tau >= 0.25), "post.smoothing_frames", &tau.to_string(), || {
            "must be 0 (off) or a time constant of at least 0.25 frames".into()
        })
    }
}
