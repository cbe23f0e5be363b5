//! `shatter run` for overnight work: killed with SIGKILL at random moments and run again, it ends
//! with the very same frames as an uninterrupted run; what is up to date is skipped.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Instant;

use support::{shatter, tree_files};

use crate::support;

const SCENE: &str = r#"
[scene]
name = "struck"
output_dir = "out"
seed = 5
[geometry]
source = "box"
box_size_m = [0.024, 0.024, 0.004]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
[sim]
frames = 16
steps_per_frame = 40
[[sim.projectile]]
center_m = [0.0, 0.0, 0.0067]
velocity_m_s = [0.0, 0.0, -150.0]
radius_m = 0.003
stiffness_pa = 3e6
[render]
backend = "cpu"
resolution = [64, 48]
samples_per_pixel = 2
[render.camera]
position_m = [0.02, 0.015, 0.05]
look_at_m = [0.0, 0.0, 0.0]
"#;

/// Every output file's bytes, by path relative to `out`, skipping the stamp file (its key order
/// is fixed, but it may hold stale entries of an interrupted run's earlier stages) and the lock
/// file (it holds the last writer's process id).
fn outputs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    tree_files(&dir.join("out"), &["stamps.json", "shatter.lock"])
}

#[test]
fn a_run_killed_five_times_ends_identical_to_an_uninterrupted_one() {
    let reference = tempfile::tempdir().expect("tempdir");
    std::fs::write(reference.path().join("pipeline.toml"), SCENE).expect("config");
    let started = Instant::now();
    let output = shatter(&["run"], reference.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let uninterrupted = started.elapsed();
    let expected = outputs(reference.path());
    assert!(expected.iter().any(|(name, _)| name.ends_with("struck.0016.exr")));

    let killed = tempfile::tempdir().expect("tempdir");
    std::fs::write(killed.path().join("pipeline.toml"), SCENE).expect("config");
    let mut rng = shatter_core::random::SplitMix64::new(2026);
    let mut kills = 0;
    for _ in 0..5 {
        let mut child = Command::new(env!("CARGO_BIN_EXE_shatter"))
            .arg("run")
            .current_dir(killed.path())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start");
        // each run gets 5 to 20% of an uninterrupted run's time: five kills land all over the
        // stages (preprocess, sim frames, post, render frames)
        let wait = uninterrupted.mul_f64(0.05 + 0.15 * rng.next_f64());
        std::thread::sleep(wait);
        if child.try_wait().expect("poll").is_none() {
            child.kill().expect("SIGKILL");
            kills += 1;
        }
        child.wait().expect("reap");
    }
    assert!(kills >= 3, "most runs were killed mid-way ({kills} of 5)");
    let output = shatter(&["run"], killed.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let resumed = outputs(killed.path());
    let names = |files: &[(String, Vec<u8>)]| files.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&resumed), names(&expected));
    for ((name, bytes), (_, expected_bytes)) in resumed.iter().zip(&expected) {
        assert!(bytes == expected_bytes, "{name} differs after five kills");
    }

    // Everything is up to date now: a third run skips every stage.
    let output = shatter(&["run"], killed.path());
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert_eq!(stdout.matches("up to date").count(), 4, "{stdout}");
}

#[test]
fn a_new_camera_renders_again_and_nothing_else() {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), SCENE.replace("frames = 16", "frames = 3")).expect("config");
    assert!(shatter(&["run"], dir.path()).status.success());
    let moved = SCENE
        .replace("frames = 16", "frames = 3")
        .replace("position_m = [0.02, 0.015, 0.05]", "position_m = [-0.02, 0.015, 0.05]");
    std::fs::write(dir.path().join("pipeline.toml"), moved).expect("config");
    let output = shatter(&["run"], dir.path());
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success());
    assert_eq!(stdout.matches("up to date").count(), 3, "preprocess, sim and post skipped: {stdout}");
    assert!(stdout.contains("3 of 3 frames"), "{stdout}");
}
