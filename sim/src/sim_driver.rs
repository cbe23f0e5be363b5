//! `shatter sim`: runs a scene's simulation frame by frame, writing point caches, the break log
//! and checkpoints; resumes from the last checkpoint; stops on instability with the last good
//! checkpoint intact. The same loop drives either backend (see [`crate::backend`]); which one is
//! [`crate::backend_choice`]'s call. A run after the lead-in starts from its handoff
//! (`lead_in_start.rs`).

use std::path::PathBuf;
use std::time::Instant;

use shatter_core::checkpoint::{self, CheckpointMeta, CheckpointState, StateRef};
use shatter_core::config::sim::BackendChoice;
use shatter_core::digest;
use shatter_core::frames::{BreakLog, FrameFileError, PointFrame};
use shatter_core::layout::missing_input;
use shatter_core::lead_in::LeadIn;
use shatter_core::memory::{self, MemoryError, SetSize};
use shatter_core::particles::ParticleSet;
use shatter_core::sim_frames::SimFrames;
use shatter_core::stage_file::StageFileError;
use shatter_core::time_step;
use shatter_core::{OutputLayout, PipelineConfig, Progress};
use shatter_gpu::GpuError;

use crate::SimError;
use crate::backend::{Backend, DeviceError};
use crate::backend_choice::{BackendError, create_backend};
use crate::lead_in_start::{HandoffMotion, paths_from_handoff, read_lead_in};
use crate::model::lightest_kg;
use crate::previous_run::PreviousRun;
use crate::simd_path::SimdPath;
use crate::state::{Dynamics, Energy};

/// How a run starts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RunOptions {
    /// Where to run (`None`: the config's `sim.backend`).
    pub backend: Option<BackendChoice>,
    /// Continue from the last checkpoint if there is one.
    pub resume: bool,
    /// Run even when `sim.dt_s` exceeds the stable time step (a warning instead of an error).
    pub allow_unstable_dt: bool,
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Bad input: the particle file or config cannot make a sound run (exit code 2).
    #[error(transparent)]
    Input(#[from] SimError),
    /// The particle file is not there: `shatter preprocess` has not run (exit code 2).
    #[error("{0}")]
    MissingInput(String),
    /// The time step is above the stable limit (exit code 2).
    #[error(
        "sim.dt_s = {dt_s:e} s exceeds the stable time step {stable_s:e} s of this material and particle set; \
         lower it, or pass --allow-unstable-dt to run anyway"
    )]
    UnstableTimeStep {
        /// The configured step.
        dt_s: f64,
        /// The stable limit.
        stable_s: f64,
    },
    /// The checkpoint belongs to another config or particle file (exit code 2).
    #[error("{path}: {what}; run without --resume to start over")]
    CheckpointMismatch {
        /// The checkpoint.
        path: PathBuf,
        /// What differs.
        what: String,
    },
    /// A projectile or indenter would throw particles through itself in one step (exit code 2).
    #[error(
        "sim.dt_s = {dt_s:e} s lets {key} = {stiffness:e} throw a particle of {mass_kg:.3e} kg across its reach in one \
         step (at most {max_dt_s:.3e} s at this stiffness); lower one of them, or pass --allow-unstable-dt to run anyway"
    )]
    UnstablePush {
        /// The stiffness key of the body.
        key: String,
        /// Its stiffness.
        stiffness: f64,
        /// The configured step.
        dt_s: f64,
        /// The lightest particle.
        mass_kg: f64,
        /// The longest step the body allows.
        max_dt_s: f64,
    },
    /// The state blew up; the last good checkpoint is kept.
    #[error(
        "the simulation became unstable at frame {frame} (step {step}): {what}; {kept}; a smaller sim.dt_s in {} \
         steadies it",
        config.display()
    )]
    Unstable {
        /// The config file (whose `sim.dt_s` to lower).
        config: PathBuf,
        /// The frame being simulated.
        frame: u32,
        /// The step reached.
        step: u64,
        /// What was seen.
        what: String,
        /// What of the outputs is intact.
        kept: String,
    },
    /// A stage file could not be read or written.
    #[error(transparent)]
    StageFile(#[from] StageFileError),
    /// A frame file or the break log could not be read or written.
    #[error(transparent)]
    FrameFile(#[from] FrameFileError),
    /// The stage would not fit in memory (exit code 2).
    #[error(transparent)]
    Memory(#[from] MemoryError),
    /// No GPU for `--backend gpu`, or the GPU failed while the backend was being set up.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The backend failed while running (e.g. the GPU reported an error mid-run).
    #[error(transparent)]
    Device(#[from] DeviceError),
}

impl From<BackendError> for RunError {
    fn from(error: BackendError) -> RunError {
        match error {
            BackendError::Input(error) => RunError::Input(error),
            BackendError::Gpu(error) => RunError::Gpu(error),
        }
    }
}

impl RunError {
    /// True when the user must change the input (config, particle file, flags).
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            RunError::Input(_)
                | RunError::MissingInput(_)
                | RunError::UnstableTimeStep { .. }
                | RunError::UnstablePush { .. }
                | RunError::CheckpointMismatch { .. }
                | RunError::Memory(_)
        )
    }
}

/// What a finished run did.
#[derive(Debug, Clone, PartialEq)]
pub struct RunReport {
    /// What ran the steps: "CPU (N threads)" or "GPU: adapter".
    pub backend: String,
    /// The CPU kernels' instruction set (`None` on the GPU).
    pub simd: Option<SimdPath>,
    /// Particles simulated.
    pub particles: usize,
    /// The frame the run started from (1 for a fresh run).
    pub started_at_frame: u32,
    /// The last frame written.
    pub frames: u32,
    /// Steps simulated in this invocation.
    pub steps: u64,
    /// Bonds broken in all.
    pub broken_bonds: u64,
    /// The time step taken, seconds.
    pub dt_s: f64,
    /// Whether it was taken from the material (`sim.dt_s` is unset).
    pub dt_from_material: bool,
    /// The longest step at which the pushing bodies hold the lightest particle, seconds.
    pub push_limit_s: f64,
    /// The stable time step, seconds.
    pub stable_dt_s: f64,
    /// Wall time, seconds.
    pub wall_s: f64,
    /// Things the user should know.
    pub warnings: Vec<String>,
    /// Where the frames are.
    pub frames_dir: PathBuf,
}

/// The state is finite: every displacement and velocity.
fn non_finite(dynamics: &Dynamics) -> Option<String> {
    for (name, arrays) in [("displacement", &dynamics.disp), ("velocity", &dynamics.vel)] {
        for values in arrays {
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return Some(format!("particle {i} has a non-finite {name}"));
            }
        }
    }
    None
}

/// Makes the backend of a run from the config and its particles; also returns a warning for the
/// user, if any.
pub type BackendFactory<'a> =
    &'a dyn Fn(&PipelineConfig, &ParticleSet) -> Result<(Box<dyn Backend>, Option<String>), BackendError>;

/// Passes `outcome` on; a failure first puts the previous run's outputs back in place, if a fresh
/// run set them aside and has not yet superseded them with a checkpoint of its own.
fn restoring<T>(previous: &mut Option<PreviousRun>, outcome: Result<T, RunError>) -> Result<T, RunError> {
    if outcome.is_err()
        && let Some(previous) = previous.take()
    {
        previous.restore()?;
    }
    outcome
}

/// Runs the simulation of `config` on the particle file in its output folder, on the backend
/// `options.backend` (or the config's `sim.backend`) chooses.
pub fn run_sim(config: &PipelineConfig, options: RunOptions, progress: &dyn Progress) -> Result<RunReport, RunError> {
    let choice = options.backend.unwrap_or(config.sim.backend);
    run_with(config, options, progress, &|config, particles| create_backend(config, particles, choice))
}

/// [`run_sim`] on the backend `make` builds (tests: a GPU context of their own choosing).
/// `options.backend` is ignored.
pub fn run_with(
    config: &PipelineConfig,
    options: RunOptions,
    progress: &dyn Progress,
    make: BackendFactory,
) -> Result<RunReport, RunError> {
    let started = Instant::now();
    let inputs = RunInputs::read(config)?;
    let physics = inputs.lead_in.as_ref().map(|lead_in| paths_from_handoff(config, lead_in.handoff_time_s));
    let (mut simulation, fallback) = make(physics.as_ref().unwrap_or(config), &inputs.particles)?;

    let mut warnings: Vec<String> = fallback.into_iter().collect();
    let stable_dt_s = check_time_step(config, options, simulation.as_ref(), &inputs.particles, &mut warnings)?;
    let frames_dir = inputs.layout.frames_dir();
    let dt_s = simulation.model().dt_s;
    let sim_frames = SimFrames::of(config, inputs.lead_in.as_ref(), dt_s).map_err(RunError::MissingInput)?;
    let total_frames = sim_frames.count();
    if config.sim.dt_s.is_none() && total_frames < 2 {
        // the frames after the first record the step taken, for the stages after this one
        return Err(SimError::BadInput(format!(
            "{}: sim.dt_s is unset and the simulation writes one frame, which records no step; set sim.dt_s",
            config.path.display()
        ))
        .into());
    }

    let resumable = options.resume && inputs.layout.checkpoint().exists();
    if options.resume && !resumable {
        warnings.push("no checkpoint to resume from: starting from the beginning".to_string());
    }
    // A fresh run's predecessor, set aside until the fresh run has a checkpoint of its own.
    let mut previous = None;
    let start = if resumable {
        resume(&inputs, simulation.as_mut(), total_frames, &mut warnings)?
    } else {
        previous = PreviousRun::set_aside(&inputs.layout)?;
        let fresh = start_fresh(config, &inputs, simulation.as_mut());
        restoring(&mut previous, fresh)?
    };

    let remaining_steps = sim_frames.steps[total_frames as usize - 1] - sim_frames.steps[start.frame as usize - 1];
    progress.start("sim", remaining_steps);
    let mut frames = FrameLoop {
        config,
        inputs: &inputs,
        sim_frames: &sim_frames,
        progress,
        simulation: simulation.as_mut(),
        log: start.log,
        broken_bonds: start.broken_bonds,
        initial_energy_j: start.initial_energy_j,
        steps: 0,
        checkpointed: resumable,
        previous,
    };
    let outcome = (start.frame + 1..=total_frames).try_for_each(|frame| frames.frame(frame, total_frames));
    progress.finish();
    restoring(&mut frames.previous, outcome)?;
    let (steps, broken_bonds) = (frames.steps, frames.broken_bonds);
    Ok(RunReport {
        backend: simulation.describe(),
        simd: simulation.simd_path(),
        particles: simulation.len(),
        started_at_frame: start.frame,
        frames: total_frames,
        steps,
        broken_bonds,
        dt_s,
        dt_from_material: config.sim.dt_s.is_none(),
        push_limit_s: simulation.model().push_limit_s,
        stable_dt_s,
        wall_s: started.elapsed().as_secs_f64(),
        warnings,
        frames_dir,
    })
}

/// What a run reads before it makes its backend.
struct RunInputs {
    /// The scene's output folder.
    layout: OutputLayout,
    /// The particle file.
    particles: ParticleSet,
    /// The particle file's checksum.
    particles_checksum: u32,
    /// The digest of the `[sim]` and `[material]` settings ([`digest::sim_settings`]).
    settings_hash: u32,
    /// The digest of the particle file and the settings ([`digest::sim_inputs`]).
    inputs: u32,
    /// The lead-in's handoff, with `[lead_in]`.
    lead_in: Option<LeadIn>,
}

impl RunInputs {
    /// Reads the particle file of `config`'s output folder (checking first that it is there and
    /// that it and the stage fit in memory) and the lead-in's handoff.
    fn read(config: &PipelineConfig) -> Result<RunInputs, RunError> {
        let layout = OutputLayout::of(config);
        if let Some(message) = missing_input(&layout.particles(), "preprocess") {
            return Err(RunError::MissingInput(message));
        }
        memory::check(&memory::load_need(&layout.particles()))?;
        let (particles, particles_checksum) = ParticleSet::read_with_checksum(&layout.particles())?;
        memory::check(&memory::sim_need(&SetSize::of(&particles)))?;
        let inputs = digest::sim_inputs(particles_checksum, config);
        let lead_in = read_lead_in(config, &layout, inputs, &particles)?;
        let settings_hash = digest::sim_settings(config);
        Ok(RunInputs { layout, particles, particles_checksum, settings_hash, inputs, lead_in })
    }
}

/// Checks a set `sim.dt_s` against the backend's stable time step and the time steps at which
/// the pushing bodies hold the lightest particle: an error, or with `--allow-unstable-dt` a
/// warning. (A step taken from the material is under both by construction.) Returns the stable
/// time step, seconds.
fn check_time_step(
    config: &PipelineConfig,
    options: RunOptions,
    simulation: &dyn Backend,
    particles: &ParticleSet,
    warnings: &mut Vec<String>,
) -> Result<f64, RunError> {
    let stable_dt_s = simulation.stable_dt_s();
    let Some(dt_s) = config.sim.dt_s else {
        return Ok(stable_dt_s);
    };
    if dt_s > stable_dt_s {
        if !options.allow_unstable_dt {
            return Err(RunError::UnstableTimeStep { dt_s, stable_s: stable_dt_s });
        }
        warnings.push(format!("sim.dt_s = {dt_s:e} s exceeds the stable time step {stable_dt_s:e} s"));
    }
    let lightest_kg = lightest_kg(particles);
    for body in config.sim.pushing_bodies() {
        let max_dt_s = body.max_dt_s(lightest_kg);
        if dt_s > max_dt_s && options.allow_unstable_dt {
            warnings.push(format!(
                "sim.dt_s = {dt_s:e} s exceeds the {max_dt_s:e} s at which {} holds particles",
                body.key
            ));
        } else if dt_s > max_dt_s {
            let (key, stiffness, mass_kg) = (body.key, body.stiffness, lightest_kg);
            return Err(RunError::UnstablePush { key, stiffness, dt_s, mass_kg, max_dt_s });
        }
    }
    Ok(stable_dt_s)
}

/// Where the frame loop starts.
struct Start {
    /// The break log, open for appending.
    log: BreakLog,
    /// The last frame written (1 for a fresh run).
    frame: u32,
    /// Bonds broken up to that frame.
    broken_bonds: u64,
    /// Kinetic plus bond energy at frame 1, joules.
    initial_energy_j: f64,
}

/// Resumes from the checkpoint: checks that it belongs to this particle file, these settings and
/// this break log, and restores the backend's state from it.
fn resume(
    inputs: &RunInputs,
    simulation: &mut dyn Backend,
    total_frames: u32,
    warnings: &mut Vec<String>,
) -> Result<Start, RunError> {
    let (checkpoint_path, log_path) = (inputs.layout.checkpoint(), inputs.layout.break_log());
    let (meta, state) = checkpoint::read(&checkpoint_path)?;
    let mismatch = |what: &str| RunError::CheckpointMismatch { path: checkpoint_path.clone(), what: what.into() };
    // Inputs first: a checkpoint of another particle file or other settings is stale, not corrupt.
    if meta.particles_checksum != inputs.particles_checksum {
        return Err(mismatch("the particle file changed since this checkpoint"));
    }
    if meta.settings_hash != inputs.settings_hash {
        return Err(mismatch("the [sim] or [material] settings changed since this checkpoint"));
    }
    if meta.frame > total_frames {
        return Err(mismatch("the checkpoint is past the simulation's last frame"));
    }
    if state.particles() != simulation.len() {
        let what = format!("the checkpoint holds {} particles, not {}", state.particles(), simulation.len());
        return Err(StageFileError::Malformed { path: checkpoint_path, what }.into());
    }
    let kind = |name: &str| name.split([':', ' ']).next().unwrap_or_default().to_string();
    if !meta.backend.is_empty() && kind(&meta.backend) != kind(&simulation.describe()) {
        warnings.push(format!(
            "the checkpoint was written by {}, this run uses {}: the frames will differ from an uninterrupted run \
             by rounding",
            meta.backend,
            simulation.describe()
        ));
    }
    if meta.frame >= 2 && simulation.model().dt_from_material {
        // a step from the material follows from the settings, but a backend's stable step may
        // round apart from another's
        let recorded_s = time_step::recorded_s(&inputs.layout).map_err(RunError::MissingInput)?;
        if recorded_s != simulation.model().dt_s {
            let what = format!(
                "the frames were simulated at a step of {recorded_s:e} s and this run takes {:e} s",
                simulation.model().dt_s
            );
            return Err(mismatch(&what));
        }
    }
    let (log, blocks) = BreakLog::open_at(&log_path, meta.break_log_bytes)?;
    if blocks.last().map_or(1, |block| block.frame) != meta.frame {
        let ends = blocks.last().map_or(1, |block| block.frame);
        let what = format!("the log ends at frame {ends}, but the checkpoint is at frame {}", meta.frame);
        return Err(RunError::FrameFile(FrameFileError::Invalid { path: log_path, what }));
    }
    let mut broken: Vec<u64> = blocks.iter().flat_map(|block| block.events.iter().map(|e| e.bond)).collect();
    broken.sort_unstable();
    let CheckpointState { disp, vel, force, boost, bond_state } = state;
    let dynamics = Dynamics { step: meta.step, disp, vel, force, boost, external_work_j: meta.external_work_j };
    simulation.restore(dynamics, &broken)?;
    simulation
        .set_bond_state(&bond_state)
        .map_err(|what| StageFileError::Malformed { path: checkpoint_path.clone(), what })?;
    Ok(Start { log, frame: meta.frame, broken_bonds: meta.broken_bonds, initial_energy_j: meta.initial_energy_j })
}

/// Starts afresh: a new break log, the initial displacements and velocities (the lead-in's
/// rigid motion, or `sim.initial_velocity_m_s`), and frame 1.
fn start_fresh(config: &PipelineConfig, inputs: &RunInputs, simulation: &mut dyn Backend) -> Result<Start, RunError> {
    let log = BreakLog::create(&inputs.layout.break_log())?;
    let initial_velocity = config.sim.initial_velocity_m_s.map(|v| v as f32);
    if let Some(lead_in) = &inputs.lead_in {
        if let Some(plastic) = &lead_in.plastic {
            // before the displacements, whose forces it changes
            simulation.set_bond_state(&plastic.extension_m).map_err(|what| {
                RunError::MissingInput(format!(
                    "{}: {what}; run `shatter rigid` again",
                    inputs.layout.lead_in().display()
                ))
            })?;
        }
        let motion = HandoffMotion::of(lead_in);
        simulation.set_displacement(&|i, rest| motion.displacement(i, rest))?;
        simulation.set_velocity(&|i, rest| motion.velocity(i, rest, initial_velocity))?;
    } else if initial_velocity != [0.0; 3] {
        simulation.set_velocity(&|_, _| initial_velocity)?;
    }
    write_frame(simulation, &inputs.layout, 1, inputs.inputs)?;
    Ok(Start { log, frame: 1, broken_bonds: 0, initial_energy_j: simulation.energy().total_j() })
}

/// The frame loop: what each frame reads, writes and counts.
struct FrameLoop<'a> {
    config: &'a PipelineConfig,
    inputs: &'a RunInputs,
    /// The steps to each frame.
    sim_frames: &'a SimFrames,
    progress: &'a dyn Progress,
    simulation: &'a mut dyn Backend,
    /// The break log, open for appending.
    log: BreakLog,
    /// Bonds broken in all.
    broken_bonds: u64,
    /// Kinetic plus bond energy at frame 1, joules.
    initial_energy_j: f64,
    /// Steps simulated in this invocation.
    steps: u64,
    /// Whether there is a checkpoint of this run (or the one resumed).
    checkpointed: bool,
    /// A fresh run's predecessor, until the first checkpoint.
    previous: Option<PreviousRun>,
}

impl FrameLoop<'_> {
    /// Simulates frame `frame` of `total_frames`, checks it is stable, writes it and its breaks,
    /// and the checkpoint when one is due.
    fn frame(&mut self, frame: u32, total_frames: u32) -> Result<(), RunError> {
        let steps_per_frame = self.sim_frames.steps_before(frame);
        for batch in 0..steps_per_frame.div_ceil(50) {
            let count = (steps_per_frame - batch * 50).min(50);
            self.simulation.advance(count)?;
            self.steps += count;
            self.progress.advance(count);
        }
        let events = self.simulation.finish_frame()?;
        self.broken_bonds += events.len() as u64;
        let energy = self.simulation.energy();
        if let Some(what) = self.trouble(&energy) {
            self.progress.finish();
            let kept = match (&self.previous, self.checkpointed) {
                (Some(_), _) => "the previous run's frames and checkpoint are back in place".to_string(),
                (None, true) => format!("frames up to {} and the last checkpoint are intact", frame - 1),
                (None, false) => format!("frames up to {} are written; no checkpoint was reached", frame - 1),
            };
            let (config, step) = (self.config.path.clone(), self.simulation.dynamics().step);
            return Err(RunError::Unstable { config, frame, step, what, kept });
        }
        write_frame(&*self.simulation, &self.inputs.layout, frame, self.inputs.inputs)?;
        self.log.append(frame, &events)?;
        if frame.is_multiple_of(self.config.sim.checkpoint_every_frames) || frame == total_frames {
            self.checkpoint(frame)?;
        }
        self.progress.message(&format!(
            "frame {frame}/{total_frames}, {} broken bonds, kinetic energy {:.3e} J",
            self.broken_bonds, energy.kinetic_j
        ));
        Ok(())
    }

    /// What is wrong with the state at the frame's end, if anything: a non-finite value, or an
    /// energy beyond `sim.runaway_energy_factor` times the initial energy plus the external work.
    fn trouble(&self, energy: &Energy) -> Option<String> {
        let dynamics = self.simulation.dynamics();
        let factor = self.config.sim.runaway_energy_factor;
        let budget = factor * (self.initial_energy_j + dynamics.external_work_j).max(0.0) + 1e-9;
        non_finite(dynamics).or_else(|| {
            (!energy.total_j().is_finite() || energy.total_j() > budget).then(|| {
                format!(
                    "kinetic plus bond energy {:.4e} J exceeds {factor} x (initial energy + external work) = \
                     {budget:.4e} J",
                    energy.total_j()
                )
            })
        })
    }

    /// Writes the checkpoint at frame `frame`; the first one discards the previous run's outputs.
    fn checkpoint(&mut self, frame: u32) -> Result<(), RunError> {
        let dynamics = self.simulation.dynamics();
        let meta = CheckpointMeta {
            frame,
            step: dynamics.step,
            break_log_bytes: self.log.len(),
            broken_bonds: self.broken_bonds,
            settings_hash: self.inputs.settings_hash,
            particles_checksum: self.inputs.particles_checksum,
            external_work_j: dynamics.external_work_j,
            initial_energy_j: self.initial_energy_j,
            backend: self.simulation.describe(),
        };
        let bond_state = self.simulation.bond_state();
        let state = StateRef {
            disp: &dynamics.disp,
            vel: &dynamics.vel,
            force: &dynamics.force,
            boost: &dynamics.boost,
            bond_state: &bond_state,
        };
        checkpoint::write(&self.inputs.layout.checkpoint(), &meta, state)?;
        self.checkpointed = true;
        if let Some(previous) = self.previous.take() {
            previous.discard()?;
        }
        Ok(())
    }
}

fn write_frame(simulation: &dyn Backend, layout: &OutputLayout, frame: u32, inputs: u32) -> Result<(), FrameFileError> {
    let dynamics = simulation.dynamics();
    PointFrame {
        frame,
        step: dynamics.step,
        time_s: simulation.time_s(),
        position: simulation.positions(),
        velocity: dynamics.vel.clone(),
        damage: simulation.damage(),
        inputs: Some(inputs),
    }
    .write(&layout.frame_points(frame))
}
