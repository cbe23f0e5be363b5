//! The CPU tracer against analytic cases: depth and normals of single cubes and tetrahedra,
//! packets of camera rays against single rays, unions of touching cubes without seams or inner
//! faces, walks out of a union, and light through a glass slab.

use glam::DVec3;
use shatter_core::particles::{Elements, ParticleSet};

use crate::camera::Camera;
use crate::hit_search::{NONE, closest_hit, element_at, union_exit};
use crate::image_loop::{pixel_hits, render};
use crate::lighting::EnvironmentMap;
use crate::materials::Look;
use crate::primitives::along;
use crate::sampling::random;
use crate::scene_geometry::SceneGeometry;
use crate::shading::refract;

fn set(positions: Vec<[f32; 3]>, elements: Elements) -> ParticleSet {
    ParticleSet::unbonded(positions, elements, 1.0)
}

fn cubes(centres: Vec<[f32; 3]>) -> SceneGeometry {
    let n = centres.len();
    let elements = Elements::Cubes { half_size_m: vec![0.5; n], orientation: [0.0, 0.0, 0.0, 1.0] };
    SceneGeometry::build(&set(centres, elements), None)
}

fn look() -> Look {
    let environment = EnvironmentMap::constant([0.5; 3]);
    Look {
        albedo: [0.8; 3],
        fracture_albedo: [0.8; 3],
        shininess: 32.0,
        max_bounces: 8,
        glass_split_events: 2,
        opaque_cubes: false,
        ..Look::under(environment)
    }
}

/// Entry distance and normal of a ray into an axis-aligned box, in f64; None if it misses
/// the box shrunk by `margin` (a sure hit needs that), Some(None) if it hits the box grown by
/// `margin` only (ambiguous: skip).
fn analytic_box(lo: DVec3, hi: DVec3, o: DVec3, d: DVec3, margin: f64) -> Option<Option<(f64, DVec3)>> {
    let slab = |lo: DVec3, hi: DVec3| {
        let (mut near, mut far, mut normal) = (f64::NEG_INFINITY, f64::INFINITY, DVec3::ZERO);
        for a in 0..3 {
            let (t0, t1) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
            let (enter, leave, sign) = if t0 < t1 { (t0, t1, -1.0) } else { (t1, t0, 1.0) };
            if enter > near {
                near = enter;
                normal = DVec3::ZERO;
                normal[a] = sign;
            }
            far = far.min(leave);
        }
        (near <= far && near > 0.0).then_some((near, normal))
    };
    match (slab(lo + margin, hi - margin), slab(lo - margin, hi + margin)) {
        (Some(_), _) => Some(slab(lo, hi)),
        (None, Some(_)) => Some(None),
        (None, None) => None,
    }
}

#[test]
fn a_single_cube_has_analytic_depth_and_normals() {
    let scene = cubes(vec![[0.0; 3]]);
    let camera = Camera::look_at(DVec3::new(1.3, 1.7, 4.0), DVec3::ZERO, DVec3::Y, 30.0, 64, 48);
    let image = render(&scene, &look(), &camera, 1).pixels;
    let mut checked = 0;
    for y in 0..48 {
        for x in 0..64 {
            let pixel = image[y * 64 + x];
            let d = DVec3::from_array(camera.direction(x as f32 + 0.5, y as f32 + 0.5).map(f64::from));
            let o = DVec3::from_array(camera.origin.map(f64::from));
            match analytic_box(DVec3::splat(-0.5), DVec3::splat(0.5), o, d, 1e-4) {
                Some(Some((t, n))) => {
                    assert!((f64::from(pixel.depth) - t).abs() < 1e-4, "({x}, {y}): depth {} vs {t}", pixel.depth);
                    for a in 0..3 {
                        assert!((f64::from(pixel.normal[a]) - n[a]).abs() < 1e-4, "({x}, {y}) normal");
                    }
                    assert_eq!(pixel.fragment, 1);
                    checked += 1;
                }
                None => assert_eq!(pixel.element, NONE, "({x}, {y}) should miss"),
                Some(None) => {}
            }
        }
    }
    assert!(checked > 300, "{checked} pixels on the cube");
}

/// Camera rays traced in packets find exactly what each finds alone: on a grid of touching
/// cubes (rays along the seams meet exact ties), on scattered tetrahedra, and from an eye on
/// the tree's first split plane (where packets whose rays cross it both ways go alone).
#[test]
fn packets_of_camera_rays_find_what_single_rays_find() {
    let grid: Vec<[f32; 3]> = (0..6 * 6 * 3).map(|k| [(k % 6) as f32, ((k / 6) % 6) as f32, (k / 36) as f32]).collect();
    let mut rng = shatter_core::random::SplitMix64::new(4);
    let mut r = move || rng.next_f64() as f32;
    let tets: Vec<[[f32; 3]; 4]> = (0..200)
        .map(|_| {
            let c = [r() * 4.0, r() * 4.0, r() * 4.0];
            [0, 1, 2, 3].map(|k| {
                let corner = [[0.0, 0.0, 0.0], [0.6, 0.0, 0.0], [0.0, 0.6, 0.0], [0.0, 0.0, 0.6]][k];
                [c[0] + corner[0], c[1] + corner[1], c[2] + corner[2]]
            })
        })
        .collect();
    let tet_set = set(tets.iter().map(|t| t[0]).collect(), Elements::Tets { vertices_m: tets.clone() });
    let scenes = [cubes(grid), SceneGeometry::build(&tet_set, None)];
    for (s, scene) in scenes.iter().enumerate() {
        let [a, b] = crate::element_kdtree::KdTree::build(&scene.element_bounds).nodes[0];
        let (axis, split) = ((a & 3) as usize, f32::from_bits(b));
        let mut on_split = DVec3::new(2.5, 2.5, 9.0);
        on_split[axis] = f64::from(split);
        let mut looking = DVec3::new(2.5, 2.5, 1.0);
        looking[axis] = f64::from(split);
        for (eye, target) in [
            (DVec3::new(2.5, 2.5, 9.0), DVec3::new(2.5, 2.5, 1.0)),
            (DVec3::new(-3.0, 8.0, 7.0), DVec3::new(2.0, 2.0, 1.0)),
            (on_split, looking),
        ] {
            let camera = Camera::look_at(eye, target, DVec3::Y, 50.0, 61, 47);
            let hits = pixel_hits(scene, &camera);
            let mut seen = 0;
            for y in 0..47 {
                for x in 0..61 {
                    let d = camera.direction(x as f32 + 0.5, y as f32 + 0.5);
                    let alone = closest_hit(scene, camera.origin, d, 0.0, 0.0);
                    assert_eq!(hits[y * 61 + x], alone, "scene {s}, eye {eye}, pixel ({x}, {y})");
                    seen += usize::from(alone.element != NONE);
                }
            }
            assert!(seen > 100, "scene {s}, eye {eye}: {seen} pixels see an element");
        }
    }
}

#[test]
fn a_single_tet_has_analytic_depth_and_normals() {
    let vertices = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let set = set(vec![[0.25; 3]], Elements::Tets { vertices_m: vec![vertices] });
    let scene = SceneGeometry::build(&set, None);
    let camera = Camera::look_at(DVec3::new(2.0, 1.5, 3.0), DVec3::splat(0.25), DVec3::Y, 30.0, 64, 48);
    let image = render(&scene, &look(), &camera, 1).pixels;
    let v = vertices.map(|p| DVec3::from_array(p.map(f64::from)));
    let faces = [[v[1], v[2], v[3]], [v[0], v[2], v[3]], [v[0], v[1], v[3]], [v[0], v[1], v[2]]];
    let mut checked = 0;
    for y in 0..48 {
        for x in 0..64 {
            let pixel = image[y * 64 + x];
            let d = DVec3::from_array(camera.direction(x as f32 + 0.5, y as f32 + 0.5).map(f64::from));
            let o = DVec3::from_array(camera.origin.map(f64::from));
            // nearest face by Moller-Trumbore in f64, keeping how far inside the triangle it is
            let mut best: Option<(f64, DVec3, f64)> = None;
            for face in &faces {
                let (e1, e2) = (face[1] - face[0], face[2] - face[0]);
                let p = d.cross(e2);
                let det = e1.dot(p);
                let s = o - face[0];
                let (u, w) = (s.dot(p) / det, d.dot(s.cross(e1)) / det);
                let t = e2.dot(s.cross(e1)) / det;
                let inset = u.min(w).min(1.0 - u - w);
                if inset >= -1e-4 && t > 0.0 && best.is_none_or(|(b, _, _)| t < b) {
                    let mut n = e1.cross(e2).normalize();
                    if n.dot(face[0] - DVec3::splat(0.25)) < 0.0 {
                        n = -n;
                    }
                    best = Some((t, n, inset));
                }
            }
            match best {
                Some((t, n, inset)) if inset > 1e-4 => {
                    assert!((f64::from(pixel.depth) - t).abs() < 1e-4, "({x}, {y}) depth");
                    assert!((DVec3::from_array(pixel.normal.map(f64::from)) - n).length() < 1e-4, "({x}, {y}) normal");
                    checked += 1;
                }
                Some(_) => {}
                None => assert_eq!(pixel.element, NONE, "({x}, {y}) should miss"),
            }
        }
    }
    assert!(checked > 100, "{checked} pixels on the tet");
}

#[test]
fn touching_cubes_show_no_seam_and_no_inner_face() {
    let scene = cubes(vec![[0.0; 3], [1.0, 0.0, 0.0]]);
    // Looking straight at the shared face's edge: every pixel inside the union must hit it.
    let camera = Camera::look_at(DVec3::new(0.5, 0.0, 4.0), DVec3::new(0.5, 0.0, 0.0), DVec3::Y, 40.0, 81, 61);
    let image = render(&scene, &look(), &camera, 1).pixels;
    let o = DVec3::from_array(camera.origin.map(f64::from));
    for y in 0..61 {
        for x in 0..81 {
            let d = DVec3::from_array(camera.direction(x as f32 + 0.5, y as f32 + 0.5).map(f64::from));
            if let Some(Some((t, _))) =
                analytic_box(DVec3::new(-0.5, -0.5, -0.5), DVec3::new(1.5, 0.5, 0.5), o, d, 1e-4)
            {
                let pixel = image[y * 81 + x];
                assert_ne!(pixel.element, NONE, "crack pixel at ({x}, {y})");
                assert!((f64::from(pixel.depth) - t).abs() < 1e-4, "({x}, {y}): depth {} vs {t}", pixel.depth);
            }
        }
    }
    // Inside the glass a ray walks on to the far side of the union, not to the inner face.
    let (t, normal, last) = union_exit(&scene, 0, [-0.4, 0.1, 0.0], [1.0, 0.0, 0.0], 0.0);
    assert!((t - 1.9).abs() < 1e-4, "exit at x = 1.5, not 0.5: t = {t}");
    assert_eq!(normal, [1.0, 0.0, 0.0]);
    assert_eq!(last, 1);
}

#[test]
fn a_walk_out_through_a_face_two_cubes_share_near_their_edge_ends_there() {
    // A above B, touching: their -x faces lie in one plane. A ray inside A leaves through
    // that plane just above the shared edge, heading down and nearly along the face, so the
    // probe point past A's face lies inside both widened rims, and B's span ends where A's
    // does: the walk must leave there, not pass between A and B until its guard runs out.
    let scene = cubes(vec![[0.0; 3], [0.0, -1.0, 0.0]]);
    let slack = scene.slack;
    let direction = DVec3::new(-0.135, -0.29, -0.95).normalize().as_vec3().to_array();
    let edge = [-0.5, -0.5 + 0.3 * slack, 0.0];
    let s = 0.3;
    let origin = along(edge, direction, -s);
    let (t, normal, last) = union_exit(&scene, 0, origin, direction, 0.0);
    assert_eq!(normal, [-1.0, 0.0, 0.0], "leaves through the shared -x plane (ended in element {last})");
    assert!((t - s).abs() < 1e-5, "at the face, t = {t} against {s}");
}

#[test]
fn the_walk_across_face_neighbours_leaves_where_the_tree_walk_does() {
    // a 4 x 4 x 4 block of touching unit cubes with its face adjacency
    let index = |x: usize, y: usize, z: usize| (x * 16 + y * 4 + z) as u32;
    let (mut centres, mut adjacency) = (Vec::new(), Vec::new());
    for x in 0..4 {
        for y in 0..4 {
            for z in 0..4 {
                centres.push([x as f32, y as f32, z as f32]);
                for (inside, next) in [(x < 3, (x + 1, y, z)), (y < 3, (x, y + 1, z)), (z < 3, (x, y, z + 1))] {
                    if inside {
                        adjacency.push([index(x, y, z), index(next.0, next.1, next.2)]);
                    }
                }
            }
        }
    }
    let elements = Elements::Cubes { half_size_m: vec![0.5; 64], orientation: [0.0, 0.0, 0.0, 1.0] };
    let particles = ParticleSet { adjacency, ..set(centres, elements) };
    let scene = SceneGeometry::build(&particles, None);
    assert_eq!(scene.face_neighbours.len(), 6 * 64);
    assert_eq!(scene.face_neighbours.iter().filter(|&&n| n != NONE).count(), 2 * 3 * 48);
    let mut tree_only = SceneGeometry::build(&particles, None);
    tree_only.face_neighbours.fill(NONE);
    for k in 0..200u32 {
        let origin = [0, 1, 2].map(|a| random(k, 0, a) * 3.0);
        let direction = {
            let v = DVec3::new(
                f64::from(random(k, 1, 0)) - 0.5,
                f64::from(random(k, 1, 1)) - 0.5,
                f64::from(random(k, 1, 2)) - 0.5,
            )
            .normalize();
            v.as_vec3().to_array()
        };
        let start = element_at(&scene, origin, NONE);
        let (t, normal, _) = union_exit(&scene, start, origin, direction, 0.0);
        let (t_tree, normal_tree, _) = union_exit(&tree_only, start, origin, direction, 0.0);
        assert!((t - t_tree).abs() < 1e-5, "ray {k}: {t} vs {t_tree}");
        assert_eq!(normal, normal_tree, "ray {k}");
        // and it is where the ray leaves the block [-0.5, 3.5]^3
        let t_far = (0..3)
            .map(|a| {
                ((-0.5 - f64::from(origin[a])) / f64::from(direction[a]))
                    .max((3.5 - f64::from(origin[a])) / f64::from(direction[a]))
            })
            .fold(f64::INFINITY, f64::min);
        assert!((f64::from(t) - t_far).abs() < 1e-4, "ray {k}: {t} vs {t_far}");
    }
    // a neighbour that has moved away is no shortcut: the walk ends at the face it left by
    let mut apart = cubes(vec![[0.0; 3], [5.0, 0.0, 0.0]]);
    apart.face_neighbours[0] = 1;
    let (t, normal, last) = union_exit(&apart, 0, [0.0; 3], [1.0, 0.0, 0.0], 0.0);
    assert_eq!((t, normal, last), (0.5, [1.0, 0.0, 0.0], 0));
}

#[test]
fn a_ray_through_a_glass_slab_of_touching_cubes_leaves_parallel() {
    let mut centres = Vec::new();
    for x in 0..5 {
        for z in 0..5 {
            centres.push([x as f32 - 2.0, 0.0, z as f32 - 2.0]);
        }
    }
    let scene = cubes(centres);
    let look = look();
    let d = {
        let v = DVec3::new(0.3, -1.0, 0.2).normalize();
        v.as_vec3().to_array()
    };
    let o = [-0.7, 2.0, -0.4];
    let entry = closest_hit(&scene, o, d, 0.0, 0.0);
    assert_eq!(entry.normal, [0.0, 1.0, 0.0], "enters through the top");
    let inside_d = refract(d, entry.normal, 1.0 / look.ior).expect("refracts in");
    let p = along(o, d, entry.t);
    let (t, m, _) = union_exit(&scene, entry.element, along(p, entry.normal, -1e-4), inside_d, 0.0);
    assert_eq!(m, [0.0, -1.0, 0.0], "leaves through the bottom face of the slab");
    assert!(t > 1.0, "crosses the slab's full thickness: {t}");
    let out = refract(inside_d, m.map(|v| -v), look.ior).expect("refracts out");
    for a in 0..3 {
        assert!((out[a] - d[a]).abs() < 1e-5, "leaves parallel: {out:?} vs {d:?}");
    }
}
