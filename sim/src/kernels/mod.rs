//! The step's kernels on the CPU, one function per kernel of the paper's GPU structure
//! (position update, spring forces, collisions, body forces, velocity update). Each works on one
//! chunk of particles and writes only that chunk's outputs.

// Indexed loops, as in the WGSL kernels of the same passes.
#![allow(clippy::needless_range_loop)]

pub(crate) mod lanes;
mod lattice_springs;
#[cfg(target_arch = "x86_64")]
mod lattice_springs_avx512;
mod springs;
#[cfg(target_arch = "x86_64")]
mod springs_avx2;

pub use lattice_springs::lattice_spring_forces;
pub use springs::{ChunkForces, ParticleRecord, PassRules, spring_forces, stretch};

use crate::contact::{BondLookup, Candidate, ContactList, contact_reach, repulsion};
use crate::model::Floor;
use lanes::{LANES, Lanes};

/// Adds to each particle i of the chunk (from `first`) the sum, over its contact candidates j in
/// their fixed order, of the force `push(i, candidate, d, r2, rest2)` returns, given the offset
/// d = x_i - x_j, its squared length r2 and the squared rest distance rest2 (None: no force).
#[inline(always)]
fn sum_over_candidates(
    first: usize,
    position: [&[f32]; 3],
    rest: [&[f32]; 3],
    contacts: &ContactList,
    force: &mut [&mut [f32]; 3],
    push: impl Fn(usize, &Candidate, [f32; 3], f32, f32) -> Option<[f32; 3]>,
) {
    let len = force[0].len();
    for local in 0..len {
        let i = first + local;
        let candidates = contacts.candidates(i);
        if candidates.is_empty() {
            continue;
        }
        let p = [position[0][i], position[1][i], position[2][i]];
        let x = [rest[0][i], rest[1][i], rest[2][i]];
        let mut sum = [0.0f32; 3];
        for candidate in candidates {
            let j = candidate.particle as usize;
            let d = [p[0] - position[0][j], p[1] - position[1][j], p[2] - position[2][j]];
            let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let xi = [x[0] - rest[0][j], x[1] - rest[1][j], x[2] - rest[2][j]];
            if let Some(f) = push(i, candidate, d, r2, xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]) {
                sum = [sum[0] + f[0], sum[1] + f[1], sum[2] + f[2]];
            }
        }
        for axis in 0..3 {
            force[axis][local] += sum[axis];
        }
    }
}

/// Collisions (the paper's `collisions`): each particle of the chunk is pushed away from every
/// particle it is not bonded to that is closer than the contact distance, or than their rest
/// distance where that is shorter (see [`contact_reach`]).
#[allow(clippy::too_many_arguments)]
pub fn collisions(
    first: usize,
    position: [&[f32]; 3],
    rest: [&[f32]; 3],
    contacts: &ContactList,
    bonds: &impl BondLookup,
    stiffness: f32,
    distance: f32,
    force: &mut [&mut [f32]; 3],
) {
    sum_over_candidates(first, position, rest, contacts, force, |_, candidate, d, r2, rest2| {
        let reach = contact_reach(distance, rest2);
        if r2 >= reach * reach || r2 == 0.0 || bonds.intact(candidate.bond) {
            return None;
        }
        Some(repulsion(stiffness, reach, d, r2.sqrt()))
    });
}

/// LAMMPS's short-range force (`pair_style peri/pmb`) on each particle of the chunk: every
/// candidate j closer than d_ij = min(0.9 |X_i - X_j|, 1.35 lambda) at rest, bonded or not,
/// pushes i away with `stiffness` V_i V_j (d_ij - r), where `stiffness` is 15 c / delta (LAMMPS's
/// force density times V_i).
#[allow(clippy::too_many_arguments)]
pub fn short_range(
    first: usize,
    position: [&[f32]; 3],
    rest: [&[f32]; 3],
    contacts: &ContactList,
    volume: &[f32],
    stiffness: f32,
    lambda: f32,
    force: &mut [&mut [f32]; 3],
) {
    sum_over_candidates(first, position, rest, contacts, force, |i, candidate, d, r2, rest2| {
        let j = candidate.particle as usize;
        let reach = (0.9 * rest2.sqrt()).min(1.35 * lambda);
        if r2 >= reach * reach || r2 == 0.0 {
            return None;
        }
        let r = r2.sqrt();
        let scale = stiffness * volume[i] * volume[j] * (reach - r) / r;
        Some(d.map(|c| c * scale))
    });
}

/// A kinematic sphere's state during one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereNow {
    /// Centre, metres.
    pub center: [f32; 3],
    /// Unit direction of travel (zero when at rest).
    pub heading: [f32; 3],
    /// Radius, metres.
    pub radius: f32,
    /// Force constant.
    pub stiffness: f32,
}

/// The paper's eq. 7 projectile force on a particle at `p`.
pub fn projectile_force(sphere: &SphereNow, p: [f32; 3]) -> [f32; 3] {
    let d = [p[0] - sphere.center[0], p[1] - sphere.center[1], p[2] - sphere.center[2]];
    let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let radius = sphere.radius;
    if !(r >= 0.75 * radius && r <= 1.5 * radius) {
        return [0.0; 3];
    }
    let shape = 16.0 * (r - 0.75 * radius) * (r - 1.5 * radius) * (r - 1.5 * radius);
    let magnitude = sphere.stiffness * shape.cbrt() * shape.cbrt();
    let away = d.map(|c| c / r);
    let mut direction = [away[0] + sphere.heading[0], away[1] + sphere.heading[1], away[2] + sphere.heading[2]];
    let norm = (direction[0] * direction[0] + direction[1] * direction[1] + direction[2] * direction[2]).sqrt();
    if norm > 1e-6 {
        direction = direction.map(|c| c / norm);
    } else {
        direction = away;
    }
    direction.map(|c| c * magnitude)
}

/// A spherical indenter's force K (R - r)^2 on a particle at `p`, pushing it out.
pub fn indenter_force(sphere: &SphereNow, p: [f32; 3]) -> [f32; 3] {
    let d = [p[0] - sphere.center[0], p[1] - sphere.center[1], p[2] - sphere.center[2]];
    let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if r >= sphere.radius || r == 0.0 {
        return [0.0; 3];
    }
    let gap = sphere.radius - r;
    let scale = sphere.stiffness * gap * gap / r;
    d.map(|c| c * scale)
}

/// External forces acting this step.
#[derive(Debug, Clone, Copy)]
pub struct BodyForces<'a> {
    /// Gravity, m/s^2.
    pub gravity: [f32; 3],
    /// Projectiles now.
    pub projectiles: &'a [SphereNow],
    /// Indenters now.
    pub indenters: &'a [SphereNow],
}

impl BodyForces<'_> {
    /// True when nothing acts (no gravity, projectile or indenter): [`body_forces`] would add
    /// only zeros, so the step leaves it out.
    pub fn is_empty(&self) -> bool {
        self.gravity == [0.0; 3] && self.projectiles.is_empty() && self.indenters.is_empty()
    }

    /// The force on a particle of mass `mass` at `p`: its weight, then each projectile's push
    /// and each indenter's, added in that order.
    fn on(&self, mass: f32, p: [f32; 3]) -> [f32; 3] {
        let mut f = self.gravity.map(|g| g * mass);
        let projectiles = self.projectiles.iter().map(|sphere| projectile_force(sphere, p));
        for push in projectiles.chain(self.indenters.iter().map(|sphere| indenter_force(sphere, p))) {
            f = [f[0] + push[0], f[1] + push[1], f[2] + push[2]];
        }
        f
    }

    /// Whether some sphere may push a particle of `range` (false only where every sphere's
    /// reach, widened by a tenth of a percent for rounding, misses the particles' bounding box:
    /// a projectile pushes out to 1.5 radii, an indenter to its radius). The box passes over
    /// NaN positions, which no sphere pushes; an infinite one stretches it to reach them all.
    fn may_push(&self, position: [&[f32]; 3], range: std::ops::Range<usize>) -> bool {
        if self.projectiles.is_empty() && self.indenters.is_empty() {
            return false;
        }
        let bounds = position.map(|axis| extent(&axis[range.clone()]));
        let reaches = |sphere: &SphereNow, reach: f32| {
            let gap2: f64 = (0..3)
                .map(|axis| {
                    let (low, high) = bounds[axis];
                    let c = sphere.center[axis];
                    let gap = if c < low {
                        low - c
                    } else if c > high {
                        c - high
                    } else {
                        0.0
                    };
                    f64::from(gap) * f64::from(gap)
                })
                .sum();
            let reach = f64::from(reach) * (1.0 + 1e-3);
            // (a NaN gap may reach)
            gap2.partial_cmp(&(reach * reach)) != Some(std::cmp::Ordering::Greater)
        };
        self.projectiles.iter().any(|sphere| reaches(sphere, 1.5 * sphere.radius))
            || self.indenters.iter().any(|sphere| reaches(sphere, sphere.radius))
    }
}

/// The smallest and largest of `values`, passing over NaNs (infinite and negative infinite when
/// there are none); eight lanes at a time.
fn extent(values: &[f32]) -> (f32, f32) {
    let (mut low, mut negated_high) = ([f32::INFINITY; LANES], [f32::INFINITY; LANES]);
    let mut blocks = values.chunks_exact(LANES);
    for block in &mut blocks {
        let x = lanes::load(block, 0);
        (low, negated_high) = (lanes::min(low, x), lanes::min(negated_high, lanes::neg(x)));
    }
    let smallest = |lanes: Lanes, rest: &mut dyn Iterator<Item = f32>| {
        lanes.into_iter().chain(rest).fold(f32::INFINITY, |least, x| if x < least { x } else { least })
    };
    let rest = blocks.remainder();
    (smallest(low, &mut rest.iter().copied()), -smallest(negated_high, &mut rest.iter().map(|x| -x)))
}

/// Body forces (the paper's `bodyforces`): gravity, projectiles and indenters, added to the
/// chunk's forces. Returns the power they deliver, sum of F . v, watts (f64, in particle order).
pub fn body_forces(
    first: usize,
    position: [&[f32]; 3],
    velocity: [&[f32]; 3],
    mass: &[f32],
    forces: &BodyForces,
    force: &mut [&mut [f32]; 3],
) -> f64 {
    let range = first..first + force[0].len();
    if forces.may_push(position, range.clone()) {
        // Particle by particle.
        let mut power = 0.0f64;
        for (local, i) in range.enumerate() {
            let f = forces.on(mass[i], [position[0][i], position[1][i], position[2][i]]);
            for axis in 0..3 {
                force[axis][local] += f[axis];
                power = add_power(power, f[axis], velocity[axis][i]);
            }
        }
        return power;
    }
    // No sphere reaches the chunk: each particle's force is its weight, plus a zero push per
    // sphere (which turns a -0 weight into +0, as the general loop's sum does).
    let spheres = !forces.projectiles.is_empty() || !forces.indenters.is_empty();
    let mass = &mass[range.clone()];
    let weight = |g: f32, m: f32| if spheres { g * m + 0.0 } else { g * m };
    for (axis, totals) in force.iter_mut().enumerate() {
        let g = forces.gravity[axis];
        for (total, &m) in totals.iter_mut().zip(mass) {
            *total += weight(g, m);
        }
    }
    // Only the axes gravity acts along deliver power (the others' terms would be zeros), summed
    // in particle order: a particle's axes in turn.
    let acting: Vec<usize> = (0..3).filter(|&axis| forces.gravity[axis] != 0.0).collect();
    let velocity = velocity.map(|v| &v[range.clone()]);
    let power_of = |power, local: usize, axis: usize| {
        add_power(power, weight(forces.gravity[axis], mass[local]), velocity[axis][local])
    };
    match acting[..] {
        // (gravity along one axis, as it mostly is: one loop the compiler keeps tight)
        [axis] => (0..mass.len()).fold(0.0, |power, local| power_of(power, local, axis)),
        _ => (0..mass.len())
            .fold(0.0, |power, local| acting.iter().fold(power, |power, &axis| power_of(power, local, axis))),
    }
}

/// `power` plus the power of force `f` at velocity `v`. A zero force's term is left out: it
/// would leave the sum as it is (the sum starts at +0, so is never -0; a non-finite velocity,
/// whose term would not be zero, stops the run at the frame's end). The sum is a chain through
/// every particle, three additions long each where every term is added.
#[inline(always)]
fn add_power(power: f64, f: f32, v: f32) -> f64 {
    if f != 0.0 { power + f64::from(f) * f64::from(v) } else { power }
}

/// Half a velocity kick: v + dt/2 F/m.
#[inline(always)]
fn half_kick(v: f32, half_dt: f32, force: f32, inverse_mass: f32) -> f32 {
    v + half_dt * force * inverse_mass
}

/// A vertical velocity `v` at `height`: reflected and scaled by the restitution where the
/// particle is below the floor and moves down.
#[inline(always)]
fn bounce(v: f32, height: f32, floor: Option<Floor>) -> f32 {
    match floor {
        Some(floor) if height < floor.height_m && v < 0.0 => v * -floor.restitution,
        _ => v,
    }
}

/// Position update (first half of velocity Verlet): v += dt/2 F/m, then u += dt v.
pub fn kick_drift(dt: f32, inverse_mass: &[f32], force: [&[f32]; 3], velocity: [&mut [f32]; 3], disp: [&mut [f32]; 3]) {
    let half = 0.5 * dt;
    for (axis, (v, u)) in velocity.into_iter().zip(disp).enumerate() {
        for i in 0..v.len() {
            v[i] = half_kick(v[i], half, force[axis][i], inverse_mass[i]);
            u[i] += dt * v[i];
        }
    }
}

/// Velocity update (second half of velocity Verlet): v += dt/2 F/m; a particle below the floor
/// that moves down has its vertical velocity reflected and scaled by the restitution.
pub fn kick_floor(
    dt: f32,
    inverse_mass: &[f32],
    force: [&[f32]; 3],
    height: (&[f32], &[f32]),
    floor: Option<Floor>,
    velocity: [&mut [f32]; 3],
) {
    let half = 0.5 * dt;
    for (axis, v) in velocity.into_iter().enumerate() {
        for i in 0..v.len() {
            v[i] = half_kick(v[i], half, force[axis][i], inverse_mass[i]);
            if axis == 1 {
                v[i] = bounce(v[i], height.0[i] + height.1[i], floor);
            }
        }
    }
}

/// [`kick_floor`] of one step, then [`kick_drift`] of the next (the forces are the same), in
/// one pass over the particles: the two passes' operations in their order, particle by particle.
/// The floor test reads the height before the drift, as `kick_floor` does; `rest_y` is the rest
/// height.
pub fn kick_floor_drift(
    dt: f32,
    inverse_mass: &[f32],
    force: [&[f32]; 3],
    rest_y: &[f32],
    floor: Option<Floor>,
    velocity: [&mut [f32]; 3],
    disp: [&mut [f32]; 3],
) {
    let half = 0.5 * dt;
    for (axis, (v, u)) in velocity.into_iter().zip(disp).enumerate() {
        for i in 0..v.len() {
            let mut kicked = half_kick(v[i], half, force[axis][i], inverse_mass[i]);
            if axis == 1 {
                kicked = bounce(kicked, rest_y[i] + u[i], floor);
            }
            v[i] = half_kick(kicked, half, force[axis][i], inverse_mass[i]);
            u[i] += dt * v[i];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Body forces particle by particle, every power term added.
    fn body_forces_by_definition(
        position: [&[f32]; 3],
        velocity: [&[f32]; 3],
        mass: &[f32],
        forces: &BodyForces,
        force: &mut [Vec<f32>; 3],
    ) -> f64 {
        let mut power = 0.0f64;
        for i in 0..mass.len() {
            let f = forces.on(mass[i], [position[0][i], position[1][i], position[2][i]]);
            for axis in 0..3 {
                force[axis][i] += f[axis];
                power += f64::from(f[axis]) * f64::from(velocity[axis][i]);
            }
        }
        power
    }

    /// On random chunks, with spheres from inside the chunk to just beyond its reach and gravity
    /// along one axis, several or none (some masses, velocities and forces +-0), `body_forces`
    /// (which leaves out the spheres of chunks they cannot reach, and zero power terms) gives the
    /// forces and power of the definition, bit for bit, and pushes some particles.
    #[test]
    fn body_forces_give_the_definitions_bits() {
        let mut rng = shatter_core::random::SplitMix64::new(7);
        let mut random = |low: f32, high: f32| low + (high - low) * rng.next_f64() as f32;
        let mut pushed = 0;
        for case in 0..400 {
            let n = 37 + case % 11;
            // a cube of 2 cm, half the particles near its top face
            let mut position: [Vec<f32>; 3] = [0, 1, 2].map(|_| (0..n).map(|_| random(-0.01, 0.01)).collect());
            for y in position[1].iter_mut().step_by(2) {
                *y = random(0.008, 0.01);
            }
            let zero_some = |value: f32, k: usize| if k.is_multiple_of(5) { [0.0, -0.0][k % 2] } else { value };
            let velocity: [Vec<f32>; 3] = [0, 1, 2].map(|_| (0..n).map(|k| zero_some(random(-3.0, 3.0), k)).collect());
            let mass: Vec<f32> = (0..n).map(|k| zero_some(random(1e-6, 2e-6), k + 1)).collect();
            let start: [Vec<f32>; 3] = [0, 1, 2].map(|_| (0..n).map(|k| zero_some(random(-1.0, 1.0), k + 2)).collect());
            let gravity = [[0.0, -9.81, 0.0], [1.5, -9.81, -0.0], [0.0; 3], [-0.0, 0.0, 2.0]][case % 4];
            // the sphere's centre inside the cube, or above it out to just beyond where it pushes
            let radius = 0.004;
            let distance = if case % 2 == 0 { random(0.0, 0.01) } else { 0.01 + random(0.0, 1.6 * radius) };
            if case % 2 == 1 {
                // a particle right below it on the cube's top face: at the edge of its reach
                [position[0][0], position[1][0], position[2][0]] = [0.0, 0.01, 0.0];
            }
            let sphere = SphereNow { center: [0.0, distance, 0.0], heading: [0.0, 0.0, -1.0], radius, stiffness: 4e5 };
            let spheres = [sphere];
            let (projectiles, indenters): (&[SphereNow], &[SphereNow]) = match case % 3 {
                0 => (&spheres, &[]),
                1 => (&[], &spheres),
                _ => (&[], &[]),
            };
            let forces = BodyForces { gravity, projectiles, indenters };
            let [px, py, pz] = &position;
            let [vx, vy, vz] = &velocity;
            let (p, v) = ([&px[..], &py[..], &pz[..]], [&vx[..], &vy[..], &vz[..]]);
            let mut expected = start.clone();
            let want = body_forces_by_definition(p, v, &mass, &forces, &mut expected);
            let mut got = start.clone();
            let [gx, gy, gz] = &mut got;
            let power = body_forces(0, p, v, &mass, &forces, &mut [&mut gx[..], &mut gy[..], &mut gz[..]]);
            assert_eq!(power.to_bits(), want.to_bits(), "case {case}: power {power} against {want}");
            for axis in 0..3 {
                let bits = |values: &[f32]| values.iter().map(|f| f.to_bits()).collect::<Vec<u32>>();
                assert_eq!(bits(&got[axis]), bits(&expected[axis]), "case {case}, axis {axis}");
            }
            let weightless = BodyForces { gravity, projectiles: &[], indenters: &[] };
            pushed += usize::from(want != body_forces_by_definition(p, v, &mass, &weightless, &mut start.clone()));
        }
        assert!(pushed > 3, "only {pushed} chunks were pushed: the sphere paths are not exercised");
    }

    #[test]
    fn stretch_from_displacement_is_exact_where_subtraction_is_not() {
        // Far from the origin a stretch of 1e-6 is below f32 resolution of positions; from the
        // displacement difference it is still exact to f32 rounding of the stretch itself.
        let xi = [1e-3, 0.0, 0.0];
        let eta = [1e-9, 0.0, 0.0];
        let (s, _, _) = stretch(xi, eta, 1e-3);
        assert!((s - 1e-6).abs() < 1e-12, "{s}");
        let (s, _, _) = stretch(xi, [0.0; 3], 1e-3);
        assert_eq!(s, 0.0);
    }

    #[test]
    fn the_fused_kick_is_the_closing_kick_then_the_opening_one_to_the_bit() {
        let mut rng = shatter_core::random::SplitMix64::new(11);
        let n = 257;
        let mut values = |scale: f64| -> Vec<f32> { (0..n).map(|_| ((rng.next_f64() - 0.5) * scale) as f32).collect() };
        let inverse_mass: Vec<f32> = values(2.0).iter().map(|m| 1e3 * (1.5 + m)).collect();
        let force = [values(1e-2), values(1e-2), values(1e-2)];
        let rest_y = values(2e-3);
        let (velocity, disp) = ([values(4.0), values(4.0), values(4.0)], [values(1e-3), values(1e-3), values(1e-3)]);
        let force = [&force[0][..], &force[1][..], &force[2][..]];
        for floor in [None, Some(Floor { height_m: 0.0, restitution: 0.5 })] {
            let dt = 1e-4;
            let (mut v, mut u) = (velocity.clone(), disp.clone());
            let [vx, vy, vz] = &mut v;
            let [ux, uy, uz] = &mut u;
            kick_floor(dt, &inverse_mass, force, (&rest_y, uy), floor, [vx, vy, vz]);
            kick_drift(dt, &inverse_mass, force, [vx, vy, vz], [ux, uy, uz]);
            let (mut fused_v, mut fused_u) = (velocity.clone(), disp.clone());
            let [fvx, fvy, fvz] = &mut fused_v;
            let [fux, fuy, fuz] = &mut fused_u;
            kick_floor_drift(dt, &inverse_mass, force, &rest_y, floor, [fvx, fvy, fvz], [fux, fuy, fuz]);
            for axis in 0..3 {
                let bits = |values: &[f32]| values.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
                assert_eq!(bits(&fused_v[axis]), bits(&v[axis]), "velocity, axis {axis}, floor {floor:?}");
                assert_eq!(bits(&fused_u[axis]), bits(&u[axis]), "displacement, axis {axis}, floor {floor:?}");
            }
        }
        // some particles bounced
        let below = (0..n).filter(|&i| rest_y[i] + disp[1][i] < 0.0 && velocity[1][i] < 0.0).count();
        assert!(below > 10, "{below}");
    }

    #[test]
    fn projectile_force_peaks_at_the_radius_with_k_r_squared() {
        let sphere = SphereNow { center: [0.0; 3], heading: [0.0; 3], radius: 0.01, stiffness: 1e6 };
        let f = projectile_force(&sphere, [0.01, 0.0, 0.0]);
        assert!((f[0] - 1e6 * 1e-4).abs() < 1e-3 * 1e2, "{f:?}");
        assert_eq!(projectile_force(&sphere, [0.007, 0.0, 0.0]), [0.0; 3]);
        assert_eq!(projectile_force(&sphere, [0.016, 0.0, 0.0]), [0.0; 3]);
        // halfway between travel and repulsion
        let moving = SphereNow { heading: [0.0, 1.0, 0.0], ..sphere };
        let f = projectile_force(&moving, [0.01, 0.0, 0.0]);
        assert!((f[0] - f[1]).abs() < 1e-3 && f[0] > 0.0, "{f:?}");
    }
}
