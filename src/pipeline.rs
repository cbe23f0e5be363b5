//! `shatter run`: every stage in order, for overnight work. A stage whose inputs and settings are
//! unchanged since it last finished is skipped (see [`crate::stamps`]); the simulation resumes
//! from its last checkpoint; rendering records each frame as it is written, so an interrupted run
//! loses at most the frame in flight. Every file is written atomically, so a kill never leaves a
//! corrupt file under a final name. A summary closes the run.

use std::time::Instant;

use shatter_core::config::sim::BackendChoice;
use shatter_core::config::{GeometrySource, TimelineConfig};
use shatter_core::fragments::FragmentFrame;
use shatter_core::shot::Shot;
use shatter_core::sim_frames::SimFrames;
use shatter_core::{OutputLayout, PipelineConfig};

use crate::rigid::RigidArgs;
use crate::sim::SimArgs;
use crate::stamps::{Hasher, Stamps};
use crate::{Failure, Stage, lead_in, post, preprocess, render, rigid, sim};

/// One line of the summary.
struct Done {
    stage: &'static str,
    seconds: f64,
    note: String,
}

/// What the steps of one run share.
struct Run<'a> {
    config: &'a PipelineConfig,
    options: &'a SimArgs,
    layout: OutputLayout,
    stamps: Stamps,
    /// The timeline shapes every stage's frames from the lead-in on, and with [rigid] the
    /// simulation ends at its longest fracture.
    timeline: Option<(&'a TimelineConfig, Option<f64>)>,
}

impl Run<'_> {
    /// How many frames the simulation writes (it follows from the lead-in, when there is one).
    fn sim_frames(&self) -> Result<u32, Failure> {
        Ok(SimFrames::read_span(self.config, &self.layout).map_err(|message| anyhow::anyhow!(message))?.1)
    }

    /// The backend the simulation runs on (part of its hash: GPU and CPU round apart).
    fn sim_backend(&self) -> BackendChoice {
        self.options.backend.map(crate::sim::BackendArg::backend).unwrap_or(self.config.sim.backend)
    }
}

/// One stage as `shatter run` takes it: what its outputs follow from, whether they are there
/// already, and how to make them.
struct Step {
    stage: Stage,
    /// Its name in the summary and its key in the stamps.
    name: &'static str,
    /// Whether the scene has the stage (the lead-in and the follow-through are optional).
    applies: fn(&PipelineConfig) -> bool,
    /// The hash of everything its outputs follow from, given its upstream step's hash.
    hash: fn(&Run, &str) -> String,
    /// Whether its outputs are there for that hash.
    up_to_date: fn(&Run, &str) -> Result<bool, Failure>,
    /// Makes its outputs; the note for the summary.
    make: fn(&mut Run, &str) -> Result<String, Failure>,
    /// The run records the step's stamp after `make` (render records one per frame itself).
    stamped: bool,
}

/// Every stage, in the order data flows.
const STEPS: [Step; 6] = [
    Step {
        stage: Stage::Preprocess,
        name: "preprocess",
        applies: |_| true,
        hash: preprocess_hash,
        up_to_date: |run, hash| Ok(run.stamps.matches("preprocess", hash) && run.layout.particles().is_file()),
        make: |run, _| {
            preprocess::run(run.config)?;
            Ok("particles.shp".into())
        },
        stamped: true,
    },
    // the particles, [lead_in], what it flies into ([sim]) and the frame rate
    Step {
        stage: Stage::LeadIn,
        name: "lead-in",
        applies: |config| config.lead_in.is_some(),
        hash: |run, upstream| {
            Hasher::default()
                .bytes(upstream.as_bytes())
                .json(&run.config.lead_in)
                .json(&run.config.sim)
                .json(&run.config.scene.frames_per_second)
                .json_if(run.timeline.as_ref())
                .finish()
        },
        up_to_date: |run, hash| Ok(run.stamps.matches("lead-in", hash) && run.layout.lead_in().is_file()),
        make: |run, _| {
            lead_in::run(run.config)?;
            Ok(String::new())
        },
        stamped: true,
    },
    // the particles and the simulation settings (the backend too)
    Step {
        stage: Stage::Sim,
        name: "sim",
        applies: |_| true,
        hash: |run, upstream| {
            Hasher::default()
                .bytes(upstream.as_bytes())
                .json(&run.config.sim)
                .json(&run.config.material)
                .json(&run.sim_backend())
                .json_if(run.timeline.as_ref())
                .finish()
        },
        up_to_date: |run, hash| {
            Ok(run.stamps.matches("sim", hash) && run.layout.frame_points(run.sim_frames()?).is_file())
        },
        make: make_sim,
        stamped: true,
    },
    // the simulation's outputs (identified by its settings: it is deterministic) and [post]
    Step {
        stage: Stage::Post,
        name: "post",
        applies: |_| true,
        hash: |run, upstream| {
            let config = run.config;
            Hasher::default()
                .bytes(upstream.as_bytes())
                .json(&config.post)
                .json(&config.scene.frames_per_second)
                .finish()
        },
        up_to_date: |run, hash| {
            Ok(run.stamps.matches("post", hash) && run.layout.fragments(run.sim_frames()?).is_file())
        },
        make: |run, _| {
            post::run(run.config)?;
            Ok(String::new())
        },
        stamped: true,
    },
    // post's outputs, [rigid] and the frame rate
    Step {
        stage: Stage::Rigid,
        name: "rigid",
        applies: |config| config.rigid.is_some(),
        hash: |run, upstream| {
            Hasher::default().bytes(upstream.as_bytes()).json(&run.config.rigid).json_if(run.timeline.as_ref()).finish()
        },
        up_to_date: |run, hash| Ok(run.stamps.matches("rigid", hash) && Shot::of(run.config, &run.layout).is_ok()),
        make: |run, _| {
            rigid::run(run.config, &RigidArgs { resume: run.layout.rigid_checkpoint().is_file() }, run.options)?;
            Ok(String::new())
        },
        stamped: true,
    },
    // frame by frame: the fragments, [render] and the image files it reads
    Step {
        stage: Stage::Render,
        name: "render",
        applies: |_| true,
        hash: |run, upstream| {
            let render = &run.config.render;
            let mut hash = Hasher::default().bytes(upstream.as_bytes()).json(render).json(&run.sim_backend());
            for path in render.environment.iter().chain(render.floor.as_ref().and_then(|f| f.texture.as_ref())) {
                hash = hash.file(path);
            }
            hash.finish()
        },
        up_to_date: |run, hash| Ok(stale_frames(run, hash)?.1.is_empty()),
        make: make_render,
        stamped: false,
    },
];

/// The preprocess hash: the geometry and material settings, and the mesh's contents.
fn preprocess_hash(run: &Run, _: &str) -> String {
    let config = run.config;
    let mut hash = Hasher::default()
        .bytes(env!("CARGO_PKG_VERSION").as_bytes())
        // a new particle format makes the file again (an old one would not read)
        .json(&shatter_core::stage_file::StageKind::Particles.version())
        .json(&(&config.scene.name, config.scene.seed))
        .json(&config.geometry)
        .json(&config.material);
    if let GeometrySource::Mesh(mesh) = &config.geometry.source {
        hash = hash.file(mesh);
    }
    hash.finish()
}

/// Simulates, resuming from the checkpoint when there is one.
fn make_sim(run: &mut Run, _: &str) -> Result<String, Failure> {
    let frames = run.sim_frames()?;
    sim::run_resuming(run.config, run.options)?;
    Ok(format!("{frames} frames"))
}

/// The shot's last frame, and the frames whose image is missing or was made for another hash.
fn stale_frames(run: &Run, hash: &str) -> Result<(u32, Vec<u32>), Failure> {
    let frames = Shot::of(run.config, &run.layout).map_err(|message| anyhow::anyhow!(message))?.last;
    let stale = (1..=frames)
        .filter(|&frame| {
            !(run.stamps.matches(&render_key(frame), hash) && run.layout.render_frame(frame, "exr").is_file())
        })
        .collect();
    Ok((frames, stale))
}

/// A rendered frame's key in the stamps.
fn render_key(frame: u32) -> String {
    format!("render.{frame:04}")
}

/// Renders the stale frames, recording each frame's stamp as it is written.
fn make_render(run: &mut Run, hash: &str) -> Result<String, Failure> {
    let (frames, stale) = stale_frames(run, hash)?;
    let stamps = &mut run.stamps;
    render::render_frames(run.config, &stale, run.options.backend, &mut |frame| {
        stamps.record(&render_key(frame), hash).map_err(|error| error.into())
    })?;
    Ok(format!("{} of {frames} frames", stale.len()))
}

/// Runs the stages of `config` up to `until`, each step's hash following from its upstream's.
pub fn run(config: &PipelineConfig, options: &SimArgs, until: Stage) -> Result<(), Failure> {
    let layout = OutputLayout::of(config);
    let output = layout.root();
    std::fs::create_dir_all(output).map_err(|error| anyhow::anyhow!("{}: cannot create: {error}", output.display()))?;
    let timeline = config
        .timeline
        .as_ref()
        .map(|timeline| (timeline, config.rigid.as_ref().map(|rigid| rigid.max_fracture_duration_s)));
    let mut run = Run { config, options, stamps: Stamps::load(layout.stamps()), layout, timeline };
    let mut done = Vec::new();
    let mut upstream = String::new();
    for step in STEPS.iter().filter(|step| step.stage <= until) {
        if !(step.applies)(config) {
            continue;
        }
        let hash = (step.hash)(&run, &upstream);
        let started = Instant::now();
        if (step.up_to_date)(&run, &hash)? {
            done.push(Done { stage: step.name, seconds: 0.0, note: "up to date".into() });
        } else {
            let note = (step.make)(&mut run, &hash)?;
            if step.stamped {
                run.stamps.record(step.name, &hash)?;
            }
            done.push(Done { stage: step.name, seconds: started.elapsed().as_secs_f64(), note });
        }
        upstream = hash;
    }
    summary(&done, config)
}

/// Prints time per stage, fragments, frames written and where they are.
fn summary(done: &[Done], config: &PipelineConfig) -> Result<(), Failure> {
    let layout = OutputLayout::of(config);
    let output = layout.root();
    println!("\nshatter run: {} ({})", config.scene.name, output.display());
    for line in done {
        let time = if line.note == "up to date" { "skipped".to_string() } else { format!("{:.1} s", line.seconds) };
        println!("  {:<11} {time:>10}  {}", line.stage, line.note);
    }
    let last = Shot::of(config, &layout).map(|shot| shot.fragments(&layout, shot.last));
    if let Ok(frame) = last.map_err(|message| anyhow::anyhow!(message)).and_then(|path| Ok(FragmentFrame::read(&path)?))
    {
        let largest = frame.elements.iter().copied().max().unwrap_or(0);
        println!("  fragments in the last frame: {} (largest {} elements)", frame.fragment_count(), largest);
    }
    if layout.render_dir().is_dir() {
        let first = layout.render_frame(1, "exr");
        println!("  frames: {} ...", first.display());
    }
    Ok(())
}
