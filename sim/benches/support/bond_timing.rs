//! What the PMB bond-update benchmarks share: their scene, and shatter's rates on one thread and
//! on all.

use std::path::Path;

use shatter_core::config::PipelineConfig;
use shatter_core::particles::ParticleSet;

use crate::step_timing::time_steps;

/// The benchmarks' scene: `geometry` (the `[geometry]` table's lines: source, sampler,
/// spacing, horizon) with glass's density and bulk modulus, no gravity, under `rules`
/// (`"levine"` or `"lammps"`).
pub fn config(geometry: &str, rules: &str) -> PipelineConfig {
    let text = format!(
        "[scene]\nname = \"bench\"\noutput_dir = \"out\"\nseed = 1\n[geometry]\n{geometry}\n\
         [material]\ndensity_kg_m3 = 2200.0\nbulk_modulus_pa = 14.9e9\n\
         [sim]\ngravity_m_s2 = [0.0, 0.0, 0.0]\nrules = \"{rules}\"\n"
    );
    PipelineConfig::from_toml_str(&text, Path::new("/nonexistent/pipeline.toml")).expect("valid config")
}

/// Seconds for `steps` steps on `threads` threads (medians of 10-step batches); on one thread
/// it prints the layout, the SIMD path (`SHATTER_SIMD` forces one) and the bond entries computed
/// per step.
pub fn time_ours(config: &PipelineConfig, particles: &ParticleSet, steps: usize, threads: usize) -> f64 {
    time_steps(config, particles, (steps, 10), threads, |sim| {
        if threads == 1 {
            let (internal, external) = sim.bond_entries();
            let layout = if sim.on_lattice() { "lattice" } else { "row" };
            let simd = sim.simd_path();
            println!(
                "  {layout} layout, {simd} kernels; bond entries per step: {internal} internal + {external} external"
            );
        }
    })
}

/// Times `steps` steps on one thread and on all, prints both rates of `updates` bond updates,
/// and returns the one-thread time.
pub fn time_one_and_all(config: &PipelineConfig, particles: &ParticleSet, steps: usize, updates: f64) -> f64 {
    let cores = rayon::current_num_threads();
    let one = time_ours(config, particles, steps, 1);
    println!("  shatter CPU, 1 thread:   {one:7.2} s  {:8.1} M bond updates/s per core", updates / one / 1e6);
    let all = time_ours(config, particles, steps, cores);
    println!(
        "  shatter CPU, {cores} threads:  {all:7.2} s  {:8.1} M bond updates/s ({:.1} per core)",
        updates / all / 1e6,
        updates / all / 1e6 / cores as f64
    );
    one
}
