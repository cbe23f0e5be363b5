//! The post and render stages of shatter.
//!
//! - [`post`]: fragments by breadth-first search over intact element adjacency, stable ids, rigid
//!   motion by mass-weighted Kabsch per fragment, optional smoothing, point caches and a USD shot.
//!
//! - [`kdtree`], [`geometry`], [`scene`], [`lighting`], [`trace`]: the ray tracer (SAH k-d tree
//!   with short-stack traversal; cube, tetrahedron and trimtope CSG unions; SH environment light
//!   and Blinn-Phong; glass), [`image_out`]: EXR and PNG, [`run`]: `shatter render`.

pub mod geometry;
pub mod gpu_trace;
pub mod image_out;
pub mod kdtree;
pub mod lighting;
pub mod post;
pub mod run;
pub mod scene;
pub mod trace;
