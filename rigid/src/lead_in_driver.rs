//! The `shatter lead-in` driver: the intact body flies as one rigid body (rapier3d) from its
//! start pose and velocity until it comes within the handoff gap of its first contact (floor,
//! projectile or indenter); its frames go to `rigid/lead_in.####.shp` and the handoff, from
//! which the simulation starts, to `rigid/lead_in.shp`.
//!
//! rapier integrates semi-implicit Euler over `solver_iterations` substeps (v += g h, then
//! x += v h), which trails the parabola by g t h / 2. The lead-in takes one substep per step
//! (nothing touches the body, so no solver iterations are needed) and starts the velocity half a
//! step back (v0 - g dt / 2): the same update is then the leapfrog scheme, exact for a uniform
//! field. The body's centre follows the parabola to rounding (tested to 1e-9), and its velocity
//! at a step is rapier's plus g dt / 2. The step is small enough
//! that the body, at the fastest it can reach, crosses at most half the handoff gap per step,
//! and divides a frame evenly, so frames fall on steps.

use std::time::Instant;

use rapier3d_f64::math::{Rotation, Vector};
use shatter_core::config::{LeadInConfig, RigidConfig, TimelineConfig};
use shatter_core::digest;
use shatter_core::fragments::{FragmentFrame, FragmentMeta};
use shatter_core::lead_in::LeadIn;
use shatter_core::particles::ParticleSet;
use shatter_core::stage_file::StageFileError;
use shatter_core::timeline::Timeline;
use shatter_core::{OutputLayout, PipelineConfig, Progress};

use crate::mass::{MassProps, element_mass_props, piece_mass_props};
use crate::rigid_driver::{RigidError, kinematic_spheres, open_particles, world_settings};
use crate::shapes::{ElementGeometry, PieceShape};
use crate::world::{KinematicSphere, PieceBody, RigidWorld, WorldSettings};

/// What a lead-in run did.
#[derive(Debug, Clone, PartialEq)]
pub struct LeadInReport {
    /// The handoff and the body's motion then.
    pub lead_in: LeadIn,
    /// The rigid time step, seconds.
    pub step_s: f64,
    /// The gap to the first contact at the handoff, metres.
    pub gap_m: f64,
    /// Wall time, seconds.
    pub wall_s: f64,
}

/// Runs the lead-in of `config`.
pub fn run_lead_in(config: &PipelineConfig, progress: &dyn Progress) -> Result<LeadInReport, RigidError> {
    let started = Instant::now();
    let Some(lead_in) = &config.lead_in else {
        return Err(RigidError::Input(format!(
            "{}: no [lead_in] table: the shot starts with the simulation (see docs/CONFIG.md)",
            config.path.display()
        )));
    };
    let flight = Flight::plan(config, lead_in)?;
    let mut world = flight.new_world();
    let (frames, steps, clearance) = match &config.timeline {
        None => flight.fly_at_real_speed(&mut world, progress)?,
        Some(timeline) => flight.fly_on_timeline(&mut world, timeline, progress)?,
    };
    progress.finish();
    let handoff = flight.handoff(&world, frames, steps);
    handoff.write(&flight.layout.lead_in())?;
    Ok(LeadInReport { lead_in: handoff, step_s: flight.dt, gap_m: clearance, wall_s: started.elapsed().as_secs_f64() })
}

/// The lead-in's flight, planned: the intact body, its start pose, the step, and the world it
/// flies in.
struct Flight<'a> {
    config: &'a PipelineConfig,
    lead_in: &'a LeadInConfig,
    layout: OutputLayout,
    particles: ParticleSet,
    /// The digest of the simulation's inputs, which the lead-in's files carry.
    inputs: u32,
    /// The intact body's mass properties at rest.
    rest: MassProps,
    shape: PieceShape,
    /// The start pose: x = R X + t.
    rotation: Rotation,
    translation_m: Vector,
    gravity: Vector,
    /// The clearance to the first contact at which the simulation takes over, metres.
    gap_m: f64,
    /// The step, seconds.
    dt: f64,
    /// Steps per frame, without a timeline (0 with one).
    steps_per_frame: u64,
    settings: WorldSettings,
    /// The floor's height, metres.
    floor_m: Option<f64>,
    spheres: Vec<KinematicSphere>,
    /// The most steps the flight may take (`lead_in.max_duration_s`).
    limit: u64,
}

impl<'a> Flight<'a> {
    /// Reads the particles and plans the flight of `lead_in`.
    fn plan(config: &'a PipelineConfig, lead_in: &'a LeadInConfig) -> Result<Flight<'a>, RigidError> {
        let (layout, particles, particles_checksum) = open_particles(config)?;
        let inputs = digest::sim_inputs(particles_checksum, config);

        let elements = element_mass_props(&particles, config.material.density_kg_m3);
        let rest = piece_mass_props(&elements, &vec![0; particles.len()], 1)[0];
        let all: Vec<u32> = (0..particles.len() as u32).collect();
        // the flight touches nothing, so [rigid]'s contact settings do not matter: the defaults keep
        // the lead-in a function of [lead_in], [sim] and the particles alone (its digest)
        let rigid = RigidConfig::default();
        let shape = ElementGeometry::of(&particles).piece_shape(&all, rigid.hull_volume_factor);
        let axis = Vector::from_array(lead_in.rotate_axis).normalize();
        let rotation = Rotation::from_axis_angle(axis, lead_in.rotate_deg.to_radians());
        let translation = rest.centre_m + Vector::from_array(lead_in.translate_m) - rotation * rest.centre_m;
        let gravity = Vector::from_array(config.sim.gravity_m_s2);
        let gap = lead_in.handoff_gap_m.unwrap_or(particles.meta.delta_m);
        let fps = config.scene.frames_per_second;
        let lowest =
            shape.hulls.iter().flatten().map(|p| (rotation * *p + translation).y).fold(f64::INFINITY, f64::min);
        let step_s = step(lead_in, config, gravity, lowest, &shape.hulls, rest.centre_m, gap);
        // without a timeline the frames are a real-speed frame interval apart and fall on steps;
        // with one they fall where it puts them, between steps
        let (dt, steps_per_frame) = match config.timeline {
            None => {
                let steps_per_frame = ((1.0 / fps) / step_s).ceil().max(1.0);
                (1.0 / (fps * steps_per_frame), steps_per_frame as u64)
            }
            Some(_) => (step_s, 0),
        };

        let settings = WorldSettings {
            // one substep: the leapfrog start below is exact for rapier's update only then
            solver_iterations: 1,
            // a flying body never sleeps, is never retired and spins freely
            sleep_speed_m_s: -1.0,
            bounds_m: None,
            rolling_damping_per_s: 0.0,
            rolling_resistance_m_s2: 0.0,
            ..world_settings(config, &rigid, particles.meta.lambda_m)
        };
        let floor_m = config.sim.floor.as_ref().map(|floor| floor.height_m);
        let spheres = kinematic_spheres(config, 0.0);
        let limit = (lead_in.max_duration_s / dt).ceil() as u64;
        Ok(Flight {
            config,
            lead_in,
            layout,
            particles,
            inputs,
            rest,
            shape,
            rotation,
            translation_m: translation,
            gravity,
            gap_m: gap,
            dt,
            steps_per_frame,
            settings,
            floor_m,
            spheres,
            limit,
        })
    }

    /// The world with the body at its start pose, its velocity half a step back (the leapfrog
    /// start, see the module doc).
    fn new_world(&self) -> RigidWorld {
        let lead_in = self.lead_in;
        let body = PieceBody {
            mass: self.rest,
            rotation: self.rotation,
            translation_m: self.translation_m,
            linear_m_s: Vector::from_array(lead_in.velocity_m_s) - self.gravity * (0.5 * self.dt),
            angular_rad_s: Vector::from_array(lead_in.angular_velocity_rad_s),
            shape: self.shape.shared_shape(),
            dust: false,
        };
        RigidWorld::new(&self.settings, self.floor_m, &self.spheres, &[body])
    }

    /// Writes lead-in frame `frame`: the body at `time_s` in pose (r, t).
    fn write_frame(&self, frame: u32, time_s: f64, (r, t): (Rotation, Vector)) -> Result<(), StageFileError> {
        let particles = &self.particles;
        FragmentFrame {
            meta: FragmentMeta { frame, step: 0, time_s, smoothed: false, inputs: Some(self.inputs) },
            fragment_of: vec![0; particles.len()],
            rotation: vec![[r.x as f32, r.y as f32, r.z as f32, r.w as f32]],
            translation_m: vec![t.to_array()],
            elements: vec![particles.len() as u32],
            mass_kg: vec![self.rest.mass_kg],
            element_affine: None,
        }
        .write(&self.layout.lead_in_fragments(frame))
    }

    /// Steps `world` until the body comes within the handoff gap, calling `visit` before each
    /// step (and at the last state): the steps taken and the clearance then. Refuses a flight
    /// that touches nothing within the limit.
    fn fly(
        &self,
        world: &mut RigidWorld,
        visit: &mut dyn FnMut(u64, &RigidWorld) -> Result<(), RigidError>,
    ) -> Result<(u64, f64), RigidError> {
        let mut steps = 0u64;
        let mut clearance = world.clearance_m(0);
        while clearance > self.gap_m {
            visit(steps, world)?;
            if steps == self.limit {
                return Err(RigidError::Input(format!(
                    "{}: lead_in.max_duration_s = {}: the body touches nothing in that time ({:.3} m away at the end)",
                    self.config.path.display(),
                    self.lead_in.max_duration_s,
                    clearance
                )));
            }
            world.advance(self.dt, self.dt);
            steps += 1;
            clearance = world.clearance_m(0);
        }
        Ok((steps, clearance))
    }

    /// The flight without a timeline: a frame every `steps_per_frame` steps. The frames written,
    /// the steps taken and the clearance at the handoff.
    fn fly_at_real_speed(
        &self,
        world: &mut RigidWorld,
        progress: &dyn Progress,
    ) -> Result<(u32, u64, f64), RigidError> {
        let (dt, steps_per_frame, limit) = (self.dt, self.steps_per_frame, self.limit);
        let mut frames = 0;
        progress.start("lead-in", limit);
        let (steps, clearance) = self.fly(world, &mut |steps, world| {
            if steps.is_multiple_of(steps_per_frame) {
                frames += 1;
                self.write_frame(frames, steps as f64 * dt, world.poses()[0])?;
                progress.advance(steps_per_frame.min(limit));
                let clearance = world.clearance_m(0);
                progress.message(&format!("frame {frames}, {:.1} mm from the first contact", clearance * 1e3));
            }
            Ok(())
        })?;
        Ok((frames, steps, clearance))
    }

    /// The flight on `timeline`: finds the impact, lays the timeline on it, then flies again
    /// writing its frames before the impact. The frames written, the steps taken and the
    /// clearance at the handoff.
    fn fly_on_timeline(
        &self,
        world: &mut RigidWorld,
        timeline: &TimelineConfig,
        progress: &dyn Progress,
    ) -> Result<(u32, u64, f64), RigidError> {
        let dt = self.dt;
        let mut frames = 0;
        progress.start("lead-in", 2 * self.limit);
        let (impact_steps, _) = self.fly(&mut self.new_world(), &mut |_, _| Ok(()))?;
        progress.advance(impact_steps);
        let timeline = Timeline::new(timeline, impact_steps as f64 * dt);
        // a timeline that ends before the impact is refused before any frame is written
        timeline
            .reaches_impact()
            .map_err(|message| RigidError::Input(format!("{}: {message}", self.config.path.display())))?;
        let before_impact = timeline.impact_frame() - 1;
        let (steps, clearance) = self.fly(world, &mut |steps, world| {
            let next_step_s = (steps + 1) as f64 * dt;
            while frames < before_impact && timeline.time_s(frames + 1) < next_step_s {
                frames += 1;
                let time_s = timeline.time_s(frames);
                let pose = pose_after(world, self.gravity, dt, self.rest.centre_m, time_s - steps as f64 * dt);
                self.write_frame(frames, time_s, pose)?;
                progress.message(&format!("frame {frames} of {before_impact} before the impact"));
            }
            progress.advance(1);
            Ok(())
        })?;
        Ok((frames, steps, clearance))
    }

    /// The handoff after `frames` frames and `steps` steps: the body's motion in `world` then,
    /// its velocity rapier's plus g dt / 2 (see the module doc).
    fn handoff(&self, world: &RigidWorld, frames: u32, steps: u64) -> LeadIn {
        let dt = self.dt;
        let (r, t) = world.poses()[0];
        let (v, w) = world.velocities()[0];
        LeadIn {
            frames,
            handoff_time_s: steps as f64 * dt,
            rotation: [r.x, r.y, r.z, r.w],
            translation_m: t.to_array(),
            centre_m: world.centres()[0].to_array(),
            velocity_m_s: (v + self.gravity * (0.5 * dt)).to_array(),
            angular_velocity_rad_s: w.to_array(),
            steps,
            inputs: self.inputs,
            others: Vec::new(),
            body_of: Vec::new(),
            plastic: None,
        }
    }
}

/// The body's pose `after_s` (under a step) past the world's state: the centre on its exact
/// parabola (rapier's velocity trails by g dt / 2, see the module doc), the rotation turned at
/// the current angular velocity.
fn pose_after(world: &RigidWorld, gravity: Vector, dt: f64, rest_centre: Vector, after_s: f64) -> (Rotation, Vector) {
    let (r, _) = world.poses()[0];
    let (v, w) = world.velocities()[0];
    let velocity = v + gravity * (0.5 * dt);
    let centre = world.centres()[0] + velocity * after_s + gravity * (0.5 * after_s * after_s);
    let rotation = (Rotation::from_scaled_axis(w * after_s) * r).normalize();
    (rotation, centre - rotation * rest_centre)
}

/// The largest step at which the body crosses at most half the handoff gap: from the fastest
/// it can move (its start speed, plus falling to the floor, plus its spin at its size, plus the
/// fastest sphere), and no longer than `max_step_s`.
fn step(
    lead_in: &LeadInConfig,
    config: &PipelineConfig,
    gravity: Vector,
    lowest_m: f64,
    hulls: &[Vec<Vector>],
    centre: Vector,
    gap: f64,
) -> f64 {
    let g = gravity.length();
    let drop = match &config.sim.floor {
        Some(floor) => (lowest_m - floor.height_m).max(0.0),
        None => 0.5 * g * lead_in.max_duration_s.powi(2),
    };
    let radius = hulls.iter().flatten().map(|p| (*p - centre).length()).fold(0.0, f64::max);
    let spin = Vector::from_array(lead_in.angular_velocity_rad_s).length() * radius;
    let spheres =
        kinematic_spheres(config, 0.0).iter().map(|s| Vector::from_array(s.velocity_m_s).length()).fold(0.0, f64::max);
    let fastest = Vector::from_array(lead_in.velocity_m_s).length() + (2.0 * g * drop).sqrt() + spin + spheres;
    if fastest > 0.0 { lead_in.max_step_s.min(0.5 * gap / fastest) } else { lead_in.max_step_s }
}
