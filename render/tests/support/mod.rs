//! What the render tests share: a particle set of given elements, unbonded, and a plain look.

use shatter_core::particles::{Elements, ParticleSet};
use shatter_render::lighting::{EnvironmentMap, key_light, sh_project};
use shatter_render::materials::Look;

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

/// A look under `environment` (its SH light and key light): opaque cubes of albedo 0.7 without a
/// highlight, no floor, the environment shown; tests change what they need.
pub fn look(environment: EnvironmentMap) -> Look {
    Look {
        sh: sh_project(&environment),
        key: key_light(&environment),
        environment,
        show_environment: true,
        ior: 1.5,
        absorption: [0.0; 3],
        albedo: [0.7; 3],
        fracture_albedo: [0.7; 3],
        specular: 0.0,
        shininess: 16.0,
        floor: None,
        max_bounces: 4,
        glass_split_events: 0,
        opaque_cubes: true,
    }
}
