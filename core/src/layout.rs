//! Every path in a scene's output folder, in one place. Stages find each other's files only
//! through [`OutputLayout`]; docs/FORMATS.md describes what each file holds.
//!
//! ```text
//! <output_dir>/
//!   particles.shp              preprocess
//!   sim.checkpoint.shp         sim (resume)
//!   frames/points.####.ply     sim: positions, velocities, damage
//!   frames/breaks.log          sim: (step, bond) per frame, append-only
//!   frames.previous/, sim.checkpoint.previous.shp
//!                              sim: the previous run's, kept until a fresh run has a checkpoint
//!   fragments/fragments.####.shp   post: fragment ids and rigid motions
//!   fragments/points.####.ply  post: positions with fragment ids
//!   fragments/fragments.usda   post: the USD shot
//!   rigid/lead_in.shp          lead-in: the handoff to the simulation
//!   rigid/lead_in.####.shp     lead-in: its frames (one fragment: the intact body)
//!   rigid/fragments.####.shp   rigid: the follow-through's frames (after the handoff)
//!   rigid/rigid.checkpoint.shp rigid: the rapier world (resume) and the shot's frame range
//!   rigid/reentry.###.shp      rigid: pieces that hit hard, back to the simulation
//!   reentry/###/               the simulation and post of re-entry ###, laid out as this folder
//!   render/<scene>.####.exr    render (and .png previews)
//!   stamps.json                `shatter run`: what each stage last finished with
//!   shatter.lock               held by the command writing into the folder (pid inside)
//! ```

use std::path::{Path, PathBuf};

use crate::PipelineConfig;

/// The paths of one scene's output folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputLayout {
    root: PathBuf,
    scene: String,
}

impl OutputLayout {
    /// The layout of the folder `root` for the scene named `scene` (rendered frames carry the
    /// scene's name).
    pub fn new(root: impl Into<PathBuf>, scene: &str) -> OutputLayout {
        OutputLayout { root: root.into(), scene: scene.to_owned() }
    }

    /// The layout of a config's `scene.output_dir` for its `scene.name`.
    pub fn of(config: &PipelineConfig) -> OutputLayout {
        OutputLayout::new(config.output_dir(), &config.scene.name)
    }

    /// The output folder itself.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The particle file `shatter preprocess` writes.
    pub fn particles(&self) -> PathBuf {
        self.root.join("particles.shp")
    }

    /// The simulation's checkpoint.
    pub fn checkpoint(&self) -> PathBuf {
        self.root.join("sim.checkpoint.shp")
    }

    /// The folder of the simulation's frames and break log.
    pub fn frames_dir(&self) -> PathBuf {
        self.root.join("frames")
    }

    /// The simulation's point cache of `frame`.
    pub fn frame_points(&self, frame: u32) -> PathBuf {
        self.frames_dir().join(points_name(frame))
    }

    /// Where a fresh simulation keeps the previous run's frames folder until it has a
    /// checkpoint of its own.
    pub fn previous_frames_dir(&self) -> PathBuf {
        self.root.join("frames.previous")
    }

    /// Where a fresh simulation keeps the previous run's checkpoint until it has its own.
    pub fn previous_checkpoint(&self) -> PathBuf {
        self.root.join("sim.checkpoint.previous.shp")
    }

    /// The bond-break log.
    pub fn break_log(&self) -> PathBuf {
        self.frames_dir().join("breaks.log")
    }

    /// The folder `shatter post` writes into.
    pub fn fragments_dir(&self) -> PathBuf {
        self.root.join("fragments")
    }

    /// The fragments file of `frame`.
    pub fn fragments(&self, frame: u32) -> PathBuf {
        self.fragments_dir().join(format!("fragments.{frame:04}.shp"))
    }

    /// The point cache with fragment ids of `frame`.
    pub fn fragment_points(&self, frame: u32) -> PathBuf {
        self.fragments_dir().join(points_name(frame))
    }

    /// The debris emitter points of `frame` (break events, post).
    pub fn debris_points(&self, frame: u32) -> PathBuf {
        self.fragments_dir().join(format!("debris.{frame:04}.ply"))
    }

    /// The USD shot.
    pub fn usd(&self) -> PathBuf {
        self.fragments_dir().join("fragments.usda")
    }

    /// The folder `shatter rigid` writes into.
    pub fn rigid_dir(&self) -> PathBuf {
        self.root.join("rigid")
    }

    /// The lead-in's handoff file.
    pub fn lead_in(&self) -> PathBuf {
        self.rigid_dir().join("lead_in.shp")
    }

    /// The fragments file of the lead-in's `frame`.
    pub fn lead_in_fragments(&self, frame: u32) -> PathBuf {
        self.rigid_dir().join(format!("lead_in.{frame:04}.shp"))
    }

    /// The fragments file of the follow-through's `frame`.
    pub fn rigid_fragments(&self, frame: u32) -> PathBuf {
        self.rigid_dir().join(format!("fragments.{frame:04}.shp"))
    }

    /// The USD of a shot with a follow-through: every frame, lead-in to rest.
    pub fn rigid_usd(&self) -> PathBuf {
        self.rigid_dir().join("shot.usda")
    }

    /// The follow-through's checkpoint.
    pub fn rigid_checkpoint(&self) -> PathBuf {
        self.rigid_dir().join("rigid.checkpoint.shp")
    }

    /// The request of re-entry `number` (from 1): the pieces that go back to the simulation.
    pub fn reentry(&self, number: u32) -> PathBuf {
        self.rigid_dir().join(format!("reentry.{number:03}.shp"))
    }

    /// The output folder of re-entry `number`'s simulation and post, laid out as a scene's.
    pub fn reentry_dir(&self, number: u32) -> PathBuf {
        self.root.join("reentry").join(format!("{number:03}"))
    }

    /// The folder of rendered frames.
    pub fn render_dir(&self) -> PathBuf {
        self.root.join("render")
    }

    /// The rendered image of `frame` with the file extension `extension` ("exr", "png"):
    /// `<scene>.####.<extension>`.
    pub fn render_frame(&self, frame: u32, extension: &str) -> PathBuf {
        self.render_dir().join(format!("{}.{frame:04}.{extension}", self.scene))
    }

    /// What `shatter run` records of each finished stage.
    pub fn stamps(&self) -> PathBuf {
        self.root.join("stamps.json")
    }

    /// The lock file of the folder's one writer (see [`crate::output_lock`]).
    pub fn lock(&self) -> PathBuf {
        self.root.join("shatter.lock")
    }
}

/// What to tell a user whose stage needs `path`, an earlier stage's output that is not there:
/// `None` when it is a file.
pub fn missing_input(path: &Path, earlier_stage: &str) -> Option<String> {
    (!path.is_file()).then(|| format!("{}: missing; run `shatter {earlier_stage}` first", path.display()))
}

fn points_name(frame: u32) -> String {
    format!("points.{frame:04}.ply")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_are_the_documented_ones() {
        let layout = OutputLayout::new("out/plate", "plate");
        assert_eq!(layout.particles(), Path::new("out/plate/particles.shp"));
        assert_eq!(layout.checkpoint(), Path::new("out/plate/sim.checkpoint.shp"));
        assert_eq!(layout.frame_points(7), Path::new("out/plate/frames/points.0007.ply"));
        assert_eq!(layout.break_log(), Path::new("out/plate/frames/breaks.log"));
        assert_eq!(layout.fragments(12), Path::new("out/plate/fragments/fragments.0012.shp"));
        assert_eq!(layout.fragment_points(3), Path::new("out/plate/fragments/points.0003.ply"));
        assert_eq!(layout.usd(), Path::new("out/plate/fragments/fragments.usda"));
        assert_eq!(layout.lead_in(), Path::new("out/plate/rigid/lead_in.shp"));
        assert_eq!(layout.lead_in_fragments(2), Path::new("out/plate/rigid/lead_in.0002.shp"));
        assert_eq!(layout.rigid_fragments(60), Path::new("out/plate/rigid/fragments.0060.shp"));
        assert_eq!(layout.rigid_checkpoint(), Path::new("out/plate/rigid/rigid.checkpoint.shp"));
        assert_eq!(layout.reentry(2), Path::new("out/plate/rigid/reentry.002.shp"));
        assert_eq!(layout.reentry_dir(2), Path::new("out/plate/reentry/002"));
        assert_eq!(layout.render_frame(240, "exr"), Path::new("out/plate/render/plate.0240.exr"));
        assert_eq!(layout.stamps(), Path::new("out/plate/stamps.json"));
        assert_eq!(layout.lock(), Path::new("out/plate/shatter.lock"));
        let message = missing_input(&layout.particles(), "preprocess").expect("no such file");
        assert_eq!(message, "out/plate/particles.shp: missing; run `shatter preprocess` first");
        assert_eq!(missing_input(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml").as_path(), "x"), None);
    }
}
