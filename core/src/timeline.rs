//! Where each frame of a `[timeline]` falls in physical time, and the simulation's frames that
//! follow from it.
//!
//! The speed curve s(u) gives physical seconds per playback second at playback time u, counted
//! from the impact (the simulation's start): `timeline.speed` far from it; with
//! `[timeline.slow_motion]`, a smoothstep ease down to the slow speed over `ramp_in_s`, the slow
//! speed from `lead_s` before the impact to `hold_s` after it, and a smoothstep ease back over
//! `ramp_out_s`. A frame's physical time is the impact's plus the integral of s from the impact
//! to the frame, in closed form. The frames are spaced 1/fps apart in playback time, and one of
//! them falls exactly on the impact, so that the simulation's first frame is a frame of the
//! shot; the shot's first frame is the earliest at or after the shot's physical start (the
//! lead-in's start pose), at most one frame interval after it.

use crate::config::timeline::TimelineConfig;

/// The speed curve of a timeline, playback time counted from the impact.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SpeedCurve {
    /// Speed far from the impact.
    base: f64,
    /// Speed in the window.
    slow: f64,
    /// Where the ease down starts, where the slow speed starts, where it ends, where the ease
    /// back ends.
    breaks: [f64; 4],
}

/// The integral of the smoothstep 3x^2 - 2x^3 from 0 to x.
fn smoothstep_integral(x: f64) -> f64 {
    x * x * x * (1.0 - 0.5 * x)
}

/// The smoothstep 3x^2 - 2x^3.
fn smoothstep(x: f64) -> f64 {
    x * x * (3.0 - 2.0 * x)
}

impl SpeedCurve {
    fn of(config: &TimelineConfig) -> SpeedCurve {
        match &config.slow_motion {
            None => SpeedCurve { base: config.speed, slow: config.speed, breaks: [0.0; 4] },
            Some(slow) => SpeedCurve {
                base: config.speed,
                slow: slow.speed,
                breaks: [-slow.lead_s - slow.ramp_in_s, -slow.lead_s, slow.hold_s, slow.hold_s + slow.ramp_out_s],
            },
        }
    }

    /// Physical seconds per playback second at `u`.
    fn speed(&self, u: f64) -> f64 {
        let [b0, b1, b2, b3] = self.breaks;
        if u < b0 || u >= b3 {
            self.base
        } else if u < b1 {
            self.base + (self.slow - self.base) * smoothstep((u - b0) / (b1 - b0))
        } else if u < b2 {
            self.slow
        } else {
            self.slow + (self.base - self.slow) * smoothstep((u - b2) / (b3 - b2))
        }
    }

    /// The integral of the speed from the slow window's start (`breaks[1]`) to `u`.
    fn integral_from_window(&self, u: f64) -> f64 {
        let [b0, b1, b2, b3] = self.breaks;
        let (base, slow) = (self.base, self.slow);
        let ramp_in = b1 - b0;
        let ramp_out = b3 - b2;
        if u < b0 {
            -0.5 * ramp_in * (base + slow) - base * (b0 - u)
        } else if u < b1 {
            let x = (u - b0) / ramp_in;
            ramp_in * (base * x + (slow - base) * smoothstep_integral(x)) - 0.5 * ramp_in * (base + slow)
        } else if u < b2 {
            slow * (u - b1)
        } else if u < b3 {
            let x = (u - b2) / ramp_out;
            slow * (b2 - b1) + ramp_out * (slow * x + (base - slow) * smoothstep_integral(x))
        } else {
            slow * (b2 - b1) + 0.5 * ramp_out * (base + slow) + base * (u - b3)
        }
    }

    /// Physical seconds from the impact (u = 0) to `u`: negative before it.
    fn physical_s(&self, u: f64) -> f64 {
        if u == 0.0 { 0.0 } else { self.integral_from_window(u) - self.integral_from_window(0.0) }
    }
}

/// A timeline laid on a shot whose impact comes `impact_time_s` physical seconds after its
/// start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timeline {
    curve: SpeedCurve,
    fps: f64,
    duration_s: f64,
    frames: u32,
    impact_frame: u32,
    impact_time_s: f64,
}

impl Timeline {
    /// The frames of `config` around an impact at `impact_time_s` (0 without a lead-in).
    pub fn new(config: &TimelineConfig, impact_time_s: f64) -> Timeline {
        let curve = SpeedCurve::of(config);
        let fps = config.fps;
        // the playback time at which the shot's physical time is 0: bisect the increasing curve
        let (mut low, mut high) = (-1.0, 0.0);
        while curve.physical_s(low) > -impact_time_s {
            low *= 2.0;
        }
        for _ in 0..200 {
            let middle = 0.5 * (low + high);
            if curve.physical_s(middle) > -impact_time_s {
                high = middle;
            } else {
                low = middle;
            }
        }
        // whole frame intervals from there to the impact, none landing before the start
        // (capped: a shot whose impact lies past its end is refused by its stages)
        let mut before = (-high * fps).floor().clamp(0.0, 1e7) as u32;
        while before > 0 && curve.physical_s(-f64::from(before) / fps) < -impact_time_s {
            before -= 1;
        }
        let frames = (config.duration_s * fps).round().max(1.0) as u32;
        Timeline { curve, fps, duration_s: config.duration_s, frames, impact_frame: before + 1, impact_time_s }
    }

    /// An error (naming `timeline.duration_s`) when the shot ends before its impact.
    pub fn reaches_impact(&self) -> Result<(), String> {
        if self.impact_frame <= self.frames {
            return Ok(());
        }
        Err(format!(
            "timeline.duration_s = {}: the shot's {} frames end before the impact at {:.4} s (its frame {}); lengthen \
             the shot or shorten the lead-in",
            self.duration_s, self.frames, self.impact_time_s, self.impact_frame
        ))
    }

    /// Frames in the shot.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// The frame at the impact: the simulation's first frame.
    pub fn impact_frame(&self) -> u32 {
        self.impact_frame
    }

    /// Physical time of shot frame `frame` since the shot's start, seconds.
    pub fn time_s(&self, frame: u32) -> f64 {
        self.impact_time_s + self.since_impact_s(frame)
    }

    /// Physical time of shot frame `frame` since the impact, seconds (negative before it).
    pub fn since_impact_s(&self, frame: u32) -> f64 {
        self.curve.physical_s(self.playback_s(frame))
    }

    /// Physical seconds per playback second at shot frame `frame`.
    pub fn speed(&self, frame: u32) -> f64 {
        self.curve.speed(self.playback_s(frame))
    }

    /// Playback seconds from the impact to `frame`.
    fn playback_s(&self, frame: u32) -> f64 {
        (f64::from(frame) - f64::from(self.impact_frame)) / self.fps
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::timeline::SlowMotionConfig;

    fn config(slow_motion: Option<SlowMotionConfig>) -> TimelineConfig {
        TimelineConfig { fps: 24.0, duration_s: 4.0, speed: 1.0, slow_motion }
    }

    #[test]
    fn real_speed_frames_are_a_frame_interval_apart_with_one_on_the_impact() {
        let timeline = Timeline::new(&config(None), 0.4);
        assert_eq!(timeline.frames(), 96);
        // 0.4 s is 9.6 frame intervals: frame 1 lies 0.4 interval after the start
        assert_eq!(timeline.impact_frame(), 10);
        assert_eq!(timeline.time_s(10), 0.4);
        assert!((timeline.time_s(1) - (0.4 - 9.0 / 24.0)).abs() < 1e-15);
        for frame in 1..96 {
            let step = timeline.time_s(frame + 1) - timeline.time_s(frame);
            assert!((step - 1.0 / 24.0).abs() < 1e-14, "frame {frame}: {step}");
        }
        let start = Timeline::new(&config(None), 0.0);
        assert_eq!((start.impact_frame(), start.time_s(1)), (1, 0.0));
    }

    #[test]
    fn the_slow_motion_window_integrates_its_speed_and_eases_without_jumps() {
        let slow = SlowMotionConfig { speed: 0.005, lead_s: 0.1, hold_s: 1.0, ramp_in_s: 0.25, ramp_out_s: 0.5 };
        let curve = SpeedCurve::of(&config(Some(slow.clone())));
        // continuous integral and speed at each break, and the integral's slope is the speed
        for at in curve.breaks {
            for f in [SpeedCurve::integral_from_window, SpeedCurve::speed] {
                let (before, after) = (f(&curve, at - 1e-12), f(&curve, at + 1e-12));
                assert!((before - after).abs() < 1e-9, "{at}: {before} {after}");
            }
        }
        for u in [-2.0, -0.3, -0.2, 0.0, 0.5, 1.2, 1.45, 3.0] {
            let h = 1e-6;
            let slope = (curve.physical_s(u + h) - curve.physical_s(u - h)) / (2.0 * h);
            assert!((slope - curve.speed(u)).abs() < 1e-6, "{u}: {slope} vs {}", curve.speed(u));
        }
        // the held window: 0.1 s before and 1 s after at 200x slow motion
        assert!((curve.physical_s(1.0) - 0.005).abs() < 1e-15);
        assert!((curve.physical_s(-0.1) + 0.0005).abs() < 1e-15);
        // each ramp covers the mean of its end speeds
        let ramp_out = curve.physical_s(1.5) - curve.physical_s(1.0);
        assert!((ramp_out - 0.5 * 0.5 * 1.005).abs() < 1e-15);

        let timeline = Timeline::new(&config(Some(slow)), 0.4);
        let impact = timeline.impact_frame();
        assert_eq!(timeline.time_s(impact), 0.4);
        assert!(timeline.time_s(1) >= 0.0 && timeline.time_s(1) < timeline.time_s(2));
        assert!(timeline.time_s(1) - timeline.speed(1) / 24.0 < 1e-3, "frame 1 is within a frame of the start");
        let spacing = timeline.time_s(impact + 1) - timeline.time_s(impact);
        assert!((spacing - 0.005 / 24.0).abs() < 1e-15);
        for frame in 1..timeline.frames() {
            assert!(timeline.time_s(frame + 1) > timeline.time_s(frame));
        }
    }

    #[test]
    fn a_window_that_would_start_before_the_shot_is_cut_at_its_start() {
        // no lead-in: the impact is the shot's start, so the shot opens in slow motion
        let slow = SlowMotionConfig { speed: 0.01, lead_s: 0.2, hold_s: 0.5, ramp_in_s: 0.25, ramp_out_s: 0.25 };
        let timeline = Timeline::new(&config(Some(slow)), 0.0);
        assert_eq!((timeline.impact_frame(), timeline.time_s(1)), (1, 0.0));
        assert!((timeline.time_s(2) - 0.01 / 24.0).abs() < 1e-15);
    }
}
