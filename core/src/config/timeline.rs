//! `[timeline]`: the shot's frame rate, its length and its speed curve (physical seconds per
//! playback second: real speed by default, with an optional slow-motion window around the
//! impact and eased ramps into and out of it). Every frame then has a physical time, and the
//! stages simulate up to it: see [`crate::timeline`].

use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::checker::Checker;

/// `[timeline]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TimelineConfig {
    /// Playback frames per second (USD time codes, EXR metadata); with `[timeline]` this takes
    /// the place of `scene.frames_per_second`.
    pub fps: f64,
    /// The shot's length, playback seconds: it has `duration_s * fps` frames (rounded).
    pub duration_s: f64,
    /// Physical seconds per playback second outside the slow-motion window (1: real speed).
    pub speed: f64,
    /// The slow-motion window around the impact, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slow_motion: Option<SlowMotionConfig>,
}

impl Default for TimelineConfig {
    fn default() -> Self {
        TimelineConfig { fps: 24.0, duration_s: 4.0, speed: 1.0, slow_motion: None }
    }
}

/// `[timeline.slow_motion]`: the speed eases from `timeline.speed` down to `speed` over
/// `ramp_in_s`, holds from `lead_s` before the impact to `hold_s` after it, and eases back over
/// `ramp_out_s` (playback seconds throughout; the ease is a smoothstep, so the speed has no
/// kink). The impact is the simulation's start: the lead-in's handoff, or the shot's first frame
/// without `[lead_in]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SlowMotionConfig {
    /// Physical seconds per playback second inside the window (0.01: 100x slow motion).
    pub speed: f64,
    /// Playback seconds of full slow motion before the impact.
    pub lead_s: f64,
    /// Playback seconds of full slow motion after the impact.
    pub hold_s: f64,
    /// Playback seconds of the ease from `timeline.speed` down to `speed`.
    pub ramp_in_s: f64,
    /// Playback seconds of the ease from `speed` back up to `timeline.speed`.
    pub ramp_out_s: f64,
}

impl Default for SlowMotionConfig {
    fn default() -> Self {
        SlowMotionConfig { speed: 0.01, lead_s: 0.0, hold_s: 1.0, ramp_in_s: 0.25, ramp_out_s: 0.5 }
    }
}

/// The slowest speed a timeline may run at, physical seconds per playback second.
pub const MIN_SPEED: f64 = 1e-6;

/// The most frames a timeline may have (an hour at 24 fps, a minute at 1,000 fps ...).
pub const MAX_TIMELINE_FRAMES: f64 = 100_000.0;

impl TimelineConfig {
    pub(super) fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        check.positive("timeline.fps", self.fps, "frames per second")?;
        check.that(self.fps <= super::MAX_FRAMES_PER_SECOND, "timeline.fps", &self.fps.to_string(), || {
            format!("must be at most {} frames per second", super::MAX_FRAMES_PER_SECOND)
        })?;
        check.positive("timeline.duration_s", self.duration_s, "seconds")?;
        let frames = (self.duration_s * self.fps).round();
        check.that(
            (1.0..=MAX_TIMELINE_FRAMES).contains(&frames),
            "timeline.duration_s",
            &self.duration_s.to_string(),
            || format!("at timeline.fps it makes {frames} frames; a shot has 1 to {MAX_TIMELINE_FRAMES}"),
        )?;
        check.that((MIN_SPEED..=1000.0).contains(&self.speed), "timeline.speed", &self.speed.to_string(), || {
            format!("must be {MIN_SPEED:e} to 1000 physical seconds per playback second")
        })?;
        if let Some(slow) = &self.slow_motion {
            let speed = slow.speed;
            check.that((MIN_SPEED..=self.speed).contains(&speed), "timeline.slow_motion.speed", &speed.to_string(), || {
                format!(
                    "must be {MIN_SPEED:e} (a million times slow motion) to timeline.speed ({}): the window slows the \
                     shot down",
                    self.speed
                )
            })?;
            for (key, value) in [
                ("timeline.slow_motion.lead_s", slow.lead_s),
                ("timeline.slow_motion.hold_s", slow.hold_s),
                ("timeline.slow_motion.ramp_in_s", slow.ramp_in_s),
                ("timeline.slow_motion.ramp_out_s", slow.ramp_out_s),
            ] {
                check.non_negative(key, value, "playback seconds")?;
                check.that(value <= 3600.0, key, &value.to_string(), || "must be at most 3600 seconds".into())?;
            }
        }
        Ok(())
    }
}
