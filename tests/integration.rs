//! The shatter integration tests as one binary: one link of wgpu and rapier instead of one per
//! file. Each `tests/*.rs` file is a module here (a test in the root crate checks that none is
//! left out); the shared helpers are the folder modules.

mod support;

mod bad_input_corpus;
mod blender_reads_frames;
mod changed_scene_cli;
mod cli;
mod code_size;
mod deformed_elements;
mod disk_full_cli;
mod farm_log_cli;
mod module_visibility;
mod output_lock_cli;
mod post_cli;
mod preview_page;
mod preview_review;
mod regression;
mod rigid_cli;
mod run_cli;
mod samplers_cli;
mod scenes;
mod secondary_fracture;
mod sim_cli;
mod stage_dependencies;
mod test_binaries;
mod unchanged_outputs;
