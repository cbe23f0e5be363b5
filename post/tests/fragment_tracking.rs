//! Fragments and their motion on synthetic shots: known pieces moved rigidly, with and without
//! noise; ids through splits; one- and two-particle fragments.

#![allow(clippy::needless_range_loop)]

use std::path::Path;

use glam::{DQuat, DVec3};
use shatter_core::NoProgress;
use shatter_core::config::PipelineConfig;
use shatter_core::particles::ParticleSet;
use shatter_core::random::SplitMix64;
use shatter_post::FragmentTracker;

fn plate() -> ParticleSet {
    let text = r#"
[scene]
name = "t"
output_dir = "out"
seed = 1
[geometry]
source = "box"
box_size_m = [0.012, 0.006, 0.004]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 2.0
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
"#;
    let config = PipelineConfig::from_toml_str(text, Path::new("/nonexistent/p.toml")).expect("config");
    shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles
}

/// Breaks every adjacency bond whose two elements `piece` puts in different pieces.
fn cut(tracker: &mut FragmentTracker, particles: &ParticleSet, piece: &dyn Fn(usize) -> usize) {
    for &[a, b] in &particles.adjacency {
        if piece(a as usize) != piece(b as usize) {
            let bond = particles.bonds.find(a as usize, b).expect("adjacent elements are bonded");
            tracker.break_bond(bond as u64);
        }
    }
}

fn positions(particles: &ParticleSet, motion: &dyn Fn(usize, DVec3) -> DVec3) -> [Vec<f32>; 3] {
    let moved: Vec<DVec3> = (0..particles.len())
        .map(|i| motion(i, DVec3::from_array(particles.rest_position_m[i].map(f64::from))))
        .collect();
    [0, 1, 2].map(|axis| moved.iter().map(|p| p[axis] as f32).collect())
}

fn random_motion(rng: &mut SplitMix64) -> (DQuat, DVec3) {
    let mut r = || 2.0 * rng.next_f64() - 1.0;
    let axis = DVec3::new(r(), r(), r()).normalize();
    (DQuat::from_axis_angle(axis, 3.0 * r()), DVec3::new(r(), r(), r()) * 0.05)
}

#[test]
fn known_rigid_motions_are_recovered_and_ids_survive_splits() {
    let particles = plate();
    let n = particles.len();
    let mass = vec![1.0; n];
    let mut tracker = FragmentTracker::new(&particles, mass);
    let x = |i: usize| particles.rest_position_m[i][0];
    let lone = (0..n).max_by(|a, b| x(*a).total_cmp(&x(*b))).expect("particles");
    let pair = {
        let [a, b] = particles.adjacency[0];
        (a as usize, b as usize)
    };
    // pieces: the lone particle, the pair, and three slabs across x
    let piece = |i: usize| {
        if i == lone {
            3
        } else if i == pair.0 || i == pair.1 {
            4
        } else if x(i) < -0.002 {
            0
        } else if x(i) < 0.002 {
            1
        } else {
            2
        }
    };

    // frame 1: intact and at rest
    let rest = positions(&particles, &|_, p| p);
    let frame = tracker.track([&rest[0], &rest[1], &rest[2]], 0.0);
    assert_eq!(frame.motion.len(), 1);
    assert!(frame.motion[0].rotation.dot(DQuat::IDENTITY).abs() > 1.0 - 1e-12);

    // frame 2: five pieces, each moved rigidly
    cut(&mut tracker, &particles, &piece);
    let mut rng = SplitMix64::new(9);
    let truth: Vec<(DQuat, DVec3)> = (0..5).map(|_| random_motion(&mut rng)).collect();
    let moved = positions(&particles, &|i, p| truth[piece(i)].0 * p + truth[piece(i)].1);
    let frame = tracker.track([&moved[0], &moved[1], &moved[2]], 0.0);
    assert_eq!(frame.motion.len(), 5, "three slabs, a pair and a lone particle");
    for i in 0..n {
        let f = frame.fragment_of[i] as usize;
        let rest = DVec3::from_array(particles.rest_position_m[i].map(f64::from));
        let fitted = frame.motion[f].rotation * rest + frame.motion[f].translation;
        let actual = DVec3::new(f64::from(moved[0][i]), f64::from(moved[1][i]), f64::from(moved[2][i]));
        assert!((fitted - actual).length() < 1e-5, "element {i} off by {:e} m", (fitted - actual).length());
    }
    for slab in 0..3 {
        let member = (0..n).find(|&i| piece(i) == slab).expect("slab has elements");
        let found = frame.motion[frame.fragment_of[member] as usize];
        let angle = found.rotation.angle_between(truth[slab].0);
        assert!(angle < 1e-5, "slab {slab}: rotation off by {angle:e} rad");
        assert!((found.translation - truth[slab].1).length() < 1e-5, "slab {slab}: translation off");
    }
    // the biggest slab kept the original id 0; the others got 1, 2, ... in order of first element
    let slab_of = |slab: usize| frame.fragment_of[(0..n).find(|&i| piece(i) == slab).expect("member")];
    let sizes: Vec<usize> = (0..5).map(|p| (0..n).filter(|&i| piece(i) == p).count()).collect();
    let largest = (0..5).max_by_key(|&p| sizes[p]).expect("pieces");
    assert_eq!(slab_of(largest), 0);

    // frame 3: the middle slab splits at x = 0; the larger half keeps its id, the other is new
    let before = slab_of(1);
    let split = |i: usize| if piece(i) == 1 && x(i) >= 0.0 { 5 } else { piece(i) };
    cut(&mut tracker, &particles, &split);
    let frame3 = tracker.track([&moved[0], &moved[1], &moved[2]], 0.0);
    assert_eq!(frame3.motion.len(), 6);
    let halves: Vec<u32> =
        [1, 5].iter().map(|&p| frame3.fragment_of[(0..n).find(|&i| split(i) == p).expect("member")]).collect();
    assert!(halves.contains(&before), "one half keeps id {before}: {halves:?}");
    assert!(halves.contains(&5), "the other half is the new id 5: {halves:?}");
    for p in 0..5 {
        if p != 1 {
            let member = (0..n).find(|&i| split(i) == p).expect("member");
            assert_eq!(frame3.fragment_of[member], frame.fragment_of[member], "piece {p} keeps its id");
        }
    }
}

#[test]
fn noisy_motions_are_recovered_to_the_noise() {
    let particles = plate();
    let n = particles.len();
    let mut tracker = FragmentTracker::new(&particles, particles.mass_kg.iter().map(|m| f64::from(*m)).collect());
    let mut rng = SplitMix64::new(4);
    let (rotation, translation) = random_motion(&mut rng);
    let noise = 1e-6;
    let moved = positions(&particles, &|_, p| {
        let jitter = DVec3::new(rng_value(p.x), rng_value(p.y), rng_value(p.z)) * noise;
        rotation * p + translation + jitter
    });
    let frame = tracker.track([&moved[0], &moved[1], &moved[2]], 0.0);
    assert_eq!(frame.motion.len(), 1);
    // 288 particles over about 1 cm with 1 um noise: the fit is good to a fraction of a micron
    assert!(frame.motion[0].rotation.angle_between(rotation) < 1e-3);
    assert!((frame.motion[0].translation - translation).length() < 5e-6);
    assert_eq!(frame.fragment_of.len(), n);
}

/// A deterministic value in [-1, 1) from a coordinate.
fn rng_value(seed: f64) -> f64 {
    let mut rng = SplitMix64::new(seed.to_bits());
    2.0 * rng.next_f64() - 1.0
}
