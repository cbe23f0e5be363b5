//! The physics tests against theory (`scenarios`) on the GPU backend: rigid motions, conservation
//! laws, energy density, wave speed, the breaking stretch.

use crate::scenarios;

use shatter_core::config::PipelineConfig;
use shatter_core::particles::ParticleSet;
use shatter_gpu::GpuContext;
use shatter_sim::gpu::{GpuOptions, GpuSimulation};
use shatter_sim::{Backend, Model, art};

fn gpu(config: &PipelineConfig, particles: &ParticleSet) -> Box<dyn Backend> {
    let ctx = GpuContext::shared_for_tests().unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    let model = Model::new(config, particles).expect("model");
    let factors = art::threshold_factors(&config.sim, particles, config.scene.seed).expect("factors");
    let correction = config.sim.stiffness_correction;
    let sim = GpuSimulation::new(ctx.into(), particles, model, factors.as_deref(), correction, &GpuOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    Box::new(sim)
}

#[test]
fn an_unset_time_step_is_taken_from_the_material_on_the_gpu() {
    scenarios::an_unset_time_step_is_taken_from_the_material(&gpu);
}

#[test]
fn rigid_motions_cause_no_internal_force_on_the_gpu() {
    scenarios::rigid_motions_cause_no_internal_force(&gpu);
}

#[test]
fn momentum_and_energy_are_conserved_in_an_elastic_vibration_on_the_gpu() {
    scenarios::momentum_and_energy_are_conserved_in_an_elastic_vibration(&gpu);
}

#[test]
fn uniform_dilation_stores_the_continuum_energy_density_at_n3_on_the_gpu() {
    scenarios::uniform_dilation_stores_the_continuum_energy_density_at_n3(&gpu);
}

#[test]
fn a_longitudinal_wave_in_a_bar_travels_at_the_bar_speed_on_the_gpu() {
    // Half the CPU test's bar (lavapipe runs it in CI): 80 particles long, for 3 periods of the
    // first mode (about 420 steps each), sampled every other step.
    scenarios::a_longitudinal_wave_in_a_bar_travels_at_the_bar_speed(&gpu, 80, 1200, 2);
}

#[test]
fn a_bar_pulled_apart_breaks_first_where_and_when_its_thresholds_say_on_the_gpu() {
    scenarios::a_bar_pulled_apart_breaks_first_where_and_when_its_thresholds_say(&gpu);
}

/// The GPU backend under `sim.rules = "lammps"`.
fn gpu_lammps(config: &PipelineConfig, particles: &ParticleSet) -> Box<dyn Backend> {
    let mut config = config.clone();
    config.sim.rules = shatter_core::config::sim::RuleSet::Lammps;
    gpu(&config, particles)
}

#[test]
fn the_lammps_rules_pass_the_physics_tests_on_the_gpu_too() {
    // As on the CPU (physics.rs): the pulled bar is left out, the signed boost weakens it.
    scenarios::rigid_motions_cause_no_internal_force(&gpu_lammps);
    scenarios::momentum_and_energy_are_conserved_in_an_elastic_vibration(&gpu_lammps);
    scenarios::uniform_dilation_stores_the_continuum_energy_density_at_n3(&gpu_lammps);
    scenarios::a_longitudinal_wave_in_a_bar_travels_at_the_bar_speed(&gpu_lammps, 80, 1200, 2);
}
