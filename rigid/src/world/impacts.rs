//! Hard contacts: a piece that hits the floor, a projectile or an indenter faster than its bonds
//! can take goes back to the simulation (`[rigid.secondary_fracture]`).
//!
//! The rule (docs/DECISIONS.md#secondary-fracture): a body that meets a rigid wall at normal
//! speed v starts a longitudinal wave whose strain is v / c_p, c_p = sqrt(M / rho) with M the
//! P-wave modulus, K + 4 G / 3 = 1.8 K for the bond-based model's Poisson ratio of 1/4. The
//! bonds at the contact reach their critical stretch s0 when v / c_p = s0: the critical
//! approach speed is s0 c_p. Two pieces of one material meeting share the velocity jump
//! equally, so between pieces it is twice that, in relative speed.

use rapier3d_f64::prelude::*;

use super::RigidWorld;

/// M / K for Poisson's ratio 1/4: 1 + (4/3) (3 (1 - 2 nu) / (2 (1 + nu))).
const P_WAVE_MODULUS_PER_BULK: f64 = 1.8;

/// The approach speed at which a contact with something rigid brings the bonds at the contact
/// to `critical_stretch`, m/s: s0 sqrt(1.8 K / rho).
pub fn critical_speed_m_s(bulk_modulus_pa: f64, density_kg_m3: f64, critical_stretch: f64) -> f64 {
    critical_stretch * (P_WAVE_MODULUS_PER_BULK * bulk_modulus_pa / density_kg_m3).sqrt()
}

/// Which pieces may break again, and how hard a contact must be.
#[derive(Debug, Clone, PartialEq)]
pub struct ImpactWatch {
    /// The approach speed against the floor, a projectile or an indenter that is hard, m/s.
    pub threshold_m_s: f64,
    /// Each piece: whether its contacts are watched (big enough, and in the world).
    pub watched: Vec<bool>,
}

/// What a watched piece hit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Struck {
    /// The floor.
    Floor,
    /// A projectile or an indenter.
    Sphere,
}

impl Struck {
    /// As the re-entry file names it.
    pub fn name(self) -> &'static str {
        match self {
            Struck::Floor => "floor",
            Struck::Sphere => "projectile or indenter",
        }
    }
}

/// A hard contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// The piece.
    pub piece: usize,
    /// What it hit.
    pub struck: Struck,
    /// The approach speed at the contact before the step, m/s.
    pub speed_m_s: f64,
}

/// What [`RigidWorld::step_for`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stepped {
    /// Steps taken (the impact's step last, when there is one).
    pub steps: u64,
    /// Their length, seconds.
    pub dt_s: f64,
    /// The first hard contact, which ended the stepping.
    pub impact: Option<Impact>,
}

/// A watched piece's motion before a step: velocity, angular velocity.
pub(super) type Motion = (Vector, Vector);

impl RigidWorld {
    /// The watched pieces' motions now (None for the others).
    pub(super) fn motions_of(&self, watch: &ImpactWatch) -> Vec<Option<Motion>> {
        self.pieces
            .iter()
            .zip(&watch.watched)
            .map(|(&handle, &watched)| {
                let body = &self.world.bodies[handle];
                watched.then(|| (body.linvel(), body.angvel()))
            })
            .collect()
    }

    /// The fastest approach of a watched piece to the floor or a sphere in the step just
    /// taken, measured with the pieces' motions `before` it, when it passes the threshold.
    pub(super) fn hardest_impact(&self, watch: &ImpactWatch, before: &[Option<Motion>]) -> Option<Impact> {
        let index = self.piece_index();
        let mut hardest: Option<Impact> = None;
        for pair in self.world.narrow_phase.contact_pairs().filter(|pair| pair.has_any_active_contact()) {
            let pieces = [pair.collider1, pair.collider2].map(|collider| self.piece_of(&index, collider));
            let (piece, other, sign) = match pieces {
                [Some(piece), None] => (piece, pair.collider2, 1.0),
                [None, Some(piece)] => (piece, pair.collider1, -1.0),
                _ => continue,
            };
            let Some((linear, angular)) = before[piece] else { continue };
            let struck = if self.is_floor(other) { Struck::Floor } else { Struck::Sphere };
            let other_velocity = self
                .world
                .colliders
                .get(other)
                .and_then(|c| c.parent())
                .map_or(Vector::ZERO, |b| self.world.bodies[b].linvel());
            let body = &self.world.bodies[self.pieces[piece]];
            for manifold in pair.manifolds() {
                for contact in &manifold.data.solver_contacts {
                    let (a, b) = manifold.data.solver_contact_world_points(contact, &self.world.bodies);
                    let point = (a + b) * 0.5;
                    let velocity = linear + angular.cross(point - body.center_of_mass());
                    // the normal points from the pair's first collider to its second
                    let speed_m_s = sign * (velocity - other_velocity).dot(manifold.data.normal);
                    if speed_m_s > watch.threshold_m_s && hardest.is_none_or(|h| speed_m_s > h.speed_m_s) {
                        hardest = Some(Impact { piece, struck, speed_m_s });
                    }
                }
            }
        }
        hardest
    }

    /// Whether `collider` is the floor (its slab or the plane dust rests on).
    fn is_floor(&self, collider: ColliderHandle) -> bool {
        Some(collider) == self.rules.floor || Some(collider) == self.rules.dust_floor
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_critical_speed_is_the_critical_stretch_times_the_p_wave_speed() {
        // glass: K = 14.9 GPa, rho = 2200 kg/m^3, s0 = 3.2e-4: c_p = 3,491 m/s, v = 1.12 m/s
        let speed = critical_speed_m_s(14.9e9, 2200.0, 3.2e-4);
        assert!((speed - 1.1172).abs() < 1e-3, "{speed}");
        // P-wave modulus of Poisson's ratio 1/4: K + 4 G / 3 with G = 3 K (1 - 2 nu) / (2 (1 + nu))
        let nu: f64 = 0.25;
        assert!(
            (1.0 + 4.0 / 3.0 * (3.0 * (1.0 - 2.0 * nu) / (2.0 * (1.0 + nu))) - P_WAVE_MODULUS_PER_BULK).abs() < 1e-12
        );
        // it grows with the strength and the stiffness, and falls with the density
        assert!(critical_speed_m_s(14.9e9, 2200.0, 6.4e-4) > speed);
        assert!(critical_speed_m_s(4.0 * 14.9e9, 2200.0, 3.2e-4) > speed);
        assert!(critical_speed_m_s(14.9e9, 4400.0, 3.2e-4) < speed);
    }
}
