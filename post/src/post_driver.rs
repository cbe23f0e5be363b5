//! The `shatter post` driver: reads the simulation's frames and break log, tracks the fragments
//! frame by frame and writes the fragments files, the point caches with fragment ids and the
//! USD shot.

use std::path::{Path, PathBuf};
use std::time::Instant;

use shatter_core::debris_points::{self, DebrisFrame};
use shatter_core::digest;
use shatter_core::fragments::{FragmentFrame, FragmentMeta};
use shatter_core::frames::{BreakBlock, BreakEvent, BreakLog, FrameFileError, PointFrame};
use shatter_core::in_flight::OneInFlight;
use shatter_core::layout::missing_input;
use shatter_core::lead_in::LeadIn;
use shatter_core::memory::{self, MemoryError, SetSize};
use shatter_core::particles::ParticleSet;
use shatter_core::ply::{Column, PlyError, PointCache};
use shatter_core::sim_frames::SimFrames;
use shatter_core::stage_file::StageFileError;
use shatter_core::surfaces;
use shatter_core::usd::{PieceTransform, UsdShot, element_of_pieces, write_usda};
use shatter_core::{OutputLayout, PipelineConfig, Progress};

use crate::components::size_histogram;
use crate::debris::debris_frame;
use crate::deformation::ElementDeformation;
use crate::kabsch::RigidMotion;
use crate::tracker::{FragmentTracker, TrackedFrame};

/// Why post failed.
#[derive(Debug, thiserror::Error)]
pub enum PostError {
    /// The simulation's outputs are missing or do not belong to the particle file (exit code 2).
    #[error("{0}")]
    MissingInput(String),
    /// The stage would not fit in memory (exit code 2).
    #[error(transparent)]
    Memory(#[from] MemoryError),
    /// A stage file could not be read or written.
    #[error(transparent)]
    StageFile(#[from] StageFileError),
    /// A frame or the break log could not be read.
    #[error(transparent)]
    FrameFile(#[from] FrameFileError),
    /// A point cache could not be written.
    #[error(transparent)]
    Ply(#[from] PlyError),
    /// The USD file could not be written.
    #[error("{path}: cannot write: {source}")]
    Usd {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

impl PostError {
    /// True when the user must run an earlier stage again.
    pub fn is_bad_input(&self) -> bool {
        matches!(self, PostError::MissingInput(_) | PostError::Memory(_))
    }
}

/// What a post run did.
#[derive(Debug, Clone, PartialEq)]
pub struct PostReport {
    /// Frames processed.
    pub frames: u32,
    /// Fragments in the last frame.
    pub fragments: usize,
    /// Fragment sizes in the last frame: (at least this many elements, fragments).
    pub size_histogram: Vec<(u32, u32)>,
    /// Where the outputs are.
    pub folder: PathBuf,
    /// Wall time, seconds.
    pub wall_s: f64,
}

/// Runs the post stage of `config` on its simulation outputs.
pub fn run_post(config: &PipelineConfig, progress: &dyn Progress) -> Result<PostReport, PostError> {
    let started = Instant::now();
    let layout = OutputLayout::of(config);
    let input = PostInput::read(config, &layout)?;
    let out_dir = layout.fragments_dir();
    std::fs::create_dir_all(&out_dir).map_err(|source| PostError::Usd { path: out_dir.clone(), source })?;
    let mut tracking = FrameTracking::new(config, &layout, &input);
    tracking.track_all(progress)?;
    let last = tracking.last.take().ok_or_else(|| PostError::MissingInput("the simulation has no frames".into()))?;
    if config.post.usd {
        tracking.write_shot_usd(&last)?;
    }
    Ok(PostReport {
        frames: input.total,
        fragments: last.motion.len(),
        size_histogram: size_histogram(&last.elements),
        folder: out_dir,
        wall_s: started.elapsed().as_secs_f64(),
    })
}

/// What post reads before its first frame: the particles, which frames the simulation wrote, and
/// its break log.
struct PostInput {
    particles: ParticleSet,
    /// The digest of the simulation's inputs, which each of its frames carries.
    sim_inputs: u32,
    sim_frames: SimFrames,
    /// The simulation's frame count.
    total: u32,
    /// The break log through the last frame.
    blocks: Vec<BreakBlock>,
}

impl PostInput {
    /// Reads the particle file and the break log, and checks that every frame is there and that
    /// the stage fits in memory.
    fn read(config: &PipelineConfig, layout: &OutputLayout) -> Result<PostInput, PostError> {
        if let Some(message) = missing_input(&layout.particles(), "preprocess") {
            return Err(PostError::MissingInput(message));
        }
        memory::check(&memory::load_need(&layout.particles()))?;
        let (particles, particles_checksum) = ParticleSet::read_with_checksum(&layout.particles())?;
        memory::check(&memory::post_need(&SetSize::of(&particles)))?;
        let sim_inputs = digest::sim_inputs(particles_checksum, config);
        let sim_frames = SimFrames::read(config, layout).map_err(PostError::MissingInput)?;
        let total = sim_frames.count();
        for frame in 1..=total {
            if !layout.frame_points(frame).is_file() {
                return Err(PostError::MissingInput(format!(
                    "{}: missing (the simulation writes {total} frames); run `shatter sim` first",
                    layout.frame_points(frame).display()
                )));
            }
        }
        let blocks = BreakLog::read_through(&layout.break_log(), total)?;
        Ok(PostInput { particles, sim_inputs, sim_frames, total, blocks })
    }
}

/// The pass over the simulation's frames: each frame's breaks, its fragments tracked, its files
/// handed on, and what the USD shot keeps of it.
struct FrameTracking<'a> {
    config: &'a PipelineConfig,
    layout: &'a OutputLayout,
    input: &'a PostInput,
    tracker: FragmentTracker,
    /// With deformed elements, the bonds' state and each element's affine map per frame.
    deformation: Option<ElementDeformation>,
    /// Each frame's fragment count and motions.
    history: Vec<(usize, Vec<RigidMotion>)>,
    /// Each frame's simulation time, seconds.
    sim_times: Vec<f64>,
    /// Each frame's debris emitter points.
    debris: Vec<DebrisFrame>,
    /// The last frame's fragments.
    last: Option<TrackedFrame>,
}

impl<'a> FrameTracking<'a> {
    /// The pass before its first frame.
    fn new(config: &'a PipelineConfig, layout: &'a OutputLayout, input: &'a PostInput) -> FrameTracking<'a> {
        let particles = &input.particles;
        let mass: Vec<f64> =
            particles.volume_m3.iter().map(|v| f64::from(*v) * config.material.density_kg_m3).collect();
        let tracker = FragmentTracker::new(particles, mass);
        let deformation =
            config.post.deformed_elements(config.material.model).then(|| ElementDeformation::new(particles));
        let total = input.total as usize;
        FrameTracking {
            config,
            layout,
            input,
            tracker,
            deformation,
            history: Vec::new(),
            sim_times: Vec::with_capacity(total),
            debris: Vec::new(),
            last: None,
        }
    }

    /// Tracks every frame and writes its files. Each frame's files are written while the next
    /// frame is read and tracked (one frame in flight); a frame counts as done once its files are.
    fn track_all(&mut self, progress: &dyn Progress) -> Result<(), PostError> {
        let total = self.input.total;
        progress.start("post", u64::from(total));
        std::thread::scope(|scope| -> Result<(), PostError> {
            let mut writing = OneInFlight::default();
            let done = |(frame, fragments): (u32, usize)| -> Result<(), PostError> {
                progress.advance(1);
                progress.message(&format!("frame {frame}/{total}: {fragments} fragments"));
                Ok(())
            };
            for frame in 1..=total {
                let (files, fragments) = self.track_frame(frame)?;
                writing.start(scope, (frame, fragments), move || files.write(), done)?;
            }
            writing.wait(done)
        })?;
        progress.finish();
        Ok(())
    }

    /// Breaks frame `frame`'s bonds and tracks its fragments: its files, and its fragment count.
    fn track_frame(&mut self, frame: u32) -> Result<(FrameFiles, usize), PostError> {
        let (config, layout, particles) = (self.config, self.layout, &self.input.particles);
        let events: Vec<BreakEvent> =
            self.input.blocks.iter().filter(|b| b.frame == frame).flat_map(|b| b.events.iter().copied()).collect();
        for event in &events {
            self.tracker.break_bond(event.bond);
            if let Some(deformation) = &mut self.deformation {
                deformation.break_bond(particles, event.bond);
            }
        }
        let points = self.read_points(frame)?;
        let position = [&points.position[0][..], &points.position[1][..], &points.position[2][..]];
        let tracked = self.tracker.track(position, config.post.smoothing_frames);
        let fragments = self.fragment_frame(frame, &points, position, &tracked);
        let frame_debris =
            debris_frame(frame, &events, &particles.bonds, &points, &tracked.fragment_of, self.input.sim_frames.dt_s);
        self.sim_times.push(points.time_s);
        let caches = config.post.point_caches.then(|| PointCaches {
            points_path: layout.fragment_points(frame),
            debris_path: layout.debris_points(frame),
            debris: frame_debris.clone(),
            points,
        });
        let files = FrameFiles { path: layout.fragments(frame), fragments, caches };
        self.debris.push(frame_debris);
        self.history.push((tracked.motion.len(), tracked.motion.clone()));
        let count = tracked.motion.len();
        self.last = Some(tracked);
        Ok((files, count))
    }

    /// The simulation's frame `frame`, checked to belong to the particle file and the settings.
    fn read_points(&self, frame: u32) -> Result<PointFrame, PostError> {
        let (layout, particles) = (self.layout, &self.input.particles);
        let points = PointFrame::read(&layout.frame_points(frame))?;
        if points.inputs != Some(self.input.sim_inputs) {
            return Err(PostError::MissingInput(format!(
                "{}: made from another particle file or other [sim] or [material] settings; run `shatter sim` again",
                layout.frame_points(frame).display()
            )));
        }
        if points.frame != frame {
            let what = format!("holds frame {}, not {frame} (renamed from another frame's name?)", points.frame);
            return Err(FrameFileError::Invalid { path: layout.frame_points(frame), what }.into());
        }
        let dt_s = self.input.sim_frames.dt_s;
        if points.time_s != points.step as f64 * dt_s {
            return Err(PostError::MissingInput(format!(
                "{}: simulated at another time step (step {} at {:e} s, not {dt_s:e} s a step); run `shatter sim` again",
                layout.frame_points(frame).display(),
                points.step,
                points.time_s
            )));
        }
        if points.damage.len() != particles.len() {
            return Err(PostError::MissingInput(format!(
                "{}: {} points, but the particle file has {}; run `shatter sim` again",
                layout.frame_points(frame).display(),
                points.damage.len(),
                particles.len()
            )));
        }
        Ok(points)
    }

    /// The fragments file of frame `frame`, tracked as `tracked` from its `points` (at `position`).
    fn fragment_frame(
        &self,
        frame: u32,
        points: &PointFrame,
        position: [&[f32]; 3],
        tracked: &TrackedFrame,
    ) -> FragmentFrame {
        let config = self.config;
        FragmentFrame {
            meta: FragmentMeta {
                frame,
                step: points.step,
                time_s: points.time_s,
                smoothed: config.post.smoothing_frames > 0.0,
                inputs: Some(digest::post_inputs(self.input.sim_inputs, config)),
            },
            fragment_of: tracked.fragment_of.clone(),
            rotation: tracked.motion.iter().map(|m| m.rotation.as_quat().to_array()).collect(),
            translation_m: tracked.motion.iter().map(|m| m.translation.to_array()).collect(),
            elements: tracked.elements.clone(),
            mass_kg: tracked.mass_kg.clone(),
            element_affine: self
                .deformation
                .as_ref()
                .map(|d| d.element_affine(&self.input.particles, position, &tracked.fragment_of, &tracked.motion)),
        }
    }

    /// Writes the USD shot: one mesh per final piece (the fragments of the `last` frame), moved
    /// with the intact body through the lead-in's frames, then with the fragment that holds it at
    /// each simulation frame.
    fn write_shot_usd(self, last: &TrackedFrame) -> Result<(), PostError> {
        let (config, layout, input) = (self.config, self.layout, self.input);
        let (particles, sim_frames) = (&input.particles, &input.sim_frames);
        let pieces = last.motion.len();
        let meshes = surfaces::piece_surfaces(particles, &last.fragment_of, pieces);
        // the lead-in's frames first (one fragment: every piece moves with the intact body)
        let lead_in_frames = sim_frames.first_shot_frame - 1;
        let elements = element_of_pieces(&last.fragment_of, pieces);
        let mut transforms = Vec::with_capacity((lead_in_frames + input.total) as usize);
        let mut lead_in_times = Vec::with_capacity(lead_in_frames as usize);
        for frame in 1..=lead_in_frames {
            let path = layout.lead_in_fragments(frame);
            if let Some(message) = missing_input(&path, "lead-in") {
                return Err(PostError::MissingInput(message));
            }
            let frame = FragmentFrame::read(&path)?;
            lead_in_times.push(frame.meta.time_s);
            transforms.push(PieceTransform::of_pieces(&frame, &elements));
        }
        let sim_start_s = match config.lead_in {
            None => 0.0,
            Some(_) => LeadIn::read_for(layout).map_err(PostError::MissingInput)?.handoff_time_s,
        };
        transforms.extend(self.history.iter().map(|(count, motions)| {
            (0..pieces as u32)
                .map(|piece| {
                    let m = motions[self.tracker.ancestor(piece, *count) as usize];
                    PieceTransform { rotation: m.rotation, translation: m.translation }
                })
                .collect()
        }));
        let path = layout.usd();
        let width = 0.5 * particles.meta.lambda_m;
        let fps = config.scene.frames_per_second;
        // the shot's frame numbers, and physical m/s to metres per playback second (the lead-in
        // emits no debris)
        let quiet = (1..=lead_in_frames).map(|frame| DebrisFrame { frame, ..DebrisFrame::default() });
        let debris: Vec<DebrisFrame> = quiet.chain(self.debris).collect();
        let speed: Vec<f64> = (1..=lead_in_frames).map(|_| 1.0).chain(sim_frames.speed.iter().copied()).collect();
        // with a lead-in or a timeline the frames have a clock of their own: their physical times
        let clocked = config.lead_in.is_some() || config.timeline.is_some();
        let times: Vec<f64> = lead_in_times.into_iter().chain(self.sim_times.iter().map(|t| sim_start_s + t)).collect();
        let shot = UsdShot {
            meshes: &meshes,
            hidden: &[],
            wholes: &[],
            transforms: &transforms,
            first_frame: 1,
            fps,
            debris: &debris,
            width_m: width,
            velocity_scale: &speed,
            physical_time_s: clocked.then_some(times.as_slice()),
        };
        write_usda(&path, &shot).map_err(|source| PostError::Usd { path, source })
    }
}

/// One frame's files: its fragments file and, when asked for, its point caches.
struct FrameFiles {
    /// The fragments file's path.
    path: PathBuf,
    fragments: FragmentFrame,
    caches: Option<PointCaches>,
}

/// A frame's point caches: the points with their fragment ids, and the debris.
struct PointCaches {
    points_path: PathBuf,
    debris_path: PathBuf,
    /// The simulation's frame.
    points: PointFrame,
    debris: DebrisFrame,
}

impl FrameFiles {
    /// Writes the fragments file, then the point caches.
    fn write(self) -> Result<(), PostError> {
        self.fragments.write(&self.path)?;
        if let Some(caches) = &self.caches {
            write_point_cache(&caches.points_path, &caches.points, &self.fragments.fragment_of)?;
            let (step, time_s) = (caches.points.step, caches.points.time_s);
            debris_points::write_point_cache(&caches.debris_path, &caches.debris, step, time_s)?;
        }
        Ok(())
    }
}

/// A point cache of the fragments folder: positions and fragment ids.
fn write_point_cache(path: &Path, points: &PointFrame, fragment_of: &[u32]) -> Result<(), PlyError> {
    let cache = PointCache {
        comments: vec![
            ("frame".into(), points.frame.to_string()),
            ("step".into(), points.step.to_string()),
            ("time_s".into(), format!("{:e}", points.time_s)),
        ],
        columns: vec![
            ("x".into(), Column::Float(points.position[0].clone())),
            ("y".into(), Column::Float(points.position[1].clone())),
            ("z".into(), Column::Float(points.position[2].clone())),
            ("fragment".into(), Column::Int(fragment_of.iter().map(|f| *f as i32).collect())),
        ],
    };
    cache.write(path)
}
