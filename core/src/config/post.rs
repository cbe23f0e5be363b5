//! `[post]`: fragments, their motion and the exports of `shatter post`.

use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::checker::Checker;
use super::material::MaterialModel;

/// How elements are drawn (`post.element_shapes`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ElementShapes {
    /// `deformed` for the elastoplastic model, `rigid` for PMB.
    #[default]
    Auto,
    /// Every element moves with its fragment's rigid (Kabsch) motion: its rest shape.
    Rigid,
    /// Every element is drawn in its deformed shape: post writes each element's affine map
    /// (cubes and trimtopes: the particle's deformation gradient; tetrahedra: the embedded mesh,
    /// split where cracks separate them) into the fragments files.
    Deformed,
}

impl ElementShapes {
    fn is_auto(&self) -> bool {
        *self == ElementShapes::Auto
    }
}

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
    /// How elements are drawn: `"auto"` (default: `"deformed"` for the elastoplastic model,
    /// `"rigid"` for PMB), `"rigid"` or `"deformed"`. Left out of the serialised settings when
    /// `"auto"`, so that the digests of scenes that do not set it are what they always were.
    #[serde(skip_serializing_if = "ElementShapes::is_auto")]
    pub element_shapes: ElementShapes,
}

impl Default for PostConfig {
    fn default() -> Self {
        PostConfig { smoothing_frames: 0.0, point_caches: true, usd: true, element_shapes: ElementShapes::Auto }
    }
}

impl PostConfig {
    /// Whether post writes the elements' deformed shapes for a scene of material model `model`.
    pub fn deformed_elements(&self, model: MaterialModel) -> bool {
        match self.element_shapes {
            ElementShapes::Auto => model == MaterialModel::Elastoplastic,
            ElementShapes::Rigid => false,
            ElementShapes::Deformed => true,
        }
    }

    pub(super) fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        let tau = self.smoothing_frames;
        check.that(tau == 0.0 || (tau.is_finite() && tau >= 0.25), "post.smoothing_frames", &tau.to_string(), || {
            "must be 0 (off) or a time constant of at least 0.25 frames".into()
        })
    }
}
