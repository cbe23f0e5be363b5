//! `[rigid]`: the follow-through, in which every fragment becomes a rigid body (rapier3d) once
//! the fracture has quieted, and flies, collides and comes to rest at real speed.

use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::checker::Checker;
use super::secondary_fracture::SecondaryFractureConfig;

/// `[rigid]`. Present, `shatter rigid` hands the fragments over to rigid bodies at the first
/// frame that the handoff rule picks and simulates `follow_through_s` more seconds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RigidConfig {
    /// Physical seconds simulated after the handoff; the shot gains `follow_through_s * fps`
    /// frames at real speed.
    pub follow_through_s: f64,
    /// Handoff rule, part 1: no bond broke in this many frames before the handoff frame.
    pub handoff_quiet_frames: u32,
    /// Handoff rule, part 2: in every fragment of at least two particles, the kinetic energy of
    /// the motion that is not rigid is at most this fraction of the rigid motion's (or below
    /// `handoff_rest_speed_m_s` per unit mass).
    pub handoff_internal_energy_ratio: f64,
    /// A fragment whose internal motion is slower than this (rms, m/s) counts as quiet whatever
    /// its rigid motion (a piece at rest still rings).
    pub handoff_rest_speed_m_s: f64,
    /// Handoff rule, part 3: at the latest this long (simulated time) after the first frame;
    /// the last simulated frame is the handoff in any case.
    pub max_fracture_duration_s: f64,
    /// The longest rigid time step, seconds; each frame takes as many equal steps as it needs.
    pub max_step_s: f64,
    /// Velocity iterations of rapier's solver per step.
    pub solver_iterations: u32,
    /// Coulomb friction coefficient between a piece and the floor.
    pub floor_friction: f64,
    /// Restitution (fraction of the normal speed kept) of a bounce on the floor.
    pub floor_restitution: f64,
    /// Coulomb friction coefficient between two pieces.
    pub piece_friction: f64,
    /// Restitution of a collision between two pieces.
    pub piece_restitution: f64,
    /// A piece is drawn as its convex hull when the hull's volume is at most this factor times
    /// the piece's; otherwise as a compound of the convex hulls of small clusters of its
    /// elements.
    pub hull_volume_factor: f64,
    /// Pieces of at most this many elements are dust: they fall, bounce on the floor and are
    /// pushed by projectiles, but do not collide with other pieces (0: every piece collides).
    /// A broken body's thousands of single elements would otherwise cost most of the contacts.
    pub dust_max_elements: u32,
    /// Two pieces whose masses differ by more than this factor do not collide: the light one
    /// passes through the heavy one, as dust does. Rapier's soft contacts hold a load F on a
    /// piece of mass m at a depth F / (m w^2); at 480 Hz a piece carrying 200 times its mass
    /// sinks 0.2 mm into its load, and a lighter one is swallowed while its contacts jitter and
    /// keep the pile from sleeping.
    pub max_mass_ratio: f64,
    /// A piece whose farthest point stays within `sleep_speed_m_s * sleep_after_s` of where it
    /// was for `sleep_after_s` (slower than this on average, m/s; jitter and rocking in place
    /// do not count) falls asleep, a pile of pieces in contact as a whole. Friction stops a
    /// sliding piece from this speed in milliseconds, so nothing visible is cut short. Once
    /// every piece sleeps the remaining frames repeat the last.
    pub sleep_speed_m_s: f64,
    /// How long a piece stays slow before it sleeps, seconds.
    pub sleep_after_s: f64,
    /// The shot's region as its lowest and highest corner, metres: a piece whose centre of
    /// mass leaves it is retired (held where it is, out of the simulation, at rest; past a
    /// side once it has landed, is farther out than the region is wide, or is dust flying on
    /// away), as a single element flung off at tens of m/s would skid for minutes. Unset: no
    /// region.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bounds_m: Option<[[f64; 3]; 2]>,
    /// Rolling resistance (Bullet's rolling friction, as a rate): the spin of a piece that
    /// touches the floor or another piece decays at this rate, 1/s; a piece in flight spins
    /// freely. A curved shard lying on its back otherwise rocks for seconds.
    pub rolling_damping_per_s: f64,
    /// The constant part of rolling resistance, m/s^2: the spin of a touching piece also
    /// slows by this much speed at its farthest point every second (as Coulomb friction
    /// does, not in proportion to the spin), so rocking and rolling stop in finite time.
    pub rolling_resistance_m_s2: f64,
    /// A checkpoint (the rapier world, for resume) is written every this many frames.
    pub checkpoint_every_frames: u32,
    /// `[rigid.secondary_fracture]`: hard impacts send pieces back to the simulation; absent,
    /// pieces stay whole.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub secondary_fracture: Option<SecondaryFractureConfig>,
}

impl Default for RigidConfig {
    fn default() -> Self {
        RigidConfig {
            follow_through_s: 3.0,
            handoff_quiet_frames: 4,
            handoff_internal_energy_ratio: 0.1,
            handoff_rest_speed_m_s: 0.01,
            max_fracture_duration_s: 0.02,
            max_step_s: 1.0 / 960.0,
            solver_iterations: 4,
            floor_friction: 0.6,
            floor_restitution: 0.2,
            piece_friction: 0.5,
            piece_restitution: 0.1,
            hull_volume_factor: 1.02,
            dust_max_elements: 1,
            max_mass_ratio: 200.0,
            sleep_speed_m_s: 0.02,
            sleep_after_s: 0.2,
            bounds_m: None,
            rolling_damping_per_s: 4.0,
            rolling_resistance_m_s2: 0.2,
            checkpoint_every_frames: 24,
            secondary_fracture: None,
        }
    }
}

impl RigidConfig {
    pub(super) fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        check.positive("rigid.follow_through_s", self.follow_through_s, "seconds")?;
        check.that(
            self.follow_through_s <= 3600.0,
            "rigid.follow_through_s",
            &self.follow_through_s.to_string(),
            || "must be at most 3600 seconds".into(),
        )?;
        check.non_negative("rigid.handoff_internal_energy_ratio", self.handoff_internal_energy_ratio, "a fraction")?;
        check.non_negative("rigid.handoff_rest_speed_m_s", self.handoff_rest_speed_m_s, "m/s")?;
        check.positive("rigid.max_fracture_duration_s", self.max_fracture_duration_s, "seconds")?;
        check.positive("rigid.max_step_s", self.max_step_s, "seconds")?;
        check.that(self.max_step_s <= 0.1, "rigid.max_step_s", &self.max_step_s.to_string(), || {
            "must be at most 0.1 seconds".into()
        })?;
        let iterations = self.solver_iterations;
        check.that((1..=64).contains(&iterations), "rigid.solver_iterations", &iterations.to_string(), || {
            "must be 1 to 64".into()
        })?;
        for (key, value) in
            [("rigid.floor_friction", self.floor_friction), ("rigid.piece_friction", self.piece_friction)]
        {
            check.non_negative(key, value, "a friction coefficient")?;
        }
        for (key, value) in
            [("rigid.floor_restitution", self.floor_restitution), ("rigid.piece_restitution", self.piece_restitution)]
        {
            check.that(value.is_finite() && (0.0..=1.0).contains(&value), key, &value.to_string(), || {
                "must be between 0 and 1".into()
            })?;
        }
        let factor = self.hull_volume_factor;
        check.that(factor.is_finite() && factor >= 1.0, "rigid.hull_volume_factor", &factor.to_string(), || {
            "must be a finite number of at least 1 (1: only exactly convex pieces are drawn as hulls)".into()
        })?;
        let ratio = self.max_mass_ratio;
        check.that(ratio.is_finite() && ratio >= 1.0, "rigid.max_mass_ratio", &ratio.to_string(), || {
            "must be a finite number of at least 1".into()
        })?;
        check.non_negative("rigid.sleep_speed_m_s", self.sleep_speed_m_s, "m/s")?;
        check.non_negative("rigid.sleep_after_s", self.sleep_after_s, "seconds")?;
        check.non_negative("rigid.rolling_damping_per_s", self.rolling_damping_per_s, "a rate, 1/s")?;
        check.non_negative("rigid.rolling_resistance_m_s2", self.rolling_resistance_m_s2, "m/s^2")?;
        if let Some([low, high]) = self.bounds_m {
            let shown = format!("{:?}", [low, high]);
            check.that(
                (0..3).all(|axis| low[axis].is_finite() && high[axis].is_finite() && low[axis] < high[axis]),
                "rigid.bounds_m",
                &shown,
                || "must be [[x, y, z], [x, y, z]]: the lowest corner, then the highest, finite and apart on every axis".into(),
            )?;
        }
        if let Some(secondary) = &self.secondary_fracture {
            secondary.validate(check)?;
        }
        let every = self.checkpoint_every_frames;
        check.that(every >= 1, "rigid.checkpoint_every_frames", &every.to_string(), || "must be at least 1".into())
    }

    /// Frames the follow-through adds at `frames_per_second`.
    pub fn follow_through_frames(&self, frames_per_second: f64) -> u32 {
        (self.follow_through_s * frames_per_second).round().max(1.0) as u32
    }
}
