//! The grid sampler end to end: bond counts, symmetry and volumes on boxes; real meshes filled to
//! their enclosed volume, the Welsh dragon's defects included.

use shatter_core::NoProgress;
use shatter_core::config::PipelineConfig;
use shatter_core::particles::{Elements, ParticleSet};
use shatter_geometry::mesh::TriangleMesh;
use shatter_preprocess::repair::repair;
use shatter_preprocess::{PreprocessError, preprocess};
use support::assets;

use crate::support;

fn config(geometry: &str) -> PipelineConfig {
    let text = format!(
        r#"
[scene]
name = "test"
output_dir = "out"
seed = 3
[geometry]
{geometry}
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
"#
    );
    PipelineConfig::from_toml_str(&text, &assets().join("../pipeline.toml")).expect("test config is valid")
}

fn box_config(size: [f64; 3], spacing: f64, horizon_factor: f64) -> PipelineConfig {
    config(&format!(
        "source = \"box\"\nbox_size_m = {size:?}\nsampler = \"grid\"\nspacing_m = {spacing}\nhorizon_factor = {horizon_factor}\n\
         [geometry.transform]\nrotate_deg = [20.0, 35.0, -10.0]\ntranslate_m = [5.0, -2.0, 1.0]"
    ))
}

fn particles(config: &PipelineConfig) -> ParticleSet {
    preprocess(config, &NoProgress).expect("preprocess").particles
}

/// The particle nearest the centroid: an interior one for a convex fill.
fn most_central(set: &ParticleSet) -> usize {
    let n = set.len() as f64;
    let centroid = set
        .rest_position_m
        .iter()
        .fold([0.0f64; 3], |acc, p| [acc[0] + p[0] as f64 / n, acc[1] + p[1] as f64 / n, acc[2] + p[2] as f64 / n]);
    let distance = |p: &[f32; 3]| (0..3).map(|k| (p[k] as f64 - centroid[k]).powi(2)).sum::<f64>();
    (0..set.len())
        .min_by(|a, b| distance(&set.rest_position_m[*a]).total_cmp(&distance(&set.rest_position_m[*b])))
        .expect("non-empty")
}

#[test]
fn interior_particles_have_32_bonds_at_n2_and_122_at_n3() {
    for (horizon, expected) in [(2.0, 32), (3.0, 122)] {
        let set = particles(&box_config([0.011, 0.011, 0.011], 0.001, horizon));
        set.validate().expect("valid particle set");
        let centre = most_central(&set);
        assert_eq!(set.bonds.row(centre).len(), expected, "N = {horizon}");
        let summary = set.summary();
        assert_eq!(summary.bonds_per_particle.max, expected as u64);
        // a corner particle sees one octant of the ball
        assert!(summary.bonds_per_particle.min < expected as u64 / 2);
    }
}

#[test]
fn bonds_are_symmetric_and_volumes_add_up() {
    let lambda = 0.002;
    let set = particles(&box_config([0.03, 0.02, 0.01], lambda, 3.0));
    assert_eq!(set.len(), 15 * 10 * 5);
    for i in 0..set.len() {
        for k in set.bonds.row(i) {
            let j = set.bonds.neighbor[k] as usize;
            let twin = set.bonds.find(j, i as u32).expect("every bond has its twin");
            assert_eq!(set.bonds.threshold[twin], set.bonds.threshold[k]);
            assert_eq!(set.bonds.rest_length_m[twin], set.bonds.rest_length_m[k]);
        }
    }
    let total: f64 = set.volume_m3.iter().map(|v| *v as f64).sum();
    assert!((total - set.len() as f64 * lambda.powi(3)).abs() < 1e-6 * total);
    let summary = set.summary();
    assert!((summary.total_mass_kg - total * 2200.0).abs() < 1e-5 * summary.total_mass_kg);
    // nothing beyond the horizon is bonded; rest lengths come from f32 positions 5 m from the
    // origin, whose rounding (ulp 4.8e-7 m) they carry
    for i in (0..set.len()).step_by(17) {
        for k in set.bonds.row(i) {
            let length = set.bonds.rest_length_m[k] as f64;
            assert!(length <= 3.0 * lambda + 2e-6, "bond of {length} m beyond delta");
        }
    }
    // the rotation is carried by the cubes
    let Elements::Cubes { orientation, half_size_m } = &set.elements else { panic!("grid makes cubes") };
    assert!((orientation[3] - 1.0).abs() > 1e-3, "rotated scene, rotated cubes");
    assert!(half_size_m.iter().all(|h| (*h as f64 - lambda / 2.0).abs() < 1e-9));
}

#[test]
fn thresholds_are_jittered_around_silling_and_askari() {
    let set = particles(&box_config([0.02, 0.02, 0.02], 0.001, 3.0));
    let delta: f64 = 0.003;
    let s0 = (5.0 * 8.0 / (9.0 * 14.9e9 * delta)).sqrt();
    let thresholds: Vec<f64> = set.bonds.threshold.iter().map(|t| *t as f64).collect();
    let mean = thresholds.iter().sum::<f64>() / thresholds.len() as f64;
    let sd = (thresholds.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / thresholds.len() as f64).sqrt();
    assert!((mean / s0 - 1.0).abs() < 1e-3, "mean {mean} vs s0 {s0}");
    assert!((sd / s0 - 0.02).abs() < 1e-3, "sd {sd}");
    let again = particles(&box_config([0.02, 0.02, 0.02], 0.001, 3.0));
    assert_eq!(again, set, "same config, same particles");
}

/// Fills a mesh at `spacing_m` and compares the filled volume with the enclosed volume of the
/// bodies kept after repair. Returns (particles, relative error).
fn fill_and_compare(file: &str, scale: f64, spacing_fraction_of_diagonal: f64) -> (usize, f64) {
    let path = assets().join(file);
    let (mesh, stats) = TriangleMesh::load_obj(&path).expect("load");
    let (repaired, _) = repair(&mesh, stats, 1e-3);
    let (lo, hi) = mesh.bounds();
    let spacing = (hi - lo).length() * scale * spacing_fraction_of_diagonal;
    let expected = repaired.signed_volume() * scale.powi(3);
    let config = config(&format!(
        "source = \"meshes/{file}\"\nsampler = \"grid\"\nspacing_m = {spacing}\nhorizon_factor = 2.0\n\
         [geometry.transform]\nscale = {scale}\nrecenter = true"
    ));
    let set = particles(&config);
    set.validate().expect("valid particle set");
    let filled = set.summary().total_volume_m3;
    eprintln!(
        "{file}: {} particles at {spacing:.3e} m, filled {filled:.5e} m^3, enclosed {expected:.5e} m^3",
        set.len()
    );
    (set.len(), (filled - expected) / expected)
}

#[test]
fn the_welsh_dragon_fills_to_its_main_body_volume() {
    let path = assets().join("welsh_dragon.obj");
    let (mesh, stats) = TriangleMesh::load_obj(&path).expect("load");
    let (repaired, report) = repair(&mesh, stats, 1e-3);
    assert_eq!(report.bodies.len(), 10, "the dragon has a main body and nine specks");
    let main = &report.bodies[0];
    assert!(main.kept && main.open_edges == 0 && main.nonmanifold_edges == 0, "{main:?}");
    assert_eq!(report.bodies.iter().filter(|b| b.kept).count(), 1);
    assert!((repaired.signed_volume() - main.volume_m3).abs() < 1e-9 * main.volume_m3);
    let (count, error) = fill_and_compare("welsh_dragon.obj", 0.001, 0.01);
    assert!(count > 10_000, "{count} particles");
    assert!(error.abs() < 0.02, "filled volume off by {:.2}%", error * 100.0);
}

#[test]
fn the_vase_and_bob_fill_to_their_volume() {
    for (file, fraction, tolerance) in [("bob_tri.obj", 0.01, 0.02), ("smooth_vase.obj", 0.004, 0.03)] {
        let (count, error) = fill_and_compare(file, 1.0, fraction);
        assert!(count > 1000, "{file}: {count} particles");
        assert!(error.abs() < tolerance, "{file}: filled volume off by {:.2}%", error * 100.0);
    }
}

#[test]
fn a_garbage_mesh_is_a_clear_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let garbage = dir.path().join("garbage.obj");
    std::fs::write(&garbage, [0u8, 159, 146, 150, 7, 255, 0, 1]).expect("write");
    let config = config(&format!(
        "source = {:?}\nsampler = \"grid\"\nspacing_m = 0.01\nhorizon_factor = 2.0",
        garbage.display().to_string()
    ));
    let error = preprocess(&config, &NoProgress).expect_err("garbage");
    assert!(matches!(error, PreprocessError::Mesh(_)), "{error}");
    assert!(error.to_string().contains("garbage.obj"), "{error}");
}
