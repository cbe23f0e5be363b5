//! The GPU tracer against its CPU twin on random scenes (on Mesa's lavapipe in CI): the same
//! element seen first in every pixel, depth within 1e-5 relative, the same normals, fragments,
//! surface kinds (outer or fracture face) and matte counts.

use crate::support;

use glam::{DQuat, DVec3};
use shatter_core::fragments::{FragmentFrame, FragmentMeta};
use shatter_core::particles::{Elements, ParticleSet};
use shatter_core::random::SplitMix64;
use shatter_gpu::GpuContext;
use shatter_render::camera::Camera;
use shatter_render::gpu_trace::GpuTracer;
use shatter_render::hit_search::NONE;
use shatter_render::image_loop::render;
use shatter_render::materials::{FloorLook, FloorTexels, Look};
use shatter_render::mattes::SURFACE_FRACTURE;
use shatter_render::scene_geometry::SceneGeometry;
use shatter_render::texture_filter::MipChain;

fn set(positions: Vec<[f32; 3]>, elements: Elements) -> ParticleSet {
    let adjacency =
        if matches!(elements, Elements::Cubes { .. }) { lattice_neighbours(&positions) } else { Vec::new() };
    support::particle_set(positions, elements, 0.1, adjacency)
}

/// Pairs of points 0.1 apart along one axis (neighbours on the test lattice).
fn lattice_neighbours(positions: &[[f32; 3]]) -> Vec<[u32; 2]> {
    let mut pairs = Vec::new();
    for (i, a) in positions.iter().enumerate() {
        for (j, b) in positions.iter().enumerate().skip(i + 1) {
            let d: f32 = (0..3).map(|k| (a[k] - b[k]).abs()).sum();
            if (d - 0.1).abs() < 1e-4 {
                pairs.push([i as u32, j as u32]);
            }
        }
    }
    pairs
}

fn look(floor: bool) -> Look {
    // a gradient sky so that shading varies with direction
    Look {
        absorption: [0.5, 0.2, 0.1],
        albedo: [0.7, 0.6, 0.5],
        fracture_albedo: [0.3, 0.5, 0.9],
        specular: 0.3,
        shininess: 32.0,
        floor: floor.then(|| FloorLook {
            height: -1.0,
            tile: 0.5,
            size: [2, 2],
            texels: FloorTexels::Linear(vec![[0.9; 3], [0.1; 3], [0.1; 3], [0.9; 3]]),
            mips: None,
        }),
        max_bounces: 6,
        glass_split_events: 2,
        opaque_cubes: false,
        ..Look::under(support::gradient_sky())
    }
}

/// The particles of [`random_scene`].
fn random_particles(seed: u64, tets: bool) -> ParticleSet {
    let mut rng = SplitMix64::new(seed);
    let mut r = move || rng.next_f64() as f32;
    let mut positions = Vec::new();
    for x in 0..6 {
        for y in 0..4 {
            for z in 0..3 {
                if r() < 0.7 {
                    positions.push([x as f32 * 0.1 - 0.3, y as f32 * 0.1 - 0.2, z as f32 * 0.1 - 0.1]);
                }
            }
        }
    }
    let n = positions.len();
    let elements = if tets {
        let vertices = positions
            .iter()
            .map(|p| {
                let mut v = [[0.0f32; 3]; 4];
                for (k, corner) in v.iter_mut().enumerate() {
                    let offset = [(k & 1) as f32, ((k >> 1) & 1) as f32, if k == 3 { 1.0 } else { 0.0 }];
                    *corner = [0, 1, 2].map(|a| p[a] + 0.09 * offset[a] * (0.6 + 0.4 * r()) - 0.03);
                }
                v
            })
            .collect();
        Elements::Tets { vertices_m: vertices }
    } else {
        let q = DQuat::from_axis_angle(DVec3::new(0.3, 1.0, 0.2).normalize(), 0.4).as_quat();
        Elements::Cubes { half_size_m: vec![0.05; n], orientation: q.to_array() }
    };
    set(positions, elements)
}

/// Random cubes on a jittered lattice (some touching), random tets, or both kinds' scenes.
fn random_scene(seed: u64, tets: bool) -> SceneGeometry {
    let mut scene = SceneGeometry::build(&random_particles(seed, tets), None);
    // three fragments, so the mattes count several ids
    scene.fragment = (0..scene.len() as u32).map(|e| e % 3).collect();
    scene
}

/// `particles` bent about the z axis (a circle of radius 0.5 through the origin, the body's x
/// along it) and stretched by 20 % across the bend per metre: each element drawn deformed by the
/// field's gradient at its particle (deformed elements, `post.element_shapes = "deformed"`).
fn bent_scene(particles: &ParticleSet) -> SceneGeometry {
    let radius = 0.5f64;
    let n = particles.len();
    let maps = particles
        .rest_position_m
        .iter()
        .map(|p| {
            let [x, y, z] = p.map(f64::from);
            let theta = x / radius;
            let (sin, cos) = theta.sin_cos();
            let arm = radius - y * 1.2;
            // phi(X) = (arm sin(theta), radius - arm cos(theta), z)
            let phi = [arm * sin, radius - arm * cos, z];
            let dx = [arm / radius * cos, arm / radius * sin, 0.0];
            let dy = [-1.2 * sin, 1.2 * cos, 0.0];
            let dz = [0.0, 0.0, 1.0];
            let mut rows = [0.0f32; 12];
            for r in 0..3 {
                let column = [dx[r], dy[r], dz[r]];
                rows[4 * r..4 * r + 3].copy_from_slice(&column.map(|v| v as f32));
                rows[4 * r + 3] = (phi[r] - (column[0] * x + column[1] * y + column[2] * z)) as f32;
            }
            rows
        })
        .collect();
    let fragments = FragmentFrame {
        meta: FragmentMeta { frame: 2, step: 1, time_s: 0.0, smoothed: false, inputs: None },
        fragment_of: (0..n as u32).map(|e| e % 3).collect(),
        rotation: vec![[0.0, 0.0, 0.0, 1.0]; 3],
        translation_m: vec![[0.0; 3]; 3],
        elements: (0..3u32).map(|f| (0..n as u32).filter(|e| e % 3 == f).count() as u32).collect(),
        mass_kg: vec![1.0; 3],
        element_affine: Some(maps),
    };
    SceneGeometry::build(particles, Some(&fragments))
}

/// Compares the tracers; returns how many pixels see a fracture face first.
fn compare(scene: &SceneGeometry, look: &Look, camera: &Camera, samples: u32) -> usize {
    let ctx = GpuContext::shared_for_tests().expect("a GPU adapter (lavapipe in CI)");
    let tracer = GpuTracer::new(ctx).expect("tracer compiles");
    let gpu = tracer.render(ctx, scene, look, camera, samples).expect("GPU render");
    let cpu = render(scene, look, camera, samples);
    let mut hits = 0;
    let mut fractures = 0;
    for (index, (g, c)) in gpu.pixels.iter().zip(&cpu.pixels).enumerate() {
        assert_eq!(g.element, c.element, "pixel {index}: element");
        assert_eq!(g.fragment, c.fragment, "pixel {index}: fragment");
        assert_eq!(g.surface, c.surface, "pixel {index}: surface kind");
        fractures += usize::from(c.surface == SURFACE_FRACTURE);
        if c.element != NONE {
            hits += 1;
            assert!((g.depth - c.depth).abs() <= 1e-5 * c.depth, "pixel {index}: depth {} vs {}", g.depth, c.depth);
            for a in 0..3 {
                assert!((g.normal[a] - c.normal[a]).abs() < 1e-5, "pixel {index}: normal");
            }
        }
        for k in 0..3 {
            // colour and the denoising guides: same paths almost everywhere; a rare Fresnel coin
            // landing differently changes a sample
            for (what, g, c) in [
                ("colour", g.color, c.color),
                ("albedo guide", g.denoising_albedo, c.denoising_albedo),
                ("normal guide", g.denoising_normal, c.denoising_normal),
            ] {
                if (g[k] - c[k]).abs() > 1e-3 * (1.0 + c[k].abs()) {
                    assert!(samples > 1, "pixel {index}: {what} {g:?} vs {c:?}");
                }
            }
        }
    }
    let pixels = cpu.pixels.len();
    assert!(hits > pixels / 10, "the scene covers the image ({hits} of {pixels})");
    // Jittered samples see the same first surfaces but for rounding right at an edge.
    let differing = gpu.mattes.iter().zip(&cpu.mattes).filter(|(g, c)| g != c).count();
    assert!(differing * 100 <= pixels, "{differing} of {pixels} pixels' matte counts differ");
    if samples == 1 {
        assert_eq!(differing, 0);
    }
    fractures
}

#[test]
fn gpu_and_cpu_agree_on_random_glass_cube_scenes() {
    let mut fractures = 0;
    for seed in 0..3 {
        let scene = random_scene(seed, false);
        let camera =
            Camera::look_at(DVec3::new(0.4, 0.5, 1.2 + seed as f64 * 0.1), DVec3::ZERO, DVec3::Y, 45.0, 48, 36);
        fractures += compare(&scene, &look(seed % 2 == 0), &camera, 1);
    }
    assert!(fractures > 0, "faces resting on neighbours show as fracture faces");
}

/// `render.material.cubes = "opaque"` (clay, metal): the cubes shade as tetrahedra do.
#[test]
fn gpu_and_cpu_agree_on_random_opaque_cube_scenes() {
    let scene = random_scene(5, false);
    let camera = Camera::look_at(DVec3::new(0.4, 0.5, 1.3), DVec3::ZERO, DVec3::Y, 45.0, 48, 36);
    let look = Look { opaque_cubes: true, ..look(true) };
    assert!(compare(&scene, &look, &camera, 2) > 0, "faces resting on neighbours show as fracture faces");
    // the floor's texture filtered over each ray's footprint (render.texture_filter)
    let mut filtered = look.clone();
    if let Some(floor) = filtered.floor.as_mut() {
        floor.mips = Some(MipChain::of(floor));
    }
    compare(&scene, &filtered, &camera, 2);
}

/// Deformed elements: each element mapped by its own affine map (sheared, stretched cubes and
/// tetrahedra): the tracers agree as on rigid scenes.
#[test]
fn gpu_and_cpu_agree_on_deformed_scenes() {
    let camera = Camera::look_at(DVec3::new(0.4, 0.5, 1.3), DVec3::new(0.0, 0.05, 0.0), DVec3::Y, 45.0, 48, 36);
    let particles = random_particles(3, false);
    let glass = bent_scene(&particles);
    let rigid = SceneGeometry::build(&particles, None);
    let turned = glass.planes.iter().zip(&rigid.planes).filter(|(a, b)| (a[0] - b[0]).abs() > 0.05).count();
    assert!(turned * 2 > rigid.planes.len(), "the elements are bent: {turned} of {} planes turned", rigid.planes.len());
    assert!(compare(&glass, &look(true), &camera, 1) > 0, "faces resting on neighbours show as fracture faces");
    let opaque = Look { opaque_cubes: true, ..look(false) };
    compare(&glass, &opaque, &camera, 2);
    let camera = Camera::look_at(DVec3::new(-0.3, 0.25, 0.5), DVec3::ZERO, DVec3::Y, 50.0, 48, 36);
    compare(&bent_scene(&random_particles(11, true)), &look(true), &camera, 2);
}

#[test]
fn gpu_and_cpu_agree_on_random_opaque_tet_scenes() {
    for seed in 10..12 {
        let scene = random_scene(seed, true);
        let camera = Camera::look_at(DVec3::new(-0.3, 0.25, 0.5), DVec3::ZERO, DVec3::Y, 50.0, 48, 36);
        compare(&scene, &look(true), &camera, 2);
    }
}

/// Clips the convex polygon `polygon` to the half-space n . x <= d.
fn clip(polygon: &[[f32; 3]], plane: [f32; 4]) -> Vec<[f32; 3]> {
    let side = |p: &[f32; 3]| plane[0] * p[0] + plane[1] * p[1] + plane[2] * p[2] - plane[3];
    let mut out = Vec::new();
    for k in 0..polygon.len() {
        let (a, b) = (polygon[k], polygon[(k + 1) % polygon.len()]);
        let (sa, sb) = (side(&a), side(&b));
        if sa <= 0.0 {
            out.push(a);
        }
        if (sa < 0.0) != (sb < 0.0) && sa != 0.0 && sb != 0.0 {
            let t = sa / (sa - sb);
            out.push([0, 1, 2].map(|i| a[i] + t * (b[i] - a[i])));
        }
    }
    out
}

/// The four triangles of `t` cut at its edges' midpoints, wound as `t`.
fn split_in_four(t: [[f32; 3]; 3]) -> [[[f32; 3]; 3]; 4] {
    let mid = |a: [f32; 3], b: [f32; 3]| [0, 1, 2].map(|k| 0.5 * (a[k] + b[k]));
    let (ab, bc, ca) = (mid(t[0], t[1]), mid(t[1], t[2]), mid(t[2], t[0]));
    [[t[0], ab, ca], [ab, t[1], bc], [ca, bc, t[2]], [ab, bc, ca]]
}

/// Fan triangles of a convex polygon, wound outward about `normal`.
fn fan(polygon: &[[f32; 3]], normal: [f32; 3]) -> Vec<[[f32; 3]; 3]> {
    (1..polygon.len().saturating_sub(1))
        .map(|k| {
            let mut t = [polygon[0], polygon[k], polygon[k + 1]];
            let e = [0, 1].map(|j| [0, 1, 2].map(|a| t[j + 1][a] - t[0][a]));
            let n = [0, 1, 2].map(|a| e[0][(a + 1) % 3] * e[1][(a + 2) % 3] - e[0][(a + 2) % 3] * e[1][(a + 1) % 3]);
            if (0..3).map(|a| n[a] * normal[a]).sum::<f32>() < 0.0 {
                t.swap(1, 2);
            }
            t
        })
        .collect()
}

/// Box cells on a lattice 0.1 apart under the tilted surface z = 0.3 x + 0.02 (outward +z): the
/// cells whose site lies below it, each column's top cell reaching up to z = 0.5 (as a clipped
/// Voronoi cell by the surface reaches out to the box every cell starts from); those the surface
/// crosses carry its triangles (each split in 16, so that cells carry several groups of them).
/// With `faces`, each cell's faces' parts below the surface, as preprocessing gives them (a
/// trimtope's bounds are then those of the part of its cell below the surface); without, none
/// (its bounds are its cell's).
fn cells_under_a_tilted_surface(faces: bool) -> ParticleSet {
    let surface = |x: f32| 0.3 * x + 0.02;
    let length = (0.3f32 * 0.3 + 1.0).sqrt();
    let normal = [-0.3 / length, 0.0, 1.0 / length];
    let below = [normal[0], normal[1], normal[2], 0.02 / length];
    let (mut sites, mut plane_offsets, mut planes, mut triangle_offsets, mut triangles) =
        (Vec::new(), vec![0u64], Vec::new(), vec![0u64], Vec::new());
    let (mut face_offsets, mut face_triangles, mut face_planes) = (vec![0u64], Vec::new(), Vec::new());
    for x in -2..=2 {
        for y in -2..=2 {
            for z in -3..=1 {
                let c = [x as f32 * 0.1, y as f32 * 0.1, z as f32 * 0.1];
                if c[2] >= surface(c[0]) {
                    continue;
                }
                let top = z == 1 || c[2] + 0.1 >= surface(c[0]);
                let (lo, hi) = (c.map(|v| v - 0.05), [c[0] + 0.05, c[1] + 0.05, if top { 0.5 } else { c[2] + 0.05 }]);
                // +axis then -axis, inside where n . x <= d
                let cell: Vec<[f32; 4]> = (0..3)
                    .flat_map(|a| {
                        let mut n = [0.0f32; 3];
                        n[a] = 1.0;
                        [[n[0], n[1], n[2], hi[a]], [-n[0], -n[1], -n[2], -lo[a]]]
                    })
                    .collect();
                let mut polygon = vec![
                    [-1.0, -1.0, surface(-1.0)],
                    [1.0, -1.0, surface(1.0)],
                    [1.0, 1.0, surface(1.0)],
                    [-1.0, 1.0, surface(-1.0)],
                ];
                for plane in &cell {
                    polygon = clip(&polygon, *plane);
                }
                triangles.extend(fan(&polygon, normal).into_iter().flat_map(split_in_four).flat_map(split_in_four));
                for (k, plane) in cell.iter().enumerate().filter(|_| faces) {
                    let (a, u, v) = (k / 2, (k / 2 + 1) % 3, (k / 2 + 2) % 3);
                    let square: Vec<[f32; 3]> = [(lo, lo), (hi, lo), (hi, hi), (lo, hi)]
                        .map(|(pu, pv)| {
                            let mut p = [0.0; 3];
                            p[a] = if k % 2 == 0 { hi[a] } else { lo[a] };
                            (p[u], p[v]) = (pu[u], pv[v]);
                            p
                        })
                        .to_vec();
                    let inside = fan(&clip(&square, below), [plane[0], plane[1], plane[2]]);
                    face_planes.extend(inside.iter().map(|_| k as u32));
                    face_triangles.extend(inside);
                }
                face_offsets.push(face_triangles.len() as u64);
                sites.push(c);
                planes.extend(cell);
                plane_offsets.push(planes.len() as u64);
                triangle_offsets.push(triangles.len() as u64);
            }
        }
    }
    let elements = Elements::Trimtopes {
        plane_offsets,
        planes,
        triangle_offsets,
        triangles_m: triangles,
        face_offsets,
        face_triangles_m: face_triangles,
        face_planes,
    };
    set(sites, elements)
}

#[test]
fn gpu_and_cpu_agree_on_trimtopes_with_an_embedded_surface() {
    let particles = cells_under_a_tilted_surface(true);
    let scene = SceneGeometry::build(&particles, None);
    let cell_bounded = SceneGeometry::build(&cells_under_a_tilted_surface(false), None);
    for (eye, samples) in [(DVec3::new(0.2, 0.6, 0.8), 1), (DVec3::new(-0.9, -0.2, -0.3), 2)] {
        let camera = Camera::look_at(eye, DVec3::new(0.0, 0.0, -0.1), DVec3::Y, 50.0, 48, 36);
        assert!(compare(&scene, &look(false), &camera, samples) > 0, "trimtope cell faces are fracture faces");
        // bounds of the part below the surface cull rays, and lose no hit
        let (tight, loose) =
            (render(&scene, &look(false), &camera, samples), render(&cell_bounded, &look(false), &camera, samples));
        assert!(tight.pixels == loose.pixels, "the cells' own bounds and the tighter ones give other pixels");
    }
    // the cells the surface crosses are bounded by what lies below it, the others by themselves
    let volume = |b: &[f32; 3], c: &[f32; 3]| (0..3).map(|a| c[a] - b[a]).product::<f32>();
    let mut crossed = [0.0f32; 2];
    for (e, (tight, loose)) in scene.element_bounds.iter().zip(&cell_bounded.element_bounds).enumerate() {
        let (tight, loose) = (volume(&tight.min, &tight.max), volume(&loose.min, &loose.max));
        if scene.triangles_of(e).is_empty() {
            assert!((tight / loose - 1.0).abs() < 1e-3, "cell {e}: bounds {tight} against its cell's {loose}");
        } else {
            crossed = [crossed[0] + tight, crossed[1] + loose];
        }
    }
    assert!(crossed[0] < 0.5 * crossed[1], "the crossed cells' bounds: {crossed:?} against their cells'");
    // deformed cells: planes and embedded triangles mapped by each cell's affine map
    let bent = bent_scene(&particles);
    assert_ne!(bent.triangles, scene.triangles);
    let camera = Camera::look_at(DVec3::new(0.2, 0.6, 0.8), DVec3::new(0.0, 0.0, -0.1), DVec3::Y, 50.0, 48, 36);
    assert!(compare(&bent, &look(false), &camera, 2) > 0, "deformed trimtope cell faces are fracture faces");
}
