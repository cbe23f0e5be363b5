//! What rapier's solver sees of each contact (a physics hook): the floor's and the pieces'
//! friction and restitution exactly as configured (not rapier's average of the two colliders'),
//! and no push from overlaps the handoff itself made.
//!
//! At the handoff, neighbouring pieces were one body a moment ago: their collision shapes
//! (hulls, a little larger than the pieces where the pieces are not quite convex) may overlap.
//! Resolving that overlap would blow the pieces apart with energy no crack gave them. Each pair
//! that overlaps at the handoff keeps its overlap depth as an allowance: the solver treats
//! contacts up to that depth as touching, so the pair may not sink deeper but is not pushed
//! out. The allowance shrinks to the pair's current depth after every step and ends when the
//! pair separates.
//!
//! Pieces whose masses differ by more than `max_mass_ratio` do not collide at all (the light
//! one passes through): rapier's soft contacts cannot hold the heavy one up on the light one.

use std::collections::BTreeMap;
use std::sync::Mutex;

use rapier3d_f64::dynamics::RigidBodyHandle;
use rapier3d_f64::geometry::{ColliderHandle, ContactPair, NarrowPhase, SolverFlags};
use rapier3d_f64::pipeline::{ContactModificationContext, PairFilterContext, PhysicsHooks};
use serde::{Deserialize, Serialize};

/// A collider pair, in order of the handles' raw parts.
pub type PairKey = ((u32, u32), (u32, u32));

/// The key of the pair `a`, `b` (either order).
pub fn pair_key(a: ColliderHandle, b: ColliderHandle) -> PairKey {
    let (a, b) = (a.into_raw_parts(), b.into_raw_parts());
    if a <= b { (a, b) } else { (b, a) }
}

/// Friction, restitution and overlap allowances of a rigid world.
#[derive(Debug, Serialize, Deserialize)]
pub struct ContactRules {
    /// The floor's collider, if there is a floor.
    pub floor: Option<ColliderHandle>,
    /// The floor's plane that dust rests on, if there is a floor and dust.
    #[serde(default)]
    pub dust_floor: Option<ColliderHandle>,
    /// Friction coefficient between a piece and the floor.
    pub floor_friction: f64,
    /// Restitution of a bounce on the floor.
    pub floor_restitution: f64,
    /// Friction coefficient between pieces (and a piece and a projectile).
    pub piece_friction: f64,
    /// Restitution between pieces.
    pub piece_restitution: f64,
    /// Pieces whose masses differ by more than this factor do not collide.
    pub max_mass_ratio: f64,
    /// Overlap allowance of each pair that overlapped at the handoff, metres.
    pub allowance_m: BTreeMap<PairKey, f64>,
    /// True until the first step: the overlaps it finds become allowances.
    pub at_handoff: bool,
    /// The overlaps found during the first step.
    #[serde(skip)]
    found: Mutex<BTreeMap<PairKey, f64>>,
}

impl Clone for ContactRules {
    fn clone(&self) -> Self {
        let found = self.found.lock().map(|found| found.clone()).unwrap_or_default();
        ContactRules { found: Mutex::new(found), allowance_m: self.allowance_m.clone(), ..*self }
    }
}

impl PartialEq for ContactRules {
    fn eq(&self, other: &Self) -> bool {
        self.floor == other.floor
            && self.dust_floor == other.dust_floor
            && self.allowance_m == other.allowance_m
            && self.at_handoff == other.at_handoff
            && [self.floor_friction, self.floor_restitution, self.piece_friction, self.piece_restitution]
                == [other.floor_friction, other.floor_restitution, other.piece_friction, other.piece_restitution]
            && self.max_mass_ratio == other.max_mass_ratio
    }
}

impl ContactRules {
    /// Rules with these coefficients and no allowances yet (the first step finds them), for
    /// the floor's collider and its plane for dust.
    pub fn new(
        [floor, dust_floor]: [Option<ColliderHandle>; 2],
        [floor_friction, floor_restitution, piece_friction, piece_restitution]: [f64; 4],
        max_mass_ratio: f64,
    ) -> ContactRules {
        ContactRules {
            floor,
            dust_floor,
            floor_friction,
            floor_restitution,
            piece_friction,
            piece_restitution,
            max_mass_ratio,
            allowance_m: BTreeMap::new(),
            at_handoff: true,
            found: Mutex::new(BTreeMap::new()),
        }
    }

    /// After a step: each allowance shrinks to its pair's current overlap; a pair that no
    /// longer overlaps loses it.
    pub fn shrink_allowances(&mut self, narrow_phase: &NarrowPhase) {
        if self.at_handoff {
            self.at_handoff = false;
            if let Ok(found) = self.found.get_mut() {
                self.allowance_m = std::mem::take(found);
            }
        }
        // only the pairs that hold an allowance are looked up: with tens of thousands of dust
        // grains on the floor, a map of every pair's overlap cost a sixteenth of each step
        self.allowance_m.retain(|&(a, b), allowance| {
            let [a, b] = [a, b].map(|(index, generation)| ColliderHandle::from_raw_parts(index, generation));
            // rapier finds a pair by walking its first collider's list of pairs: never the
            // floor's, which holds every grain lying on it
            let (a, b) = if Some(a) == self.floor { (b, a) } else { (a, b) };
            let depth = narrow_phase.contact_pair(a, b).map_or(0.0, pair_depth);
            *allowance = allowance.min(depth);
            depth > 0.0
        });
    }
}

/// The deepest overlap of a pair's contact points now, metres; 0 if none.
pub fn pair_depth(pair: &ContactPair) -> f64 {
    deepest(pair.manifolds().iter().flat_map(|m| m.points.iter().map(|p| p.dist)))
}

/// The deepest penetration among contact distances (negative: overlapping), metres; 0 if none.
fn deepest(distances: impl Iterator<Item = f64>) -> f64 {
    distances.fold(0.0, |deepest: f64, dist| deepest.max(-dist))
}

impl PhysicsHooks for ContactRules {
    /// Two pieces whose masses differ by more than `max_mass_ratio` pass through each other:
    /// the light one could not hold the heavy one up (see `rigid.max_mass_ratio`).
    fn filter_contact_pair(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        let dynamic_mass = |body: Option<RigidBodyHandle>| {
            body.map(|b| &context.bodies[b]).filter(|b| b.is_dynamic()).map(|b| b.mass())
        };
        match (dynamic_mass(context.rigid_body1), dynamic_mass(context.rigid_body2)) {
            (Some(a), Some(b)) if a.max(b) > self.max_mass_ratio * a.min(b) => None,
            _ => Some(SolverFlags::COMPUTE_RIGID_IMPULSES),
        }
    }

    fn modify_solver_contacts(&self, context: &mut ContactModificationContext) {
        let is_floor = |collider| Some(collider) == self.floor || Some(collider) == self.dust_floor;
        let on_floor = is_floor(context.collider1) || is_floor(context.collider2);
        let key = pair_key(context.collider1, context.collider2);
        let Some(manifold) = context.rigid_mut() else { return };
        let allowance = if self.at_handoff {
            let depth = deepest(manifold.solver_contacts.iter().map(|c| c.dist));
            if depth > 0.0
                && let Ok(mut found) = self.found.lock()
            {
                let entry = found.entry(key).or_insert(0.0);
                *entry = entry.max(depth);
            }
            (depth > 0.0).then_some(depth)
        } else {
            self.allowance_m.get(&key).copied()
        };
        if on_floor {
            *manifold.friction = self.floor_friction;
            *manifold.restitution = self.floor_restitution;
        } else {
            *manifold.friction = self.piece_friction;
            *manifold.restitution = self.piece_restitution;
        }
        if let Some(allowance) = allowance {
            for contact in manifold.solver_contacts.iter_mut() {
                contact.dist = (contact.dist + allowance).min(contact.dist.max(0.0));
            }
        }
    }
}
