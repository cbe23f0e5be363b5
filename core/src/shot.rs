//! The frames of a shot and which stage's file holds each: the simulation's frames
//! (`fragments/`, written by post) up to the handoff, the follow-through's (`rigid/`) after it.
//! Without `[rigid]`, the shot is the simulation's frames.

use std::path::PathBuf;

use crate::rigid_checkpoint::RigidCheckpoint;
use crate::{OutputLayout, PipelineConfig};

/// A shot's frame range.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shot {
    /// The last frame from the fracture (post's fragments files): `sim.frames` without `[rigid]`.
    pub handoff: u32,
    /// The shot's last frame.
    pub last: u32,
    /// Whether frames after `handoff` come from the follow-through.
    pub rigid: bool,
}

impl Shot {
    /// The shot of `config`: with `[rigid]`, as the finished follow-through recorded it. An
    /// error names what to run when the follow-through is missing or unfinished.
    pub fn of(config: &PipelineConfig, layout: &OutputLayout) -> Result<Shot, String> {
        if config.rigid.is_none() {
            return Ok(Shot { handoff: config.sim.frames, last: config.sim.frames, rigid: false });
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
        Ok(Shot { handoff: meta.handoff_frame, last: meta.last_frame, rigid: true })
    }

    /// The fragments file of `frame`.
    pub fn fragments(&self, layout: &OutputLayout, frame: u32) -> PathBuf {
        if self.rigid && frame > self.handoff { layout.rigid_fragments(frame) } else { layout.fragments(frame) }
    }

    /// The stage that writes `frame`'s fragments file (for messages).
    pub fn stage_of(&self, frame: u32) -> &'static str {
        if self.rigid && frame > self.handoff { "rigid" } else { "post" }
    }
}
