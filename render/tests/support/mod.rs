//! What the render tests share: a particle set of given elements, unbonded.

use shatter_core::particles::{Bonds, Elements, ParticleMeta, ParticleSet};

/// `elements` at `positions`, particle spacing `lambda_m`, with `adjacency` and no bonds.
pub fn particle_set(
    positions: Vec<[f32; 3]>,
    elements: Elements,
    lambda_m: f64,
    adjacency: Vec<[u32; 2]>,
) -> ParticleSet {
    let n = positions.len();
    ParticleSet {
        meta: ParticleMeta {
            scene_name: "t".into(),
            source: "box".into(),
            sampler: "grid".into(),
            lambda_m,
            horizon_factor: 1.0,
            delta_m: lambda_m,
            density_kg_m3: 1.0,
            bulk_modulus_pa: 1.0,
            mean_critical_stretch: 0.01,
            threshold_jitter: 0.0,
            seed: 0,
        },
        rest_position_m: positions,
        volume_m3: vec![1.0; n],
        mass_kg: vec![1.0; n],
        elements,
        bonds: Bonds { offsets: vec![0; n + 1], ..Bonds::default() },
        adjacency,
    }
}
