//! Benchmark: 3D Delaunay tetrahedralization of 200,000 points (target: under 20 s on 2 cores).
//!
//! `cargo bench -p shatter-preprocess --bench delaunay [-- COUNT]` triangulates COUNT points
//! (default 200,000) in three layouts and prints the time of each, the tet count and the gap
//! between the tets' total volume and the volume their hull faces enclose:
//!
//! - uniform random points in a cube;
//! - nested spherical shells, each sampled independently with near-uniform spacing;
//! - offset shells: one near-uniform sampling of a sphere repeated on concentric layers, so points
//!   line up along radii (as offsetting a surface mesh along its normals does), which makes many
//!   nearly coplanar and cospherical groups.
//!
//! With `--points-dir DIR` it also writes each layout's points to `DIR/<layout>.f64` (x, y, z as
//! little-endian f64), so that `scripts/peers/delaunay_peers.py` can time qhull and TetGen on the
//! same points (`scripts/compare-peers.sh` does both).

use std::time::Instant;

use glam::DVec3;
use shatter_preprocess::delaunay::{NO_NEIGHBOR, Tetrahedralization, tet_volume, tetrahedralize};

/// Concentric layers, spaced like the points within them.
const LAYERS: usize = 10;
const LAYER_SPACING: f64 = 0.0225;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let count: usize = args.iter().find_map(|arg| arg.parse().ok()).unwrap_or(200_000);
    let points_dir = args.iter().position(|a| a == "--points-dir").and_then(|k| args.get(k + 1));
    println!("Delaunay benchmark: {count} points per layout, {} threads available", rayon::current_num_threads());
    for (name, points) in [
        ("random cube", random_cube(count)),
        ("nested shells", nested_shells(count)),
        ("offset shells", offset_shells(count)),
    ] {
        if let Some(dir) = points_dir {
            let bytes: Vec<u8> = points.iter().flat_map(|p| p.to_array()).flat_map(f64::to_le_bytes).collect();
            let path = std::path::Path::new(dir).join(format!("{}.f64", name.replace(' ', "_")));
            std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        }
        run(name, &points);
    }
}

fn run(name: &str, points: &[DVec3]) {
    let started = Instant::now();
    let tri = tetrahedralize(points).expect("benchmark points triangulate");
    let seconds = started.elapsed().as_secs_f64();
    let (tets, hull) = volumes(points, &tri);
    println!(
        "  {name:>14}: {seconds:6.2} s, {:8.0} points/s, {} tets ({:.2} per point), volume gap {:.1e}",
        points.len() as f64 / seconds,
        tri.tets.len(),
        tri.tets.len() as f64 / points.len() as f64,
        (tets - hull).abs() / hull,
    );
}

/// The tets' total volume, and the volume the hull faces enclose (divergence theorem).
fn volumes(points: &[DVec3], tri: &Tetrahedralization) -> (f64, f64) {
    let tets = tri.tets.iter().map(|&tet| tet_volume(points, tet)).sum();
    let mut hull = 0.0;
    for (tet, neighbors) in tri.tets.iter().zip(&tri.neighbors) {
        for k in (0..4).filter(|&k| neighbors[k] == NO_NEIGHBOR) {
            // The tet with its vertex k moved to the origin: its signed volume is the cone's.
            let mut cone = tet.map(|i| points[i as usize]);
            cone[k] = DVec3::ZERO;
            let [a, b, c, d] = cone;
            hull += (a - d).dot((b - d).cross(c - d)) / 6.0;
        }
    }
    (tets, hull)
}

/// SplitMix64 (deterministic).
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn random_cube(count: usize) -> Vec<DVec3> {
    let mut rng = Rng(1);
    (0..count).map(|_| DVec3::new(rng.unit(), rng.unit(), rng.unit())).collect()
}

/// Near-uniform points on the unit sphere (Fibonacci spiral), turned by `twist` radians.
fn fibonacci_sphere(count: usize, twist: f64) -> impl Iterator<Item = DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count).map(move |i| {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
        let r = (1.0 - z * z).sqrt();
        let phi = golden * i as f64 + twist;
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    })
}

fn radius(layer: usize) -> f64 {
    1.0 - LAYER_SPACING * layer as f64
}

/// Layers sampled independently, with point counts proportional to their areas.
fn nested_shells(count: usize) -> Vec<DVec3> {
    let areas: f64 = (0..LAYERS).map(|l| radius(l).powi(2)).sum();
    let mut points = Vec::with_capacity(count);
    for layer in 0..LAYERS {
        let remaining = count - points.len();
        let share =
            if layer + 1 == LAYERS { remaining } else { (count as f64 * radius(layer).powi(2) / areas) as usize };
        points.extend(fibonacci_sphere(share, layer as f64).map(|p| p * radius(layer)));
    }
    points
}

/// One sampling repeated on every layer, scaled: points line up along radii.
fn offset_shells(count: usize) -> Vec<DVec3> {
    let directions: Vec<DVec3> = fibonacci_sphere(count / LAYERS, 0.0).collect();
    (0..LAYERS).flat_map(|layer| directions.iter().map(move |&d| d * radius(layer))).collect()
}
