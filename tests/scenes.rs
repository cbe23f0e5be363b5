//! The shipped scenes: every file in assets/scenes is a valid configuration whose output goes to
//! `out/<scene name>`, and the default pipeline.toml is the small glass plate shot.

use std::path::{Component, Path, PathBuf};

use shatter_core::PipelineConfig;
use shatter_core::config::GeometrySource;

fn repository() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `path` with its `.` and `..` components folded away, without touching the file system.
fn lexically_normal(path: &Path) -> PathBuf {
    let mut normal = PathBuf::new();
    for component in path.components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir => {
                normal.pop();
            }
            other => normal.push(other),
        }
    }
    normal
}

/// The configuration with every path it holds made lexically normal, and the file it came from
/// forgotten, so that two files that say the same thing from different folders compare equal.
fn normalized(mut config: PipelineConfig) -> PipelineConfig {
    config.path = PathBuf::new();
    config.scene.output_dir = lexically_normal(&config.scene.output_dir);
    if let GeometrySource::Mesh(path) = &mut config.geometry.source {
        *path = lexically_normal(path);
    }
    if let Some(path) = &mut config.render.environment {
        *path = lexically_normal(path);
    }
    if let Some(path) = config.render.floor.as_mut().and_then(|floor| floor.texture.as_mut()) {
        *path = lexically_normal(path);
    }
    config
}

fn scene_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repository().join("assets/scenes"))
        .expect("assets/scenes")
        .map(|entry| entry.expect("entry").path())
        .filter(|path| path.extension().is_some_and(|extension| extension == "toml"))
        .collect();
    files.sort();
    files
}

#[test]
fn every_scene_loads_and_writes_under_out_by_its_own_name() {
    let files = scene_files();
    let names: Vec<String> =
        files.iter().map(|path| path.file_stem().expect("stem").to_string_lossy().into_owned()).collect();
    for shot in ["glass_plate", "vase", "dragon"] {
        for preset in ["small", "paper"] {
            let name = format!("{shot}_{preset}");
            assert!(names.contains(&name), "assets/scenes/{name}.toml is missing");
        }
    }
    for (path, name) in files.iter().zip(&names) {
        let config = normalized(PipelineConfig::load(path).unwrap_or_else(|error| panic!("{error}")));
        assert_eq!(&config.scene.name, name, "{}", path.display());
        assert_eq!(config.scene.output_dir, repository().join("out").join(name), "{}", path.display());
        for asset in [
            config.render.environment.clone(),
            config.render.floor.as_ref().and_then(|floor| floor.texture.clone()),
            match &config.geometry.source {
                GeometrySource::Mesh(mesh) => Some(mesh.clone()),
                GeometrySource::Box => None,
            },
        ]
        .into_iter()
        .flatten()
        {
            assert!(asset.is_file(), "{}: {} does not exist", path.display(), asset.display());
        }
    }
}

#[test]
fn the_default_pipeline_is_the_small_glass_plate_shot() {
    let default = normalized(PipelineConfig::load(&repository().join("pipeline.toml")).expect("pipeline.toml"));
    let scene = normalized(
        PipelineConfig::load(&repository().join("assets/scenes/glass_plate_small.toml")).expect("glass_plate_small"),
    );
    assert_eq!(format!("{default:#?}"), format!("{scene:#?}"));
}
