//! Benchmark: `preprocess()` with the mesh samplers at the paper's scales.
//!
//! `cargo bench -p shatter-preprocess --bench samplers [-- tet_shell [SPACING_M [LAYER_SPACING_M]]]`
//! runs the `tet_shell` sampler on `assets/meshes/smooth_vase.obj` (metres, N = 2, six layers;
//! default spacing 1.78 mm, layer spacing equal to it: about 640K tets, the paper's vase has
//! 637,027) and prints the time of each phase, the particle and bond counts, and the figures behind
//! the choice of lambda: the smallest distance between two barycentres, and how many bonds a
//! particle would have if lambda were that distance instead of the point spacing.
//!
//! `cargo bench -p shatter-preprocess --bench samplers -- voronoi [PARTICLES]` runs the `voronoi`
//! sampler on the Welsh dragon (millimetres to metres, N = 3; default 10,000 particles) and prints
//! the time of each phase and the counts. With no arguments both run.

use std::sync::Mutex;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;
use shatter_core::Progress;
use shatter_core::config::PipelineConfig;
use shatter_geometry::PointKdTree;
use shatter_preprocess::preprocess;

/// Prints each phase's wall time as it finishes.
struct Phases {
    current: Mutex<Option<(String, Instant)>>,
    started: Instant,
}

impl Progress for Phases {
    fn start(&self, phase: &str, _total: u64) {
        *self.current.lock().expect("lock") = Some((phase.to_string(), Instant::now()));
    }

    fn advance(&self, _units: u64) {}

    fn finish(&self) {
        if let Some((phase, started)) = self.current.lock().expect("lock").take() {
            println!(
                "  {phase:<14} {:8.2} s  (at {:7.2} s)",
                started.elapsed().as_secs_f64(),
                self.started.elapsed().as_secs_f64()
            );
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|arg| !arg.starts_with('-')).collect();
    let numbers: Vec<f64> = args.iter().skip(1).filter_map(|arg| arg.parse().ok()).collect();
    let which = args.first().map(String::as_str).unwrap_or("both");
    if which == "tet_shell" || which == "both" {
        let spacing = numbers.first().copied().unwrap_or(0.00178);
        tet_shell(spacing, numbers.get(1).copied().unwrap_or(spacing));
    }
    if which == "voronoi" || which == "both" {
        voronoi(numbers.first().copied().unwrap_or(10_000.0) as u64);
    }
}

fn config(text: &str) -> PipelineConfig {
    let base = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/pipeline.toml");
    PipelineConfig::from_toml_str(text, &base).expect("benchmark config is valid")
}

/// Runs `preprocess()`, printing each phase; returns the result and the whole time.
fn run(config: &PipelineConfig) -> (shatter_preprocess::Preprocessed, f64) {
    let phases = Phases { current: Mutex::new(None), started: Instant::now() };
    let result = preprocess(config, &phases).expect("preprocess");
    let total = phases.started.elapsed().as_secs_f64();
    for note in &result.notes {
        println!("  note: {note}");
    }
    let set = &result.particles;
    let summary = set.summary();
    println!(
        "  total          {total:8.2} s: {} particles, {} bonds ({} to {} per particle, mean {:.1}), {} adjacent pairs",
        set.len(),
        summary.bonds,
        summary.bonds_per_particle.min,
        summary.bonds_per_particle.max,
        summary.bonds_per_particle.mean,
        summary.adjacency_edges
    );
    (result, total)
}

fn voronoi(particles: u64) {
    println!(
        "voronoi benchmark: welsh_dragon.obj (1/1000), {particles} particles, N = 3, {} threads",
        rayon::current_num_threads()
    );
    let config = config(&format!(
        r#"
[scene]
name = "dragon"
output_dir = "out"
seed = 1
[geometry]
source = "meshes/welsh_dragon.obj"
sampler = "voronoi"
spacing_m = 0.001
horizon_factor = 3.0
[geometry.transform]
scale = 0.001
[geometry.voronoi]
particles = {particles}
[material]
density_kg_m3 = 2000.0
bulk_modulus_pa = 2.94e9
critical_stretch = 0.001
"#
    ));
    let (result, _) = run(&config);
    if let shatter_core::particles::Elements::Trimtopes { planes, triangles_m, .. } = &result.particles.elements {
        println!("  {} planes, {} surface triangles", planes.len(), triangles_m.len());
    }
}

fn tet_shell(spacing: f64, layer_spacing: f64) {
    println!(
        "tet_shell benchmark: smooth_vase.obj, spacing {spacing} m, layer spacing {layer_spacing} m, N = 2, {} threads",
        rayon::current_num_threads()
    );
    let text = format!(
        r#"
[scene]
name = "vase"
output_dir = "out"
seed = 1
[geometry]
source = "meshes/smooth_vase.obj"
sampler = "tet_shell"
spacing_m = {spacing}
horizon_factor = 2.0
[geometry.tet_shell]
layer_spacing_m = {layer_spacing}
[material]
density_kg_m3 = 2000.0
bulk_modulus_pa = 2.94e9
critical_stretch = 0.001
"#
    );
    let (result, _) = run(&config(&text));
    let set = &result.particles;
    let volume: f64 = set.volume_m3.iter().map(|v| *v as f64).sum();
    println!("  tet volume {volume:.6e} m^3");

    // lambda: the point spacing (used) against the smallest distance between barycentres.
    let points: Vec<DVec3> = set.rest_position_m.iter().map(|p| DVec3::from_array(p.map(f64::from))).collect();
    let tree = PointKdTree::new(&points);
    let nearest: Vec<f64> = (0..points.len())
        .into_par_iter()
        .map_init(Vec::new, |found, i| {
            found.clear();
            tree.within(points[i], spacing * spacing, found);
            found
                .iter()
                .filter(|&&j| j as usize != i)
                .map(|&j| points[i].distance(points[j as usize]))
                .fold(spacing, f64::min)
        })
        .collect();
    let closest = nearest.iter().copied().fold(f64::INFINITY, f64::min);
    let mut sorted = nearest.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let delta = 2.0 * closest;
    let bonds: usize = (0..points.len())
        .into_par_iter()
        .map_init(Vec::new, |found, i| {
            found.clear();
            tree.within(points[i], delta * delta, found);
            found.len() - 1
        })
        .sum();
    println!(
        "  nearest barycentre: smallest {closest:.4e} m = {:.4} spacing, median {median:.4e} m = {:.3} spacing",
        closest / spacing,
        median / spacing
    );
    println!(
        "  with lambda = the smallest barycentre distance: delta = {delta:.4e} m, {:.3} bonds per particle",
        bonds as f64 / points.len() as f64
    );
}
