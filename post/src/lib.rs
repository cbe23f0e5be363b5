//! The post stage of shatter, `shatter post` (section 4 "Alignment" of Levine et al.): per
//! frame, the fragments (connected components of the element adjacency graph over intact bonds,
//! by breadth-first search), their stable ids, their mass-weighted rigid motions (Kabsch),
//! optional smoothing, statistics; and the exports: a fragments file per frame, point caches
//! with fragment ids, debris points, a USD shot (written with `shatter_core::usd`).
//!
//! - [`components`]: the adjacency graph, BFS and stable ids.
//! - [`kabsch`]: the mass-weighted best rigid motion.
//! - [`smoothing`]: smoothing of sudden transform changes.
//! - [`tracker`]: all of the above, frame after frame.
//! - [`debris`]: the break log's events of each frame as debris emitter points.
//! - [`post_driver`]: the stage's driver.

pub mod components;
mod debris;
pub mod deformation;
mod kabsch;
mod post_driver;
mod smoothing;
mod tracker;

pub use post_driver::{PostError, PostReport, run_post};
pub use tracker::{FragmentTracker, TrackedFrame};
