//! A simulation that starts from the lead-in's handoff (`[lead_in]`): the handoff read and
//! checked to belong to this run, the projectiles' and indenters' paths moved to its time, and the
//! body's rigid motion there (each body's, for a re-entry of pieces that met), which sets the
//! particles' first displacements and velocities; for a re-entry of elastoplastic pieces, from
//! their permanent shape, with their bonds' plastic extensions.

use shatter_core::layout::missing_input;
use shatter_core::lead_in::{BodyMotion, LeadIn};
use shatter_core::{OutputLayout, ParticleSet, PipelineConfig};

use crate::sim_driver::RunError;

/// The lead-in's handoff, when the scene has `[lead_in]`: checked to belong to this particle
/// file and these settings.
pub(crate) fn read_lead_in(
    config: &PipelineConfig,
    layout: &OutputLayout,
    inputs: u32,
    particles: &ParticleSet,
) -> Result<Option<LeadIn>, RunError> {
    if config.lead_in.is_none() {
        return Ok(None);
    }
    let path = layout.lead_in();
    if let Some(message) = missing_input(&path, "lead-in") {
        return Err(RunError::MissingInput(message));
    }
    let lead_in = LeadIn::read(&path)?;
    if lead_in.inputs != inputs {
        return Err(RunError::MissingInput(format!(
            "{}: made from another particle file or other [lead_in], [sim] or [material] settings; run `shatter \
             lead-in` again",
            path.display()
        )));
    }
    let stale = |what: String| RunError::MissingInput(format!("{}: {what}; run `shatter rigid` again", path.display()));
    let count = particles.len();
    if !lead_in.others.is_empty() && lead_in.body_of.len() != count {
        return Err(stale(format!(
            "names the bodies of {} particles, not of the particle file's {count}",
            lead_in.body_of.len()
        )));
    }
    if let Some(plastic) = &lead_in.plastic {
        let entries = particles.bonds.neighbor.len();
        if plastic.shape_m.len() != count || plastic.extension_m.len() != entries {
            return Err(stale(format!(
                "gives the shape of {} particles and the plastic extensions of {} bond entries, not the particle \
                 file's {count} and {entries}",
                plastic.shape_m.len(),
                plastic.extension_m.len()
            )));
        }
    }
    Ok(Some(lead_in))
}

/// The config the simulation runs with after a lead-in: projectiles and indenters, whose paths
/// are given in the shot's time, where they are at the handoff (the simulation's time 0).
pub(crate) fn paths_from_handoff(config: &PipelineConfig, handoff_time_s: f64) -> PipelineConfig {
    let mut physics = config.clone();
    for p in &mut physics.sim.projectile {
        p.center_m = [0, 1, 2].map(|a| p.center_m[a] + p.velocity_m_s[a] * handoff_time_s);
    }
    for i in &mut physics.sim.indenter {
        i.center_m = [0, 1, 2].map(|a| i.center_m[a] + i.velocity_m_s[a] * handoff_time_s);
    }
    physics
}

/// The bodies' rigid motions at the lead-in's handoff, applied to particles by index and rest
/// position.
pub(crate) struct HandoffMotion<'a> {
    bodies: Vec<RigidMotion>,
    /// Each particle's body; empty for one body.
    body_of: &'a [u32],
    /// Each particle's place in its body's rest frame; empty where it is its rest position.
    shape_m: &'a [[f32; 3]],
}

impl HandoffMotion<'_> {
    /// The motions `lead_in` hands off.
    pub(crate) fn of(lead_in: &LeadIn) -> HandoffMotion<'_> {
        let bodies = std::iter::once(lead_in.motion()).chain(lead_in.others.iter().copied());
        HandoffMotion {
            bodies: bodies.map(|body| RigidMotion::of(&body)).collect(),
            body_of: &lead_in.body_of,
            shape_m: lead_in.plastic.as_ref().map_or(&[], |plastic| &plastic.shape_m),
        }
    }

    /// The motion of particle `i`, and where it sits in its body's rest frame.
    fn body(&self, i: usize, rest: [f32; 3]) -> (&RigidMotion, [f32; 3]) {
        let body = &self.bodies[self.body_of.get(i).map_or(0, |&body| body as usize)];
        (body, self.shape_m.get(i).copied().unwrap_or(rest))
    }

    /// The displacement that moves particle `i`, at rest position `rest`, to where it is.
    pub(crate) fn displacement(&self, i: usize, rest: [f32; 3]) -> [f32; 3] {
        let (body, at) = self.body(i, rest);
        let x = body.position(at);
        [0, 1, 2].map(|a| (x[a] - f64::from(rest[a])) as f32)
    }

    /// Particle `i`'s velocity: its body's v + w x (x - c), plus `extra`.
    pub(crate) fn velocity(&self, i: usize, rest: [f32; 3], extra: [f32; 3]) -> [f32; 3] {
        let (body, at) = self.body(i, rest);
        body.velocity(at, extra)
    }
}

/// A body's rigid motion at the lead-in's handoff, applied to particles by rest position.
struct RigidMotion {
    rotation: [[f64; 3]; 3],
    translation: [f64; 3],
    centre: [f64; 3],
    velocity: [f64; 3],
    angular: [f64; 3],
}

impl RigidMotion {
    /// The motion `body` gives.
    fn of(body: &BodyMotion) -> RigidMotion {
        let [x, y, z, w] = body.rotation;
        let rotation = [
            [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
            [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
            [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
        ];
        RigidMotion {
            rotation,
            translation: body.translation_m,
            centre: body.centre_m,
            velocity: body.velocity_m_s,
            angular: body.angular_velocity_rad_s,
        }
    }

    /// Where a particle at `at` in the body's rest frame is: R X + t.
    fn position(&self, at: [f32; 3]) -> [f64; 3] {
        let x = at.map(f64::from);
        [0, 1, 2].map(|a| (0..3).map(|b| self.rotation[a][b] * x[b]).sum::<f64>() + self.translation[a])
    }

    /// v + w x (x - c) of a particle at `at` in the body's rest frame, plus
    /// `sim.initial_velocity_m_s` as without a lead-in.
    fn velocity(&self, at: [f32; 3], extra: [f32; 3]) -> [f32; 3] {
        let x = self.position(at);
        let r = [0, 1, 2].map(|a| x[a] - self.centre[a]);
        let w = self.angular;
        let spin = [w[1] * r[2] - w[2] * r[1], w[2] * r[0] - w[0] * r[2], w[0] * r[1] - w[1] * r[0]];
        [0, 1, 2].map(|a| (self.velocity[a] + spin[a]) as f32 + extra[a])
    }
}

#[cfg(test)]
mod tests {
    use shatter_core::lead_in::PlasticStart;

    use super::*;

    fn lead_in(plastic: Option<PlasticStart>) -> LeadIn {
        LeadIn {
            frames: 0,
            handoff_time_s: 0.0,
            // a quarter turn about z, then 1 m up
            rotation: [0.0, 0.0, std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2],
            translation_m: [0.0, 1.0, 0.0],
            centre_m: [0.0, 1.0, 0.0],
            velocity_m_s: [0.0, -2.0, 0.0],
            angular_velocity_rad_s: [0.0, 0.0, 3.0],
            steps: 0,
            inputs: 0,
            others: Vec::new(),
            body_of: Vec::new(),
            plastic,
        }
    }

    #[test]
    fn a_particle_starts_where_its_body_puts_its_shape_and_moves_with_it() {
        let rest = [0.1f32, 0.0, 0.0];
        // its rest position: R X + t = (0, 1.1, 0), moving at v + w x (x - c) = (-0.3, -2, 0)
        let rigid = lead_in(None);
        let motion = HandoffMotion::of(&rigid);
        let close = |a: [f32; 3], b: [f32; 3]| (0..3).all(|k| (a[k] - b[k]).abs() < 1e-6);
        assert!(close(motion.displacement(0, rest), [-0.1, 1.1, 0.0]), "{:?}", motion.displacement(0, rest));
        assert!(close(motion.velocity(0, rest, [0.0; 3]), [-0.3, -2.0, 0.0]));
        // dented: its shape 2 cm further out along x, so 2 cm higher, and faster about the centre
        let plastic = PlasticStart { shape_m: vec![[0.12, 0.0, 0.0]], extension_m: Vec::new() };
        let dented = lead_in(Some(plastic));
        let motion = HandoffMotion::of(&dented);
        assert!(close(motion.displacement(0, rest), [-0.1, 1.12, 0.0]), "{:?}", motion.displacement(0, rest));
        assert!(close(motion.velocity(0, rest, [0.0; 3]), [-0.36, -2.0, 0.0]));
    }
}
