//! Every SIMD path this CPU runs (`--simd`, `SHATTER_SIMD`): the physics scenarios pass on each,
//! on both bond layouts, and the default shot's first frames are the same to the bit on each.
//! (Each kernel's unit tests compare its paths on random chunks.)

use std::path::Path;

use crate::scenarios;

use shatter_core::NoProgress;
use shatter_core::config::PipelineConfig;
use shatter_core::particles::ParticleSet;
use shatter_sim::{Backend, CpuSimulation, LayoutChoice, SimdPath};

/// A CPU simulation on `layout` and the SIMD path `simd`.
fn on_path(config: &PipelineConfig, particles: &ParticleSet, layout: LayoutChoice, simd: SimdPath) -> CpuSimulation {
    let mut sim = CpuSimulation::from_config_with_layout(config, particles, layout).expect("simulation");
    sim.set_simd_path(simd).expect("an available path");
    assert_eq!(sim.simd_path(), simd);
    sim
}

/// `physics.rs` runs the scenarios on the best path; here they run on every other path this CPU
/// has, on both layouts.
#[test]
fn the_physics_scenarios_pass_on_every_simd_path_and_layout() {
    for simd in SimdPath::available().into_iter().filter(|simd| *simd != SimdPath::best()) {
        for layout in [LayoutChoice::Fastest, LayoutChoice::RowsOnly] {
            let make = move |config: &PipelineConfig, particles: &ParticleSet| -> Box<dyn Backend> {
                Box::new(on_path(config, particles, layout, simd))
            };
            scenarios::rigid_motions_cause_no_internal_force(&make);
            scenarios::momentum_and_energy_are_conserved_in_an_elastic_vibration(&make);
            scenarios::uniform_dilation_stores_the_continuum_energy_density_at_n3(&make);
            scenarios::a_longitudinal_wave_in_a_bar_travels_at_the_bar_speed(&make, 160, 2400, 1);
            scenarios::a_bar_pulled_apart_breaks_first_where_and_when_its_thresholds_say(&make);
        }
    }
}

/// The default shot (`pipeline.toml`: 50,000 cubes struck by a projectile, weakened paths) through
/// its first five frames, by which the projectile has broken bonds: the same state and the same
/// breaks, step by step, on every path. (The paths run the same operations in the same order, so
/// they agree exactly, where backends agree only within the physics tests' bounds.)
#[test]
fn the_default_shot_breaks_the_same_bonds_on_every_simd_path() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../pipeline.toml");
    let config = PipelineConfig::load(&path).expect("pipeline.toml");
    let particles = shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles;
    let steps = 4 * u64::from(config.sim.steps_per_frame);
    let run = |simd: SimdPath| {
        let mut sim = on_path(&config, &particles, LayoutChoice::Fastest, simd);
        assert!(sim.on_lattice(), "the default plate runs on the lattice layout");
        let mut breaks = Vec::new();
        for _ in 0..steps {
            sim.step();
            breaks.extend(sim.take_breaks());
        }
        (sim.dynamics().clone(), breaks)
    };
    let (portable, portable_breaks) = run(SimdPath::Portable);
    assert!(portable_breaks.len() > 100, "the projectile should break bonds: {}", portable_breaks.len());
    for simd in SimdPath::available().into_iter().filter(|simd| *simd != SimdPath::Portable) {
        let (state, breaks) = run(simd);
        assert_eq!(breaks, portable_breaks, "{simd}: breaks");
        assert!(state == portable, "{simd}: the state differs from the portable path's");
    }
}
