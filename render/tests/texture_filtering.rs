//! The floor texture filtered over each ray's footprint: a checker floor seen at a grazing angle
//! at 4 samples a pixel is close to a 1,024-sample reference by NVIDIA FLIP; point sampling at 4
//! samples is not (moire toward the horizon).

use crate::support;

use glam::DVec3;
use shatter_core::particles::Elements;
use shatter_render::camera::Camera;
use shatter_render::floor_albedos::FloorAlbedos;
use shatter_render::image_loop::{render, render_keeping};
use shatter_render::materials::{FloorLook, FloorTexels, Look};
use shatter_render::scene_geometry::SceneGeometry;
use shatter_render::texture_filter::MipChain;

/// A checker of 64 x 64 texels on a floor tile of 1 m, point sampled or filtered.
fn look(filtered: bool) -> Look {
    let size = 64usize;
    let texels =
        (0..size * size).map(|i| if (i % size + i / size).is_multiple_of(2) { [0.9; 3] } else { [0.05; 3] }).collect();
    let mut floor =
        FloorLook { height: 0.0, tile: 1.0, size: [size, size], texels: FloorTexels::Linear(texels), mips: None };
    if filtered {
        floor.mips = Some(MipChain::of(&floor));
    }
    Look { floor: Some(floor), ..Look::under(support::uniform_sky([1.0; 3], (4, 2))) }
}

/// The image as 8-bit sRGB.
fn srgb8(pixels: &[shatter_render::integrator::Pixel]) -> Vec<u8> {
    let encode = |c: f32| {
        let c = c.clamp(0.0, 1.0);
        let v = if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
        (v * 255.0).round() as u8
    };
    pixels.iter().flat_map(|p| p.color.map(encode)).collect()
}

fn flip_mean(reference: &[u8], test: &[u8], (width, height): (u32, u32)) -> f32 {
    let reference = nv_flip::FlipImageRgb8::with_data(width, height, reference);
    let test = nv_flip::FlipImageRgb8::with_data(width, height, test);
    let error = nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    nv_flip::FlipPool::from_image(&error).mean()
}

#[test]
fn a_grazing_checker_floor_at_4_samples_is_close_to_1024_without_moire() {
    // one cube far behind the camera: the floor fills the lower half of the frame
    let elements = Elements::Cubes { half_size_m: vec![0.01], orientation: [0.0, 0.0, 0.0, 1.0] };
    let particles = support::particle_set(vec![[0.0, 0.5, 50.0]], elements, 0.02, Vec::new());
    let scene = SceneGeometry::build(&particles, None);
    let (width, height) = (160u32, 90u32);
    let camera = Camera::look_at(DVec3::new(0.0, 0.25, 0.0), DVec3::new(0.3, 0.2, -5.0), DVec3::Y, 40.0, width, height);
    let reference = srgb8(&render(&scene, &look(false), &camera, 1024).pixels);
    let filtered = flip_mean(&reference, &srgb8(&render(&scene, &look(true), &camera, 4).pixels), (width, height));
    let point = flip_mean(&reference, &srgb8(&render(&scene, &look(false), &camera, 4).pixels), (width, height));
    eprintln!("FLIP mean against 1,024 point samples: filtered {filtered:.4}, point {point:.4} (4 samples)");
    assert!(filtered < BOUND, "filtered at 4 samples: FLIP {filtered} (bound {BOUND})");
    assert!(point > BOUND, "point sampled at 4 samples: FLIP {point} passes the bound {BOUND}");
}

/// The FLIP bound (measured: filtered 0.0205, point sampled 0.0948).
const BOUND: f32 = 0.04;

/// The floor albedos kept from frame to frame change nothing: frames whose pieces move in front
/// of the floor (hiding some of it, showing other parts) are the same to the bit with them as
/// without, and so is a frame of another camera after them.
#[test]
fn floor_albedos_kept_between_frames_leave_the_images_as_they_are() {
    let elements = || Elements::Cubes { half_size_m: vec![0.1, 0.1], orientation: [0.0, 0.0, 0.0, 1.0] };
    let frames: Vec<SceneGeometry> = [[0.0, 0.1, -2.0], [0.4, 0.3, -2.5], [-0.5, 0.1, -1.5]]
        .into_iter()
        .map(|centre| {
            let centres = vec![centre, [centre[0] + 0.2, centre[1], centre[2]]];
            SceneGeometry::build(&support::particle_set(centres, elements(), 0.2, Vec::new()), None)
        })
        .collect();
    let look = look(true);
    let (width, height) = (48u32, 30u32);
    let camera = Camera::look_at(DVec3::new(0.0, 0.5, 0.0), DVec3::new(0.1, 0.1, -2.0), DVec3::Y, 40.0, width, height);
    let mut kept = FloorAlbedos::default();
    for scene in &frames {
        let alone = render(scene, &look, &camera, 3);
        assert!(render_keeping(scene, &look, &camera, 3, Some(&mut kept)) == alone, "a frame differs");
    }
    let other = Camera { width: 40, ..camera };
    let alone = render(&frames[0], &look, &other, 3);
    assert!(render_keeping(&frames[0], &look, &other, 3, Some(&mut kept)) == alone, "another camera differs");
}
