//! `shatter render`: fragments to EXR frames.

use shatter_core::PipelineConfig;

use crate::Failure;
use crate::progress::Bars;
use crate::sim::BackendArg;

/// Command-line choices of `shatter render`.
#[derive(Debug, Clone, clap::Args)]
pub struct RenderArgs {
    /// Frames to render, e.g. `1-240`, `12` or `1-10,20` (default: all of sim.frames).
    #[arg(long, value_name = "LIST")]
    pub frames: Option<String>,
    /// Where to trace: a hardware GPU when found, else the CPU (auto); or force one. Default:
    /// render.backend.
    #[arg(long, value_enum)]
    pub backend: Option<BackendArg>,
}

/// Runs the render stage.
pub fn run(config: &PipelineConfig, args: &RenderArgs) -> Result<(), Failure> {
    let backend = args.backend.map(BackendArg::backend);
    let report = shatter_render::run::run(config, args.frames.as_deref(), backend, &Bars::default())?;
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
