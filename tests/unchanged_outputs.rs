//! A scene without the shot tables (`[lead_in]`, `[rigid]`, `[timeline]`) writes byte for byte
//! what shatter wrote before they existed: each output file's CRC-32 and size against
//! `tests/golden/unchanged_scene.crc32`, recorded by the build of commit 4c31523 (the last
//! before the rigid phases) on the scene `tests/golden/unchanged_scene.toml`.

use std::path::Path;

use support::{shatter, stderr, tree_files};

use crate::support;

#[test]
fn a_scene_without_the_shot_tables_writes_what_it_always_wrote() {
    let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden");
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::copy(golden.join("unchanged_scene.toml"), dir.path().join("pipeline.toml")).expect("scene");
    let output = shatter(&["run"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    // the lock and stamps are bookkeeping; the checkpoint names the thread count it ran on
    let files = tree_files(&dir.path().join("out"), &["shatter.lock", "stamps.json", "sim.checkpoint.shp"]);
    let listing: Vec<String> =
        files.iter().map(|(name, bytes)| format!("{name} {:08x} {}", crc32fast::hash(bytes), bytes.len())).collect();
    let expected = std::fs::read_to_string(golden.join("unchanged_scene.crc32")).expect("checksums");
    let expected: Vec<&str> = expected.lines().collect();
    let differing: Vec<String> = listing
        .iter()
        .filter(|line| !expected.contains(&line.as_str()))
        .cloned()
        .chain(
            expected.iter().filter(|line| !listing.contains(&line.to_string())).map(|line| format!("missing: {line}")),
        )
        .collect();
    assert!(differing.is_empty(), "{} of {} files differ:\n{}", differing.len(), expected.len(), differing.join("\n"));
}
