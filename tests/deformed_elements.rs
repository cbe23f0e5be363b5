//! Deformed elements (issue #19, point 7; `post.element_shapes`): a bent elastic beam renders
//! with its silhouette within a pixel of the bent body's, where rigid elements do not; an
//! undeformed body renders identically in rigid and deformed modes; and through the CLI, an
//! elastoplastic scene's fragments files carry the elements' affine maps and render, a PMB
//! scene's do not.

use crate::support;

use std::path::Path;

use shatter_core::NoProgress;
use shatter_core::config::PipelineConfig;
use shatter_core::fragments::{AFFINE_RIGID, FragmentFrame, FragmentMeta};
use shatter_core::particles::ParticleSet;
use shatter_post::FragmentTracker;
use shatter_post::deformation::ElementDeformation;
use shatter_render::camera::Camera;
use shatter_render::hit_search::NONE;
use shatter_render::image_loop::render;
use shatter_render::integrator::Pixel;
use shatter_render::lighting::EnvironmentMap;
use shatter_render::materials::Look;
use shatter_render::mattes::SURFACE_FRACTURE;
use shatter_render::scene_geometry::SceneGeometry;
use support::{shatter, stderr};

/// Particles of a box `size_m` centred at the origin, sampled by `sampler` at 1 mm spacing.
fn sampled(sampler: &str, size_m: [f64; 3], horizon: f64) -> ParticleSet {
    let text = format!(
        "[scene]\nname = \"t\"\noutput_dir = \"out\"\nseed = 1\n[geometry]\nsource = \"box\"\n\
         box_size_m = {size_m:?}\nsampler = \"{sampler}\"\nspacing_m = 0.001\nhorizon_factor = {horizon:?}\n\
         [material]\ndensity_kg_m3 = 2200.0\nbulk_modulus_pa = 14.9e9\n"
    );
    let config = PipelineConfig::from_toml_str(&text, Path::new("/nonexistent/p.toml")).expect("config");
    shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles
}

/// The particles moved by `map` (x, y, z arrays, as a simulation frame holds them).
fn moved(particles: &ParticleSet, map: &dyn Fn([f64; 3]) -> [f64; 3]) -> [Vec<f32>; 3] {
    let points: Vec<[f64; 3]> = particles.rest_position_m.iter().map(|p| map(p.map(f64::from))).collect();
    [0, 1, 2].map(|axis| points.iter().map(|p| p[axis] as f32).collect())
}

/// The fragments frame post writes for positions `position` with every bond intact: rigid
/// (no affine maps) and deformed.
fn fragments(particles: &ParticleSet, position: &[Vec<f32>; 3]) -> (FragmentFrame, FragmentFrame) {
    let position = [&position[0][..], &position[1][..], &position[2][..]];
    let mass = particles.mass_kg.iter().map(|m| f64::from(*m)).collect();
    let tracked = FragmentTracker::new(particles, mass).track(position, 0.0);
    let rigid = FragmentFrame {
        meta: FragmentMeta { frame: 2, step: 1, time_s: 1e-3, smoothed: false, inputs: None },
        fragment_of: tracked.fragment_of.clone(),
        rotation: tracked.motion.iter().map(|m| m.rotation.as_quat().to_array()).collect(),
        translation_m: tracked.motion.iter().map(|m| m.translation.to_array()).collect(),
        elements: tracked.elements.clone(),
        mass_kg: tracked.mass_kg.clone(),
        element_affine: None,
    };
    let affine =
        ElementDeformation::new(particles).element_affine(particles, position, &tracked.fragment_of, &tracked.motion);
    let deformed = FragmentFrame { element_affine: Some(affine), ..rigid.clone() };
    (rigid, deformed)
}

fn look() -> Look {
    let environment = EnvironmentMap::constant([1.0, 0.9, 0.8]);
    Look {
        show_environment: false,
        absorption: [0.5, 0.2, 0.1],
        albedo: [0.7, 0.6, 0.5],
        fracture_albedo: [0.3, 0.5, 0.9],
        specular: 0.3,
        shininess: 32.0,
        max_bounces: 6,
        opaque_cubes: false,
        ..Look::under(environment)
    }
}

/// A pinhole camera at `eye` looking along -z, vertical field of view 2 atan(`tan_half`).
fn camera_along_z(eye: [f64; 3], tan_half: f64, width: u32, height: u32) -> Camera {
    let aspect = f64::from(width) / f64::from(height);
    Camera {
        origin: eye.map(|v| v as f32),
        forward: [0.0, 0.0, -1.0],
        right: [(tan_half * aspect) as f32, 0.0, 0.0],
        up: [0.0, tan_half as f32, 0.0],
        width,
        height,
        lens: None,
    }
}

/// Quaternion [x, y, z, w] rotation of `v`.
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let [x, y, z, w] = q;
    let u = [x, y, z];
    let cross =
        |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let t = cross(u, v).map(|c| 2.0 * c);
    let s = cross(u, t);
    [0, 1, 2].map(|k| v[k] + w * t[k] + s[k])
}

#[test]
fn an_undeformed_body_renders_identically_in_rigid_and_deformed_modes() {
    let half = 0.5f64 * 0.7f64;
    let q = [0.3 * half.sin(), 0.9 * half.sin(), 0.3162 * half.sin(), half.cos()];
    let norm = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    let q = q.map(|c| c / norm);
    for (sampler, size) in [("grid", [0.008, 0.005, 0.004]), ("tet_shell", [0.008, 0.006, 0.005])] {
        let particles = sampled(sampler, size, 2.0);
        let at_rest = moved(&particles, &|x| x);
        let turned = moved(&particles, &|x| {
            let r = rotate(q, x);
            [r[0] + 0.002, r[1] - 0.001, r[2] + 0.003]
        });
        for (what, position) in [("at rest", at_rest), ("moved rigidly", turned)] {
            let (rigid, deformed) = fragments(&particles, &position);
            let affine = deformed.element_affine.as_ref().expect("maps");
            assert!(
                affine.iter().all(|m| *m == AFFINE_RIGID),
                "{sampler} {what}: every element moves with its fragment"
            );
            let camera = camera_along_z([0.001, 0.002, 0.03], 0.25, 96, 72);
            let look = Look { opaque_cubes: sampler == "grid", ..look() };
            let a = render(&SceneGeometry::build(&particles, Some(&rigid)), &look, &camera, 2);
            let b = render(&SceneGeometry::build(&particles, Some(&deformed)), &look, &camera, 2);
            let covered = a.pixels.iter().filter(|p| p.element != NONE).count();
            assert!(covered > 500, "{sampler} {what}: the body is in view ({covered} pixels)");
            assert_eq!(a, b, "{sampler} {what}: rigid and deformed renders differ");
        }
    }
}

/// The beam: 24 x 4 x 4 mm along x, bent in the xy plane onto an arc of radius `RADIUS` about
/// (0, RADIUS, 0) (its axis y = 0 keeps its length; fibres at y shorten by the factor
/// (RADIUS - y) / RADIUS).
const RADIUS: f64 = 0.02;
const HALF: [f64; 3] = [0.012, 0.002, 0.002];

fn bend(x: [f64; 3]) -> [f64; 3] {
    let theta = x[0] / RADIUS;
    let arm = RADIUS - x[1];
    [arm * theta.sin(), RADIUS - arm * theta.cos(), x[2]]
}

/// Whether `p` is inside the bent beam.
fn inside_bent(p: [f64; 3]) -> bool {
    let (dx, dy) = (p[0], RADIUS - p[1]);
    let arm = (dx * dx + dy * dy).sqrt();
    let theta = dx.atan2(dy);
    (theta * RADIUS).abs() <= HALF[0] && (RADIUS - arm).abs() <= HALF[1] && p[2].abs() <= HALF[2]
}

/// The bent beam's coverage by brute force: along each pixel centre's ray through the slab
/// |z| <= HALF[2], 2,000 points tested.
fn reference_mask(camera: &Camera) -> Vec<bool> {
    let (width, height) = (camera.width, camera.height);
    let eye = camera.origin.map(f64::from);
    (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| {
            let d = camera.direction(x as f32 + 0.5, y as f32 + 0.5).map(f64::from);
            let (t0, t1) = ((eye[2] - HALF[2]) / -d[2], (eye[2] + HALF[2]) / -d[2]);
            let (t0, t1) = (t0.min(t1), t0.max(t1));
            (0..=2000).any(|k| {
                let t = t0 + (t1 - t0) * f64::from(k) / 2000.0;
                inside_bent([0, 1, 2].map(|a| eye[a] + t * d[a]))
            })
        })
        .collect()
}

/// The largest distance, in pixels (Chebyshev), from a pixel where `mask` and `reference`
/// disagree to the nearest pixel where `reference` takes `mask`'s value there; and how many
/// pixels disagree.
fn silhouette_error(mask: &[bool], reference: &[bool], width: usize, height: usize) -> (usize, usize) {
    let mut worst = 0;
    let mut wrong = 0;
    for y in 0..height {
        for x in 0..width {
            let value = mask[y * width + x];
            if value == reference[y * width + x] {
                continue;
            }
            wrong += 1;
            let distance = (1..width.max(height))
                .find(|&r| {
                    let (x0, x1) = (x.saturating_sub(r), (x + r).min(width - 1));
                    let (y0, y1) = (y.saturating_sub(r), (y + r).min(height - 1));
                    (y0..=y1).any(|yy| (x0..=x1).any(|xx| reference[yy * width + xx] == value))
                })
                .unwrap_or(usize::MAX);
            worst = worst.max(distance);
        }
    }
    (worst, wrong)
}

#[test]
fn a_bent_beam_renders_with_its_silhouette_within_a_pixel_of_the_bent_body() {
    let particles = sampled("grid", HALF.map(|h| 2.0 * h), 2.0);
    assert_eq!(particles.len(), 24 * 4 * 4);
    let bent = moved(&particles, &bend);
    let (rigid, deformed) = fragments(&particles, &bent);
    let affine = deformed.element_affine.as_ref().expect("maps");
    assert!(affine.iter().all(|m| *m != AFFINE_RIGID), "every element is bent");
    // about 7 pixels per millimetre (a cube of 1 mm spans 7 pixels)
    let camera = camera_along_z([0.0, 0.004, 0.05], 0.2, 192, 144);
    let started = std::time::Instant::now();
    let pixels = |frame: &FragmentFrame| -> Vec<Pixel> {
        render(&SceneGeometry::build(&particles, Some(frame)), &Look { opaque_cubes: true, ..look() }, &camera, 1)
            .pixels
    };
    let (deformed_pixels, rigid_pixels) = (pixels(&deformed), pixels(&rigid));
    let mask = |pixels: &[Pixel]| pixels.iter().map(|p| p.element != NONE).collect::<Vec<bool>>();
    let (deformed_mask, rigid_mask) = (mask(&deformed_pixels), mask(&rigid_pixels));
    // where neighbouring elements' maps differ, a seam between them may show a sliver of face:
    // within one fragment it is not a fracture face
    let fracture = deformed_pixels.iter().filter(|p| p.surface == SURFACE_FRACTURE).count();
    let render_s = started.elapsed().as_secs_f64();
    let reference = reference_mask(&camera);
    let (w, h) = (camera.width as usize, camera.height as usize);
    let covered = reference.iter().filter(|c| **c).count();
    assert!(covered > 3000, "the bent beam is in view: {covered} pixels");
    let (deformed_error, deformed_wrong) = silhouette_error(&deformed_mask, &reference, w, h);
    let (rigid_error, rigid_wrong) = silhouette_error(&rigid_mask, &reference, w, h);
    eprintln!(
        "bent beam, {covered} pixels covered: deformed elements {deformed_wrong} pixels off the silhouette, \
         at most {deformed_error} px from it; rigid elements {rigid_wrong} pixels, at most {rigid_error} px \
         ({render_s:.2} s for both renders); {fracture} pixels see a fracture face"
    );
    assert!(deformed_error <= 1, "deformed elements: silhouette {deformed_error} px from the bent body's");
    assert!(rigid_error > 3, "rigid elements draw the beam straight: {rigid_error} px off");
    assert_eq!(fracture, 0, "an intact beam shows no fracture face");
}

/// A 2 x 0.8 x 0.8 cm bar of 2 mm cubes (160 particles), elastoplastic, pulled by grips at its
/// ends: three frames, rendered small.
const PULLED_BAR: &str = r#"
[scene]
name = "pulled_bar"
output_dir = "out"
seed = 1
[geometry]
source = "box"
box_size_m = [0.02, 0.008, 0.008]
sampler = "grid"
spacing_m = 0.002
horizon_factor = 2.5
[material]
model = "elastoplastic"
density_kg_m3 = 1000.0
bulk_modulus_pa = 2.0e6
shear_modulus_pa = 1.5e6
critical_stretch = 0.5
[sim]
frames = 3
steps_per_frame = 20
dt_s = 5e-6
gravity_m_s2 = [0.0, 0.0, 0.0]
[[sim.grip]]
box_min_m = [-0.011, -0.01, -0.01]
box_max_m = [-0.0085, 0.01, 0.01]
velocity_m_s = [-2.0, 0.0, 0.0]
[[sim.grip]]
box_min_m = [0.0085, -0.01, -0.01]
box_max_m = [0.011, 0.01, 0.01]
velocity_m_s = [2.0, 0.0, 0.0]
[render]
resolution = [48, 32]
samples_per_pixel = 1
previews = false
[render.material]
cubes = "opaque"
"#;

fn run_scene(text: &str, until: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), text).expect("config");
    let output = shatter(&["run", "--until", until, "--backend", "cpu"], dir.path());
    assert!(output.status.success(), "shatter run: {}", stderr(&output));
    dir
}

#[test]
fn an_elastoplastic_scene_writes_and_renders_deformed_elements_and_a_pmb_scene_does_not() {
    let dir = run_scene(PULLED_BAR, "render");
    let out = dir.path().join("out");
    let last = FragmentFrame::read(&out.join("fragments/fragments.0003.shp")).expect("fragments");
    let affine = last.element_affine.as_ref().expect("an elastoplastic scene's fragments carry affine maps");
    assert_eq!(affine.len(), 160);
    assert!(affine.iter().any(|m| *m != AFFINE_RIGID), "the pulled bar is stretched");
    let first = FragmentFrame::read(&out.join("fragments/fragments.0001.shp")).expect("fragments");
    assert!(first.element_affine.expect("maps").iter().all(|m| *m == AFFINE_RIGID), "the rest frame is rigid");
    assert!(out.join("render/pulled_bar.0003.exr").is_file(), "the frames render");
    let path = out.join("fragments/fragments.0003.shp");
    let inspected = shatter(&["inspect", path.to_str().expect("path"), "--json"], dir.path());
    let summary: serde_json::Value = serde_json::from_slice(&inspected.stdout).expect("inspect's JSON");
    let deformed = affine.iter().filter(|m| **m != AFFINE_RIGID).count();
    assert_eq!(summary["deformed_elements"], deformed, "inspect counts the deformed elements");

    // the same scene with rigid elements asked for: no section
    let rigid = PULLED_BAR.replace("[render]\n", "[post]\nelement_shapes = \"rigid\"\n[render]\n");
    let dir = run_scene(&rigid, "post");
    let frame = FragmentFrame::read(&dir.path().join("out/fragments/fragments.0003.shp")).expect("fragments");
    assert!(frame.element_affine.is_none());

    // a PMB scene: no section, unless asked for
    let plate = format!("{}[sim]\nframes = 2\nsteps_per_frame = 10\n", support::SMALL_PLATE);
    let dir = run_scene(&plate, "post");
    let path = dir.path().join("out/fragments/fragments.0002.shp");
    assert!(FragmentFrame::read(&path).expect("fragments").element_affine.is_none());
    assert!(!String::from_utf8_lossy(&std::fs::read(&path).expect("read")).contains("element_affine"));
    let deformed = format!("{plate}[post]\nelement_shapes = \"deformed\"\n");
    let dir = run_scene(&deformed, "post");
    let frame = FragmentFrame::read(&dir.path().join("out/fragments/fragments.0002.shp")).expect("fragments");
    assert_eq!(frame.element_affine.expect("asked for").len(), 400);

    // a bad value names the key
    let bad = format!("{plate}[post]\nelement_shapes = \"bent\"\n");
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), bad).expect("config");
    let output = shatter(&["post"], dir.path());
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("post.element_shapes"), "{}", stderr(&output));
}
