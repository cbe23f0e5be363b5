//! The `voronoi` sampler end to end, through `preprocess()`, on the particle set as it is stored
//! (f32, world coordinates after the scene transform): cell volumes and surface pieces adding up to
//! the mesh's, particles at least lambda apart, each cell's planes bounding a convex polytope
//! around its site, adjacency symmetric and made of cells that share a face; bob, spot and the
//! Welsh dragon.
//!
//! Run with `--nocapture` to see the measured figures.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;
use shatter_core::NoProgress;
use shatter_core::config::PipelineConfig;
use shatter_core::particles::{Elements, ParticleSet};
use shatter_geometry::PointKdTree;
use shatter_geometry::mesh::TriangleMesh;
use shatter_preprocess::{PreprocessError, preprocess};
use support::{load, polytope_vertices};

use crate::support;

/// A voronoi scene of `mesh` with extra `[geometry]` lines (a transform) and `[geometry.voronoi]`
/// lines.
fn config(mesh: &str, spacing: f64, horizon: f64, geometry: &str, voronoi: &str) -> PipelineConfig {
    support::mesh_config("voronoi", mesh, spacing, horizon, 11, geometry, voronoi)
}

fn vec(p: [f32; 3]) -> DVec3 {
    DVec3::from_array(p.map(f64::from))
}

fn plane_normal(plane: &[f32; 4]) -> DVec3 {
    DVec3::new(plane[0] as f64, plane[1] as f64, plane[2] as f64)
}

/// Everything the stored set promises; returns (volume error, area error, stored triangles).
fn check_cells(name: &str, set: &ParticleSet, mesh: &TriangleMesh, polytopes: usize) -> (f64, f64, usize) {
    set.validate().expect("the particle set follows the format's rules");
    let Elements::Trimtopes { plane_offsets, planes, triangle_offsets, triangles_m, .. } = &set.elements else {
        panic!("{name}: not trimtopes")
    };
    let n = set.len();
    let lambda = set.meta.lambda_m;
    assert!((set.meta.delta_m / lambda - set.meta.horizon_factor).abs() < 1e-12);

    // Totals against the mesh's.
    let volume: f64 = set.volume_m3.iter().map(|v| *v as f64).sum();
    let area: f64 =
        triangles_m.par_iter().map(|[a, b, c]| (vec(*b) - vec(*a)).cross(vec(*c) - vec(*a)).length() * 0.5).sum();
    let volume_error = volume / mesh.signed_volume() - 1.0;
    let area_error = area / mesh.area() - 1.0;
    assert!(volume_error.abs() < 5e-3, "{name}: cell volumes miss the mesh's by {volume_error:e}");
    assert!(area_error.abs() < 1e-3, "{name}: surface pieces miss the mesh's area by {area_error:e}");
    assert!(triangles_m.len() >= mesh.triangles.len(), "{name}: the surface lost triangles");
    let masses_ok =
        set.mass_kg.iter().zip(&set.volume_m3).all(|(m, v)| (*m as f64 / (*v as f64 * 2000.0) - 1.0).abs() < 1e-6);
    assert!(masses_ok, "{name}: mass = density x volume");

    // No two particles closer than lambda, as stored.
    let positions: Vec<DVec3> = set.rest_position_m.iter().map(|p| vec(*p)).collect();
    let tree = PointKdTree::new(&positions);
    let closest = (0..n)
        .into_par_iter()
        .map_init(Vec::new, |found, i| {
            found.clear();
            tree.within(positions[i], 4.0 * lambda * lambda, found);
            found
                .iter()
                .filter(|&&j| j as usize != i)
                .map(|&j| positions[i].distance(positions[j as usize]))
                .fold(f64::INFINITY, f64::min)
        })
        .reduce(|| f64::INFINITY, f64::min);
    assert!(closest >= lambda, "{name}: two particles are {closest:e} apart, lambda = {lambda:e}");

    // Each cell: unit normals, its site strictly inside every plane, a bounded non-empty polytope
    // (checked for the first `polytopes` cells: vertex enumeration is cubic in the planes), its
    // surface pieces inside it.
    let scale = positions.iter().fold(0.0f64, |m, p| m.max(p.abs().max_element())) + lambda;
    let tolerance = 1e-5 * scale;
    let far = 100.0 * scale;
    (0..n).into_par_iter().for_each(|i| {
        let cell = &planes[plane_offsets[i] as usize..plane_offsets[i + 1] as usize];
        let site = positions[i];
        for plane in cell {
            let normal = plane_normal(plane);
            assert!((normal.length() - 1.0).abs() < 1e-6, "{name}: cell {i} has a plane without a unit normal");
            assert!(normal.dot(site) < plane[3] as f64 - 0.25 * lambda, "{name}: site {i} is not inside {plane:?}");
        }
        let pieces = &triangles_m[triangle_offsets[i] as usize..triangle_offsets[i + 1] as usize];
        for corner in pieces.iter().flatten() {
            let inside = cell.iter().all(|p| plane_normal(p).dot(vec(*corner)) <= p[3] as f64 + tolerance);
            assert!(inside, "{name}: a surface piece of cell {i} sticks out of it");
        }
        if i < polytopes {
            let mut bounded: Vec<[f64; 4]> = cell.iter().map(|p| p.map(f64::from)).collect();
            let box_planes = [
                [-1.0, 0.0, 0.0, far],
                [1.0, 0.0, 0.0, far],
                [0.0, -1.0, 0.0, far],
                [0.0, 1.0, 0.0, far],
                [0.0, 0.0, -1.0, far],
                [0.0, 0.0, 1.0, far],
            ];
            bounded.extend(box_planes);
            let vertices = polytope_vertices(&bounded, tolerance);
            assert!(vertices.len() >= 4, "{name}: cell {i} is empty");
            for plane in &box_planes {
                let on =
                    vertices.iter().any(|v| (DVec3::new(plane[0], plane[1], plane[2]).dot(*v) - plane[3]).abs() < 1.0);
                assert!(!on, "{name}: cell {i} is unbounded");
            }
            let centre = vertices.iter().sum::<DVec3>() / vertices.len() as f64;
            assert!(cell.iter().all(|p| plane_normal(p).dot(centre) <= p[3] as f64), "{name}: cell {i} is not convex");
        }
    });

    // Adjacency: sorted, unique, symmetric, between cells with opposite face planes.
    assert!(set.adjacency.windows(2).all(|pair| pair[0] < pair[1]), "{name}: adjacency sorted and unique");
    let mut reversed: Vec<[u32; 2]> = set.adjacency.iter().map(|&[a, b]| [b, a]).collect();
    reversed.sort_unstable();
    for &[b, a] in &reversed {
        assert!(a < b && set.adjacency.binary_search(&[a, b]).is_ok(), "{name}: adjacency is not symmetric");
    }
    set.adjacency.par_iter().for_each(|&[a, b]| {
        let cell = |k: u32| &planes[plane_offsets[k as usize] as usize..plane_offsets[k as usize + 1] as usize];
        let shared = cell(a)
            .iter()
            .any(|p| cell(b).iter().any(|q| (0..4).all(|k| (p[k] + q[k]).abs() <= 1e-5 * (1.0 + p[k].abs()))));
        assert!(shared, "{name}: adjacent cells {a} and {b} have no opposite face planes");
        let (pa, pb) = (positions[a as usize], positions[b as usize]);
        assert!(pa.distance(pb) <= set.meta.delta_m * (1.0 + 1e-6), "{name}: an adjacent pair is not a bond");
    });
    let step: f64 = positions.windows(2).map(|pair| pair[0].distance(pair[1])).sum::<f64>() / n as f64;
    assert!(step < 2.5 * lambda, "{name}: consecutive particles are {step:e} m apart on average: not in Z-order");

    let summary = set.summary();
    eprintln!(
        "{name}: {n} cells, lambda {lambda:.4e} m (closest pair {:.6} lambda); volume error {volume_error:+.2e}, area \
         error {area_error:+.2e}; {} surface triangles (mesh {}); bonds per particle {} to {} (mean {:.1}); {} \
         adjacent pairs ({:.2} per cell); mean step along the order {:.2} lambda",
        closest / lambda,
        triangles_m.len(),
        mesh.triangles.len(),
        summary.bonds_per_particle.min,
        summary.bonds_per_particle.max,
        summary.bonds_per_particle.mean,
        set.adjacency.len(),
        2.0 * set.adjacency.len() as f64 / n as f64,
        step / lambda,
    );
    (volume_error, area_error, triangles_m.len())
}

fn run(name: &str, scale: f64, config: &PipelineConfig, polytopes: usize) -> ParticleSet {
    let started = Instant::now();
    let result = preprocess(config, &NoProgress).expect("preprocess");
    eprintln!("{name}: preprocess() in {:.2?}", started.elapsed());
    for note in &result.notes {
        eprintln!("{name}: note: {note}");
    }
    check_cells(name, &result.particles, &load(name, scale), polytopes);
    result.particles
}

#[test]
fn bob_through_preprocess_rotated_and_moved() {
    let transform = "[geometry.transform]\nrotate_deg = [20.0, 35.0, -10.0]\ntranslate_m = [0.5, 1.0, -0.3]";
    let set = run("bob_tri.obj", 1.0, &config("bob_tri.obj", 0.07, 3.0, transform, ""), usize::MAX);
    assert_eq!(set.meta.lambda_m, 0.07);
    assert_eq!(set.meta.sampler, "voronoi");
}

#[test]
fn spot_through_preprocess_by_count_and_on_any_thread_count() {
    let set =
        run("spot_triangulated.obj", 1.0, &config("spot_triangulated.obj", 1.0, 2.0, "", "particles = 3000"), 500);
    assert!((set.len() as f64 / 3000.0 - 1.0).abs() < 0.05, "{} cells", set.len());
    let config = config("spot_triangulated.obj", 0.1, 2.0, "", "");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a one-thread pool");
    let single = pool.install(|| preprocess(&config, &NoProgress).expect("preprocess").particles);
    assert_eq!(preprocess(&config, &NoProgress).expect("preprocess").particles, single, "thread count matters");
}

#[test]
fn the_welsh_dragon_keeps_its_surface_at_ten_thousand_cells() {
    let transform = "[geometry.transform]\nscale = 0.001\nrotate_deg = [-90.0, 0.0, 0.0]";
    let set =
        run("welsh_dragon.obj", 0.001, &config("welsh_dragon.obj", 1.0, 3.0, transform, "particles = 10000"), 300);
    assert!((set.len() as f64 / 10_000.0 - 1.0).abs() < 0.05, "{} cells", set.len());
}

#[test]
fn a_spacing_too_fine_names_the_key() {
    let fine = preprocess(&config("spot_triangulated.obj", 1e-6, 2.0, "", ""), &NoProgress);
    match fine {
        // refused for its memory first, or by the blue-noise grid's size on a machine that has it
        Err(error @ PreprocessError::Setting { key: "geometry.spacing_m", .. }) => {
            assert!(error.to_string().contains("too fine"), "{error}");
        }
        Err(PreprocessError::Memory(error)) => assert!(error.keys.contains("geometry.spacing_m"), "{error}"),
        other => panic!("expected a spacing error, got {:?}", other.map(|r| r.particles.len())),
    }
}
