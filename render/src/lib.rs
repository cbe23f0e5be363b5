//! The post and render stages of shatter.
//!
//! - [`post`]: fragments by breadth-first search over intact element adjacency, stable ids, rigid
//!   motion by mass-weighted Kabsch per fragment, optional smoothing, point caches and a USD shot.
//!
//! The renderer (k-d tree ray tracing of cube, tetrahedron and trimtope CSG unions under
//! spherical-harmonic light, to EXR) arrives with issue #8.

pub mod geometry;
pub mod kdtree;
pub mod lighting;
pub mod post;
pub mod scene;
pub mod trace;
