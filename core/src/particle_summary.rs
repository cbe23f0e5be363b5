//! [`ParticleSummary`]: the figures `shatter inspect` and `shatter preprocess` show for a
//! particle set.

use serde::Serialize;

use crate::particles::{ElementType, ParticleMeta, ParticleSet};
use crate::stage_file::StageKind;

/// The figures `shatter inspect` shows for a particle file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParticleSummary {
    /// Always "particles".
    pub kind: &'static str,
    /// Format version of the file.
    pub format_version: u32,
    /// Number of particles.
    pub particles: usize,
    /// Number of unique bonds.
    pub bonds: usize,
    /// Bonds per particle.
    pub bonds_per_particle: CountStats,
    /// lambda, metres.
    pub lambda_m: f64,
    /// delta, metres.
    pub delta_m: f64,
    /// N in delta = N * lambda.
    pub horizon_factor: f64,
    /// Sum of particle volumes, m^3.
    pub total_volume_m3: f64,
    /// Sum of particle masses, kg.
    pub total_mass_kg: f64,
    /// "cube", "tet" or "trimtope".
    pub element_type: ElementType,
    /// Number of adjacent element pairs.
    pub adjacency_edges: usize,
    /// Bounding box of the rest positions, metres.
    pub bounds_m: [[f32; 3]; 2],
    /// Critical stretch over all bonds.
    pub threshold: ValueStats,
    /// How the set was made.
    pub meta: ParticleMeta,
}

/// Minimum, maximum and mean of a count.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CountStats {
    /// Smallest.
    pub min: u64,
    /// Largest.
    pub max: u64,
    /// Mean.
    pub mean: f64,
}

/// Minimum, maximum and mean of a value.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ValueStats {
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
    /// Mean.
    pub mean: f64,
}

impl ParticleSet {
    /// The figures `shatter inspect` shows.
    pub fn summary(&self) -> ParticleSummary {
        let n = self.len();
        let counts = (0..n).map(|i| self.bonds.offsets[i + 1] - self.bonds.offsets[i]);
        let (min, max) = counts.fold((u64::MAX, 0), |(lo, hi), c| (lo.min(c), hi.max(c)));
        let mut bounds = [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]];
        for p in &self.rest_position_m {
            for (axis, &c) in p.iter().enumerate() {
                bounds[0][axis] = bounds[0][axis].min(c);
                bounds[1][axis] = bounds[1][axis].max(c);
            }
        }
        let thresholds = &self.bonds.threshold;
        let threshold = ValueStats {
            min: thresholds.iter().copied().fold(f32::INFINITY, f32::min) as f64,
            max: thresholds.iter().copied().fold(f32::NEG_INFINITY, f32::max) as f64,
            mean: thresholds.iter().map(|t| *t as f64).sum::<f64>() / thresholds.len().max(1) as f64,
        };
        ParticleSummary {
            kind: "particles",
            format_version: StageKind::Particles.version(),
            particles: n,
            bonds: self.bonds.unique_count(),
            bonds_per_particle: CountStats {
                min: if n == 0 { 0 } else { min },
                max,
                mean: self.bonds.neighbor.len() as f64 / n.max(1) as f64,
            },
            lambda_m: self.meta.lambda_m,
            delta_m: self.meta.delta_m,
            horizon_factor: self.meta.horizon_factor,
            total_volume_m3: self.volume_m3.iter().map(|v| *v as f64).sum(),
            total_mass_kg: self.mass_kg.iter().map(|m| *m as f64).sum(),
            element_type: self.elements.element_type(),
            adjacency_edges: self.adjacency.len(),
            bounds_m: bounds,
            threshold,
            meta: self.meta.clone(),
        }
    }
}
