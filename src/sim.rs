//! `shatter sim`: particles to frames and the bond-break log.

use shatter_core::PipelineConfig;
use shatter_core::config::sim::BackendChoice;
use shatter_core::time_step;
use shatter_sim::sim_driver::{RunError, RunOptions, RunReport, run_sim};
use shatter_sim::{SimError, SimdPath};

use crate::Failure;
use crate::progress_bars::for_stderr;

/// Command-line choices of `shatter sim`.
#[derive(Debug, Clone, Default, clap::Args)]
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

/// The time step taken, where it came from, and the stable step, e.g. "dt 1.192e-7 s = 2^-23
/// (unset sim.dt_s: the largest power of two at most 0.5 x the stable dt; stable dt 2.442e-7 s)".
fn describe_step(report: &RunReport) -> String {
    let name = time_step::power_of_two_name(report.dt_s).map_or(String::new(), |name| format!(" = {name}"));
    let fraction = time_step::STABLE_STEP_FRACTION;
    let source = match report.dt_from_material {
        false => "sim.dt_s".to_string(),
        true if report.push_limit_s < report.stable_dt_s => format!(
            "unset sim.dt_s: the largest power of two at most {fraction} x {:.3e} s, the pushing bodies' limit",
            report.push_limit_s
        ),
        true => format!("unset sim.dt_s: the largest power of two at most {fraction} x the stable dt"),
    };
    format!("dt {:.3e} s{name} ({source}; stable dt {:.3e} s)", report.dt_s, report.stable_dt_s)
}

/// Simulates, resuming from the checkpoint when there is one (from the start when it belongs to
/// other settings).
pub fn run_resuming(config: &PipelineConfig, options: &SimArgs) -> Result<(), Failure> {
    let layout = shatter_core::OutputLayout::of(config);
    let resume = layout.checkpoint().is_file();
    match run(config, &SimArgs { resume, ..options.clone() }) {
        Err(failure) if is_checkpoint_mismatch(&failure) => {
            eprintln!("note: the checkpoint belongs to other settings: simulating from the start");
            run(config, &SimArgs { resume: false, ..options.clone() })
        }
        result => result,
    }
}

fn is_checkpoint_mismatch(failure: &Failure) -> bool {
    failure
        .error
        .chain()
        .any(|cause| matches!(cause.downcast_ref::<RunError>(), Some(RunError::CheckpointMismatch { .. })))
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
        "sim on {}{}: {} particles, frames {}..{} ({} steps, {:.0} steps/s), {} bonds broken, {}",
        report.backend,
        report.simd.map_or(String::new(), |simd| format!(", {simd} kernels")),
        report.particles,
        report.started_at_frame,
        report.frames,
        report.steps,
        steps_per_second,
        report.broken_bonds,
        describe_step(&report)
    );
    println!("wrote {} in {:.1} s", report.frames_dir.display(), report.wall_s);
    Ok(())
}
