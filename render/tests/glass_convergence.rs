//! Glass converges: a 64-sample render of an upright glass slab over a checkered floor, seen
//! across its top edge as in the default shot, is within LDR-FLIP mean 0.02 of a 1,024-sample,
//! 64-bounce reference, with stratified pixel samples and 8 bounces (paths then escape to the
//! floor or the environment) and the first glass event split at Fresnel's weights; picking each
//! branch at random (the default, cheaper) is further from it but within 0.025.

use crate::support;

use glam::DVec3;
use shatter_core::particles::Elements;
use shatter_render::camera::Camera;
use shatter_render::image_loop::render;
use shatter_render::image_out::write_png;
use shatter_render::integrator::Pixel;
use shatter_render::lighting::EnvironmentMap;
use shatter_render::materials::{FloorLook, FloorTexels, Look};
use shatter_render::scene_geometry::SceneGeometry;

fn slab() -> SceneGeometry {
    let spacing = 0.01f32;
    let mut positions = Vec::new();
    for x in 0..12 {
        for y in 0..10 {
            for z in 0..2 {
                positions.push([(x as f32 - 5.5) * spacing, (y as f32 + 0.5) * spacing, (z as f32 - 0.5) * spacing]);
            }
        }
    }
    let n = positions.len();
    let elements = Elements::Cubes { half_size_m: vec![spacing / 2.0; n], orientation: [0.0, 0.0, 0.0, 1.0] };
    let particles = support::particle_set(positions, elements, f64::from(spacing), Vec::new());
    SceneGeometry::build(&particles, None)
}

fn look(bounces: u32, split: u32) -> Look {
    // a dim sky with a bright band low on the horizon, as a studio map
    let (width, height) = (64, 32);
    let texels = (0..width * height)
        .map(|i| {
            let row = i / width;
            if (14..17).contains(&row) { [6.0, 5.0, 4.0] } else { [0.05, 0.06, 0.08] }
        })
        .collect();
    Look {
        absorption: [1.0, 0.3, 0.6],
        albedo: [0.8; 3],
        fracture_albedo: [0.8; 3],
        specular: 0.2,
        shininess: 64.0,
        floor: Some(FloorLook {
            height: 0.0,
            tile: 0.2,
            size: [2, 2],
            texels: FloorTexels::Linear(vec![[0.9, 0.6, 0.3], [0.05; 3], [0.05; 3], [0.9, 0.6, 0.3]]),
            mips: None,
        }),
        max_bounces: bounces,
        glass_split_events: split,
        opaque_cubes: false,
        ..Look::under(EnvironmentMap { width, height, texels })
    }
}

/// The render's 8-bit preview, as the regression tests compare them.
fn preview(pixels: &[Pixel], width: u32, height: u32) -> image::RgbImage {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("frame.png");
    write_png(&path, width as usize, height as usize, pixels, 0.0).expect("png");
    image::open(&path).expect("png reads").into_rgb8()
}

fn flip_mean(reference: &image::RgbImage, test: &image::RgbImage) -> f32 {
    let (width, height) = reference.dimensions();
    let reference = nv_flip::FlipImageRgb8::with_data(width, height, reference.as_raw());
    let test = nv_flip::FlipImageRgb8::with_data(width, height, test.as_raw());
    let error = nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    nv_flip::FlipPool::from_image(&error).mean()
}

#[test]
fn sixty_four_samples_of_split_glass_paths_match_a_deep_reference() {
    let scene = slab();
    let (width, height) = (96, 64);
    let camera =
        Camera::look_at(DVec3::new(0.03, 0.16, 0.16), DVec3::new(0.0, 0.08, 0.0), DVec3::Y, 40.0, width, height);
    let image = |bounces: u32, split: u32, samples: u32| {
        preview(&render(&scene, &look(bounces, split), &camera, samples).pixels, width, height)
    };
    let reference = image(64, 2, 1024);
    let (split_image, random_image) = (image(8, 1, 64), image(8, 0, 64));
    if let Ok(dir) = std::env::var("SHATTER_GLASS_IMAGES") {
        for (name, picture) in [("reference", &reference), ("split", &split_image), ("random", &random_image)] {
            picture.save(std::path::Path::new(&dir).join(format!("{name}.png"))).expect("save");
        }
    }
    let split = flip_mean(&reference, &split_image);
    let random = flip_mean(&reference, &random_image);
    println!("FLIP mean against 1,024 spp x 64 bounces: split {split:.4}, random choice {random:.4}");
    assert!(split < 0.02, "64 spp, the first glass event split: FLIP mean {split}");
    assert!(random < 0.025, "64 spp, random branch choice (the default): FLIP mean {random}");
    assert!(split < random, "splitting converges faster: {split} vs {random}");
}
