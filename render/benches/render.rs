//! Benchmark: primary rays per second on a 600,000-element scene (100 x 100 x 60 glass cubes,
//! rotated), and on a preprocessed particle file's elements where one is named (dragon_paper's
//! 473,749 trimtopes: `scripts/gpu-bench.sh` makes one), on the CPU path and, when one is found, on
//! a GPU (`SHATTER_GPU_ALLOW_SOFTWARE=1` lets lavapipe stand in). Also the paper-scale target's
//! shape: 1920 x 1080 at 4 samples per pixel, timed on the GPU only.
//!
//! `cargo bench -p shatter-render --bench render [-- WIDTH HEIGHT] [-- --particles FILE]` (default
//! 640 x 360 for the CPU). The file's scene is seen from a fixed direction, framed on its bounds.
//! On the CPU it times building the scene (its k-d tree), the nearest hits alone (as a
//! ray-casting library counts them), then primary hits shaded, then full glass paths
//! (`scripts/peers/embree_glass.py` traces the same paths with Embree for the cubes).
//! On a GPU it times primary hits and full glass paths at the CPU's size, printing how far its
//! images are from the CPU's, and then, on a hardware GPU, at 1920 x 1080 x 4 spp. The cubes
//! carry their face adjacency, as preprocessing gives every grid (the glass walk uses it).

use std::path::Path;
use std::time::Instant;

use glam::{DQuat, DVec3};
use rayon::prelude::*;
use shatter_core::particles::{Elements, ParticleSet};
use shatter_gpu::{AdapterChoice, GpuContext};
use shatter_render::camera::Camera;
use shatter_render::gpu_trace::GpuTracer;
use shatter_render::hit_search::closest_hit;
use shatter_render::image_loop::{Rendered, pixel_hits, render};
use shatter_render::lighting::EnvironmentMap;
use shatter_render::materials::Look;
use shatter_render::scene_geometry::SceneGeometry;

/// Passes of the nearest-hit query, each timed: a pass at the default size takes tens of
/// milliseconds, too short for one timing on a shared machine; the median is reported (as
/// `scripts/peers/embree_primary.py` reports Embree's).
const NEAREST_PASSES: usize = 9;
/// Passes of each shaded render, each timed; the median is reported.
const SHADED_PASSES: usize = 5;

fn scene() -> ParticleSet {
    let mut positions = Vec::with_capacity(600_000);
    for x in 0..100 {
        for y in 0..100 {
            for z in 0..60 {
                positions.push([x as f32 * 0.001 - 0.05, y as f32 * 0.001, z as f32 * 0.001 - 0.03]);
            }
        }
    }
    let n = positions.len();
    // face neighbours, as preprocessing records them: the next cube along x, y and z
    let index = |x: usize, y: usize, z: usize| ((x * 100 + y) * 60 + z) as u32;
    let mut adjacency = Vec::with_capacity(3 * n);
    for x in 0..100 {
        for y in 0..100 {
            for z in 0..60 {
                let here = index(x, y, z);
                adjacency.extend(
                    [
                        (x + 1 < 100, index(x + 1, y, z)),
                        (y + 1 < 100, index(x, y + 1, z)),
                        (z + 1 < 60, index(x, y, z + 1)),
                    ]
                    .into_iter()
                    .filter(|(inside, _)| *inside)
                    .map(|(_, next)| [here, next]),
                );
            }
        }
    }
    let elements =
        Elements::Cubes { half_size_m: vec![0.0005; n], orientation: DQuat::from_rotation_y(0.3).as_quat().to_array() };
    ParticleSet {
        volume_m3: vec![1e-9; n],
        mass_kg: vec![1e-9; n],
        adjacency,
        ..ParticleSet::unbonded(positions, elements, 0.001)
    }
}

/// One scene to time: its elements and where the camera stands.
struct Case {
    label: String,
    particles: ParticleSet,
    eye: DVec3,
    target: DVec3,
}

/// The cube block, seen from above one corner.
fn cube_case() -> Case {
    let particles = scene();
    let label = format!("{} glass cubes", particles.len());
    Case { label, particles, eye: DVec3::new(0.09, 0.12, 0.11), target: DVec3::new(0.0, 0.05, 0.0) }
}

/// A particle file's elements, framed on their bounds from a fixed direction (the 40-degree
/// camera's vertical field holds three quarters of the bounding sphere: an elongated body fills
/// more of the frame).
fn file_case(path: &Path) -> Case {
    let particles = ParticleSet::read(path).unwrap_or_else(|error| panic!("{}: {error}", path.display()));
    let (lo, hi) = particles.rest_position_m.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
        let p = DVec3::from_array(p.map(f64::from));
        (lo.min(p), hi.max(p))
    });
    let (centre, radius) = ((lo + hi) / 2.0, (hi - lo).length() / 2.0);
    let eye = centre + DVec3::new(0.6, 0.35, 0.72).normalize() * 0.75 * radius / 20f64.to_radians().sin();
    let label = format!("{} {}s of {}", particles.len(), particles.elements.element_type().name(), path.display());
    Case { label, particles, eye, target: centre }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut sizes = args.iter().filter_map(|a| a.parse::<u32>().ok());
    let (width, height) = (sizes.next().unwrap_or(640), sizes.next().unwrap_or(360));
    let file = args.iter().position(|a| a == "--particles").and_then(|at| args.get(at + 1));
    let gpu = match GpuContext::new(AdapterChoice::from_env()) {
        Ok(context) => {
            let tracer = GpuTracer::new(&context).expect("tracer compiles");
            Some((context, tracer))
        }
        Err(_) => {
            println!("render benchmark: no GPU found (SHATTER_GPU_ALLOW_SOFTWARE=1 accepts lavapipe)");
            None
        }
    };
    let mut cases = vec![cube_case()];
    cases.extend(file.map(|path| file_case(Path::new(path))));
    for case in &cases {
        bench_case(case, (width, height), gpu.as_ref());
    }
}

/// Times `case` at `size` on the CPU and, given one, the GPU.
fn bench_case(case: &Case, (width, height): (u32, u32), gpu: Option<&(GpuContext, GpuTracer)>) {
    let particles = &case.particles;
    let started = Instant::now();
    let geometry = SceneGeometry::build(particles, None);
    println!("render benchmark: {}; scene + k-d tree built in {:.2} s", case.label, started.elapsed().as_secs_f64());
    let environment = EnvironmentMap::constant([1.0; 3]);
    let mut look = Look {
        absorption: [1.0, 0.3, 0.6],
        albedo: [0.8; 3],
        fracture_albedo: [0.8; 3],
        specular: 0.2,
        shininess: 64.0,
        max_bounces: 1,
        glass_split_events: 2,
        opaque_cubes: false,
        ..Look::under(environment)
    };
    let camera = |w: u32, h: u32| Camera::look_at(case.eye, case.target, DVec3::Y, 40.0, w, h);
    // What a ray-casting library counts (Embree's figure in scripts/compare-peers.sh): the
    // nearest element along each pixel-centre ray, no shading; in packets as the renderer
    // traces first surfaces, then one ray at a time, which must find the same.
    let rays = f64::from(width * height);
    let mut passes: Vec<(f64, Vec<_>)> = (0..NEAREST_PASSES)
        .map(|_| {
            let started = Instant::now();
            let hits = pixel_hits(&geometry, &camera(width, height));
            (started.elapsed().as_secs_f64(), hits)
        })
        .collect();
    passes.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (seconds, hits) = passes.swap_remove(NEAREST_PASSES / 2);
    let cam = camera(width, height);
    let started_single = Instant::now();
    let single: Vec<_> = (0..height)
        .into_par_iter()
        .flat_map_iter(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| closest_hit(&geometry, cam.origin, cam.direction(x as f32 + 0.5, y as f32 + 0.5), 0.0, 0.0))
        .collect();
    let seconds_single = started_single.elapsed().as_secs_f64();
    assert!(hits == single, "packets and single rays found other hits");
    println!(
        "  CPU ({} threads), nearest hits: {width} x {height}, median of {NEAREST_PASSES} passes {seconds:.3} s: {:.2} M rays/s ({} rays hit; one ray at a time {:.2} M rays/s)",
        rayon::current_num_threads(),
        rays / seconds / 1e6,
        hits.iter().filter(|h| h.element != u32::MAX).count(),
        rays / seconds_single / 1e6
    );
    let passes = [("primary hits only", 1), ("glass paths, 8 events", 8)];
    let mut cpu_images = Vec::new();
    for (label, bounces) in passes {
        look.max_bounces = bounces;
        let mut passes: Vec<(f64, Rendered)> = (0..SHADED_PASSES)
            .map(|_| {
                let started = Instant::now();
                let image = render(&geometry, &look, &camera(width, height), 1);
                (started.elapsed().as_secs_f64(), image)
            })
            .collect();
        passes.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (seconds, image) = passes.swap_remove(SHADED_PASSES / 2);
        let hits = image.pixels.iter().filter(|p| p.alpha > 0.0).count();
        // the image's mean, to set beside a peer tracing the same paths (scripts/peers/embree_glass.py)
        let sum: f64 = image.pixels.iter().flat_map(|p| p.color).map(f64::from).sum();
        println!(
            "  CPU ({} threads), {label}: {width} x {height} x 1 spp, median of {SHADED_PASSES} passes {seconds:.2} s: {:.3} \
             M rays/s ({hits} pixels on the body; mean colour {:.5})",
            rayon::current_num_threads(),
            f64::from(width * height) / seconds / 1e6,
            sum / (3.0 * image.pixels.len() as f64)
        );
        cpu_images.push(image);
    }
    let Some((context, tracer)) = gpu else {
        return;
    };
    let gpu = context.describe();
    for ((label, bounces), cpu_image) in passes.into_iter().zip(&cpu_images) {
        look.max_bounces = bounces;
        // First the CPU's size (it warms the pipeline up and is compared with the CPU's image),
        // then, on a hardware GPU, the target's: a pass too slow for the second still leaves
        // its figure and its agreement behind.
        let started = Instant::now();
        let image = tracer.render(context, &geometry, &look, &camera(width, height), 1).expect("render");
        let seconds = started.elapsed().as_secs_f64();
        let differences: Vec<f32> = image
            .pixels
            .iter()
            .zip(&cpu_image.pixels)
            .map(|(g, c)| {
                (0..3).map(|k| (g.color[k] - c.color[k]).abs()).fold(g.alpha - c.alpha, |a, d| a.abs().max(d))
            })
            .collect();
        let mean = differences.iter().map(|d| f64::from(*d)).sum::<f64>() / differences.len() as f64;
        let off = differences.iter().filter(|d| **d > 1e-3).count();
        println!(
            "  GPU {gpu}, {label}: {width} x {height} x 1 spp in {seconds:.3} s: {:.2} M rays/s (upload and readback \
             included); against the CPU: mean largest channel difference {mean:.2e}, {off} of {} pixels off by more than 1e-3",
            f64::from(width * height) / seconds / 1e6,
            differences.len()
        );
        if !context.is_software() {
            let (w, h, spp) = (1920, 1080, 4);
            let started = Instant::now();
            tracer.render(context, &geometry, &look, &camera(w, h), spp).expect("render");
            let seconds = started.elapsed().as_secs_f64();
            println!(
                "  GPU {gpu}, {label}: {w} x {h} x {spp} spp in {seconds:.3} s: {:.2} M rays/s (upload and readback included)",
                f64::from(w * h * spp) / seconds / 1e6
            );
        }
    }
}
