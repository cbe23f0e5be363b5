//! Scenes of the elastoplastic tests on both backends (`elastoplastic_physics.rs` on the CPU,
//! `gpu_elastoplastic.rs` on the GPU): blocks of grid cubes and their centres.

#![allow(dead_code)] // each test binary uses its part

use std::path::Path;

use shatter_core::NoProgress;
use shatter_core::config::PipelineConfig;
use shatter_core::particles::ParticleSet;

pub const RHO: f64 = 2200.0;
pub const LAMBDA: f64 = 0.001;
/// The horizon factor: on the cubic grid N = 2.5 makes the family's fourth moment isotropic to
/// 0.6% (N = 3: 13% off; docs/DECISIONS.md#elastoplastic-horizon).
pub const HORIZON_FACTOR: f64 = 2.5;
/// Glass's Young's modulus, Pa.
pub const E: f64 = 72e9;

/// A box of `counts` cubes of 1 mm at [`HORIZON_FACTOR`] in the elastoplastic model with
/// Poisson's ratio `nu`, with extra `[material]` and `[sim]` keys.
pub fn block(counts: [usize; 3], nu: f64, material: &str, sim: &str) -> (PipelineConfig, ParticleSet) {
    let material = format!("model = \"elastoplastic\"\nyoungs_modulus_pa = {E}\npoisson_ratio = {nu}\n{material}");
    let config = load(&block_text(counts, &material, sim));
    let particles = shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles;
    (config, particles)
}

/// The scene text of a box of `counts` cubes of 1 mm (no gravity) with `[material]` keys
/// `material` besides the density and `[sim]` keys `sim`.
pub fn block_text(counts: [usize; 3], material: &str, sim: &str) -> String {
    let size = counts.map(|c| c as f64 * LAMBDA);
    format!(
        r#"
[scene]
name = "t"
output_dir = "out"
seed = 4
[geometry]
source = "box"
box_size_m = {size:?}
sampler = "grid"
spacing_m = {LAMBDA}
horizon_factor = {HORIZON_FACTOR}
[material]
density_kg_m3 = {RHO}
{material}
[sim]
gravity_m_s2 = [0.0, 0.0, 0.0]
{sim}
"#
    )
}

pub fn load(text: &str) -> PipelineConfig {
    PipelineConfig::from_toml_str(text, Path::new("/nonexistent/pipeline.toml")).expect("valid config")
}

pub fn centre(particles: &ParticleSet) -> [f32; 3] {
    let n = particles.len() as f64;
    [0, 1, 2].map(|a| (particles.rest_position_m.iter().map(|p| f64::from(p[a])).sum::<f64>() / n) as f32)
}

/// The particle nearest the centre.
pub fn middle(particles: &ParticleSet) -> usize {
    let c = centre(particles);
    let d = |i: usize| (0..3).map(|k| (particles.rest_position_m[i][k] - c[k]).powi(2)).sum::<f32>();
    (0..particles.len()).min_by(|a, b| d(*a).total_cmp(&d(*b))).expect("particles")
}
