//! What `shatter sim` writes per frame into the frames folder: a binary PLY point cache
//! ([`point_frame`]: position, velocity, damage; readable by Blender and Houdini) and the
//! append-only bond-break log ([`break_log`]).
//!
//! Both are checksummed: the PLY header carries a CRC-32 of its body in a comment (see
//! [`crate::ply`]), and each block of the break log carries one of its records. Formats:
//! docs/FORMATS.md.

pub mod break_log;
pub mod point_frame;

use std::path::{Path, PathBuf};

use crate::ply::PlyError;

pub use break_log::{BreakBlock, BreakEvent, BreakLog};
pub use point_frame::PointFrame;

/// Why a frame file or the break log could not be written or read. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum FrameFileError {
    /// The operating system refused an operation.
    #[error("{path}: cannot {action}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A point cache could not be read or written.
    #[error(transparent)]
    Ply(#[from] PlyError),
    /// The file is not what it should be.
    #[error("{path}: {what}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
}

pub(crate) fn io_error<'a>(path: &'a Path, action: &'static str) -> impl FnOnce(std::io::Error) -> FrameFileError + 'a {
    move |source| FrameFileError::Io { path: path.to_path_buf(), action, source }
}

pub(crate) fn invalid(path: &Path, what: impl Into<String>) -> FrameFileError {
    FrameFileError::Invalid { path: path.to_path_buf(), what: what.into() }
}
