//! `[geometry]`: the source shape, its placement and repair, and how it becomes particles.

use std::fmt;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::checker::Checker;

/// The largest horizon factor N accepted: bonds per particle grow as N^3 (about 2,100 at N = 8).
pub const MAX_HORIZON_FACTOR: f64 = 8.0;

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
    #[serde(default = "super::lammps_terms::unset")]
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
    /// A closed triangle mesh in a Wavefront OBJ file. After [`PipelineConfig::load`](super::PipelineConfig::load) the path is
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

impl GeometryConfig {
    /// Checks the source, the spacing and horizon, the transform, and the samplers' and the
    /// repair's settings.
    pub(super) fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        match &self.source {
            GeometrySource::Box => {
                let Some(size) = self.box_size_m else {
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
        if let (GeometrySource::Mesh(_), Some(size)) = (&self.source, self.box_size_m) {
            check.positive_array("geometry.box_size_m", &size)?;
        }
        check.positive("geometry.spacing_m", self.spacing_m, "metres")?;
        if let (GeometrySource::Box, Some(size)) = (&self.source, self.box_size_m) {
            let spacing = self.spacing_m;
            check.that(
                size.iter().all(|side| *side >= spacing),
                "geometry.box_size_m",
                &format!("{size:?}"),
                || format!("every side must be at least geometry.spacing_m = {spacing} m (one particle across)"),
            )?;
        }
        let horizon = self.horizon_factor;
        check.that(
            horizon.is_finite() && (1.0..=MAX_HORIZON_FACTOR).contains(&horizon),
            "geometry.horizon_factor",
            &horizon.to_string(),
            || format!("must be between 1 and {MAX_HORIZON_FACTOR} (the paper uses 2 to 6)"),
        )?;

        let transform = &self.transform;
        check.positive("geometry.transform.scale", transform.scale, "source units to metres")?;
        check.finite_array("geometry.transform.rotate_deg", &transform.rotate_deg)?;
        check.finite_array("geometry.transform.translate_m", &transform.translate_m)?;
        let shell = &self.tet_shell;
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
        if let Some(particles) = self.voronoi.particles {
            check.that(
                (1..=u64::from(u32::MAX)).contains(&particles),
                "geometry.voronoi.particles",
                &particles.to_string(),
                || format!("must be between 1 and {} (particles are numbered with 32 bits)", u32::MAX),
            )?;
        }
        let fraction = self.mesh_repair.min_body_volume_fraction;
        check.that(
            (0.0..1.0).contains(&fraction),
            "geometry.mesh_repair.min_body_volume_fraction",
            &fraction.to_string(),
            || "must be at least 0 and below 1".to_string(),
        )?;
        Ok(())
    }
}
