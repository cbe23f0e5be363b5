//! A full disk mid-stage: every stage fails with the I/O error (exit 1), never panics, and leaves
//! the outputs of the run before it byte-identical: no partial file under a real name, no
//! temporary left behind, a fresh simulation's predecessor put back in place. The full disk is a
//! file-size limit (`ulimit -f`) with SIGXFSZ ignored, so that writes fail with EFBIG as they
//! would with ENOSPC.

use std::process::Command;

use support::{SMALL_PLATE, shatter, stderr, tree_files};

use crate::support;

/// The small plate, run briefly and rendered small.
fn scene() -> String {
    format!(
        "{SMALL_PLATE}[sim]\nframes = 4\nsteps_per_frame = 5\n[render]\nbackend = \"cpu\"\nresolution = [64, 36]\n\
         samples_per_pixel = 1\n"
    )
}

#[test]
fn a_full_disk_fails_every_stage_and_keeps_the_previous_outputs() {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), scene()).expect("config");
    assert!(shatter(&["run"], dir.path()).status.success());
    let outputs = || tree_files(&dir.path().join("out"), &["shatter.lock"]);
    let before = outputs();
    // in 512-byte blocks: 4 KiB lets the stamp file through but no particle file, frame (11.5
    // KiB), checkpoint (16 KiB) or image; 12 KiB lets a fresh simulation write its frames, but not
    // its first checkpoint
    for (command, blocks) in [("preprocess", 8), ("sim", 8), ("sim", 24), ("post", 8), ("render", 8)] {
        let shatter = env!("CARGO_BIN_EXE_shatter");
        let script = format!("trap '' XFSZ; ulimit -f {blocks}; exec {shatter:?} {command}");
        let output = Command::new("sh").args(["-c", &script]).current_dir(dir.path()).output().expect("sh runs");
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(1), "{command}: {message}");
        assert!(message.contains("cannot write: File too large"), "{command}: {message}");
        assert!(!message.contains("panicked"), "{command}: {message}");
        let after = outputs();
        let names = |files: &[(String, Vec<u8>)]| files.iter().map(|(name, _)| name.clone()).collect::<Vec<_>>();
        assert_eq!(names(&after), names(&before), "{command}: the same files, and no others");
        assert!(after == before, "{command}: every previous output is byte-identical");
    }
    let output = shatter(&["run"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(tree_files(&dir.path().join("out"), &["shatter.lock"]) == before, "nothing was left to redo");
}
