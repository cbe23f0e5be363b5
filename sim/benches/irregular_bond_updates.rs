//! Benchmark: bond updates per second per core on particles that are not on a lattice (the row
//! layout), under Levine's rules, beside LAMMPS's `pair_style peri/pmb` on the same particles
//! (positions and volumes written as a LAMMPS data file), horizon and step count when `lmp` is
//! installed (Debian package `lammps`). Two particle sets fill a box at N = 3: the tets of a
//! filled tet shell and clipped Voronoi cells.
//!
//! `cargo bench -p shatter-sim --bench irregular_bond_updates [-- STEPS]` (default 20). A bond
//! update is one bond's force (stretch, break test, force) in one step; both codes are credited
//! with shatter's unique bonds x steps (LAMMPS bonds the same pairs: all within the horizon).

#[path = "support/bond_timing.rs"]
mod bond_timing;
#[path = "support/lammps_particles.rs"]
mod lammps_particles;
#[path = "support/lammps_run.rs"]
mod lammps_run;
#[path = "support/step_timing.rs"]
mod step_timing;

use bond_timing::{config, time_one_and_all};
use shatter_core::NoProgress;
use shatter_core::particles::ParticleSet;

/// The particle sets: a name and the `[geometry]` lines that make it.
const CASES: [(&str, &str); 2] = [
    (
        "tet shell (filled core)",
        "source = \"box\"\nbox_size_m = [0.04, 0.04, 0.04]\nsampler = \"tet_shell\"\nspacing_m = 0.0015\n\
         horizon_factor = 3.0\n[geometry.tet_shell]\nlayers = 4\nfilled_core = true",
    ),
    (
        "Voronoi cells",
        "source = \"box\"\nbox_size_m = [0.05, 0.05, 0.05]\nsampler = \"voronoi\"\nspacing_m = 0.001\n\
         horizon_factor = 3.0\n[geometry.voronoi]\nparticles = 100000",
    ),
];

/// LAMMPS's loop time on `particles` with the PMB constants of the benchmarks' glass (bulk
/// modulus 14.9 GPa) at their horizon, if `lmp` runs.
fn time_lammps(particles: &ParticleSet, steps: usize) -> Option<f64> {
    let meta = &particles.meta;
    let c = 18.0 * meta.bulk_modulus_pa / (std::f64::consts::PI * meta.delta_m.powi(4));
    // shatter bonds pairs up to delta (1 + 1e-9); LAMMPS's cutoff a hair above delta bonds the
    // same pairs. The step is well inside the stable one for this spacing.
    let pair = format!(
        "pair_style peri/pmb\npair_coeff * * {c:e} {:e} {:e} 0.25",
        meta.delta_m * (1.0 + 1e-7),
        meta.mean_critical_stretch
    );
    let timestep_s = 0.5e-7 * meta.lambda_m / 0.001;
    let case = lammps_particles::particles_input(
        &particles.rest_position_m,
        &particles.volume_m3,
        meta.lambda_m,
        &pair,
        timestep_s,
        steps,
    );
    lammps_run::loop_time_s(&case, "irregular")
}

fn main() {
    let steps = std::env::args().skip(1).find_map(|arg| arg.parse::<usize>().ok()).unwrap_or(20);
    for (name, geometry) in CASES {
        let levine = config(geometry, "levine");
        let particles = shatter_preprocess::preprocess(&levine, &NoProgress).expect("preprocess").particles;
        let bonds = particles.bonds.unique_count();
        let updates = (bonds * steps) as f64;
        println!(
            "{name}: {} particles, {bonds} bonds ({:.0} per particle) at N = 3, {steps} steps",
            particles.len(),
            2.0 * bonds as f64 / particles.len() as f64
        );
        let one = time_one_and_all(&levine, &particles, steps, updates);
        match time_lammps(&particles, steps) {
            Some(lammps) => {
                println!(
                    "  LAMMPS peri/pmb, 1 core: {lammps:7.2} s  {:8.1} M bond updates/s per core",
                    updates / lammps / 1e6
                );
                println!("  per-core ratio, shatter 1 thread / LAMMPS, {name}: {:.1}x", lammps / one);
            }
            None => println!("  LAMMPS (lmp) not found or failed: install Debian's `lammps` package to compare"),
        }
    }
}
