//! A scene changed between runs never wedges its output folder: a checkpoint made from other
//! inputs is stale, not corrupt. `shatter run` starts the simulation over and says why;
//! `shatter sim --resume` says the checkpoint belongs to other inputs and how to start over
//! (exit code 2); and the outputs then equal a fresh run's. A stage run alone refuses frames or
//! fragments made from other inputs (exit code 2), by the digest they carry.

use crate::support;

use support::{folder_files, shatter, stderr};

fn scene(box_size: &str, spacing: &str, steps: u32) -> String {
    format!(
        r#"
[scene]
name = "changed"
output_dir = "out"
seed = 5
[geometry]
source = "box"
box_size_m = {box_size}
sampler = "grid"
spacing_m = {spacing}
horizon_factor = 3.0
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
[sim]
frames = 4
steps_per_frame = {steps}
gravity_m_s2 = [0.0, 0.0, 0.0]
initial_velocity_m_s = [0.0, 0.0, -1.0]
"#
    )
}

const BEFORE: (&str, &str, u32) = ("[0.012, 0.012, 0.004]", "0.001", 40);

/// A folder whose simulation ran to the end with the `BEFORE` scene, then got `config`.
fn simulated_then_changed(config: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), scene(BEFORE.0, BEFORE.1, BEFORE.2)).expect("config");
    let output = shatter(&["run", "--until", "sim"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    std::fs::write(dir.path().join("pipeline.toml"), config).expect("config");
    dir
}

/// (what changed, the new scene, what `sim --resume` says after a new preprocess).
fn changes() -> Vec<(&'static str, String, &'static str)> {
    vec![
        ("box size", scene("[0.016, 0.012, 0.004]", BEFORE.1, BEFORE.2), "the particle file changed"),
        ("spacing", scene(BEFORE.0, "0.0015", BEFORE.2), "the particle file changed"),
        ("steps per frame", scene(BEFORE.0, BEFORE.1, 30), "settings changed"),
    ]
}

#[test]
fn run_starts_a_stale_simulation_over_and_saying_why() {
    for (what, config, _) in changes() {
        let dir = simulated_then_changed(&config);
        for attempt in 0..2 {
            let output = shatter(&["run", "--until", "sim"], dir.path());
            assert!(output.status.success(), "{what}, run {attempt}: {}", stderr(&output));
            if attempt == 0 {
                assert!(stderr(&output).contains("simulating from the start"), "{what}: {}", stderr(&output));
            }
        }
        let fresh = tempfile::tempdir().expect("tempdir");
        std::fs::write(fresh.path().join("pipeline.toml"), &config).expect("config");
        assert!(shatter(&["run", "--until", "sim"], fresh.path()).status.success());
        assert!(
            folder_files(&dir.path().join("out/frames")) == folder_files(&fresh.path().join("out/frames")),
            "{what}: the frames differ from a fresh run's"
        );
    }
}

#[test]
fn resuming_a_stale_checkpoint_is_bad_input_that_says_how_to_start_over() {
    for (what, config, message) in changes() {
        let dir = simulated_then_changed(&config);
        assert!(shatter(&["preprocess"], dir.path()).status.success(), "{what}");
        let checkpoint = std::fs::read(dir.path().join("out/sim.checkpoint.shp")).expect("checkpoint");
        let output = shatter(&["sim", "--resume"], dir.path());
        let said = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{what}: {said}");
        assert!(said.contains(message) && said.contains("run without --resume"), "{what}: {said}");
        assert_eq!(std::fs::read(dir.path().join("out/sim.checkpoint.shp")).expect("checkpoint"), checkpoint, "{what}");
        let output = shatter(&["sim"], dir.path());
        assert!(output.status.success(), "{what}: {}", stderr(&output));
    }
}

#[test]
fn a_stage_run_alone_refuses_outputs_of_other_inputs() {
    // (what changed after sim and post ran, the stage then run alone, what it asks for)
    let before = scene(BEFORE.0, BEFORE.1, BEFORE.2);
    let cases = [
        ("[sim] steps per frame", scene(BEFORE.0, BEFORE.1, 30), "post", "run `shatter sim` again"),
        ("[material] stiffness", before.replace("14.9e9", "20e9"), "post", "run `shatter sim` again"),
        (
            "[sim] steps per frame",
            scene(BEFORE.0, BEFORE.1, 30),
            "render",
            "run `shatter sim` and `shatter post` again",
        ),
        ("[post] smoothing", format!("{before}[post]\nsmoothing_frames = 2.0\n"), "render", "and `shatter post` again"),
    ];
    for (what, config, stage, asks) in cases {
        let dir = simulated_then_changed(&before);
        let output = shatter(&["post"], dir.path());
        assert!(output.status.success(), "{what}: {}", stderr(&output));
        std::fs::write(dir.path().join("pipeline.toml"), &config).expect("config");
        let output = shatter(&[stage], dir.path());
        let said = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{what}, {stage}: {said}");
        assert!(said.contains("made from") && said.contains(asks), "{what}, {stage}: {said}");
    }
}
