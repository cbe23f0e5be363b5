//! The elastoplastic model on the GPU backend: against theory (rigid motions, conservation,
//! Young's modulus and Poisson's ratio, plasticity and its cap, grips), against the CPU backend
//! on a struck plate (contact, plasticity and fracture), and a resume that matches an
//! uninterrupted run bit for bit. Sizes are the CPU tests' or smaller: CI runs them on lavapipe.

use crate::elastoplastic_scenes;

use elastoplastic_scenes::{E, LAMBDA, block, centre, middle};
use shatter_core::config::PipelineConfig;
use shatter_core::particles::ParticleSet;
use shatter_gpu::GpuContext;
use shatter_sim::gpu::{GpuOptions, GpuSimulation};
use shatter_sim::{Backend, CpuSimulation, Model, art};

fn gpu(config: &PipelineConfig, particles: &ParticleSet) -> GpuSimulation {
    let ctx = GpuContext::shared_for_tests().unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    let model = Model::new(config, particles).expect("model");
    let factors = art::threshold_factors(&config.sim, particles, config.scene.seed).expect("factors");
    let correction = config.sim.stiffness_correction;
    GpuSimulation::new(ctx.into(), particles, model, factors.as_deref(), correction, &GpuOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
}

fn max_force(sim: &dyn Backend) -> f64 {
    let force = &sim.dynamics().force;
    (0..sim.len()).map(|i| (0..3).map(|a| f64::from(force[a][i]).powi(2)).sum::<f64>().sqrt()).fold(0.0, f64::max)
}

/// Advances `steps` steps and ends the frame; returns the bonds broken.
fn run(sim: &mut dyn Backend, steps: u64) -> usize {
    sim.advance(steps).expect("advance");
    sim.finish_frame().expect("frame").len()
}

#[test]
fn rigid_motions_cause_no_internal_force_on_the_gpu() {
    let (config, particles) = block([8, 7, 6], 0.3, "", "");
    let mut sim = gpu(&config, &particles);
    sim.set_displacement(&|_, _| [0.013, -0.021, 0.0047]).expect("translate");
    assert_eq!(max_force(&sim), 0.0, "a translation stretches nothing");
    let c = centre(&particles);
    let strain = 1e-4f32;
    sim.set_displacement(&|_, x| [0, 1, 2].map(|a| strain * (x[a] - c[a]))).expect("dilate");
    let dilation_force = max_force(&sim);
    assert!(dilation_force > 0.0);
    let rotation = glam::Quat::from_axis_angle(glam::Vec3::new(1.0, 2.0, 3.0).normalize(), 0.6);
    let c3 = glam::Vec3::from_array(c);
    sim.set_displacement(&|_, x| {
        let x = glam::Vec3::from_array(x);
        (rotation * (x - c3) + c3 + glam::Vec3::new(0.01, 0.0, -0.02) - x).to_array()
    })
    .expect("rotate");
    let equivalent_strain = max_force(&sim) / dilation_force * f64::from(strain);
    eprintln!("rotation leaves forces of a {equivalent_strain:e} strain on the GPU");
    assert!(equivalent_strain < 1e-6, "rotation leaves forces of a {equivalent_strain:e} strain");
    assert_eq!(sim.finish_frame().expect("frame").len(), 0);
}

#[test]
fn momentum_and_energy_are_conserved_over_20000_elastic_steps_on_the_gpu() {
    let (config, particles) =
        block([24, 4, 4], 0.3, "critical_stretch = 0.01", "contact = { stiffness_pa = 0.0 }\ndt_s = 4e-8");
    let mut sim = gpu(&config, &particles);
    let c = centre(&particles);
    sim.set_displacement(&|_, x| [1e-6 * (std::f32::consts::PI * (x[0] - c[0]) / 0.024).sin(), 0.0, 0.0])
        .expect("displace");
    sim.set_velocity(&|i, _| {
        let spin = (i % 7) as f32 * 0.01;
        [0.02 + spin, -0.01, 0.03 - spin]
    })
    .expect("velocity");
    let dt = sim.model().dt_s;
    assert!(dt < 0.5 * sim.stable_dt_s(), "dt {dt:e} against the stable {:e}", sim.stable_dt_s());
    let (p0, l0) = sim.momentum();
    let scale: f64 = sim.mass().iter().map(|m| f64::from(*m)).sum::<f64>() * 0.05;
    let mut energies = Vec::new();
    for _ in 0..500 {
        assert_eq!(run(&mut sim, 40), 0);
        energies.push(sim.energy().total_j());
        let (p, _) = sim.momentum();
        assert!((p - p0).length() < 1e-5 * scale, "linear momentum drifted by {}", (p - p0).length());
    }
    let (_, l) = sim.momentum();
    assert!((l - l0).length() < 1e-4 * scale * 0.012, "angular momentum drifted by {}", (l - l0).length());
    let mean = |values: &[f64]| values.iter().sum::<f64>() / values.len() as f64;
    let (first, last) = (mean(&energies[..25]), mean(&energies[energies.len() - 25..]));
    let drift = (last - first).abs() / first;
    eprintln!("energy drift {:.4}% over 20,000 steps on the GPU", drift * 100.0);
    assert!(drift < 0.005, "energy drifted by {:.3}% over 20,000 steps", drift * 100.0);
}

#[test]
fn uniaxial_stress_in_the_interior_gives_the_youngs_modulus_and_poisson_ratio_on_the_gpu() {
    // As on the CPU: the energy density of the interior is a parabola in the lateral strain l;
    // uniaxial stress is its minimum, at l = -nu e, with density E e^2 / 2.
    for nu in [0.1, 0.25, 0.4] {
        let (config, particles) = block([13, 13, 13], nu, "", "");
        let mut sim = gpu(&config, &particles);
        let (c, i) = (centre(&particles), middle(&particles));
        let e = 1e-4;
        let mut w = |l: f64| {
            let strain = [e, l, l];
            sim.set_displacement(&|_, x| [0, 1, 2].map(|a| (strain[a] * f64::from(x[a] - c[a])) as f32))
                .expect("strain");
            sim.bond_energy_per_particle()[i] / f64::from(particles.volume_m3[i])
        };
        let (a, b, c) = (w(-0.5 * e), w(0.0), w(0.5 * e));
        let h = 0.5 * e;
        let curvature = (a - 2.0 * b + c) / (h * h);
        let slope = (c - a) / (2.0 * h);
        let measured_nu = slope / curvature / e;
        let measured_e = 2.0 * (b - slope * slope / (2.0 * curvature)) / (e * e);
        eprintln!("nu = {nu}: measured nu {measured_nu:.4}, E {measured_e:.4e} Pa on the GPU");
        assert!((measured_nu / nu - 1.0).abs() < 0.05, "nu = {nu}: measured {measured_nu}");
        assert!((measured_e / E - 1.0).abs() < 0.05, "nu = {nu}: measured E {measured_e:e}");
    }
}

/// The squared speed of a plane wave of wavelength `wavelength` (m) along x polarised along
/// `polarisation`, from the interior's force: -f / (m u) = omega^2 = c^2 k^2.
fn wave_speed_squared(sim: &mut dyn Backend, particles: &ParticleSet, polarisation: usize, wavelength: f64) -> f64 {
    let k = 2.0 * std::f64::consts::PI / wavelength;
    let i = middle(particles);
    let x0 = f64::from(particles.rest_position_m[i][0]);
    let amplitude = 1e-7;
    sim.set_displacement(&|_, x| {
        let mut u = [0.0f32; 3];
        u[polarisation] = (amplitude * (k * (f64::from(x[0]) - x0)).cos()) as f32;
        u
    })
    .expect("wave");
    let force = f64::from(sim.dynamics().force[polarisation][i]);
    -force / (f64::from(sim.mass()[i]) * amplitude) / (k * k)
}

#[test]
fn p_and_s_waves_travel_at_their_continuum_speeds_and_match_pmb_at_nu_one_quarter_on_the_gpu() {
    for nu in [0.1, 0.25, 0.4] {
        let (config, particles) = block([15, 15, 15], nu, "", "");
        let mut sim = gpu(&config, &particles);
        let (bulk, shear) = (config.material.bulk_modulus_pa, config.material.shear_modulus_pa());
        for (polarisation, name, modulus) in [(0, "P", bulk + 4.0 * shear / 3.0), (1, "S", shear)] {
            let theory = (modulus / elastoplastic_scenes::RHO).sqrt();
            let speed = wave_speed_squared(&mut sim, &particles, polarisation, 0.2).sqrt();
            eprintln!("nu = {nu}: {name} wave {speed:.1} m/s on the GPU, theory {theory:.1} m/s");
            assert!((speed / theory - 1.0).abs() < 0.05, "nu = {nu}: {name} wave {speed} m/s against {theory}");
        }
        if nu == 0.25 {
            // the same particles in the PMB model with the same K: the same response
            let pmb_text = elastoplastic_scenes::block_text(
                [15, 15, 15],
                &format!("bulk_modulus_pa = {}", config.material.bulk_modulus_pa),
                "",
            );
            let mut pmb = gpu(&elastoplastic_scenes::load(&pmb_text), &particles);
            for polarisation in [0, 1] {
                let a = wave_speed_squared(&mut sim, &particles, polarisation, 0.2);
                let b = wave_speed_squared(&mut pmb, &particles, polarisation, 0.2);
                eprintln!("polarisation {polarisation}: state-based c^2 {a:.5e}, PMB {b:.5e} on the GPU");
                assert!((a / b - 1.0).abs() < 0.05, "polarisation {polarisation}: {a:e} against PMB's {b:e}");
            }
        }
    }
}

/// A yield stress of 100 MPa (the CPU tests'): glass's E puts the yield strain at 1.39e-3.
const YIELD_STRESS_PA: f64 = 100e6;

/// Strains `to` k / `count` for k = 1 ..= `count`.
fn steps(to: f64, count: usize) -> impl Iterator<Item = f64> {
    (1..=count).map(move |k| to * k as f64 / count as f64)
}

/// The largest plastic extension over its bond's rest length in `state`.
fn largest_plastic_ratio(state: &[f32], particles: &ParticleSet) -> f64 {
    state.iter().zip(&particles.bonds.rest_length_m).map(|(p, l)| f64::from(p.abs() / l)).fold(0.0, f64::max)
}

/// Loads `sim` along the uniaxial-stress path to each strain of `strains` in turn; `watch` sees
/// the plastic state after each.
fn load_uniaxially(
    sim: &mut dyn Backend,
    particles: &ParticleSet,
    nu: f64,
    strains: impl Iterator<Item = f64>,
    mut watch: impl FnMut(f64, &[f32]),
) {
    let c = centre(particles);
    for e in strains {
        sim.set_displacement(&|_, x| {
            let d = [0, 1, 2].map(|a| f64::from(x[a] - c[a]));
            [e * d[0], -nu * e * d[1], -nu * e * d[2]].map(|u| u as f32)
        })
        .expect("load");
        sim.finish_frame().expect("frame");
        watch(e, &sim.bond_state());
    }
}

#[test]
fn plastic_flow_starts_at_the_yield_stress_and_leaves_a_permanent_set_on_the_gpu() {
    let nu = 0.3;
    let material = format!("yield_stress_pa = {YIELD_STRESS_PA}\ncritical_stretch = 0.5");
    let (config, particles) = block([13, 13, 13], nu, &material, "");
    let yield_strain = YIELD_STRESS_PA / E;
    let mut sim = gpu(&config, &particles);
    load_uniaxially(&mut sim, &particles, nu, steps(0.9 * yield_strain, 10), |e, state| {
        assert_eq!(
            largest_plastic_ratio(state, &particles),
            0.0,
            "plastic flow at {e:e}, below 0.9 x the yield strain"
        );
    });
    // the interior's first plastic bond marks the measured yield point
    let mut sim = gpu(&config, &particles);
    let interior = particles.bonds.row(middle(&particles));
    let mut onset = None;
    load_uniaxially(&mut sim, &particles, nu, steps(2.0 * yield_strain, 200), |e, state| {
        if onset.is_none() && state[interior.clone()].iter().any(|p| *p != 0.0) {
            onset = Some(e);
        }
    });
    let measured = E * onset.expect("the interior yields by twice the yield strain");
    eprintln!("measured yield stress {measured:.4e} Pa on the GPU");
    assert!((measured / YIELD_STRESS_PA - 1.0).abs() < 0.1, "yield at {measured:e} Pa");
    // released, the body's energy is least at a longer shape: the permanent set
    let loaded = sim.bond_state();
    let mut energy_at = |e: f64| {
        sim.set_bond_state(&loaded).expect("state");
        let c = centre(&particles);
        sim.set_displacement(&|_, x| {
            let d = [0, 1, 2].map(|a| f64::from(x[a] - c[a]));
            [e * d[0], -nu * e * d[1], -nu * e * d[2]].map(|u| u as f32)
        })
        .expect("load");
        sim.finish_frame().expect("frame");
        sim.energy().bond_j
    };
    let samples: Vec<(f64, f64)> =
        (0..=20).map(|k| k as f64 / 20.0 * 2.0 * yield_strain).map(|e| (e, energy_at(e))).collect();
    let (set, _) = samples.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1)).expect("samples");
    eprintln!("permanent set {set:.3e} on the GPU (yield strain {yield_strain:.3e})");
    assert!(set > 0.2 * yield_strain && set <= yield_strain, "permanent set {set:e}");
}

#[test]
fn the_plastic_extension_never_exceeds_its_cap_on_the_gpu() {
    let (nu, cap) = (0.3, 5e-4);
    let material = format!("yield_stress_pa = {YIELD_STRESS_PA}\nplastic_cap_ratio = {cap}\ncritical_stretch = 0.5");
    let (config, particles) = block([9, 9, 9], nu, &material, "");
    let mut sim = gpu(&config, &particles);
    let mut largest = 0.0f64;
    load_uniaxially(&mut sim, &particles, nu, steps(5.0 * YIELD_STRESS_PA / E, 50), |_, state| {
        largest = largest.max(largest_plastic_ratio(state, &particles));
    });
    eprintln!("largest plastic extension {largest:.4e} |xi| on the GPU (cap {cap:e})");
    assert!(largest <= cap * (1.0 + 1e-6), "plastic extension {largest:e} |xi| over the cap");
    assert!(largest > 0.99 * cap, "the load should reach the cap: {largest:e}");
}

/// The CPU tests' struck plate: contact, plasticity and fracture all in play.
fn struck_plate() -> (PipelineConfig, ParticleSet) {
    block(
        [16, 16, 3],
        0.3,
        "yield_stress_pa = 2e8\nplastic_cap_ratio = 0.05\ndamage_strengthening = 1.0\ncritical_stretch = 0.004",
        "dt_s = 4e-8\n[[sim.projectile]]\ncenter_m = [0.0, 0.0, 0.0045]\nvelocity_m_s = [0.0, 0.0, -300.0]\nradius_m = \
         0.002\nstiffness_pa = 1e12",
    )
}

#[test]
fn the_gpu_and_the_cpu_agree_on_a_struck_plate() {
    let (config, particles) = struck_plate();
    let mut on_gpu = gpu(&config, &particles);
    let mut on_cpu = CpuSimulation::from_config(&config, &particles).expect("simulation");
    let (mut gpu_breaks, mut cpu_breaks) = (0, 0);
    for _ in 0..4 {
        gpu_breaks += run(&mut on_gpu, 100);
        cpu_breaks += run(&mut on_cpu, 100);
    }
    let (g, c) = (on_gpu.dynamics(), on_cpu.dynamics());
    let n = particles.len();
    let norm = |d: &[Vec<f32>; 3]| (0..n).map(|i| (0..3).map(|a| f64::from(d[a][i]).powi(2)).sum::<f64>()).sum::<f64>();
    let difference: f64 =
        (0..n).map(|i| (0..3).map(|a| f64::from(g.disp[a][i] - c.disp[a][i]).powi(2)).sum::<f64>()).sum();
    let relative = (difference / norm(&c.disp)).sqrt();
    let flowed = |state: Vec<f32>| state.iter().filter(|p| **p != 0.0).count();
    let (gpu_flowed, cpu_flowed) = (flowed(on_gpu.bond_state()), flowed(on_cpu.bond_state()));
    let (ge, ce) = (on_gpu.energy(), on_cpu.energy());
    eprintln!(
        "struck plate, 400 steps: bonds broken GPU {gpu_breaks} / CPU {cpu_breaks}; entries flowed {gpu_flowed} / \
         {cpu_flowed}; rms displacement difference {relative:.2e} of the CPU's; energy {:.6e} / {:.6e} J",
        ge.total_j(),
        ce.total_j()
    );
    assert!(cpu_breaks > 50 && cpu_flowed > 100, "the plate should crack and yield");
    assert!((gpu_breaks as f64 / cpu_breaks as f64 - 1.0).abs() < 0.05, "{gpu_breaks} against {cpu_breaks} breaks");
    assert!((gpu_flowed as f64 / cpu_flowed as f64 - 1.0).abs() < 0.05, "{gpu_flowed} against {cpu_flowed}");
    assert!(relative < 0.02, "displacements differ by {relative:e} of their size");
    assert!((ge.total_j() / ce.total_j() - 1.0).abs() < 0.01);
}

#[test]
fn a_resumed_gpu_run_matches_an_uninterrupted_one_bit_for_bit() {
    let (config, particles) = struck_plate();
    let mut whole = gpu(&config, &particles);
    let mut broken = Vec::new();
    whole.advance(150).expect("advance");
    broken.extend(whole.finish_frame().expect("frame").iter().map(|e| e.bond));
    let (dynamics, state) = (whole.dynamics().clone(), whole.bond_state());
    run(&mut whole, 150);
    broken.sort_unstable();
    let mut resumed = gpu(&config, &particles);
    resumed.restore(dynamics, &broken).expect("restore");
    resumed.set_bond_state(&state).expect("state");
    run(&mut resumed, 150);
    assert!(!broken.is_empty() && state.iter().any(|p| *p != 0.0), "the plate should crack and yield before the cut");
    assert!(whole.dynamics() == resumed.dynamics(), "the resumed run's state differs");
    assert_eq!(whole.bond_state(), resumed.bond_state());
    assert_eq!(whole.energy().total_j().to_bits(), resumed.energy().total_j().to_bits());
}

#[test]
fn a_beam_stretched_by_grips_thins_by_its_poisson_ratio_on_the_gpu() {
    let (nu, speed) = (0.4, 0.5);
    let grips = format!(
        "dt_s = 4e-8\n[[sim.grip]]\nbox_min_m = [-0.02, -0.01, -0.01]\nbox_max_m = [-0.0125, 0.01, 0.01]\n\
         velocity_m_s = [-{speed}, 0.0, 0.0]\n[[sim.grip]]\nbox_min_m = [0.0125, -0.01, -0.01]\n\
         box_max_m = [0.02, 0.01, 0.01]\nvelocity_m_s = [{speed}, 0.0, 0.0]\nrelease_s = 1.0"
    );
    let (config, particles) = block([30, 6, 6], nu, "critical_stretch = 0.05", &grips);
    let mut sim = gpu(&config, &particles);
    let steps = 2000;
    assert_eq!(run(&mut sim, steps), 0);
    let x = |i: usize, a: usize| f64::from(particles.rest_position_m[i][a]);
    let u = |i: usize, a: usize| f64::from(sim.dynamics().disp[a][i]);
    let end = (0..particles.len()).max_by(|a, b| x(*a, 0).total_cmp(&x(*b, 0))).expect("particles");
    let expected = speed * steps as f64 * sim.model().dt_s;
    assert!((u(end, 0) / expected - 1.0).abs() < 1e-3, "the grip moved {:e} m, not {expected:e} m", u(end, 0));
    let middle: Vec<usize> = (0..particles.len()).filter(|&i| x(i, 0).abs() < 5.0 * LAMBDA).collect();
    let slope = |a: usize| {
        let n = middle.len() as f64;
        let (mx, mu) = middle.iter().fold((0.0, 0.0), |(sx, su), &i| (sx + x(i, a) / n, su + u(i, a) / n));
        let (num, den) = middle
            .iter()
            .fold((0.0, 0.0), |(p, q), &i| (p + (x(i, a) - mx) * (u(i, a) - mu), q + (x(i, a) - mx).powi(2)));
        num / den
    };
    let measured = -0.5 * (slope(1) + slope(2)) / slope(0);
    let (energy, work) = (sim.energy().total_j(), sim.dynamics().external_work_j);
    eprintln!("nu = {nu}: thinning ratio {measured:.3} on the GPU; grip work {work:.4e} J, energy {energy:.4e} J");
    assert!((measured - nu).abs() < 0.06, "nu = {nu}: measured {measured}");
    assert!((energy / work - 1.0).abs() < 0.02, "energy {energy:e} J against the grips' work {work:e} J");
}

#[test]
fn bonds_beyond_one_binding_are_refused_with_their_sizes() {
    let (config, particles) = struck_plate();
    let ctx = GpuContext::shared_for_tests().unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    let model = Model::new(&config, &particles).expect("model");
    let options = GpuOptions { max_binding_bytes: Some(256 * 1024), ..GpuOptions::default() };
    let error = GpuSimulation::new(ctx.into(), &particles, model, None, config.sim.stiffness_correction, &options)
        .expect_err("more than one binding");
    eprintln!("{error}");
    assert!(error.to_string().contains("one storage binding") && error.to_string().contains("262144"), "{error}");
}
