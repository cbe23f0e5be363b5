//! `[sim.shards]`: a Voronoi shard pattern of the body's bonds, strong inside shards and weak
//! across.

use serde::{Deserialize, Serialize};

/// `[sim.shards]`: `count` shard centres are picked among the particles (seeded); each particle
/// belongs to the nearest; thresholds of bonds inside a shard are multiplied by `inside_factor`,
/// across shards by `across_factor`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShardsConfig {
    /// Number of shards.
    pub count: u32,
    /// Threshold multiplier for bonds within a shard.
    #[serde(default = "default_inside_factor")]
    pub inside_factor: f64,
    /// Threshold multiplier for bonds between shards.
    #[serde(default = "default_across_factor")]
    pub across_factor: f64,
    /// The shards' centres, metres; empty (the default): `count` particles picked by a seeded
    /// rank ([`crate::random::ranked_choice`]). A re-entry's scene sets the shot's, so that a
    /// piece's particles keep their shards.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub centres_m: Vec<[f64; 3]>,
}

/// The salt of the shards' ranked choice of centres.
const SHARD_CENTRE_SALT: u64 = 0x5a4d;

impl ShardsConfig {
    /// The shards' centres among particles at `rest_m` (rest positions) for `seed`: `centres_m`
    /// when given, else the particles the seeded rank picks.
    pub fn centres(&self, rest_m: &[[f32; 3]], seed: u64) -> Vec<[f64; 3]> {
        if !self.centres_m.is_empty() {
            return self.centres_m.clone();
        }
        crate::random::ranked_choice(rest_m.len(), self.count as usize, seed, SHARD_CENTRE_SALT)
            .into_iter()
            .map(|i| rest_m[i].map(f64::from))
            .collect()
    }
}

fn default_inside_factor() -> f64 {
    2.0
}

fn default_across_factor() -> f64 {
    0.5
}
