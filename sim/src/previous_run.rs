//! A fresh simulation never destroys the results of the one before it until it has results of
//! its own: the previous frames folder and checkpoint are set aside (renamed) when a fresh run
//! starts, deleted when the new run writes its first checkpoint, and put back when the new run
//! fails before that. A run killed before its first checkpoint leaves them set aside; the next
//! fresh start keeps them set aside (its own partial frames are the ones discarded) until a run
//! gets as far as a checkpoint.

use std::path::{Path, PathBuf};

use shatter_core::OutputLayout;
use shatter_core::frames::FrameFileError;

/// The previous run's outputs, set aside.
#[derive(Debug)]
pub struct PreviousRun {
    frames: PathBuf,
    checkpoint: PathBuf,
    set_aside_frames: PathBuf,
    set_aside_checkpoint: PathBuf,
}

fn io_error(path: &Path, action: &'static str) -> impl FnOnce(std::io::Error) -> FrameFileError {
    let path = path.to_path_buf();
    move |source| FrameFileError::Io { path, action, source }
}

fn remove_folder(path: &Path) -> Result<(), FrameFileError> {
    match std::fs::remove_dir_all(path) {
        Err(error) if error.kind() != std::io::ErrorKind::NotFound => Err(io_error(path, "remove")(error)),
        _ => Ok(()),
    }
}

fn remove_file(path: &Path) -> Result<(), FrameFileError> {
    match std::fs::remove_file(path) {
        Err(error) if error.kind() != std::io::ErrorKind::NotFound => Err(io_error(path, "remove")(error)),
        _ => Ok(()),
    }
}

impl PreviousRun {
    /// Before a fresh run: sets the frames folder and the checkpoint aside, and leaves an empty
    /// frames folder. `None` when there was nothing to keep. Outputs already set aside by a run
    /// killed before its first checkpoint stay set aside, and what that run wrote is removed.
    pub fn set_aside(layout: &OutputLayout) -> Result<Option<PreviousRun>, FrameFileError> {
        let previous = PreviousRun {
            frames: layout.frames_dir(),
            checkpoint: layout.checkpoint(),
            set_aside_frames: layout.previous_frames_dir(),
            set_aside_checkpoint: layout.previous_checkpoint(),
        };
        let already_aside = previous.set_aside_frames.exists() || previous.set_aside_checkpoint.exists();
        let something_now = previous.frames.exists() || previous.checkpoint.exists();
        if already_aside {
            remove_folder(&previous.frames)?;
            remove_file(&previous.checkpoint)?;
        } else if something_now {
            if previous.frames.exists() {
                std::fs::rename(&previous.frames, &previous.set_aside_frames)
                    .map_err(io_error(&previous.frames, "set aside"))?;
            }
            if previous.checkpoint.exists() {
                std::fs::rename(&previous.checkpoint, &previous.set_aside_checkpoint)
                    .map_err(io_error(&previous.checkpoint, "set aside"))?;
            }
        }
        std::fs::create_dir_all(&previous.frames).map_err(io_error(&previous.frames, "create the folder"))?;
        Ok((already_aside || something_now).then_some(previous))
    }

    /// The new run has a checkpoint: the previous run's outputs go.
    pub fn discard(self) -> Result<(), FrameFileError> {
        remove_folder(&self.set_aside_frames)?;
        remove_file(&self.set_aside_checkpoint)
    }

    /// The new run failed before its first checkpoint: its frames go and the previous run's
    /// outputs come back.
    pub fn restore(self) -> Result<(), FrameFileError> {
        remove_folder(&self.frames)?;
        remove_file(&self.checkpoint)?;
        if self.set_aside_frames.exists() {
            std::fs::rename(&self.set_aside_frames, &self.frames)
                .map_err(io_error(&self.set_aside_frames, "restore"))?;
        }
        if self.set_aside_checkpoint.exists() {
            std::fs::rename(&self.set_aside_checkpoint, &self.checkpoint)
                .map_err(io_error(&self.set_aside_checkpoint, "restore"))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(path: &Path, text: &str) {
        std::fs::create_dir_all(path.parent().expect("parent")).expect("mkdir");
        std::fs::write(path, text).expect("write");
    }

    #[test]
    fn the_previous_run_comes_back_after_a_failure_and_goes_after_a_checkpoint() {
        let dir = tempfile::tempdir().expect("tempdir");
        let layout = OutputLayout::new(dir.path(), "t");
        write(&layout.frame_points(1), "old frame");
        write(&layout.checkpoint(), "old checkpoint");

        let aside = PreviousRun::set_aside(&layout).expect("set aside").expect("something to keep");
        assert!(layout.frames_dir().is_dir() && !layout.frame_points(1).exists() && !layout.checkpoint().exists());
        write(&layout.frame_points(1), "new frame");
        aside.restore().expect("restore");
        assert_eq!(std::fs::read_to_string(layout.frame_points(1)).expect("frame"), "old frame");
        assert_eq!(std::fs::read_to_string(layout.checkpoint()).expect("checkpoint"), "old checkpoint");

        // killed before its first checkpoint, then started again: the old run stays aside
        let _killed = PreviousRun::set_aside(&layout).expect("set aside");
        write(&layout.frame_points(1), "partial frame");
        let aside = PreviousRun::set_aside(&layout).expect("set aside again").expect("still kept");
        assert!(!layout.frame_points(1).exists(), "the killed run's partial frames are gone");
        aside.restore().expect("restore");
        assert_eq!(std::fs::read_to_string(layout.frame_points(1)).expect("frame"), "old frame");

        let aside = PreviousRun::set_aside(&layout).expect("set aside").expect("something to keep");
        write(&layout.checkpoint(), "new checkpoint");
        aside.discard().expect("discard");
        assert!(!layout.previous_frames_dir().exists() && !layout.previous_checkpoint().exists());
        assert_eq!(std::fs::read_to_string(layout.checkpoint()).expect("checkpoint"), "new checkpoint");
        assert!(PreviousRun::set_aside(&OutputLayout::new(dir.path().join("empty"), "t")).expect("empty").is_none());
    }
}
