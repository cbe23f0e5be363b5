//! The shatter-render integration tests as one binary: one link of wgpu and rapier instead of one per
//! file. Each `tests/*.rs` file is a module here (a test in the root crate checks that none is
//! left out); the shared helpers are the folder modules.

mod support;

mod cryptomatte;
mod denoising_guides;
mod depth_of_field;
mod glass_convergence;
mod gpu_trace;
mod motion_blur;
mod texture_filtering;
