//! The denoising guides (Blender's Denoising Albedo and Denoising Normal passes): the albedo and
//! normal of the first diffuse surface along each path, through glass tinted by it.

use crate::support;

use glam::DVec3;
use shatter_core::particles::{Elements, ParticleSet};
use shatter_render::camera::Camera;
use shatter_render::image_loop::render;
use shatter_render::materials::{FloorLook, FloorTexels, Look};
use shatter_render::scene_geometry::SceneGeometry;

fn look(opaque_cubes: bool) -> Look {
    Look {
        absorption: [2.0, 0.5, 1.0],
        albedo: [0.7, 0.5, 0.3],
        fracture_albedo: [0.2, 0.4, 0.6],
        specular: 0.2,
        floor: Some(FloorLook {
            height: -0.1,
            tile: 100.0,
            size: [1, 1],
            texels: FloorTexels::Linear(vec![[0.25, 0.5, 0.125]]),
            mips: None,
        }),
        max_bounces: 8,
        opaque_cubes,
        ..Look::under(support::uniform_sky([0.6, 0.7, 0.9], (4, 2)))
    }
}

/// One cube of 0.2 m at the origin, seen from above the floor.
fn cube() -> ParticleSet {
    let elements = Elements::Cubes { half_size_m: vec![0.1], orientation: [0.0, 0.0, 0.0, 1.0] };
    support::particle_set(vec![[0.0, 0.0, 0.0]], elements, 0.2, Vec::new())
}

#[test]
fn the_guides_are_the_first_diffuse_surfaces_albedo_and_normal() {
    let scene = SceneGeometry::build(&cube(), None);
    // straight at the cube's +z face, with floor below and sky above
    let camera = Camera::look_at(DVec3::new(0.0, 0.0, 2.0), DVec3::ZERO, DVec3::Y, 30.0, 33, 33);
    let at = |pixels: &[shatter_render::integrator::Pixel], x: usize, y: usize| pixels[y * 33 + x];
    let opaque = render(&scene, &look(true), &camera, 1).pixels;
    let face = at(&opaque, 16, 16);
    assert_eq!(face.denoising_albedo, [0.7, 0.5, 0.3], "the opaque material's albedo");
    assert_eq!(face.denoising_normal, [0.0, 0.0, 1.0], "the face's normal");
    let floor = at(&opaque, 16, 32);
    assert_eq!(floor.denoising_albedo, [0.25, 0.5, 0.125], "the floor texture's albedo");
    assert_eq!(floor.denoising_normal, [0.0, 1.0, 0.0]);
    let sky = at(&opaque, 16, 0);
    assert_eq!(sky.denoising_albedo, [1.0; 3], "the environment: white");
    assert_eq!(sky.denoising_normal, [0.0; 3]);
    // through glass: what lies behind, tinted by the glass on the way, or its first glass
    // normal where the path ends in the sky
    let glass = render(&scene, &look(false), &camera, 1).pixels;
    let through = at(&glass, 16, 16);
    let tint = through.denoising_albedo;
    assert!(tint.iter().all(|v| *v > 0.0 && *v < 1.0) && tint[0] < tint[1], "tinted: {tint:?}");
    let n = through.denoising_normal;
    assert!(n == [0.0, 0.0, 1.0] || n == [0.0, 1.0, 0.0], "the glass face or the floor: {n:?}");
}
