//! The scene description, `pipeline.toml`: schema, parsing and validation.
//!
//! Every table rejects unknown keys. Values carry their SI unit in the key name. Relative paths
//! resolve against the folder that holds the config file. [`PipelineConfig::load`] returns either
//! a fully validated config or one [`ConfigError`] that names the file, the key and what would be
//! valid. The schema is documented for users in `docs/CONFIG.md`.

mod array_lengths;
mod checker;
mod config_error;
pub mod derived;
mod geometry;
mod lammps_terms;
pub mod lead_in;
pub mod material;
mod pipeline_config;
pub mod post;
mod relative_paths;
pub mod render;
pub mod rigid;
mod scene;
pub mod secondary_fracture;
mod shards;
pub mod sim;
pub mod timeline;

pub use config_error::ConfigError;
pub use geometry::{
    GeometryConfig, GeometrySource, MAX_HORIZON_FACTOR, MAX_TET_SHELL_LAYERS, MeshRepairConfig, Sampler,
    TetShellConfig, TransformConfig, VoronoiConfig, default_tet_shell_layers,
};
pub use lead_in::LeadInConfig;
pub use material::{DEFAULT_FRACTURE_ENERGY_J_M2, MAX_THRESHOLD_JITTER, MaterialConfig};
pub use pipeline_config::{MAX_CONFIG_BYTES, MAX_FOLLOW_THROUGH_FRAMES, PipelineConfig};
pub use post::PostConfig;
pub use render::RenderConfig;
pub use rigid::RigidConfig;
pub use scene::{MAX_FRAMES_PER_SECOND, MAX_SCENE_NAME_BYTES, SceneConfig};
pub use secondary_fracture::SecondaryFractureConfig;
pub use sim::SimConfig;
pub use timeline::TimelineConfig;
