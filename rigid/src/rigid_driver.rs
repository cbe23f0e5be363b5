//! The `shatter rigid` driver: picks the handoff frame, turns each fragment into a rigid body
//! and simulates the follow-through frame by frame into `rigid/fragments.####.shp`, with a
//! checkpoint of the rapier world every few frames so an interrupted run resumes bit for bit.

use std::path::PathBuf;
use std::time::Instant;

use rapier3d_f64::math::{Rotation, Vector};
use serde::{Deserialize, Serialize};

use shatter_core::config::RigidConfig;
use shatter_core::digest;
use shatter_core::fragments::{FragmentFrame, FragmentMeta, compose_affine_with_motion};
use shatter_core::frames::{BreakLog, FrameFileError, PointFrame};
use shatter_core::layout::missing_input;
use shatter_core::lead_in::LeadIn;
use shatter_core::memory::{self, MemoryError, SetSize};
use shatter_core::particles::ParticleSet;
use shatter_core::ply::PlyError;
use shatter_core::rigid_checkpoint::{RigidCheckpoint, RigidMeta};
use shatter_core::sim_frames::SimFrames;
use shatter_core::stage_file::StageFileError;
use shatter_core::timeline::Timeline;
use shatter_core::{OutputLayout, PipelineConfig, Progress};

use crate::hand_over::{hand_over, vectors};
use crate::handoff::{cracks_stopped, pieces_calm};
use crate::reentries::{Reentries, ReentryReport, ReentryState, Stop};
use crate::shot_usd::write_shot_usd;
use crate::world::{KinematicSphere, RigidWorld, WorldSettings};

/// Why the follow-through failed.
#[derive(Debug, thiserror::Error)]
pub enum RigidError {
    /// An earlier stage's outputs are missing or stale, or `[rigid]` is not set (exit code 2).
    #[error("{0}")]
    Input(String),
    /// The stage would not fit in memory (exit code 2).
    #[error(transparent)]
    Memory(#[from] MemoryError),
    /// A stage file could not be read or written.
    #[error(transparent)]
    StageFile(#[from] StageFileError),
    /// A point cache or the break log could not be read.
    #[error(transparent)]
    FrameFile(#[from] FrameFileError),
    /// A debris point cache could not be read.
    #[error(transparent)]
    Ply(#[from] PlyError),
    /// The shot's USD could not be written.
    #[error("{path}: cannot write: {source}")]
    Usd {
        /// The USD file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The rigid world could not be saved or restored.
    #[error("{path}: {what}")]
    Snapshot {
        /// The checkpoint.
        path: PathBuf,
        /// What went wrong.
        what: String,
    },
}

impl RigidError {
    /// True when the user must fix the config or run an earlier stage.
    pub fn is_bad_input(&self) -> bool {
        matches!(self, RigidError::Input(_) | RigidError::Memory(_))
    }
}

/// What a follow-through run did.
#[derive(Debug, Clone, PartialEq)]
pub struct RigidReport {
    /// The last frame of the fracture.
    pub handoff_frame: u32,
    /// Its simulated time, seconds.
    pub handoff_time_s: f64,
    /// Why the handoff happened there.
    pub handoff_reason: String,
    /// The shot's last frame.
    pub last_frame: u32,
    /// Rigid bodies (pieces).
    pub pieces: usize,
    /// Frames written by this run.
    pub frames_written: u32,
    /// The frame from which every piece slept, if it came.
    pub asleep_from: Option<u32>,
    /// Pieces still awake at the end (moving, or not yet still long enough to sleep).
    pub awake_at_end: usize,
    /// The deepest overlap at the end between two pieces or a piece and the floor, beyond
    /// what the handoff allowed, metres.
    pub deepest_overlap_m: f64,
    /// Handoff bookkeeping (fresh runs only).
    pub conservation: Option<Conservation>,
    /// The re-entries whose pieces came back in this run.
    pub reentries: Vec<ReentryReport>,
    /// The re-entry whose simulation and post must run before the follow-through can go on:
    /// the run stopped there (see [`crate::reentries`]).
    pub awaiting_reentry: Option<u32>,
    /// Wall time, seconds.
    pub wall_s: f64,
}

/// Momentum, angular momentum and kinetic energy of the particles and of the rigid bodies at
/// the handoff.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conservation {
    /// |P_bodies - P_particles| / |P_particles|.
    pub momentum_error: f64,
    /// |L_bodies - L_particles| / |L_particles| (about the origin).
    pub angular_momentum_error: f64,
    /// The particles' kinetic energy, J.
    pub particle_energy_j: f64,
    /// The kinetic energy of the particles' best rigid motion, piece by piece, J.
    pub rigid_part_j: f64,
    /// The rigid bodies' kinetic energy, J.
    pub body_energy_j: f64,
}

/// Runs the follow-through of `config`; with `resume`, continues from its checkpoint when
/// that belongs to the same inputs.
pub fn run_rigid(config: &PipelineConfig, resume: bool, progress: &dyn Progress) -> Result<RigidReport, RigidError> {
    let started = Instant::now();
    let Some(rigid) = &config.rigid else {
        return Err(RigidError::Input(format!(
            "{}: no [rigid] table: the shot has no follow-through (see docs/CONFIG.md)",
            config.path.display()
        )));
    };
    let (layout, particles, particles_checksum) = open_particles(config)?;
    let post_inputs = digest::post_inputs(digest::sim_inputs(particles_checksum, config), config);
    let inputs = digest::rigid_inputs(post_inputs, config);
    let clock = Clock::of(config, rigid, &layout)?;
    let last_frame = clock.last_frame;
    let with_reentries = rigid.secondary_fracture.as_ref().is_some_and(|s| s.enabled());

    let previous = resume.then(|| RigidCheckpoint::read(&layout.rigid_checkpoint()).ok()).flatten();
    let (mut world, meta, handoff, conservation, reason, saved_state) = match previous {
        Some(checkpoint) if checkpoint.meta.inputs == inputs && checkpoint.meta.last_frame == last_frame => {
            let (world, state) = restore(&layout, &checkpoint.world, with_reentries)?;
            let handoff = read_fragments(&layout, checkpoint.meta.handoff_frame, &particles, post_inputs)?;
            (world, checkpoint.meta, handoff, None, "resumed".to_string(), state)
        }
        _ => {
            let (frame, reason) =
                choose_handoff(config, rigid, clock.sim_frames.count(), &layout, &particles, post_inputs)?;
            let handoff = read_fragments(&layout, frame, &particles, post_inputs)?;
            let points = PointFrame::read(&layout.frame_points(frame))?;
            let (world, conservation) = hand_over(config, rigid, &particles, &handoff, &points);
            let meta = RigidMeta {
                handoff_frame: frame,
                handoff_time_s: handoff.meta.time_s,
                last_frame,
                frame,
                steps: 0,
                asleep: false,
                inputs,
            };
            (world, meta, handoff, Some(conservation), reason, None)
        }
    };
    let mut reentries = Reentries::new(config, &layout, &particles, &handoff, inputs)?;
    let mut report = RigidReport {
        handoff_frame: meta.handoff_frame,
        handoff_time_s: meta.handoff_time_s,
        handoff_reason: reason,
        last_frame,
        pieces: handoff.fragment_count(),
        frames_written: 0,
        asleep_from: None,
        awake_at_end: 0,
        deepest_overlap_m: 0.0,
        conservation,
        reentries: Vec::new(),
        awaiting_reentry: None,
        wall_s: 0.0,
    };
    if let (Some(reentries), Some(state)) = (&mut reentries, saved_state) {
        report.awaiting_reentry = reentries.resume(state)?;
    }
    let mut meta = meta;
    let first = meta.frame + 1;
    if report.awaiting_reentry.is_none() {
        let run = FrameRun { layout: &layout, clock: &clock, rigid, inputs, progress };
        report.awaiting_reentry = run.frames(&mut world, &mut meta, &handoff, reentries.as_mut(), &mut report)?;
    }
    report.frames_written = meta.frame + 1 - first;
    report.awake_at_end = world.awake_pieces().len();
    report.deepest_overlap_m = world.deepest_penetration_m();
    // the pieces as re-entries left them: the shot's USD has a mesh for each, which before its
    // split moves with the piece that held it
    let pieces = reentries.as_ref().map_or(&handoff, |reentries| &reentries.table);
    report.pieces = pieces.fragment_count();
    if report.awaiting_reentry.is_none() {
        if first > last_frame {
            write_checkpoint(&layout, &meta, &world, reentries.as_ref().map(|r| &r.state))?;
        }
        if config.post.usd {
            write_shot_usd(config, &layout, &particles, pieces, &clock.sim_frames, reentries.as_ref())?;
        }
    }
    if let Some(reentries) = reentries {
        report.reentries = reentries.reports;
    }
    report.wall_s = started.elapsed().as_secs_f64();
    Ok(report)
}

/// What the frame loop of a run shares.
struct FrameRun<'a> {
    layout: &'a OutputLayout,
    clock: &'a Clock,
    rigid: &'a RigidConfig,
    inputs: u32,
    progress: &'a dyn Progress,
}

impl FrameRun<'_> {
    /// Simulates and writes the frames after `meta.frame`; stops early at a re-entry whose
    /// simulation has not run yet, and returns its number.
    fn frames(
        &self,
        world: &mut RigidWorld,
        meta: &mut RigidMeta,
        handoff: &FragmentFrame,
        mut reentries: Option<&mut Reentries>,
        report: &mut RigidReport,
    ) -> Result<Option<u32>, RigidError> {
        let last_frame = meta.last_frame;
        self.progress.start("rigid", u64::from(last_frame - meta.frame));
        for frame in meta.frame + 1..=last_frame {
            let time_s = self.clock.time_s(meta, frame);
            let poses = match reentries.as_deref_mut() {
                None => {
                    if !meta.asleep {
                        meta.steps += world.advance(self.clock.step_s(meta, frame), self.rigid.max_step_s);
                        meta.asleep = world.all_asleep();
                    }
                    world.poses()
                }
                Some(reentries) => {
                    if !meta.asleep || !reentries.state.active.is_empty() {
                        while let Stop::Started(number) = reentries.step_to(world, time_s, frame, &mut meta.steps)? {
                            meta.frame = frame - 1;
                            let bytes = write_checkpoint(self.layout, meta, world, Some(&reentries.state))?;
                            // continue from the checkpoint's world, as a resumed run does
                            *world = restore(self.layout, &bytes, true)?.0;
                            if reentries.load_active()?.is_some() {
                                self.progress.finish();
                                return Ok(Some(number));
                            }
                        }
                        meta.asleep = world.all_asleep() && reentries.state.active.is_empty();
                    }
                    reentries.frame_poses(world, time_s)?
                }
            };
            if meta.asleep && report.asleep_from.is_none() {
                report.asleep_from = Some(frame);
            }
            let table = reentries.as_deref().map_or(handoff, |reentries| &reentries.table);
            rigid_frame(table, &poses, frame, time_s, self.inputs).write(&self.layout.rigid_fragments(frame))?;
            meta.frame = frame;
            if (frame - meta.handoff_frame).is_multiple_of(self.rigid.checkpoint_every_frames) || frame == last_frame {
                write_checkpoint(self.layout, meta, world, reentries.as_deref().map(|r| &r.state))?;
            }
            self.progress.advance(1);
            self.progress.message(&format!(
                "frame {frame}/{last_frame}{}",
                if meta.asleep { ", every piece asleep" } else { "" }
            ));
        }
        self.progress.finish();
        Ok(None)
    }
}

/// When the follow-through's frames fall: a frame interval apart at real speed without
/// `[timeline]`, where the timeline puts them with it.
struct Clock {
    /// The simulation's frames.
    sim_frames: SimFrames,
    /// The last frame, in the simulation's numbering.
    last_frame: u32,
    /// Frames per second without a timeline.
    fps: f64,
    /// The timeline and the shot frame of the simulation's frame 1.
    timeline: Option<(Timeline, u32)>,
}

impl Clock {
    fn of(config: &PipelineConfig, rigid: &RigidConfig, layout: &OutputLayout) -> Result<Clock, RigidError> {
        let lead_in = match config.lead_in {
            None => None,
            Some(_) => Some(LeadIn::read_for(layout).map_err(RigidError::Input)?),
        };
        let sim_frames = SimFrames::read(config, layout).map_err(RigidError::Input)?;
        let simulated = sim_frames.count();
        let fps = config.scene.frames_per_second;
        Ok(match &config.timeline {
            None => {
                let last_frame = simulated + rigid.follow_through_frames(fps);
                Clock { sim_frames, last_frame, fps, timeline: None }
            }
            Some(timeline) => {
                let impact_time_s = lead_in.as_ref().map_or(0.0, |lead_in| lead_in.handoff_time_s);
                let timeline = Timeline::new(timeline, impact_time_s);
                let offset = sim_frames.first_shot_frame - 1;
                let last_frame = timeline.frames() - offset;
                Clock { sim_frames, last_frame, fps, timeline: Some((timeline, offset)) }
            }
        })
    }

    /// The simulated time of `frame` (the simulation's numbering), seconds since its start.
    fn time_s(&self, meta: &RigidMeta, frame: u32) -> f64 {
        match &self.timeline {
            None => meta.handoff_time_s + f64::from(frame - meta.handoff_frame) / self.fps,
            Some((timeline, offset)) => {
                let since = |frame: u32| timeline.since_impact_s(frame + offset);
                meta.handoff_time_s + (since(frame) - since(meta.handoff_frame))
            }
        }
    }

    /// The physical time from `frame - 1` to `frame`, seconds.
    fn step_s(&self, meta: &RigidMeta, frame: u32) -> f64 {
        match &self.timeline {
            None => 1.0 / self.fps,
            Some(_) => self.time_s(meta, frame) - self.time_s(meta, frame - 1),
        }
    }
}

/// The output folder's layout (its `rigid/` folder made) and the particle file with its
/// checksum, once the stage is known to fit in memory.
pub(crate) fn open_particles(config: &PipelineConfig) -> Result<(OutputLayout, ParticleSet, u32), RigidError> {
    let layout = OutputLayout::of(config);
    if let Some(message) = missing_input(&layout.particles(), "preprocess") {
        return Err(RigidError::Input(message));
    }
    memory::check(&memory::load_need(&layout.particles()))?;
    let (particles, particles_checksum) = ParticleSet::read_with_checksum(&layout.particles())?;
    memory::check(&memory::post_need(&SetSize::of(&particles)))?;
    let folder = layout.rigid_dir();
    std::fs::create_dir_all(&folder)
        .map_err(|error| RigidError::Input(format!("{}: cannot create: {error}", folder.display())))?;
    Ok((layout, particles, particles_checksum))
}

/// A checkpoint's world, and the re-entries' state beside it when the shot has them.
#[derive(Serialize, Deserialize)]
struct WithReentries {
    world: Vec<u8>,
    reentries: ReentryState,
}

/// Writes the checkpoint; returns its world's bytes.
fn write_checkpoint(
    layout: &OutputLayout,
    meta: &RigidMeta,
    world: &RigidWorld,
    reentries: Option<&ReentryState>,
) -> Result<Vec<u8>, RigidError> {
    let path = layout.rigid_checkpoint();
    let failed = |error: rmp_serde::encode::Error| RigidError::Snapshot {
        path: path.clone(),
        what: format!("cannot serialise the rigid world: {error}"),
    };
    let mut bytes = world.snapshot().map_err(failed)?;
    if let Some(state) = reentries {
        bytes = rmp_serde::to_vec_named(&WithReentries { world: bytes, reentries: state.clone() }).map_err(failed)?;
    }
    RigidCheckpoint { meta: meta.clone(), world: bytes.clone() }.write(&path)?;
    Ok(bytes)
}

/// The world of a checkpoint's bytes, with the re-entries' state when it has one (for
/// `shatter inspect`, which does not know the scene's settings).
pub fn checkpoint_world(bytes: &[u8]) -> Result<(RigidWorld, Option<ReentryState>), String> {
    match RigidWorld::restore(bytes) {
        Ok(world) => Ok((world, None)),
        Err(error) => {
            let saved: WithReentries = rmp_serde::from_slice(bytes).map_err(|_| error.to_string())?;
            Ok((RigidWorld::restore(&saved.world).map_err(|e| e.to_string())?, Some(saved.reentries)))
        }
    }
}

/// The world (and with `with_reentries` the re-entries' state) of a checkpoint's bytes.
fn restore(
    layout: &OutputLayout,
    bytes: &[u8],
    with_reentries: bool,
) -> Result<(RigidWorld, Option<ReentryState>), RigidError> {
    let failed = |what: String| RigidError::Snapshot {
        path: layout.rigid_checkpoint(),
        what: format!("cannot restore the rigid world: {what}"),
    };
    let (world, state) = match with_reentries {
        false => (RigidWorld::restore(bytes), None),
        true => {
            let saved: WithReentries = rmp_serde::from_slice(bytes).map_err(|e| failed(e.to_string()))?;
            (RigidWorld::restore(&saved.world), Some(saved.reentries))
        }
    };
    Ok((world.map_err(|e| failed(e.to_string()))?, state))
}

/// Post's fragments of `frame`, checked against the particle file and post's inputs.
pub(crate) fn read_fragments(
    layout: &OutputLayout,
    frame: u32,
    particles: &ParticleSet,
    post_inputs: u32,
) -> Result<FragmentFrame, RigidError> {
    let path = layout.fragments(frame);
    if let Some(message) = missing_input(&path, "post") {
        return Err(RigidError::Input(message));
    }
    let fragments = FragmentFrame::read(&path)?;
    if fragments.meta.inputs != Some(post_inputs) || fragments.fragment_of.len() != particles.len() {
        return Err(RigidError::Input(format!(
            "{}: made from other inputs (particle file, [sim], [material] or [post] settings); run `shatter sim` and \
             `shatter post` again",
            path.display()
        )));
    }
    Ok(fragments)
}

/// The handoff frame and why (see [`crate::handoff`]).
pub(crate) fn choose_handoff(
    config: &PipelineConfig,
    rigid: &RigidConfig,
    simulated: u32,
    layout: &OutputLayout,
    particles: &ParticleSet,
    post_inputs: u32,
) -> Result<(u32, String), RigidError> {
    let blocks = BreakLog::read_through(&layout.break_log(), simulated)?;
    let mut breaks = vec![0u64; simulated as usize];
    for block in &blocks {
        if let Some(count) = breaks.get_mut(block.frame as usize - 1) {
            *count += block.events.len() as u64;
        }
    }
    let mass: Vec<f64> = particles.volume_m3.iter().map(|v| f64::from(*v) * config.material.density_kg_m3).collect();
    for frame in 2..=simulated {
        let fragments = read_fragments(layout, frame, particles, post_inputs)?;
        if fragments.meta.time_s >= rigid.max_fracture_duration_s {
            return Ok((frame, format!("rigid.max_fracture_duration_s ({} s) reached", rigid.max_fracture_duration_s)));
        }
        if !cracks_stopped(&breaks, frame, rigid.handoff_quiet_frames) {
            continue;
        }
        let points = PointFrame::read(&layout.frame_points(frame))?;
        let (position, velocity) = vectors(&points);
        if pieces_calm(rigid, &fragments.fragment_of, fragments.fragment_count(), &mass, &position, &velocity) {
            return Ok((
                frame,
                format!(
                    "no bond broke in {} frames and every piece moves rigidly (internal energy at most {} of rigid)",
                    rigid.handoff_quiet_frames, rigid.handoff_internal_energy_ratio
                ),
            ));
        }
    }
    Ok((simulated, "the last simulated frame (the cracks never quieted)".into()))
}

/// The rigid world's settings for a shot of particles `lambda_m` apart.
pub fn world_settings(config: &PipelineConfig, rigid: &RigidConfig, lambda_m: f64) -> WorldSettings {
    WorldSettings::of(rigid, config.sim.gravity_m_s2, LENGTH_UNIT_SPACINGS * lambda_m)
}

/// The projectiles and indenters at simulated time `time_s`, on their straight paths.
pub(crate) fn kinematic_spheres(config: &PipelineConfig, time_s: f64) -> Vec<KinematicSphere> {
    let projectiles = config.sim.projectile.iter().map(|p| (p.center_m, p.velocity_m_s, p.radius_m));
    let indenters = config.sim.indenter.iter().map(|i| (i.center_m, i.velocity_m_s, i.radius_m));
    projectiles
        .chain(indenters)
        .map(|(centre, velocity, radius_m)| KinematicSphere {
            centre_m: [0, 1, 2].map(|a| centre[a] + velocity[a] * time_s),
            velocity_m_s: velocity,
            radius_m,
        })
        .collect()
}

/// Rapier's length unit (the scale of its tolerances) in particle spacings: about a small
/// piece.
pub const LENGTH_UNIT_SPACINGS: f64 = 10.0;

/// The fragments file of a rigid frame: the pieces of `table` (the handoff's, or as re-entries
/// left them) at `poses`.
fn rigid_frame(
    table: &FragmentFrame,
    poses: &[(Rotation, Vector)],
    frame: u32,
    time_s: f64,
    inputs: u32,
) -> FragmentFrame {
    FragmentFrame {
        meta: FragmentMeta { frame, step: table.meta.step, time_s, smoothed: false, inputs: Some(inputs) },
        fragment_of: table.fragment_of.clone(),
        rotation: poses.iter().map(|(r, _)| [r.x as f32, r.y as f32, r.z as f32, r.w as f32]).collect(),
        translation_m: poses.iter().map(|(_, t)| t.to_array()).collect(),
        elements: table.elements.clone(),
        mass_kg: table.mass_kg.clone(),
        // deformed elements keep the shapes they had when their piece became rigid and move
        // with their bodies since then
        element_affine: table.element_affine.as_ref().map(|affine| {
            affine
                .iter()
                .zip(&table.fragment_of)
                .map(|(map, &f)| {
                    let f = f as usize;
                    let (r, t) = &poses[f];
                    let to = ([r.x as f32, r.y as f32, r.z as f32, r.w as f32], t.to_array());
                    compose_affine_with_motion(map, (table.rotation[f], table.translation_m[f]), to)
                })
                .collect()
        }),
    }
}
