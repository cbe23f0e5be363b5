//! [`FrameFileError`]: why a frame file or the break log could not be written or read.

use std::path::{Path, PathBuf};

use crate::ply::PlyError;

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

/// Turns an I/O error of `action` on `path` into a [`FrameFileError::Io`].
pub(super) fn io_error<'a>(path: &'a Path, action: &'static str) -> impl FnOnce(std::io::Error) -> FrameFileError + 'a {
    move |source| FrameFileError::Io { path: path.to_path_buf(), action, source }
}

/// A [`FrameFileError::Invalid`] of `path`: `what` is wrong.
pub(super) fn invalid(path: &Path, what: impl Into<String>) -> FrameFileError {
    FrameFileError::Invalid { path: path.to_path_buf(), what: what.into() }
}
