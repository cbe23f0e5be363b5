//! Benchmark: `shatter post` work for one frame of 600,000 elements (target: under 1 s on two
//! cores): components over intact adjacency, stable ids, Kabsch per fragment, and writing the
//! frame's fragments file and point cache; and with deformed elements (`post.element_shapes =
//! "deformed"`), the elements' affine maps (deformation gradients over every intact bond), for
//! the cubes and for vase_small's tetrahedral shell (the embedded mesh).
//!
//! `cargo bench -p shatter-post --bench post`

use std::path::Path;
use std::time::Instant;

use glam::{DQuat, DVec3};
use shatter_core::NoProgress;
use shatter_core::config::PipelineConfig;
use shatter_core::fragments::{FragmentFrame, FragmentMeta};
use shatter_core::ply::{Column, PointCache};
use shatter_core::random::SplitMix64;
use shatter_post::FragmentTracker;
use shatter_post::deformation::ElementDeformation;

fn main() {
    let text = r#"
[scene]
name = "bench"
output_dir = "out"
seed = 1
[geometry]
source = "box"
box_size_m = [0.1, 0.1, 0.06]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 2.0
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
"#;
    let config = PipelineConfig::from_toml_str(text, Path::new("/nonexistent/p.toml")).expect("config");
    let particles = shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles;
    let n = particles.len();
    // Cut into blocks of 5 x 5 x 60 cells: 400 fragments, each moved rigidly.
    let block = |i: usize| {
        let p = particles.rest_position_m[i];
        let cell = |c: f32| ((c + 0.05) / 0.005).floor() as i32;
        (cell(p[0]) * 100 + cell(p[1])) as usize
    };
    let mass = particles.mass_kg.iter().map(|m| f64::from(*m)).collect();
    let started = Instant::now();
    let mut tracker = FragmentTracker::new(&particles, mass);
    let setup_s = started.elapsed().as_secs_f64();
    let rest: Vec<[f32; 3]> = particles.rest_position_m.clone();
    let at_rest = [0, 1, 2].map(|a| rest.iter().map(|p| p[a]).collect::<Vec<f32>>());
    tracker.track([&at_rest[0], &at_rest[1], &at_rest[2]], 0.0);
    for &[a, b] in &particles.adjacency {
        if block(a as usize) != block(b as usize) {
            tracker.break_bond(particles.bonds.find(a as usize, b).expect("bonded") as u64);
        }
    }
    let mut rng = SplitMix64::new(5);
    let motions: Vec<(DQuat, DVec3)> = (0..10_000)
        .map(|_| {
            let mut r = || 2.0 * rng.next_f64() - 1.0;
            (DQuat::from_axis_angle(DVec3::new(r(), r(), r()).normalize(), r()), DVec3::new(r(), r(), r()) * 0.01)
        })
        .collect();
    let moved: [Vec<f32>; 3] = [0, 1, 2].map(|a| {
        (0..n)
            .map(|i| {
                let (q, t) = motions[block(i)];
                (q * DVec3::from_array(rest[i].map(f64::from)) + t)[a] as f32
            })
            .collect()
    });
    let dir = tempfile::tempdir().expect("tempdir");
    let started = Instant::now();
    let frame = tracker.track([&moved[0], &moved[1], &moved[2]], 0.0);
    let track_s = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let fragments = FragmentFrame {
        meta: FragmentMeta { frame: 2, step: 1, time_s: 0.0, smoothed: false, inputs: None },
        fragment_of: frame.fragment_of.clone(),
        rotation: frame.motion.iter().map(|m| m.rotation.as_quat().to_array()).collect(),
        translation_m: frame.motion.iter().map(|m| m.translation.to_array()).collect(),
        elements: frame.elements.clone(),
        mass_kg: frame.mass_kg.clone(),
        element_affine: None,
    };
    fragments.write(&dir.path().join("fragments.0002.shp")).expect("write");
    PointCache {
        comments: vec![("frame".into(), "2".into())],
        columns: vec![
            ("x".into(), Column::Float(moved[0].clone())),
            ("y".into(), Column::Float(moved[1].clone())),
            ("z".into(), Column::Float(moved[2].clone())),
            ("fragment".into(), Column::Int(frame.fragment_of.iter().map(|f| *f as i32).collect())),
        ],
    }
    .write(&dir.path().join("points.0002.ply"))
    .expect("write");
    let write_s = started.elapsed().as_secs_f64();
    println!(
        "post benchmark: {n} elements, {} adjacency pairs, {} fragments",
        particles.adjacency.len(),
        frame.motion.len()
    );
    println!("  graph setup (once per run): {setup_s:.3} s");
    let started = Instant::now();
    let mut deformation = ElementDeformation::new(&particles);
    for &[a, b] in &particles.adjacency {
        if block(a as usize) != block(b as usize) {
            deformation.break_bond(&particles, particles.bonds.find(a as usize, b).expect("bonded") as u64);
        }
    }
    let deformation_setup_s = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let affine =
        deformation.element_affine(&particles, [&moved[0], &moved[1], &moved[2]], &frame.fragment_of, &frame.motion);
    let affine_s = started.elapsed().as_secs_f64();
    assert_eq!(affine.len(), n);
    println!(
        "  deformed elements ({} bond entries): setup and breaks {deformation_setup_s:.3} s, affine maps {affine_s:.3} s per frame",
        particles.bonds.neighbor.len()
    );
    println!(
        "  one frame: components + ids + Kabsch {track_s:.3} s, writing {write_s:.3} s, total {:.3} s",
        track_s + write_s
    );
    tet_shell();
}

/// Deformed tetrahedra: vase_small's shell (43,160 tets), cut in two by a plane through its
/// axis and each half moved apart, so that the vertices on the cut split.
fn tet_shell() {
    let mesh = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes/smooth_vase.obj");
    let text = format!(
        r#"
[scene]
name = "vase"
output_dir = "out"
seed = 3
[geometry]
source = "{}"
sampler = "tet_shell"
spacing_m = 0.006
horizon_factor = 2.0
[geometry.tet_shell]
layers = 3
layer_spacing_m = 0.0015
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 2.94e9
critical_stretch = 0.001
"#,
        mesh.display()
    );
    let config = PipelineConfig::from_toml_str(&text, Path::new("/nonexistent/p.toml")).expect("config");
    let particles = shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles;
    let n = particles.len();
    let left = |i: usize| particles.rest_position_m[i][0] < 0.0;
    let started = Instant::now();
    let mut deformation = ElementDeformation::new(&particles);
    let mut tracker = FragmentTracker::new(&particles, particles.mass_kg.iter().map(|m| f64::from(*m)).collect());
    for i in 0..n {
        for entry in particles.bonds.row(i) {
            let j = particles.bonds.neighbor[entry] as usize;
            if i < j && left(i) != left(j) {
                deformation.break_bond(&particles, entry as u64);
                tracker.break_bond(entry as u64);
            }
        }
    }
    let setup_s = started.elapsed().as_secs_f64();
    let moved: [Vec<f32>; 3] = [0, 1, 2].map(|a| {
        (0..n)
            .map(|i| {
                let p = particles.rest_position_m[i];
                let shift = if left(i) { -0.01 } else { 0.01 };
                p[a] + if a == 0 { shift * (1.0 + 2.0 * p[1]) } else { 0.0 }
            })
            .collect()
    });
    let frame = tracker.track([&moved[0], &moved[1], &moved[2]], 0.0);
    let started = Instant::now();
    let affine =
        deformation.element_affine(&particles, [&moved[0], &moved[1], &moved[2]], &frame.fragment_of, &frame.motion);
    let affine_s = started.elapsed().as_secs_f64();
    assert_eq!(affine.len(), n);
    println!(
        "post benchmark, deformed tetrahedra: {n} tets ({} bond entries), {} fragments: setup and breaks {setup_s:.3} s, \
         affine maps (embedded mesh) {affine_s:.3} s per frame",
        particles.bonds.neighbor.len(),
        frame.motion.len()
    );
}
