//! The preview's resolution: the spacing at which the scene has about the particles the page
//! asks for. A solid (grid cubes, Voronoi cells) has its volume over the spacing cubed; a shell of
//! tetrahedra has a count that follows its surface and its layers, not its volume, so its spacing
//! is found by preprocessing it at trial spacings (the count goes as the spacing to the -2 while
//! the layers stay: two or three trials of a few thousand particles each). Found once per geometry
//! and count (docs/DECISIONS.md#preview).

use shatter_core::config::{GeometrySource, Sampler, default_tet_shell_layers};
use shatter_core::{NoProgress, PipelineConfig};
use shatter_geometry::mesh::TriangleMesh;

use super::preview_config::PreviewScene;

/// Most trial preprocessings of a shell.
const SHELL_TRIALS: usize = 4;
/// A trial whose count is within this fraction of the target ends the search.
const CLOSE_ENOUGH: f64 = 0.15;
/// Particles per (layer x surface area / spacing^2) of a tet shell, the first trial's guess
/// (`vase_small`: 43,160 tets in 3 layers of 0.29 m^2 at 6 mm); the trials correct it.
const SHELL_PARTICLES_PER_LAYER_AREA: f64 = 0.5;

/// The spacings found, by geometry and target.
#[derive(Debug, Default)]
pub struct Resolution {
    found: Option<(String, f64)>,
}

impl Resolution {
    /// The spacing, metres, at which `scene` has about `target` particles; never finer than the
    /// scene's own.
    pub fn spacing_m(&mut self, scene: &PreviewScene, target: u64) -> Result<f64, String> {
        let key = format!("{:?} {target}", scene.config.geometry);
        if let Some((found, spacing_m)) = &self.found
            && *found == key
        {
            return Ok(*spacing_m);
        }
        let measures = Measures::of(&scene.config)?;
        let spacing_m = match scene.config.geometry.sampler {
            Sampler::TetShell => shell_spacing(scene, &measures, target)?,
            Sampler::Grid | Sampler::Voronoi => solid_spacing(&scene.config, measures.volume_m3, target),
        };
        self.found = Some((key, spacing_m));
        Ok(spacing_m)
    }
}

/// A scene's body: its volume and surface area after the transform's scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measures {
    /// Enclosed volume, m^3.
    pub volume_m3: f64,
    /// Surface area, m^2.
    pub area_m2: f64,
}

impl Measures {
    /// The measures of `config`'s box, or of its mesh (read from its file).
    pub fn of(config: &PipelineConfig) -> Result<Measures, String> {
        let geometry = &config.geometry;
        match (&geometry.source, geometry.box_size_m) {
            (GeometrySource::Box, Some([x, y, z])) => {
                Ok(Measures { volume_m3: x * y * z, area_m2: 2.0 * (x * y + y * z + z * x) })
            }
            (GeometrySource::Mesh(path), _) => {
                let (mesh, _) = TriangleMesh::load_obj(path).map_err(|error| format!("{}: {error}", path.display()))?;
                let scale = geometry.transform.scale;
                Ok(Measures {
                    volume_m3: mesh.signed_volume().abs() * scale.powi(3),
                    area_m2: mesh.area() * scale * scale,
                })
            }
            (GeometrySource::Box, None) => Err("geometry.box_size_m is not set".to_string()),
        }
    }
}

/// A solid's spacing: the volume over `target`, cube rooted; never finer than the scene's own.
pub fn solid_spacing(config: &PipelineConfig, volume_m3: f64, target: u64) -> f64 {
    (volume_m3 / target.max(1) as f64).cbrt().max(config.geometry.spacing_m)
}

/// A tet shell's spacing: from a guess by its area and layers, each trial's count moves the
/// spacing by the square root of its ratio to the target.
fn shell_spacing(scene: &PreviewScene, measures: &Measures, target: u64) -> Result<f64, String> {
    let own_m = scene.config.geometry.spacing_m;
    let geometry = &scene.config.geometry;
    let layers =
        f64::from(geometry.tet_shell.layers.unwrap_or_else(|| default_tet_shell_layers(geometry.horizon_factor)));
    let mut spacing_m =
        (SHELL_PARTICLES_PER_LAYER_AREA * layers * measures.area_m2 / target.max(1) as f64).sqrt().max(own_m);
    for _ in 0..SHELL_TRIALS {
        let ratio = trial_count(scene, spacing_m, target)? as f64 / target.max(1) as f64;
        let next = (spacing_m * ratio.sqrt()).max(own_m);
        if (ratio - 1.0).abs() <= CLOSE_ENOUGH || next == spacing_m {
            break;
        }
        spacing_m = next;
    }
    Ok(spacing_m)
}

/// How many particles the scene has at `spacing_m`: preprocessed in memory, nothing written.
fn trial_count(scene: &PreviewScene, spacing_m: f64, target: u64) -> Result<usize, String> {
    let text = scene.preview_text(spacing_m, target, &std::env::temp_dir())?;
    let config = PipelineConfig::from_toml_str(&text, &scene.path).map_err(|error| error.to_string())?;
    let preprocessed = shatter_preprocess::preprocess(&config, &NoProgress).map_err(|error| error.to_string())?;
    Ok(preprocessed.particles.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::preview::preview_config::{Edits, TEST_SCENE};

    #[test]
    fn a_solids_spacing_follows_its_volume_and_a_shells_its_trials() {
        let scene_text = TEST_SCENE;
        let path = std::path::Path::new("scene/pipeline.toml");
        let scene = PreviewScene::new(path, scene_text, &Edits::new()).expect("scene");
        let measures = Measures::of(&scene.config).expect("measures");
        assert!((measures.area_m2 - 2.0 * (4e-4 + 8e-5 + 8e-5)).abs() < 1e-12);
        // 1.6e-6 m^3 over 200 particles: 2 mm
        let mut resolution = Resolution::default();
        assert!((resolution.spacing_m(&scene, 200).expect("spacing") - 0.002).abs() < 1e-9);
        // a shell of 2 layers over the box's surface: the trials land within reach of the target
        let shell = scene_text.replace("\"grid\"", "\"tet_shell\"") + "[geometry.tet_shell]\nlayers = 2\n";
        let shell = PreviewScene::new(path, &shell, &Edits::new()).expect("shell");
        let spacing_m = Resolution::default().spacing_m(&shell, 1500).expect("spacing");
        let count = trial_count(&shell, spacing_m, 1500).expect("count");
        assert!((1000..=2000).contains(&count), "{count} particles at {spacing_m} m for 1,500");
    }
}
