//! What the page is shown of an output folder, read as its writer leaves it (never locked): the
//! shot's frames as they land ([`PageFrames`]), each as the message the page draws, and the bonds
//! broken by each frame. The simulation's frames carry the fragments their broken bonds make,
//! found here as post finds them (the same ids), so that they show while the simulation runs;
//! the lead-in's and the follow-through's carry their files' fragments.

use std::sync::{Arc, Mutex, PoisonError};
use std::time::SystemTime;

use shatter_core::OutputLayout;
use shatter_core::debris_points::read_point_cache;
use shatter_core::fragments::FragmentFrame;
use shatter_core::frames::{BreakLog, PointFrame};
use shatter_core::particles::ParticleSet;
use shatter_post::components::FragmentIds;
use shatter_render::frame_review::RenderedFrame;

use super::frame_message::{Fragments, PageFrame};
use super::page_frames::{FrameSource, PageFrames};

/// An output folder being written or written.
#[derive(Debug, Clone)]
pub struct RunFolder {
    layout: OutputLayout,
    density_kg_m3: f64,
    /// What earlier requests read, shared by the clones the server's workers hold.
    cache: Arc<Mutex<Cache>>,
}

/// What a run folder's readers keep between requests.
#[derive(Debug, Default)]
struct Cache {
    /// The handoff, once the follow-through has written a frame.
    handoff: Option<u32>,
    /// The particles' rest positions and masses, once read.
    rest: Option<Arc<Rest>>,
    /// The fragments of the simulation's frames from frame 1 on, as far as counted.
    sim_fragments: Vec<Arc<Fragments>>,
    /// The counter of fragments, after the last of `sim_fragments`.
    ids: Option<FragmentIds>,
    /// The kinetic energy of the simulation's frames from frame 1 on, as far as read, joules.
    kinetic_energy_j: Vec<f64>,
    /// The rendered frame read last: its number, when it was written, and it.
    rendered: Option<(u32, SystemTime, Arc<RenderedFrame>)>,
}

/// The particles at rest.
#[derive(Debug)]
struct Rest {
    position_m: Vec<[f32; 3]>,
    mass_kg: Vec<f64>,
}

/// A frame's particles where they are, and when.
struct Placed {
    time_s: f64,
    position_m: Vec<[f32; 3]>,
}

impl RunFolder {
    /// The folder of `layout`, whose material has density `density_kg_m3`.
    pub fn new(layout: OutputLayout, density_kg_m3: f64) -> RunFolder {
        RunFolder { layout, density_kg_m3, cache: Arc::default() }
    }

    fn cache(&self) -> std::sync::MutexGuard<'_, Cache> {
        self.cache.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The page's frames now.
    pub fn page_frames(&self) -> PageFrames {
        let known = self.cache().handoff;
        let frames = PageFrames::of(&self.layout, known);
        self.cache().handoff = frames.handoff;
        frames
    }

    /// When the simulation's frame `frame` was written, if it is there.
    pub fn frame_written(&self, frame: u32) -> Option<std::time::SystemTime> {
        std::fs::metadata(self.layout.frame_points(frame)).and_then(|meta| meta.modified()).ok()
    }

    /// The bonds broken by each of the simulation's frames, in frame order from frame 2 (the
    /// break log's blocks, as far as they are written whole); empty before the log exists.
    pub fn broken_bonds(&self) -> Vec<u64> {
        let blocks = BreakLog::read(&self.layout.break_log()).unwrap_or_default();
        let mut total = 0u64;
        blocks
            .iter()
            .map(|block| {
                total += block.events.len() as u64;
                total
            })
            .collect()
    }

    /// The kinetic energy of each of the simulation's first `frames` frames, joules (each frame
    /// read once).
    pub fn kinetic_energy_j(&self, frames: u32) -> Result<Vec<f64>, String> {
        let rest = self.rest()?;
        let known = self.cache().kinetic_energy_j.len() as u32;
        for frame in known + 1..=frames {
            let points = self.points(frame)?;
            let speed_squared = |i: usize| (0..3).map(|a| f64::from(points.velocity[a][i]).powi(2)).sum::<f64>();
            let energy = rest.mass_kg.iter().enumerate().map(|(i, m)| 0.5 * m * speed_squared(i)).sum();
            // another request may have read it meanwhile
            let mut cache = self.cache();
            if cache.kinetic_energy_j.len() as u32 == frame - 1 {
                cache.kinetic_energy_j.push(energy);
            }
        }
        let cache = self.cache();
        Ok(cache.kinetic_energy_j[..(frames as usize).min(cache.kinetic_energy_j.len())].to_vec())
    }

    /// The shot's frames of `frames` that are rendered (their EXR written).
    pub fn rendered_frames(&self, frames: &PageFrames) -> Vec<u32> {
        (1..=frames.count()).filter(|&frame| self.layout.render_frame(frame, "exr").is_file()).collect()
    }

    /// Shot frame `frame`'s render, read again only when it was written anew.
    pub fn rendered(&self, frame: u32) -> Result<Arc<RenderedFrame>, String> {
        let path = self.layout.render_frame(frame, "exr");
        let written = std::fs::metadata(&path)
            .and_then(|meta| meta.modified())
            .map_err(|error| format!("{}: {error}", path.display()))?;
        if let Some((number, at, rendered)) = &self.cache().rendered
            && (*number, *at) == (frame, written)
        {
            return Ok(Arc::clone(rendered));
        }
        let rendered = Arc::new(RenderedFrame::read(&path).map_err(|error| error.to_string())?);
        self.cache().rendered = Some((frame, written, Arc::clone(&rendered)));
        Ok(rendered)
    }

    /// The output folder.
    pub fn root(&self) -> &std::path::Path {
        self.layout.root()
    }

    /// Page frame `frame` as the page's message (see [`PageFrame::message`]); an error names
    /// the file that could not be read.
    pub fn frame_message(&self, frames: &PageFrames, frame: u32) -> Result<Vec<u8>, String> {
        let source = frames.locate(frame).ok_or_else(|| format!("frame {frame} is not there yet"))?;
        let page_frame = match source {
            FrameSource::Sim(local) => {
                let points = self.points(local)?;
                let speed_m_s = (0..points.damage.len())
                    .map(|i| (0..3).map(|a| points.velocity[a][i].powi(2)).sum::<f32>().sqrt())
                    .collect();
                PageFrame {
                    frame,
                    source: source.code(),
                    time_s: points.time_s,
                    position_m: positions(&points),
                    damage: points.damage,
                    speed_m_s,
                    fragments: (*self.sim_fragments(local, frames.sim)?).clone(),
                    debris_m: self.debris(local),
                }
            }
            FrameSource::LeadIn(_) | FrameSource::Rigid(_) => self.rigid_frame(frames, frame, source)?,
        };
        Ok(page_frame.message())
    }

    /// A lead-in or follow-through frame: its fragments' motions applied to the rest positions,
    /// speeds from the page frame before (after, for the first), the damage where the
    /// simulation left it (none before it).
    fn rigid_frame(&self, frames: &PageFrames, frame: u32, source: FrameSource) -> Result<PageFrame, String> {
        let fragments = self.fragments_file(source)?;
        let here = self.place(frames, source, &fragments)?;
        let other = if frame > 1 { frame - 1 } else { frame + 1 };
        let speed_m_s = match frames.locate(other) {
            Some(_) => {
                let there = self.placed(frames, other)?;
                let dt_s = (here.time_s - there.time_s).abs().max(f64::MIN_POSITIVE);
                here.position_m.iter().zip(&there.position_m).map(|(p, q)| (distance(p, q) / dt_s) as f32).collect()
            }
            None => vec![0.0; here.position_m.len()],
        };
        let damage = match source {
            FrameSource::Rigid(_) => self.points(frames.sim)?.damage,
            _ => vec![0.0; here.position_m.len()],
        };
        Ok(PageFrame {
            frame,
            source: source.code(),
            time_s: here.time_s,
            position_m: here.position_m,
            damage,
            speed_m_s,
            fragments: Fragments {
                fragment_of: fragments.fragment_of,
                elements: fragments.elements,
                mass_kg: fragments.mass_kg,
            },
            debris_m: Vec::new(),
        })
    }

    /// Page frame `frame`'s particles where it puts them, and its time from the simulation's
    /// start.
    fn placed(&self, frames: &PageFrames, frame: u32) -> Result<Placed, String> {
        let source = frames.locate(frame).ok_or_else(|| format!("frame {frame} is not there yet"))?;
        if let FrameSource::Sim(local) = source {
            let points = self.points(local)?;
            return Ok(Placed { time_s: points.time_s, position_m: positions(&points) });
        }
        self.place(frames, source, &self.fragments_file(source)?)
    }

    /// A lead-in or follow-through frame's particles, its `fragments` file's motions applied to
    /// the rest positions, and its time from the simulation's start.
    fn place(&self, frames: &PageFrames, source: FrameSource, fragments: &FragmentFrame) -> Result<Placed, String> {
        let rest = self.rest()?;
        let position_m = rest
            .position_m
            .iter()
            .zip(&fragments.fragment_of)
            .map(|(x, &f)| {
                let q = glam::DQuat::from_array(fragments.rotation[f as usize].map(f64::from));
                let t = glam::DVec3::from_array(fragments.translation_m[f as usize]);
                (q * glam::DVec3::from_array(x.map(f64::from)) + t).as_vec3().to_array()
            })
            .collect();
        let time_s = match source {
            FrameSource::LeadIn(_) => fragments.meta.time_s - frames.sim_start_s,
            _ => fragments.meta.time_s,
        };
        Ok(Placed { time_s, position_m })
    }

    /// The debris points of the simulation's frame `frame`, once post has written them.
    fn debris(&self, frame: u32) -> Vec<[f32; 3]> {
        read_point_cache(&self.layout.debris_points(frame)).map(|debris| debris.position).unwrap_or_default()
    }

    /// The simulation's frame `frame`.
    fn points(&self, frame: u32) -> Result<PointFrame, String> {
        PointFrame::read(&self.layout.frame_points(frame)).map_err(|error| error.to_string())
    }

    /// The fragments file of a lead-in or follow-through frame.
    fn fragments_file(&self, source: FrameSource) -> Result<FragmentFrame, String> {
        let path = match source {
            FrameSource::LeadIn(local) => self.layout.lead_in_fragments(local),
            FrameSource::Sim(local) => self.layout.fragments(local),
            FrameSource::Rigid(local) => self.layout.rigid_fragments(local),
        };
        FragmentFrame::read(&path).map_err(|error| error.to_string())
    }

    /// The particles at rest, read once.
    fn rest(&self) -> Result<Arc<Rest>, String> {
        if let Some(rest) = &self.cache().rest {
            return Ok(Arc::clone(rest));
        }
        let particles = self.particles()?;
        let mass_kg = particles.volume_m3.iter().map(|v| f64::from(*v) * self.density_kg_m3).collect();
        let rest = Arc::new(Rest { position_m: particles.rest_position_m, mass_kg });
        self.cache().rest = Some(Arc::clone(&rest));
        Ok(rest)
    }

    fn particles(&self) -> Result<ParticleSet, String> {
        ParticleSet::read(&self.layout.particles()).map_err(|error| error.to_string())
    }

    /// The fragments of the simulation's frame `frame`: its break log's bonds broken through
    /// that frame, counted frame by frame from frame 1 as post counts them.
    /// Every frame up to the `through`th that the log holds is counted from the one read of it (a
    /// page asks for the frames in turn).
    fn sim_fragments(&self, frame: u32, through: u32) -> Result<Arc<Fragments>, String> {
        let mut cache = self.cache();
        if let Some(fragments) = cache.sim_fragments.get(frame as usize - 1) {
            return Ok(Arc::clone(fragments));
        }
        drop(cache);
        let rest = self.rest()?;
        let blocks = BreakLog::read(&self.layout.break_log()).map_err(|error| error.to_string())?;
        cache = self.cache();
        if cache.ids.is_none() {
            let particles = self.particles()?;
            cache.ids = Some(FragmentIds::new(&particles));
        }
        loop {
            let next = cache.sim_fragments.len() as u32 + 1;
            // frame 1 is the rest state; the log's blocks end at frames 2 on
            let logged = next == 1 || blocks.iter().any(|block| block.frame == next);
            if next > frame && (next > through || !logged) {
                break;
            }
            if !logged {
                return Err(format!(
                    "{}: frame {next}'s breaks are not written yet",
                    self.layout.break_log().display()
                ));
            }
            let ids = cache.ids.as_mut().expect("made above");
            for block in blocks.iter().filter(|block| block.frame == next) {
                block.events.iter().for_each(|event| ids.break_bond(event.bond));
            }
            ids.next_frame();
            let fragments = Fragments::of(ids.fragment_of().to_vec(), ids.count(), &rest.mass_kg);
            cache.sim_fragments.push(Arc::new(fragments));
        }
        Ok(Arc::clone(&cache.sim_fragments[frame as usize - 1]))
    }
}

/// A point frame's positions, particle by particle.
fn positions(points: &PointFrame) -> Vec<[f32; 3]> {
    (0..points.damage.len()).map(|i| [0, 1, 2].map(|a| points.position[a][i])).collect()
}

fn distance(p: &[f32; 3], q: &[f32; 3]) -> f64 {
    (0..3).map(|a| f64::from(p[a] - q[a]).powi(2)).sum::<f64>().sqrt()
}
