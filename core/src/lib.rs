//! Shared types of the shatter pipeline.
//!
//! - [`config`]: the `pipeline.toml` schema, parsing and validation.
//! - [`atomic_file`]: files written whole or not at all (temporary name, fsync, rename).
//! - [`stage_file`]: the versioned, checksummed, atomically written binary container that every
//!   stage file uses.
//! - [`digest`]: what each stage's outputs were made from, stored in them.
//! - [`layout`]: every path in a scene's output folder; [`output_lock`]: its one writer.
//! - [`checkpoint`]: the simulation's checkpoint (full state at a frame boundary).
//! - [`frames`]: the simulation's per-frame point caches and its bond-break log; [`in_flight`]:
//!   a stage's frame files written while it computes the next.
//! - [`fragments`]: the per-frame fragments file written by `shatter post`.
//! - [`particles`]: the particle file written by `shatter preprocess` (rest state, element
//!   geometry, bonds, element adjacency); `particle_summary`: the figures shown for one.
//! - [`lead_in`]: where the lead-in hands the body over to the simulation.
//! - [`rigid_checkpoint`]: the follow-through's rapier world (resume) and frame range;
//!   [`shot`]: which file holds each frame of a shot.
//! - [`timeline`]: where a `[timeline]` puts each frame in physical time; [`sim_frames`]: the
//!   simulation's frames that follow; [`time_step`]: the step taken when `sim.dt_s` is unset,
//!   and how later stages read it from the frames.
//! - [`debris_points`]: post's debris emitter point caches; [`surfaces`] and [`usd`]: the
//!   pieces' surfaces and the USD export of a shot (written by post, and by rigid for a shot
//!   with a follow-through).
//! - [`ply`]: checksummed binary PLY point caches, the public per-frame format.
//! - [`memory`]: each stage's peak memory, estimated and refused up front when it cannot fit.
//! - [`progress`]: how library code reports progress to the CLI.
//! - [`random`]: seeded, order-independent randomness; [`disjoint_sets`]: union-find.

pub mod atomic_file;
pub mod checkpoint;
pub mod config;
pub mod debris_points;
pub mod digest;
pub mod disjoint_sets;
pub mod fragments;
pub mod frames;
pub mod in_flight;
pub mod layout;
pub mod lead_in;
pub mod memory;
pub mod output_lock;
mod particle_subset;
mod particle_summary;
pub mod particles;
pub mod ply;
mod progress;
pub mod random;
pub mod reentry;
pub mod rigid_checkpoint;
pub mod shot;
pub mod sim_frames;
pub mod stage_file;
pub mod surfaces;
pub mod time_step;
pub mod timeline;
pub mod usd;

pub use config::{ConfigError, PipelineConfig};
pub use layout::OutputLayout;
pub use particles::ParticleSet;
pub use progress::{NoProgress, Progress};
pub use stage_file::StageFileError;
