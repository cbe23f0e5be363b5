//! The preview's scene: the scene's own config, with the artist's edits, at a coarser spacing,
//! run into a scratch folder (never the scene's output folder).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use shatter_core::PipelineConfig;
use shatter_core::config::{GeometrySource, Sampler};

/// Particles a preview aims at unless the page asks for another count.
pub const DEFAULT_TARGET_PARTICLES: u64 = 12_000;

/// The artist's edits to a scene's config: dotted keys (`sim.projectile[0].velocity_m_s`) and
/// their TOML values.
pub type Edits = BTreeMap<String, toml::Value>;

/// The scene a preview runs: the edited text (what "Save" would write, as a table) and its
/// checked config.
#[derive(Debug, Clone)]
pub struct PreviewScene {
    /// The scene's config file.
    pub path: PathBuf,
    /// The scene's config with the edits, as checked.
    pub config: PipelineConfig,
    /// The edited config as a TOML table.
    table: toml::Table,
}

impl PreviewScene {
    /// The scene at `path` (its text `text`) with `edits`, checked as the CLI checks a config:
    /// a refused edit gives the CLI's message.
    pub fn new(path: &Path, text: &str, edits: &Edits) -> Result<PreviewScene, String> {
        let path = std::path::absolute(path).map_err(|error| format!("{}: {error}", path.display()))?;
        let mut table: toml::Table = toml::from_str(text).map_err(|error| format!("{}: {error}", path.display()))?;
        for (key, value) in edits {
            set_key(&mut table, key, value.clone())
                .map_err(|message| format!("{}: {key}: {message}", path.display()))?;
        }
        let edited = toml::to_string(&table).map_err(|error| error.to_string())?;
        let config = PipelineConfig::from_toml_str(&edited, &path).map_err(|error| error.to_string())?;
        Ok(PreviewScene { path, config, table })
    }

    /// The preview's config text: the edited scene at `spacing_m` (a Voronoi scene: `target`
    /// cells), writing into `output_dir`, with every path absolute (the text is written into the
    /// scratch folder, not beside the scene). The frames keep their physical length. With an
    /// explicit `sim.dt_s` the step grows with the spacing (the stable step does) and a frame
    /// takes fewer steps of it; an unset step is the material's own, the largest power of two
    /// under half the coarser stable step, and the frames keep their steps: they span the same
    /// time until the coarser step reaches the next power of two (twice the time per frame at
    /// most at the same coarseness; a timeline's frames are times already).
    /// Projectiles and indenters push each particle they reach: their stiffness grows with the
    /// particles' volume, so that they push the body as hard as at the scene's spacing.
    pub fn preview_text(&self, spacing_m: f64, target: u64, output_dir: &Path) -> Result<String, String> {
        let config = &self.config;
        let mut table = self.table.clone();
        let coarser = spacing_m / config.geometry.spacing_m;
        let mut set = |key: &str, value: toml::Value| set_key(&mut table, key, value);
        set("scene.output_dir", path_value(output_dir))?;
        set("geometry.spacing_m", toml::Value::Float(spacing_m))?;
        if config.geometry.sampler == Sampler::Voronoi {
            set("geometry.voronoi.particles", toml::Value::Integer(target.min(i64::MAX as u64) as i64))?;
        }
        if let GeometrySource::Mesh(mesh) = &config.geometry.source {
            set("geometry.source", path_value(mesh))?;
        }
        let steps_given = self.table.get("sim").and_then(|sim| sim.get("steps_per_frame")).is_some();
        if let Some(dt_s) = config.sim.dt_s
            && steps_given
        {
            let steps = (config.sim.steps_per_frame as f64 / coarser).round().max(1.0);
            set("sim.dt_s", toml::Value::Float(dt_s * config.sim.steps_per_frame as f64 / steps))?;
            set("sim.steps_per_frame", toml::Value::Integer(steps as i64))?;
        }
        // the paper's projectile force (eq. 7) and an indenter's act on each particle they reach:
        // a force per particle volume keeps its push on the body as the particles coarsen
        let volume_ratio = match (config.geometry.sampler, config.geometry.voronoi.particles) {
            (Sampler::Voronoi, Some(cells)) => cells as f64 / target.max(1) as f64,
            _ => coarser.powi(3),
        };
        for (index, projectile) in config.sim.projectile.iter().enumerate() {
            set(
                &format!("sim.projectile[{index}].stiffness_pa"),
                toml::Value::Float(projectile.stiffness_pa * volume_ratio),
            )?;
        }
        for (index, indenter) in config.sim.indenter.iter().enumerate() {
            if indenter.lammps_stiffness_n_m5.is_none() {
                let stiffness = toml::Value::Float(indenter.stiffness_n_m2 * volume_ratio);
                set(&format!("sim.indenter[{index}].stiffness_n_m2"), stiffness)?;
            }
        }
        for (index, seam) in config.sim.seam.iter().enumerate() {
            if let Some(mesh) = &seam.mesh {
                set(&format!("sim.seam[{index}].mesh"), path_value(mesh))?;
            }
        }
        if let Some(environment) = &config.render.environment {
            set("render.environment", path_value(environment))?;
        }
        if let Some(texture) = config.render.floor.as_ref().and_then(|floor| floor.texture.as_ref()) {
            set("render.floor.texture", path_value(texture))?;
        }
        toml::to_string(&table).map_err(|error| error.to_string())
    }
}

/// The keys the page offers for editing, where the scene has them: the material's strength and
/// stiffness, each projectile's speed and start, the drop (the lead-in's lift, turn and speed),
/// each weakened path's strength, start, direction and length, the seed.
const EDITABLE: &[&str] = &[
    "scene.seed",
    "material.critical_stretch",
    "material.fracture_energy_j_m2",
    "material.bulk_modulus_pa",
    "sim.projectile[].velocity_m_s",
    "sim.projectile[].center_m",
    "lead_in.translate_m",
    "lead_in.rotate_axis",
    "lead_in.rotate_deg",
    "lead_in.velocity_m_s",
    "sim.weakened_path[].threshold_factor",
    "sim.weakened_path[].start_m",
    "sim.weakened_path[].direction",
    "sim.weakened_path[].steps",
];

impl PreviewScene {
    /// The editable keys the edited scene sets, with their values.
    pub fn editable_values(&self) -> Vec<(String, toml::Value)> {
        let mut values = Vec::new();
        for pattern in EDITABLE {
            let keys: Vec<String> = match pattern.split_once("[]") {
                Some((array, field)) => {
                    let count = get_key(&self.table, array).and_then(toml::Value::as_array).map_or(0, Vec::len);
                    (0..count).map(|index| format!("{array}[{index}]{field}")).collect()
                }
                None => vec![pattern.to_string()],
            };
            values.extend(
                keys.into_iter().filter_map(|key| get_key(&self.table, &key).cloned().map(|value| (key, value))),
            );
        }
        values
    }
}

impl PreviewScene {
    /// `value` for `key`, its whole numbers made floats where the scene's value there is a float
    /// (the page sends `40` for `40.0`: the saved file keeps the scene's own kinds).
    pub fn typed_like_scene(&self, key: &str, value: toml::Value) -> toml::Value {
        match get_key(&self.table, key) {
            Some(old) => floats_like(old, value),
            None => value,
        }
    }
}

/// `new` with its integers made floats where `old` has floats (arrays entry by entry).
fn floats_like(old: &toml::Value, new: toml::Value) -> toml::Value {
    match (old, new) {
        (toml::Value::Float(_), toml::Value::Integer(whole)) => toml::Value::Float(whole as f64),
        (toml::Value::Array(olds), toml::Value::Array(news)) => toml::Value::Array(
            news.into_iter()
                .enumerate()
                .map(|(k, new)| match olds.get(k).or(olds.first()) {
                    Some(old) => floats_like(old, new),
                    None => new,
                })
                .collect(),
        ),
        (_, new) => new,
    }
}

/// The value of the dotted `key` (as [`set_key`] names it) in `table`, if set.
fn get_key<'a>(table: &'a toml::Table, key: &str) -> Option<&'a toml::Value> {
    let mut parts = key.split('.');
    let first = parts.next()?;
    let mut here = entry(table, first)?;
    for part in parts {
        here = entry(here.as_table()?, part)?;
    }
    Some(here)
}

/// `part` (a name, or `name[i]`) of `table`.
fn entry<'a>(table: &'a toml::Table, part: &str) -> Option<&'a toml::Value> {
    match part.split_once('[') {
        Some((name, index)) => table.get(name)?.as_array()?.get(index.trim_end_matches(']').parse::<usize>().ok()?),
        None => table.get(part),
    }
}

/// A path as a TOML string.
fn path_value(path: &Path) -> toml::Value {
    toml::Value::String(path.to_string_lossy().into_owned())
}

/// Sets the dotted `key` (each part a name, or `name[i]` for entry i of an array of tables) in
/// `table` to `value`, making the tables on the way; an array entry must exist.
pub fn set_key(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<(), String> {
    let parts: Vec<&str> = key.split('.').collect();
    let (last, path) = parts.split_last().ok_or("an empty key")?;
    let mut here = table;
    for part in path {
        here = match part.split_once('[') {
            Some((name, index)) => {
                let index: usize = index.trim_end_matches(']').parse().map_err(|_| format!("{part}: not an index"))?;
                let array = here.get_mut(name).and_then(toml::Value::as_array_mut).ok_or(format!("no [[{name}]]"))?;
                let length = array.len();
                array
                    .get_mut(index)
                    .and_then(toml::Value::as_table_mut)
                    .ok_or(format!("{name} has {length} entries, not {}", index + 1))?
            }
            None => here
                .entry(part.to_string())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                .as_table_mut()
                .ok_or(format!("{part} is not a table"))?,
        };
    }
    here.insert(last.to_string(), value);
    Ok(())
}

/// A small struck plate, for the preview's unit tests.
#[cfg(test)]
pub(super) const TEST_SCENE: &str = "[scene]\nname = \"t\"\noutput_dir = \"out\"\nseed = 1\n\n[geometry]\nsource = \"box\"\n\
    box_size_m = [0.02, 0.02, 0.004]\nsampler = \"grid\"\nspacing_m = 0.001\nhorizon_factor = 3.0\n\n[material]\n\
    density_kg_m3 = 2200.0\nbulk_modulus_pa = 14.9e9\ncritical_stretch = 0.001\n\n[sim]\nframes = 4\n\
    steps_per_frame = 40\n\n[[sim.projectile]]\ncenter_m = [0.0, 0.0, 0.006]\n\
    velocity_m_s = [0.0, 0.0, -100.0]\nradius_m = 0.002\nstiffness_pa = 4e5\n";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edits_reach_nested_keys_and_array_entries() {
        let mut edits = Edits::new();
        edits.insert("sim.projectile[0].velocity_m_s".into(), toml::Value::try_from([0.0, 0.0, -40.0]).expect("value"));
        edits.insert("material.critical_stretch".into(), toml::Value::Float(0.002));
        let scene = PreviewScene::new(Path::new("scene/pipeline.toml"), TEST_SCENE, &edits).expect("scene");
        assert_eq!(scene.config.sim.projectile[0].velocity_m_s, [0.0, 0.0, -40.0]);
        let typed = scene
            .typed_like_scene("sim.projectile[0].velocity_m_s", toml::Value::try_from([0, 0, -40]).expect("value"));
        assert_eq!(typed.to_string(), "[0.0, 0.0, -40.0]");
        assert_eq!(scene.typed_like_scene("scene.seed", toml::Value::Integer(4)), toml::Value::Integer(4));
        assert_eq!(scene.config.material.critical_stretch, Some(0.002));
        let mut table = toml::Table::new();
        assert!(set_key(&mut table, "sim.projectile[0].radius_m", toml::Value::Float(1.0)).is_err());
        let values: Vec<String> =
            scene.editable_values().into_iter().map(|(key, value)| format!("{key} = {value}")).collect();
        assert_eq!(
            values,
            [
                "scene.seed = 1",
                "material.critical_stretch = 0.002",
                "material.bulk_modulus_pa = 14900000000.0",
                "sim.projectile[0].velocity_m_s = [0.0, 0.0, -40.0]",
                "sim.projectile[0].center_m = [0.0, 0.0, 0.006]"
            ]
        );
    }

    #[test]
    fn a_weakened_paths_strength_route_and_length_are_offered() {
        let text = format!(
            "{TEST_SCENE}\n[[sim.weakened_path]]\nstart_m = [0.0, 0.0, 0.0]\ndirection = [1.0, 0.0, 0.0]\n\
             plane_normal = [0.0, 0.0, 1.0]\nsteps = 5\nstep_length_m = 0.002\nradius_m = 0.0015\n\
             threshold_factor = 0.6\n"
        );
        let mut edits = Edits::new();
        edits.insert("sim.weakened_path[0].direction".into(), toml::Value::try_from([0.0, 1.0, 0.0]).expect("value"));
        let scene = PreviewScene::new(Path::new("pipeline.toml"), &text, &edits).expect("scene");
        let keys: Vec<String> = scene.editable_values().into_iter().map(|(key, _)| key).collect();
        for key in ["threshold_factor", "start_m", "direction", "steps"] {
            assert!(keys.contains(&format!("sim.weakened_path[0].{key}")), "{key}: {keys:?}");
        }
        assert_eq!(scene.config.sim.weakened_path[0].direction, [0.0, 1.0, 0.0]);
    }

    #[test]
    fn a_refused_edit_gives_the_cli_message() {
        let mut edits = Edits::new();
        edits.insert("material.critical_stretch".into(), toml::Value::Float(-1.0));
        let error = PreviewScene::new(Path::new("pipeline.toml"), TEST_SCENE, &edits).expect_err("refused");
        let cli = PipelineConfig::from_toml_str(&TEST_SCENE.replace("0.001\n\n[sim]", "-1.0\n\n[sim]"), Path::new("x"))
            .expect_err("refused")
            .to_string();
        assert!(error.contains("material.critical_stretch"), "{error}");
        assert_eq!(error.split_once(": ").map(|(_, m)| m), cli.split_once(": ").map(|(_, m)| m));
    }

    #[test]
    fn the_preview_is_coarser_and_writes_elsewhere() {
        let scene = PreviewScene::new(Path::new("scene/pipeline.toml"), TEST_SCENE, &Edits::new()).expect("scene");
        let spacing = 0.002;
        let text = scene.preview_text(spacing, 200, Path::new("/tmp/preview/run")).expect("text");
        let config = PipelineConfig::from_toml_str(&text, Path::new("/elsewhere/pipeline.toml")).expect("valid");
        assert_eq!(config.output_dir(), Path::new("/tmp/preview/run"));
        assert_eq!(config.geometry.spacing_m, spacing);
        // the material's step: the frames keep their steps
        assert_eq!(config.sim.steps_per_frame, 40);
        // the projectile pushes each of the particles, 8 times as large, 8 times as hard
        assert_eq!(config.sim.projectile[0].stiffness_pa, 3.2e6);
        let explicit = TEST_SCENE.replace("frames = 4\n", "frames = 4\ndt_s = 1e-7\n");
        let scene = PreviewScene::new(Path::new("scene/pipeline.toml"), &explicit, &Edits::new()).expect("scene");
        let text = scene.preview_text(spacing, 200, Path::new("/tmp/preview/run")).expect("text");
        let config = PipelineConfig::from_toml_str(&text, Path::new("/elsewhere/pipeline.toml")).expect("valid");
        assert_eq!(config.sim.steps_per_frame, 20);
        assert_eq!(config.sim.dt_s, Some(2e-7));
    }
}
