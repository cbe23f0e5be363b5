//! The render stage of shatter, `shatter render`: the fragments of each frame ray traced to
//! multi-layer EXR (and PNG previews).
//!
//! - [`element_kdtree`]: the SAH k-d tree over element bounds, with short-stack traversal.
//! - [`element_index`]: the CPU tracer's two-level index: one rest-frame tree for a render, and
//!   per frame a tree over the fragments' boxes.
//! - [`primitives`]: ray hits of cubes, tetrahedra and trimtopes, and their CSG unions.
//! - [`scene`]: the elements of a frame placed by their fragments' motions; the camera.
//! - [`lighting`]: SH environment light, Blinn-Phong, the environment map.
//! - [`trace`]: the CPU tracer (glass, floor, shading); the CPU twin of `shaders/trace.wgsl`.
//! - [`gpu_trace`]: the GPU tracer running `shaders/trace.wgsl`.
//! - [`mattes`]: per-pixel counts of the fragments and surface kinds seen first.
//! - [`cryptomatte`]: those counts as Cryptomatte ranks with their manifests.
//! - [`motion`]: the motion pass from the fragments' rigid motions.
//! - [`image_out`]: EXR and PNG writing.
//! - [`render_driver`]: the stage's driver (frame ranges, progress).

pub mod cryptomatte;
pub mod element_index;
pub mod element_kdtree;
pub mod gpu_trace;
pub mod image_out;
pub mod lighting;
pub mod mattes;
pub mod motion;
pub mod primitives;
pub mod render_driver;
pub mod scene;
pub mod trace;
