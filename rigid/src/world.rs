//! The rigid world of a follow-through: one dynamic body per piece, a fixed floor, projectiles
//! and indenters as kinematic spheres, stepped by rapier with the [`ContactRules`] hook. The
//! whole world serialises, so a resumed run continues bit for bit.

use rapier3d_f64::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

use shatter_core::config::RigidConfig;
use shatter_core::disjoint_sets::DisjointSets;

use crate::contact_rules::{ContactRules, pair_depth, pair_key};
use crate::mass::MassProps;
use crate::plane_contacts;

mod bounds;
mod impacts;
mod piece_swaps;

pub use impacts::{Impact, ImpactWatch, Stepped, Struck, critical_speed_m_s};

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
    /// The shot's region, metres (lowest and highest corner): a piece whose centre of mass
    /// leaves it is retired, held where it is and taken out of the simulation (past a side,
    /// once it touches something).
    pub bounds_m: Option<[[f64; 3]; 2]>,
    /// The decay rate of a touching piece's spin, 1/s (rolling resistance).
    pub rolling_damping_per_s: f64,
    /// The constant part of rolling resistance: a touching piece's spin slows by this much
    /// speed at its farthest point every second, m/s^2, so that rocking stops in finite time.
    pub rolling_resistance_m_s2: f64,
}

impl WorldSettings {
    /// The settings `[rigid]` gives, under `gravity_m_s2` with the solver's length unit
    /// `length_unit_m`.
    pub fn of(rigid: &RigidConfig, gravity_m_s2: [f64; 3], length_unit_m: f64) -> WorldSettings {
        WorldSettings {
            gravity_m_s2,
            length_unit_m,
            solver_iterations: rigid.solver_iterations as usize,
            floor_friction: rigid.floor_friction,
            floor_restitution: rigid.floor_restitution,
            piece_friction: rigid.piece_friction,
            piece_restitution: rigid.piece_restitution,
            sleep_speed_m_s: rigid.sleep_speed_m_s,
            sleep_after_s: rigid.sleep_after_s,
            max_mass_ratio: rigid.max_mass_ratio,
            bounds_m: rigid.bounds_m,
            rolling_damping_per_s: rigid.rolling_damping_per_s,
            rolling_resistance_m_s2: rigid.rolling_resistance_m_s2,
        }
    }
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
    bounds_m: Option<[[f64; 3]; 2]>,
    rolling_damping_per_s: f64,
    #[serde(default)]
    rolling_resistance_m_s2: f64,
}

/// Where a piece was when its current still spell began, and how long that has lasted.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct RestWatch {
    centre_m: [f64; 3],
    rotation: [f64; 4],
    /// The distance from its centre of mass to its farthest point, metres.
    reach_m: f64,
    still_s: f64,
    /// Left the shot's region (see [`WorldSettings::bounds_m`]).
    retired: bool,
}

/// The hook every collider runs: [`ContactRules`] modifies its solver contacts.
const CONTACT_HOOKS: ActiveHooks = ActiveHooks::MODIFY_SOLVER_CONTACTS;

/// An empty physics world with the solver settings of `settings`.
fn physics_world(settings: &WorldSettings) -> PhysicsWorld {
    let mut world = PhysicsWorld::new();
    world.gravity = Vector::from_array(settings.gravity_m_s2);
    world.integration_parameters.length_unit = settings.length_unit_m;
    world.integration_parameters.num_solver_iterations = settings.solver_iterations;
    // rapier merges the manifolds of a compound's parts that share a normal into one of at
    // most four points; as a piece lying on a compound of hundreds of hulls rocks, the four
    // points chosen jump from part to part, and a curved shard rocked on for seconds, fed by
    // the jumps (measured: a 24-hull shard still at 1.3 rad/s after 3 s with clustering, at
    // rest at once without; the vase shot's last pieces sleep 12 frames earlier)
    world.integration_parameters.contact_clustering = false;
    // rapier caps every body's speed at 400 length units a second (4,000 spacings a second:
    // 8 m/s at a 2 mm spacing), which stopped a slab falling from 7 m at 8 m/s and hid its hard
    // landing; the steps are short enough for any speed a shot reaches (CCD, the slab floor)
    world.integration_parameters.normalized_max_linear_velocity = f64::MAX;
    world.narrow_phase.set_query_dispatcher(plane_contacts::dispatcher());
    world
}

/// Inserts the floor slab, its top at `height_m`, and returns its collider. With `any_dust`,
/// dust passes through it: dust rests on the plane of [`insert_dust_floor`].
fn insert_floor(world: &mut PhysicsWorld, height_m: f64, any_dust: bool) -> ColliderHandle {
    // a slab, not a half-space: on a half-space the plate shot's largest shard (9,330
    // cubes, a compound of hulls) sank 29 mm through the floor and stayed there; dust
    // meets the plane at its top instead (below)
    let top = Vector::new(0.0, height_m - FLOOR_HALF_THICKNESS_M, 0.0);
    let body = world.insert_body(RigidBodyBuilder::fixed().translation(top));
    let slab = SharedShape::cuboid(FLOOR_HALF_WIDTH_M, FLOOR_HALF_THICKNESS_M, FLOOR_HALF_WIDTH_M);
    let filter = if any_dust { Group::ALL.difference(DUST) } else { Group::ALL };
    let collider = ColliderBuilder::new(slab).active_hooks(CONTACT_HOOKS).collision_groups(groups(ENVIRONMENT, filter));
    world.insert_collider(collider, Some(body))
}

/// Inserts a projectile or indenter.
fn insert_sphere(world: &mut PhysicsWorld, sphere: &KinematicSphere) {
    let body = RigidBodyBuilder::kinematic_velocity_based()
        .translation(Vector::from_array(sphere.centre_m))
        .linvel(Vector::from_array(sphere.velocity_m_s));
    let body = world.insert_body(body);
    let collider = ColliderBuilder::ball(sphere.radius_m)
        .active_hooks(CONTACT_HOOKS)
        .collision_groups(groups(ENVIRONMENT, Group::ALL));
    world.insert_collider(collider, Some(body));
}

/// Inserts a piece's body (and its collider, when it has a shape).
fn insert_piece(world: &mut PhysicsWorld, settings: &WorldSettings, piece: &PieceBody) -> RigidBodyHandle {
    let inertia = piece.mass.inertia();
    let mass = MassProperties::with_inertia_matrix(piece.mass.centre_m, piece.mass.mass_kg, inertia);
    let body = RigidBodyBuilder::dynamic()
        .pose(Pose::from_parts(piece.translation_m, piece.rotation))
        .additional_mass_properties(mass)
        .linvel(piece.linear_m_s)
        .angvel(piece.angular_rad_s)
        // dust meets only the floor, a slab a metre thick, and the spheres: 46 m/s crosses
        // 5 cm in a step, so CCD buys nothing (it cost 6% of the paper-scale vase's steps)
        .ccd_enabled(!piece.dust)
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
            .active_hooks(CONTACT_HOOKS | ActiveHooks::FILTER_CONTACT_PAIRS)
            .collision_groups(group);
        world.insert_collider(collider, Some(handle));
    }
    handle
}

/// Inserts the plane dust rests on, at `height_m` (the floor slab's top).
fn insert_dust_floor(world: &mut PhysicsWorld, height_m: f64) -> ColliderHandle {
    let body = world.insert_body(RigidBodyBuilder::fixed().translation(Vector::new(0.0, height_m, 0.0)));
    let collider = ColliderBuilder::new(SharedShape::halfspace(Vector::Y))
        .active_hooks(CONTACT_HOOKS)
        .collision_groups(groups(ENVIRONMENT, DUST));
    world.insert_collider(collider, Some(body))
}

impl RestWatch {
    /// The watch of `piece`, just inserted as `body`: still for no time yet.
    fn new(body: &RigidBody, piece: &PieceBody) -> RestWatch {
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
            retired: false,
        }
    }
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
        let mut world = physics_world(settings);
        let any_dust = pieces.iter().any(|piece| piece.dust && piece.shape.is_some());
        let floor = floor_height_m.map(|height| insert_floor(&mut world, height, any_dust));
        for sphere in spheres {
            insert_sphere(&mut world, sphere);
        }
        let handles: Vec<RigidBodyHandle> =
            pieces.iter().map(|piece| insert_piece(&mut world, settings, piece)).collect();
        // Dust rests on a plane at the slab's top, met in closed form (see `plane_contacts`),
        // not on the slab, which parry meets with GJK and EPA: tens of thousands of grains
        // rest on the floor of the paper-scale vase. Inserted after the pieces, so that rapier
        // files each grain's pair under the grain (it walks the lower collider's list of pairs
        // to find one) and the floor's and pieces' colliders keep their handles.
        let dust_floor = floor_height_m.filter(|_| any_dust).map(|height| insert_dust_floor(&mut world, height));
        let coefficients =
            [settings.floor_friction, settings.floor_restitution, settings.piece_friction, settings.piece_restitution];
        let rules = ContactRules::new([floor, dust_floor], coefficients, settings.max_mass_ratio);
        let watch =
            handles.iter().zip(pieces).map(|(&handle, piece)| RestWatch::new(&world.bodies[handle], piece)).collect();
        RigidWorld {
            world,
            rules,
            pieces: handles,
            watch,
            sleep_speed_m_s: settings.sleep_speed_m_s,
            sleep_after_s: settings.sleep_after_s,
            bounds_m: settings.bounds_m,
            rolling_damping_per_s: settings.rolling_damping_per_s,
            rolling_resistance_m_s2: settings.rolling_resistance_m_s2,
        }
    }

    /// Advances `duration_s` in equal steps no longer than `max_step_s`; returns the steps taken.
    pub fn advance(&mut self, duration_s: f64, max_step_s: f64) -> u64 {
        let steps = self.step_for(duration_s, max_step_s, None).steps;
        self.end_interval(duration_s);
        steps
    }

    /// Steps through `duration_s` in equal steps no longer than `max_step_s`; with `watch`,
    /// stops after the first step in which a watched piece hits something hard. Call
    /// [`RigidWorld::end_interval`] after the interval's last step.
    pub fn step_for(&mut self, duration_s: f64, max_step_s: f64, watch: Option<&ImpactWatch>) -> Stepped {
        let steps = (duration_s / max_step_s).ceil().max(1.0) as u64;
        let dt_s = duration_s / steps as f64;
        self.set_step(dt_s);
        for step in 1..=steps {
            let before = watch.map(|watch| self.motions_of(watch));
            self.world.step_with_events(&self.rules, &());
            self.rules.shrink_allowances(&self.world.narrow_phase);
            if let (Some(watch), Some(before)) = (watch, before)
                && let Some(impact) = self.hardest_impact(watch, &before)
            {
                return Stepped { steps: step, dt_s, impact: Some(impact) };
            }
        }
        Stepped { steps, dt_s, impact: None }
    }

    /// Takes `steps` steps of exactly `dt_s` (the steps a [`RigidWorld::step_for`] took before
    /// its impact, replayed from the same world).
    pub fn step_exactly(&mut self, dt_s: f64, steps: u64) {
        self.set_step(dt_s);
        for _ in 0..steps {
            self.world.step_with_events(&self.rules, &());
            self.rules.shrink_allowances(&self.world.narrow_phase);
        }
    }

    /// Sets the step length and the contacts' stiffness that goes with it.
    fn set_step(&mut self, dt_s: f64) {
        self.world.integration_parameters.dt = dt_s;
        // stiffer contacts than rapier's defaults (30 Hz between bodies, 60 Hz against the
        // floor): a pile of small pieces under gravity sinks into itself by hundredths of a
        // millimetre, not millimetres, and a light piece under a heavy shard is not pressed
        // into the floor; capped where the substeps would make them unstable
        let substep_rate_hz = self.world.integration_parameters.num_solver_iterations as f64 / dt_s;
        let frequency_hz = CONTACT_FREQUENCY_HZ.min(substep_rate_hz / 8.0);
        self.world.integration_parameters.contact_softness.natural_frequency = frequency_hz;
        self.world.integration_parameters.static_contact_softness.natural_frequency = 2.0 * frequency_hz;
    }

    /// What follows an interval of `duration_s` of steps: pieces outside the region retired,
    /// still piles put to sleep, touching pieces' spin damped.
    pub fn end_interval(&mut self, duration_s: f64) {
        let (touching, piles) = self.contacts();
        self.retire_outside_bounds(&touching);
        self.settle(duration_s, piles);
        self.resist_rolling(&touching);
    }

    /// Which pieces touch anything (the floor, a sphere, another piece), and the piles that
    /// contacts between pieces link them into.
    fn contacts(&self) -> (Vec<bool>, DisjointSets) {
        let mut touching = vec![false; self.pieces.len()];
        let mut piles = DisjointSets::new(self.pieces.len());
        let index = self.piece_index();
        for pair in self.world.narrow_phase.contact_pairs().filter(|pair| pair.has_any_active_contact()) {
            let pieces = [pair.collider1, pair.collider2].map(|collider| self.piece_of(&index, collider));
            for piece in pieces.into_iter().flatten() {
                touching[piece] = true;
            }
            if let [Some(a), Some(b)] = pieces {
                piles.join(a as u32, b as u32);
            }
        }
        (touching, piles)
    }

    /// Each piece's index by its body handle's raw parts.
    fn piece_index(&self) -> BTreeMap<(u32, u32), usize> {
        self.pieces.iter().enumerate().map(|(i, body)| (body.into_raw_parts(), i)).collect()
    }

    /// The piece that `collider` belongs to (None for the floor or a sphere).
    fn piece_of(&self, index: &BTreeMap<(u32, u32), usize>, collider: ColliderHandle) -> Option<usize> {
        let body = self.world.colliders.get(collider)?.parent()?;
        index.get(&body.into_raw_parts()).copied()
    }

    /// Rolling resistance: a piece that touches something has its spin damped through the
    /// next frame, at `rolling_damping_per_s` and by `rolling_resistance_m_s2` more, taken as
    /// a rate at the frame's start (the deceleration over the spin's speed at its farthest
    /// point); in flight it spins freely. rapier has no rolling friction: a curved shard of
    /// the vase (94 g, lying on its back on a compound of 256 hulls) rocked by a degree or
    /// more each frame for as long as it was simulated, and with the rate alone a 3,436-tet
    /// shard still rocked at 1.2 rad/s after 2.5 s (the rate slows the slow rocking slowly).
    fn resist_rolling(&mut self, touching: &[bool]) {
        for ((&handle, &touches), watch) in self.pieces.iter().zip(touching).zip(&self.watch) {
            // read first: indexing rapier's set mutably marks a body modified
            let body = &self.world.bodies[handle];
            let rim_speed_m_s = body.angvel().length() * watch.reach_m;
            let damping = if !touches {
                0.0
            } else if rim_speed_m_s > 0.0 {
                self.rolling_damping_per_s + self.rolling_resistance_m_s2 / rim_speed_m_s
            } else {
                self.rolling_damping_per_s
            };
            if body.angular_damping() != damping {
                self.world.bodies[handle].set_angular_damping(damping);
            }
        }
    }

    /// rapier puts a body to sleep when its velocity stays low, step by step. A piece resting
    /// on the floor or on another piece can jitter in place (its contacts switching between
    /// faces), with an angular velocity of several rad/s whose sign flips every step while it
    /// turns by a fraction of a degree, or, lying on a compound of hundreds of hulls, rock by a
    /// degree for ever: it never sleeps, and neither does the pile it rests on, which rapier
    /// puts to sleep only as a whole. Here the test is the net motion: a piece is still while
    /// its farthest point stays within the distance the sleep speed covers in `sleep_after_s`
    /// of where it was when the spell began, and a pile (pieces linked by contacts; a lone
    /// piece is a pile of one) whose every piece has been still for `sleep_after_s` is put to
    /// sleep, every piece at once. (One put to sleep on its own under others was pushed into by
    /// them and blew the pile apart when it woke.)
    fn settle(&mut self, frame_s: f64, mut piles: DisjointSets) {
        if self.sleep_speed_m_s < 0.0 || frame_s <= 0.0 {
            return;
        }
        for (watch, &handle) in self.watch.iter_mut().zip(&self.pieces) {
            // read-only: indexing rapier's set mutably marks a body modified
            let body = &self.world.bodies[handle];
            let centre = body.center_of_mass();
            let rotation = *body.rotation();
            let [x, y, z, w] = watch.rotation;
            let turned = Rotation::from_xyzw(x, y, z, w).angle_between(rotation);
            let moved = (centre - Vector::from_array(watch.centre_m)).length() + turned * watch.reach_m;
            watch.still_s = if watch.retired || body.is_sleeping() {
                self.sleep_after_s
            } else if moved > self.sleep_speed_m_s * self.sleep_after_s {
                // a new spell begins here
                watch.centre_m = centre.to_array();
                watch.rotation = [rotation.x, rotation.y, rotation.z, rotation.w];
                0.0
            } else {
                watch.still_s + frame_s
            };
        }
        let mut restless = vec![false; self.pieces.len()];
        for (piece, watch) in self.watch.iter().enumerate() {
            if watch.still_s < self.sleep_after_s {
                restless[piles.root(piece as u32) as usize] = true;
            }
        }
        for (piece, &handle) in self.pieces.iter().enumerate() {
            let watch = &self.watch[piece];
            if !restless[piles.root(piece as u32) as usize]
                && !watch.retired
                && !self.world.bodies[handle].is_sleeping()
            {
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

    /// Each piece's mass, kg.
    pub fn masses_kg(&self) -> Vec<f64> {
        self.pieces.iter().map(|&h| self.world.bodies[h].mass()).collect()
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

    /// The pieces that are awake (still moving, or not yet still for long enough to sleep);
    /// retired pieces are at rest.
    pub fn awake_pieces(&self) -> Vec<usize> {
        (0..self.pieces.len()).filter(|&i| !self.at_rest(i)).collect()
    }

    /// Whether every piece sleeps (or is retired).
    pub fn all_asleep(&self) -> bool {
        (0..self.pieces.len()).all(|i| self.at_rest(i))
    }

    fn at_rest(&self, piece: usize) -> bool {
        self.watch[piece].retired || self.world.bodies[self.pieces[piece]].is_sleeping()
    }

    /// The pieces retired for leaving the shot's region (see [`WorldSettings::bounds_m`]).
    pub fn retired_pieces(&self) -> usize {
        self.watch.iter().filter(|watch| watch.retired).count()
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
        let index = self.piece_index();
        let piece_of = |collider| self.piece_of(&index, collider);
        let mut overlaps: Vec<(Option<usize>, Option<usize>, f64)> = Vec::new();
        for pair in self.world.narrow_phase.contact_pairs() {
            let depth = pair_depth(pair);
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
        let mut world: RigidWorld = rmp_serde::from_slice(bytes)?;
        // the dispatcher is code, not state: rapier does not serialise it
        world.world.narrow_phase.set_query_dispatcher(plane_contacts::dispatcher());
        Ok(world)
    }
}
