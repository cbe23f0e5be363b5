//! What the PMB bond-update benchmarks share: their scene and the timing of shatter's CPU
//! simulation on a particle set.

use std::path::Path;
use std::time::Instant;

use shatter_core::config::PipelineConfig;
use shatter_core::particles::ParticleSet;
use shatter_sim::CpuSimulation;

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

/// Seconds for `steps` steps on `threads` threads from small random velocities: the median of
/// batches of 10 steps, scaled, so that a noisy neighbour on a shared machine moves the figure
/// less. On one thread it prints the layout and the bond entries computed per step.
pub fn time_ours(config: &PipelineConfig, particles: &ParticleSet, steps: usize, threads: usize) -> f64 {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
    pool.install(|| {
        let mut sim = CpuSimulation::from_config(config, particles).expect("simulation");
        sim.set_velocity(|i, _| {
            let h = shatter_core::random::splitmix64(i as u64);
            [0, 1, 2].map(|k| ((h >> (16 * k)) & 0xffff) as f32 / 65535.0 * 2e-3 - 1e-3)
        });
        let (internal, external) = sim.bond_entries();
        if threads == 1 {
            let layout = if sim.on_lattice() { "lattice" } else { "row" };
            println!("  {layout} layout; bond entries per step: {internal} internal + {external} external");
        }
        sim.step(); // warm caches
        let mut batches: Vec<f64> = (0..steps.div_ceil(10))
            .map(|_| {
                let started = Instant::now();
                for _ in 0..10 {
                    sim.step();
                }
                started.elapsed().as_secs_f64()
            })
            .collect();
        batches.sort_by(f64::total_cmp);
        batches[batches.len() / 2] * steps as f64 / 10.0
    })
}
