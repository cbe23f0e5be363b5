//! A rendered frame as Blender's compositor reads it: Debian's `blender` (which scripts/test.sh
//! installs) runs scripts/check_exr_in_blender.py on a frame of a small scene. Blender lists
//! every pass, its Denoise node takes the frame's Denoising Normal and Denoising Albedo as its
//! guides, and its Cryptomatte node finds both mattes.

use std::path::Path;
use std::process::Command;

use support::{shatter, stderr};

use crate::support;

#[test]
fn blender_reads_every_pass_and_takes_the_denoising_passes() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().expect("tempdir");
    // a small scene of two frames, blurred, with the denoising passes (the defaults)
    let scene = std::fs::read_to_string(root.join("tests/golden/unchanged_scene.toml")).expect("scene");
    let scene = scene.replace("shutter = 0.0\n", "").replace("denoising_passes = false\n", "");
    std::fs::write(dir.path().join("pipeline.toml"), scene).expect("config");
    let output = shatter(&["run"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let frame = dir.path().join("out/render/unchanged.0002.exr");
    let check = Command::new("blender")
        .args(["-b", "--factory-startup", "--python"])
        .arg(root.join("scripts/check_exr_in_blender.py"))
        .arg("--")
        .arg(&frame)
        .output()
        .expect("blender runs (scripts/test.sh installs Debian's blender)");
    let stdout = String::from_utf8_lossy(&check.stdout);
    assert!(
        check.status.success() && stdout.contains("  ok: "),
        "Blender's check failed:\n{stdout}{}",
        String::from_utf8_lossy(&check.stderr)
    );
    for pass in ["Denoising Albedo", "Denoising Normal"] {
        assert!(stdout.contains(&format!("{pass} -> ")), "{pass} not taken by the Denoise node:\n{stdout}");
    }
}
