//! One writer per output folder: an advisory lock on the folder's `shatter.lock`, taken by every
//! command that writes into the folder and held for the life of the command. The operating
//! system releases it when the process ends, however it ends, so a killed run never leaves a
//! stale lock behind. Readers (`shatter inspect`) take no lock.
//!
//! Renders share the folder ([`Access::Shared`]): a farm renders frame chunks of one shot at once,
//! each frame written atomically under its own name, while nothing else may write. Every other
//! writing command takes it alone ([`Access::Exclusive`]).
//!
//! The lock file holds the exclusive holder's process id as text, so that a second writer can
//! say who holds the folder.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::OutputLayout;

/// Why the output folder could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another process holds the folder.
    #[error(
        "{folder}: another shatter process ({holder}) is writing into this output folder; wait for it to end, or give \
         this scene another scene.output_dir"
    )]
    Busy {
        /// The output folder.
        folder: PathBuf,
        /// "pid N", or what is known of the holder.
        holder: String,
    },
    /// The folder or its lock file cannot be made or locked.
    #[error("{path}: cannot {action}: {source}")]
    Io {
        /// The folder or lock file.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// How a command holds its output folder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// Alone: preprocess, sim, post, run.
    Exclusive,
    /// Beside other shared holders, never beside an exclusive one: render (of disjoint frames).
    Shared,
}

/// The lock on an output folder, held until dropped.
#[derive(Debug)]
pub struct OutputLock {
    _file: File,
}

impl OutputLock {
    /// Creates the output folder if needed and locks it for this process with `access`, or fails
    /// at once with [`LockError::Busy`] naming the holder's process id when another process holds
    /// it in a way that excludes `access`.
    pub fn acquire(layout: &OutputLayout, access: Access) -> Result<OutputLock, LockError> {
        let folder = layout.root();
        let io = |path: &Path, action: &'static str| {
            let path = path.to_path_buf();
            move |source| LockError::Io { path, action, source }
        };
        std::fs::create_dir_all(folder).map_err(io(folder, "create the output folder"))?;
        let path = layout.lock();
        // Opened without truncating: the holder's process id stays readable until we hold it.
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(io(&path, "open"))?;
        let locked = match access {
            Access::Exclusive => file.try_lock(),
            Access::Shared => file.try_lock_shared(),
        };
        match locked {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let mut text = String::new();
                let holder = match file.read_to_string(&mut text) {
                    Ok(_) if text.trim().starts_with("pid ") && access == Access::Shared => text.trim().to_owned(),
                    Ok(_) if text.trim().starts_with("pid ") => {
                        format!("{}, or renders sharing the folder", text.trim())
                    }
                    _ => "pid unknown".to_owned(),
                };
                return Err(LockError::Busy { folder: folder.to_path_buf(), holder });
            }
            Err(TryLockError::Error(source)) => return Err(LockError::Io { path, action: "lock", source }),
        }
        if access == Access::Shared {
            // shared holders leave the last exclusive holder's id: they must not write at once
            return Ok(OutputLock { _file: file });
        }
        file.set_len(0).map_err(io(&path, "write"))?;
        file.seek(SeekFrom::Start(0)).map_err(io(&path, "write"))?;
        writeln!(file, "pid {}", std::process::id()).map_err(io(&path, "write"))?;
        Ok(OutputLock { _file: file })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_writer_is_refused_with_the_holders_pid_until_the_first_lets_go() {
        let dir = tempfile::tempdir().expect("tempdir");
        let layout = OutputLayout::new(dir.path().join("out"), "t");
        let first = OutputLock::acquire(&layout, Access::Exclusive).expect("first lock");
        let message = OutputLock::acquire(&layout, Access::Exclusive).expect_err("second lock").to_string();
        assert!(message.contains(&format!("pid {}", std::process::id())), "{message}");
        assert!(message.contains(&layout.root().display().to_string()), "{message}");
        drop(first);
        let again = OutputLock::acquire(&layout, Access::Exclusive).expect("free again");
        assert_eq!(std::fs::read_to_string(layout.lock()).expect("lock file"), format!("pid {}\n", std::process::id()));
        assert!(OutputLock::acquire(&layout, Access::Shared).is_err(), "no render beside a writer");
        drop(again);
    }

    #[test]
    fn renders_share_the_folder_and_keep_every_other_writer_out() {
        let dir = tempfile::tempdir().expect("tempdir");
        let layout = OutputLayout::new(dir.path().join("out"), "t");
        let first = OutputLock::acquire(&layout, Access::Shared).expect("a render");
        let second = OutputLock::acquire(&layout, Access::Shared).expect("another render beside it");
        let message = OutputLock::acquire(&layout, Access::Exclusive).expect_err("a writer").to_string();
        assert!(message.contains("another shatter process"), "{message}");
        drop((first, second));
        assert!(OutputLock::acquire(&layout, Access::Exclusive).is_ok(), "free once the renders end");
    }
}
