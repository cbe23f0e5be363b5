//! What the render tests share: a particle set of given elements, unbonded, and skies.

use shatter_core::particles::{Elements, ParticleSet};
use shatter_render::lighting::EnvironmentMap;

/// `elements` at `positions`, particle spacing `lambda_m`, with `adjacency` and no bonds.
pub fn particle_set(
    positions: Vec<[f32; 3]>,
    elements: Elements,
    lambda_m: f64,
    adjacency: Vec<[u32; 2]>,
) -> ParticleSet {
    ParticleSet { adjacency, ..ParticleSet::unbonded(positions, elements, lambda_m) }
}

/// A uniform environment of radiance `radiance`, `width` x `height` texels.
pub fn uniform_sky(radiance: [f32; 3], (width, height): (usize, usize)) -> EnvironmentMap {
    EnvironmentMap { width, height, texels: vec![radiance; width * height] }
}

/// A 32 x 16 sky whose colour varies with direction, so that shading does.
pub fn gradient_sky() -> EnvironmentMap {
    let (width, height) = (32, 16);
    let texels = (0..width * height)
        .map(|i| [0.2 + (i % width) as f32 / width as f32, 0.5, 1.0 - (i / width) as f32 / height as f32])
        .collect();
    EnvironmentMap { width, height, texels }
}
