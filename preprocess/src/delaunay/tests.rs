//! The tetrahedralization against brute force, on random, lattice, cospherical, coplanar and
//! nearly degenerate point sets.

use std::collections::{BTreeSet, HashMap, HashSet};

use glam::DVec3;
use robust::insphere;

use super::insertion_order::{MortonFrame, spread_bits};
use super::predicates::{coord, orient};
use super::splitmix::SplitMix64;
use super::*;

/// Uniform in [0, 1).
fn unit(rng: &mut SplitMix64) -> f64 {
    (rng.next() >> 11) as f64 / (1u64 << 53) as f64
}

fn random_points(count: usize, seed: u64) -> Vec<DVec3> {
    let mut rng = SplitMix64::new(seed);
    (0..count).map(|_| DVec3::new(unit(&mut rng), unit(&mut rng), unit(&mut rng))).collect()
}

fn lattice(n: i32) -> Vec<DVec3> {
    let mut points = Vec::new();
    for x in 0..n {
        for y in 0..n {
            for z in 0..n {
                points.push(DVec3::new(x as f64, y as f64, z as f64));
            }
        }
    }
    points
}

/// Every integer point at squared distance `r2` from the origin: exactly cospherical.
fn integer_sphere(r2: i64) -> Vec<DVec3> {
    let r = (r2 as f64).sqrt() as i64 + 1;
    let mut points = Vec::new();
    for x in -r..=r {
        for y in -r..=r {
            for z in -r..=r {
                if x * x + y * y + z * z == r2 {
                    points.push(DVec3::new(x as f64, y as f64, z as f64));
                }
            }
        }
    }
    points
}

/// Near-uniform points on the unit sphere (Fibonacci spiral).
fn fibonacci_sphere(count: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

fn orient_of(points: &[DVec3], tet: [u32; 4]) -> f64 {
    let [a, b, c, d] = tet.map(|i| points[i as usize]);
    orient(a, b, c, d)
}

fn insphere_of(points: &[DVec3], tet: [u32; 4], e: usize) -> f64 {
    let [a, b, c, d] = tet.map(|i| coord(points[i as usize]));
    insphere(a, b, c, d, coord(points[e]))
}

/// The hull faces (tet faces without a neighbour), each turned so that its normal
/// `(b - a) × (c - a)` points away from the tet.
fn hull_faces(points: &[DVec3], tri: &Tetrahedralization) -> Vec<[u32; 3]> {
    let mut faces = Vec::new();
    for (tet, neighbors) in tri.tets.iter().zip(&tri.neighbors) {
        for k in 0..4 {
            if neighbors[k] != NO_NEIGHBOR {
                continue;
            }
            let others: Vec<u32> = (0..4).filter(|&i| i != k).map(|i| tet[i]).collect();
            let mut face = [others[0], others[1], others[2]];
            if orient_of(points, [face[0], face[1], face[2], tet[k]]) < 0.0 {
                face.swap(1, 2);
            }
            faces.push(face);
        }
    }
    faces
}

/// The volume closed by outward faces, by the divergence theorem.
fn enclosed_volume(points: &[DVec3], faces: &[[u32; 3]]) -> f64 {
    let o = points[faces[0][0] as usize];
    faces
        .iter()
        .map(|face| {
            let [a, b, c] = face.map(|i| points[i as usize] - o);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

fn total_volume(points: &[DVec3], tri: &Tetrahedralization) -> f64 {
    tri.tets.iter().map(|&tet| tet_volume(points, tet)).sum()
}

/// Everything but the Delaunay property: orientation, adjacency, a closed convex hull
/// boundary, every point used, and tet volumes summing to the hull's volume (to
/// `tolerance`, relative). Returns the hull volume.
fn check_structure(points: &[DVec3], tri: &Tetrahedralization, tolerance: f64) -> f64 {
    assert_eq!(tri.tets.len(), tri.neighbors.len());
    assert!(!tri.tets.is_empty());
    let skipped: HashSet<u32> = tri.duplicates.iter().map(|&[s, _]| s).collect();
    for &[s, kept] in &tri.duplicates {
        assert!(kept < s && points[s as usize] == points[kept as usize] && !skipped.contains(&kept));
    }

    let mut used = vec![false; points.len()];
    for (t, &tet) in tri.tets.iter().enumerate() {
        for &v in &tet {
            assert!((v as usize) < points.len() && !skipped.contains(&v), "tet {t} = {tet:?}");
            used[v as usize] = true;
        }
        assert!(orient_of(points, tet) > 0.0, "tet {t} = {tet:?} is not positively oriented");
        assert!(tet_volume(points, tet) > 0.0, "tet {t} = {tet:?} has no volume");
    }
    for (i, used) in used.iter().enumerate() {
        assert_eq!(*used, !skipped.contains(&(i as u32)), "point {i}");
    }

    for (t, (tet, neighbors)) in tri.tets.iter().zip(&tri.neighbors).enumerate() {
        for (k, &u) in neighbors.iter().enumerate() {
            if u == NO_NEIGHBOR {
                continue;
            }
            let back: Vec<usize> = (0..4).filter(|&j| tri.neighbors[u as usize][j] == t as u32).collect();
            assert_eq!(back.len(), 1, "tet {t} face {k}: neighbour {u} does not point back once");
            let j = back[0];
            let other = tri.tets[u as usize];
            let face_t: BTreeSet<u32> = (0..4).filter(|&i| i != k).map(|i| tet[i]).collect();
            let face_u: BTreeSet<u32> = (0..4).filter(|&i| i != j).map(|i| other[i]).collect();
            assert_eq!(face_t, face_u, "tets {t} and {u} do not share the face between them");
            assert!(!tet.contains(&other[j]), "tets {t} and {u} share four vertices");
        }
    }

    // The hull faces form a closed, consistently oriented surface ...
    let faces = hull_faces(points, tri);
    let mut directed = HashSet::new();
    for &[a, b, c] in &faces {
        for edge in [(a, b), (b, c), (c, a)] {
            assert!(directed.insert(edge), "hull edge {edge:?} is used twice in one direction");
        }
    }
    for &(a, b) in &directed {
        assert!(directed.contains(&(b, a)), "hull edge ({a}, {b}) is on one hull face only");
    }
    // ... convex at every edge (a closed, locally convex surface bounds a convex body) ...
    let mut face_of_edge = HashMap::new();
    for (f, &[a, b, c]) in faces.iter().enumerate() {
        for (edge, apex) in [((a, b), c), ((b, c), a), ((c, a), b)] {
            face_of_edge.insert(edge, (f, apex));
        }
    }
    for (&(a, b), &(f, apex)) in &face_of_edge {
        let [x, y, z] = faces[face_of_edge[&(b, a)].0].map(|i| points[i as usize]);
        assert!(orient(x, y, z, points[apex as usize]) >= 0.0, "hull face {f} is reflex at edge ({a}, {b})");
    }
    // ... and each face supports the point set: it is the convex hull's boundary.
    if faces.len() * points.len() <= 50_000_000 {
        for &[a, b, c] in &faces {
            for (i, &p) in points.iter().enumerate() {
                let side = orient(points[a as usize], points[b as usize], points[c as usize], p);
                assert!(side >= 0.0, "point {i} is outside hull face [{a}, {b}, {c}]");
            }
        }
    }

    let hull = enclosed_volume(points, &faces);
    let tets = total_volume(points, tri);
    assert!(
        (hull - tets).abs() <= tolerance * hull,
        "tet volumes sum to {tets}, the hull encloses {hull} (relative gap {:e})",
        (hull - tets).abs() / hull
    );
    hull
}

/// No point strictly inside any tet's circumsphere, by brute force.
fn check_empty_spheres(points: &[DVec3], tri: &Tetrahedralization) {
    for (t, &tet) in tri.tets.iter().enumerate() {
        for e in 0..points.len() {
            assert!(insphere_of(points, tet, e) <= 0.0, "point {e} is inside the circumsphere of tet {t}");
        }
    }
}

/// No point strictly inside any tet's circumsphere, among the vertices of the tet's
/// neighbours and `samples` random points per tet.
fn check_local_and_sampled_spheres(points: &[DVec3], tri: &Tetrahedralization, samples: usize) {
    let mut rng = SplitMix64::new(99);
    for (t, (&tet, neighbors)) in tri.tets.iter().zip(&tri.neighbors).enumerate() {
        let near = neighbors.iter().filter(|&&u| u != NO_NEIGHBOR).flat_map(|&u| tri.tets[u as usize]);
        let sampled: Vec<u32> = (0..samples).map(|_| rng.below(points.len()) as u32).collect();
        for e in near.chain(sampled) {
            assert!(insphere_of(points, tet, e as usize) <= 0.0, "point {e} is inside the circumsphere of tet {t}");
        }
    }
}

fn sorted_tets(tri: &Tetrahedralization) -> BTreeSet<[u32; 4]> {
    tri.tets
        .iter()
        .map(|&tet| {
            let mut tet = tet;
            tet.sort_unstable();
            tet
        })
        .collect()
}

/// All 4-tuples with a strictly empty circumsphere (points in general position).
fn brute_force_tets(points: &[DVec3]) -> BTreeSet<[u32; 4]> {
    let n = points.len() as u32;
    let mut tets = BTreeSet::new();
    for a in 0..n {
        for b in a + 1..n {
            for c in b + 1..n {
                for d in c + 1..n {
                    let side = orient_of(points, [a, b, c, d]);
                    assert!(side != 0.0, "not in general position");
                    let oriented = if side > 0.0 { [a, b, c, d] } else { [b, a, c, d] };
                    let empty = (0..points.len()).filter(|&e| ![a, b, c, d].contains(&(e as u32))).all(|e| {
                        let inside = insphere_of(points, oriented, e);
                        assert!(inside != 0.0, "not in general position");
                        inside < 0.0
                    });
                    if empty {
                        tets.insert([a, b, c, d]);
                    }
                }
            }
        }
    }
    tets
}

/// The convex hull volume from all supporting triangles (points in general position).
fn brute_force_hull_volume(points: &[DVec3]) -> f64 {
    let n = points.len() as u32;
    let mut faces = Vec::new();
    for a in 0..n {
        for b in a + 1..n {
            for c in b + 1..n {
                let sides: Vec<f64> =
                    (0..n).filter(|e| ![a, b, c].contains(e)).map(|e| orient_of(points, [a, b, c, e])).collect();
                if sides.iter().all(|&s| s > 0.0) {
                    faces.push([a, b, c]);
                } else if sides.iter().all(|&s| s < 0.0) {
                    faces.push([a, c, b]);
                }
            }
        }
    }
    enclosed_volume(points, &faces)
}

#[test]
fn small_random_sets_match_brute_force() {
    for (seed, count) in [(1, 5), (2, 8), (3, 13), (4, 21), (5, 30), (6, 40), (7, 40)] {
        let points = random_points(count, seed);
        let tri = tetrahedralize(&points).expect("random points triangulate");
        check_structure(&points, &tri, 1e-12);
        assert_eq!(sorted_tets(&tri), brute_force_tets(&points), "{count} points, seed {seed}");
    }
}

#[test]
fn volumes_sum_to_brute_force_hull_volume() {
    for seed in 10..14 {
        let points = random_points(60, seed);
        let tri = tetrahedralize(&points).expect("random points triangulate");
        let hull = check_structure(&points, &tri, 1e-12);
        let reference = brute_force_hull_volume(&points);
        assert!((hull - reference).abs() <= 1e-12 * reference, "{hull} vs {reference}");
        let tets = total_volume(&points, &tri);
        assert!((tets - reference).abs() <= 1e-12 * reference, "{tets} vs {reference}");
    }
}

#[test]
fn random_300_points_have_empty_circumspheres() {
    let points = random_points(300, 20);
    let tri = tetrahedralize(&points).expect("random points triangulate");
    check_structure(&points, &tri, 1e-12);
    check_empty_spheres(&points, &tri);
}

#[test]
fn random_5000_points_have_locally_and_sampled_empty_circumspheres() {
    let points = random_points(5000, 21);
    let tri = tetrahedralize(&points).expect("random points triangulate");
    check_structure(&points, &tri, 1e-12);
    check_local_and_sampled_spheres(&points, &tri, 64);
}

#[test]
fn lattice_with_cospherical_cubes() {
    let points = lattice(6);
    let tri = tetrahedralize(&points).expect("a lattice triangulates");
    let hull = check_structure(&points, &tri, 1e-12);
    assert!((hull - 125.0).abs() <= 1e-12 * 125.0);
    check_empty_spheres(&points, &tri);
    // Each unit cube's eight corners are cospherical: no Delaunay tet reaches past one cube.
    for &tet in &tri.tets {
        let [a, b, c, d] = tet.map(|i| points[i as usize]);
        let extent = a.max(b).max(c).max(d) - a.min(b).min(c).min(d);
        assert!(extent.max_element() <= 1.0, "tet {tet:?} spans more than one cube");
    }
}

#[test]
fn larger_lattice_is_locally_delaunay() {
    let points = lattice(14);
    let tri = tetrahedralize(&points).expect("a lattice triangulates");
    let hull = check_structure(&points, &tri, 1e-12);
    assert!((hull - 13f64.powi(3)).abs() <= 1e-12 * hull);
    check_local_and_sampled_spheres(&points, &tri, 32);
}

#[test]
fn cube_corners_are_all_cospherical() {
    let points = lattice(2);
    let tri = tetrahedralize(&points).expect("a cube triangulates");
    let hull = check_structure(&points, &tri, 1e-12);
    assert!((hull - 1.0).abs() <= 1e-12);
    assert!(tri.tets.len() == 5 || tri.tets.len() == 6, "{} tets", tri.tets.len());
    check_empty_spheres(&points, &tri);
}

/// The determinant of a small integer matrix, by cofactor expansion.
fn integer_determinant(m: &[Vec<i128>]) -> i128 {
    if m.len() == 1 {
        return m[0][0];
    }
    (0..m.len())
        .map(|col| {
            let minor: Vec<Vec<i128>> = m[1..]
                .iter()
                .map(|row| row.iter().enumerate().filter(|&(c, _)| c != col).map(|(_, &v)| v).collect())
                .collect();
            let sign = if col % 2 == 0 { 1 } else { -1 };
            sign * m[0][col] * integer_determinant(&minor)
        })
        .sum()
}

/// Shewchuk's insphere determinant in integers: rows `[q - e, |q - e|²]` for `q` in `a..d`.
fn integer_insphere(p: [DVec3; 5]) -> i128 {
    let rows: Vec<Vec<i128>> = p[..4]
        .iter()
        .map(|&q| {
            let d = (q - p[4]).as_i64vec3();
            let (x, y, z) = (i128::from(d.x), i128::from(d.y), i128::from(d.z));
            vec![x, y, z, x * x + y * y + z * z]
        })
        .collect();
    integer_determinant(&rows)
}

/// The sign of the crate's predicates matters most on exactly degenerate input: check it
/// against integer arithmetic on the cospherical and lattice points the tests use.
#[test]
fn exact_predicate_agrees_with_integer_arithmetic() {
    let mut points = integer_sphere(50);
    points.extend(lattice(3));
    let mut rng = SplitMix64::new(5);
    let mut zeros = 0;
    for _ in 0..20_000 {
        let five: [DVec3; 5] = std::array::from_fn(|_| points[rng.below(points.len())]);
        let [a, b, c, d, e] = five.map(coord);
        let exact = integer_insphere(five).signum();
        let inside = insphere(a, b, c, d, e);
        let sign = if inside > 0.0 {
            1
        } else if inside < 0.0 {
            -1
        } else {
            0
        };
        assert_eq!(sign, exact, "{five:?}");
        zeros += usize::from(exact == 0);
    }
    assert!(zeros > 1000, "the sample holds many cospherical 5-tuples");
}

#[test]
fn exactly_cospherical_points() {
    for r2 in [50, 325] {
        let points = integer_sphere(r2);
        let tri = tetrahedralize(&points).expect("sphere points triangulate");
        check_structure(&points, &tri, 1e-12);
        check_empty_spheres(&points, &tri);

        let mut with_centre = points.clone();
        with_centre.push(DVec3::ZERO);
        let tri = tetrahedralize(&with_centre).expect("sphere points triangulate");
        check_structure(&with_centre, &tri, 1e-12);
        check_empty_spheres(&with_centre, &tri);
        let centre = (with_centre.len() - 1) as u32;
        assert!(tri.tets.iter().all(|tet| tet.contains(&centre)), "the centre is in every ball");
    }
}

#[test]
fn points_on_a_sphere_and_nested_offset_shells() {
    let sphere = fibonacci_sphere(2000);
    let tri = tetrahedralize(&sphere).expect("sphere points triangulate");
    check_structure(&sphere, &tri, 1e-12);
    check_local_and_sampled_spheres(&sphere, &tri, 32);

    // Offset surfaces: the same directions on every layer, so points line up radially.
    let directions = fibonacci_sphere(600);
    let mut shells: Vec<DVec3> =
        (0..4).flat_map(|layer| directions.iter().map(move |&d| d * (1.0 - 0.1 * layer as f64))).collect();
    shells.push(DVec3::ZERO);
    let tri = tetrahedralize(&shells).expect("shells triangulate");
    check_structure(&shells, &tri, 1e-12);
    check_empty_spheres(&shells, &tri);
}

#[test]
fn coplanar_subsets() {
    // A square grid in a plane and an apex on each side: the hull has flat square facets
    // made of cocircular points.
    let mut pyramid: Vec<DVec3> = lattice(8).into_iter().filter(|p| p.z == 0.0).collect();
    pyramid.push(DVec3::new(3.5, 3.5, 2.0));
    let tri = tetrahedralize(&pyramid).expect("a pyramid triangulates");
    let hull = check_structure(&pyramid, &tri, 1e-12);
    assert!((hull - 49.0 * 2.0 / 3.0).abs() <= 1e-12 * hull);
    check_empty_spheres(&pyramid, &tri);
    pyramid.push(DVec3::new(1.0, 2.0, -3.0));
    let tri = tetrahedralize(&pyramid).expect("a double pyramid triangulates");
    check_structure(&pyramid, &tri, 1e-12);
    check_empty_spheres(&pyramid, &tri);

    // The surface of a cube lattice plus a few interior points; parallel grid layers.
    let surface: Vec<DVec3> =
        lattice(7).into_iter().filter(|p| p.min_element() == 0.0 || p.max_element() == 6.0).collect();
    let mut box_shell = surface.clone();
    box_shell.extend([DVec3::new(3.0, 3.0, 3.0), DVec3::new(2.5, 3.25, 1.0), DVec3::new(1.0, 1.0, 5.0)]);
    for points in [surface, box_shell] {
        let tri = tetrahedralize(&points).expect("a box surface triangulates");
        let hull = check_structure(&points, &tri, 1e-12);
        assert!((hull - 216.0).abs() <= 1e-12 * hull);
        check_empty_spheres(&points, &tri);
    }
    let layers: Vec<DVec3> = lattice(9)
        .into_iter()
        .filter(|p| p.z % 4.0 == 0.0)
        .map(|p| if p.z == 4.0 { p + DVec3::new(0.5, 0.5, 0.0) } else { p })
        .collect();
    let tri = tetrahedralize(&layers).expect("layers triangulate");
    check_structure(&layers, &tri, 1e-12);
    check_empty_spheres(&layers, &tri);
}

#[test]
fn nearly_degenerate_inputs() {
    // Nearly coplanar: a random slab 1e-9 thick.
    let mut rng = SplitMix64::new(30);
    let slab: Vec<DVec3> =
        (0..400).map(|_| DVec3::new(unit(&mut rng), unit(&mut rng), 1e-9 * unit(&mut rng))).collect();
    let tri = tetrahedralize(&slab).expect("a thin slab triangulates");
    check_structure(&slab, &tri, 1e-6);
    check_empty_spheres(&slab, &tri);

    // The moment curve: every pair of points is a Delaunay edge, many slivers.
    let curve: Vec<DVec3> = (1..=40).map(|t| DVec3::new(t as f64, (t * t) as f64, (t * t * t) as f64)).collect();
    let tri = tetrahedralize(&curve).expect("the moment curve triangulates");
    check_structure(&curve, &tri, 1e-12);
    check_empty_spheres(&curve, &tri);

    // A lattice jittered by a few ulps.
    let jittered: Vec<DVec3> = lattice(6)
        .into_iter()
        .map(|p| p + DVec3::new(unit(&mut rng), unit(&mut rng), unit(&mut rng)) * 1e-15)
        .collect();
    let tri = tetrahedralize(&jittered).expect("a jittered lattice triangulates");
    check_structure(&jittered, &tri, 1e-12);
    check_empty_spheres(&jittered, &tri);
}

#[test]
fn duplicates_are_skipped_and_reported() {
    let mut points = random_points(200, 40);
    points.push(points[7]);
    points.insert(3, points[150]);
    points.push(DVec3::new(0.0, 0.5, 0.5));
    points.push(DVec3::new(-0.0, 0.5, 0.5));
    points.push(points[7]);
    let tri = tetrahedralize(&points).expect("points with repeats triangulate");
    check_structure(&points, &tri, 1e-12);
    check_empty_spheres(&points, &tri);
    assert_eq!(tri.duplicates, vec![[151, 3], [201, 8], [203, 202], [204, 7]]);
}

#[test]
fn output_is_deterministic() {
    let mut points = lattice(5);
    points.extend(random_points(300, 50).into_iter().map(|p| p * 4.0));
    let first = tetrahedralize(&points).expect("triangulates");
    let second = tetrahedralize(&points).expect("triangulates");
    assert_eq!(first, second);
}

/// The benchmark's layouts at full size (200,000 points), checked like the small sets. Slow in
/// debug builds: `cargo test --release -p shatter-preprocess --lib delaunay -- --ignored`.
#[test]
#[ignore]
fn full_size_layouts_are_valid() {
    const COUNT: usize = 200_000;
    const LAYERS: usize = 10;
    let radius = |layer: usize| 1.0 - 0.0225 * layer as f64;
    let directions = fibonacci_sphere(COUNT / LAYERS);
    let offset: Vec<DVec3> = (0..LAYERS).flat_map(|layer| directions.iter().map(move |&d| d * radius(layer))).collect();
    let nested: Vec<DVec3> = (0..LAYERS)
        .flat_map(|layer| {
            let count = (COUNT as f64 * radius(layer).powi(2) / 8.2) as usize;
            fibonacci_sphere(count).into_iter().map(move |d| d * radius(layer))
        })
        .collect();
    for points in [random_points(COUNT, 70), offset, nested] {
        let tri = tetrahedralize(&points).expect("triangulates");
        check_structure(&points, &tri, 1e-11);
        check_local_and_sampled_spheres(&points, &tri, 4);
    }
}

#[test]
fn morton_codes_interleave_bits() {
    assert_eq!(spread_bits(0b1011), 0b1_000_001_001);
    assert_eq!(spread_bits(0x1f_ffff), 0x1249_2492_4924_9249);
    let frame = MortonFrame::new([DVec3::ZERO, DVec3::ONE].into_iter());
    assert_eq!(frame.code(DVec3::ZERO), 0);
    assert_eq!(frame.code(DVec3::ONE), (1 << 63) - 1);
    assert_eq!(frame.code(DVec3::new(0.0, 1.0, 0.0)), 0x1249_2492_4924_9249 << 1);
}

#[test]
fn rejects_bad_input() {
    let points = random_points(3, 60);
    assert_eq!(tetrahedralize(&points), Err(DelaunayError::TooFewPoints { count: 3 }));
    assert_eq!(tetrahedralize(&[]), Err(DelaunayError::TooFewPoints { count: 0 }));

    let plane: Vec<DVec3> = lattice(4).into_iter().filter(|p| p.x + p.y + p.z == 3.0).collect();
    assert_eq!(tetrahedralize(&plane), Err(DelaunayError::Coplanar { distinct: plane.len() }));
    let line: Vec<DVec3> = (0..10).map(|i| DVec3::splat(i as f64)).collect();
    assert_eq!(tetrahedralize(&line), Err(DelaunayError::Coplanar { distinct: 10 }));
    let repeated = vec![DVec3::ONE; 5];
    assert_eq!(tetrahedralize(&repeated), Err(DelaunayError::Coplanar { distinct: 1 }));

    let mut points = random_points(10, 61);
    points[4].y = f64::NAN;
    assert!(matches!(tetrahedralize(&points), Err(DelaunayError::NonFinite { index: 4, .. })));
    points[4].y = f64::INFINITY;
    assert!(matches!(tetrahedralize(&points), Err(DelaunayError::NonFinite { index: 4, .. })));
    points[4].y = 1e40;
    assert!(matches!(tetrahedralize(&points), Err(DelaunayError::OutOfRange { index: 4, .. })));
}
