//! The page's frames: the shot as far as it is written, whichever stage writes each frame. The
//! lead-in's frames come first (once its handoff file is written), then the simulation's as they
//! land, then, once the follow-through has begun, its frames after the handoff (the simulation's
//! frames past the handoff then leave the page's list). Page frame i is the shot's frame i.

use shatter_core::OutputLayout;
use shatter_core::lead_in::LeadIn;

/// Where a page frame comes from, and its number in that stage's files.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameSource {
    /// The lead-in's frame (`rigid/lead_in.NNNN.shp`).
    LeadIn(u32),
    /// The simulation's frame (`frames/points.NNNN.shf`).
    Sim(u32),
    /// The follow-through's frame, numbered as the simulation's (`rigid/fragments.NNNN.shp`).
    Rigid(u32),
}

impl FrameSource {
    /// The source's code in a frame message: 0 lead-in, 1 simulation, 2 follow-through.
    pub fn code(self) -> u32 {
        match self {
            FrameSource::LeadIn(_) => 0,
            FrameSource::Sim(_) => 1,
            FrameSource::Rigid(_) => 2,
        }
    }
}

/// The page's frames of an output folder as it stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PageFrames {
    /// The lead-in's frames (0 without one, or before its handoff file is written).
    pub lead_in: u32,
    /// The simulation's frames on the page: those written, up to the handoff once it is known.
    pub sim: u32,
    /// The follow-through's frames written, after the handoff.
    pub rigid: u32,
    /// The simulation's last frame before the follow-through's, once its first frame is written.
    pub handoff: Option<u32>,
    /// The shot's time at the simulation's start (the lead-in's handoff), seconds.
    pub sim_start_s: f64,
}

impl PageFrames {
    /// The frames of `layout` now. `handoff` is the handoff found by an earlier look, if any (it
    /// never changes once the follow-through has written a frame).
    pub fn of(layout: &OutputLayout, handoff: Option<u32>) -> PageFrames {
        let lead_in = layout.lead_in().is_file().then(|| LeadIn::read(&layout.lead_in()).ok()).flatten();
        let written = count_from(1, |frame| layout.frame_points(frame).is_file());
        // the follow-through's first frame is the one after the handoff, at most one past the
        // simulation's last
        let handoff = handoff.or_else(|| {
            (1..=written + 1).find(|&frame| layout.rigid_fragments(frame).is_file()).map(|first| first - 1)
        });
        let rigid = handoff.map_or(0, |h| count_from(h + 1, |frame| layout.rigid_fragments(frame).is_file()));
        PageFrames {
            lead_in: lead_in.as_ref().map_or(0, |lead_in| lead_in.frames),
            sim: handoff.map_or(written, |h| written.min(h)),
            rigid,
            handoff,
            sim_start_s: lead_in.map_or(0.0, |lead_in| lead_in.handoff_time_s),
        }
    }

    /// How many frames the page has.
    pub fn count(&self) -> u32 {
        self.lead_in + self.sim + self.rigid
    }

    /// Where page frame `frame` (from 1) comes from; None past the last.
    pub fn locate(&self, frame: u32) -> Option<FrameSource> {
        if frame == 0 || frame > self.count() {
            return None;
        }
        if frame <= self.lead_in {
            return Some(FrameSource::LeadIn(frame));
        }
        let local = frame - self.lead_in;
        Some(if local <= self.sim { FrameSource::Sim(local) } else { FrameSource::Rigid(local) })
    }
}

/// How many consecutive numbers from `first` on pass `present`.
fn count_from(first: u32, present: impl Fn(u32) -> bool) -> u32 {
    (first..).take_while(|&frame| present(frame)).count() as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn page_frames_run_through_the_lead_in_the_simulation_and_the_follow_through() {
        let frames = PageFrames { lead_in: 3, sim: 5, rigid: 4, handoff: Some(5), sim_start_s: 0.2 };
        assert_eq!(frames.count(), 12);
        assert_eq!(frames.locate(0), None);
        assert_eq!(frames.locate(3), Some(FrameSource::LeadIn(3)));
        assert_eq!(frames.locate(4), Some(FrameSource::Sim(1)));
        assert_eq!(frames.locate(8), Some(FrameSource::Sim(5)));
        assert_eq!(frames.locate(9), Some(FrameSource::Rigid(6)));
        assert_eq!(frames.locate(12), Some(FrameSource::Rigid(9)));
        assert_eq!(frames.locate(13), None);
    }

    #[test]
    fn the_simulations_frames_past_the_handoff_leave_once_the_follow_through_writes() {
        let dir = tempfile::tempdir().expect("dir");
        let layout = OutputLayout::new(dir.path(), "s");
        std::fs::create_dir_all(layout.frames_dir()).expect("frames");
        std::fs::create_dir_all(layout.rigid_dir()).expect("rigid");
        for frame in 1..=6 {
            std::fs::write(layout.frame_points(frame), b"").expect("frame");
        }
        let before = PageFrames::of(&layout, None);
        assert_eq!((before.sim, before.rigid, before.handoff, before.count()), (6, 0, None, 6));
        for frame in 5..=7 {
            std::fs::write(layout.rigid_fragments(frame), b"").expect("rigid frame");
        }
        let after = PageFrames::of(&layout, None);
        assert_eq!((after.sim, after.rigid, after.handoff, after.count()), (4, 3, Some(4), 7));
        assert_eq!(after.locate(5), Some(FrameSource::Rigid(5)));
    }
}
