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

/// A look under a uniform environment of radiance `radiance` (`width` x `height` texels):
/// opaque cubes of albedo 0.7 without a highlight, no floor, the environment shown; tests
/// change what they need.
pub fn look(radiance: [f32; 3], (width, height): (usize, usize)) -> Look {
    let environment = EnvironmentMap { width, height, texels: vec![radiance; width * height] };
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
