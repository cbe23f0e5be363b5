//! Clipped Voronoi diagrams of cubes, octahedra and overlapping or hollow meshes: volumes and
//! areas adding up, adjacency, degenerate site layouts and bad input.

use glam::DVec3;
use shatter_core::random::SplitMix64;
use shatter_geometry::mesh::TriangleMesh;

use super::*;
use crate::mesh_query::MeshQuery;
use crate::test_meshes::{cube, octahedron};

/// `count` random points strictly inside the mesh.
fn random_sites(mesh: &TriangleMesh, count: usize, seed: u64) -> Vec<DVec3> {
    let query = MeshQuery::new(mesh);
    let (lo, hi) = mesh.bounds();
    let mut rng = SplitMix64::new(seed);
    let mut sites = Vec::new();
    while sites.len() < count {
        let p = lo + (hi - lo) * DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
        if query.contains(p) {
            sites.push(p);
        }
    }
    sites
}

fn diagram(mesh: &TriangleMesh, sites: &[DVec3]) -> ClippedVoronoi {
    clipped_voronoi(sites, mesh, &MeshQuery::new(mesh)).expect("the diagram builds")
}

fn triangle_area([a, b, c]: &[DVec3; 3]) -> f64 {
    (*b - *a).cross(*c - *a).length() * 0.5
}

/// Relative errors of the cells' total volume and total surface area.
fn totals_error(mesh: &TriangleMesh, voronoi: &ClippedVoronoi) -> (f64, f64) {
    let volume: f64 = voronoi.cells.iter().map(|c| c.volume).sum();
    let area: f64 = voronoi.cells.iter().flat_map(|c| &c.triangles).map(triangle_area).sum();
    ((volume / mesh.signed_volume() - 1.0).abs(), (area / mesh.area() - 1.0).abs())
}

#[test]
fn a_cube_cut_among_random_sites_keeps_its_volume_and_area() {
    let mesh = cube(1.0);
    for seed in 0..5 {
        let voronoi = diagram(&mesh, &random_sites(&mesh, 4 + 3 * seed as usize, seed));
        let (volume, area) = totals_error(&mesh, &voronoi);
        assert!(volume < 1e-9 && area < 1e-12, "seed {seed}: volume {volume:e}, area {area:e}");
        assert!(voronoi.cells.iter().all(|c| c.volume > 0.0));
    }
}

#[test]
fn a_sphere_cut_among_random_sites_keeps_its_volume_and_area() {
    let mesh = octahedron(12, 1.0, true);
    for seed in 0..4 {
        let voronoi = diagram(&mesh, &random_sites(&mesh, 5 + 10 * seed as usize, seed));
        let (volume, area) = totals_error(&mesh, &voronoi);
        assert!(volume < 1e-9 && area < 1e-12, "seed {seed}: volume {volume:e}, area {area:e}");
    }
}

#[test]
fn sites_outside_the_mesh_get_what_their_cells_hold_inside() {
    let mesh = octahedron(6, 1.0, true);
    let mut sites = random_sites(&mesh, 10, 3);
    sites.extend([DVec3::new(1.5, 0.2, 0.1), DVec3::new(-3.0, 0.0, 0.0), DVec3::new(0.3, 0.9, 0.9)]);
    let voronoi = diagram(&mesh, &sites);
    let (volume, area) = totals_error(&mesh, &voronoi);
    assert!(volume < 1e-9 && area < 1e-12, "volume {volume:e}, area {area:e}");
    // Far away: nothing inside, no neighbours.
    let far = &voronoi.cells[11];
    assert_eq!((far.volume, far.triangles.len()), (0.0, 0));
    assert!(voronoi.adjacency.iter().all(|pair| !pair.contains(&11)));
}

#[test]
fn one_site_takes_the_whole_mesh() {
    let mesh = octahedron(4, 2.0, true);
    let voronoi = diagram(&mesh, &[DVec3::new(0.1, 0.2, 0.3)]);
    let cell = &voronoi.cells[0];
    assert!((cell.volume / mesh.signed_volume() - 1.0).abs() < 1e-12);
    assert_eq!(cell.triangles.len(), mesh.triangles.len());
    assert_eq!(cell.planes.len(), 6); // the box
    assert!(voronoi.adjacency.is_empty());
}

#[test]
fn a_regular_grid_of_sites_cuts_a_cube_into_equal_cubes() {
    // Cospherical sites, bisectors through the cube's face diagonals and their crossings:
    // the degenerate cases.
    for n in [2usize, 3] {
        let mesh = cube(1.0);
        let sites: Vec<DVec3> = (0..n * n * n)
            .map(|i| (DVec3::new((i % n) as f64, ((i / n) % n) as f64, (i / n / n) as f64) + 0.5) / n as f64)
            .collect();
        let voronoi = diagram(&mesh, &sites);
        let expected = 1.0 / (n * n * n) as f64;
        for cell in &voronoi.cells {
            assert!((cell.volume - expected).abs() < 1e-14, "n = {n}: volume {}", cell.volume);
            // Only the faces of a cube: 6 planes, bisectors or box planes.
            assert_eq!(cell.planes.len(), 6, "n = {n}");
        }
        let (volume, area) = totals_error(&mesh, &voronoi);
        assert!(volume < 1e-12 && area < 1e-12);
        // Face neighbours only: pairs differing by one step along one axis.
        assert_eq!(voronoi.adjacency.len(), 3 * n * n * (n - 1), "n = {n}");
        for [a, b] in &voronoi.adjacency {
            let d = sites[*a as usize] - sites[*b as usize];
            assert!((d.length() * n as f64 - 1.0).abs() < 1e-12);
        }
    }
}

#[test]
fn two_separate_bodies_are_both_shared_out() {
    let mut mesh = cube(1.0);
    let mut far = octahedron(5, 0.7, true);
    far.map_positions(|p| p + DVec3::new(3.0, 0.5, 0.5));
    merge(&mut mesh, far);
    // Sites only in the cube: the octahedron goes to the cells reaching over to it.
    let voronoi = diagram(&mesh, &random_sites(&cube(1.0), 9, 4));
    let (volume, area) = totals_error(&mesh, &voronoi);
    assert!(volume < 1e-9 && area < 1e-12, "volume {volume:e}, area {area:e}");
}

/// Appends `other`'s triangles to `mesh`.
fn merge(mesh: &mut TriangleMesh, other: TriangleMesh) {
    let offset = mesh.positions.len() as u32;
    mesh.positions.extend(other.positions);
    mesh.triangles.extend(other.triangles.iter().map(|t| t.map(|v| v + offset)));
}

#[test]
fn overlapping_shells_and_cavities_count_with_their_winding_number() {
    // Two interpenetrating cubes: the overlap counts twice, as the signed volume counts it.
    let mut overlapping = cube(1.0);
    let mut other = cube(1.0);
    other.map_positions(|p| p + DVec3::splat(0.5));
    merge(&mut overlapping, other);
    // A cube with an inside-out cube inside it: a cavity.
    let mut hollow = cube(3.0);
    let mut cavity = cube(1.0);
    cavity.flip();
    cavity.map_positions(|p| p + DVec3::ONE);
    merge(&mut hollow, cavity);
    for (mesh, volume) in [(overlapping, 2.0), (hollow, 26.0)] {
        assert!((mesh.signed_volume() - volume).abs() < 1e-12);
        for seed in 0..3 {
            let voronoi = diagram(&mesh, &random_sites(&mesh, 25, seed));
            let (volume, area) = totals_error(&mesh, &voronoi);
            assert!(volume < 1e-9 && area < 1e-12, "seed {seed}: volume {volume:e}, area {area:e}");
        }
    }
}

#[test]
fn adjacency_is_symmetric_sorted_and_between_touching_cells() {
    let mesh = octahedron(10, 1.0, true);
    let voronoi = diagram(&mesh, &random_sites(&mesh, 40, 8));
    assert!(voronoi.adjacency.windows(2).all(|w| w[0] < w[1]));
    assert!(voronoi.adjacency.iter().all(|[a, b]| a < b));
    let sites = random_sites(&mesh, 40, 8);
    for &[a, b] in &voronoi.adjacency {
        let plane = bisector(&sites, a, b);
        let opposite = plane.map(|x| -x);
        assert!(voronoi.cells[a as usize].planes.contains(&plane));
        assert!(voronoi.cells[b as usize].planes.contains(&opposite));
    }
    // Every interior cell touches several others.
    assert!(voronoi.adjacency.len() > 2 * 40);
}

#[test]
fn the_diagram_does_not_depend_on_the_thread_count() {
    let mesh = octahedron(10, 1.0, true);
    let sites = random_sites(&mesh, 60, 2);
    let many = diagram(&mesh, &sites);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    let one = pool.install(|| diagram(&mesh, &sites));
    assert_eq!(many, one);
}

#[test]
fn bad_sites_are_reported() {
    let mesh = cube(1.0);
    let query = MeshQuery::new(&mesh);
    assert_eq!(clipped_voronoi(&[], &mesh, &query), Err(VoronoiError::NoSites));
    let repeated = [DVec3::splat(0.5), DVec3::splat(0.2), DVec3::splat(0.5)];
    assert_eq!(clipped_voronoi(&repeated, &mesh, &query), Err(VoronoiError::Duplicate { index: 2, of: 0 }));
    let nan = [DVec3::splat(0.5), DVec3::new(f64::NAN, 0.0, 0.0)];
    assert!(matches!(clipped_voronoi(&nan, &mesh, &query), Err(VoronoiError::NonFinite { index: 1, .. })));
    // Two or three sites, and coplanar ones, use every pair.
    for sites in
        [&[DVec3::splat(0.25), DVec3::splat(0.75)][..], &[0.2, 0.4, 0.6, 0.8].map(|x| DVec3::new(x, 1.0 - x, 0.5))]
    {
        let voronoi = clipped_voronoi(sites, &mesh, &query).expect("few sites");
        let (volume, area) = totals_error(&mesh, &voronoi);
        assert!(volume < 1e-12 && area < 1e-12);
    }
}
