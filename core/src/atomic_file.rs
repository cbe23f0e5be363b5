//! Writing files so that a crash never leaves a half-written one under its real name: written
//! under a temporary name in the same folder, fsynced, then renamed; and sweeping the temporary
//! files that killed processes left behind.

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// The temporary name a file is written under before it replaces `path`: hidden, in the same
/// folder (so the rename is atomic), unique to this process.
pub(crate) fn temporary_path(path: &Path) -> PathBuf {
    let file_name = path.file_name().map(|name| name.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{file_name}.partial-{}", std::process::id()))
}

/// Deletes the temporary files that killed processes left in `folder` and its subfolders (two
/// levels deep, as deep as a scene's output goes): files named like `temporary_path`'s whose
/// process no longer runs. A file of a live process (another run writing here) is left alone.
/// Returns how many were deleted; a folder that does not exist has none.
pub fn remove_abandoned_temporaries(folder: &Path) -> io::Result<usize> {
    let mut removed = 0;
    let mut folders = vec![(folder.to_path_buf(), 0)];
    while let Some((folder, depth)) = folders.pop() {
        let entries = match std::fs::read_dir(&folder) {
            Ok(entries) => entries,
            Err(error) if error.kind() == io::ErrorKind::NotFound => continue,
            Err(error) => return Err(error),
        };
        for entry in entries {
            let entry = entry?;
            let path = entry.path();
            if entry.file_type()?.is_dir() {
                if depth < 2 {
                    folders.push((path, depth + 1));
                }
                continue;
            }
            let name = entry.file_name().to_string_lossy().into_owned();
            let owner = name.strip_prefix('.').and_then(|rest| rest.rsplit_once(".partial-")).map(|(_, pid)| pid);
            let Some(pid) = owner.and_then(|pid| pid.parse::<u32>().ok()) else { continue };
            if !process_is_running(pid) {
                std::fs::remove_file(&path)?;
                removed += 1;
            }
        }
    }
    Ok(removed)
}

/// Whether process `pid` runs: this one always; others by `/proc` where there is one, else
/// assumed gone.
fn process_is_running(pid: u32) -> bool {
    pid == std::process::id() || Path::new("/proc").join(pid.to_string()).exists()
}

/// Renames the finished, fsynced `temp` over `path` and makes the rename durable.
pub(crate) fn publish(temp: &Path, path: &Path) -> io::Result<()> {
    std::fs::rename(temp, path)?;
    if let Some(folder) = path.parent().filter(|folder| !folder.as_os_str().is_empty()) {
        // Not every filesystem lets a folder be synced; the rename itself is already atomic.
        if let Ok(folder) = File::open(folder) {
            let _ = folder.sync_all();
        }
    }
    Ok(())
}

/// Writes `parts` to `path` atomically: to a temporary file in the same folder, fsynced, then
/// renamed. A crash leaves either the old file or the new one, never a mix.
pub fn write_atomically(path: &Path, parts: &[&[u8]]) -> io::Result<()> {
    let temp = temporary_path(path);
    let result = (|| {
        let mut file = File::create(&temp)?;
        for part in parts {
            file.write_all(part)?;
        }
        file.sync_all()?;
        publish(&temp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn abandoned_temporaries_are_swept_and_live_ones_kept() {
        let dir = tempfile::tempdir().expect("tempdir");
        let frames = dir.path().join("frames");
        std::fs::create_dir(&frames).expect("mkdir");
        // Linux pids never reach 2^31; these processes cannot run
        let dead =
            [dir.path().join(".particles.shp.partial-2147483000"), frames.join(".points.0002.ply.partial-2147483001")];
        let live = temporary_path(&frames.join("points.0003.ply"));
        let keep = [frames.join("points.0001.ply"), dir.path().join("notes.partial-12"), live.clone()];
        for path in dead.iter().chain(&keep) {
            std::fs::write(path, b"x").expect("write");
        }
        assert_eq!(remove_abandoned_temporaries(dir.path()).expect("sweep"), 2);
        assert!(dead.iter().all(|path| !path.exists()));
        assert!(keep.iter().all(|path| path.exists()));
        assert_eq!(remove_abandoned_temporaries(&dir.path().join("missing")).expect("no folder"), 0);
    }
}
