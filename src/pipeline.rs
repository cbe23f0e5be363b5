//! `shatter run`: every stage in order, for overnight work. A stage whose inputs and settings are
//! unchanged since it last finished is skipped (see [`crate::stamps`]); the simulation resumes
//! from its last checkpoint; rendering records each frame as it is written, so an interrupted run
//! loses at most the frame in flight. Every file is written atomically, so a kill never leaves a
//! corrupt file under a final name. A summary closes the run.

use std::time::Instant;

use shatter_core::config::GeometrySource;
use shatter_core::fragments::FragmentFrame;
use shatter_core::shot::Shot;
use shatter_core::sim_frames::SimFrames;
use shatter_core::{OutputLayout, PipelineConfig};
use shatter_sim::sim_driver::RunError;

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

/// Runs the stages of `config` up to `until`.
pub fn run(config: &PipelineConfig, options: &SimArgs, until: Stage) -> Result<(), Failure> {
    let layout = OutputLayout::of(config);
    let output = layout.root();
    std::fs::create_dir_all(output).map_err(|error| anyhow::anyhow!("{}: cannot create: {error}", output.display()))?;
    let mut stamps = Stamps::load(layout.stamps());
    let mut done = Vec::new();
    // the timeline shapes every stage's frames from the lead-in on, and with [rigid] the
    // simulation ends at its longest fracture
    let timeline = config
        .timeline
        .as_ref()
        .map(|timeline| (timeline, config.rigid.as_ref().map(|rigid| rigid.max_fracture_duration_s)));

    // preprocess: the geometry and material settings, and the mesh's contents
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
    let preprocess_hash = hash.finish();
    let started = Instant::now();
    if stamps.matches("preprocess", &preprocess_hash) && layout.particles().is_file() {
        done.push(Done { stage: "preprocess", seconds: 0.0, note: "up to date".into() });
    } else {
        preprocess::run(config)?;
        stamps.record("preprocess", &preprocess_hash)?;
        done.push(Done { stage: "preprocess", seconds: started.elapsed().as_secs_f64(), note: "particles.shp".into() });
    }
    if until < Stage::LeadIn {
        return summary(&done, config);
    }

    // lead-in (with [lead_in] only): the particles, [lead_in], what it flies into ([sim]) and
    // the frame rate
    let mut upstream = preprocess_hash.clone();
    if config.lead_in.is_some() {
        let lead_in_hash = Hasher::default()
            .bytes(preprocess_hash.as_bytes())
            .json(&config.lead_in)
            .json(&config.sim)
            .json(&config.scene.frames_per_second)
            .json_if(timeline.as_ref())
            .finish();
        let started = Instant::now();
        if stamps.matches("lead-in", &lead_in_hash) && layout.lead_in().is_file() {
            done.push(Done { stage: "lead-in", seconds: 0.0, note: "up to date".into() });
        } else {
            lead_in::run(config)?;
            stamps.record("lead-in", &lead_in_hash)?;
            done.push(Done { stage: "lead-in", seconds: started.elapsed().as_secs_f64(), note: String::new() });
        }
        upstream = lead_in_hash;
    }
    if until < Stage::Sim {
        return summary(&done, config);
    }

    // sim: the particles and the simulation settings (the backend too: GPU and CPU round apart)
    let backend = options.backend.map(crate::sim::BackendArg::backend).unwrap_or(config.sim.backend);
    let sim_hash = Hasher::default()
        .bytes(upstream.as_bytes())
        .json(&config.sim)
        .json(&config.material)
        .json(&backend)
        .json_if(timeline.as_ref())
        .finish();
    let frames = SimFrames::read(config, &layout).map_err(|message| anyhow::anyhow!(message))?.count();
    let started = Instant::now();
    if stamps.matches("sim", &sim_hash) && layout.frame_points(frames).is_file() {
        done.push(Done { stage: "sim", seconds: 0.0, note: "up to date".into() });
    } else {
        let resume = layout.checkpoint().is_file();
        let resumed = SimArgs { resume, ..options.clone() };
        match sim::run(config, &resumed) {
            Err(failure) if is_checkpoint_mismatch(&failure) => {
                eprintln!("note: the checkpoint belongs to other settings: simulating from the start");
                sim::run(config, &SimArgs { resume: false, ..options.clone() })?;
            }
            result => result?,
        }
        stamps.record("sim", &sim_hash)?;
        done.push(Done { stage: "sim", seconds: started.elapsed().as_secs_f64(), note: format!("{frames} frames") });
    }
    if until < Stage::Post {
        return summary(&done, config);
    }

    // post: the simulation's outputs (identified by its settings: it is deterministic) and [post]
    let post_hash =
        Hasher::default().bytes(sim_hash.as_bytes()).json(&config.post).json(&config.scene.frames_per_second).finish();
    let started = Instant::now();
    if stamps.matches("post", &post_hash) && layout.fragments(frames).is_file() {
        done.push(Done { stage: "post", seconds: 0.0, note: "up to date".into() });
    } else {
        post::run(config)?;
        stamps.record("post", &post_hash)?;
        done.push(Done { stage: "post", seconds: started.elapsed().as_secs_f64(), note: String::new() });
    }
    if until < Stage::Rigid {
        return summary(&done, config);
    }

    // rigid (with [rigid] only): post's outputs, [rigid] and the frame rate
    let mut shot_hash = post_hash.clone();
    if config.rigid.is_some() {
        let rigid_hash =
            Hasher::default().bytes(post_hash.as_bytes()).json(&config.rigid).json_if(timeline.as_ref()).finish();
        let started = Instant::now();
        if stamps.matches("rigid", &rigid_hash) && Shot::of(config, &layout).is_ok() {
            done.push(Done { stage: "rigid", seconds: 0.0, note: "up to date".into() });
        } else {
            rigid::run(config, &RigidArgs { resume: layout.rigid_checkpoint().is_file() })?;
            stamps.record("rigid", &rigid_hash)?;
            done.push(Done { stage: "rigid", seconds: started.elapsed().as_secs_f64(), note: String::new() });
        }
        shot_hash = rigid_hash;
    }
    if until < Stage::Render {
        return summary(&done, config);
    }
    let shot = Shot::of(config, &layout).map_err(|message| anyhow::anyhow!(message))?;
    let frames = shot.last;

    // render, frame by frame: the fragments, [render] and the image files it reads
    let mut hash = Hasher::default().bytes(shot_hash.as_bytes()).json(&config.render).json(&backend);
    for path in config.render.environment.iter().chain(config.render.floor.as_ref().and_then(|f| f.texture.as_ref())) {
        hash = hash.file(path);
    }
    let render_hash = hash.finish();
    let key = |frame: u32| format!("render.{frame:04}");
    let stale: Vec<u32> = (1..=frames)
        .filter(|&frame| !(stamps.matches(&key(frame), &render_hash) && layout.render_frame(frame, "exr").is_file()))
        .collect();
    let started = Instant::now();
    if stale.is_empty() {
        done.push(Done { stage: "render", seconds: 0.0, note: "up to date".into() });
    } else {
        let render_backend = options.backend;
        render::render_frames(config, &stale, render_backend, &mut |frame| {
            stamps.record(&key(frame), &render_hash).map_err(|error| error.into())
        })?;
        let note = format!("{} of {frames} frames", stale.len());
        done.push(Done { stage: "render", seconds: started.elapsed().as_secs_f64(), note });
    }
    summary(&done, config)
}

fn is_checkpoint_mismatch(failure: &Failure) -> bool {
    failure
        .error
        .chain()
        .any(|cause| matches!(cause.downcast_ref::<RunError>(), Some(RunError::CheckpointMismatch { .. })))
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
