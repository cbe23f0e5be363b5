//! 3D motion blur against analytic cases: a cube moving across the frame blurs into the streak
//! that its motion over the shutter predicts, a turning piece sweeps the arc of its turn (not
//! the chord), the CPU and GPU tracers agree on a blurred frame, and a blurred frame is the same
//! for any thread count.

use crate::support;

use glam::{DQuat, DVec3};
use shatter_core::fragments::{FragmentFrame, FragmentMeta};
use shatter_core::particles::{Elements, ParticleSet};
use shatter_gpu::GpuContext;
use shatter_render::camera::Camera;
use shatter_render::gpu_trace::GpuTracer;
use shatter_render::image_loop::{Rendered, render};
use shatter_render::materials::Look;
use shatter_render::scene_geometry::SceneGeometry;
use shatter_render::shutter::FramePoses;

/// Half the cubes' edge, metres.
const HALF: f32 = 0.05;

/// Opaque cubes on a black, transparent background: alpha is the cubes' coverage.
fn coverage_look() -> Look {
    Look { show_environment: false, ..Look::under(support::uniform_sky([0.5; 3], (4, 2))) }
}

/// Cubes at `centres`, one fragment each unless `fragment_of` says otherwise.
fn cubes(centres: Vec<[f32; 3]>) -> ParticleSet {
    let n = centres.len();
    let elements = Elements::Cubes { half_size_m: vec![HALF; n], orientation: [0.0, 0.0, 0.0, 1.0] };
    support::particle_set(centres, elements, f64::from(2.0 * HALF), Vec::new())
}

/// A frame moving every element as one fragment by rotation `q` and translation `t`.
fn frame(elements: usize, q: DQuat, t: [f64; 3]) -> FragmentFrame {
    let q = q.as_quat().to_array();
    FragmentFrame {
        meta: FragmentMeta { frame: 2, step: 0, time_s: 0.0, smoothed: false, inputs: None },
        fragment_of: vec![0; elements],
        rotation: vec![q],
        translation_m: vec![t],
        elements: vec![elements as u32],
        mass_kg: vec![1.0],
        element_affine: None,
    }
}

/// The alpha of each pixel, row-major.
fn alphas(rendered: &Rendered) -> Vec<f32> {
    rendered.pixels.iter().map(|p| p.alpha).collect()
}

/// Where the profile first and last crosses `level`, interpolated between columns (column x
/// stands at x + 0.5).
fn crossings(profile: &[f64], level: f64) -> (f64, f64) {
    let at = |x: usize| {
        let (a, b) = (profile[x], profile[x + 1]);
        x as f64 + 0.5 + (level - a) / (b - a)
    };
    let first = (0..profile.len() - 1).find(|&x| profile[x] < level && profile[x + 1] >= level).expect("rises");
    let last = (0..profile.len() - 1).rev().find(|&x| profile[x] >= level && profile[x + 1] < level).expect("falls");
    (at(first), at(last))
}

#[test]
fn a_moving_cube_blurs_into_the_predicted_streak() {
    // 0.3 m a frame along x, seen from 10 m: a 180-degree shutter sweeps 0.15 m
    let (width, height, samples, step_m) = (96u32, 16u32, 256u32, 0.3f64);
    let camera = Camera::look_at(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, DVec3::Y, 2.0, width, height);
    let particles = cubes(vec![[0.0; 3]]);
    let (before, now, after) = (
        frame(1, DQuat::IDENTITY, [-step_m, 0.0, 0.0]),
        frame(1, DQuat::IDENTITY, [0.0; 3]),
        frame(1, DQuat::IDENTITY, [step_m, 0.0, 0.0]),
    );
    let poses = FramePoses { current: Some(&now), previous: Some(Some(&before)), next: Some(Some(&after)) };
    let scene = SceneGeometry::build_over_shutter(&particles, poses, 0.5);
    assert!(scene.motion.is_some());
    let rendered = render(&scene, &coverage_look(), &camera, samples);
    // the rows that see the cube's back face whole, averaged
    let back = |y: f32| camera.pixel_of(DVec3::new(0.0, f64::from(y), -f64::from(HALF))).expect("in front")[1];
    let (top, bottom) = (back(HALF).ceil() as usize, back(-HALF).floor() as usize);
    assert!(bottom >= top + 4, "rows {top}..{bottom}");
    let alpha = alphas(&rendered);
    let measured: Vec<f64> = (0..width as usize)
        .map(|x| (top..bottom).map(|y| f64::from(alpha[y * width as usize + x])).sum::<f64>() / (bottom - top) as f64)
        .collect();
    // predicted: the silhouette's columns [a, b] at each time of the shutter, over each pixel
    let silhouette = |shift: f64| {
        let xs: Vec<f64> = (0..8)
            .map(|c| {
                let corner = DVec3::new(
                    shift + if c & 1 == 1 { 1.0 } else { -1.0 } * f64::from(HALF),
                    if c & 2 == 2 { 1.0 } else { -1.0 } * f64::from(HALF),
                    if c & 4 == 4 { 1.0 } else { -1.0 } * f64::from(HALF),
                );
                camera.pixel_of(corner).expect("in front")[0]
            })
            .collect();
        (xs.iter().cloned().fold(f64::INFINITY, f64::min), xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max))
    };
    let times = 4000;
    let predicted: Vec<f64> = (0..width as usize)
        .map(|x| {
            (0..times)
                .map(|k| {
                    let tau = -0.25 + 0.5 * (k as f64 + 0.5) / times as f64;
                    let (a, b) = silhouette(tau * step_m);
                    (b.min(x as f64 + 1.0) - a.max(x as f64)).max(0.0)
                })
                .sum::<f64>()
                / times as f64
        })
        .collect();
    let worst = measured.iter().zip(&predicted).map(|(m, p)| (m - p).abs()).fold(0.0, f64::max);
    assert!(worst < 0.02, "profile off by {worst}:\nmeasured {measured:.3?}\npredicted {predicted:.3?}");
    // the streak's length, between its outer 5% points, against the prediction's
    let (m0, m1) = crossings(&measured, 0.05);
    let (p0, p1) = crossings(&predicted, 0.05);
    let (length, expected) = (m1 - m0, p1 - p0);
    assert!((length - expected).abs() < 0.02 * expected, "streak {length:.2} px, predicted {expected:.2} px");
    // longer than the still cube by the distance swept
    let (still_a, still_b) = silhouette(0.0);
    let swept = silhouette(0.075).1 - silhouette(-0.075).1;
    assert!(length > (still_b - still_a) + 0.8 * swept, "{length} px against {} px still", still_b - still_a);
    // the layers stay those of the frame's centre: depth and ids only where the still cube is
    let row = (top + bottom) / 2;
    for x in 0..width as usize {
        let pixel = &rendered.pixels[row * width as usize + x];
        let centre = x as f64 + 0.5;
        if centre < still_a - 0.5 || centre > still_b + 0.5 {
            assert_eq!(pixel.fragment, 0, "column {x}: nothing at the centre time");
        } else if centre > still_a + 0.5 && centre < still_b - 0.5 {
            assert_eq!(pixel.fragment, 1, "column {x}: the cube at the centre time");
        }
    }
}

#[test]
fn a_turning_piece_sweeps_the_arc_of_its_turn() {
    // two cubes 0.5 m either side of their centroid, turning 2.4 rad a frame about the view axis
    // (the piece's centre stays put); a full-frame shutter sweeps each over 2.4 rad of a circle
    let (size, samples, turn, radius) = (64u32, 128u32, 2.4f64, 0.5f64);
    let camera = Camera::look_at(DVec3::new(0.0, 0.0, 20.0), DVec3::ZERO, DVec3::Y, 3.8, size, size);
    let particles = cubes(vec![[radius as f32, 0.0, 0.0], [-radius as f32, 0.0, 0.0]]);
    let turned = |angle: f64| frame(2, DQuat::from_rotation_z(angle), [0.0; 3]);
    let (before, now, after) = (turned(-turn), turned(0.0), turned(turn));
    let poses = FramePoses { current: Some(&now), previous: Some(Some(&before)), next: Some(Some(&after)) };
    let scene = SceneGeometry::build_over_shutter(&particles, poses, 1.0);
    let alpha = alphas(&render(&scene, &coverage_look(), &camera, samples));
    let eye = DVec3::new(0.0, 0.0, 20.0);
    // what the pixel at (x, y) sees at z = 0, nearly orthographic from 20 m
    let ground = |x: f64, y: f64| {
        let d = DVec3::from_array(camera.direction(x as f32, y as f32).map(f64::from));
        eye + d * (-eye.z / d.z)
    };
    // predicted coverage: the point turned back by the piece's angle at each time lies in a
    // cube's footprint
    let covered = |p: DVec3, tau: f64| {
        let q = DQuat::from_rotation_z(-turn * tau) * p;
        let inside = |cx: f64| (q.x - cx).abs() <= f64::from(HALF) && q.y.abs() <= f64::from(HALF);
        inside(radius) || inside(-radius)
    };
    let predict = |x: usize, y: usize| {
        let mut hits = 0;
        let (grid, times) = (4, 256);
        for u in 0..grid * grid {
            let p = ground(x as f64 + (u % grid) as f64 / 4.0 + 0.125, y as f64 + (u / grid) as f64 / 4.0 + 0.125);
            hits += (0..times).filter(|k| covered(p, -0.5 + (*k as f64 + 0.5) / times as f64)).count();
        }
        hits as f64 / (grid * grid * times) as f64
    };
    let pixel_at = |angle: f64, r: f64| {
        let p = camera.pixel_of(DVec3::new(r * angle.cos(), r * angle.sin(), 0.0)).expect("in front");
        (p[0] as usize, p[1] as usize)
    };
    // along the arc: as predicted, summed over 3 x 3 pixels to tame the sampling noise
    for angle in [-1.0, -0.6, -0.3, 0.3, 0.6, 1.0] {
        let (x, y) = pixel_at(angle, radius);
        let (mut got, mut want) = (0.0, 0.0);
        for (dx, dy) in (0..9).map(|k| (k % 3, k / 3)) {
            got += f64::from(alpha[(y + dy - 1) * size as usize + x + dx - 1]);
            want += predict(x + dx - 1, y + dy - 1);
        }
        assert!(want > 9.0 * 0.05, "the arc at {angle} rad is covered part of the time");
        assert!((got - want).abs() < 9.0 * 0.02, "arc at {angle} rad: alpha {} against {}", got / 9.0, want / 9.0);
    }
    // the chord from the centre pose to the next (where blending the positions would draw the
    // cube halfway) stays empty
    let chord = DVec3::new(radius * (1.0 + turn.cos()) / 2.0, radius * turn.sin() / 2.0, 0.0);
    let p = camera.pixel_of(chord).expect("in front");
    assert_eq!(alpha[p[1] as usize * size as usize + p[0] as usize], 0.0, "the chord's midpoint is empty");
}

/// Random glass cubes in three fragments, each moving and turning its own way.
fn moving_scene(shutter: f64) -> SceneGeometry {
    let mut centres = Vec::new();
    for k in 0..40u32 {
        let (x, y, z) = (k % 5, (k / 5) % 4, k / 20);
        centres.push([x as f32 * 0.1 - 0.2, y as f32 * 0.1 - 0.15, z as f32 * 0.1 - 0.05]);
    }
    let particles = cubes(centres);
    let n = particles.len();
    let pose = |s: f64| {
        let mut f = frame(n, DQuat::IDENTITY, [0.0; 3]);
        f.fragment_of = (0..n as u32).map(|e| e % 3).collect();
        f.rotation = (0..3)
            .map(|k| DQuat::from_axis_angle(DVec3::new(1.0, k as f64, 0.5).normalize(), s * 0.6).as_quat().to_array())
            .collect();
        f.translation_m = (0..3).map(|k| [s * 0.2 * k as f64, -s * 0.12, s * 0.08]).collect();
        f.elements = (0..3u32).map(|k| (0..n as u32).filter(|e| e % 3 == k).count() as u32).collect();
        f.mass_kg = vec![1.0; 3];
        f
    };
    let (before, now, after) = (pose(-1.0), pose(0.0), pose(1.2));
    let poses = FramePoses { current: Some(&now), previous: Some(Some(&before)), next: Some(Some(&after)) };
    SceneGeometry::build_over_shutter(&particles, poses, shutter)
}

fn glass_look() -> Look {
    Look {
        absorption: [0.5, 0.2, 0.1],
        glass_split_events: 1,
        opaque_cubes: false,
        ..Look::under(support::gradient_sky())
    }
}

#[test]
fn gpu_and_cpu_agree_on_a_blurred_frame() {
    let scene = moving_scene(0.5);
    assert!(scene.motion.is_some());
    let camera = Camera::look_at(DVec3::new(0.3, 0.4, 1.4), DVec3::ZERO, DVec3::Y, 45.0, 48, 36);
    let look = glass_look();
    let ctx = GpuContext::shared_for_tests().expect("a GPU adapter (lavapipe in CI)");
    let tracer = GpuTracer::new(ctx).expect("tracer compiles");
    let samples = 8;
    let gpu = tracer.render(ctx, &scene, &look, &camera, samples).expect("GPU render");
    let cpu = render(&scene, &look, &camera, samples);
    let still = render(&moving_scene(0.0), &look, &camera, samples);
    let mut difference = 0.0f64;
    let mut blur = 0.0f64;
    for ((g, c), s) in gpu.pixels.iter().zip(&cpu.pixels).zip(&still.pixels) {
        // the layers are the centre's: as for still frames
        assert_eq!((g.element, g.fragment, g.surface), (c.element, c.fragment, c.surface));
        assert_eq!((c.element, c.fragment, c.surface), (s.element, s.fragment, s.surface));
        difference += (0..3).map(|k| f64::from((g.color[k] - c.color[k]).abs())).sum::<f64>()
            + f64::from((g.alpha - c.alpha).abs());
        blur += (0..3).map(|k| f64::from((c.color[k] - s.color[k]).abs())).sum::<f64>();
    }
    let pixels = cpu.pixels.len() as f64;
    assert!(blur / pixels > 0.003, "the blurred frame differs from the still one ({})", blur / pixels);
    assert!(
        difference / pixels < 0.02 * blur / pixels,
        "GPU against CPU: {} (blur {})",
        difference / pixels,
        blur / pixels
    );
    let differing = gpu.mattes.iter().zip(&cpu.mattes).filter(|(g, c)| g != c).count();
    assert!(differing * 100 <= cpu.mattes.len(), "{differing} pixels' matte counts differ");
}

#[test]
fn a_blurred_frame_is_the_same_for_any_thread_count() {
    let scene = moving_scene(0.5);
    let camera = Camera::look_at(DVec3::new(0.3, 0.4, 1.4), DVec3::ZERO, DVec3::Y, 45.0, 40, 30);
    let look = glass_look();
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
        pool.install(|| render(&scene, &look, &camera, 4))
    };
    let one = on(1);
    assert!(one == on(2) && one == on(3), "bit-identical pixels and mattes");
}
