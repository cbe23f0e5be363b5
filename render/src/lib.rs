//! The render stage of shatter, `shatter render`: the fragments of each frame ray traced to
//! multi-layer EXR (and PNG previews). The tracer is split by concept, as a physically based
//! renderer is; each CPU module that the GPU tracer mirrors has a WGSL twin of the same name in
//! `shaders/`.
//!
//! The scene:
//! - [`scene_geometry`]: a frame's elements as planes, triangles and sites, flattened for tracing.
//! - [`placing`]: the elements placed by their fragments' rigid motions or their affine maps.
//! - [`face_seams`]: which faces rest against a neighbour (union walks, fracture faces).
//! - [`element_kdtree`]: the SAH k-d tree over element bounds, with short-stack traversal.
//! - [`packet_traversal`]: packets of camera rays walking the k-d tree together.
//! - [`element_index`]: the CPU tracer's two-level index: one rest-frame tree for a render, and
//!   per frame a tree over the fragments' boxes.
//! - [`primitives`]: ray hits of cubes, tetrahedra and trimtopes, and their CSG unions.
//! - [`shutter`]: how the pieces move while the shutter is open, and rays carried to the frame's
//!   centre (3D motion blur).
//!
//! The tracer:
//! - [`camera`]: the pinhole camera and its OpenEXR matrices.
//! - [`sampling`]: random numbers and pixel samples.
//! - [`hit_search`]: the nearest hit over unions of elements, and walks out of a union.
//! - [`materials`]: the look: glass, opaque and floor materials, the floor texture.
//! - [`texture_filter`]: the floor texture's mip chain and lookups over a ray's footprint.
//! - [`lighting`]: SH environment light, the key light, the environment map.
//! - [`shading`]: reflection, refraction, Fresnel, opaque surfaces and the floor.
//! - [`integrator`]: radiance along one camera ray, and its first-surface layers.
//! - [`image_loop`]: every pixel of an image, in bands and packets; the CPU tracer's entry.
//! - [`floor_albedos`]: the camera samples' filtered floor albedos, kept from frame to frame.
//! - [`gpu_trace`]: the GPU tracer running the WGSL twins (`shaders/`).
//!
//! The passes and files:
//! - [`mattes`]: per-pixel counts of the fragments and surface kinds seen first.
//! - [`cryptomatte`]: those counts as Cryptomatte ranks with their manifests.
//! - [`motion`]: the motion pass from the fragments' rigid motions.
//! - [`image_out`]: EXR and PNG writing (`exr_blocks`: the EXR's blocks filled from the pixels).
//! - [`frame_review`]: a written frame read back for review: its passes drawn, a Cryptomatte pick.
//! - [`render_driver`]: the stage's driver (frame ranges, progress).

pub mod camera;
pub mod cryptomatte;
mod element_index;
mod element_kdtree;
mod exr_blocks;
mod face_seams;
pub mod floor_albedos;
pub mod frame_review;
pub mod gpu_trace;
pub mod hit_search;
pub mod image_loop;
pub mod image_out;
pub mod integrator;
pub mod lighting;
pub mod materials;
pub mod mattes;
mod motion;
mod packet_traversal;
mod placing;
mod primitives;
pub mod render_driver;
mod sampling;
pub mod scene_geometry;
mod shading;
pub mod shutter;
pub mod texture_filter;

#[cfg(test)]
mod trace_tests;
