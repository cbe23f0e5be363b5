//! The physics tests against theory (`scenarios`) on the CPU backend, and what only the CPU
//! promises: results independent of the thread count; contact between broken neighbours.

mod scenarios;

use scenarios::{block, max_force};
use shatter_core::config::PipelineConfig;
use shatter_core::particles::ParticleSet;
use shatter_sim::{Backend, Simulation};

fn simulation(config: &PipelineConfig, particles: &ParticleSet) -> Simulation {
    Simulation::from_config(config, particles).expect("simulation")
}

fn cpu(config: &PipelineConfig, particles: &ParticleSet) -> Box<dyn Backend> {
    Box::new(simulation(config, particles))
}

#[test]
fn rigid_motions_cause_no_internal_force() {
    scenarios::rigid_motions_cause_no_internal_force(&cpu);
}

#[test]
fn momentum_and_energy_are_conserved_in_an_elastic_vibration() {
    scenarios::momentum_and_energy_are_conserved_in_an_elastic_vibration(&cpu);
}

#[test]
fn uniform_dilation_stores_the_continuum_energy_density_at_n3() {
    scenarios::uniform_dilation_stores_the_continuum_energy_density_at_n3(&cpu);
}

#[test]
fn a_longitudinal_wave_in_a_bar_travels_at_the_bar_speed() {
    // 160 particles long, 2,400 steps (about 3 periods of the first mode), every step sampled.
    scenarios::a_longitudinal_wave_in_a_bar_travels_at_the_bar_speed(&cpu, 160, 2400, 1);
}

#[test]
fn a_bar_pulled_apart_breaks_first_where_and_when_its_thresholds_say() {
    scenarios::a_bar_pulled_apart_breaks_first_where_and_when_its_thresholds_say(&cpu);
}

/// A plate struck by a projectile: contact, fracture and body forces all in play.
fn struck_plate() -> (PipelineConfig, ParticleSet) {
    block(
        [20, 20, 4],
        3.0,
        "",
        "[[sim.projectile]]\ncenter_m = [0.0, 0.0, 0.0067]\nvelocity_m_s = [0.0, 0.0, -150.0]\nradius_m = 0.003\nstiffness_pa = 3e7",
    )
}

#[test]
fn results_are_bit_identical_for_any_thread_count() {
    let (config, particles) = struck_plate();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
        pool.install(|| {
            let mut sim = simulation(&config, &particles);
            let mut breaks = Vec::new();
            for _ in 0..300 {
                sim.step();
                breaks.extend(sim.take_breaks());
            }
            (sim.dynamics().clone(), breaks)
        })
    };
    let (one, one_breaks) = run(1);
    let (two, two_breaks) = run(2);
    assert!(!one_breaks.is_empty(), "the projectile should break bonds");
    assert_eq!(one_breaks, two_breaks);
    assert!(one == two, "1 and 2 threads differ");
    assert!(run(3).0 == one, "1 and 3 threads differ");
}

#[test]
fn broken_neighbours_closer_than_the_contact_distance_repel_only_when_pushed_closer() {
    // d_c = 2.5 lambda: every neighbour within it was bonded; break all the bonds at rest
    let (config, particles) = block([4, 4, 4], 3.0, "", "[sim.contact]\nstiffness_pa = 1e12\ndistance_m = 0.0025");
    let mut sim = simulation(&config, &particles);
    let every_bond: Vec<u64> = (0..particles.bonds.neighbor.len() as u64).collect();
    let at_rest = sim.dynamics().clone();
    sim.restore(at_rest.clone(), &every_bond);
    sim.step();
    assert_eq!(max_force(&sim), 0.0, "a broken bond's particles stay where they sat, unpushed");

    // pushed a tenth of lambda toward its neighbour, a particle is pushed back
    let mut pushed = at_rest;
    pushed.disp[0][0] = 1e-4;
    sim.restore(pushed, &every_bond);
    sim.step();
    assert!(sim.dynamics().force[0][0] < 0.0, "pushed back: {}", sim.dynamics().force[0][0]);
}
