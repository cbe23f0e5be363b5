//! Benchmark: the GPU backend's steps per second and bond updates per second on grid blocks
//! standing in for the paper's scenes, (a) vase scale, 85^3 = 614,125 particles at N = 2, and
//! (b) dragon scale, 78^3 = 474,552 particles at N = 6, and (c) an elastoplastic block, 60^3 at
//! N = 2.5; and on the real scenes given with `--scene` (their particle file, preprocessed when
//! it is missing, and their own model: floor, gravity, projectiles, contact). Also prints the
//! bytes a step moves and how close the step comes to the memory-bandwidth floor, and with
//! `--agreement` how far the GPU's state is from the CPU backend's after the same steps.
//!
//! `cargo bench -p shatter-sim --bench gpu_steps [-- STEPS [--small] [--agreement] [--scene
//! CONFIG.toml ...]]` (default 200 steps). It takes the hardware GPU wgpu finds
//! (`SHATTER_GPU_ADAPTER` picks one by name); without one it runs small blocks (24^3 at N = 2,
//! 16^3 at N = 6, 20^3 elastoplastic) on a software adapter (Mesa lavapipe), only to show that the
//! path works. `--small` forces the small blocks; `--adapter` only prints the adapter it would
//! use ("hardware NAME" or "software NAME"). `scripts/gpu-bench.sh` runs it with the rest
//! of the GPU figures.
//!
//! A bond update is one bond's stretch, break test and force in one step, credited once per
//! unique bond whatever the layout (the GPU computes each bond at both ends), as in the CPU
//! benchmark `bond_updates`. Bytes per step: every stream read or written once (12 bytes per
//! stored bond entry: partner, stiffness, threshold; the broken-bit words; the per-particle
//! records; the elastoplastic model's own arrays), partners' records gathered from cache. The
//! floor is bytes / bandwidth, with the bandwidth measured by a buffer copy on the device (and
//! the nominal figure of known GPUs, or `SHATTER_GPU_BANDWIDTH_GBS`, when there is one).

use std::path::Path;
use std::time::Instant;

use shatter_core::config::PipelineConfig;
use shatter_core::particles::ParticleSet;
use shatter_core::{NoProgress, OutputLayout};
use shatter_gpu::{AdapterChoice, GpuContext, wgpu};
use shatter_sim::gpu::{GpuOptions, GpuSimulation};
use shatter_sim::{Backend, CpuSimulation, Model, art};

/// A grid block of `side`^3 cubes of 1 mm at horizon factor `horizon`, of `[material]` keys
/// `material`.
fn config(side: usize, horizon: f64, material: &str) -> PipelineConfig {
    let size = side as f64 * 0.001;
    let text = format!(
        r#"
[scene]
name = "bench"
output_dir = "out"
seed = 1
[geometry]
source = "box"
box_size_m = [{size}, {size}, {size}]
sampler = "grid"
spacing_m = 0.001
horizon_factor = {horizon}
[material]
{material}
[sim]
gravity_m_s2 = [0.0, -9.81, 0.0]
"#
    );
    PipelineConfig::from_toml_str(&text, Path::new("/nonexistent/pipeline.toml")).expect("valid config")
}

/// The nominal memory bandwidth of known GPUs, bytes/s.
fn nominal_bandwidth(name: &str) -> Option<f64> {
    if let Some(gbs) = std::env::var("SHATTER_GPU_BANDWIDTH_GBS").ok().and_then(|v| v.parse::<f64>().ok()) {
        return Some(gbs * 1e9);
    }
    let name = name.to_ascii_lowercase();
    let table = [
        ("h200", 4800.0),
        ("h100 pcie", 2000.0),
        ("h100 nvl", 3900.0),
        ("h100", 3350.0),
        ("a100 80gb pcie", 1935.0),
        ("a100-sxm4-80gb", 2039.0),
        ("a100", 1555.0),
        ("l40s", 864.0),
        ("rtx 4090", 1008.0),
        ("rtx 3090", 936.0),
    ];
    table.iter().find(|(key, _)| name.contains(key)).map(|(_, gbs)| gbs * 1e9)
}

/// Bytes per second of a large buffer-to-buffer copy on the device (read + write counted).
fn measured_bandwidth(ctx: &GpuContext) -> f64 {
    let bytes = (ctx.limits.max_buffer_size / 4).min(1 << 30) / 4 * 4;
    let make = |label| {
        ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes,
            usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    };
    let (a, b) = (make("copy source"), make("copy target"));
    let copy = |rounds: u32| {
        let mut encoder = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        for _ in 0..rounds {
            encoder.copy_buffer_to_buffer(&a, 0, &b, 0, bytes);
        }
        let index = ctx.queue.submit([encoder.finish()]);
        ctx.device.poll(wgpu::PollType::Wait { submission_index: Some(index), timeout: None }).expect("wait");
    };
    copy(1);
    let rounds = 8;
    let started = Instant::now();
    copy(rounds);
    2.0 * bytes as f64 * f64::from(rounds) / started.elapsed().as_secs_f64()
}

/// PMB glass.
const GLASS: &str = "density_kg_m3 = 2200.0\nbulk_modulus_pa = 14.9e9";

/// A ductile metal in the elastoplastic model.
const METAL: &str = "model = \"elastoplastic\"\ndensity_kg_m3 = 2700.0\nyoungs_modulus_pa = 7e10\npoisson_ratio = 0.33\n\
                     yield_stress_pa = 2e8\ncritical_stretch = 0.01";

/// What a benchmark case measures besides the GPU's speed.
#[derive(Clone, Copy)]
struct Measure {
    steps: u64,
    bandwidth: (f64, Option<f64>),
    agreement: bool,
}

/// Benchmarks a grid block.
fn bench_block(ctx: &'static GpuContext, label: &str, side: usize, horizon: f64, material: &str, measure: Measure) {
    let config = config(side, horizon, material);
    let started = Instant::now();
    let particles = shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles;
    println!(
        "{label}: {side}^3 = {} particles at N = {horizon}, {} bonds ({:.0} per particle), preprocessed in {:.1} s",
        particles.len(),
        particles.bonds.unique_count(),
        2.0 * particles.bonds.unique_count() as f64 / particles.len() as f64,
        started.elapsed().as_secs_f64()
    );
    bench(ctx, &config, &particles, measure);
}

/// Benchmarks the scene of config file `path`, on its particle file (preprocessed here when it
/// is missing).
fn bench_scene(ctx: &'static GpuContext, path: &str, measure: Measure) {
    let config = match PipelineConfig::load(Path::new(path)) {
        Ok(config) => config,
        Err(error) => {
            println!("{path}: {error}");
            return;
        }
    };
    let file = OutputLayout::of(&config).particles();
    let started = Instant::now();
    let particles = match ParticleSet::read(&file) {
        Ok(particles) => particles,
        Err(_) => shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles,
    };
    println!(
        "scene {}: {} particles ({}), {} bonds ({:.0} per particle), loaded in {:.1} s",
        config.scene.name,
        particles.len(),
        particles.meta.sampler,
        particles.bonds.unique_count(),
        2.0 * particles.bonds.unique_count() as f64 / particles.len() as f64,
        started.elapsed().as_secs_f64()
    );
    bench(ctx, &config, &particles, measure);
}

/// Small random velocities (the same on both backends).
fn jiggle(i: usize, _: [f32; 3]) -> [f32; 3] {
    let h = shatter_core::random::splitmix64(i as u64);
    [0, 1, 2].map(|k| ((h >> (16 * k)) & 0xffff) as f32 / 65535.0 * 2e-3 - 1e-3)
}

fn bench(ctx: &'static GpuContext, config: &PipelineConfig, particles: &ParticleSet, measure: Measure) {
    let Measure { steps, bandwidth, agreement } = measure;
    let unique = particles.bonds.unique_count();
    let started = Instant::now();
    let model = Model::new(config, particles).expect("model");
    let factors = art::threshold_factors(&config.sim, particles, config.scene.seed).expect("factors");
    let correction = config.sim.stiffness_correction;
    let mut sim = match GpuSimulation::new(
        ctx.into(),
        particles,
        model,
        factors.as_deref(),
        correction,
        &GpuOptions::default(),
    ) {
        Ok(sim) => sim,
        Err(error) => {
            println!("  cannot run on this adapter: {error}");
            return;
        }
    };
    sim.set_velocity(&jiggle).expect("velocities");
    println!(
        "  set up in {:.1} s: {} stored bond entries (sliced layout, padding included) in {} binding range(s)",
        started.elapsed().as_secs_f64(),
        sim.stored_entries(),
        sim.ranges()
    );
    // Warm up, then time: steps plus one frame boundary, minus a frame boundary alone.
    sim.advance(10).expect("steps");
    sim.finish_frame().expect("frame");
    let started = Instant::now();
    sim.finish_frame().expect("frame");
    let sync = started.elapsed().as_secs_f64();
    let started = Instant::now();
    sim.advance(steps).expect("steps");
    sim.finish_frame().expect("frame");
    let total = started.elapsed().as_secs_f64();
    let per_step = ((total - sync) / steps as f64).max(1e-9);
    let (bond_bytes, particle_bytes) = sim.bytes_per_step();
    let bytes = (bond_bytes + particle_bytes) as f64;
    println!(
        "  {:.1} steps/s ({:.3} ms/step), {:.2} G bond updates/s ({:.2} G entry updates/s)",
        1.0 / per_step,
        per_step * 1e3,
        unique as f64 / per_step / 1e9,
        sim.stored_entries() as f64 / per_step / 1e9,
    );
    println!(
        "  bytes per step: {:.1} MB ({:.1} MB bond streams, {:.1} MB particle streams); {:.0} GB/s effective",
        bytes / 1e6,
        bond_bytes as f64 / 1e6,
        particle_bytes as f64 / 1e6,
        bytes / per_step / 1e9
    );
    let (measured, nominal) = bandwidth;
    let floor = bytes / measured;
    println!(
        "  bandwidth floor {:.3} ms/step at the measured copy bandwidth: the step takes {:.2}x the floor",
        floor * 1e3,
        per_step / floor
    );
    if let Some(nominal) = nominal {
        let floor = bytes / nominal;
        println!(
            "  bandwidth floor {:.3} ms/step at the nominal {:.0} GB/s: the step takes {:.2}x the floor",
            floor * 1e3,
            nominal / 1e9,
            per_step / floor
        );
    }
    println!("  frame-boundary readback of the state: {:.1} ms", sync * 1e3);
    if agreement {
        agree(config, particles, &sim, steps + 10);
    }
}

/// Runs the CPU backend from the same start for `steps` steps and prints how far the GPU's
/// state `gpu` is from it: broken bonds, displacements, kinetic and bond energy.
fn agree(config: &PipelineConfig, particles: &ParticleSet, gpu: &GpuSimulation, steps: u64) {
    let started = Instant::now();
    let mut cpu = CpuSimulation::from_config(config, particles).expect("CPU simulation");
    Backend::set_velocity(&mut cpu, &jiggle).expect("velocities");
    let mut broken = 0;
    for _ in 0..steps {
        cpu.step();
        broken += cpu.take_breaks().len();
    }
    let n = particles.len();
    let (g, c) = (gpu.dynamics(), cpu.dynamics());
    let mut difference = 0.0f64;
    let mut size = 0.0f64;
    let mut largest = 0.0f64;
    for i in 0..n {
        for a in 0..3 {
            let d = f64::from(g.disp[a][i] - c.disp[a][i]);
            difference += d * d;
            size += f64::from(c.disp[a][i]).powi(2);
            largest = largest.max(d.abs());
        }
    }
    let gpu_broken = gpu
        .damage()
        .iter()
        .zip(&particles.bonds.offsets.windows(2).map(|w| w[1] - w[0]).collect::<Vec<_>>())
        .map(|(d, count)| f64::from(*d) * *count as f64)
        .sum::<f64>()
        / 2.0;
    let (ge, ce) = (gpu.energy(), Backend::energy(&cpu));
    println!(
        "  CPU agreement after {steps} steps (CPU {:.1} s): bonds broken GPU {:.0} / CPU {broken}; displacements rms \
         {:.2e} of the CPU's, largest {largest:.2e} m; kinetic energy {:+.3e}, bond energy {:+.3e} relative",
        started.elapsed().as_secs_f64(),
        gpu_broken,
        (difference / size.max(f64::MIN_POSITIVE)).sqrt(),
        ge.kinetic_j / ce.kinetic_j - 1.0,
        ge.bond_j / ce.bond_j - 1.0
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let steps = args.iter().find_map(|a| a.parse::<u64>().ok()).unwrap_or(200);
    let small = args.iter().any(|a| a == "--small");
    let agreement = args.iter().any(|a| a == "--agreement");
    let scenes: Vec<&String> =
        args.iter().zip(args.iter().skip(1)).filter(|(flag, _)| *flag == "--scene").map(|(_, path)| path).collect();
    let (ctx, software) = match GpuContext::new(AdapterChoice::from_env()) {
        Ok(ctx) => {
            let software = ctx.is_software();
            (ctx, software)
        }
        Err(error) => {
            println!("{error}\nno hardware GPU: small blocks on a software adapter, to show the path works");
            match GpuContext::new(AdapterChoice::AllowSoftware) {
                Ok(ctx) => (ctx, true),
                Err(error) => {
                    println!("no adapter at all: {error}");
                    return;
                }
            }
        }
    };
    if args.iter().any(|a| a == "--adapter") {
        // what scripts/gpu-bench.sh asks first
        println!("{} {}", if software { "software" } else { "hardware" }, ctx.describe());
        return;
    }
    let ctx: &'static GpuContext = Box::leak(Box::new(ctx));
    let measured = measured_bandwidth(ctx);
    let nominal = nominal_bandwidth(&ctx.info.name);
    println!(
        "GPU steps on {}: max storage binding {} MB; measured copy bandwidth {:.0} GB/s{}",
        ctx.describe(),
        ctx.max_storage_binding_bytes() >> 20,
        measured / 1e9,
        nominal.map_or(String::new(), |n| format!(", nominal {:.0} GB/s", n / 1e9))
    );
    let (vase, dragon, metal, steps) =
        if small || software { (24, 16, 20, steps.min(20)) } else { (85, 78, 60, steps) };
    let measure = Measure { steps, bandwidth: (measured, nominal), agreement };
    bench_block(ctx, "(a) vase scale", vase, 2.0, GLASS, measure);
    bench_block(ctx, "(b) dragon scale", dragon, 6.0, GLASS, measure);
    bench_block(ctx, "(c) elastoplastic", metal, 2.5, METAL, measure);
    for scene in scenes {
        bench_scene(ctx, scene, measure);
    }
}
