//! The frames of a shot and which stage's file holds each: the lead-in's (`rigid/lead_in.*`,
//! with `[lead_in]`), then the simulation's (post's `fragments/`) up to the handoff, then the
//! follow-through's (`rigid/`, with `[rigid]`). The simulation and post number their frames from
//! 1 at the simulation's start; the shot numbers from its own start, so a shot frame is the
//! simulation's frame plus the lead-in's frame count.

use std::path::PathBuf;

use crate::lead_in::LeadIn;
use crate::rigid_checkpoint::RigidCheckpoint;
use crate::sim_frames::SimFrames;
use crate::{OutputLayout, PipelineConfig};

/// The stage whose file holds a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// The lead-in (`shatter lead-in`).
    LeadIn,
    /// The simulation, through post (`shatter post`).
    Post,
    /// The follow-through (`shatter rigid`).
    Rigid,
}

impl Source {
    /// The command that writes it.
    pub fn command(self) -> &'static str {
        match self {
            Source::LeadIn => "lead-in",
            Source::Post => "post",
            Source::Rigid => "rigid",
        }
    }
}

/// A shot's frame range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shot {
    /// Frames of the lead-in, before the simulation's frame 1.
    pub lead_in: u32,
    /// The shot's time at the simulation's start (the lead-in's handoff), seconds: the
    /// simulation's and the follow-through's files count time from there.
    pub sim_start_s: f64,
    /// The last frame from the simulation, in its own numbering: all of its frames without
    /// `[rigid]`.
    pub handoff: u32,
    /// The shot's last frame.
    pub last: u32,
    /// Whether frames after `handoff` come from the follow-through.
    pub rigid: bool,
}

impl Shot {
    /// The shot of `config`, as its lead-in and finished follow-through recorded it. An error
    /// names what to run when one is missing or unfinished.
    pub fn of(config: &PipelineConfig, layout: &OutputLayout) -> Result<Shot, String> {
        let lead_in = match config.lead_in {
            None => None,
            Some(_) => Some(LeadIn::read_for(layout)?),
        };
        let sim_start_s = lead_in.as_ref().map_or(0.0, |lead_in| lead_in.handoff_time_s);
        let (first_shot_frame, frames) = SimFrames::span(config, lead_in.as_ref())?;
        let lead_in = first_shot_frame - 1;
        if config.rigid.is_none() {
            return Ok(Shot { lead_in, sim_start_s, handoff: frames, last: lead_in + frames, rigid: false });
        }
        let path = layout.rigid_checkpoint();
        if !path.is_file() {
            return Err(format!("{}: missing ([rigid] is set); run `shatter rigid` first", path.display()));
        }
        let checkpoint = RigidCheckpoint::read(&path).map_err(|error| error.to_string())?;
        let meta = checkpoint.meta;
        if meta.frame < meta.last_frame {
            return Err(format!(
                "{}: the follow-through stopped at frame {} of {}; run `shatter rigid --resume` to finish it",
                path.display(),
                meta.frame,
                meta.last_frame
            ));
        }
        Ok(Shot { lead_in, sim_start_s, handoff: meta.handoff_frame, last: lead_in + meta.last_frame, rigid: true })
    }

    /// Which stage holds shot frame `frame`, and its number there.
    pub fn locate(&self, frame: u32) -> (Source, u32) {
        if frame <= self.lead_in {
            return (Source::LeadIn, frame);
        }
        let local = frame - self.lead_in;
        if self.rigid && local > self.handoff { (Source::Rigid, local) } else { (Source::Post, local) }
    }

    /// The shot's time of shot frame `frame`, whose fragments file says `file_time_s`.
    pub fn time_s(&self, frame: u32, file_time_s: f64) -> f64 {
        match self.locate(frame).0 {
            Source::LeadIn => file_time_s,
            Source::Post | Source::Rigid => self.sim_start_s + file_time_s,
        }
    }

    /// The fragments file of shot frame `frame`.
    pub fn fragments(&self, layout: &OutputLayout, frame: u32) -> PathBuf {
        match self.locate(frame) {
            (Source::LeadIn, local) => layout.lead_in_fragments(local),
            (Source::Post, local) => layout.fragments(local),
            (Source::Rigid, local) => layout.rigid_fragments(local),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shot_frames_map_to_each_stage_in_turn() {
        let shot = Shot { lead_in: 10, sim_start_s: 0.4, handoff: 20, last: 10 + 68, rigid: true };
        assert_eq!(shot.time_s(3, 0.1), 0.1);
        assert_eq!(shot.time_s(31, 0.5), 0.9);
        assert_eq!(shot.locate(1), (Source::LeadIn, 1));
        assert_eq!(shot.locate(10), (Source::LeadIn, 10));
        assert_eq!(shot.locate(11), (Source::Post, 1));
        assert_eq!(shot.locate(30), (Source::Post, 20));
        assert_eq!(shot.locate(31), (Source::Rigid, 21));
        let layout = OutputLayout::new("out", "s");
        assert_eq!(shot.fragments(&layout, 31), layout.rigid_fragments(21));
        let plain = Shot { lead_in: 0, sim_start_s: 0.0, handoff: 48, last: 48, rigid: false };
        assert_eq!(plain.locate(48), (Source::Post, 48));
    }
}
