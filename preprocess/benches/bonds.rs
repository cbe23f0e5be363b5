//! Benchmark: bonds for a million grid particles at N = 3 (target: under 10 s on 2 cores).
//!
//! `cargo bench -p shatter-preprocess --bench bonds [-- SIDE]` fills a cube of SIDE^3 particles
//! (default 100, i.e. 1M) and prints the time of each phase and the bond throughput.

use std::time::Instant;

use shatter_core::NoProgress;
use shatter_preprocess::bonds::{BondParams, build_bonds};
use shatter_preprocess::samplers::grid::fill_box;

fn main() {
    let side: usize = std::env::args().skip(1).find_map(|arg| arg.parse().ok()).unwrap_or(100);
    let spacing = 0.001;
    let started = Instant::now();
    let (sample, _) = fill_box([side as f64 * spacing; 3], spacing).expect("lattice fits");
    let points = sample.points();
    let stored: Vec<[f32; 3]> = points.iter().map(|p| p.as_vec3().to_array()).collect();
    let lattice_s = started.elapsed().as_secs_f64();

    let params = BondParams { delta_m: 3.0 * spacing, mean_threshold: 3e-4, jitter: 0.02, seed: 1 };
    let started = Instant::now();
    let bonds = build_bonds(&points, &stored, &params, &NoProgress);
    let bonds_s = started.elapsed().as_secs_f64();

    let entries = bonds.neighbor.len();
    println!(
        "grid bonds benchmark: {} particles ({side}^3), N = 3, {} threads",
        points.len(),
        rayon::current_num_threads()
    );
    println!("  lattice + Morton order + adjacency: {lattice_s:.2} s");
    println!(
        "  bonds: {bonds_s:.2} s for {} unique bonds ({entries} CSR entries): {:.1} M entries/s",
        entries / 2,
        entries as f64 / bonds_s / 1e6
    );
}
