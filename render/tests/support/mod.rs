//! What the render tests share: a particle set of given elements, unbonded.

use shatter_core::particles::{Elements, ParticleSet};

/// `elements` at `positions`, particle spacing `lambda_m`, with `adjacency` and no bonds.
pub fn particle_set(
    positions: Vec<[f32; 3]>,
    elements: Elements,
    lambda_m: f64,
    adjacency: Vec<[u32; 2]>,
) -> ParticleSet {
    ParticleSet { adjacency, ..ParticleSet::unbonded(positions, elements, lambda_m) }
}
