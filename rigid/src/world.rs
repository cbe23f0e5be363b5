//! The rigid world of a follow-through: one dynamic body per piece, a fixed floor, projectiles
//! and indenters as kinematic spheres, stepped by rapier with the [`ContactRules`] hook. The
//! whole world serialises, so a resumed run continues bit for bit.

use rapier3d_f64::prelude::*;
use serde::{Deserialize, Serialize};

use crate::contact_rules::{ContactRules, deepest, pair_key};
use crate::mass::MassProps;

/// Half the floor slab's width, metres: far beyond any shot.
const FLOOR_HALF_WIDTH_M: f64 = 1.0e3;
/// Half the floor slab's thickness, metres: nothing falls through a metre of floor.
const FLOOR_HALF_THICKNESS_M: f64 = 0.5;

/// The natural frequency of rapier's soft contact constraints between pieces, Hz (twice this
/// against the floor), when the steps are short enough: at most an eighth of the solver's
/// substep rate (a quarter against the floor), where soft contacts stay stable.
pub const CONTACT_FREQUENCY_HZ: f64 = 480.0;

/// Settings of a rigid world.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldSettings {
    /// Gravity, m/s^2.
    pub gravity_m_s2: [f64; 3],
    /// The length the solver's tolerances scale with (rapier's `length_unit`), metres.
    pub length_unit_m: f64,
    /// Solver velocity iterations per step.
    pub solver_iterations: usize,
    /// Friction coefficient piece-floor.
    pub floor_friction: f64,
    /// Restitution piece-floor.
    pub floor_restitution: f64,
    /// Friction coefficient piece-piece.
    pub piece_friction: f64,
    /// Restitution piece-piece.
    pub piece_restitution: f64,
    /// Pieces whose masses differ by more than this factor pass through each other.
    pub max_mass_ratio: f64,
    /// Speed below which a piece may fall asleep, m/s.
    pub sleep_speed_m_s: f64,
    /// How long it must stay below it, seconds.
    pub sleep_after_s: f64,
}

/// A piece as it enters the rigid world.
#[derive(Debug, Clone)]
pub struct PieceBody {
    /// Rest-frame mass properties.
    pub mass: MassProps,
    /// Rotation from the rest frame.
    pub rotation: Rotation,
    /// Translation: x = R X + t.
    pub translation_m: Vector,
    /// Velocity of the centre of mass, m/s.
    pub linear_m_s: Vector,
    /// Angular velocity, rad/s.
    pub angular_rad_s: Vector,
    /// Collision shape in the rest frame; None for a piece that collides with nothing.
    pub shape: Option<SharedShape>,
    /// Dust collides with the floor, projectiles and indenters only, not with other pieces.
    pub dust: bool,
}

/// Collision groups: pieces collide with pieces and the environment; dust with the environment
/// only; the environment (floor, spheres) with everything.
const PIECES: Group = Group::GROUP_1;
const DUST: Group = Group::GROUP_2;
const ENVIRONMENT: Group = Group::GROUP_3;

fn groups(memberships: Group, filter: Group) -> InteractionGroups {
    InteractionGroups::new(memberships, filter, InteractionTestMode::And)
}

/// A sphere on a straight path (a projectile or an indenter).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KinematicSphere {
    /// Centre at the handoff, metres.
    pub centre_m: [f64; 3],
    /// Velocity, m/s.
    pub velocity_m_s: [f64; 3],
    /// Radius, metres.
    pub radius_m: f64,
}

/// The rigid world.
#[derive(Serialize, Deserialize)]
pub struct RigidWorld {
    world: PhysicsWorld,
    rules: ContactRules,
    pieces: Vec<RigidBodyHandle>,
    /// Each piece's rest watch (see [`RigidWorld::settle`]).
    watch: Vec<RestWatch>,
    sleep_speed_m_s: f64,
    sleep_after_s: f64,
}

/// Where a piece was at the end of the last frame, and how long it has moved less than the
/// sleep speed from frame to frame.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct RestWatch {
    centre_m: [f64; 3],
    rotation: [f64; 4],
    /// The distance from its centre of mass to its farthest point, metres.
    reach_m: f64,
    still_s: f64,
}

impl RigidWorld {
    /// A world of `pieces` above a floor at `floor_height_m` (if any), with `spheres`, at the
    /// handoff. Overlaps between shapes at this moment become allowances in the first step
    /// (see [`ContactRules`]).
    pub fn new(
        settings: &WorldSettings,
        floor_height_m: Option<f64>,
        spheres: &[KinematicSphere],
        pieces: &[PieceBody],
    ) -> RigidWorld {
        let mut world = PhysicsWorld::new();
        world.gravity = Vector::from_array(settings.gravity_m_s2);
        world.integration_parameters.length_unit = settings.length_unit_m;
        world.integration_parameters.num_solver_iterations = settings.solver_iterations;
        let hooks = ActiveHooks::MODIFY_SOLVER_CONTACTS;
        let floor = floor_height_m.map(|height| {
            // a slab, not a half-space: on a half-space the plate shot's largest shard (9,330
            // cubes, a compound of hulls) sank 29 mm through the floor and stayed there
            let top = Vector::new(0.0, height - FLOOR_HALF_THICKNESS_M, 0.0);
            let body = world.insert_body(RigidBodyBuilder::fixed().translation(top));
            let slab = SharedShape::cuboid(FLOOR_HALF_WIDTH_M, FLOOR_HALF_THICKNESS_M, FLOOR_HALF_WIDTH_M);
            let collider =
                ColliderBuilder::new(slab).active_hooks(hooks).collision_groups(groups(ENVIRONMENT, Group::ALL));
            world.insert_collider(collider, Some(body))
        });
        for sphere in spheres {
            let body = RigidBodyBuilder::kinematic_velocity_based()
                .translation(Vector::from_array(sphere.centre_m))
                .linvel(Vector::from_array(sphere.velocity_m_s));
            let body = world.insert_body(body);
            let collider = ColliderBuilder::ball(sphere.radius_m)
                .active_hooks(hooks)
                .collision_groups(groups(ENVIRONMENT, Group::ALL));
            world.insert_collider(collider, Some(body));
        }
        let mut handles = Vec::with_capacity(pieces.len());
        for piece in pieces {
            let inertia = piece.mass.inertia();
            let mass = MassProperties::with_inertia_matrix(piece.mass.centre_m, piece.mass.mass_kg, inertia);
            let body = RigidBodyBuilder::dynamic()
                .pose(Pose::from_parts(piece.translation_m, piece.rotation))
                .additional_mass_properties(mass)
                .linvel(piece.linear_m_s)
                .angvel(piece.angular_rad_s)
                .ccd_enabled(true)
                .gyroscopic_forces_enabled(true)
                .build();
            let handle = world.insert_body(body);
            let activation = world.bodies[handle].activation_mut();
            activation.normalized_linear_threshold = settings.sleep_speed_m_s / settings.length_unit_m;
            activation.time_until_sleep = settings.sleep_after_s;
            if let Some(shape) = &piece.shape {
                let group = if piece.dust { groups(DUST, ENVIRONMENT) } else { groups(PIECES, PIECES | ENVIRONMENT) };
                let collider = ColliderBuilder::new(shape.clone())
                    .density(0.0)
                    .active_hooks(hooks | ActiveHooks::FILTER_CONTACT_PAIRS)
                    .collision_groups(group);
                world.insert_collider(collider, Some(handle));
            }
            handles.push(handle);
        }
        let coefficients =
            [settings.floor_friction, settings.floor_restitution, settings.piece_friction, settings.piece_restitution];
        let rules = ContactRules::new(floor, coefficients, settings.max_mass_ratio);
        let watch = handles
            .iter()
            .zip(pieces)
            .map(|(&handle, piece)| {
                let body = &world.bodies[handle];
                let reach_m = piece.shape.as_ref().map_or(0.0, |shape| {
                    let sphere = shape.compute_local_bounding_sphere();
                    (sphere.center() - piece.mass.centre_m).length() + sphere.radius()
                });
                let rotation = *body.rotation();
                RestWatch {
                    centre_m: body.center_of_mass().to_array(),
                    rotation: [rotation.x, rotation.y, rotation.z, rotation.w],
                    reach_m,
                    still_s: 0.0,
                }
            })
            .collect();
        RigidWorld {
            world,
            rules,
            pieces: handles,
            watch,
            sleep_speed_m_s: settings.sleep_speed_m_s,
            sleep_after_s: settings.sleep_after_s,
        }
    }

    /// Advances `duration_s` in equal steps no longer than `max_step_s`; returns the steps taken.
    pub fn advance(&mut self, duration_s: f64, max_step_s: f64) -> u64 {
        let steps = (duration_s / max_step_s).ceil().max(1.0);
        let dt = duration_s / steps;
        self.world.integration_parameters.dt = dt;
        // stiffer contacts than rapier's defaults (30 Hz between bodies, 60 Hz against the
        // floor): a pile of small pieces under gravity sinks into itself by hundredths of a
        // millimetre, not millimetres, and a light piece under a heavy shard is not pressed
        // into the floor; capped where the substeps would make them unstable
        let substep_rate_hz = self.world.integration_parameters.num_solver_iterations as f64 / dt;
        let frequency_hz = CONTACT_FREQUENCY_HZ.min(substep_rate_hz / 8.0);
        self.world.integration_parameters.contact_softness.natural_frequency = frequency_hz;
        self.world.integration_parameters.static_contact_softness.natural_frequency = 2.0 * frequency_hz;
        for _ in 0..steps as u64 {
            self.world.step_with_events(&self.rules, &());
            self.rules.shrink_allowances(&self.world.narrow_phase);
        }
        self.settle(duration_s);
        steps as u64
    }

    /// rapier puts a body to sleep when its velocity stays low, step by step. A small piece
    /// resting on the floor can jitter in place (its contacts switching between faces), with
    /// an angular velocity of several rad/s whose sign flips every step while it turns by a
    /// fraction of a degree: it never sleeps. Here the test is the net motion over each frame:
    /// a piece that touches no other piece and whose farthest point moved slower than the
    /// sleep speed from frame to frame for `sleep_after_s` is put to sleep. Pieces in a pile
    /// are left to rapier, which puts a pile to sleep as a whole: one put to sleep on its own
    /// under others was pushed into by them and blew the pile apart when it woke.
    fn settle(&mut self, frame_s: f64) {
        if self.sleep_speed_m_s < 0.0 || frame_s <= 0.0 {
            return;
        }
        let mut in_piles = std::collections::BTreeSet::new();
        for pair in self.world.narrow_phase.contact_pairs().filter(|pair| pair.has_any_active_contact()) {
            let parents = [pair.collider1, pair.collider2]
                .map(|collider| self.world.colliders.get(collider).and_then(|c| c.parent()));
            if let [Some(a), Some(b)] = parents
                && self.world.bodies[a].is_dynamic()
                && self.world.bodies[b].is_dynamic()
            {
                in_piles.extend([a.into_raw_parts(), b.into_raw_parts()]);
            }
        }
        for (watch, &handle) in self.watch.iter_mut().zip(&self.pieces) {
            // read-only: indexing rapier's set mutably marks a body modified
            let body = &self.world.bodies[handle];
            let centre = body.center_of_mass();
            let rotation = *body.rotation();
            let [x, y, z, w] = watch.rotation;
            let turned = Rotation::from_xyzw(x, y, z, w).angle_between(rotation);
            let moved = (centre - Vector::from_array(watch.centre_m)).length() + turned * watch.reach_m;
            watch.centre_m = centre.to_array();
            watch.rotation = [rotation.x, rotation.y, rotation.z, rotation.w];
            if body.is_sleeping()
                || in_piles.contains(&handle.into_raw_parts())
                || moved > self.sleep_speed_m_s * frame_s
            {
                watch.still_s = 0.0;
                continue;
            }
            watch.still_s += frame_s;
            if watch.still_s >= self.sleep_after_s {
                self.world.bodies[handle].sleep();
            }
        }
    }

    /// Each piece's pose: rotation from the rest frame and translation (x = R X + t).
    pub fn poses(&self) -> Vec<(Rotation, Vector)> {
        self.pieces
            .iter()
            .map(|&handle| {
                let body = &self.world.bodies[handle];
                (*body.rotation(), body.translation())
            })
            .collect()
    }

    /// Each piece's velocity of its centre of mass and angular velocity.
    pub fn velocities(&self) -> Vec<(Vector, Vector)> {
        self.pieces.iter().map(|&h| (self.world.bodies[h].linvel(), self.world.bodies[h].angvel())).collect()
    }

    /// Each piece's centre of mass in the world, metres.
    pub fn centres(&self) -> Vec<Vector> {
        self.pieces.iter().map(|&h| self.world.bodies[h].center_of_mass()).collect()
    }

    /// Total kinetic energy of the pieces, J.
    pub fn kinetic_energy_j(&self) -> f64 {
        self.pieces.iter().map(|&h| self.world.bodies[h].kinetic_energy()).sum()
    }

    /// The distance from piece `piece`'s shape to the nearest other collider (the floor, a
    /// sphere, another piece), metres: 0 when touching, infinite when there is none.
    pub fn clearance_m(&self, piece: usize) -> f64 {
        let body = &self.world.bodies[self.pieces[piece]];
        let mut nearest = f64::INFINITY;
        for &own in body.colliders() {
            let own = &self.world.colliders[own];
            for (_, other) in self.world.colliders.iter() {
                if other.parent() == Some(self.pieces[piece]) {
                    continue;
                }
                let distance =
                    rapier3d_f64::parry::query::distance(own.position(), own.shape(), other.position(), other.shape());
                nearest = nearest.min(distance.map_or(0.0, |d| d.distance));
            }
        }
        nearest
    }

    /// The pieces that are awake (still moving, or not yet still for long enough to sleep).
    pub fn awake_pieces(&self) -> Vec<usize> {
        (0..self.pieces.len()).filter(|&i| !self.world.bodies[self.pieces[i]].is_sleeping()).collect()
    }

    /// Whether every piece sleeps.
    pub fn all_asleep(&self) -> bool {
        self.pieces.iter().all(|&h| self.world.bodies[h].is_sleeping())
    }

    /// The overlap allowances still in force (see [`ContactRules`]).
    pub fn allowances(&self) -> usize {
        self.rules.allowance_m.len()
    }

    /// The deepest overlap between two pieces or a piece and the floor now, metres, beyond
    /// the handoff's allowances.
    pub fn deepest_penetration_m(&self) -> f64 {
        self.overlaps().first().map_or(0.0, |overlap| overlap.2)
    }

    /// Every overlap now beyond the handoff's allowances, deepest first: the two pieces (None
    /// for the floor, a projectile or an indenter) and the depth, metres.
    pub fn overlaps(&self) -> Vec<(Option<usize>, Option<usize>, f64)> {
        let index: std::collections::BTreeMap<_, usize> =
            self.pieces.iter().enumerate().map(|(i, body)| (body.into_raw_parts(), i)).collect();
        let piece_of = |collider: ColliderHandle| {
            let body = self.world.colliders.get(collider)?.parent()?;
            index.get(&body.into_raw_parts()).copied()
        };
        let mut overlaps: Vec<(Option<usize>, Option<usize>, f64)> = Vec::new();
        for pair in self.world.narrow_phase.contact_pairs() {
            let depth = deepest(pair.manifolds().iter().flat_map(|m| m.points.iter().map(|p| p.dist)));
            let beyond =
                depth - self.rules.allowance_m.get(&pair_key(pair.collider1, pair.collider2)).copied().unwrap_or(0.0);
            if beyond > 0.0 {
                overlaps.push((piece_of(pair.collider1), piece_of(pair.collider2), beyond));
            }
        }
        overlaps.sort_by(|a, b| b.2.total_cmp(&a.2));
        overlaps
    }

    /// The world serialised (MessagePack: every f64, infinities too, round trips exactly).
    pub fn snapshot(&self) -> Result<Vec<u8>, rmp_serde::encode::Error> {
        rmp_serde::to_vec_named(self)
    }

    /// A world from [`RigidWorld::snapshot`].
    pub fn restore(bytes: &[u8]) -> Result<RigidWorld, rmp_serde::decode::Error> {
        rmp_serde::from_slice(bytes)
    }
}
