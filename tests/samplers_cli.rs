//! `shatter preprocess` with the `tet_shell` and `voronoi` samplers, as users meet it: small
//! scenes of the bundled meshes, summarised by `shatter inspect --json`, and one bad value per new
//! config key (exit code 2, a message naming the key, nothing written).

use std::path::Path;
use std::process::{Command, Output};

fn shatter(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shatter")).args(args).current_dir(dir).output().expect("shatter runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

fn mesh_path(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/meshes").join(name).display().to_string()
}

/// A scene of `mesh` with `sampler`, `spacing_m` and extra lines after `[geometry]`'s keys.
fn scene_text(mesh: &str, sampler: &str, spacing: f64, extra: &str) -> String {
    format!(
        r#"
[scene]
name = "samplers"
output_dir = "out"
seed = 5
[geometry]
source = {source:?}
sampler = "{sampler}"
spacing_m = {spacing}
horizon_factor = 2.0
{extra}
[material]
density_kg_m3 = 2000.0
bulk_modulus_pa = 2.94e9
"#,
        source = mesh_path(mesh)
    )
}

/// Runs `shatter preprocess` on `text` in a fresh folder; returns the folder and the output.
fn preprocess(text: &str) -> (tempfile::TempDir, Output) {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), text).expect("write config");
    let output = shatter(&["preprocess"], dir.path());
    (dir, output)
}

/// `shatter inspect --json` of the scene's particle file.
fn inspect(dir: &Path) -> serde_json::Value {
    let file = dir.join("out/particles.shp");
    let output = shatter(&["inspect", file.to_str().expect("utf-8 path"), "--json"], dir);
    assert!(output.status.success(), "{}", stderr(&output));
    serde_json::from_slice(&output.stdout).expect("JSON")
}

fn number(summary: &serde_json::Value, key: &str) -> f64 {
    summary[key].as_f64().unwrap_or_else(|| panic!("{key} missing from {summary}"))
}

#[test]
fn a_tet_shell_scene_preprocesses_to_tets() {
    // spot: 0.718 m^3, 5.71 m^2; a shell of three layers 3 cm apart.
    let text = scene_text("spot_triangulated.obj", "tet_shell", 0.03, "[geometry.tet_shell]\nlayers = 3");
    let (dir, output) = preprocess(&text);
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("particles (tet)"), "{stdout}");
    let summary = inspect(dir.path());
    assert_eq!(summary["element_type"], "tet");
    assert_eq!(summary["meta"]["sampler"], "tet_shell");
    let particles = number(&summary, "particles");
    assert!(particles > 10_000.0 && particles < 200_000.0, "{particles} tets");
    assert_eq!(number(&summary, "lambda_m"), 0.03);
    assert!((number(&summary, "delta_m") - 0.06).abs() < 1e-12);
    assert!(summary["bonds_per_particle"]["min"].as_u64().expect("number") > 0);
    let mean = summary["bonds_per_particle"]["mean"].as_f64().expect("number");
    assert!(mean > 30.0 && mean < 300.0, "{mean} bonds per particle");
    // Each tet has at most four face neighbours, most have several.
    let adjacency = number(&summary, "adjacency_edges");
    assert!(adjacency > particles && adjacency <= 2.0 * particles, "{adjacency} adjacent pairs");
    let volume = number(&summary, "total_volume_m3");
    // About its area (5.71 m^2) times the depth of the innermost layer (6 cm), less for the curvature.
    assert!(volume > 0.7 * 5.71 * 0.06 && volume < 5.71 * 0.06, "{volume} m^3: a 6 cm shell inside spot");
    assert!((number(&summary, "total_mass_kg") / (2000.0 * volume) - 1.0).abs() < 1e-5);
}

#[test]
fn a_voronoi_scene_preprocesses_to_trimtopes() {
    // bob: 0.689 m^3, 2,000 cells.
    let text = scene_text("bob_tri.obj", "voronoi", 0.05, "[geometry.voronoi]\nparticles = 2000");
    let (dir, output) = preprocess(&text);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stderr(&output).contains("geometry.spacing_m is not used"), "{}", stderr(&output));
    let summary = inspect(dir.path());
    assert_eq!(summary["element_type"], "trimtope");
    assert_eq!(summary["meta"]["sampler"], "voronoi");
    let particles = number(&summary, "particles");
    assert!((particles / 2000.0 - 1.0).abs() < 0.05, "{particles} cells");
    let volume = number(&summary, "total_volume_m3");
    assert!((volume / 0.6889180 - 1.0).abs() < 5e-3, "{volume} m^3");
    let lambda = number(&summary, "lambda_m");
    assert!(lambda > 0.05 && lambda < 0.08, "lambda {lambda}");
    assert!((number(&summary, "delta_m") / lambda - 2.0).abs() < 1e-12);
    let adjacency = number(&summary, "adjacency_edges");
    assert!(adjacency > 4.0 * particles && adjacency < 10.0 * particles, "{adjacency} adjacent pairs");
}

#[test]
fn bad_sampler_keys_name_the_key_and_exit_with_2() {
    let shell =
        |lines: &str| scene_text("spot_triangulated.obj", "tet_shell", 0.05, &format!("[geometry.tet_shell]\n{lines}"));
    let voronoi = |lines: &str| scene_text("bob_tri.obj", "voronoi", 0.05, &format!("[geometry.voronoi]\n{lines}"));
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        ("one layer", shell("layers = 1"), vec!["geometry.tet_shell.layers = 1", "between 2 and 1000"]),
        ("fractional layers", shell("layers = 2.5"), vec!["geometry.tet_shell.layers", "invalid type"]),
        (
            "negative layer spacing",
            shell("layer_spacing_m = -0.001"),
            vec!["geometry.tet_shell.layer_spacing_m = -0.001", "greater than 0"],
        ),
        (
            "filled core not a bool",
            shell("filled_core = \"yes\""),
            vec!["geometry.tet_shell.filled_core", "expected a boolean"],
        ),
        (
            "unknown shell key",
            shell("layer_count = 4"),
            vec!["geometry.tet_shell.layer_count", "unknown field `layer_count`"],
        ),
        ("zero particles", voronoi("particles = 0"), vec!["geometry.voronoi.particles = 0", "between 1 and"]),
        ("negative particles", voronoi("particles = -5"), vec!["geometry.voronoi.particles", "invalid value"]),
        ("unknown voronoi key", voronoi("sites = 100"), vec!["geometry.voronoi.sites", "unknown field `sites`"]),
        (
            "spacing too fine for tet_shell",
            scene_text("spot_triangulated.obj", "tet_shell", 1e-5, ""),
            vec!["geometry.spacing_m and geometry.horizon_factor: sampling the mesh into about", "of memory"],
        ),
        (
            "spacing too fine for voronoi",
            scene_text("bob_tri.obj", "voronoi", 1e-5, ""),
            vec!["geometry.spacing_m and geometry.horizon_factor: sampling the mesh into about", "of memory"],
        ),
    ];
    for (what, text, expected) in cases {
        let (dir, output) = preprocess(&text);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{what}: exit code; stderr:\n{message}");
        for fragment in expected {
            assert!(message.contains(fragment), "{what}: expected {fragment:?} in:\n{message}");
        }
        assert!(!message.contains("panicked"), "{what}: {message}");
        assert!(!dir.path().join("out/particles.shp").exists(), "{what}: nothing written");
    }
}
