//! The shatter-sim integration tests as one binary: one link of wgpu and rapier instead of one per
//! file. Each `tests/*.rs` file is a module here (a test in the root crate checks that none is
//! left out); the shared helpers are the folder modules.

mod elastoplastic_scenes;
mod scenarios;

mod elastoplastic_physics;
mod gpu;
mod gpu_elastoplastic;
mod gpu_physics;
mod gpu_run;
mod lammps_agreement;
mod physics;
mod simd_paths;
