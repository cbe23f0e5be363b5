//! `[render]`: camera, image, lighting and look of `shatter render`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::checker::Checker;
use super::sim::BackendChoice;

/// The largest `environment_intensity`: a million times a map's radiance is far past any real
/// light, and far enough from single precision's limit that radiance times it stays finite.
pub const MAX_ENVIRONMENT_INTENSITY: f64 = 1e6;

/// `[render]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderConfig {
    /// Where the ray tracer runs.
    pub backend: BackendChoice,
    /// Image width and height in pixels.
    pub resolution: [u32; 2],
    /// Samples per pixel (antialiasing, glass paths); the first goes through the pixel centre and
    /// gives the depth, normal and fragment layers.
    pub samples_per_pixel: u32,
    /// Longest path through glass, in surface events (reflections and refractions); a path
    /// still going then takes the environment's radiance along its last direction.
    pub max_bounces: u32,
    /// Glass surface events, counted from the camera, at which a path follows both the reflected
    /// and the refracted branch weighted by Fresnel (later events pick one at random): 0 is plain
    /// random choice; each split costs a branch, at most 4 pending per sample.
    pub glass_split_events: u32,
    /// The shutter's open time as a fraction of a frame, centred on the frame's time: each
    /// camera ray sees the pieces where their motion puts them at its own time in that interval
    /// (3D motion blur). 0.5 is a 180-degree shutter; 0 gives still frames.
    pub shutter: f64,
    /// How the floor texture is sampled.
    pub texture_filter: TextureFilter,
    /// Also write the denoising passes (Blender's Denoising Albedo and Denoising Normal), the
    /// guides a comp's denoiser takes with the colour.
    pub denoising_passes: bool,
    /// Equirectangular HDR environment (.hdr or .exr), relative to the config file's folder;
    /// absent, a uniform sky of radiance 1.
    pub environment: Option<PathBuf>,
    /// Multiplier of the environment's radiance.
    pub environment_intensity: f64,
    /// Show the environment behind the scene (else black and transparent).
    pub show_environment: bool,
    /// Also write tonemapped PNG previews beside the EXR frames.
    pub previews: bool,
    /// Exposure of the previews, in stops.
    pub preview_exposure_stops: f64,
    /// `[render.camera]`.
    pub camera: CameraConfig,
    /// `[render.material]`.
    pub material: LookConfig,
    /// `[render.floor]`: a textured floor plane; absent, none.
    pub floor: Option<RenderFloorConfig>,
}

impl Default for RenderConfig {
    fn default() -> Self {
        RenderConfig {
            backend: BackendChoice::Auto,
            resolution: [960, 540],
            samples_per_pixel: 4,
            max_bounces: 8,
            glass_split_events: 0,
            shutter: 0.5,
            denoising_passes: true,
            texture_filter: TextureFilter::Anisotropic,
            environment: None,
            environment_intensity: 1.0,
            show_environment: true,
            previews: true,
            preview_exposure_stops: 0.0,
            camera: CameraConfig::default(),
            material: LookConfig::default(),
            floor: None,
        }
    }
}

/// `[render.camera]`: a pinhole camera, or with `f_stop` a thin lens (depth of field). Without a
/// position it frames the body's rest bounds from the front and a little above.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraConfig {
    /// Eye position, metres; absent, chosen to frame the body.
    pub position_m: Option<[f64; 3]>,
    /// Point looked at, metres; absent, the centre of the body.
    pub look_at_m: Option<[f64; 3]>,
    /// Up direction.
    pub up: [f64; 3],
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
    /// The lens's f-number (focal length over aperture diameter); absent, a pinhole (everything
    /// sharp).
    pub f_stop: Option<f64>,
    /// Distance of the plane in focus along the view, metres; absent, the body's rest centre's.
    pub focus_distance_m: Option<f64>,
    /// Height of the sensor that the vertical field of view spans, millimetres (a full-frame
    /// 35 mm camera's: 24); with `f_stop` it sets the focal length, so the aperture.
    pub sensor_height_mm: f64,
}

impl Default for CameraConfig {
    fn default() -> Self {
        CameraConfig {
            position_m: None,
            look_at_m: None,
            up: [0.0, 1.0, 0.0],
            fov_deg: 40.0,
            f_stop: None,
            focus_distance_m: None,
            sensor_height_mm: 24.0,
        }
    }
}

/// How the floor texture is sampled (`render.texture_filter`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TextureFilter {
    /// Averaged over each ray's footprint: a mip chain, several trilinear lookups along the
    /// footprint's long axis (no moire toward the horizon).
    #[default]
    Anisotropic,
    /// The texel under the point (aliases where a pixel covers many texels).
    Point,
}

/// What cubes are made of (`render.material.cubes`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CubeSurface {
    /// Glass: refracting, tinted by `glass_absorption_per_m` (the paper's glass plate).
    #[default]
    Glass,
    /// Opaque, as tetrahedra and trimtopes are: `albedo`, `fracture_albedo` (clay, metal).
    Opaque,
}

impl CubeSurface {
    fn is_glass(&self) -> bool {
        *self == CubeSurface::Glass
    }
}

/// `[render.material]`: how elements look. Cubes are glass unless `cubes = "opaque"`; tetrahedra
/// and trimtopes are opaque.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LookConfig {
    /// What cubes are made of.
    #[serde(skip_serializing_if = "CubeSurface::is_glass")]
    pub cubes: CubeSurface,
    /// Index of refraction of glass.
    pub glass_ior: f64,
    /// Absorption of light inside glass per metre travelled, RGB (a tint: 0 is clear).
    pub glass_absorption_per_m: [f64; 3],
    /// Diffuse albedo of opaque elements, RGB in [0, 1].
    pub albedo: [f64; 3],
    /// Diffuse albedo of opaque elements' fracture faces (faces that rested against another
    /// element), RGB in [0, 1]; absent, `albedo`.
    pub fracture_albedo: Option<[f64; 3]>,
    /// Strength of the normalized Blinn-Phong highlight of opaque elements.
    pub specular: f64,
    /// Blinn-Phong exponent.
    pub shininess: f64,
}

impl Default for LookConfig {
    fn default() -> Self {
        LookConfig {
            cubes: CubeSurface::Glass,
            glass_ior: 1.5,
            glass_absorption_per_m: [1.0, 0.3, 0.6],
            albedo: [0.8, 0.75, 0.7],
            fracture_albedo: None,
            specular: 0.2,
            shininess: 64.0,
        }
    }
}

/// `[render.floor]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderFloorConfig {
    /// Height of the floor plane, metres.
    pub height_m: f64,
    /// Albedo texture (sRGB image), relative to the config file's folder; absent, `albedo`.
    pub texture: Option<PathBuf>,
    /// Size of one texture tile, metres.
    pub tile_size_m: f64,
    /// Albedo without a texture, RGB in [0, 1].
    pub albedo: [f64; 3],
}

impl Default for RenderFloorConfig {
    fn default() -> Self {
        RenderFloorConfig { height_m: 0.0, texture: None, tile_size_m: 0.5, albedo: [0.5, 0.5, 0.5] }
    }
}

impl RenderConfig {
    pub(super) fn resolve_paths(&mut self, base: &Path) {
        let resolve = |path: &mut PathBuf| super::relative_paths::resolve_path(base, path);
        if let Some(path) = &mut self.environment {
            resolve(path);
        }
        if let Some(path) = self.floor.as_mut().and_then(|floor| floor.texture.as_mut()) {
            resolve(path);
        }
    }

    pub(super) fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        let [width, height] = self.resolution;
        check.that(
            (1..=16384).contains(&width) && (1..=16384).contains(&height),
            "render.resolution",
            &format!("{:?}", self.resolution),
            || "width and height must be between 1 and 16384 pixels".into(),
        )?;
        check.that(
            (1..=4096).contains(&self.samples_per_pixel),
            "render.samples_per_pixel",
            &self.samples_per_pixel.to_string(),
            || "must be between 1 and 4096".into(),
        )?;
        check.that(
            self.max_bounces >= 1 && self.max_bounces <= 64,
            "render.max_bounces",
            &self.max_bounces.to_string(),
            || "must be between 1 and 64".into(),
        )?;
        check.that(
            self.glass_split_events <= 8,
            "render.glass_split_events",
            &self.glass_split_events.to_string(),
            || "must be between 0 and 8".into(),
        )?;
        check.within("render.shutter", self.shutter, 0.0..=1.0, "a fraction of a frame (0: still frames)")?;
        for (key, path) in [
            ("render.environment", &self.environment),
            ("render.floor.texture", &self.floor.as_ref().and_then(|f| f.texture.clone())),
        ] {
            if let Some(path) = path {
                check.that(path.is_file(), key, &format!("{:?}", path.display().to_string()), || {
                    "file not found (relative paths start at the config file's folder)".into()
                })?;
            }
        }
        if let Some(path) = &self.environment {
            let hdr = path
                .extension()
                .and_then(|ext| ext.to_str())
                .is_some_and(|ext| ext.eq_ignore_ascii_case("hdr") || ext.eq_ignore_ascii_case("exr"));
            check.that(hdr, "render.environment", &format!("{:?}", path.display().to_string()), || {
                "must be a Radiance .hdr or OpenEXR .exr map: an 8-bit image holds no light brighter than white".into()
            })?;
        }
        let intensity = self.environment_intensity;
        check.that(
            intensity.is_finite() && (0.0..=MAX_ENVIRONMENT_INTENSITY).contains(&intensity),
            "render.environment_intensity",
            &intensity.to_string(),
            || format!("must be a multiplier from 0 to {MAX_ENVIRONMENT_INTENSITY:e}"),
        )?;
        check.finite("render.preview_exposure_stops", self.preview_exposure_stops)?;
        self.camera.validate(check)?;
        self.material.validate(check)?;
        if let Some(floor) = &self.floor {
            check.finite("render.floor.height_m", floor.height_m)?;
            check.positive("render.floor.tile_size_m", floor.tile_size_m, "metres")?;
            check.unit_colour("render.floor.albedo", &floor.albedo)?;
        }
        Ok(())
    }
}

impl CameraConfig {
    fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        let camera = self;
        if let Some(position) = &camera.position_m {
            check.finite_array("render.camera.position_m", position)?;
        }
        if let Some(target) = &camera.look_at_m {
            check.finite_array("render.camera.look_at_m", target)?;
        }
        if let (Some(position), Some(target)) = (&camera.position_m, &camera.look_at_m) {
            check.that(position != target, "render.camera.look_at_m", &format!("{target:?}"), || {
                "must differ from render.camera.position_m".into()
            })?;
        }
        check.direction("render.camera.up", &camera.up)?;
        let fov = camera.fov_deg;
        check.that(fov > 0.0 && fov < 179.0, "render.camera.fov_deg", &fov.to_string(), || {
            "must be between 0 and 179 degrees".into()
        })?;
        if let Some(f_stop) = camera.f_stop {
            check.within("render.camera.f_stop", f_stop, 0.5..=256.0, "an f-number (left out: a pinhole)")?;
        }
        if let Some(focus) = camera.focus_distance_m {
            check.within("render.camera.focus_distance_m", focus, 0.001..=1e6, "metres")?;
        }
        check.within("render.camera.sensor_height_mm", camera.sensor_height_mm, 1.0..=1000.0, "millimetres")?;
        Ok(())
    }
}

impl LookConfig {
    fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        let look = self;
        check.that(
            look.glass_ior >= 1.0 && look.glass_ior <= 4.0,
            "render.material.glass_ior",
            &look.glass_ior.to_string(),
            || "must be between 1 and 4".into(),
        )?;
        check.that(
            look.glass_absorption_per_m.iter().all(|a| a.is_finite() && *a >= 0.0),
            "render.material.glass_absorption_per_m",
            &format!("{:?}", look.glass_absorption_per_m),
            || "every entry must be finite and 0 or more".into(),
        )?;
        check.unit_colour("render.material.albedo", &look.albedo)?;
        if let Some(albedo) = &look.fracture_albedo {
            check.unit_colour("render.material.fracture_albedo", albedo)?;
        }
        check.non_negative("render.material.specular", look.specular, "a multiplier")?;
        check.positive("render.material.shininess", look.shininess, "a Blinn-Phong exponent")?;
        Ok(())
    }
}
