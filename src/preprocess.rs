//! `shatter preprocess`: geometry to particles.shp.

use std::time::Instant;

use anyhow::Context;
use shatter_core::{OutputLayout, PipelineConfig};

use crate::Failure;
use crate::progress_bars::for_stderr;

/// Preprocesses the scene and writes its particle file.
pub fn run(config: &PipelineConfig) -> Result<(), Failure> {
    let started = Instant::now();
    let result = shatter_preprocess::preprocess(config, &*for_stderr())?;
    for line in result.mesh_report.iter().flat_map(|report| report.lines()) {
        println!("{line}");
    }
    for note in &result.notes {
        eprintln!("note: {note}");
    }
    let layout = OutputLayout::of(config);
    let folder = layout.root();
    std::fs::create_dir_all(folder).with_context(|| format!("cannot create the output folder {}", folder.display()))?;
    let path = layout.particles();
    result.particles.write(&path)?;
    let summary = result.particles.summary();
    let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    println!(
        "preprocess: {} particles ({}), {} bonds ({} to {} per particle, mean {:.1}), {} adjacent pairs",
        summary.particles,
        summary.element_type.name(),
        summary.bonds,
        summary.bonds_per_particle.min,
        summary.bonds_per_particle.max,
        summary.bonds_per_particle.mean,
        summary.adjacency_edges,
    );
    println!(
        "            lambda {:.4e} m, delta {:.4e} m, volume {:.4e} m^3, mass {:.4e} kg, mean critical stretch {:.3e}",
        summary.lambda_m,
        summary.delta_m,
        summary.total_volume_m3,
        summary.total_mass_kg,
        summary.meta.mean_critical_stretch
    );
    println!("wrote {} ({:.1} MB) in {:.2} s", path.display(), bytes as f64 / 1e6, started.elapsed().as_secs_f64());
    Ok(())
}
