//! The geometry of the voronoi sampler on real meshes: blue-noise sites inside bob, spot and the
//! repaired Welsh dragon, cut into clipped Voronoi cells whose volumes and surface pieces add up
//! to the mesh's, with sound cell polytopes and face adjacency.
//!
//! Run with `--nocapture` to see the measured figures.

use std::collections::HashMap;
use std::time::Instant;

use glam::DVec3;
use shatter_geometry::PointKdTree;
use shatter_geometry::mesh::TriangleMesh;
use shatter_preprocess::clipped_voronoi::{ClippedVoronoi, bisector, clipped_voronoi};
use shatter_preprocess::mesh_query::MeshQuery;
use shatter_preprocess::samplers::blue_noise::poisson_disk_with_count;
use support::polytope_vertices;

use crate::support;

fn load(name: &str) -> TriangleMesh {
    support::load(name, 1.0)
}

/// Loads a mesh from the assets folder, dropping bodies under 0.1% of the largest's volume.
fn check_mesh(name: &str, count: usize, independent_checks: usize) {
    let started = Instant::now();
    let mesh = load(name);
    let loaded = started.elapsed();
    let query = MeshQuery::new(&mesh);
    let volume = mesh.signed_volume();
    let (min_distance, sites) = poisson_disk_with_count(&query, mesh.bounds(), volume, count, 11);
    let sampled = started.elapsed();
    let voronoi = clipped_voronoi(&sites, &mesh, &query).expect("the diagram builds");
    let clipped = started.elapsed();
    eprintln!(
        "{name}: {} triangles, {} sites (asked {count}) at r = {min_distance:.4e}; load {:.2?}, sample {:.2?}, clip {:.2?}",
        mesh.triangles.len(),
        sites.len(),
        loaded,
        sampled - loaded,
        clipped - sampled,
    );
    assert!((sites.len() as f64 / count as f64 - 1.0).abs() < 0.05);

    let closest = check_min_distance(&sites, min_distance);
    check_inside(&mesh, &query, &sites, independent_checks);
    let (volume_error, area_error) = totals_error(&mesh, &voronoi);
    eprintln!(
        "{name}: closest pair {:.6} r; volume error {volume_error:.2e}, area error {area_error:.2e}",
        closest / min_distance
    );
    assert!(volume_error < 5e-3, "{name}: cell volumes miss the mesh volume by {volume_error:e}");
    assert!(area_error < 1e-3, "{name}: cell surfaces miss the mesh area by {area_error:e}");
    assert!(voronoi.cells.iter().all(|cell| cell.volume > 0.0), "{name}: a cell around an inside site is empty");
    check_closed_cells(name, &voronoi);
    let vertices = check_polytopes(&mesh, &sites, &voronoi);
    check_adjacency(&mesh, &sites, &voronoi, &vertices);
    eprintln!("{name}: all checks in {:.2?}", started.elapsed());
}

fn triangle_area([a, b, c]: &[DVec3; 3]) -> f64 {
    (*b - *a).cross(*c - *a).length() * 0.5
}

/// Relative errors of the cells' total volume and total surface area against the mesh's.
fn totals_error(mesh: &TriangleMesh, voronoi: &ClippedVoronoi) -> (f64, f64) {
    let volume: f64 = voronoi.cells.iter().map(|cell| cell.volume).sum();
    let area: f64 = voronoi.cells.iter().flat_map(|cell| &cell.triangles).map(triangle_area).sum();
    ((volume / mesh.signed_volume() - 1.0).abs(), (area / mesh.area() - 1.0).abs())
}

/// Every cell alone, its surface pieces and the inside parts of all its faces, is a closed,
/// consistently oriented surface: each directed edge (by the exact bits of its ends) comes as
/// often as its reverse. (Post's pieces are closed when their cells are.) Where the surface
/// intersects itself, the cut curve crosses itself on a face; those faces were once left open.
fn check_closed_cells(name: &str, voronoi: &ClippedVoronoi) {
    let key = |p: DVec3| (p + DVec3::ZERO).to_array().map(f64::to_bits);
    let (mut open_cells, mut all_edges) = (Vec::new(), 0);
    for (index, cell) in voronoi.cells.iter().enumerate() {
        let mut net: HashMap<([u64; 3], [u64; 3]), i64> = HashMap::new();
        for t in cell.triangles.iter().chain(&cell.face_triangles) {
            for k in 0..3 {
                let (a, b) = (key(t[k]), key(t[(k + 1) % 3]));
                if a < b {
                    *net.entry((a, b)).or_default() += 1;
                } else if b < a {
                    *net.entry((b, a)).or_default() -= 1;
                }
            }
        }
        all_edges += net.len();
        let open = net.values().filter(|&&count| count != 0).count();
        if open > 0 {
            open_cells.push((index, open));
        }
    }
    eprintln!("  {all_edges} cell edges, open cells (cell, unmatched edges): {open_cells:?}");
    assert!(open_cells.is_empty(), "{name}: cells are not closed: {open_cells:?}");
}

/// No two sites closer than `min_distance` (the k-d tree's range query is inclusive); returns
/// the closest pair's distance.
fn check_min_distance(sites: &[DVec3], min_distance: f64) -> f64 {
    let tree = PointKdTree::new(sites);
    let mut found = Vec::new();
    let mut closest = f64::INFINITY;
    for (i, site) in sites.iter().enumerate() {
        found.clear();
        tree.within(*site, min_distance * min_distance, &mut found);
        assert_eq!(found, [i as u32], "site {i} has a neighbour within the minimum distance");
        found.clear();
        tree.within(*site, 4.0 * min_distance * min_distance, &mut found);
        for &j in found.iter().filter(|&&j| j as usize != i) {
            closest = closest.min(site.distance(sites[j as usize]));
        }
    }
    assert!(closest >= min_distance);
    closest
}

/// Every site inside by the exact test; `independent` of them (the nearest to the surface first)
/// also by the generalized winding number summed over all triangles.
fn check_inside(mesh: &TriangleMesh, query: &MeshQuery, sites: &[DVec3], independent: usize) {
    assert!(sites.iter().all(|site| query.contains(*site)), "a site is outside the mesh");
    let mut by_depth: Vec<(f64, DVec3)> = sites.iter().map(|site| (query.distance(*site), *site)).collect();
    by_depth.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (depth, site) in by_depth.iter().take(independent) {
        let winding = winding_number(mesh, *site);
        assert!((winding - 1.0).abs() < 1e-6, "site {site} ({depth:e} deep) has winding number {winding}");
    }
    eprintln!("  shallowest site {:.3e} deep (winding numbers checked for {independent})", by_depth[0].0);
}

/// The generalized winding number: the solid angle the surface subtends at `p` over 4 pi (Van
/// Oosterom and Strackee's formula per triangle).
fn winding_number(mesh: &TriangleMesh, p: DVec3) -> f64 {
    let solid_angle: f64 = (0..mesh.triangles.len())
        .map(|t| {
            let [a, b, c] = mesh.corners(t).map(|q| q - p);
            let (la, lb, lc) = (a.length(), b.length(), c.length());
            let numerator = a.dot(b.cross(c));
            let denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
            2.0 * numerator.atan2(denominator)
        })
        .sum();
    solid_angle / (4.0 * std::f64::consts::PI)
}

/// Points among `vertices` on a plane.
fn on_plane<'a>(vertices: &'a [DVec3], plane: &'a [f64; 4], tolerance: f64) -> impl Iterator<Item = DVec3> + 'a {
    let normal = DVec3::new(plane[0], plane[1], plane[2]);
    vertices.iter().copied().filter(move |v| (normal.dot(*v) - plane[3]).abs() <= tolerance)
}

/// The largest area of a triangle on three of `points` (zero when they are collinear).
fn spread(points: &[DVec3]) -> f64 {
    let Some(&first) = points.first() else { return 0.0 };
    let far = points.iter().copied().max_by(|a, b| a.distance(first).total_cmp(&b.distance(first))).unwrap_or(first);
    points.iter().map(|p| triangle_area(&[first, far, *p])).fold(0.0, f64::max)
}

/// Every cell: its site strictly inside every plane; its planes bound a non-empty, bounded
/// polytope (no vertex on a far box added around it), each plane a face of non-zero area; its
/// surface pieces inside it. Returns each cell's vertices.
fn check_polytopes(mesh: &TriangleMesh, sites: &[DVec3], voronoi: &ClippedVoronoi) -> Vec<Vec<DVec3>> {
    let (lo, hi) = mesh.bounds();
    let extent = (hi - lo).max_element();
    let tolerance = 1e-9 * extent;
    let far = 100.0 * extent;
    let far_box = [
        [-1.0, 0.0, 0.0, far - lo.x],
        [1.0, 0.0, 0.0, far + hi.x],
        [0.0, -1.0, 0.0, far - lo.y],
        [0.0, 1.0, 0.0, far + hi.y],
        [0.0, 0.0, -1.0, far - lo.z],
        [0.0, 0.0, 1.0, far + hi.z],
    ];
    let mut all_vertices = Vec::with_capacity(sites.len());
    for (index, (cell, site)) in voronoi.cells.iter().zip(sites).enumerate() {
        for plane in &cell.planes {
            let normal = DVec3::new(plane[0], plane[1], plane[2]);
            assert!((normal.length() - 1.0).abs() < 1e-12);
            assert!(normal.dot(*site) < plane[3] - tolerance, "cell {index}: the site is not inside {plane:?}");
        }
        let mut planes = cell.planes.clone();
        planes.extend(far_box);
        let vertices = polytope_vertices(&planes, tolerance);
        assert!(vertices.len() >= 4, "cell {index} is empty");
        for plane in &far_box {
            assert_eq!(on_plane(&vertices, plane, tolerance).count(), 0, "cell {index} is unbounded");
        }
        for plane in &cell.planes {
            let face: Vec<DVec3> = on_plane(&vertices, plane, tolerance).collect();
            assert!(spread(&face) > 0.0, "cell {index}: plane {plane:?} is not a face");
        }
        for corner in cell.triangles.iter().flatten() {
            assert!(cell.planes.iter().all(|p| DVec3::new(p[0], p[1], p[2]).dot(*corner) <= p[3] + tolerance));
        }
        all_vertices.push(vertices);
    }
    all_vertices
}

/// Adjacency sorted, unique, each pair (a < b) sharing a face: opposite bisector planes, each a
/// face of non-zero area of both cells.
fn check_adjacency(mesh: &TriangleMesh, sites: &[DVec3], voronoi: &ClippedVoronoi, vertices: &[Vec<DVec3>]) {
    assert!(voronoi.adjacency.windows(2).all(|pair| pair[0] < pair[1]), "adjacency is sorted and unique");
    let (lo, hi) = mesh.bounds();
    let tolerance = 1e-9 * (hi - lo).max_element();
    for &[a, b] in &voronoi.adjacency {
        assert!(a < b);
        let plane = bisector(sites, a, b);
        let opposite = plane.map(|x| -x);
        for (cell, face_plane) in [(a, plane), (b, opposite)] {
            assert!(voronoi.cells[cell as usize].planes.contains(&face_plane), "cells {a} and {b} share no face");
            let face: Vec<DVec3> = on_plane(&vertices[cell as usize], &face_plane, tolerance).collect();
            assert!(spread(&face) > 0.0, "cells {a} and {b} share a face without area");
        }
    }
    let degree = 2.0 * voronoi.adjacency.len() as f64 / voronoi.cells.len() as f64;
    eprintln!("  {} adjacent pairs ({degree:.2} per cell)", voronoi.adjacency.len());
}

#[test]
fn bob_is_cut_into_clipped_cells() {
    check_mesh("bob_tri.obj", 3000, 3000);
}

#[test]
fn spot_is_cut_into_clipped_cells() {
    check_mesh("spot_triangulated.obj", 3000, 3000);
}

#[test]
fn the_welsh_dragon_is_cut_into_ten_thousand_clipped_cells() {
    check_mesh("welsh_dragon.obj", 10_000, 60);
}
