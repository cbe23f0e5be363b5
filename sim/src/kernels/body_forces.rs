//! The body forces (the paper's `bodyforces`): gravity, projectiles (eq. 7) and spherical
//! indenters, added to a chunk's forces, and the power they deliver.

use super::lanes::{self, LANES, Lanes};

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
