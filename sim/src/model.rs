//! The physical model of a run: constants derived from the config and the particle file, and the
//! checks that refuse a run that cannot be right.

use glam::DVec3;
use shatter_core::PipelineConfig;
use shatter_core::config::material::MaterialModel;
use shatter_core::config::sim::{BreakRule, BreakingStepForce, CompressionBoost, ContactModel, Rules};
use shatter_core::particles::ParticleSet;
use shatter_core::time_step;

use crate::SimError;
use crate::elastoplastic::StateBasedConstants;

/// The lightest particle's mass, kg (what a pushing body throws farthest in one step).
pub(crate) fn lightest_kg(particles: &ParticleSet) -> f64 {
    particles.mass_kg.iter().fold(f64::INFINITY, |least, mass| least.min(f64::from(*mass)))
}

/// A sphere on a straight path at constant velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MovingSphere {
    /// Centre at t = 0, metres.
    pub center_m: DVec3,
    /// Velocity, m/s.
    pub velocity_m_s: DVec3,
    /// Radius, metres.
    pub radius_m: f64,
    /// Force constant: K_S (Pa) for a projectile, K (N/m^2) for an indenter.
    pub stiffness: f64,
}

impl MovingSphere {
    /// Centre at time `t` seconds.
    pub fn center_at(&self, t: f64) -> DVec3 {
        self.center_m + self.velocity_m_s * t
    }
}

/// The floor plane y = height.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Floor {
    /// Height, metres.
    pub height_m: f32,
    /// Fraction of the normal velocity kept on a bounce.
    pub restitution: f32,
}

/// A grip: particles held at a set velocity until a release time.
#[derive(Debug, Clone, PartialEq)]
pub struct Grip {
    /// The particles it holds, in index order.
    pub particles: Vec<u32>,
    /// Their velocity, m/s.
    pub velocity_m_s: [f32; 3],
    /// When it lets go, seconds (infinite: never).
    pub release_s: f64,
}

/// Sets the velocity of every particle a grip holds at time `t` to the grip's.
pub(crate) fn hold_grips(grips: &[Grip], t: f64, vel: &mut [Vec<f32>; 3]) {
    for grip in grips.iter().filter(|grip| t < grip.release_s) {
        for &i in &grip.particles {
            for (axis, v) in grip.velocity_m_s.into_iter().enumerate() {
                vel[axis][i as usize] = v;
            }
        }
    }
}

/// Everything the step needs besides the state.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    /// Time step, seconds: `sim.dt_s`, or with it unset the material's, which the backend
    /// takes when it has its bond tables ([`Model::take_time_step`]).
    pub dt_s: f64,
    /// Whether the time step comes from the material (`sim.dt_s` is unset).
    pub dt_from_material: bool,
    /// The longest step at which every pushing body holds the lightest particle, seconds
    /// (infinite without one).
    pub push_limit_s: f64,
    /// Bond constant c = 18 K / (pi delta^4), N/m^6.
    pub bond_constant: f64,
    /// Compression strengthening alpha.
    pub alpha: f32,
    /// Which threshold decides.
    pub break_rule: BreakRule,
    /// The rule set's four rules.
    pub rules: Rules,
    /// The lattice spacing lambda, metres.
    pub lambda_m: f64,
    /// The horizon delta, metres.
    pub delta_m: f64,
    /// Gravity, m/s^2.
    pub gravity_m_s2: [f32; 3],
    /// K_c, Pa (0: no contact).
    pub contact_stiffness_pa: f32,
    /// d_c, metres.
    pub contact_distance_m: f32,
    /// The floor, if any.
    pub floor: Option<Floor>,
    /// Projectiles (the paper's eq. 7).
    pub projectiles: Vec<MovingSphere>,
    /// Spherical indenters, F = K (R - r)^2.
    pub indenters: Vec<MovingSphere>,
    /// Grips (CPU backend).
    pub grips: Vec<Grip>,
    /// Multiplier from the file's thresholds to this run's (the material may have changed).
    pub threshold_scale: f64,
    /// Density, kg/m^3.
    pub density_kg_m3: f64,
    /// The elastoplastic model's constants; None: the PMB model.
    pub elastoplastic: Option<StateBasedConstants>,
}

impl Model {
    /// The model a config describes for a particle set. Fails when the particle file was made
    /// from different geometry settings, or a body starts inside the particles or below the floor.
    pub fn new(config: &PipelineConfig, particles: &ParticleSet) -> Result<Model, SimError> {
        check_particles_match(config, particles)?;
        let sim = &config.sim;
        let material = &config.material;
        let delta = particles.meta.delta_m;
        let sphere = |center: [f64; 3], velocity: [f64; 3], radius: f64, stiffness: f64| MovingSphere {
            center_m: DVec3::from_array(center),
            velocity_m_s: DVec3::from_array(velocity),
            radius_m: radius,
            stiffness,
        };
        let lightest_kg = lightest_kg(particles);
        let model = Model {
            dt_s: sim.dt_s.unwrap_or(0.0),
            dt_from_material: sim.dt_s.is_none(),
            push_limit_s: sim
                .pushing_bodies()
                .iter()
                .map(|body| body.max_dt_s(lightest_kg))
                .fold(f64::INFINITY, f64::min),
            bond_constant: 18.0 * material.bulk_modulus_pa / (std::f64::consts::PI * delta.powi(4)),
            alpha: material.compression_alpha as f32,
            break_rule: sim.break_rule,
            rules: sim.rules(),
            lambda_m: particles.meta.lambda_m,
            delta_m: delta,
            gravity_m_s2: sim.gravity_m_s2.map(|g| g as f32),
            contact_stiffness_pa: sim.contact.stiffness_pa as f32,
            contact_distance_m: sim.contact.distance_m.unwrap_or(0.5 * particles.meta.lambda_m) as f32,
            floor: sim
                .floor
                .as_ref()
                .map(|floor| Floor { height_m: floor.height_m as f32, restitution: floor.restitution as f32 }),
            projectiles: sim
                .projectile
                .iter()
                .map(|p| sphere(p.center_m, p.velocity_m_s, p.radius_m, p.stiffness_pa))
                .collect(),
            indenters: sim
                .indenter
                .iter()
                .map(|p| sphere(p.center_m, p.velocity_m_s, p.radius_m, p.stiffness_n_m2))
                .collect(),
            grips: grips(config, particles)?,
            threshold_scale: material.mean_critical_stretch(delta) / particles.meta.mean_critical_stretch,
            density_kg_m3: material.density_kg_m3,
            elastoplastic: (material.model == MaterialModel::Elastoplastic)
                .then(|| StateBasedConstants::of(config, delta)),
        };
        model.check_start(particles)?;
        Ok(model)
    }

    /// Takes the time step from the material when `sim.dt_s` is unset: the largest power of two
    /// at most half the smaller of `stable_dt_s` (the bond tables' stable step, seconds) and the
    /// pushing bodies' limit ([`shatter_core::time_step`]). Fails, naming the key to set, when
    /// nothing limits the step.
    pub(crate) fn take_time_step(&mut self, stable_dt_s: f64) -> Result<(), String> {
        if !self.dt_from_material {
            return Ok(());
        }
        let limit_s = stable_dt_s.min(self.push_limit_s);
        self.dt_s = time_step::from_limit_s(limit_s).ok_or_else(|| {
            format!(
                "sim.dt_s is unset and nothing sets a step (stable step {stable_dt_s:e} s, pushing bodies' limit \
                 {:e} s): set sim.dt_s",
                self.push_limit_s
            )
        })?;
        Ok(())
    }

    /// The spring pass's rules.
    pub fn pass_rules(&self) -> crate::kernels::PassRules {
        crate::kernels::PassRules {
            signed_boost: self.rules.compression_boost == CompressionBoost::Signed,
            breaking_step_force: self.rules.breaking_step_force == BreakingStepForce::Applied,
        }
    }

    /// Whether contact acts at all: LAMMPS's always does, the penalty contact when it has a
    /// stiffness.
    pub fn has_contact(&self) -> bool {
        self.rules.contact == ContactModel::Lammps || self.contact_stiffness_pa > 0.0
    }

    /// The distance within which contact candidates are gathered: 1.35 lambda for LAMMPS's
    /// short-range force, d_c for the penalty contact.
    pub fn contact_reach_m(&self) -> f32 {
        match self.rules.contact {
            ContactModel::Lammps => (1.35 * self.lambda_m) as f32,
            ContactModel::Penalty => self.contact_distance_m,
        }
    }

    /// Refuses bodies that start inside the particles (they would fire them off at once) and
    /// particles that start below the floor.
    fn check_start(&self, particles: &ParticleSet) -> Result<(), SimError> {
        let nearest = |center: DVec3| {
            particles
                .rest_position_m
                .iter()
                .enumerate()
                .map(|(i, p)| (i, DVec3::from_array(p.map(f64::from)).distance(center)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
        };
        for (index, projectile) in self.projectiles.iter().enumerate() {
            let reach = 1.5 * projectile.radius_m;
            if let Some((particle, distance)) = nearest(projectile.center_m).filter(|(_, d)| *d < reach) {
                return Err(SimError::BadStart(format!(
                    "sim.projectile[{index}] starts inside or touching the body: particle {particle} is {distance:.4e} m \
                     from its centre, and the projectile pushes out to 3r/2 = {reach:.4e} m; start it farther away"
                )));
            }
        }
        for (index, indenter) in self.indenters.iter().enumerate() {
            if let Some((particle, distance)) = nearest(indenter.center_m).filter(|(_, d)| *d < indenter.radius_m) {
                return Err(SimError::BadStart(format!(
                    "sim.indenter[{index}] starts inside the body: particle {particle} is {distance:.4e} m from its \
                     centre, within its radius {:.4e} m; start it farther away",
                    indenter.radius_m
                )));
            }
        }
        if let Some(floor) = &self.floor
            && let Some((i, p)) = particles.rest_position_m.iter().enumerate().find(|(_, p)| p[1] < floor.height_m)
        {
            return Err(SimError::BadStart(format!(
                "particle {i} starts at y = {} m, below the floor at sim.floor.height_m = {} m; move the body up \
                     (geometry.transform.translate_m) or the floor down",
                p[1], floor.height_m
            )));
        }
        Ok(())
    }
}

/// The grips of a config: each holds the particles whose rest positions lie in its box, and must
/// hold at least one.
fn grips(config: &PipelineConfig, particles: &ParticleSet) -> Result<Vec<Grip>, SimError> {
    config
        .sim
        .grip
        .iter()
        .enumerate()
        .map(|(index, grip)| {
            let inside = |p: &[f32; 3]| (0..3).all(|a| (grip.box_min_m[a]..=grip.box_max_m[a]).contains(&f64::from(p[a])));
            let held: Vec<u32> =
                (0..particles.len()).filter(|&i| inside(&particles.rest_position_m[i])).map(|i| i as u32).collect();
            if held.is_empty() {
                return Err(SimError::BadStart(format!(
                    "sim.grip[{index}] holds no particle: no rest position lies between box_min_m = {:?} and box_max_m = \
                     {:?}; place the box over the part of the body to hold",
                    grip.box_min_m, grip.box_max_m
                )));
            }
            Ok(Grip {
                particles: held,
                velocity_m_s: grip.velocity_m_s.map(|v| v as f32),
                release_s: grip.release_s.unwrap_or(f64::INFINITY),
            })
        })
        .collect()
}

/// The particle file must come from the config's geometry (else `shatter preprocess` is due).
fn check_particles_match(config: &PipelineConfig, particles: &ParticleSet) -> Result<(), SimError> {
    let meta = &particles.meta;
    let geometry = &config.geometry;
    let relative_mismatch = |a: f64, b: f64| (a - b).abs() > 1e-9 * a.abs().max(b.abs());
    let stale = |key: &str, file: String, config: String| {
        Err(SimError::StaleParticles(format!(
            "the particle file was made with {key} = {file}, the config now says {config}; run `shatter preprocess` \
             again"
        )))
    };
    if relative_mismatch(meta.lambda_m, geometry.spacing_m) && meta.sampler == "grid" {
        return stale("geometry.spacing_m", meta.lambda_m.to_string(), geometry.spacing_m.to_string());
    }
    if relative_mismatch(meta.horizon_factor, geometry.horizon_factor) {
        return stale("geometry.horizon_factor", meta.horizon_factor.to_string(), geometry.horizon_factor.to_string());
    }
    if meta.sampler != geometry.sampler.name() {
        return stale("geometry.sampler", meta.sampler.clone(), geometry.sampler.name().to_string());
    }
    if meta.source != geometry.source.to_string() {
        return stale("geometry.source", meta.source.clone(), geometry.source.to_string());
    }
    if relative_mismatch(meta.threshold_jitter, config.material.threshold_jitter) {
        return stale(
            "material.threshold_jitter",
            meta.threshold_jitter.to_string(),
            config.material.threshold_jitter.to_string(),
        );
    }
    if meta.seed != config.scene.seed {
        return stale("scene.seed", meta.seed.to_string(), config.scene.seed.to_string());
    }
    Ok(())
}
