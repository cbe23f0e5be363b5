//! The physics tests against theory, written once against the [`Backend`] trait and run on both
//! backends (`physics.rs` on the CPU, `gpu_physics.rs` on the GPU): rigid motions, conservation
//! laws, energy density, wave speed, the breaking stretch.

use std::path::Path;

use shatter_core::NoProgress;
use shatter_core::config::PipelineConfig;
use shatter_core::particles::ParticleSet;
use shatter_sim::Backend;

/// Makes the backend under test for a scene.
pub type Make = dyn Fn(&PipelineConfig, &ParticleSet) -> Box<dyn Backend>;

const K: f64 = 14.9e9;
const RHO: f64 = 2200.0;
const LAMBDA: f64 = 0.001;

/// A box of `counts` cubes of 1 mm at horizon factor `n`, with extra `[material]` and `[sim]` keys.
pub fn block(counts: [usize; 3], n: f64, material: &str, sim: &str) -> (PipelineConfig, ParticleSet) {
    load(&block_text(counts, n, material, sim))
}

/// The TOML text of [`block`]'s scene (no gravity), for tests that edit it further.
pub fn block_text(counts: [usize; 3], n: f64, material: &str, sim: &str) -> String {
    let size = counts.map(|c| c as f64 * LAMBDA);
    format!(
        r#"
[scene]
name = "t"
output_dir = "out"
seed = 4
[geometry]
source = "box"
box_size_m = {size:?}
sampler = "grid"
spacing_m = {LAMBDA}
horizon_factor = {n}
[material]
density_kg_m3 = {RHO}
bulk_modulus_pa = {K}
{material}
[sim]
gravity_m_s2 = [0.0, 0.0, 0.0]
{sim}
"#
    )
}

/// A scene's config and its preprocessed particles.
pub fn load(text: &str) -> (PipelineConfig, ParticleSet) {
    let config = PipelineConfig::from_toml_str(text, Path::new("/nonexistent/pipeline.toml")).expect("valid config");
    let particles = shatter_preprocess::preprocess(&config, &NoProgress).expect("preprocess").particles;
    (config, particles)
}

pub fn max_force(sim: &dyn Backend) -> f64 {
    let force = &sim.dynamics().force;
    (0..sim.len()).map(|i| (0..3).map(|a| f64::from(force[a][i]).powi(2)).sum::<f64>().sqrt()).fold(0.0, f64::max)
}

fn centre(particles: &ParticleSet) -> [f32; 3] {
    let n = particles.len() as f64;
    [0, 1, 2].map(|a| (particles.rest_position_m.iter().map(|p| f64::from(p[a])).sum::<f64>() / n) as f32)
}

fn step(sim: &mut dyn Backend, steps: u64) {
    sim.advance(steps).expect("advance");
    assert!(sim.finish_frame().expect("frame").is_empty(), "no fracture in this test");
}

/// Scenario: see the test of this name.
pub fn rigid_motions_cause_no_internal_force(make: &Make) {
    let (config, particles) = block([8, 7, 6], 3.0, "", "");
    let mut sim = make(&config, &particles);
    sim.set_displacement(&|_, _| [0.013, -0.021, 0.0047]).expect("set");
    assert_eq!(max_force(&*sim), 0.0, "a translation stretches nothing");

    let c = centre(&particles);
    let strain = 1e-4f32;
    sim.set_displacement(&|_, x| [0, 1, 2].map(|a| strain * (x[a] - c[a]))).expect("set");
    let dilation_force = max_force(&*sim);
    assert!(dilation_force > 0.0);

    let rotation = glam::Quat::from_axis_angle(glam::Vec3::new(1.0, 2.0, 3.0).normalize(), 0.6);
    let c3 = glam::Vec3::from_array(c);
    sim.set_displacement(&|_, x| {
        let x = glam::Vec3::from_array(x);
        (rotation * (x - c3) + c3 + glam::Vec3::new(0.01, 0.0, -0.02) - x).to_array()
    })
    .expect("set");
    // Express the residual as the strain that would cause it: f32 rounding is about 1e-7.
    let residual = max_force(&*sim);
    let equivalent_strain = residual / dilation_force * f64::from(strain);
    eprintln!("rotation leaves forces of a {equivalent_strain:e} strain");
    assert!(equivalent_strain < 1e-6, "rotation leaves forces of a {equivalent_strain:e} strain");
    assert!(sim.finish_frame().expect("frame").is_empty());
}

/// A bar along x in its first longitudinal mode u_x = A cos(pi x / L), released from rest.
fn vibrating_bar(
    make: &Make,
    length: usize,
    section: [usize; 2],
    amplitude: f32,
    sim_keys: &str,
) -> (Box<dyn Backend>, ParticleSet) {
    let (config, particles) = block([length, section[0], section[1]], 3.0, "critical_stretch = 0.01", sim_keys);
    let mut sim = make(&config, &particles);
    let half_length = length as f32 * LAMBDA as f32 / 2.0;
    let c = centre(&particles);
    sim.set_displacement(&|_, x| {
        let phase = std::f32::consts::PI * (x[0] - c[0] + half_length) / (2.0 * half_length);
        [amplitude * phase.cos(), 0.0, 0.0]
    })
    .expect("set");
    (sim, particles)
}

/// Scenario: see the test of this name.
pub fn momentum_and_energy_are_conserved_in_an_elastic_vibration(make: &Make) {
    let (mut sim, _) = vibrating_bar(make, 24, [4, 4], 2e-6, "contact = { stiffness_pa = 0.0 }");
    sim.set_velocity(&|i, _| {
        let spin = (i % 7) as f32 * 0.01;
        [0.02 + spin, -0.01, 0.03 - spin]
    })
    .expect("set");
    let (p0, l0) = sim.momentum();
    let scale: f64 = sim.mass().iter().map(|m| f64::from(*m)).sum::<f64>() * 0.05;
    // Velocity Verlet's energy oscillates about a constant (here by about 0.5%: the bar's
    // lateral breathing modes run at omega dt ~ 0.3); drift is the change of its mean, taken
    // over the first and the last 1,000 steps of 20,000.
    let mut energies = Vec::new();
    for frame in 0..2_000 {
        step(&mut *sim, 10);
        energies.push(sim.energy().total_j());
        if frame % 50 == 0 {
            let (p, _) = sim.momentum();
            assert!((p - p0).length() < 1e-5 * scale, "linear momentum drifted by {}", (p - p0).length());
        }
    }
    let (_, l) = sim.momentum();
    let lever = 0.012; // half the bar
    assert!((l - l0).length() < 1e-4 * scale * lever, "angular momentum drifted by {}", (l - l0).length());
    let mean = |values: &[f64]| values.iter().sum::<f64>() / values.len() as f64;
    let (first, last) = (mean(&energies[..100]), mean(&energies[energies.len() - 100..]));
    let drift = (last - first).abs() / first;
    let swing = energies.iter().map(|e| (e - first).abs() / first).fold(0.0, f64::max);
    eprintln!("energy drift {:.4}% over 20,000 steps (largest swing {:.3}%)", drift * 100.0, swing * 100.0);
    assert!(drift < 0.005, "energy drifted by {:.3}% over 20,000 steps", drift * 100.0);
    assert!(swing < 0.02, "energy swings by {:.3}%", swing * 100.0);
}

/// Scenario: see the test of this name.
pub fn uniform_dilation_stores_the_continuum_energy_density_at_n3(make: &Make) {
    let s = 1e-4f32;
    for (correction, tolerance) in [("energy", 0.03), ("none", 0.15)] {
        let (config, particles) = block([13, 13, 13], 3.0, "", &format!("stiffness_correction = \"{correction}\""));
        let mut sim = make(&config, &particles);
        let c = centre(&particles);
        sim.set_displacement(&|_, x| [0, 1, 2].map(|a| s * (x[a] - c[a]))).expect("set");
        let energy = sim.bond_energy_per_particle();
        let middle = (0..particles.len())
            .min_by(|a, b| {
                let d = |i: usize| (0..3).map(|k| (particles.rest_position_m[i][k] - c[k]).powi(2)).sum::<f32>();
                d(*a).total_cmp(&d(*b))
            })
            .expect("particles");
        let density = energy[middle] / f64::from(particles.volume_m3[middle]);
        let theory = 4.5 * K * f64::from(s).powi(2);
        let error = density / theory - 1.0;
        eprintln!("stiffness_correction = {correction}: interior energy density off by {:.2}%", error * 100.0);
        assert!(error.abs() < tolerance, "{correction}: {:.2}% off", error * 100.0);
    }
}

/// Times between upward zero crossings of `samples` (taken every `dt`).
fn period(samples: &[f64], dt: f64) -> f64 {
    let crossings: Vec<f64> = samples
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[0] < 0.0 && w[1] >= 0.0)
        .map(|(k, w)| (k as f64 + w[0] / (w[0] - w[1])) * dt)
        .collect();
    assert!(crossings.len() >= 2, "not enough oscillation: {crossings:?}");
    (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64
}

/// A bar `length` particles long and 8 x 8 across in its first longitudinal mode, run for
/// `steps` steps and sampled every `every` steps: the wave travels at sqrt(1.5 K / rho) within
/// 5%. (The stiffness correction leaves the thinnest bars a little stiff: 4 x 4 +14%, 6 x 6 +7%,
/// 8 x 8 +3.7%; without it they are soft: -17%, -12%, -9%.)
pub fn a_longitudinal_wave_in_a_bar_travels_at_the_bar_speed(make: &Make, length: usize, steps: u64, every: u64) {
    let (mut sim, particles) = vibrating_bar(make, length, [8, 8], 1e-6, "");
    let dt = sim.model().dt_s;
    let c = centre(&particles);
    // the end 5 mm of the bar
    let from_centre = (length as f64 / 2.0 - 5.0) * LAMBDA;
    let end: Vec<usize> =
        (0..particles.len()).filter(|&i| f64::from(particles.rest_position_m[i][0] - c[0]) > from_centre).collect();
    let started = std::time::Instant::now();
    let mut samples = Vec::new();
    for _ in 0..steps / every {
        step(&mut *sim, every);
        let u = &sim.dynamics().disp[0];
        samples.push(end.iter().map(|&i| f64::from(u[i])).sum::<f64>() / end.len() as f64);
    }
    let speed = 2.0 * length as f64 * LAMBDA / period(&samples, every as f64 * dt);
    let theory = (1.5 * K / RHO).sqrt();
    let error = speed / theory - 1.0;
    eprintln!(
        "bar wave speed {speed:.1} m/s, theory {theory:.1} m/s ({:+.2}%); {} particles, {steps} steps in {:.1?}",
        error * 100.0,
        particles.len(),
        started.elapsed()
    );
    assert!(error.abs() < 0.05, "wave speed off by {:.2}%", error * 100.0);
}

/// Scenario: see the test of this name.
pub fn a_bar_pulled_apart_breaks_first_where_and_when_its_thresholds_say(make: &Make) {
    // A seam across the middle halves the thresholds of the bonds crossing it.
    let (config, particles) = block(
        [30, 3, 3],
        3.0,
        "",
        "[[sim.seam]]\npoint_m = [0.0, 0.0, 0.0]\nnormal = [1.0, 0.0, 0.0]\nthreshold_factor = 0.5",
    );
    let c = centre(&particles);
    let bonds = &particles.bonds;
    let x = |i: usize| particles.rest_position_m[i].map(f64::from);
    // Under u = e (x - c) x_hat a bond stretches to |(xi_x (1 + e), xi_y, xi_z)| / L - 1: it
    // breaks at e = sqrt(((1 + tau) L)^2 - xi_y^2 - xi_z^2) / |xi_x| - 1.
    let mut predicted = (f64::INFINITY, 0u64);
    for i in 0..particles.len() {
        for k in bonds.row(i) {
            let j = bonds.neighbor[k] as usize;
            let xi = [0, 1, 2].map(|a| x(j)[a] - x(i)[a]);
            if j < i || xi[0] == 0.0 {
                continue;
            }
            let crosses = (x(i)[0] - f64::from(c[0])) * (x(j)[0] - f64::from(c[0])) < 0.0;
            let tau = f64::from(bonds.threshold[k]) * if crosses { 0.5 } else { 1.0 };
            let length = f64::from(bonds.rest_length_m[k]);
            let e = (((1.0 + tau) * length).powi(2) - xi[1].powi(2) - xi[2].powi(2)).sqrt() / xi[0].abs() - 1.0;
            if e < predicted.0 {
                predicted = (e, k as u64);
            }
        }
    }
    let (e_star, first_bond) = predicted;
    let mut sim = make(&config, &particles);
    let increment = 2e-4 * e_star;
    let mut e = 0.99 * e_star;
    let breaks = loop {
        sim.set_displacement(&|_, p| [e as f32 * (p[0] - c[0]), 0.0, 0.0]).expect("set");
        let breaks = sim.finish_frame().expect("frame");
        if !breaks.is_empty() {
            break breaks;
        }
        e += increment;
        assert!(e < 1.1 * e_star, "nothing broke by 1.1 x the predicted stretch");
    };
    assert!(
        e >= e_star * (1.0 - 1e-5) && e <= e_star + increment * 1.01,
        "first break at e = {e:e}, predicted {e_star:e}"
    );
    assert!(breaks.iter().any(|b| b.bond == first_bond), "bond {first_bond} should break first: {breaks:?}");
    for event in &breaks {
        let i = bonds.offsets.partition_point(|o| *o <= event.bond) - 1;
        let j = bonds.neighbor[event.bond as usize] as usize;
        assert!((x(i)[0] - f64::from(c[0])) * (x(j)[0] - f64::from(c[0])) < 0.0, "bond {i}-{j} is not on the seam");
    }
}

/// Checks the step a backend took with `sim.dt_s` unset: the largest power of two at most half
/// the smaller of its stable step and the pushing bodies' limit.
fn takes_the_largest_power_of_two_under_half_the_limit(sim: &dyn Backend, what: &str) -> f64 {
    let (dt, limit) = (sim.model().dt_s, sim.stable_dt_s().min(sim.model().push_limit_s));
    assert!(sim.model().dt_from_material, "{what}");
    assert_eq!(dt, 2f64.powi(dt.log2().round() as i32), "{what}: {dt:e} is a power of two");
    assert!(dt <= 0.5 * limit && 0.5 * limit < 2.0 * dt, "{what}: {dt:e} against the limit {limit:e}");
    dt
}

/// With `sim.dt_s` unset the backend takes its step from the material: the paper's glass on its
/// 1 mm grid at N = 3 lands on the paper's 2^-23 s; the LAMMPS rules and an elastoplastic steel
/// take theirs by the same rule from their own stable steps; a stiff projectile's limit binds
/// when it is the smaller.
pub fn an_unset_time_step_is_taken_from_the_material(make: &Make) {
    let (config, particles) = block([8, 8, 4], 3.0, "", "");
    let glass = make(&config, &particles);
    assert_eq!(takes_the_largest_power_of_two_under_half_the_limit(glass.as_ref(), "glass"), 2f64.powi(-23));
    let (config, particles) = block([8, 8, 4], 3.0, "", "rules = \"lammps\"");
    takes_the_largest_power_of_two_under_half_the_limit(make(&config, &particles).as_ref(), "LAMMPS's rules");
    let steel = block_text([8, 8, 4], 3.0, "model = \"elastoplastic\"\nshear_modulus_pa = 7.1e10", "")
        .replace(&format!("density_kg_m3 = {RHO}"), "density_kg_m3 = 7850.0")
        .replace(&format!("bulk_modulus_pa = {K}"), "bulk_modulus_pa = 3.33e11");
    let (config, particles) = load(&steel);
    let steel = make(&config, &particles);
    let dt = takes_the_largest_power_of_two_under_half_the_limit(steel.as_ref(), "steel");
    assert!(dt < 2f64.powi(-23), "steel is stiffer and heavier than glass: {dt:e}");
    let stiff = "[[sim.projectile]]\ncenter_m = [0.0, 0.0, 0.0075]\nvelocity_m_s = [0.0, 0.0, -10.0]\n\
                 radius_m = 0.003\nstiffness_pa = 1e13";
    let (config, particles) = block([8, 8, 4], 3.0, "", stiff);
    let struck = make(&config, &particles);
    assert!(struck.model().push_limit_s < struck.stable_dt_s(), "the projectile binds");
    takes_the_largest_power_of_two_under_half_the_limit(struck.as_ref(), "a stiff projectile");
}
