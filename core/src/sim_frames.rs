//! The simulation's frames: how many steps from its start each lies, and how fast the shot
//! plays there. Without `[timeline]`, `sim.frames` frames `sim.steps_per_frame` steps apart;
//! with it, the shot's frames from the impact on, each at the step nearest its physical time
//! (at least one step after the one before), up to the shot's end or, with `[rigid]`, the first
//! frame at or past `rigid.max_fracture_duration_s` (the follow-through takes over by then).
//! How many frames there are does not depend on the time step; which steps they lie at does.

use crate::lead_in::LeadIn;
use crate::time_step::{self, UNSET_STEP_STAND_IN_S};
use crate::timeline::Timeline;
use crate::{OutputLayout, PipelineConfig};

/// The simulation's frames.
#[derive(Debug, Clone, PartialEq)]
pub struct SimFrames {
    /// Steps from the simulation's start to each frame (frame 1: 0).
    pub steps: Vec<u64>,
    /// Physical seconds per playback second at each frame (USD velocities).
    pub speed: Vec<f64>,
    /// The shot frame of the simulation's frame 1.
    pub first_shot_frame: u32,
    /// The time step, seconds.
    pub dt_s: f64,
}

impl SimFrames {
    /// The frames of `config` at time step `dt_s` (seconds), whose lead-in (with `[lead_in]`)
    /// ended as `lead_in` says. An error names the key to change.
    pub fn of(config: &PipelineConfig, lead_in: Option<&LeadIn>, dt_s: f64) -> Result<SimFrames, String> {
        let sim = &config.sim;
        let Some(timeline_config) = &config.timeline else {
            let steps = (0..u64::from(sim.frames)).map(|frame| frame * u64::from(sim.steps_per_frame)).collect();
            let speed = dt_s * f64::from(sim.steps_per_frame) * config.scene.frames_per_second;
            let first_shot_frame = lead_in.map_or(0, |lead_in| lead_in.frames) + 1;
            return Ok(SimFrames { steps, speed: vec![speed; sim.frames as usize], first_shot_frame, dt_s });
        };
        let impact_time_s = lead_in.map_or(0.0, |lead_in| lead_in.handoff_time_s);
        let timeline = Timeline::new(timeline_config, impact_time_s);
        let impact = timeline.impact_frame();
        timeline.reaches_impact().map_err(|message| format!("{}: {message}", config.path.display()))?;
        let fracture_cap_s = config.rigid.as_ref().map_or(f64::INFINITY, |rigid| rigid.max_fracture_duration_s);
        let mut frames = SimFrames { steps: Vec::new(), speed: Vec::new(), first_shot_frame: impact, dt_s };
        for frame in impact..=timeline.frames() {
            let since_impact_s = timeline.since_impact_s(frame);
            let nearest = (since_impact_s / dt_s).round() as u64;
            let steps = match frames.steps.last() {
                Some(&before) => nearest.max(before + 1),
                None => 0,
            };
            frames.steps.push(steps);
            frames.speed.push(timeline.speed(frame));
            if since_impact_s >= fracture_cap_s {
                break;
            }
        }
        Ok(frames)
    }

    /// The frames of the finished simulation of `config` in `layout`: its lead-in's handoff read
    /// from there when it has one, and its time step `sim.dt_s` or, unset, the one its frames
    /// record.
    pub fn read(config: &PipelineConfig, layout: &OutputLayout) -> Result<SimFrames, String> {
        let dt_s = match config.sim.dt_s {
            Some(dt_s) => dt_s,
            None => time_step::recorded_s(layout)?,
        };
        SimFrames::of(config, read_lead_in(config, layout)?.as_ref(), dt_s)
    }

    /// The shot frame of the simulation's frame 1 and how many frames it writes (neither
    /// depends on the time step, so this holds before the simulation has run).
    pub fn span(config: &PipelineConfig, lead_in: Option<&LeadIn>) -> Result<(u32, u32), String> {
        let frames = SimFrames::of(config, lead_in, config.sim.dt_s.unwrap_or(UNSET_STEP_STAND_IN_S))?;
        Ok((frames.first_shot_frame, frames.count()))
    }

    /// [`SimFrames::span`], reading the lead-in's handoff from `layout` when there is one.
    pub fn read_span(config: &PipelineConfig, layout: &OutputLayout) -> Result<(u32, u32), String> {
        SimFrames::span(config, read_lead_in(config, layout)?.as_ref())
    }

    /// How many frames the simulation writes.
    pub fn count(&self) -> u32 {
        self.steps.len() as u32
    }

    /// Steps from frame `frame - 1` to frame `frame` (frames from 2).
    pub fn steps_before(&self, frame: u32) -> u64 {
        let index = frame as usize - 1;
        self.steps[index] - self.steps[index - 1]
    }
}

/// The lead-in's handoff in `layout`, with `[lead_in]`.
fn read_lead_in(config: &PipelineConfig, layout: &OutputLayout) -> Result<Option<LeadIn>, String> {
    match config.lead_in {
        None => Ok(None),
        Some(_) => LeadIn::read_for(layout).map(Some),
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    const BASE: &str = "[scene]\nname = \"t\"\noutput_dir = \"out\"\nseed = 1\n[geometry]\nsource = \"box\"\n\
                        box_size_m = [0.004, 0.004, 0.004]\nsampler = \"grid\"\nspacing_m = 0.001\n\
                        horizon_factor = 2.0\n[material]\ndensity_kg_m3 = 2200.0\nbulk_modulus_pa = 14.9e9\n";

    fn config(extra: &str) -> Result<PipelineConfig, String> {
        PipelineConfig::from_toml_str(&format!("{BASE}{extra}"), Path::new("p.toml")).map_err(|e| e.to_string())
    }

    fn lead_in(handoff_time_s: f64) -> LeadIn {
        LeadIn {
            frames: 0,
            handoff_time_s,
            rotation: [0.0, 0.0, 0.0, 1.0],
            translation_m: [0.0; 3],
            centre_m: [0.0; 3],
            velocity_m_s: [0.0; 3],
            angular_velocity_rad_s: [0.0; 3],
            steps: 0,
            inputs: 0,
            others: Vec::new(),
            body_of: Vec::new(),
            plastic: None,
        }
    }

    #[test]
    fn without_a_timeline_the_frames_are_a_fixed_count_of_steps_apart() {
        let config = config("[sim]\nframes = 4\nsteps_per_frame = 10\n").expect("valid");
        let frames = SimFrames::of(&config, None, 1e-6).expect("valid");
        assert_eq!(frames.steps, [0, 10, 20, 30]);
        assert_eq!(frames.speed, [1e-6 * 10.0 * 24.0; 4]);
        assert_eq!(SimFrames::span(&config, None).expect("valid"), (1, 4));
        assert_eq!(frames.first_shot_frame, 1);
        assert_eq!(frames.steps_before(3), 10);
    }

    #[test]
    fn a_timeline_puts_the_frames_on_the_nearest_steps_up_to_the_longest_fracture() {
        let slow = "[timeline]\nduration_s = 2.0\n[timeline.slow_motion]\nspeed = 0.0048\n\
                    hold_s = 0.5\n[rigid]\nmax_fracture_duration_s = 0.002\n";
        let config = config(slow).expect("valid");
        let frames = SimFrames::of(&config, Some(&lead_in(0.4)), 1e-6).expect("valid");
        assert_eq!(SimFrames::span(&config, Some(&lead_in(0.4))).expect("valid"), (frames.first_shot_frame, 11));
        let timeline = Timeline::new(config.timeline.as_ref().expect("valid"), 0.4);
        assert_eq!(frames.first_shot_frame, timeline.impact_frame());
        // 200 steps a frame in the held window: 0.002 s is frame 11
        assert_eq!(&frames.steps[..4], [0, 200, 400, 600]);
        assert_eq!(frames.count(), 11);
        assert_eq!(*frames.steps.last().expect("valid"), 2000);
        assert!((frames.speed[0] - 0.0048).abs() < 1e-15);
        // without [rigid] the simulation runs to the shot's end, through the ramp, a step apart at least
        let to_end =
            SimFrames::of(&PipelineConfig { rigid: None, ..config.clone() }, Some(&lead_in(0.4)), 1e-6).expect("valid");
        assert_eq!(to_end.first_shot_frame + to_end.count() - 1, timeline.frames());
        assert!(to_end.steps.windows(2).all(|pair| pair[1] > pair[0]));
        // a shot that ends before the impact names its length
        let error = SimFrames::of(&config, Some(&lead_in(5.0)), 1e-6).expect_err("refused");
        assert!(error.contains("timeline.duration_s = 2") && error.contains("before the impact"), "{error}");
    }

    #[test]
    fn a_timeline_refuses_the_keys_it_replaces() {
        for (extra, key) in [
            ("[sim]\nframes = 4\n", "sim.frames"),
            ("[sim]\nsteps_per_frame = 4\n", "sim.steps_per_frame"),
            ("[rigid]\nfollow_through_s = 2.0\n", "rigid.follow_through_s"),
        ] {
            let error = config(&format!("{extra}[timeline]\nfps = 30.0\n")).expect_err("refused");
            assert!(error.contains(key) && error.contains("[timeline]"), "{error}");
        }
        let text = format!("{}[timeline]\n", BASE.replace("seed = 1\n", "seed = 1\nframes_per_second = 30.0\n"));
        let error = PipelineConfig::from_toml_str(&text, Path::new("p.toml")).expect_err("refused").to_string();
        assert!(error.contains("scene.frames_per_second") && error.contains("timeline.fps"), "{error}");
        let error = config("[timeline]\n[timeline.slow_motion]\nspeed = 2.0\n").expect_err("refused");
        assert!(error.contains("timeline.slow_motion.speed"), "{error}");
        assert_eq!(config("[timeline]\nfps = 30.0\n").expect("valid").scene.frames_per_second, 30.0);
    }
}
