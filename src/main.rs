//! `shatter`: mesh in, EXR frames of it shattering out. The command line: arguments, progress
//! bars and stage dispatch; the work happens in the library crates.

mod inspect;
mod lead_in;
mod pipeline;
mod post;
mod preprocess;
mod preview;
mod progress_bars;
mod progress_log;
mod render;
mod rigid;
mod sim;
mod stamps;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use shatter_core::memory::MemoryError;
use shatter_core::output_lock::{Access, OutputLock};
use shatter_core::{ConfigError, OutputLayout, PipelineConfig};
use shatter_post::PostError;
use shatter_preprocess::PreprocessError;
use shatter_render::render_driver::RenderError;
use shatter_rigid::RigidError;
use shatter_sim::sim_driver::RunError;

/// Exit code for bad input: a config, mesh or setting the user must fix (clap uses it for bad
/// arguments too).
const EXIT_BAD_INPUT: u8 = 2;

#[derive(Debug, Parser)]
#[command(name = "shatter", version, about = "Peridynamic fracture, from a mesh to EXR frames of it breaking apart")]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Worker threads of every stage (default: one per core; at most 1024). Results do not
    /// depend on it.
    #[arg(long, global = true, value_name = "N", value_parser = parse_threads)]
    threads: Option<usize>,
}

/// The most worker threads `--threads` accepts: far more than any machine's cores, far fewer
/// than would exhaust memory starting them.
const MAX_THREADS: usize = 1024;

fn parse_threads(text: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(threads) if (1..=MAX_THREADS).contains(&threads) => Ok(threads),
        _ => Err(format!("must be a whole number from 1 to {MAX_THREADS}")),
    }
}

#[derive(Debug, clap::Args)]
struct ConfigArg {
    /// The scene's pipeline.toml; relative paths in it start at its folder.
    #[arg(long, value_name = "PATH", default_value = "pipeline.toml")]
    config: PathBuf,
}

/// The stages, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, clap::ValueEnum)]
enum Stage {
    Preprocess,
    LeadIn,
    Sim,
    Post,
    Rigid,
    Render,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Sample the scene's geometry into particles, bonds and elements (writes particles.shp).
    Preprocess(ConfigArg),
    /// Fly the intact body as one rigid body to its first contact (needs a [lead_in] table).
    LeadIn(ConfigArg),
    /// Simulate fracture (writes frames, the bond-break log and checkpoints).
    Sim {
        #[command(flatten)]
        config: ConfigArg,
        #[command(flatten)]
        options: sim::SimArgs,
    },
    /// Find fragments and their rigid motion per frame.
    Post(ConfigArg),
    /// Hand the fragments over to rigid bodies once the cracks quiet and simulate the
    /// follow-through (needs a [rigid] table).
    Rigid {
        #[command(flatten)]
        config: ConfigArg,
        #[command(flatten)]
        options: rigid::RigidArgs,
    },
    /// Ray trace the fragments to EXR frames.
    Render {
        #[command(flatten)]
        config: ConfigArg,
        #[command(flatten)]
        options: render::RenderArgs,
    },
    /// Run every stage in order, skipping what is up to date and resuming what was interrupted.
    Run {
        #[command(flatten)]
        config: ConfigArg,
        #[command(flatten)]
        options: sim::SimArgs,
        /// Stop after this stage.
        #[arg(long, value_enum, default_value = "render")]
        until: Stage,
    },
    /// Serve the scene live in a browser on 127.0.0.1: its stages at a coarser spacing, rerun as
    /// the page edits it (the scene's output folder is not touched).
    Preview {
        #[command(flatten)]
        config: ConfigArg,
        #[command(flatten)]
        options: preview::PreviewArgs,
    },
    /// Summarise any stage file.
    Inspect {
        /// The stage file.
        path: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
}

/// A failure with the exit code it deserves.
#[derive(Debug)]
struct Failure {
    code: u8,
    error: anyhow::Error,
}

impl<E: Into<anyhow::Error>> From<E> for Failure {
    fn from(error: E) -> Self {
        let error = error.into();
        let find = |test: &dyn Fn(&(dyn std::error::Error + 'static)) -> bool| error.chain().any(test);
        let code = if find(&|cause| {
            cause.is::<ConfigError>()
                || cause.is::<MemoryError>()
                || cause.is::<PreprocessError>()
                || cause.downcast_ref::<RunError>().is_some_and(RunError::is_bad_input)
                || cause.downcast_ref::<PostError>().is_some_and(PostError::is_bad_input)
                || cause.downcast_ref::<RigidError>().is_some_and(RigidError::is_bad_input)
                || cause.downcast_ref::<RenderError>().is_some_and(RenderError::is_bad_input)
        }) {
            EXIT_BAD_INPUT
        } else {
            1
        };
        Failure { code, error }
    }
}

/// The scene of a command that writes into its output folder: its config, and the folder's lock,
/// held until the command ends (one writer per folder, or renders side by side; anything else
/// fails at once, exit code 1).
fn open_scene(arg: &ConfigArg, access: Access) -> Result<(PipelineConfig, OutputLock), Failure> {
    let config = PipelineConfig::load(&arg.config)?;
    for key in config.unused_keys() {
        eprintln!("warning: {}: {key} is set but has no effect", arg.config.display());
    }
    let lock = OutputLock::acquire(&OutputLayout::of(&config), access)?;
    // A run killed mid-write leaves hidden temporary files; the next sole writer of the scene
    // clears them (never a render, whose neighbours' temporaries are still being written).
    if access == Access::Exclusive
        && let Err(error) = shatter_core::atomic_file::remove_abandoned_temporaries(config.output_dir())
    {
        eprintln!("warning: {}: cannot clear abandoned temporary files: {error}", config.output_dir().display());
    }
    Ok((config, lock))
}

fn run(cli: Cli) -> Result<(), Failure> {
    if let Some(threads) = cli.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .map_err(|error| anyhow::anyhow!("cannot start {threads} worker threads: {error}"))?;
    }
    // Each writing command holds its folder's lock (`_lock`) until it returns.
    match cli.command {
        Command::Preprocess(arg) => {
            let (config, _lock) = open_scene(&arg, Access::Exclusive)?;
            check_memory(&config, Stage::Preprocess, Stage::Preprocess)?;
            preprocess::run(&config)
        }
        Command::LeadIn(arg) => {
            let (config, _lock) = open_scene(&arg, Access::Exclusive)?;
            lead_in::run(&config)
        }
        Command::Sim { config, options } => {
            sim::force_simd(&options)?;
            let (config, _lock) = open_scene(&config, Access::Exclusive)?;
            check_memory(&config, Stage::Sim, Stage::Sim)?;
            sim::run(&config, &options)
        }
        Command::Post(arg) => {
            let (config, _lock) = open_scene(&arg, Access::Exclusive)?;
            post::run(&config)
        }
        Command::Rigid { config, options } => {
            let (config, _lock) = open_scene(&config, Access::Exclusive)?;
            rigid::run(&config, &options, &sim::SimArgs::default())
        }
        Command::Render { config, options } => {
            let (config, _lock) = open_scene(&config, Access::Shared)?;
            check_memory(&config, Stage::Render, Stage::Render)?;
            render::run(&config, &options)
        }
        Command::Run { config, options, until } => {
            sim::force_simd(&options)?;
            let (config, _lock) = open_scene(&config, Access::Exclusive)?;
            check_memory(&config, Stage::Preprocess, until)?;
            pipeline::run(&config, &options, until)
        }
        Command::Preview { config, options } => Ok(preview::run(config.config, &options)?),
        Command::Inspect { path, json } => inspect::run(&path, json),
    }
}

/// Refuses, before anything is allocated, a stage from `first` to `last` whose estimated peak
/// memory cannot fit (see [`shatter_core::memory`]).
fn check_memory(config: &PipelineConfig, first: Stage, last: Stage) -> Result<(), Failure> {
    let stages = [Stage::Preprocess, Stage::LeadIn, Stage::Sim, Stage::Post, Stage::Rigid, Stage::Render];
    let names = ["preprocess", "lead-in", "sim", "post", "rigid", "render"];
    for (stage, need) in shatter_core::memory::config_needs(config) {
        let position = names.iter().position(|name| *name == stage).map(|i| stages[i]);
        if position.is_some_and(|s| (first..=last).contains(&s)) {
            shatter_core::memory::check(&need)?;
        }
    }
    Ok(())
}

/// The error and its causes, each cause once: library errors already quote their source.
fn describe(error: &anyhow::Error) -> String {
    let mut message = String::new();
    for cause in error.chain() {
        let text = cause.to_string();
        if !message.contains(&text) {
            if !message.is_empty() {
                message.push_str(": ");
            }
            message.push_str(&text);
        }
    }
    message
}

/// Keeps Mesa's Wayland client quiet on machines without a display (a farm node, CI): when
/// XDG_RUNTIME_DIR is unset, every GPU probe printed "XDG_RUNTIME_DIR is invalid or not set"
/// twice. Pointing it at a folder that holds no display socket makes the probe fail silently;
/// a set XDG_RUNTIME_DIR is left alone.
fn quiet_display_probe() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none_or(|dir| dir.is_empty()) {
        let folder = std::env::temp_dir().join("shatter-no-display");
        // SAFETY: called first thing in `main`, before any thread exists, so nothing reads the
        // environment while it changes.
        #[allow(unsafe_code)]
        unsafe {
            std::env::set_var("XDG_RUNTIME_DIR", folder);
        }
    }
}

fn main() -> ExitCode {
    quiet_display_probe();
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure { code, error }) => {
            eprintln!("error: {}", describe(&error));
            ExitCode::from(code)
        }
    }
}
