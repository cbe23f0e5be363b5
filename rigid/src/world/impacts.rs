//! Hard contacts: a piece that hits the floor, a projectile or an indenter faster than its bonds
//! can take goes back to the simulation (`[rigid.secondary_fracture]`).
//!
//! The rule (docs/DECISIONS.md#secondary-fracture): a body that meets a rigid wall at normal
//! speed v starts a longitudinal wave whose strain is v / c_p, c_p = sqrt(M / rho) with M the
//! P-wave modulus, K + 4 G / 3 (1.8 K for the bond-based model's Poisson ratio of 1/4). The
//! bonds at the contact reach their critical stretch s0 when v / c_p = s0: the critical
//! approach speed is s0 c_p. Two pieces of one material meeting share the velocity jump
//! equally, so between pieces it is twice that, in relative speed. A contact between two pieces
//! is watched when both are: a piece too small to be watched is too small to load the other's
//! bonds as a half-space of its own material would.

use std::collections::BTreeMap;

use rapier3d_f64::prelude::*;

use super::RigidWorld;

/// The approach speed at which a contact with something rigid brings the bonds at the contact
/// to `critical_stretch`, m/s: s0 sqrt(M / rho), M the P-wave modulus
/// ([`shatter_core::config::MaterialConfig::p_wave_modulus_pa`]).
pub fn critical_speed_m_s(p_wave_modulus_pa: f64, density_kg_m3: f64, critical_stretch: f64) -> f64 {
    critical_stretch * (p_wave_modulus_pa / density_kg_m3).sqrt()
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
    /// Another watched piece (its index).
    Piece(usize),
}

impl Struck {
    /// As the re-entry file names it.
    pub fn name(self) -> String {
        match self {
            Struck::Floor => "floor".into(),
            Struck::Sphere => "projectile or indenter".into(),
            Struck::Piece(other) => format!("piece {other}"),
        }
    }
}

/// A hard contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// The piece (the lower index of two pieces that met).
    pub piece: usize,
    /// What it hit.
    pub struck: Struck,
    /// The approach speed at the contact before the step, m/s (between two pieces, their
    /// relative speed).
    pub speed_m_s: f64,
}

impl Impact {
    /// The pieces in the contact, ascending.
    pub fn pieces(&self) -> Vec<usize> {
        match self.struck {
            Struck::Piece(other) => vec![self.piece, other],
            Struck::Floor | Struck::Sphere => vec![self.piece],
        }
    }

    /// The approach speed that is hard for this contact, m/s, given the one against something
    /// rigid: that against the floor or a sphere, twice it between two pieces.
    pub fn threshold_m_s(&self, rigid_threshold_m_s: f64) -> f64 {
        let factor = if matches!(self.struck, Struck::Piece(_)) { PIECE_THRESHOLD_FACTOR } else { 1.0 };
        factor * rigid_threshold_m_s
    }

    /// How many times its threshold the contact's speed is.
    fn severity(&self, rigid_threshold_m_s: f64) -> f64 {
        self.speed_m_s / self.threshold_m_s(rigid_threshold_m_s)
    }
}

/// Between two pieces of one material the velocity jump is shared equally: hard at twice the
/// approach speed against something rigid.
const PIECE_THRESHOLD_FACTOR: f64 = 2.0;

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

    /// The hardest contact of a watched piece with the floor, a sphere or another watched
    /// piece in the step just taken (the most times its threshold), measured with the pieces'
    /// motions `before` it, when it passes its threshold.
    pub(super) fn hardest_impact(&self, watch: &ImpactWatch, before: &[Option<Motion>]) -> Option<Impact> {
        let index = self.piece_index();
        let mut hardest: Option<Impact> = None;
        for pair in self.world.narrow_phase.contact_pairs().filter(|pair| pair.has_any_active_contact()) {
            let colliders = [pair.collider1, pair.collider2];
            let Some((piece, struck)) = self.contact_kind(&index, colliders, before) else { continue };
            // each side's velocity at a point, as it moved before the step: a watched piece's
            // motion then, a sphere's velocity, the floor's none
            let side = colliders.map(|collider| {
                let body = self.world.colliders.get(collider).and_then(|c| c.parent());
                let motion = self.piece_of(&index, collider).and_then(|piece| before[piece]);
                let centre = body.map_or(Vector::ZERO, |b| self.world.bodies[b].center_of_mass());
                let linear = body.map_or(Vector::ZERO, |b| self.world.bodies[b].linvel());
                move |point: Vector| match motion {
                    Some((v, w)) => v + w.cross(point - centre),
                    None => linear,
                }
            });
            for manifold in pair.manifolds() {
                for contact in &manifold.data.solver_contacts {
                    let (a, b) = manifold.data.solver_contact_world_points(contact, &self.world.bodies);
                    let point = (a + b) * 0.5;
                    // the normal points from the pair's first collider to its second
                    let speed_m_s = (side[0](point) - side[1](point)).dot(manifold.data.normal);
                    let impact = Impact { piece, struck, speed_m_s };
                    let severity = impact.severity(watch.threshold_m_s);
                    if severity > 1.0 && hardest.is_none_or(|h| severity > h.severity(watch.threshold_m_s)) {
                        hardest = Some(impact);
                    }
                }
            }
        }
        hardest
    }

    /// The watched piece of a contact between `colliders` and what it hit (for two watched
    /// pieces, the lower index and the other), or None when it is not watched.
    fn contact_kind(
        &self,
        index: &BTreeMap<(u32, u32), usize>,
        colliders: [ColliderHandle; 2],
        before: &[Option<Motion>],
    ) -> Option<(usize, Struck)> {
        let pieces = colliders.map(|collider| self.piece_of(index, collider));
        let watched = |piece: usize| before[piece].is_some();
        match pieces {
            [Some(a), Some(b)] if watched(a) && watched(b) => Some((a.min(b), Struck::Piece(a.max(b)))),
            [Some(piece), None] | [None, Some(piece)] if watched(piece) => {
                let other = if pieces[0].is_some() { colliders[1] } else { colliders[0] };
                Some((piece, if self.is_floor(other) { Struck::Floor } else { Struck::Sphere }))
            }
            _ => None,
        }
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
        // glass: K = 14.9 GPa, so M = 1.8 K, rho = 2200 kg/m^3, s0 = 3.2e-4: c_p = 3,491 m/s,
        // v = 1.12 m/s
        let speed = critical_speed_m_s(1.8 * 14.9e9, 2200.0, 3.2e-4);
        assert!((speed - 1.1172).abs() < 1e-3, "{speed}");
        assert!(critical_speed_m_s(1.8 * 14.9e9, 2200.0, 6.4e-4) > speed);
        assert!(critical_speed_m_s(4.0 * 1.8 * 14.9e9, 2200.0, 3.2e-4) > speed);
        assert!(critical_speed_m_s(1.8 * 14.9e9, 4400.0, 3.2e-4) < speed);
    }
}
