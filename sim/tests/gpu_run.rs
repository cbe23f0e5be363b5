//! `shatter sim` on the GPU backend: the frame loop, checkpoints and resume are the CPU's, and a
//! run killed mid-way and resumed writes the same bytes as an uninterrupted one. Also the
//! choice of backend.

use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use shatter_core::config::PipelineConfig;
use shatter_core::config::sim::BackendChoice;
use shatter_core::particles::ParticleSet;
use shatter_core::{NoProgress, OutputLayout, Progress};
use shatter_gpu::{AdapterChoice, GpuContext};
use shatter_sim::backend_choice::BackendError;
use shatter_sim::gpu::{GpuOptions, GpuSimulation};
use shatter_sim::sim_driver::{RunOptions, run_with};
use shatter_sim::{Backend, Model, art, create_backend};

fn gpu() -> &'static GpuContext {
    GpuContext::shared_for_tests().unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"))
}

/// PMB glass.
const GLASS: &str = "density_kg_m3 = 2200.0\nbulk_modulus_pa = 14.9e9";

/// An elastoplastic metal that dents, yields and tears (the CLI tests').
const METAL: &str = "model = \"elastoplastic\"\ndensity_kg_m3 = 2700.0\nyoungs_modulus_pa = 7e9\npoisson_ratio = 0.33\n\
                     yield_stress_pa = 2e7\nplastic_cap_ratio = 0.05\ncritical_stretch = 0.004";

fn scene(dir: &Path) -> PipelineConfig {
    scene_of(dir, GLASS)
}

/// A plate struck by a projectile, of the `[material]` keys `material`, preprocessed in `dir`.
fn scene_of(dir: &Path, material: &str) -> PipelineConfig {
    let text = format!(
        r#"
[scene]
name = "struck"
output_dir = "out"
seed = 2
[geometry]
source = "box"
box_size_m = [0.02, 0.02, 0.004]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0
[material]
{material}
[sim]
frames = 12
steps_per_frame = 60
gravity_m_s2 = [0.0, -9.81, 0.0]
[[sim.projectile]]
center_m = [0.0, 0.0, 0.0067]
velocity_m_s = [0.0, 0.0, -150.0]
radius_m = 0.003
stiffness_pa = 3e7
"#
    );
    let path = dir.join("pipeline.toml");
    std::fs::write(&path, text).expect("write config");
    let config = PipelineConfig::load(&path).expect("config");
    let particles = shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles;
    std::fs::create_dir_all(config.output_dir()).expect("output folder");
    particles.write(&OutputLayout::of(&config).particles()).expect("particles");
    config
}

type Made = Result<(Box<dyn Backend>, Option<String>), BackendError>;

fn on_gpu(config: &PipelineConfig, particles: &ParticleSet) -> Made {
    let model = Model::new(config, particles)?;
    let factors = art::threshold_factors(&config.sim, particles, config.scene.seed)?;
    let correction = config.sim.stiffness_correction;
    let sim =
        GpuSimulation::new(gpu().into(), particles, model, factors.as_deref(), correction, &GpuOptions::default())?;
    Ok((Box::new(sim), None))
}

fn frame_files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(dir.join("out/frames"))
        .expect("frames")
        .map(|e| {
            let path = e.expect("entry").path();
            let bytes = std::fs::read(&path).expect("read");
            (path.file_name().expect("name").into(), bytes)
        })
        .collect();
    files.sort();
    files
}

/// Panics (as a kill would stop the process) after `limit` steps.
struct Killer {
    steps: AtomicU64,
    limit: u64,
}

impl Progress for Killer {
    fn start(&self, _phase: &str, _total: u64) {}
    fn advance(&self, units: u64) {
        if self.steps.fetch_add(units, Ordering::SeqCst) + units >= self.limit {
            panic!("killed");
        }
    }
    fn finish(&self) {}
}

#[test]
fn a_gpu_run_killed_and_resumed_writes_the_same_frames() {
    killed_and_resumed_on_the_gpu(GLASS);
}

/// The elastoplastic model's plastic extensions travel in the checkpoint on the GPU too.
#[test]
fn an_elastoplastic_gpu_run_killed_and_resumed_writes_the_same_frames() {
    let reference = killed_and_resumed_on_the_gpu(METAL);
    let checkpoint = reference.path().join("out/sim.checkpoint.shp");
    let (_, state) = shatter_core::checkpoint::read(&checkpoint).expect("checkpoint");
    let yielded = state.bond_state.iter().filter(|p| **p != 0.0).count();
    assert!(yielded > 100, "the plate should yield: {yielded} plastic bond entries");
}

/// Runs the struck plate of `material` on the GPU whole, then again killed mid-way and resumed:
/// the frames must be the same. Returns the folder of the uninterrupted run.
fn killed_and_resumed_on_the_gpu(material: &str) -> tempfile::TempDir {
    let reference = tempfile::tempdir().expect("tempdir");
    let config = scene_of(reference.path(), material);
    let report = run_with(&config, RunOptions::default(), &NoProgress, &on_gpu).expect("run");
    assert!(report.backend.starts_with("GPU"), "{}", report.backend);
    assert!(report.broken_bonds > 1000, "the plate breaks");
    let expected = frame_files(reference.path());
    assert_eq!(expected.len(), 13, "12 point caches and the break log");

    let killed = tempfile::tempdir().expect("tempdir");
    let config = scene_of(killed.path(), material);
    let killer = Killer { steps: AtomicU64::new(0), limit: 5 * 60 + 30 };
    let result = std::panic::catch_unwind(AssertUnwindSafe(|| {
        run_with(&config, RunOptions::default(), &killer, &on_gpu).map(|_| ())
    }));
    assert!(result.is_err(), "the run was killed");
    let written = frame_files(killed.path()).len() - 1;
    assert!(written < 12, "killed mid-run ({written} frames)");
    let options = RunOptions { resume: true, ..RunOptions::default() };
    let report = run_with(&config, options, &NoProgress, &on_gpu).expect("resume");
    assert!(report.started_at_frame > 1, "resumed from frame {}", report.started_at_frame);
    let resumed = frame_files(killed.path());
    assert_eq!(resumed.len(), expected.len());
    for ((name, bytes), (expected_name, expected_bytes)) in resumed.iter().zip(&expected) {
        assert_eq!(name, expected_name);
        assert!(bytes == expected_bytes, "{} differs after resume", name.display());
    }
    reference
}

#[test]
fn a_run_resumed_on_another_backend_is_warned_about() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut config = scene(dir.path());
    config.sim.frames = 3;
    let options = RunOptions { backend: Some(BackendChoice::Cpu), ..RunOptions::default() };
    shatter_sim::sim_driver::run_sim(&config, options, &NoProgress).expect("cpu run");
    let options = RunOptions { resume: true, ..RunOptions::default() };
    let report = run_with(&config, options, &NoProgress, &on_gpu).expect("resume on the GPU");
    assert!(report.warnings.iter().any(|w| w.contains("the checkpoint was written by CPU")), "{:?}", report.warnings);
}

#[test]
fn the_backend_is_the_one_asked_for() {
    let dir = tempfile::tempdir().expect("tempdir");
    let config = scene(dir.path());
    let particles = ParticleSet::read(&OutputLayout::of(&config).particles()).expect("particles");
    let (cpu, _) = create_backend(&config, &particles, BackendChoice::Cpu).expect("cpu");
    assert!(cpu.describe().starts_with("CPU"), "{}", cpu.describe());
    // What `gpu` and `auto` give depends on the machine (and SHATTER_GPU_ALLOW_SOFTWARE).
    match GpuContext::new(AdapterChoice::from_env()) {
        Ok(ctx) => {
            let (sim, _) = create_backend(&config, &particles, BackendChoice::Gpu).expect("gpu");
            assert_eq!(sim.describe(), format!("GPU: {}", ctx.describe()));
            let (sim, _) = create_backend(&config, &particles, BackendChoice::Auto).expect("auto");
            assert!(sim.describe().starts_with("GPU"), "{}", sim.describe());
        }
        Err(error) => {
            let Err(gpu) = create_backend(&config, &particles, BackendChoice::Gpu) else {
                panic!("no adapter, yet --backend gpu ran");
            };
            eprintln!("--backend gpu: {gpu}");
            assert_eq!(gpu.to_string(), error.to_string(), "the message is shatter-gpu's");
            assert!(gpu.to_string().contains("--backend cpu"), "{gpu}");
            let (sim, warning) = create_backend(&config, &particles, BackendChoice::Auto).expect("auto");
            assert!(sim.describe().starts_with("CPU") && warning.is_none(), "{}", sim.describe());
        }
    }
}

#[test]
fn the_initial_velocity_carries_the_body_on_both_backends() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut config = scene(dir.path());
    config.sim.frames = 4;
    config.sim.projectile.clear();
    config.sim.gravity_m_s2 = [0.0; 3];
    let velocity = [1.5f32, -4.0, 0.25];
    config.sim.initial_velocity_m_s = velocity.map(f64::from);
    let particles = ParticleSet::read(&OutputLayout::of(&config).particles()).expect("particles");
    let last = OutputLayout::of(&config).frame_points(4);
    let options = RunOptions { backend: Some(BackendChoice::Cpu), ..RunOptions::default() };
    let cpu = shatter_sim::sim_driver::run_sim(&config, options, &NoProgress).expect("cpu run");
    let on_cpu = shatter_core::frames::PointFrame::read(&last).expect("cpu frame");
    let gpu = run_with(&config, RunOptions::default(), &NoProgress, &on_gpu).expect("gpu run");
    let on_gpu = shatter_core::frames::PointFrame::read(&last).expect("gpu frame");
    assert!(cpu.backend.starts_with("CPU") && gpu.backend.starts_with("GPU"));
    // a free body in uniform motion: every particle moved by v t and still moves at v
    let t = on_cpu.time_s as f32;
    assert!(t > 0.0);
    for frame in [&on_cpu, &on_gpu] {
        for axis in 0..3 {
            for (i, rest) in particles.rest_position_m.iter().enumerate() {
                let moved = frame.position[axis][i] - rest[axis];
                assert!((moved - velocity[axis] * t).abs() < 1e-7, "particle {i} axis {axis}: moved {moved}");
                assert!((frame.velocity[axis][i] - velocity[axis]).abs() < 1e-4, "particle {i} axis {axis}");
            }
        }
    }
}
