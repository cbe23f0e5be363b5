//! How the simulation benchmarks time shatter's CPU simulation on a particle set.

use std::time::Instant;

use shatter_core::config::PipelineConfig;
use shatter_core::particles::ParticleSet;
use shatter_sim::CpuSimulation;

/// Seconds for `steps` steps on `threads` threads from small random velocities: the median of
/// batches of `batch` steps, scaled, so that a noisy neighbour on a shared machine moves the
/// figure less. `describe` sees the simulation before its first step.
pub fn time_steps(
    config: &PipelineConfig,
    particles: &ParticleSet,
    (steps, batch): (usize, usize),
    threads: usize,
    describe: impl FnOnce(&CpuSimulation) + Send,
) -> f64 {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
    pool.install(|| {
        let mut sim = CpuSimulation::from_config(config, particles).expect("simulation");
        sim.set_velocity(|i, _| {
            let h = shatter_core::random::splitmix64(i as u64);
            [0, 1, 2].map(|k| ((h >> (16 * k)) & 0xffff) as f32 / 65535.0 * 2e-3 - 1e-3)
        });
        describe(&sim);
        sim.step(); // warm caches
        let mut batches: Vec<f64> = (0..steps.div_ceil(batch))
            .map(|_| {
                let started = Instant::now();
                for _ in 0..batch {
                    sim.step();
                }
                started.elapsed().as_secs_f64()
            })
            .collect();
        batches.sort_by(f64::total_cmp);
        batches[batches.len() / 2] * steps as f64 / batch as f64
    })
}
