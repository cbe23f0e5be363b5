//! The shipped scenes: every file in assets/scenes is a valid configuration whose output goes to
//! `out/<scene name>`, and the default pipeline.toml is the small glass plate shot.

use std::path::PathBuf;

use shatter_core::PipelineConfig;
use shatter_core::config::GeometrySource;

fn repository() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The configuration with the file it came from forgotten, so that two files that say the same
/// thing from different folders compare equal (their relative paths are resolved, `..` folded).
fn without_its_path(mut config: PipelineConfig) -> PipelineConfig {
    config.path = PathBuf::new();
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
        let config = without_its_path(PipelineConfig::load(path).unwrap_or_else(|error| panic!("{error}")));
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
    let default = without_its_path(PipelineConfig::load(&repository().join("pipeline.toml")).expect("pipeline.toml"));
    let scene = without_its_path(
        PipelineConfig::load(&repository().join("assets/scenes/glass_plate_small.toml")).expect("glass_plate_small"),
    );
    assert_eq!(format!("{default:#?}"), format!("{scene:#?}"));
}
