//! The `tet_shell` sampler end to end, through `preprocess()`: layer points at their depth and
//! never too close, tets positively oriented as stored, face adjacency symmetric and complete, tet
//! volumes adding up to the shell's volume (computed independently from the distance field) on
//! the vase and bob, and the Welsh dragon coming through in one piece.
//!
//! Run with `--nocapture` to see the measured figures.

use std::collections::HashMap;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;
use robust::{Coord3D, orient3d};
use shatter_core::NoProgress;
use shatter_core::config::PipelineConfig;
use shatter_core::particles::{Elements, ParticleSet};
use shatter_core::random::{SplitMix64, splitmix64};
use shatter_geometry::PointKdTree;
use shatter_geometry::mesh::TriangleMesh;
use shatter_preprocess::inside::{FillRule, inside_cells};
use shatter_preprocess::lattice::Lattice;
use shatter_preprocess::mesh_query::MeshQuery;
use shatter_preprocess::samplers::tet_shell::{CORE, ShellParams, shell_points};
use shatter_preprocess::{Preprocessed, preprocess};
use support::load;

use crate::support;

/// A tet_shell scene of `mesh` with extra `[geometry]` lines and `[geometry.tet_shell]` lines.
fn config(mesh: &str, spacing: f64, horizon: f64, geometry: &str, shell: &str) -> PipelineConfig {
    support::mesh_config("tet_shell", mesh, spacing, horizon, 7, geometry, shell)
}

fn coord(p: [f32; 3]) -> Coord3D<f64> {
    Coord3D { x: p[0] as f64, y: p[1] as f64, z: p[2] as f64 }
}

/// Figures of a checked tet particle set.
#[derive(Debug)]
struct Figures {
    particles: usize,
    volume: f64,
    min_bonds: u64,
    max_bonds: u64,
    mean_bonds: f64,
    closest_pair: f64,
}

/// Checks the structural promises of a tet particle set: the format's rules, every stored tet
/// positively oriented (exactly) with the particle at its barycentre, the face adjacency exactly
/// the pairs of stored tets sharing a face, each pair once, no face shared by three tets, and the
/// particles in a spatially coherent order.
fn check_tets(name: &str, set: &ParticleSet) -> Figures {
    set.validate().expect("the particle set follows the format's rules");
    let Elements::Tets { vertices_m } = &set.elements else { panic!("{name}: not tets") };
    assert_eq!(vertices_m.len(), set.len());
    let lambda = set.meta.lambda_m;
    for (i, tet) in vertices_m.iter().enumerate() {
        let [a, b, c, d] = tet.map(coord);
        assert!(orient3d(a, b, c, d) > 0.0, "{name}: tet {i} is inverted or flat as stored: {tet:?}");
        assert!(set.volume_m3[i] > 0.0);
        let centre = tet.iter().fold(DVec3::ZERO, |sum, p| sum + DVec3::from_array(p.map(f64::from))) * 0.25;
        let position = DVec3::from_array(set.rest_position_m[i].map(f64::from));
        let rounding = 1e-6 * (lambda + position.abs().max_element());
        assert!(centre.distance(position) < rounding, "{name}: particle {i} is not at its tet's barycentre");
    }
    // Faces by their corners' bits (sorted): shared by at most two tets, and then adjacent.
    let mut faces: HashMap<[[u32; 3]; 3], Vec<u32>> = HashMap::new();
    for (i, tet) in vertices_m.iter().enumerate() {
        for skip in 0..4 {
            let mut face: Vec<[u32; 3]> = (0..4).filter(|&k| k != skip).map(|k| tet[k].map(f32::to_bits)).collect();
            face.sort_unstable();
            faces.entry([face[0], face[1], face[2]]).or_default().push(i as u32);
        }
    }
    let mut shared: Vec<[u32; 2]> = Vec::new();
    for tets in faces.values() {
        assert!(tets.len() <= 2, "{name}: a face is shared by {} tets", tets.len());
        if let [a, b] = tets[..] {
            shared.push([a.min(b), a.max(b)]);
        }
    }
    shared.sort_unstable();
    assert!(set.adjacency.windows(2).all(|pair| pair[0] < pair[1]), "{name}: adjacency sorted and unique");
    assert!(set.adjacency.iter().all(|[a, b]| a < b));
    assert_eq!(set.adjacency, shared, "{name}: adjacency is exactly the tets sharing a face");
    // Symmetric: every pair seen from both of its tets.
    let mut degree = vec![0u32; set.len()];
    let mut listed: Vec<[u32; 2]> = Vec::new();
    for &[a, b] in &set.adjacency {
        degree[a as usize] += 1;
        degree[b as usize] += 1;
        listed.push([b, a]);
    }
    listed.sort_unstable();
    for &[b, a] in &listed {
        assert!(set.adjacency.binary_search(&[a, b]).is_ok());
    }
    assert!(degree.iter().all(|d| *d <= 4), "{name}: a tet has more than four face neighbours");

    let positions: Vec<DVec3> = set.rest_position_m.iter().map(|p| DVec3::from_array(p.map(f64::from))).collect();
    let step: f64 = positions.windows(2).map(|pair| pair[0].distance(pair[1])).sum::<f64>() / set.len() as f64;
    assert!(step < 2.0 * lambda, "{name}: consecutive particles are {step:e} m apart on average: not in Z-order");
    let closest = closest_pair(&positions, lambda);

    let summary = set.summary();
    Figures {
        particles: set.len(),
        volume: set.volume_m3.iter().map(|v| *v as f64).sum(),
        min_bonds: summary.bonds_per_particle.min,
        max_bonds: summary.bonds_per_particle.max,
        mean_bonds: summary.bonds_per_particle.mean,
        closest_pair: closest,
    }
}

/// The smallest distance between two of `points` (searched within `reach`).
fn closest_pair(points: &[DVec3], reach: f64) -> f64 {
    let tree = PointKdTree::new(points);
    (0..points.len())
        .into_par_iter()
        .map_init(Vec::new, |found, i| {
            found.clear();
            tree.within(points[i], reach * reach, found);
            found
                .iter()
                .filter(|&&j| j as usize != i)
                .map(|&j| points[i].distance(points[j as usize]))
                .fold(reach, f64::min)
        })
        .reduce(|| reach, f64::min)
}

/// The volume of the part of the mesh deeper than `depth`, by the midpoint rule on a lattice of
/// cells of side `cell`: cells whose centre is inside (by the lattice inside test) and farther
/// than `depth` from the surface.
fn volume_deeper_than(mesh: &TriangleMesh, query: &MeshQuery, depth: f64, cell: f64) -> f64 {
    let (lo, hi) = mesh.bounds();
    let lattice = Lattice::covering(lo, hi, cell);
    let inside = inside_cells(mesh, &lattice, FillRule::NonZero).inside;
    let count = (0..lattice.cell_count())
        .into_par_iter()
        .filter(|&c| inside[c] && query.distance(lattice.centre(lattice.cell(c))) > depth)
        .count();
    count as f64 * cell.powi(3)
}

/// Preprocesses a tet_shell scene, checks it, and compares its volume with the shell's.
fn check_shell(name: &str, scale: f64, config: &PipelineConfig, cell: f64, tolerance: f64) -> (Figures, Preprocessed) {
    let started = Instant::now();
    let result = preprocess(config, &NoProgress).expect("preprocess");
    let elapsed = started.elapsed();
    for note in &result.notes {
        eprintln!("{name}: note: {note}");
    }
    let figures = check_tets(name, &result.particles);
    let mesh = load(name, scale);
    let query = MeshQuery::new(&mesh);
    let geometry = &config.geometry;
    let depth = f64::from(geometry.tet_shell_layers() - 1) * geometry.tet_shell_layer_spacing_m();
    let core = if geometry.tet_shell.filled_core { 0.0 } else { volume_deeper_than(&mesh, &query, depth, cell) };
    let shell = mesh.signed_volume() - core;
    let error = figures.volume / shell - 1.0;
    eprintln!(
        "{name}: {} tets in {elapsed:.2?}; volume {:.6e} against shell {shell:.6e} (mesh {:.6e}, core {core:.6e}): \
         error {:+.3}%; bonds per particle {} to {} (mean {:.1}); closest barycentres {:.3e} m = {:.4} lambda",
        figures.particles,
        figures.volume,
        mesh.signed_volume(),
        100.0 * error,
        figures.min_bonds,
        figures.max_bonds,
        figures.mean_bonds,
        figures.closest_pair,
        figures.closest_pair / result.particles.meta.lambda_m,
    );
    assert!(error.abs() < tolerance, "{name}: the tets' volume misses the shell's by {:.3}%", 100.0 * error);
    (figures, result)
}

#[test]
fn the_vase_shell_has_the_shells_volume() {
    // The wall is about 5.6 mm thick: layers 1.5 mm apart leave room for two under each side.
    let config = config("smooth_vase.obj", 0.004, 2.0, "", "layer_spacing_m = 0.0015");
    let (figures, _) = check_shell("smooth_vase.obj", 1.0, &config, 0.001, 0.02);
    assert!(figures.particles > 50_000);
}

#[test]
fn the_bob_shell_has_the_shells_volume() {
    let config = config("bob_tri.obj", 0.03, 2.0, "", "");
    let (figures, result) = check_shell("bob_tri.obj", 1.0, &config, 0.005, 0.02);
    assert!(figures.min_bonds > 0, "every tet is bonded");
    // The layers' default: six (the paper's vase) at N = 2.
    let meta = &result.particles.meta;
    assert_eq!(meta.sampler, "tet_shell");
    assert_eq!(meta.lambda_m, 0.03);
    assert!((meta.delta_m - 0.06).abs() < 1e-15);
}

#[test]
fn a_filled_bob_has_the_meshs_volume() {
    let config = config("bob_tri.obj", 0.04, 3.0, "", "layers = 3\nfilled_core = true");
    check_shell("bob_tri.obj", 1.0, &config, 0.01, 0.02);
}

#[test]
fn the_welsh_dragon_comes_through() {
    // Millimetres to metres; about 68 x 155 x 124 mm.
    let config = config(
        "welsh_dragon.obj",
        0.0025,
        2.0,
        "[geometry.transform]\nscale = 0.001\nrecenter = false\nrotate_deg = [-90.0, 0.0, 0.0]\ntranslate_m = [0.0, 0.5, 0.0]",
        "layers = 4",
    );
    let (figures, result) = check_shell("welsh_dragon.obj", 0.001, &config, 0.001, 0.05);
    assert!(figures.particles > 10_000);
    assert!(figures.min_bonds > 0 || figures.mean_bonds > 10.0);
    assert!(result.mesh_report.is_some());
}

/// Layer points: at their layer's depth, inside, at least the spacing apart within a layer and the
/// layer spacing across layers, and covering each layer (every point of the surface near a
/// surface sample).
#[test]
fn layer_points_keep_their_distances_and_cover_the_layers() {
    let mesh = load("bob_tri.obj", 1.0);
    let query = MeshQuery::new(&mesh);
    let params = ShellParams {
        spacing: 0.03,
        layers: 4,
        layer_spacing: 0.02,
        filled_core: true,
        seed: 3,
        keep_thick_surface_tets: true,
    };
    let shell = shell_points(&mesh, &query, &params).expect("points");
    for (p, &layer) in shell.points.iter().zip(&shell.layer) {
        let depth = query.distance(*p);
        if layer == CORE {
            assert!(depth >= 0.08 && query.contains(*p));
        } else {
            assert!((depth - 0.02 * f64::from(layer)).abs() <= 1e-9 * 0.02, "layer {layer} point at depth {depth}");
            assert!(layer == 0 || query.contains(*p));
        }
    }
    let tree = PointKdTree::new(&shell.points);
    let mut found = Vec::new();
    let mut closest_same = f64::INFINITY;
    let mut closest_across = f64::INFINITY;
    for (i, p) in shell.points.iter().enumerate() {
        found.clear();
        tree.within(*p, 0.045 * 0.045, &mut found);
        for &j in found.iter().filter(|&&j| j as usize != i) {
            let distance = p.distance(shell.points[j as usize]);
            if shell.layer[i] == shell.layer[j as usize] {
                closest_same = closest_same.min(distance);
            } else {
                closest_across = closest_across.min(distance);
            }
        }
    }
    eprintln!(
        "bob layers: {:?} points, core {}; closest in a layer {:.5} r, across layers {:.5} h",
        shell.per_layer,
        shell.core,
        closest_same / 0.03,
        closest_across / 0.02
    );
    assert!(closest_same >= 0.03);
    assert!(closest_across >= 0.02 * (1.0 - 2e-9));

    // Coverage of the surface layer: random surface points and their nearest surface sample.
    let surface: Vec<DVec3> =
        shell.points.iter().zip(&shell.layer).filter(|(_, l)| **l == 0).map(|(p, _)| *p).collect();
    let tree = PointKdTree::new(&surface);
    let areas: Vec<f64> = (0..mesh.triangles.len())
        .map(|t| {
            let [a, b, c] = mesh.corners(t);
            (b - a).cross(c - a).length() * 0.5
        })
        .collect();
    let total: f64 = areas.iter().sum();
    let mut rng = SplitMix64::new(splitmix64(99));
    let mut farthest: f64 = 0.0;
    for (t, area) in areas.iter().enumerate() {
        let [a, b, c] = mesh.corners(t);
        let draws = (area / total * 200_000.0).ceil() as usize;
        for _ in 0..draws {
            let (s, u) = (rng.next_f64().sqrt(), rng.next_f64());
            let p = a * (1.0 - s) + b * (s * (1.0 - u)) + c * (s * u);
            let mut radius = 0.03;
            loop {
                found.clear();
                tree.within(p, radius * radius, &mut found);
                if !found.is_empty() {
                    break;
                }
                radius *= 1.1;
            }
            let nearest = found.iter().map(|&j| p.distance(surface[j as usize])).fold(f64::INFINITY, f64::min);
            farthest = farthest.max(nearest);
        }
    }
    eprintln!("bob surface: every sampled point within {:.3} r of a layer point", farthest / 0.03);
    assert!(farthest < 1.6 * 0.03, "a gap of {farthest} on the surface layer");
}

#[test]
fn the_same_scene_gives_the_same_particles_on_any_thread_count() {
    let config = config("spot_triangulated.obj", 0.05, 2.0, "", "layers = 3");
    let a = preprocess(&config, &NoProgress).expect("preprocess").particles;
    let b = preprocess(&config, &NoProgress).expect("preprocess").particles;
    assert_eq!(a, b);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a one-thread pool");
    let single = pool.install(|| preprocess(&config, &NoProgress).expect("preprocess").particles);
    assert_eq!(a, single, "the result does not depend on the thread count");
    check_tets("spot_triangulated.obj", &a);
}
