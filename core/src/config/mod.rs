//! The scene description, `pipeline.toml`: schema, parsing and validation.
//!
//! Every table rejects unknown keys. Values carry their SI unit in the key name. Relative paths
//! resolve against the folder that holds the config file. [`PipelineConfig::load`] returns either
//! a fully validated config or one [`ConfigError`] that names the file, the key and what would be
//! valid. The schema is documented for users in `docs/CONFIG.md`.

use std::fmt;
use std::path::{Component, Path, PathBuf};

use serde::{Deserialize, Serialize};

mod array_lengths;
pub mod derived;
mod lammps_terms;
pub mod lead_in;
pub mod material;
pub mod post;
pub mod render;
pub mod rigid;
pub mod sim;
pub mod timeline;

pub use lead_in::LeadInConfig;
pub use material::{DEFAULT_FRACTURE_ENERGY_J_M2, MaterialConfig};
pub use post::PostConfig;
pub use render::RenderConfig;
pub use rigid::RigidConfig;
pub use sim::SimConfig;
pub use timeline::TimelineConfig;

/// The largest horizon factor N accepted: bonds per particle grow as N^3 (about 2,100 at N = 8).
pub const MAX_HORIZON_FACTOR: f64 = 8.0;
/// The longest scene name: it names files (`<name>.####.exr`, and a temporary name a little
/// longer while one is written) that must stay within the 255 bytes file systems allow.
pub const MAX_SCENE_NAME_BYTES: usize = 200;
/// The highest frame rate accepted (high-speed cameras stop well below).
pub const MAX_FRAMES_PER_SECOND: f64 = 100_000.0;
/// The most frames a follow-through may add to a shot.
pub const MAX_FOLLOW_THROUGH_FRAMES: f64 = 1_000_000.0;
/// The largest config file read.
pub const MAX_CONFIG_BYTES: u64 = 1 << 20;
/// The largest per-bond threshold jitter accepted, as a fraction of the mean threshold.
pub const MAX_THRESHOLD_JITTER: f64 = 0.2;

/// A problem with a `pipeline.toml`: it cannot be read, it is not valid TOML for the schema, or a
/// value is out of range. The CLI exits with code 2 on any of these.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{path}: cannot read the config file: {source}")]
    Read {
        /// The config file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not valid TOML, has an unknown key, a missing key or a value of the wrong type.
    #[error("{path}: key `{key}`: {message}")]
    Parse {
        /// The config file.
        path: PathBuf,
        /// Dotted path of the offending key (`scene.foo`), or `(top level)`.
        key: String,
        /// The parser's message, with line, column and the offending line.
        message: String,
    },
    /// A key has a value outside its allowed range, or keys contradict each other.
    #[error("{path}: {key} = {value}: {message}")]
    Invalid {
        /// The config file.
        path: PathBuf,
        /// Dotted path of the offending key.
        key: String,
        /// The offending value as written in TOML.
        value: String,
        /// What is wrong and what would be valid.
        message: String,
    },
}

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

/// `[geometry]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeometryConfig {
    /// `"box"` or the path of a closed Wavefront OBJ mesh (relative to the config file's folder).
    pub source: GeometrySource,
    /// Box edge lengths in metres; used only when `source = "box"`.
    #[serde(default)]
    pub box_size_m: Option<[f64; 3]>,
    /// How the solid becomes particles.
    pub sampler: Sampler,
    /// Spacing in metres, which is also lambda: the cube side for `grid`, the minimum distance
    /// between the points of a layer for `tet_shell`, the minimum distance between sites for
    /// `voronoi` (unless `[geometry.voronoi] particles` is given).
    pub spacing_m: f64,
    /// N in delta = N * lambda: particles closer than delta are bonded. May be left out for
    /// `horizon_m`.
    #[serde(default = "lammps_terms::unset")]
    pub horizon_factor: f64,
    /// The horizon delta in metres (LAMMPS's `pair_coeff` cutoff) instead of `horizon_factor`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub horizon_m: Option<f64>,
    /// `[geometry.transform]`: placement of the source in the world.
    #[serde(default)]
    pub transform: TransformConfig,
    /// `[geometry.mesh_repair]`: what to do with defects of real meshes.
    #[serde(default)]
    pub mesh_repair: MeshRepairConfig,
    /// `[geometry.tet_shell]`: the layered shell of the `tet_shell` sampler.
    #[serde(default)]
    pub tet_shell: TetShellConfig,
    /// `[geometry.voronoi]`: the blue-noise sites of the `voronoi` sampler.
    #[serde(default)]
    pub voronoi: VoronoiConfig,
}

/// The most layers `[geometry.tet_shell]` accepts.
pub const MAX_TET_SHELL_LAYERS: u32 = 1000;

/// The layers of the `tet_shell` sampler when `layers` is not given: the paper's six for its vase,
/// or one more than the horizon factor N where N is 6 or more (the paper: layers should outnumber N).
pub fn default_tet_shell_layers(horizon_factor: f64) -> u32 {
    let beyond_horizon = horizon_factor.floor().clamp(0.0, MAX_TET_SHELL_LAYERS as f64 - 1.0) as u32 + 1;
    beyond_horizon.max(6)
}

/// `[geometry.tet_shell]`: layers offset inward from the surface, each sampled with blue noise at
/// `spacing_m`, tetrahedralized together (the paper's vase).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TetShellConfig {
    /// Number of layers, the surface included (at least 2); default
    /// [`default_tet_shell_layers`] (6, or N + 1 for N >= 6).
    pub layers: Option<u32>,
    /// Distance between consecutive layers in metres; default `spacing_m`.
    pub layer_spacing_m: Option<f64>,
    /// Fill the core under the innermost layer with blue-noise points and keep its tets: a solid
    /// tetrahedral mesh instead of a shell.
    pub filled_core: bool,
}

impl GeometryConfig {
    /// The number of `tet_shell` layers: the configured one or the default for the horizon factor.
    pub fn tet_shell_layers(&self) -> u32 {
        self.tet_shell.layers.unwrap_or_else(|| default_tet_shell_layers(self.horizon_factor))
    }

    /// The distance between `tet_shell` layers in metres: the configured one or `spacing_m`.
    pub fn tet_shell_layer_spacing_m(&self) -> f64 {
        self.tet_shell.layer_spacing_m.unwrap_or(self.spacing_m)
    }
}

/// `[geometry.voronoi]`: blue-noise sites inside the mesh, cut into clipped Voronoi cells (the
/// paper's dragon).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VoronoiConfig {
    /// Aim for about this many particles (within a few percent) instead of using `spacing_m` as
    /// the minimum distance between sites; the minimum distance is then chosen to match.
    pub particles: Option<u64>,
}

/// Where the solid comes from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(from = "String", into = "String")]
pub enum GeometrySource {
    /// An axis-aligned box of `box_size_m`, centred at the origin before the transform.
    Box,
    /// A closed triangle mesh in a Wavefront OBJ file. After [`PipelineConfig::load`] the path is
    /// absolute or relative to the working directory (resolved against the config's folder).
    Mesh(PathBuf),
}

impl From<String> for GeometrySource {
    fn from(value: String) -> Self {
        if value == "box" { GeometrySource::Box } else { GeometrySource::Mesh(PathBuf::from(value)) }
    }
}

impl From<GeometrySource> for String {
    fn from(value: GeometrySource) -> Self {
        value.to_string()
    }
}

impl fmt::Display for GeometrySource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GeometrySource::Box => f.write_str("box"),
            GeometrySource::Mesh(path) => write!(f, "{}", path.display()),
        }
    }
}

/// How the solid is turned into particles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Sampler {
    /// Cubes of side lambda on a regular grid (the paper's glass plate).
    Grid,
    /// Tetrahedra of a layered shell under the surface (the paper's vase).
    TetShell,
    /// Clipped Voronoi cells of blue-noise points: trimtopes (the paper's dragon).
    Voronoi,
}

impl Sampler {
    /// The name used in `pipeline.toml`.
    pub fn name(self) -> &'static str {
        match self {
            Sampler::Grid => "grid",
            Sampler::TetShell => "tet_shell",
            Sampler::Voronoi => "voronoi",
        }
    }
}

/// `[geometry.transform]`: the source is scaled about its own origin (optionally after moving its
/// bounding-box centre there), sampled in that frame, then rotated and translated into the world.
/// Rotation is about X, then Y, then Z (world axes).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TransformConfig {
    /// Uniform scale from source units to metres (0.001 for a mesh in millimetres).
    pub scale: f64,
    /// Move the source's bounding-box centre to the origin before scaling and rotating.
    pub recenter: bool,
    /// Rotation in degrees about the world X, Y and Z axes, applied in that order.
    pub rotate_deg: [f64; 3],
    /// Translation in metres, applied last.
    pub translate_m: [f64; 3],
}

impl Default for TransformConfig {
    fn default() -> Self {
        TransformConfig { scale: 1.0, recenter: false, rotate_deg: [0.0; 3], translate_m: [0.0; 3] }
    }
}

/// `[geometry.mesh_repair]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MeshRepairConfig {
    /// Separate bodies of the mesh whose enclosed volume is below this fraction of the largest
    /// body's are dropped (and reported): stray specks that real scans carry.
    pub min_body_volume_fraction: f64,
}

impl Default for MeshRepairConfig {
    fn default() -> Self {
        MeshRepairConfig { min_body_volume_fraction: 1e-3 }
    }
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
        let scene = &self.scene;
        let name_ok = !scene.name.is_empty()
            && scene.name.len() <= MAX_SCENE_NAME_BYTES
            && !scene.name.starts_with('.')
            && scene.name.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
        check.that(name_ok, "scene.name", &format!("{:?}", scene.name), || {
            format!(
                "must be 1 to {MAX_SCENE_NAME_BYTES} letters, digits, '_', '-' and '.', not starting with '.' (it \
                 names output files)"
            )
        })?;
        check.positive("scene.frames_per_second", scene.frames_per_second, "frames per second")?;
        let fps = scene.frames_per_second;
        check.that(fps <= MAX_FRAMES_PER_SECOND, "scene.frames_per_second", &fps.to_string(), || {
            format!("must be at most {MAX_FRAMES_PER_SECOND} frames per second")
        })?;

        let geometry = &self.geometry;
        match &geometry.source {
            GeometrySource::Box => {
                let Some(size) = geometry.box_size_m else {
                    return Err(check.invalid(
                        "geometry.box_size_m",
                        "(missing)",
                        "source = \"box\" needs box_size_m = [x, y, z] in metres",
                    ));
                };
                check.positive_array("geometry.box_size_m", &size)?;
            }
            GeometrySource::Mesh(mesh) => {
                let shown = format!("{:?}", mesh.display().to_string());
                let is_obj =
                    mesh.extension().and_then(|ext| ext.to_str()).is_some_and(|ext| ext.eq_ignore_ascii_case("obj"));
                check.that(is_obj, "geometry.source", &shown, || {
                    "must be \"box\" or the path of a Wavefront .obj mesh".to_string()
                })?;
                check.that(mesh.is_file(), "geometry.source", &shown, || {
                    "mesh file not found (relative paths start at the config file's folder)".to_string()
                })?;
            }
        }
        if let (GeometrySource::Mesh(_), Some(size)) = (&geometry.source, geometry.box_size_m) {
            check.positive_array("geometry.box_size_m", &size)?;
        }
        check.positive("geometry.spacing_m", geometry.spacing_m, "metres")?;
        if let (GeometrySource::Box, Some(size)) = (&geometry.source, geometry.box_size_m) {
            let spacing = geometry.spacing_m;
            check.that(
                size.iter().all(|side| *side >= spacing),
                "geometry.box_size_m",
                &format!("{size:?}"),
                || format!("every side must be at least geometry.spacing_m = {spacing} m (one particle across)"),
            )?;
        }
        let horizon = geometry.horizon_factor;
        check.that(
            horizon.is_finite() && (1.0..=MAX_HORIZON_FACTOR).contains(&horizon),
            "geometry.horizon_factor",
            &horizon.to_string(),
            || format!("must be between 1 and {MAX_HORIZON_FACTOR} (the paper uses 2 to 6)"),
        )?;

        let transform = &geometry.transform;
        check.positive("geometry.transform.scale", transform.scale, "source units to metres")?;
        check.finite_array("geometry.transform.rotate_deg", &transform.rotate_deg)?;
        check.finite_array("geometry.transform.translate_m", &transform.translate_m)?;
        let shell = &geometry.tet_shell;
        if let Some(layers) = shell.layers {
            check.that((2..=MAX_TET_SHELL_LAYERS).contains(&layers), "geometry.tet_shell.layers", &layers.to_string(), || {
                format!(
                    "must be between 2 and {MAX_TET_SHELL_LAYERS}: the surface and at least one layer under it (the \
                     paper: more layers than horizon_factor)"
                )
            })?;
        }
        if let Some(layer_spacing) = shell.layer_spacing_m {
            check.positive("geometry.tet_shell.layer_spacing_m", layer_spacing, "metres")?;
        }
        if let Some(particles) = geometry.voronoi.particles {
            check.that(
                (1..=u64::from(u32::MAX)).contains(&particles),
                "geometry.voronoi.particles",
                &particles.to_string(),
                || format!("must be between 1 and {} (particles are numbered with 32 bits)", u32::MAX),
            )?;
        }
        let fraction = geometry.mesh_repair.min_body_volume_fraction;
        check.that(
            (0.0..1.0).contains(&fraction),
            "geometry.mesh_repair.min_body_volume_fraction",
            &fraction.to_string(),
            || "must be at least 0 and below 1".to_string(),
        )?;

        let material = &self.material;
        check.positive("material.density_kg_m3", material.density_kg_m3, "kg/m^3")?;
        check.positive("material.bulk_modulus_pa", material.bulk_modulus_pa, "Pa")?;
        match (material.fracture_energy_j_m2, material.critical_stretch) {
            (Some(_), Some(_)) => {
                return Err(check.invalid(
                    "material.critical_stretch",
                    &format!("{}", material.critical_stretch.unwrap_or_default()),
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
        let jitter = material.threshold_jitter;
        check.that(
            jitter.is_finite() && (0.0..=MAX_THRESHOLD_JITTER).contains(&jitter),
            "material.threshold_jitter",
            &jitter.to_string(),
            || format!("must be between 0 and {MAX_THRESHOLD_JITTER} (a fraction of the mean threshold)"),
        )?;
        check.non_negative("material.compression_alpha", material.compression_alpha, "dimensionless")?;
        material.validate_model(&check)?;
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

/// Builds [`ConfigError::Invalid`] errors for one config file.
struct Checker<'a> {
    path: &'a Path,
}

impl Checker<'_> {
    fn invalid(&self, key: &str, value: &str, message: &str) -> ConfigError {
        ConfigError::Invalid {
            path: self.path.to_path_buf(),
            key: key.to_string(),
            value: value.to_string(),
            message: message.to_string(),
        }
    }

    fn that(&self, ok: bool, key: &str, value: &str, message: impl FnOnce() -> String) -> Result<(), ConfigError> {
        if ok { Ok(()) } else { Err(self.invalid(key, value, &message())) }
    }

    fn positive(&self, key: &str, value: f64, unit: &str) -> Result<(), ConfigError> {
        self.that(value.is_finite() && value > 0.0, key, &value.to_string(), || {
            format!("must be a finite number greater than 0 ({unit})")
        })
    }

    fn non_negative(&self, key: &str, value: f64, unit: &str) -> Result<(), ConfigError> {
        self.that(value.is_finite() && value >= 0.0, key, &value.to_string(), || {
            format!("must be a finite number, 0 or more ({unit})")
        })
    }

    fn finite(&self, key: &str, value: f64) -> Result<(), ConfigError> {
        self.that(value.is_finite(), key, &value.to_string(), || "must be a finite number".to_string())
    }

    fn direction(&self, key: &str, values: &[f64; 3]) -> Result<(), ConfigError> {
        let ok = values.iter().all(|v| v.is_finite()) && values.iter().any(|v| *v != 0.0);
        self.that(ok, key, &format!("{values:?}"), || "must be a finite, non-zero vector".to_string())
    }

    fn unit_colour(&self, key: &str, values: &[f64; 3]) -> Result<(), ConfigError> {
        let ok = values.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v));
        self.that(ok, key, &format!("{values:?}"), || "every entry must be between 0 and 1".to_string())
    }

    fn positive_array(&self, key: &str, values: &[f64; 3]) -> Result<(), ConfigError> {
        let ok = values.iter().all(|v| v.is_finite() && *v > 0.0);
        self.that(ok, key, &format!("{values:?}"), || {
            "every entry must be a finite number greater than 0 (metres)".to_string()
        })
    }

    fn finite_array(&self, key: &str, values: &[f64; 3]) -> Result<(), ConfigError> {
        let ok = values.iter().all(|v| v.is_finite());
        self.that(ok, key, &format!("{values:?}"), || "every entry must be a finite number".to_string())
    }
}

/// Makes a relative `path` relative to `base` (the config file's folder) and folds away its `.`
/// and `..` components as text, so that messages name `out/vase` rather than
/// `assets/scenes/../../out/vase` (like a shell's `cd`, not like following links).
pub(crate) fn resolve_path(base: &Path, path: &mut PathBuf) {
    if path.is_absolute() {
        return;
    }
    let mut resolved = PathBuf::new();
    for component in base.join(&*path).components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir if matches!(resolved.components().next_back(), Some(Component::Normal(_))) => {
                resolved.pop();
            }
            Component::ParentDir if resolved.has_root() => {}
            other => resolved.push(other),
        }
    }
    if resolved.as_os_str().is_empty() {
        resolved.push(".");
    }
    *path = resolved;
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn relative_paths_start_at_the_config_folder_with_dot_dots_folded() {
        let cases = [
            ("/work/assets/scenes", "../../out/vase", "/work/out/vase"),
            ("/work/assets/scenes", "./../meshes/./vase.obj", "/work/assets/meshes/vase.obj"),
            ("assets/scenes", "../../out", "out"),
            ("assets", "../../out", "../out"),
            ("", "../out", "../out"),
            ("assets", "..", "."),
            ("/", "../../x", "/x"),
            ("/work", "/abs/../kept", "/abs/../kept"),
        ];
        for (base, path, expected) in cases {
            let mut resolved = PathBuf::from(path);
            resolve_path(Path::new(base), &mut resolved);
            assert_eq!(resolved, PathBuf::from(expected), "{base} + {path}");
        }
    }
}
