//! `shatter render`: the fragments of each frame ray traced to multi-layer EXR (and PNG previews),
//! frame ranges for render farms, progress with ETA.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use glam::DVec3;
use shatter_core::config::render::{CubeSurface, RenderConfig, TextureFilter};
use shatter_core::config::sim::BackendChoice;
use shatter_core::digest;
use shatter_core::fragments::FragmentFrame;
use shatter_core::in_flight::OneInFlight;
use shatter_core::layout::missing_input;
use shatter_core::memory::{self, MemoryError, SetSize};
use shatter_core::particles::ParticleSet;
use shatter_core::shot::{Shot, Source};
use shatter_core::stage_file::StageFileError;
use shatter_core::{OutputLayout, PipelineConfig, Progress};
use shatter_gpu::{AdapterChoice, GpuContext, GpuError};

use crate::camera::{Camera, Lens};
use crate::cryptomatte::{Matte, fragment_matte, material_matte};
use crate::element_index::REST_TREE_MIN_ELEMENTS;
use crate::element_kdtree::Aabb;
use crate::floor_albedos::FloorAlbedos;
use crate::gpu_trace::GpuTracer;
use crate::image_loop::{Rendered, render_keeping};
use crate::image_out::{FrameHeader, FrameLayers, HeaderLens, ImageError, write_exr, write_png};
use crate::integrator::Pixel;
use crate::lighting::{EnvironmentMap, LightingError, key_light, sh_project};
use crate::materials::{FloorLook, FloorTexels, Look};
use crate::motion::{Motions, motion_vectors};
use crate::placing::SceneBasis;
use crate::scene_geometry::SceneGeometry;
use crate::shutter::{FramePoses, SceneMotion};
use crate::texture_filter::MipChain;

/// Why rendering failed.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Bad input the user must fix: frames out of range, missing fragments, a bad texture (exit 2).
    #[error("{0}")]
    Input(String),
    /// The environment map is unusable (exit 2).
    #[error(transparent)]
    Lighting(#[from] LightingError),
    /// The stage would not fit in memory (exit code 2).
    #[error(transparent)]
    Memory(#[from] MemoryError),
    /// A stage file could not be read.
    #[error(transparent)]
    StageFile(#[from] StageFileError),
    /// An image could not be written.
    #[error(transparent)]
    Image(#[from] ImageError),
    /// The GPU failed (or `--backend gpu` found none).
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The caller's work after a frame failed.
    #[error("after frame {frame}: {source}")]
    AfterFrame {
        /// The frame just written.
        frame: u32,
        /// What failed.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

/// Called after each frame is written (e.g. to record that it is up to date).
pub type AfterFrame<'a> = &'a mut dyn FnMut(u32) -> Result<(), Box<dyn std::error::Error + Send + Sync>>;

impl RenderError {
    /// True when the user must change the input.
    pub fn is_bad_input(&self) -> bool {
        matches!(self, RenderError::Input(_) | RenderError::Lighting(_) | RenderError::Memory(_))
    }
}

/// What a render run did.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderReport {
    /// Frames written.
    pub frames: Vec<u32>,
    /// Image size.
    pub resolution: [u32; 2],
    /// Samples per pixel.
    pub samples: u32,
    /// Primary rays per second over the run.
    pub rays_per_second: f64,
    /// Where the frames are.
    pub folder: PathBuf,
    /// Wall time, seconds.
    pub wall_s: f64,
    /// The device that traced: "CPU" or the GPU adapter.
    pub device: String,
}

/// Where the rays are traced.
enum Tracer {
    /// The CPU, with the floor albedos it keeps from frame to frame.
    Cpu(Mutex<FloorAlbedos>),
    Gpu(Box<(GpuContext, GpuTracer)>),
}

impl Tracer {
    /// The tracer `backend` asks for: `auto` takes a hardware GPU when there is one.
    fn new(backend: BackendChoice) -> Result<Tracer, RenderError> {
        let gpu = |context: GpuContext| -> Result<Tracer, RenderError> {
            let tracer = GpuTracer::new(&context)?;
            Ok(Tracer::Gpu(Box::new((context, tracer))))
        };
        match backend {
            BackendChoice::Cpu => Ok(Tracer::Cpu(Mutex::default())),
            BackendChoice::Gpu => gpu(GpuContext::new(AdapterChoice::from_env())?),
            BackendChoice::Auto => match GpuContext::new(AdapterChoice::from_env()) {
                Ok(context) => gpu(context),
                Err(_) => Ok(Tracer::Cpu(Mutex::default())),
            },
        }
    }

    fn describe(&self) -> String {
        match self {
            Tracer::Cpu(_) => format!("CPU ({} threads)", rayon::current_num_threads()),
            Tracer::Gpu(gpu) => gpu.0.describe(),
        }
    }

    fn render(
        &self,
        scene: &SceneGeometry,
        look: &Look,
        camera: &Camera,
        samples: u32,
    ) -> Result<Rendered, RenderError> {
        match self {
            Tracer::Cpu(floor) => {
                let mut floor = floor.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                Ok(render_keeping(scene, look, camera, samples, Some(&mut floor)))
            }
            Tracer::Gpu(gpu) => Ok(gpu.1.render(&gpu.0, scene, look, camera, samples)?),
        }
    }
}

/// Parses a frame list such as `1-240`, `7` or `1-10,20,30-32` against frames 1..=`last`.
pub fn parse_frames(text: &str, last: u32) -> Result<Vec<u32>, String> {
    let mut frames = Vec::new();
    for part in text.split(',').map(str::trim) {
        let number =
            |s: &str| s.trim().parse::<u32>().map_err(|_| format!("--frames {text:?}: {s:?} is not a frame number"));
        let (first, end) = match part.split_once('-') {
            Some((a, b)) => (number(a)?, number(b)?),
            None => (number(part)?, number(part)?),
        };
        if first == 0 || end < first || end > last {
            return Err(format!("--frames {text:?}: {part} is not within frames 1-{last} (the shot's frames)"));
        }
        frames.extend(first..=end);
    }
    frames.sort_unstable();
    frames.dedup();
    Ok(frames)
}

/// The look of a scene from its config.
pub fn look(render: &RenderConfig) -> Result<Look, RenderError> {
    let environment = match &render.environment {
        Some(path) => EnvironmentMap::load(path, render.environment_intensity as f32)?,
        None => EnvironmentMap::constant([render.environment_intensity as f32; 3]),
    };
    let floor = match &render.floor {
        None => None,
        Some(floor) => {
            let (size, texels) = match &floor.texture {
                Some(path) => load_texture(path)?,
                None => ([1, 1], FloorTexels::Linear(vec![floor.albedo.map(|v| v as f32)])),
            };
            let mut look =
                FloorLook { height: floor.height_m as f32, tile: floor.tile_size_m as f32, size, texels, mips: None };
            if render.texture_filter == TextureFilter::Anisotropic && floor.texture.is_some() {
                look.mips = Some(MipChain::of(&look));
            }
            Some(look)
        }
    };
    let material = &render.material;
    Ok(Look {
        sh: sh_project(&environment),
        key: key_light(&environment),
        environment,
        show_environment: render.show_environment,
        ior: material.glass_ior as f32,
        absorption: material.glass_absorption_per_m.map(|v| v as f32),
        albedo: material.albedo.map(|v| v as f32),
        fracture_albedo: material.fracture_albedo.unwrap_or(material.albedo).map(|v| v as f32),
        specular: material.specular as f32,
        shininess: material.shininess as f32,
        floor,
        max_bounces: render.max_bounces,
        glass_split_events: render.glass_split_events,
        opaque_cubes: material.cubes == CubeSurface::Opaque,
    })
}

/// An sRGB texture's size and texels.
fn load_texture(path: &Path) -> Result<([usize; 2], FloorTexels), RenderError> {
    let image = image::open(path)
        .map_err(|error| RenderError::Input(format!("render.floor.texture: {}: cannot read: {error}", path.display())))?
        .into_rgb8();
    let texels = image.pixels().map(|p| p.0).collect();
    Ok(([image.width() as usize, image.height() as usize], FloorTexels::srgb8(texels)))
}

/// The camera of a scene: configured, or framing the body's rest bounds; with
/// `render.camera.f_stop`, a thin lens focused at `focus_distance_m`, or on the body's rest
/// centre.
pub fn camera(render: &RenderConfig, particles: &ParticleSet) -> Camera {
    let [width, height] = render.resolution;
    let bounds = particles.rest_position_m.iter().fold(Aabb::EMPTY, |b, p| b.union(&Aabb { min: *p, max: *p }));
    let config = &render.camera;
    let centre = DVec3::from_array([0, 1, 2].map(|a| f64::from(bounds.min[a] + bounds.max[a]) * 0.5));
    let mut camera = match config.position_m {
        Some(position) => Camera::look_at(
            DVec3::from_array(position),
            config.look_at_m.map_or(centre, DVec3::from_array),
            DVec3::from_array(config.up),
            config.fov_deg,
            width,
            height,
        ),
        None => Camera::framing(&bounds, config.fov_deg, width, height),
    };
    camera.lens = config.f_stop.map(|f_stop| {
        let focus_m = config.focus_distance_m.unwrap_or_else(|| body_distance_m(&camera, centre));
        Lens::of(f_stop, focus_m, config.fov_deg, config.sensor_height_mm)
    });
    camera
}

/// The distance of `point` along `camera`'s view (at least a millimetre).
fn body_distance_m(camera: &Camera, point: DVec3) -> f64 {
    let v = |a: [f32; 3]| DVec3::from_array(a.map(f64::from));
    (point - v(camera.origin)).dot(v(camera.forward)).max(1e-3)
}

/// The lens a frame's header names: f-number, focus distance (metres), focal length and sensor
/// height (millimetres).
fn header_lens(render: &RenderConfig, camera: &Camera) -> Option<HeaderLens> {
    let (f_stop, lens) = (render.camera.f_stop?, camera.lens?);
    let focus_m = f64::from(lens.focus_distance_m);
    let focal_length_mm = 1e3 * Lens::focal_length_m(focus_m, render.camera.fov_deg, render.camera.sensor_height_mm);
    Some(HeaderLens { f_stop, focus_m, focal_length_mm, sensor_height_mm: render.camera.sensor_height_mm })
}

/// Shot frame `frame`'s fragments (the lead-in's, post's, or the follow-through's: see
/// [`Shot`]), checked against the particle file (`elements`) and the inputs each stage's files
/// must have been made from (`inputs`: the simulation's, post's, the follow-through's); None for
/// frame 1 when post has not written it (the rest state).
fn read_fragments(
    layout: &OutputLayout,
    shot: &Shot,
    frame: u32,
    elements: usize,
    inputs: [u32; 3],
) -> Result<Option<FragmentFrame>, RenderError> {
    let path = shot.fragments(layout, frame);
    let (source, local) = shot.locate(frame);
    let command = source.command();
    if !path.is_file() {
        if frame == 1 && source == Source::Post {
            return Ok(None);
        }
        return Err(RenderError::Input(format!("{}: missing; run `shatter {command}` first", path.display())));
    }
    let again = match source {
        Source::Post => "`shatter sim` and `shatter post`".to_string(),
        other => format!("`shatter {}`", other.command()),
    };
    let fragments = FragmentFrame::read(&path)?;
    if fragments.fragment_of.len() != elements {
        return Err(RenderError::Input(format!(
            "{}: {} elements, but the particle file has {elements}; run {again} again",
            path.display(),
            fragments.fragment_of.len(),
        )));
    }
    let (expected, what) = match source {
        Source::LeadIn => (inputs[0], "particle file, [lead_in], [sim] or [material] settings"),
        Source::Post => (inputs[1], "particle file, [sim], [material] or [post] settings"),
        Source::Rigid => (inputs[2], "[rigid] settings, frame rate or earlier stages"),
    };
    if fragments.meta.inputs != Some(expected) {
        return Err(RenderError::Input(format!(
            "{}: made from other inputs ({what}); run {again} again",
            path.display()
        )));
    }
    if fragments.meta.frame != local {
        let what = format!("holds frame {}, not {local} (renamed from another frame's name?)", fragments.meta.frame);
        return Err(StageFileError::Malformed { path, what }.into());
    }
    Ok(Some(fragments))
}

/// One frame's finished image, to be written as its EXR (and PNG preview).
struct FrameFiles {
    /// Width and height, pixels.
    size: [usize; 2],
    pixels: Vec<Pixel>,
    motion: Vec<[f32; 4]>,
    mattes: [Matte; 2],
    /// Write the denoising passes.
    denoising: bool,
    header: FrameHeader,
    /// The EXR's path.
    exr: PathBuf,
    /// The preview's path and exposure, stops.
    preview: Option<(PathBuf, f32)>,
}

impl FrameFiles {
    /// Writes the EXR, then the preview.
    fn write(self) -> Result<(), ImageError> {
        let [width, height] = self.size;
        let layers =
            FrameLayers { pixels: &self.pixels, motion: &self.motion, mattes: &self.mattes, denoising: self.denoising };
        write_exr(&self.exr, width, height, &layers, &self.header)?;
        if let Some((path, exposure)) = &self.preview {
            write_png(path, width, height, &self.pixels, *exposure)?;
        }
        Ok(())
    }
}

/// Renders the frames `frames` (all of the shot's when None) of `config` on `backend` (the
/// config's `render.backend` when None), calling `after_frame` when each frame is written.
pub fn run_render(
    config: &PipelineConfig,
    frames: Option<&[u32]>,
    backend: Option<BackendChoice>,
    progress: &dyn Progress,
    after_frame: AfterFrame,
) -> Result<RenderReport, RenderError> {
    let started = Instant::now();
    let render_config = &config.render;
    let job = RenderJob::open(config, frames, backend)?;
    let [width, height] = render_config.resolution;
    let samples = render_config.samples_per_pixel;
    progress.start("render", job.frames.len() as u64);
    // What every frame shares, with one k-d tree of the elements at rest for the CPU tracer
    // (see element_index).
    let particles = &job.particles;
    let basis =
        SceneBasis::new(particles, matches!(job.tracer, Tracer::Cpu(_)) && particles.len() >= REST_TREE_MIN_ELEMENTS);
    // Each frame's files are written while the next frame is traced (one frame in flight); a
    // frame counts as done (`after_frame`, progress) once its files are.
    std::thread::scope(|scope| -> Result<(), RenderError> {
        let mut writing = OneInFlight::default();
        let mut done = |frame: u32| {
            after_frame(frame).map_err(|source| RenderError::AfterFrame { frame, source })?;
            progress.advance(1);
            progress.message(&format!("frame {frame}"));
            Ok::<(), RenderError>(())
        };
        let traced =
            job.trace_frames(&basis, &mut |frame, files| writing.start(scope, frame, move || files.write(), &mut done));
        let written = writing.wait(&mut done);
        traced.and(written)
    })?;
    progress.finish();
    let wall_s = started.elapsed().as_secs_f64();
    let rays = f64::from(width) * f64::from(height) * f64::from(samples) * job.frames.len() as f64;
    let device = job.tracer.describe();
    Ok(RenderReport {
        frames: job.frames,
        resolution: render_config.resolution,
        samples,
        rays_per_second: rays / wall_s.max(1e-9),
        folder: job.folder,
        wall_s,
        device,
    })
}

/// A render run's inputs: the frames to render, the particles, the look, the camera and the
/// tracer.
struct RenderJob<'a> {
    config: &'a PipelineConfig,
    layout: OutputLayout,
    shot: Shot,
    frames: Vec<u32>,
    particles: ParticleSet,
    /// The inputs each stage's fragments must have been made from (see [`read_fragments`]).
    inputs: [u32; 3],
    look: Look,
    camera: Camera,
    tracer: Tracer,
    /// Where the frames go (made here).
    folder: PathBuf,
}

impl<'a> RenderJob<'a> {
    /// Reads the particle file and sets up the render of `frames` (all of the shot's when None)
    /// on `backend` (the config's when None).
    fn open(
        config: &'a PipelineConfig,
        frames: Option<&[u32]>,
        backend: Option<BackendChoice>,
    ) -> Result<RenderJob<'a>, RenderError> {
        let render_config = &config.render;
        let layout = OutputLayout::of(config);
        let shot = Shot::of(config, &layout).map_err(RenderError::Input)?;
        let frames: Vec<u32> = match frames {
            Some(frames) => frames.to_vec(),
            None => (1..=shot.last).collect(),
        };
        if let Some(message) = missing_input(&layout.particles(), "preprocess") {
            return Err(RenderError::Input(message));
        }
        memory::check(&memory::load_need(&layout.particles()))?;
        let (particles, particles_checksum) = ParticleSet::read_with_checksum(&layout.particles())?;
        memory::check(&memory::render_need(&SetSize::of(&particles), render_config.resolution))?;
        let post_inputs = digest::post_inputs(digest::sim_inputs(particles_checksum, config), config);
        let sim_inputs = digest::sim_inputs(particles_checksum, config);
        let inputs = [sim_inputs, post_inputs, digest::rigid_inputs(post_inputs, config)];
        let look = look(render_config)?;
        let camera = camera(render_config, &particles);
        let tracer = Tracer::new(backend.unwrap_or(render_config.backend))?;
        let folder = layout.render_dir();
        std::fs::create_dir_all(&folder).map_err(|source| ImageError::Io { path: folder.clone(), source })?;
        Ok(RenderJob { config, layout, shot, frames, particles, inputs, look, camera, tracer, folder })
    }

    /// Traces each frame on `basis`, handing its files to `write`. Each frame needs its
    /// neighbours' motions too; frames already read are kept while needed.
    fn trace_frames(
        &self,
        basis: &SceneBasis,
        write: &mut dyn FnMut(u32, FrameFiles) -> Result<(), RenderError>,
    ) -> Result<(), RenderError> {
        let last = self.shot.last;
        let mut loaded: BTreeMap<u32, Option<FragmentFrame>> = BTreeMap::new();
        for &frame in &self.frames {
            let neighbours = frame.saturating_sub(1).max(1)..=(frame + 1).min(last);
            loaded.retain(|f, _| neighbours.contains(f));
            for f in neighbours {
                if let std::collections::btree_map::Entry::Vacant(slot) = loaded.entry(f) {
                    slot.insert(read_fragments(&self.layout, &self.shot, f, self.particles.len(), self.inputs)?);
                }
            }
            let fragments = loaded[&frame].as_ref();
            let previous = (frame > 1).then(|| loaded[&(frame - 1)].as_ref());
            let next = (frame < last).then(|| loaded[&(frame + 1)].as_ref());
            write(frame, self.trace_frame(basis, frame, fragments, previous, next)?)?;
        }
        Ok(())
    }

    /// Traces frame `frame` (its fragments, and its neighbours' for the motion vectors): its
    /// files.
    fn trace_frame(
        &self,
        basis: &SceneBasis,
        frame: u32,
        fragments: Motions,
        previous: Option<Motions>,
        next: Option<Motions>,
    ) -> Result<FrameFiles, RenderError> {
        let (config, render_config, camera) = (self.config, &self.config.render, &self.camera);
        let poses = FramePoses { current: fragments, previous, next };
        let motion = SceneMotion::new(&self.particles.rest_position_m, poses, render_config.shutter);
        let scene = SceneGeometry::build_with(&self.particles, fragments, basis, motion);
        let rendered = self.tracer.render(&scene, &self.look, camera, render_config.samples_per_pixel)?;
        let motion = motion_vectors(camera, &rendered.pixels, fragments, previous, next);
        let ids: Vec<u32> = (0..fragments.map_or(1, |f| f.fragment_count() as u32)).collect();
        let mattes = [fragment_matte(&rendered.mattes, &ids), material_matte(&rendered.mattes)];
        let header = FrameHeader {
            comment: format!("shatter render: scene {}, frame {frame}", config.scene.name),
            world_to_camera: camera.world_to_camera(),
            world_to_ndc: camera.world_to_ndc(),
            frames_per_second: config.scene.frames_per_second,
            simulation_time_s: self.shot.time_s(frame, fragments.map_or(0.0, |f| f.meta.time_s)),
            shutter_s: render_config.shutter / config.scene.frames_per_second,
            lens: header_lens(render_config, camera),
        };
        let preview = render_config
            .previews
            .then(|| (self.layout.render_frame(frame, "png"), render_config.preview_exposure_stops as f32));
        let exr = self.layout.render_frame(frame, "exr");
        let [width, height] = render_config.resolution;
        Ok(FrameFiles {
            size: [width as usize, height as usize],
            pixels: rendered.pixels,
            motion,
            mattes,
            denoising: render_config.denoising_passes,
            header,
            exr,
            preview,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_lists_parse_like_a_render_farm_writes_them() {
        assert_eq!(parse_frames("1-5", 48).expect("range"), vec![1, 2, 3, 4, 5]);
        assert_eq!(parse_frames("7", 48).expect("one"), vec![7]);
        assert_eq!(parse_frames("1-3, 10,2", 48).expect("list"), vec![1, 2, 3, 10]);
        assert!(parse_frames("0-3", 48).expect_err("zero").contains("not within frames 1-48"));
        assert!(parse_frames("40-50", 48).is_err());
        assert!(parse_frames("5-3", 48).is_err());
        assert!(parse_frames("a-b", 48).expect_err("text").contains("not a frame number"));
    }
}
