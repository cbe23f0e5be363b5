//! Benchmark: bond updates per second per core on a 49^3 block (117,649 particles) at N = 3,
//! under Levine's rules (the lattice layout) and LAMMPS's (`sim.rules = "lammps"`: the row
//! layout's portable kernel and short-range contact), beside LAMMPS's `pair_style peri/pmb` on
//! the same lattice, horizon and step count when `lmp` is installed (Debian package `lammps`).
//!
//! `cargo bench -p shatter-sim --bench bond_updates [-- STEPS [SIDE]]` (defaults 100 and 49). A
//! bond update is one bond's force (stretch, break test, force) in one step; both codes are
//! credited with unique bonds x steps, whatever their internal layout.

#[path = "support/lammps_block.rs"]
mod lammps_block;
#[path = "support/lammps_run.rs"]
mod lammps_run;
#[path = "support/step_timing.rs"]
mod step_timing;

#[path = "support/bond_timing.rs"]
mod bond_timing;

use bond_timing::{config, time_one_and_all, time_ours};
use shatter_core::NoProgress;
use shatter_core::config::PipelineConfig;

/// The benchmark's block: `side`^3 cubes of 1 mm at N = 3, under `rules`.
fn block(side: usize, rules: &str) -> PipelineConfig {
    let size = side as f64 * 0.001;
    config(
        &format!(
            "source = \"box\"\nbox_size_m = [{size}, {size}, {size}]\nsampler = \"grid\"\n\
             spacing_m = 0.001\nhorizon_factor = 3.0"
        ),
        rules,
    )
}

/// LAMMPS's loop time for the same block, if `lmp` runs.
fn time_lammps(side: usize, steps: usize) -> Option<f64> {
    let c = 18.0 * 14.9e9 / (std::f64::consts::PI * 0.003f64.powi(4));
    let pair = format!("pair_style peri/pmb\npair_coeff * * {c:e} 0.0030001 0.0003153 0.25");
    lammps_run::loop_time_s(&lammps_block::block_input(side, &pair, 1.1920928955078125e-07, steps), "pmb")
}

fn main() {
    let mut args = std::env::args().skip(1).filter_map(|arg| arg.parse::<usize>().ok());
    let steps = args.next().unwrap_or(100);
    let side = args.next().unwrap_or(49);
    let levine = block(side, "levine");
    let particles = shatter_preprocess::preprocess(&levine, &NoProgress).expect("preprocess").particles;
    let bonds = particles.bonds.unique_count();
    let updates = (bonds * steps) as f64;
    println!(
        "bond updates: {} particles ({side}^3), {bonds} bonds at N = 3, {steps} steps; a bond update = one bond, one step",
        particles.len()
    );
    let one = time_one_and_all(&levine, &particles, steps, updates);
    let lammps_rules = block(side, "lammps");
    let rules_one = time_ours(&lammps_rules, &particles, steps, 1);
    println!(
        "  shatter CPU, LAMMPS rules, 1 thread: {rules_one:7.2} s  {:8.1} M bond updates/s per core",
        updates / rules_one / 1e6
    );
    match time_lammps(side, steps) {
        Some(lammps) => {
            println!(
                "  LAMMPS peri/pmb, 1 core: {lammps:7.2} s  {:8.1} M bond updates/s per core",
                updates / lammps / 1e6
            );
            println!("  per-core ratio, shatter 1 thread / LAMMPS: {:.1}x", lammps / one);
            println!("  per-core ratio under LAMMPS's rules, shatter 1 thread / LAMMPS: {:.1}x", lammps / rules_one);
        }
        None => println!("  LAMMPS (lmp) not found: install Debian's `lammps` package to compare"),
    }
}
