//! Benchmark: bond updates per second per core of the elastoplastic model on a 47^3 block
//! (103,823 particles) at N = 2.5, elastic and with plasticity, beside LAMMPS's
//! `pair_style peri/lps` and `peri/eps` on the same lattice, horizon and step count when `lmp` is
//! installed (Debian package `lammps`).
//!
//! `cargo bench -p shatter-sim --bench elastoplastic_updates [-- STEPS [SIDE]]` (defaults 20 and
//! 47). A bond update is one bond's work in one step (both its families' force scalars, the break
//! test, the force); both codes are credited with unique bonds x steps.

#[path = "support/lammps_block.rs"]
mod lammps_block;
#[path = "support/lammps_run.rs"]
mod lammps_run;
#[path = "support/step_timing.rs"]
mod step_timing;

use std::path::Path;

use shatter_core::NoProgress;
use shatter_core::config::PipelineConfig;

/// Glass-like moduli: K = 60 GPa, mu = 27.7 GPa (E = 72 GPa, nu = 0.3).
const BULK_PA: f64 = 60e9;
const SHEAR_PA: f64 = 27.692307692307693e9;
/// The uniaxial yield stress of the plastic run, Pa.
const YIELD_PA: f64 = 1e8;

fn config(side: usize, plastic: bool) -> PipelineConfig {
    let size = side as f64 * 0.001;
    let yield_key = if plastic { format!("yield_stress_pa = {YIELD_PA:e}") } else { String::new() };
    let text = format!(
        r#"
[scene]
name = "bench"
output_dir = "out"
seed = 1
[geometry]
source = "box"
box_size_m = [{size}, {size}, {size}]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 2.5
[material]
model = "elastoplastic"
density_kg_m3 = 2200.0
bulk_modulus_pa = {BULK_PA:e}
shear_modulus_pa = {SHEAR_PA:e}
critical_stretch = 0.01
{yield_key}
[sim]
gravity_m_s2 = [0.0, 0.0, 0.0]
dt_s = 4e-8
"#
    );
    PipelineConfig::from_toml_str(&text, Path::new("/nonexistent/pipeline.toml")).expect("valid config")
}

/// Seconds for `steps` steps on `threads` threads: the median of single steps, scaled.
fn time_ours(config: &PipelineConfig, particles: &shatter_core::ParticleSet, steps: usize, threads: usize) -> f64 {
    step_timing::time_steps(config, particles, (steps, 1), threads, |_| {})
}

/// LAMMPS's loop time for the same block with `pair_style` `style` (`peri/lps` or `peri/eps`), if
/// `lmp` runs.
fn time_lammps(side: usize, steps: usize, style: &str) -> Option<f64> {
    // pair_coeff: bulk, shear, horizon, s00, alpha (and, for eps, the yield stress)
    let yield_stress = if style == "peri/eps" { format!(" {YIELD_PA:e}") } else { String::new() };
    let pair = format!("pair_style {style}\npair_coeff * * {BULK_PA:e} {SHEAR_PA:e} 0.0025001 0.01 0.0{yield_stress}");
    lammps_run::loop_time_s(&lammps_block::block_input(side, &pair, 4e-8, steps), &style.replace('/', "-"))
}

fn main() {
    let mut args = std::env::args().skip(1).filter_map(|arg| arg.parse::<usize>().ok());
    let steps = args.next().unwrap_or(20);
    let side = args.next().unwrap_or(47);
    let elastic = config(side, false);
    let particles = shatter_preprocess::preprocess(&elastic, &NoProgress).expect("preprocess").particles;
    let bonds = particles.bonds.unique_count();
    let updates = (bonds * steps) as f64;
    let cores = rayon::current_num_threads();
    println!(
        "elastoplastic bond updates: {} particles ({side}^3), {bonds} bonds at N = 2.5, {steps} steps",
        particles.len()
    );
    let rate = |seconds: f64| updates / seconds / 1e6;
    let one = time_ours(&elastic, &particles, steps, 1);
    println!("  shatter CPU, elastic, 1 thread:   {one:7.2} s  {:7.1} M bond updates/s per core", rate(one));
    let all = time_ours(&elastic, &particles, steps, cores);
    println!(
        "  shatter CPU, elastic, {cores} threads:  {all:7.2} s  {:7.1} M bond updates/s ({:.1} per core)",
        rate(all),
        rate(all) / cores as f64
    );
    let plastic = config(side, true);
    let plastic_one = time_ours(&plastic, &particles, steps, 1);
    println!(
        "  shatter CPU, plastic, 1 thread:   {plastic_one:7.2} s  {:7.1} M bond updates/s per core",
        rate(plastic_one)
    );
    for (style, ours) in [("peri/lps", one), ("peri/eps", plastic_one)] {
        match time_lammps(side, steps, style) {
            Some(lammps) => println!(
                "  LAMMPS {style}, 1 core:  {lammps:7.2} s  {:7.1} M bond updates/s per core; per-core ratio {:.1}x",
                rate(lammps),
                lammps / ours
            ),
            None => {
                println!("  LAMMPS {style}: lmp not found or failed (install Debian's `lammps` package to compare)")
            }
        }
    }
    // the paper's Table 1: 50M bonds in 2.4 s per step on a 6-core i7-5930K
    let paper = 50e6 / 2.4 / 1e6;
    println!("  Chen et al., Table 1: {paper:.1} M bond updates/s on 6 cores ({:.1} per core)", paper / 6.0);
}
