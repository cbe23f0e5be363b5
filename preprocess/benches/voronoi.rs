//! Benchmark: the geometry of the voronoi sampler on real meshes.
//!
//! `cargo bench -p shatter-preprocess --bench voronoi` times, for the repaired Welsh dragon at
//! 10,000 cells and bob at 50,000, each phase: loading and repairing the mesh, building the
//! [`MeshQuery`], Poisson disk sampling to the target count (the count search runs the sampler up
//! to three times; one run at the final distance is timed on its own too) and clipping the Voronoi
//! cells. It also prints how well the cells' volumes and surface areas add up to the mesh's.

use std::path::Path;
use std::time::Instant;

use glam::DVec3;
use shatter_geometry::mesh::TriangleMesh;
use shatter_preprocess::clipped_voronoi::clipped_voronoi;
use shatter_preprocess::mesh_query::MeshQuery;
use shatter_preprocess::repair::repair;
use shatter_preprocess::samplers::blue_noise::{poisson_disk, poisson_disk_with_count};

fn main() {
    println!("Voronoi sampler benchmark, {} threads available", rayon::current_num_threads());
    run("welsh_dragon.obj", 10_000);
    run("bob_tri.obj", 50_000);
}

fn run(name: &str, count: usize) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes").join(name);
    let started = Instant::now();
    let (mesh, stats) = TriangleMesh::load_obj(&path).expect("benchmark mesh loads");
    let (mesh, _) = repair(&mesh, stats, 1e-3);
    let loaded = seconds(started);

    let started = Instant::now();
    let query = MeshQuery::new(&mesh);
    let built = seconds(started);

    let volume = mesh.signed_volume();
    let started = Instant::now();
    let (min_distance, sites) = poisson_disk_with_count(&query, mesh.bounds(), volume, count, 1);
    let searched = seconds(started);
    let started = Instant::now();
    let again = poisson_disk(&query, mesh.bounds(), min_distance, 1);
    let sampled = seconds(started);
    assert_eq!(again, sites, "sampling is deterministic");

    let started = Instant::now();
    let voronoi = clipped_voronoi(&sites, &mesh, &query).expect("the diagram builds");
    let clipped = seconds(started);

    let cell_volume: f64 = voronoi.cells.iter().map(|cell| cell.volume).sum();
    let pieces: Vec<&[DVec3; 3]> = voronoi.cells.iter().flat_map(|cell| &cell.triangles).collect();
    let area: f64 = pieces.iter().map(|[a, b, c]| (*b - *a).cross(*c - *a).length() * 0.5).sum();
    println!(
        "{name}: {} triangles, {} sites (asked {count}), min distance {min_distance:.4e}",
        mesh.triangles.len(),
        sites.len()
    );
    println!("  load + repair   {loaded:7.3} s");
    println!("  MeshQuery build {built:7.3} s");
    println!("  Poisson, count  {searched:7.3} s (search for the distance)");
    println!("  Poisson, once   {sampled:7.3} s");
    println!("  clip cells      {clipped:7.3} s");
    println!(
        "  {} surface triangles, volume error {:.1e}, area error {:.1e}, {} adjacent pairs",
        pieces.len(),
        (cell_volume / volume - 1.0).abs(),
        (area / mesh.area() - 1.0).abs(),
        voronoi.adjacency.len()
    );
}

fn seconds(started: Instant) -> f64 {
    started.elapsed().as_secs_f64()
}
