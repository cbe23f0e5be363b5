//! `[lead_in]`: the shot starts with the intact body flying as one rigid body (rapier3d) from a
//! start pose and velocity until it comes within `handoff_gap_m` of its first contact (the
//! floor, a projectile or an indenter); the simulation then starts from there, so no
//! peridynamic step is spent while nothing touches the body.

use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::checker::Checker;

/// `[lead_in]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LeadInConfig {
    /// Where the body starts, relative to the particle file's rest pose, metres.
    pub translate_m: [f64; 3],
    /// Axis of the start rotation about the body's centre of mass.
    pub rotate_axis: [f64; 3],
    /// Angle of the start rotation, degrees.
    pub rotate_deg: f64,
    /// Velocity of the centre of mass at the start, m/s.
    pub velocity_m_s: [f64; 3],
    /// Angular velocity at the start, rad/s.
    pub angular_velocity_rad_s: [f64; 3],
    /// The simulation takes over when the body is this close to its first contact, metres;
    /// default: the horizon delta (every particle's bonds are still at rest there).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub handoff_gap_m: Option<f64>,
    /// The longest rigid time step, seconds.
    pub max_step_s: f64,
    /// The lead-in fails (exit 2) when nothing is touched within this time, seconds.
    pub max_duration_s: f64,
}

impl Default for LeadInConfig {
    fn default() -> Self {
        LeadInConfig {
            translate_m: [0.0; 3],
            rotate_axis: [0.0, 1.0, 0.0],
            rotate_deg: 0.0,
            velocity_m_s: [0.0; 3],
            angular_velocity_rad_s: [0.0; 3],
            handoff_gap_m: None,
            max_step_s: 1e-4,
            max_duration_s: 10.0,
        }
    }
}

impl LeadInConfig {
    pub(super) fn validate(&self, check: &Checker) -> Result<(), ConfigError> {
        check.finite_array("lead_in.translate_m", &self.translate_m)?;
        check.direction("lead_in.rotate_axis", &self.rotate_axis)?;
        check.finite("lead_in.rotate_deg", self.rotate_deg)?;
        check.finite_array("lead_in.velocity_m_s", &self.velocity_m_s)?;
        check.finite_array("lead_in.angular_velocity_rad_s", &self.angular_velocity_rad_s)?;
        if let Some(gap) = self.handoff_gap_m {
            check.positive("lead_in.handoff_gap_m", gap, "metres")?;
        }
        check.positive("lead_in.max_step_s", self.max_step_s, "seconds")?;
        check.that(self.max_step_s <= 0.01, "lead_in.max_step_s", &self.max_step_s.to_string(), || {
            "must be at most 0.01 seconds".into()
        })?;
        check.positive("lead_in.max_duration_s", self.max_duration_s, "seconds")?;
        check.that(self.max_duration_s <= 3600.0, "lead_in.max_duration_s", &self.max_duration_s.to_string(), || {
            "must be at most 3600 seconds".into()
        })
    }
}
