//! `shatter sim` as users meet it: outputs, resume after a kill, refusals of bad input.

use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn shatter(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shatter")).args(args).current_dir(dir).output().expect("shatter runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// A plate struck by a projectile, `frames` frames of `steps` steps.
fn scene(side: usize, frames: u32, steps: u32, extra_sim: &str) -> String {
    scene_of(GLASS, side, frames, steps, extra_sim)
}

/// PMB glass.
const GLASS: &str = "density_kg_m3 = 2200.0\nbulk_modulus_pa = 14.9e9";

/// An elastoplastic metal that dents, yields and tears.
const METAL: &str = "model = \"elastoplastic\"\ndensity_kg_m3 = 2700.0\nyoungs_modulus_pa = 7e9\npoisson_ratio = 0.33\n\
                     yield_stress_pa = 2e7\nplastic_cap_ratio = 0.05\ncritical_stretch = 0.004";

/// An elastoplastic steel: stiffer and heavier than glass, so it needs a shorter step.
const STEEL: &str = "model = \"elastoplastic\"\ndensity_kg_m3 = 7850.0\nyoungs_modulus_pa = 2e11\npoisson_ratio = 0.4\n\
                     yield_stress_pa = 2.5e8\nplastic_cap_ratio = 0.05\ncritical_stretch = 0.004";

/// [`scene`] of the `[material]` keys `material`.
fn scene_of(material: &str, side: usize, frames: u32, steps: u32, extra_sim: &str) -> String {
    let size = side as f64 * 0.001;
    format!(
        r#"
[scene]
name = "struck"
output_dir = "out"
seed = 2
[geometry]
source = "box"
box_size_m = [{size}, {size}, 0.004]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0
[material]
{material}
[sim]
frames = {frames}
steps_per_frame = {steps}
gravity_m_s2 = [0.0, 0.0, 0.0]
{extra_sim}
[[sim.projectile]]
center_m = [0.0, 0.0, 0.0067]
velocity_m_s = [0.0, 0.0, -150.0]
radius_m = 0.003
stiffness_pa = 3e7
"#
    )
}

fn folder_with(config: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), config).expect("write config");
    dir
}

fn frame_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir.join("out/frames"))
        .expect("frames folder")
        .map(|entry| {
            let entry = entry.expect("entry");
            (entry.file_name().to_string_lossy().into_owned(), std::fs::read(entry.path()).expect("read"))
        })
        .collect();
    files.sort();
    files
}

#[test]
fn a_killed_run_resumes_to_bit_identical_frames() {
    killed_and_resumed(&scene(30, 40, 60, ""));
}

/// The elastoplastic model's plastic extensions travel in the checkpoint: its resumed frames
/// are bit for bit those of an uninterrupted run too.
#[test]
fn a_killed_elastoplastic_run_resumes_to_bit_identical_frames() {
    let reference = killed_and_resumed(&scene_of(METAL, 30, 40, 60, ""));
    let checkpoint = reference.path().join("out/sim.checkpoint.shp");
    let (_, state) = shatter_core::checkpoint::read(&checkpoint).expect("checkpoint");
    let yielded = state.bond_state.iter().filter(|p| **p != 0.0).count();
    assert!(yielded > 100, "the plate should yield: {yielded} plastic bond entries");
}

/// Runs `config` whole, then again killed at frame 6 and resumed: the frames must be the same.
/// Returns the folder of the uninterrupted run.
fn killed_and_resumed(config: &str) -> tempfile::TempDir {
    let config = config.to_owned();
    let reference = folder_with(&config);
    let output = shatter(&["run", "--until", "sim"], reference.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let expected = frame_files(reference.path());
    assert_eq!(expected.iter().filter(|(name, _)| name.ends_with(".ply")).count(), 40);
    let log = &expected.iter().find(|(name, _)| name == "breaks.log").expect("log").1;
    assert!(log.len() > 16 + 39 * 16, "bonds broke: the log has records");

    let killed = folder_with(&config);
    assert!(shatter(&["preprocess"], killed.path()).status.success());
    let mut child = Command::new(env!("CARGO_BIN_EXE_shatter"))
        .arg("sim")
        .current_dir(killed.path())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("start sim");
    let started = Instant::now();
    while !killed.path().join("out/frames/points.0006.ply").exists() {
        assert!(started.elapsed() < Duration::from_secs(120), "sim too slow to reach frame 6");
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().expect("SIGKILL");
    let status = child.wait().expect("reap");
    assert!(!status.success(), "the run was killed before it finished");
    let written = frame_files(killed.path()).iter().filter(|(name, _)| name.ends_with(".ply")).count();
    assert!(written < 40, "killed mid-run ({written} frames written)");

    let output = shatter(&["sim", "--resume"], killed.path());
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(String::from_utf8_lossy(&output.stdout).contains("frames "), "{}", String::from_utf8_lossy(&output.stdout));
    let resumed = frame_files(killed.path());
    assert_eq!(resumed.len(), expected.len());
    for ((name, bytes), (expected_name, expected_bytes)) in resumed.iter().zip(&expected) {
        assert_eq!(name, expected_name);
        assert!(bytes == expected_bytes, "{name} differs after resume");
    }
    reference
}

#[test]
fn bad_simulation_input_is_refused_clearly() {
    // a truncated particle file
    let dir = folder_with(&scene(10, 2, 10, ""));
    assert!(shatter(&["preprocess"], dir.path()).status.success());
    let particles = dir.path().join("out/particles.shp");
    let bytes = std::fs::read(&particles).expect("read");
    std::fs::write(&particles, &bytes[..bytes.len() / 2]).expect("truncate");
    let output = shatter(&["sim"], dir.path());
    assert_eq!(output.status.code(), Some(1));
    assert!(stderr(&output).contains("particles.shp") && stderr(&output).contains("truncated"), "{}", stderr(&output));

    // a time step above the stable one
    let dir = folder_with(&scene(10, 2, 10, "dt_s = 1e-6"));
    let output = shatter(&["run", "--until", "sim"], dir.path());
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("sim.dt_s = 1e-6 s exceeds the stable time step"), "{}", stderr(&output));
    // ... which --allow-unstable-dt runs, until the energy runs away: the frames before stay
    let output = shatter(&["sim", "--allow-unstable-dt"], dir.path());
    assert_eq!(output.status.code(), Some(1), "{}", stderr(&output));
    assert!(stderr(&output).contains("became unstable"), "{}", stderr(&output));
    // ... and what the message says is there, is there
    assert!(stderr(&output).contains("frames up to 1 are written; no checkpoint was reached"), "{}", stderr(&output));
    assert!(dir.path().join("out/frames/points.0001.ply").exists());
    assert!(!dir.path().join("out/sim.checkpoint.shp").exists());

    // a projectile starting inside the body
    let inside = scene(10, 2, 10, "").replace("center_m = [0.0, 0.0, 0.0067]", "center_m = [0.0, 0.0, 0.001]");
    let dir = folder_with(&inside);
    let output = shatter(&["run", "--until", "sim"], dir.path());
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("sim.projectile[0] starts inside or touching the body"), "{}", stderr(&output));

    // particles made with other geometry settings
    let dir = folder_with(&scene(10, 2, 10, ""));
    assert!(shatter(&["preprocess"], dir.path()).status.success());
    let config = std::fs::read_to_string(dir.path().join("pipeline.toml")).expect("read");
    std::fs::write(dir.path().join("pipeline.toml"), config.replace("horizon_factor = 3.0", "horizon_factor = 2.0"))
        .expect("write");
    let output = shatter(&["sim"], dir.path());
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("run `shatter preprocess` again"), "{}", stderr(&output));
}

#[test]
fn resuming_with_changed_settings_is_refused() {
    let dir = folder_with(&scene(10, 3, 10, ""));
    assert!(shatter(&["run", "--until", "sim"], dir.path()).status.success());
    let config = std::fs::read_to_string(dir.path().join("pipeline.toml")).expect("read");
    std::fs::write(dir.path().join("pipeline.toml"), config.replace("frames = 3", "frames = 5\nbreak_rule = \"min\""))
        .expect("write");
    let output = shatter(&["sim", "--resume"], dir.path());
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("settings changed since this checkpoint"), "{}", stderr(&output));
}

/// The files of a finished simulation: frames, break log, checkpoint.
fn simulation_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = frame_files(dir);
    files.push(("checkpoint".into(), std::fs::read(dir.join("out/sim.checkpoint.shp")).expect("checkpoint")));
    files
}

#[test]
fn a_failing_fresh_run_puts_the_previous_results_back() {
    let dir = folder_with(&scene(10, 4, 20, "checkpoint_every_frames = 2"));
    assert!(shatter(&["run", "--until", "sim"], dir.path()).status.success());
    let good = simulation_files(dir.path());

    // the same scene with a time step that blows up in the second frame, before any checkpoint
    std::fs::write(dir.path().join("pipeline.toml"), scene(10, 4, 20, "checkpoint_every_frames = 2\ndt_s = 1e-5"))
        .expect("config");
    let output = shatter(&["sim", "--allow-unstable-dt"], dir.path());
    assert_eq!(output.status.code(), Some(1), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("the previous run's frames and checkpoint are back in place"),
        "{}",
        stderr(&output)
    );
    assert!(simulation_files(dir.path()) == good, "the previous run's outputs are byte-identical");
    assert!(
        !dir.path().join("out/frames.previous").exists()
            && !dir.path().join("out/sim.checkpoint.previous.shp").exists()
    );

    // a fresh run that gets as far as a checkpoint replaces them, and leaves nothing aside
    std::fs::write(dir.path().join("pipeline.toml"), scene(10, 4, 25, "checkpoint_every_frames = 2")).expect("config");
    let output = shatter(&["sim"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(simulation_files(dir.path()) != good);
    assert!(
        !dir.path().join("out/frames.previous").exists()
            && !dir.path().join("out/sim.checkpoint.previous.shp").exists()
    );
}

#[test]
fn a_projectile_that_would_throw_particles_through_itself_is_refused_by_its_key() {
    // 3e12 Pa: its largest force, K_S r^2 = 2.7e7 N, moves a 2.2e-6 kg cube 0.87 m in a set step
    // of 2^-23 s, where it acts over 2.25 mm
    let text = scene(10, 2, 5, "dt_s = 1.1920928955078125e-7").replace("stiffness_pa = 3e7", "stiffness_pa = 3e12");
    let dir = folder_with(&text);
    let output = shatter(&["run", "--until", "sim"], dir.path());
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("lets sim.projectile[0].stiffness_pa = 3e12 throw a particle of 2.200e-6 kg across"),
        "{}",
        stderr(&output)
    );
    assert!(!dir.path().join("out/frames").exists(), "refused before anything was written");
    let output = shatter(&["sim", "--allow-unstable-dt"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stderr(&output).contains("at which sim.projectile[0].stiffness_pa holds particles"), "{}", stderr(&output));
    // unset, the step is taken under the projectile's bound, sqrt(2.25e-3 m x 2.2e-6 kg / 2.7e7 N)
    // = 1.354e-8 s: half of it, down to a power of two
    let dir = folder_with(&scene(10, 2, 5, "").replace("stiffness_pa = 3e7", "stiffness_pa = 3e12"));
    let output = shatter(&["run", "--until", "sim"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    let said = "dt 3.725e-9 s = 2^-28 (unset sim.dt_s: the largest power of two at most 0.5 x 1.354e-8 s, the pushing";
    assert!(stdout.contains(said), "{stdout}");
}

/// `--simd` and `SHATTER_SIMD` pick the CPU kernels' instruction set: every path this CPU has
/// writes the same frames, the summary names the path, and an unknown name or a path the CPU
/// lacks is exit 2 naming where it came from.
#[test]
fn every_simd_path_writes_the_same_frames_and_a_bad_one_is_refused_by_name() {
    let config = scene(12, 4, 40, "backend = \"cpu\"");
    let mut frames = Vec::new();
    for path in ["portable", "avx2", "avx512"] {
        let dir = folder_with(&config);
        let output = shatter(&["run", "--until", "sim", "--simd", path], dir.path());
        if output.status.success() {
            let summary = String::from_utf8_lossy(&output.stdout);
            assert!(summary.contains(&format!(", {path} kernels:")), "{summary}");
            frames.push((path, frame_files(dir.path())));
        } else {
            assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
            assert!(stderr(&output).contains(&format!("--simd = {path}: this CPU cannot run")), "{}", stderr(&output));
        }
    }
    assert_eq!(frames[0].0, "portable", "the portable path runs everywhere");
    for (path, files) in &frames[1..] {
        assert!(*files == frames[0].1, "the {path} path's frames differ from the portable path's");
    }

    let dir = folder_with(&config);
    let output = shatter(&["sim", "--simd", "sse9"], dir.path());
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("sse9") && stderr(&output).contains("portable, avx2, avx512"),
        "{}",
        stderr(&output)
    );
    let output = Command::new(env!("CARGO_BIN_EXE_shatter"))
        .args(["run", "--until", "sim"])
        .env("SHATTER_SIMD", "sse9")
        .current_dir(dir.path())
        .output()
        .expect("shatter runs");
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("SHATTER_SIMD: unknown SIMD path \"sse9\""), "{}", stderr(&output));
}

#[test]
fn a_steel_box_without_a_time_step_runs_at_one_from_its_material_and_says_which() {
    let dir = folder_with(&scene_of(STEEL, 8, 3, 20, ""));
    assert!(shatter(&["preprocess"], dir.path()).status.success());
    let output = shatter(&["sim"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    // its stable step is 9e-8 s: half of it, down to a power of two
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("dt 2.980e-8 s = 2^-25 (unset sim.dt_s"), "{stdout}");
    // the frames record it, and post takes it from them
    let frame = shatter_core::frames::PointFrame::read(&dir.path().join("out/frames/points.0002.ply")).expect("frame");
    assert_eq!((frame.step, frame.time_s), (20, 20.0 * 2f64.powi(-25)));
    let output = shatter(&["post"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));

    // glass's 2^-23 s, set: post refuses the frames of the material's step ...
    let glass_step = scene_of(STEEL, 8, 3, 20, "dt_s = 1.1920928955078125e-7");
    std::fs::write(dir.path().join("pipeline.toml"), glass_step).expect("config");
    let output = shatter(&["post"], dir.path());
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("points.0002.ply: simulated at another time step"), "{}", stderr(&output));
    // ... and the simulation refuses the step, which is over steel's stable step
    let output = shatter(&["sim"], dir.path());
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("exceeds the stable time step"), "{}", stderr(&output));

    // frames taken at a set 2^-23 s (past the stable step, with --allow-unstable-dt): resuming
    // them with the step unset, whose settings digest alike, is refused by the step
    std::fs::write(dir.path().join("pipeline.toml"), scene_of(STEEL, 8, 3, 2, "dt_s = 1.1920928955078125e-7"))
        .expect("config");
    let output = shatter(&["sim", "--allow-unstable-dt"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    std::fs::write(dir.path().join("pipeline.toml"), scene_of(STEEL, 8, 3, 2, "")).expect("config");
    let output = shatter(&["sim", "--resume"], dir.path());
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    let said =
        "the frames were simulated at a step of 1.1920928955078125e-7 s and this run takes 2.9802322387695313e-8 s";
    assert!(stderr(&output).contains(said), "{}", stderr(&output));

    // a simulation of one frame takes no step, so none would record the material's
    std::fs::write(dir.path().join("pipeline.toml"), scene_of(STEEL, 8, 1, 20, "")).expect("config");
    let output = shatter(&["sim"], dir.path());
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("sim.dt_s is unset and the simulation writes one frame"), "{}", stderr(&output));
}
