//! Depth of field against thin-lens optics: a small cube on the plane in focus stays as sharp as
//! through a pinhole; off it, it spreads into the circle of confusion that the thin-lens
//! equation predicts, within 5%; the CPU and GPU tracers agree through the lens.

use crate::support;

use glam::DVec3;
use shatter_core::particles::{Elements, ParticleSet};
use shatter_gpu::GpuContext;
use shatter_render::camera::{Camera, Lens};
use shatter_render::gpu_trace::GpuTracer;
use shatter_render::image_loop::render;
use shatter_render::materials::Look;
use shatter_render::scene_geometry::SceneGeometry;

/// The image's side, pixels.
const SIZE: u32 = 64;
/// Its vertical field of view, degrees.
const FOV_DEG: f64 = 20.0;
/// The sensor's height, mm.
const SENSOR_MM: f64 = 24.0;

/// Opaque cubes on a transparent background: alpha is their coverage.
fn look() -> Look {
    Look { show_environment: false, ..Look::under(support::uniform_sky([0.5; 3], (4, 2))) }
}

/// A cube `edge_m` wide at distance `distance_m` in front of the camera at z = 1.
fn cube(edge_m: f32, distance_m: f32) -> ParticleSet {
    let elements = Elements::Cubes { half_size_m: vec![0.5 * edge_m], orientation: [0.0, 0.0, 0.0, 1.0] };
    support::particle_set(vec![[0.0, 0.0, 1.0 - distance_m]], elements, f64::from(edge_m), Vec::new())
}

/// The camera at z = 1 looking down -z, through a lens of f-number `f_stop` focused at
/// `focus_m`, or a pinhole.
fn camera(lens: Option<(f64, f64)>) -> Camera {
    let mut camera = Camera::look_at(DVec3::new(0.0, 0.0, 1.0), DVec3::ZERO, DVec3::Y, FOV_DEG, SIZE, SIZE);
    camera.lens = lens.map(|(f_stop, focus_m)| Lens::of(f_stop, focus_m, FOV_DEG, SENSOR_MM));
    camera
}

/// The alpha-weighted mean squared distance from the alpha's centroid, pixels squared.
fn spread(alpha: &[f32]) -> f64 {
    let (mut total, mut mx, mut my) = (0.0, 0.0, 0.0);
    for (i, a) in alpha.iter().enumerate() {
        let (x, y, a) = ((i % SIZE as usize) as f64 + 0.5, (i / SIZE as usize) as f64 + 0.5, f64::from(*a));
        (total, mx, my) = (total + a, mx + a * x, my + a * y);
    }
    let (mx, my) = (mx / total, my / total);
    alpha
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let (x, y) = ((i % SIZE as usize) as f64 + 0.5, (i / SIZE as usize) as f64 + 0.5);
            f64::from(*a) * ((x - mx).powi(2) + (y - my).powi(2))
        })
        .sum::<f64>()
        / total
}

fn alphas(scene: &SceneGeometry, camera: &Camera, samples: u32) -> Vec<f32> {
    render(scene, &look(), camera, samples).pixels.iter().map(|p| p.alpha).collect()
}

#[test]
fn a_point_off_focus_spreads_into_the_thin_lens_circle_of_confusion() {
    let (f_stop, focus_m, distance_m, edge_m) = (1.4, 0.25, 1.0, 0.01f32);
    let scene = SceneGeometry::build(&cube(edge_m, distance_m as f32), None);
    let blurred = spread(&alphas(&scene, &camera(Some((f_stop, focus_m))), 1024));
    let sharp = spread(&alphas(&scene, &camera(None), 1024));
    // thin-lens optics: the sensor v behind the lens images the focus plane and spans the field
    // of view; the focal length f from 1/f = 1/v + 1/s, the aperture f / N; a point at d
    // blurs into a disk of diameter A |d - s| / d * f / (s - f) on the sensor
    let v = 0.5e-3 * SENSOR_MM / (0.5 * FOV_DEG.to_radians()).tan();
    let f = 1.0 / (1.0 / v + 1.0 / focus_m);
    let aperture = f / f_stop;
    let coc_m = aperture * (distance_m - focus_m).abs() / distance_m * f / (focus_m - f);
    let coc_px = coc_m / (1e-3 * SENSOR_MM) * f64::from(SIZE);
    // a uniform disk of radius R adds R^2 / 2 to the spread of the pinhole's image
    let radius_px = (2.0 * (blurred - sharp)).sqrt();
    eprintln!("blur diameter {} px, thin lens {coc_px} px", 2.0 * radius_px);
    assert!(coc_px > 10.0, "a visible circle: {coc_px} px");
    assert!(
        (2.0 * radius_px / coc_px - 1.0).abs() < 0.05,
        "blur diameter {} px, thin lens {coc_px} px",
        2.0 * radius_px
    );
}

#[test]
fn a_point_in_focus_stays_sharp() {
    let scene = SceneGeometry::build(&cube(0.02, 0.5), None);
    let through_lens = alphas(&scene, &camera(Some((1.4, 0.5))), 256);
    let pinhole = alphas(&scene, &camera(None), 256);
    let (a, b) = (spread(&through_lens), spread(&pinhole));
    assert!((a - b).abs() < 0.02 * b, "spread through the lens {a} px^2, pinhole {b} px^2");
    let worst = through_lens.iter().zip(&pinhole).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    assert!(worst < 0.1, "pixels differ by up to {worst}");
    // and the same cube off focus does not stay sharp
    let off = alphas(&scene, &camera(Some((1.4, 0.3))), 256);
    assert!(spread(&off) > 2.0 * b);
}

#[test]
fn gpu_and_cpu_agree_through_a_lens() {
    let mut centres = Vec::new();
    for k in 0..12u32 {
        centres.push([(k % 4) as f32 * 0.05 - 0.075, (k / 4) as f32 * 0.05 - 0.05, (k % 3) as f32 * -0.3]);
    }
    let n = centres.len();
    let elements = Elements::Cubes { half_size_m: vec![0.02; n], orientation: [0.0, 0.0, 0.0, 1.0] };
    let scene = SceneGeometry::build(&support::particle_set(centres, elements, 0.04, Vec::new()), None);
    let camera = camera(Some((2.0, 0.8)));
    let ctx = GpuContext::shared_for_tests().expect("a GPU adapter (lavapipe in CI)");
    let tracer = GpuTracer::new(ctx).expect("tracer compiles");
    let gpu = tracer.render(ctx, &scene, &look(), &camera, 16).expect("GPU render");
    let cpu = render(&scene, &look(), &camera, 16);
    let mut difference = 0.0f64;
    for (g, c) in gpu.pixels.iter().zip(&cpu.pixels) {
        assert_eq!((g.element, g.fragment, g.surface), (c.element, c.fragment, c.surface), "the pinhole's layers");
        difference += f64::from((g.alpha - c.alpha).abs());
    }
    let pixels = cpu.pixels.len() as f64;
    assert!(difference / pixels < 1e-3, "alpha differs by {} on average", difference / pixels);
    let differing = gpu.mattes.iter().zip(&cpu.mattes).filter(|(g, c)| g != c).count();
    assert!(differing * 100 <= cpu.mattes.len(), "{differing} pixels' matte counts differ");
}
