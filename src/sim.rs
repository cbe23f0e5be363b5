//! `shatter sim`: particles to frames and the bond-break log.

use shatter_core::PipelineConfig;
use shatter_core::config::sim::BackendChoice;
use shatter_sim::sim_driver::{RunError, RunOptions, run_sim};
use shatter_sim::{SimError, SimdPath};

use crate::Failure;
use crate::progress_bars::for_stderr;

/// Command-line choices of `shatter sim`.
#[derive(Debug, Clone, clap::Args)]
pub struct SimArgs {
    /// Where to run: a hardware GPU when found, else the CPU (auto); or force one. A software GPU
    /// (Mesa lavapipe) counts only with SHATTER_GPU_ALLOW_SOFTWARE=1.
    #[arg(long, value_enum)]
    pub backend: Option<BackendArg>,
    /// Continue from the last checkpoint instead of starting over.
    #[arg(long)]
    pub resume: bool,
    /// Run even when sim.dt_s exceeds the stable time step.
    #[arg(long)]
    pub allow_unstable_dt: bool,
    /// The CPU kernels' instruction set: portable, avx2 or avx512 (default: SHATTER_SIMD, else
    /// the widest this CPU runs). Every path gives the same results; benches compare speeds.
    #[arg(long, value_name = "PATH", value_parser = SimdPath::parse)]
    pub simd: Option<SimdPath>,
}

/// `--backend` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BackendArg {
    /// A hardware GPU when one is found, else the CPU.
    Auto,
    /// The CPU.
    Cpu,
    /// The GPU.
    Gpu,
}

impl BackendArg {
    /// The config's backend value.
    pub fn backend(self) -> BackendChoice {
        match self {
            BackendArg::Auto => BackendChoice::Auto,
            BackendArg::Cpu => BackendChoice::Cpu,
            BackendArg::Gpu => BackendChoice::Gpu,
        }
    }
}

/// Forces `--simd`'s path for the process, before any stage runs; a path this CPU lacks is bad
/// input (exit code 2).
pub fn force_simd(args: &SimArgs) -> Result<(), Failure> {
    match args.simd.map(SimdPath::force) {
        Some(Err(message)) => Err(RunError::Input(SimError::BadInput(message)).into()),
        _ => Ok(()),
    }
}

/// Runs the simulation stage.
pub fn run(config: &PipelineConfig, args: &SimArgs) -> Result<(), Failure> {
    let backend = args.backend.map_or(config.sim.backend, BackendArg::backend);
    let options = RunOptions { backend: Some(backend), resume: args.resume, allow_unstable_dt: args.allow_unstable_dt };
    let report = run_sim(config, options, &*for_stderr())?;
    for warning in &report.warnings {
        eprintln!("warning: {warning}");
    }
    let steps_per_second = report.steps as f64 / report.wall_s.max(1e-9);
    println!(
        "sim on {}{}: {} particles, frames {}..{} ({} steps, {:.0} steps/s), {} bonds broken, stable dt {:.3e} s",
        report.backend,
        report.simd.map_or(String::new(), |simd| format!(", {simd} kernels")),
        report.particles,
        report.started_at_frame,
        report.frames,
        report.steps,
        steps_per_second,
        report.broken_bonds,
        report.stable_dt_s
    );
    println!("wrote {} in {:.1} s", report.frames_dir.display(), report.wall_s);
    Ok(())
}
