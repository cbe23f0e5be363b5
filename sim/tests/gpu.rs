//! The GPU backend against the CPU one on lavapipe (or any adapter): agreement on a fracturing
//! scene, run-to-run determinism, bond arrays split across bindings, capacity overflows, resume.

// The shared physics scenarios; this file uses only their scene builders.
#[allow(dead_code)]
use crate::scenarios;

use std::collections::BTreeSet;

use shatter_core::config::PipelineConfig;
use shatter_core::frames::BreakEvent;
use shatter_core::particles::ParticleSet;
use shatter_gpu::GpuContext;
use shatter_sim::gpu::{GpuOptions, GpuSimulation};
use shatter_sim::{Backend, CpuSimulation, Dynamics, Model, art};

fn gpu() -> &'static GpuContext {
    GpuContext::shared_for_tests().unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"))
}

const PROJECTILE: &str = "[[sim.projectile]]\ncenter_m = [0.0, 0.0, 0.0067]\nvelocity_m_s = [0.0, 0.0, -150.0]\nradius_m = 0.003\nstiffness_pa = 3e7";

/// The plate of `sim/tests/physics.rs` struck by a projectile: contact, fracture, body forces.
fn struck_plate() -> (PipelineConfig, ParticleSet) {
    scenarios::block([20, 20, 4], 3.0, "", PROJECTILE)
}

fn gpu_simulation(config: &PipelineConfig, particles: &ParticleSet, options: &GpuOptions) -> GpuSimulation {
    let model = Model::new(config, particles).expect("model");
    let factors = art::threshold_factors(&config.sim, particles, config.scene.seed).expect("factors");
    GpuSimulation::new(gpu().into(), particles, model, factors.as_deref(), config.sim.stiffness_correction, options)
        .unwrap_or_else(|e| panic!("{e}"))
}

/// `frames` frames of `steps` steps: the breaks and the state after each frame.
fn run(sim: &mut dyn Backend, frames: usize, steps: u64) -> (Vec<BreakEvent>, Vec<Dynamics>) {
    let mut breaks = Vec::new();
    let mut states = Vec::new();
    for _ in 0..frames {
        sim.advance(steps).expect("advance");
        breaks.extend(sim.finish_frame().expect("frame"));
        states.push(sim.dynamics().clone());
    }
    (breaks, states)
}

/// The largest displacement difference over the largest displacement.
fn displacement_error(a: &Dynamics, b: &Dynamics) -> f64 {
    let scale = a.disp.iter().flatten().fold(0.0f64, |m, u| m.max(f64::from(u.abs())));
    let worst = (0..3)
        .flat_map(|axis| (0..a.disp[0].len()).map(move |i| f64::from((a.disp[axis][i] - b.disp[axis][i]).abs())))
        .fold(0.0f64, f64::max);
    if scale == 0.0 { worst } else { worst / scale }
}

/// The largest difference of `field` over its largest value.
fn field_error(a: &[Vec<f32>; 3], b: &[Vec<f32>; 3]) -> f64 {
    let scale = a.iter().flatten().fold(0.0f64, |m, u| m.max(f64::from(u.abs())));
    let worst = (0..3)
        .flat_map(|axis| (0..a[0].len()).map(move |i| f64::from((a[axis][i] - b[axis][i]).abs())))
        .fold(0.0f64, f64::max);
    if scale == 0.0 { worst } else { worst / scale }
}

#[test]
fn gpu_and_cpu_agree_on_a_struck_plate() {
    let (config, particles) = struck_plate();
    let mut cpu = CpuSimulation::from_config(&config, &particles).expect("cpu");
    let (cpu_breaks, cpu_states) = run(&mut cpu, 100, 10);
    let mut gpu = gpu_simulation(&config, &particles, &GpuOptions::default());
    let (gpu_breaks, gpu_states) = run(&mut gpu, 100, 10);
    let set = |b: &[BreakEvent]| b.iter().map(|e| e.bond).collect::<BTreeSet<u64>>();
    let (c, g) = (set(&cpu_breaks), set(&gpu_breaks));
    let differ = c.symmetric_difference(&g).count();
    // The first step whose breaks differ.
    let per_step = |b: &[BreakEvent]| b.iter().map(|e| (e.step, e.bond)).collect::<BTreeSet<(u64, u64)>>();
    let first = per_step(&cpu_breaks).symmetric_difference(&per_step(&gpu_breaks)).map(|e| e.0).min();
    eprintln!(
        "1,000 steps: CPU {} breaks, GPU {}, symmetric difference {differ} ({:.3}%), first differing step {first:?}",
        c.len(),
        g.len(),
        100.0 * differ as f64 / c.len() as f64
    );
    assert!(c.len() > 1000, "the plate fractures");
    assert!(differ as f64 <= 0.01 * c.len() as f64, "break sets differ by {differ} of {}", c.len());
    // Until a break differs, the states differ by rounding only: displacements agree to a few
    // f32 epsilons of the largest displacement (summation orders differ: lanes of 8 and Newton's
    // third law within a chunk on the CPU, one row after the other on the GPU).
    for (frame, (a, b)) in cpu_states.iter().zip(&gpu_states).enumerate() {
        let end = (frame as u64 + 1) * 10;
        let error = displacement_error(a, b);
        if frame % 5 == 4 && first.is_none_or(|first| end < first + 50) {
            eprintln!("step {end}: displacements differ by {error:.2e} of the largest");
        }
        if first.is_none_or(|first| end < first) {
            assert!(error <= 2e-6, "step {end}, before any break differs: displacements differ by {error:e}");
        }
    }
}

/// The largest force difference of a particle relative to the sum of the magnitudes of what
/// makes its force: its bonds' forces c V_i V_j |s| (without the stiffness correction, near 1)
/// plus its net force. Summed in another order, a sum of ~100 terms differs by a few ulps of
/// that, not of the net, which may be much smaller.
fn force_error(particles: &ParticleSet, model: &Model, broken: &[u64], a: &Dynamics, b: &Dynamics) -> f64 {
    let bonds = &particles.bonds;
    let rest = &particles.rest_position_m;
    let volume = &particles.volume_m3;
    let mut worst = 0.0f64;
    for i in 0..particles.len() {
        let mut scale = (0..3).map(|k| f64::from(a.force[k][i]).powi(2)).sum::<f64>().sqrt();
        for entry in bonds.row(i) {
            let j = bonds.neighbor[entry] as usize;
            let id = if i < j { entry } else { bonds.find(j, i as u32).expect("symmetric") } as u64;
            if broken.binary_search(&id).is_ok() {
                continue;
            }
            let xi = [0, 1, 2].map(|k| rest[j][k] - rest[i][k]);
            let eta = [0, 1, 2].map(|k| a.disp[k][j] - a.disp[k][i]);
            let (s, _, _) = shatter_sim::kernels::stretch(xi, eta, bonds.rest_length_m[entry]);
            scale += model.bond_constant * f64::from(volume[i]) * f64::from(volume[j]) * f64::from(s.abs());
        }
        let difference = (0..3).map(|k| f64::from(a.force[k][i] - b.force[k][i]).powi(2)).sum::<f64>().sqrt();
        if scale > 0.0 {
            worst = worst.max(difference / scale);
        }
    }
    worst
}

/// Differences of single steps taken by both backends from the CPU's state.
#[derive(Debug, Default)]
struct Lockstep {
    breaks: usize,
    one_sided: usize,
    closest: f64,
    displacement: f64,
    velocity: f64,
    force: f64,
}

/// `steps` steps, each taken by both backends from the CPU's state. Asserts that a bond breaks
/// on one backend only when its stretch was within 1e-6 (8 f32 ulps) of its threshold.
fn lockstep(config: &PipelineConfig, particles: &ParticleSet, steps: u64) -> Lockstep {
    let cpu = CpuSimulation::from_config(config, particles).expect("cpu");
    lockstep_from(config, particles, cpu, steps)
}

/// [`lockstep`] from a given CPU simulation's state.
fn lockstep_from(config: &PipelineConfig, particles: &ParticleSet, mut cpu: CpuSimulation, steps: u64) -> Lockstep {
    let model = Model::new(config, particles).expect("model");
    let mut gpu = gpu_simulation(config, particles, &GpuOptions::default());
    let bonds = &particles.bonds;
    let rest = &particles.rest_position_m;
    let mut broken: Vec<u64> = Vec::new();
    let mut out = Lockstep::default();
    for step in 1..=steps {
        let before = cpu.dynamics().clone();
        gpu.restore(before.clone(), &broken).expect("restore");
        cpu.step();
        gpu.advance(1).expect("step");
        let cpu_breaks: BTreeSet<u64> = cpu.take_breaks().iter().map(|e| e.bond).collect();
        let gpu_breaks: BTreeSet<u64> = gpu.finish_frame().expect("sync").iter().map(|e| e.bond).collect();
        let (a, b) = (cpu.dynamics(), gpu.dynamics());
        out.displacement = out.displacement.max(displacement_error(a, b));
        out.velocity = out.velocity.max(field_error(&a.vel, &b.vel));
        out.breaks += cpu_breaks.len();
        for &id in cpu_breaks.symmetric_difference(&gpu_breaks) {
            // The stretch at the break step (the displacements after the drift) and the
            // threshold it was compared with (the boosts of the step before).
            let i = bonds.offsets.partition_point(|o| *o <= id) - 1;
            let j = bonds.neighbor[id as usize] as usize;
            let xi = [0, 1, 2].map(|k| rest[j][k] - rest[i][k]);
            let eta = [0, 1, 2].map(|k| a.disp[k][j] - a.disp[k][i]);
            let (s, _, _) = shatter_sim::kernels::stretch(xi, eta, bonds.rest_length_m[id as usize]);
            let tau = (f64::from(bonds.threshold[id as usize]) * model.threshold_scale) as f32;
            let limit = tau + before.boost[i].max(before.boost[j]);
            let margin = f64::from((s - limit).abs()) / f64::from(limit);
            out.closest = out.closest.max(margin);
            out.one_sided += 1;
            assert!(
                margin <= 1e-6,
                "step {step}: bond {id} ({i}-{j}) broke on one backend only, its stretch {s:e} {margin:e} from the \
                 threshold {limit:e}"
            );
        }
        broken.extend(&cpu_breaks);
        broken.sort_unstable();
        out.force = out.force.max(force_error(particles, &model, &broken, a, b));
    }
    eprintln!("{steps} single steps from the CPU's state: {out:?}");
    out
}

/// The plate again, but every step both backends start from the CPU's state: each step's
/// positions, velocities and forces agree to f32 rounding, and a bond breaks on one and not the
/// other only when its stretch was within a few ulps of its threshold.
#[test]
fn every_step_of_the_struck_plate_agrees_with_the_cpu() {
    let (config, particles) = struck_plate();
    let out = lockstep(&config, &particles, 1000);
    assert!(out.breaks > 1000);
    assert!(out.displacement <= 1e-6 && out.velocity <= 1e-5 && out.force <= 1e-5, "{out:?}");
}

/// A slab dropped on the floor under gravity while an indenter presses into it: the floor's
/// bounce, gravity and the indenter step for step as on the CPU.
#[test]
fn every_step_of_a_slab_on_the_floor_under_an_indenter_agrees_with_the_cpu() {
    let text = scenarios::block_text(
        [10, 4, 10],
        3.0,
        "",
        "[sim.floor]\nheight_m = -0.00155\nrestitution = 0.9\n[[sim.indenter]]\ncenter_m = [0.0005, 0.0036, 0.0]\n\
         velocity_m_s = [0.0, -20.0, 0.0]\nradius_m = 0.002\nstiffness_n_m2 = 1e9",
    )
    .replace("gravity_m_s2 = [0.0, 0.0, 0.0]", "gravity_m_s2 = [0.0, -9.81, 0.0]");
    let (config, particles) = scenarios::load(&text);
    let mut cpu = CpuSimulation::from_config(&config, &particles).expect("cpu");
    cpu.set_velocity(|_, _| [0.0, -3.0, 0.0]);
    let out = lockstep_from(&config, &particles, cpu, 300);
    assert!(out.breaks > 0, "the indenter breaks bonds");
    assert!(out.displacement <= 1e-6 && out.velocity <= 1e-5 && out.force <= 1e-5, "{out:?}");
}

/// Bit-identical runs: twice the same; with the bond arrays split across many bindings; and with
/// capacities (contact candidates, break events) so small that frames must be replayed.
#[test]
fn gpu_runs_are_bit_identical_whatever_the_bindings_and_capacities() {
    let (config, particles) = struck_plate();
    let outcome = |options: &GpuOptions| {
        let mut gpu = gpu_simulation(&config, &particles, options);
        let (breaks, states) = run(&mut gpu, 10, 40);
        let state_bits: Vec<Vec<u32>> = states.iter().map(bits).collect();
        (breaks, state_bits, gpu.ranges(), gpu.contact_cap(), gpu.event_capacity())
    };
    let reference = outcome(&GpuOptions::default());
    assert!(reference.0.len() > 1000, "bonds break");
    assert_eq!(reference.2, 1);
    let again = outcome(&GpuOptions::default());
    assert!(again.0 == reference.0 && again.1 == reference.1, "two runs differ");

    let split = outcome(&GpuOptions { max_binding_bytes: Some(48 * 1024), ..GpuOptions::default() });
    eprintln!("bond arrays in {} ranges", split.2);
    assert!(split.2 >= 4, "{} ranges", split.2);
    assert!(split.0 == reference.0 && split.1 == reference.1, "split bindings change the results");

    let small = outcome(&GpuOptions { contact_cap: 1, event_capacity: Some(8), ..GpuOptions::default() });
    eprintln!("capacities grew to {} candidates and {} events", small.3, small.4);
    assert!(small.4 > 8, "the event buffer grew");
    assert!(small.0 == reference.0 && small.1 == reference.1, "replayed frames change the results");
}

fn bits(d: &Dynamics) -> Vec<u32> {
    let arrays = d.disp.iter().chain(&d.vel).chain(&d.force).chain(std::iter::once(&d.boost));
    arrays.flat_map(|a| a.iter().map(|x| x.to_bits())).chain([d.step as u32]).collect()
}
