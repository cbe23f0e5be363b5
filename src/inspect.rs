//! `shatter inspect`: summarise any stage file.

use std::path::Path;

use shatter_core::particles::ParticleSet;
use shatter_core::stage_file::{StageKind, read_header};

use crate::Failure;

/// Prints a summary of the stage file at `path`, as text or JSON.
pub fn run(path: &Path, json: bool) -> Result<(), Failure> {
    let header = read_header(path)?;
    match header.kind {
        StageKind::Particles => {
            let summary = ParticleSet::read(path)?.summary();
            if json {
                println!("{}", serde_json::to_string_pretty(&summary)?);
            } else {
                let [lo, hi] = summary.bounds_m;
                println!("{}: particles file, format version {}", path.display(), summary.format_version);
                println!(
                    "  scene            {} (source {}, sampler {})",
                    summary.meta.scene_name, summary.meta.source, summary.meta.sampler
                );
                println!("  particles        {} ({} elements)", summary.particles, summary.element_type.name());
                println!(
                    "  bonds            {} unique; per particle min {}, max {}, mean {:.2}",
                    summary.bonds,
                    summary.bonds_per_particle.min,
                    summary.bonds_per_particle.max,
                    summary.bonds_per_particle.mean
                );
                println!("  adjacency edges  {}", summary.adjacency_edges);
                println!(
                    "  lambda, delta    {:.6e} m, {:.6e} m (N = {})",
                    summary.lambda_m, summary.delta_m, summary.horizon_factor
                );
                println!("  volume, mass     {:.6e} m^3, {:.6e} kg", summary.total_volume_m3, summary.total_mass_kg);
                println!(
                    "  critical stretch mean {:.4e} (min {:.4e}, max {:.4e}; s0 {:.4e}, jitter {})",
                    summary.threshold.mean,
                    summary.threshold.min,
                    summary.threshold.max,
                    summary.meta.mean_critical_stretch,
                    summary.meta.threshold_jitter
                );
                println!("  bounds           {lo:?} .. {hi:?} m");
            }
        }
    }
    Ok(())
}
