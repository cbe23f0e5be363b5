//! `shatter post` (section 4 "Alignment" of Levine et al.): per frame, the fragments (connected
//! components of the element adjacency graph over intact bonds, by breadth-first search), their
//! stable ids, their mass-weighted rigid motions (Kabsch), optional smoothing, statistics; and the
//! exports: a fragments file per frame, point caches with fragment ids, a USD shot.

pub mod components;
pub mod kabsch;
pub mod smoothing;
pub mod surfaces;
pub mod usd;

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::{DQuat, DVec3};
use shatter_core::fragments::{FragmentFrame, FragmentMeta};
use shatter_core::particles::ParticleSet;
use shatter_core::ply::{Column, PlyError, PointCache};
use shatter_core::stage_file::StageFileError;
use shatter_core::{PipelineConfig, Progress};
use shatter_sim::frames::{BreakLog, FrameFileError, PointFrame};
use shatter_sim::run::{BREAK_LOG_FILE, FRAMES_DIR, PARTICLES_FILE, frame_path};

use self::components::{AdjacencyGraph, StableIds, size_histogram};
use self::kabsch::{Accumulator, RigidMotion};
use self::smoothing::SmoothState;
use self::usd::{PieceTransform, write_usda};

/// The folder `shatter post` writes into, inside the output folder.
pub const FRAGMENTS_DIR: &str = "fragments";
/// The USD shot's name in the fragments folder.
pub const USD_FILE: &str = "fragments.usda";

/// The fragments file of frame `frame`.
pub fn fragments_path(dir: &Path, frame: u32) -> PathBuf {
    dir.join(format!("fragments.{frame:04}.shp"))
}

/// Why post failed.
#[derive(Debug, thiserror::Error)]
pub enum PostError {
    /// The simulation's outputs are missing or do not belong to the particle file (exit code 2).
    #[error("{0}")]
    MissingInput(String),
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
        matches!(self, PostError::MissingInput(_))
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

/// The fragments of one frame with their rigid motions, computed from the intact adjacency and
/// the current positions. Keeps the state that carries over between frames.
#[derive(Debug, Clone)]
pub struct FragmentTracker {
    graph: AdjacencyGraph,
    intact: Vec<bool>,
    /// (bond id, adjacency edge), sorted: which edges a broken bond cuts.
    edges_by_bond: Vec<(u64, u32)>,
    labels: Vec<u32>,
    ids: StableIds,
    /// The fragment each id split from (itself for the first frame's fragments).
    parent: Vec<u32>,
    rotation: Vec<DQuat>,
    smoothed: Vec<SmoothState>,
    rest: Vec<DVec3>,
    mass: Vec<f64>,
}

/// One frame's result.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackedFrame {
    /// The fragment of each element.
    pub fragment_of: Vec<u32>,
    /// The motion of each fragment (smoothed if asked).
    pub motion: Vec<RigidMotion>,
    /// Elements per fragment.
    pub elements: Vec<u32>,
    /// Mass per fragment, kg.
    pub mass_kg: Vec<f64>,
}

impl FragmentTracker {
    /// A tracker for `particles` with element masses `mass_kg`.
    pub fn new(particles: &ParticleSet, mass_kg: Vec<f64>) -> FragmentTracker {
        let graph = AdjacencyGraph::new(particles);
        let mut edges_by_bond: Vec<(u64, u32)> =
            (0..graph.edge_count()).map(|edge| (graph.edge_bond(edge), edge as u32)).collect();
        edges_by_bond.sort_unstable();
        FragmentTracker {
            intact: vec![true; graph.edge_count()],
            graph,
            edges_by_bond,
            labels: Vec::new(),
            ids: StableIds::new(),
            parent: Vec::new(),
            rotation: Vec::new(),
            smoothed: Vec::new(),
            rest: particles.rest_position_m.iter().map(|p| DVec3::from_array(p.map(f64::from))).collect(),
            mass: mass_kg,
        }
    }

    /// Marks the adjacency edges resting on `bond` broken.
    pub fn break_bond(&mut self, bond: u64) {
        let start = self.edges_by_bond.partition_point(|(b, _)| *b < bond);
        for &(b, edge) in &self.edges_by_bond[start..] {
            if b != bond {
                break;
            }
            self.intact[edge as usize] = false;
        }
    }

    /// The id chain: the fragment that piece id `id` belonged to when there were `count` fragments.
    pub fn ancestor(&self, mut id: u32, count: usize) -> u32 {
        while id as usize >= count {
            id = self.parent[id as usize];
        }
        id
    }

    /// Fragments and motions for current positions `position` (x, y, z arrays);
    /// `smoothing_frames` > 0 smooths the motions.
    pub fn track(&mut self, position: [&[f32]; 3], smoothing_frames: f64) -> TrackedFrame {
        let components = self.graph.components(&self.intact, &mut self.labels);
        let first_frame = self.parent.is_empty();
        let parents = self.ids.assign(&self.labels, components);
        let count = self.ids.count();
        if first_frame {
            self.parent = (0..count as u32).collect();
            self.rotation = vec![DQuat::IDENTITY; count];
        } else {
            for &p in &parents {
                self.parent.push(p);
                self.rotation.push(self.rotation[p as usize]);
            }
        }
        let fragment_of = self.ids.fragment_of().to_vec();
        let current =
            |i: usize| DVec3::new(f64::from(position[0][i]), f64::from(position[1][i]), f64::from(position[2][i]));
        // Kabsch per fragment, about each fragment's first element to keep the sums small.
        let mut reference = vec![usize::MAX; count];
        let mut accumulators = vec![Accumulator::default(); count];
        let mut elements = vec![0u32; count];
        let mut mass_kg = vec![0.0f64; count];
        for (i, &f) in fragment_of.iter().enumerate() {
            let f = f as usize;
            if reference[f] == usize::MAX {
                reference[f] = i;
            }
            let r = reference[f];
            accumulators[f].add(self.mass[i], self.rest[i] - self.rest[r], current(i) - current(r));
            elements[f] += 1;
            mass_kg[f] += self.mass[i];
        }
        let mut motion: Vec<RigidMotion> = (0..count)
            .map(|f| {
                let local = accumulators[f].solve(self.rotation[f]);
                let r = reference[f];
                // x - x_r = R (X - X_r) + t'  =>  x = R X + (t' + x_r - R X_r)
                let translation = local.translation + current(r) - local.rotation * self.rest[r];
                RigidMotion { rotation: local.rotation, translation }
            })
            .collect();
        for (f, m) in motion.iter().enumerate() {
            self.rotation[f] = m.rotation;
        }
        if smoothing_frames > 0.0 {
            let rest_centre = fragment_centres(&fragment_of, &self.rest, &self.mass, &mass_kg);
            if self.smoothed.is_empty() {
                self.smoothed = (0..count)
                    .map(|f| {
                        SmoothState::at(motion[f].rotation * rest_centre[f] + motion[f].translation, motion[f].rotation)
                    })
                    .collect();
            } else {
                for f in self.smoothed.len()..count {
                    let parent = &self.smoothed[self.parent[f] as usize];
                    let smoothed_centre = parent.rotation * rest_centre[f]
                        + (parent.centre - parent.rotation * rest_centre[self.parent[f] as usize]);
                    self.smoothed.push(parent.part_at(smoothed_centre));
                }
                for f in 0..count {
                    let target = motion[f].rotation * rest_centre[f] + motion[f].translation;
                    self.smoothed[f].follow(target, motion[f].rotation, smoothing_frames);
                }
            }
            for f in 0..count {
                let state = &self.smoothed[f];
                motion[f] = RigidMotion {
                    rotation: state.rotation,
                    translation: state.centre - state.rotation * rest_centre[f],
                };
            }
        }
        TrackedFrame { fragment_of, motion, elements, mass_kg }
    }
}

/// Mass-weighted rest centres of the fragments.
fn fragment_centres(fragment_of: &[u32], rest: &[DVec3], mass: &[f64], fragment_mass: &[f64]) -> Vec<DVec3> {
    let mut centres = vec![DVec3::ZERO; fragment_mass.len()];
    for (i, &f) in fragment_of.iter().enumerate() {
        centres[f as usize] += mass[i] * rest[i];
    }
    for (centre, m) in centres.iter_mut().zip(fragment_mass) {
        *centre /= *m;
    }
    centres
}

/// Runs the post stage of `config` on its simulation outputs.
pub fn run(config: &PipelineConfig, progress: &dyn Progress) -> Result<PostReport, PostError> {
    let started = Instant::now();
    let output = config.output_dir();
    let particles = ParticleSet::read(&output.join(PARTICLES_FILE))?;
    let frames_dir = output.join(FRAMES_DIR);
    let total = config.sim.frames;
    for frame in 1..=total {
        if !frame_path(&frames_dir, frame).is_file() {
            return Err(PostError::MissingInput(format!(
                "{}: missing (sim.frames = {total}); run `shatter sim` first",
                frame_path(&frames_dir, frame).display()
            )));
        }
    }
    let blocks = BreakLog::read(&frames_dir.join(BREAK_LOG_FILE))?;
    let out_dir = output.join(FRAGMENTS_DIR);
    std::fs::create_dir_all(&out_dir).map_err(|source| PostError::Usd { path: out_dir.clone(), source })?;
    let mass: Vec<f64> = particles.volume_m3.iter().map(|v| f64::from(*v) * config.material.density_kg_m3).collect();
    let mut tracker = FragmentTracker::new(&particles, mass);
    let smoothing = config.post.smoothing_frames;
    let mut history: Vec<(usize, Vec<RigidMotion>)> = Vec::new();
    let mut last = None;
    progress.start("post", u64::from(total));
    for frame in 1..=total {
        for block in blocks.iter().filter(|b| b.frame == frame) {
            for event in &block.events {
                tracker.break_bond(event.bond);
            }
        }
        let points = PointFrame::read(&frame_path(&frames_dir, frame))?;
        if points.damage.len() != particles.len() {
            return Err(PostError::MissingInput(format!(
                "{}: {} points, but the particle file has {}; run `shatter sim` again",
                frame_path(&frames_dir, frame).display(),
                points.damage.len(),
                particles.len()
            )));
        }
        let position = [&points.position[0][..], &points.position[1][..], &points.position[2][..]];
        let tracked = tracker.track(position, smoothing);
        let fragments = FragmentFrame {
            meta: FragmentMeta { frame, step: points.step, time_s: points.time_s, smoothed: smoothing > 0.0 },
            fragment_of: tracked.fragment_of.clone(),
            rotation: tracked.motion.iter().map(|m| m.rotation.as_quat().to_array()).collect(),
            translation_m: tracked.motion.iter().map(|m| m.translation.to_array()).collect(),
            elements: tracked.elements.clone(),
            mass_kg: tracked.mass_kg.clone(),
        };
        fragments.write(&fragments_path(&out_dir, frame))?;
        if config.post.point_caches {
            write_point_cache(&out_dir, &points, &tracked.fragment_of)?;
        }
        history.push((tracked.motion.len(), tracked.motion.clone()));
        progress.advance(1);
        progress.message(&format!("frame {frame}/{total}: {} fragments", tracked.motion.len()));
        last = Some(tracked);
    }
    progress.finish();
    let last = last.ok_or_else(|| PostError::MissingInput("sim.frames is 0".into()))?;
    if config.post.usd {
        let pieces = last.motion.len();
        let meshes = surfaces::piece_surfaces(&particles, &last.fragment_of, pieces);
        let transforms: Vec<Vec<PieceTransform>> = history
            .iter()
            .map(|(count, motions)| {
                (0..pieces as u32)
                    .map(|piece| {
                        let m = motions[tracker.ancestor(piece, *count) as usize];
                        PieceTransform { rotation: m.rotation, translation: m.translation }
                    })
                    .collect()
            })
            .collect();
        let path = out_dir.join(USD_FILE);
        write_usda(&path, &meshes, &transforms, 1, config.scene.frames_per_second)
            .map_err(|source| PostError::Usd { path, source })?;
    }
    Ok(PostReport {
        frames: total,
        fragments: last.motion.len(),
        size_histogram: size_histogram(&last.elements),
        folder: out_dir,
        wall_s: started.elapsed().as_secs_f64(),
    })
}

/// `points.####.ply` in the fragments folder: positions and fragment ids.
fn write_point_cache(dir: &Path, points: &PointFrame, fragment_of: &[u32]) -> Result<(), PlyError> {
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
    cache.write(&dir.join(format!("points.{:04}.ply", points.frame)))
}
