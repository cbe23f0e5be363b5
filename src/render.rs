//! `shatter render`: fragments to EXR frames.

use shatter_core::shot::Shot;
use shatter_core::{OutputLayout, PipelineConfig};
use shatter_render::render_driver::{AfterFrame, RenderError, parse_frames, run_render};

use crate::Failure;
use crate::progress_bars::for_stderr;
use crate::sim::BackendArg;

/// Command-line choices of `shatter render`.
#[derive(Debug, Clone, clap::Args)]
pub struct RenderArgs {
    /// Frames to render, e.g. `1-240`, `12` or `1-10,20` (default: all of the shot's: the
    /// simulation's frames, and the follow-through's with `[rigid]`).
    #[arg(long, value_name = "LIST")]
    pub frames: Option<String>,
    /// Where to trace: a hardware GPU when found, else the CPU (auto); or force one. Default:
    /// render.backend.
    #[arg(long, value_enum)]
    pub backend: Option<BackendArg>,
}

/// Runs the render stage for the frames `args` asks for.
pub fn run(config: &PipelineConfig, args: &RenderArgs) -> Result<(), Failure> {
    let shot = Shot::of(config, &OutputLayout::of(config)).map_err(RenderError::Input)?;
    let frames = match &args.frames {
        Some(text) => parse_frames(text, shot.last).map_err(RenderError::Input)?,
        None => (1..=shot.last).collect(),
    };
    render_frames(config, &frames, args.backend, &mut |_| Ok(()))
}

/// Renders `frames`, calling `after_frame` when each is written.
pub fn render_frames(
    config: &PipelineConfig,
    frames: &[u32],
    backend: Option<BackendArg>,
    after_frame: AfterFrame,
) -> Result<(), Failure> {
    let backend = backend.map(BackendArg::backend);
    let report = run_render(config, Some(frames), backend, &*for_stderr(), after_frame)?;
    let [width, height] = report.resolution;
    println!(
        "render: {} frames at {width} x {height}, {} samples per pixel ({:.2} M primary rays/s)",
        report.frames.len(),
        report.samples,
        report.rays_per_second / 1e6
    );
    println!("wrote {} in {:.1} s on {}", report.folder.display(), report.wall_s, report.device);
    Ok(())
}
