//! The handoff of a piece's particles to one rigid body: its linear velocity from the total
//! momentum and its angular velocity from the total angular momentum about the body's centre
//! of mass, so both are conserved exactly (to rounding) across the handoff. For a piece whose
//! particles move rigidly this is the least-squares fit of v + w x r; what does not fit (elastic
//! ringing) is the piece's internal kinetic energy, which the handoff rule watches.

use rapier3d_f64::math::{Matrix, Vector};

use crate::mass::outer;

/// The particles of one piece at the handoff.
#[derive(Debug, Clone, Copy)]
pub struct ParticleMotion<'a> {
    /// Masses, kg.
    pub mass_kg: &'a [f64],
    /// Positions, metres.
    pub position_m: &'a [Vector],
    /// Velocities, m/s.
    pub velocity_m_s: &'a [Vector],
}

/// A piece's rigid velocity and the kinetic energies around it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidVelocity {
    /// Velocity of the centre of mass, m/s.
    pub linear_m_s: Vector,
    /// Angular velocity, rad/s.
    pub angular_rad_s: Vector,
    /// The particles' kinetic energy, J.
    pub particle_energy_j: f64,
    /// The kinetic energy of the particles' best rigid motion (point masses), J.
    pub rigid_part_j: f64,
    /// The rigid body's kinetic energy with `inertia`, J.
    pub body_energy_j: f64,
}

impl RigidVelocity {
    /// Kinetic energy of the motion that is not rigid, J.
    pub fn internal_energy_j(&self) -> f64 {
        (self.particle_energy_j - self.rigid_part_j).max(0.0)
    }
}

/// Total momentum and angular momentum (about the world origin) of particles.
pub fn momenta(particles: &ParticleMotion) -> (Vector, Vector) {
    let mut momentum = Vector::ZERO;
    let mut angular = Vector::ZERO;
    for ((m, x), v) in particles.mass_kg.iter().zip(particles.position_m).zip(particles.velocity_m_s) {
        momentum += *v * *m;
        angular += x.cross(*v) * *m;
    }
    (momentum, angular)
}

/// The rigid velocity of a body with centre of mass `centre_m` and inertia tensor `inertia`
/// (world frame, about the centre) that carries the particles' momentum and angular momentum.
pub fn fit(particles: &ParticleMotion, centre_m: Vector, inertia: Matrix) -> RigidVelocity {
    let mass: f64 = particles.mass_kg.iter().sum();
    let (momentum, _) = momenta(particles);
    let linear = if mass > 0.0 { momentum / mass } else { Vector::ZERO };
    let mut angular_momentum = Vector::ZERO;
    let mut particle_energy = 0.0;
    let mut point_inertia = Matrix::ZERO;
    let mut point_centre = Vector::ZERO;
    for ((m, x), v) in particles.mass_kg.iter().zip(particles.position_m).zip(particles.velocity_m_s) {
        angular_momentum += (*x - centre_m).cross(*v) * *m;
        particle_energy += 0.5 * m * v.length_squared();
        point_centre += *x * *m;
    }
    if mass > 0.0 {
        point_centre /= mass;
    }
    let mut point_angular = Vector::ZERO;
    for ((m, x), v) in particles.mass_kg.iter().zip(particles.position_m).zip(particles.velocity_m_s) {
        let r = *x - point_centre;
        point_inertia += (Matrix::from_diagonal(Vector::splat(r.length_squared())) - outer(r, r)) * *m;
        point_angular += r.cross(*v - linear) * *m;
    }
    let translational = 0.5 * mass * linear.length_squared();
    let mut angular = solve(inertia, angular_momentum);
    // a body never turns faster than its particles' energy allows (an element so thin that its
    // inertia is rounding would otherwise spin from rounding in L)
    let spin = 0.5 * angular.dot(inertia * angular);
    let available = (particle_energy - translational).max(0.0);
    if !spin.is_finite() {
        angular = Vector::ZERO;
    } else if spin > available {
        angular *= (available / spin).sqrt();
    }
    let point_omega = solve(point_inertia, point_angular);
    RigidVelocity {
        linear_m_s: linear,
        angular_rad_s: angular,
        particle_energy_j: particle_energy,
        rigid_part_j: translational + 0.5 * point_omega.dot(point_angular),
        body_energy_j: translational + 0.5 * angular.dot(inertia * angular),
    }
}

/// Solves I w = L for a symmetric positive semi-definite I. Directions in which I (nearly)
/// vanishes, relative to its largest eigenvalue (a single point mass, particles in a line), get
/// no rotation: noise in them would otherwise spin the piece at any speed.
fn solve(inertia: Matrix, angular_momentum: Vector) -> Vector {
    let eigen = rapier3d_f64::math::SymmetricEigen::new(inertia);
    let largest = eigen.eigenvalues.max_element();
    if !(largest.is_finite() && largest > 0.0) {
        return Vector::ZERO;
    }
    if eigen.eigenvalues.min_element() > 1e-6 * largest {
        return inertia.inverse() * angular_momentum;
    }
    let mut omega = Vector::ZERO;
    for axis in 0..3 {
        let value = eigen.eigenvalues[axis];
        if value > 1e-6 * largest {
            let direction = eigen.eigenvectors.col(axis);
            omega += direction * (direction.dot(angular_momentum) / value);
        }
    }
    omega
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rigid_motion_is_recovered_and_momenta_are_kept() {
        let positions: Vec<Vector> = (0..27)
            .map(|i| {
                Vector::new((i % 3) as f64, ((i / 3) % 3) as f64, (i / 9) as f64) * 0.01 + Vector::new(0.1, 0.2, 0.3)
            })
            .collect();
        let mass = vec![0.002; positions.len()];
        let v0 = Vector::new(0.3, -1.0, 2.0);
        let w0 = Vector::new(4.0, -2.0, 7.0);
        let centre = Vector::new(0.11, 0.21, 0.31);
        let velocity: Vec<Vector> = positions.iter().map(|x| v0 + w0.cross(*x - centre)).collect();
        let particles = ParticleMotion { mass_kg: &mass, position_m: &positions, velocity_m_s: &velocity };
        // cubes of edge 1 cm at each particle: the point inertia plus each cube's own
        let own = 0.002 * 2.0 * 1e-4 / 12.0;
        let mut inertia = Matrix::from_diagonal(Vector::splat(own * 27.0));
        for (m, x) in mass.iter().zip(&positions) {
            let r = *x - centre;
            inertia += (Matrix::from_diagonal(Vector::splat(r.length_squared())) - outer(r, r)) * *m;
        }
        let fitted = fit(&particles, centre, inertia);
        assert!((fitted.linear_m_s - (v0 + w0.cross(centre - centre))).length() < 1e-12);
        let (p, l) = momenta(&particles);
        let body_p = fitted.linear_m_s * mass.iter().sum::<f64>();
        let body_l = inertia * fitted.angular_rad_s + centre.cross(body_p);
        assert!((body_p - p).length() <= 1e-12 * p.length());
        assert!((body_l - l).length() <= 1e-12 * l.length(), "{body_l:?} vs {l:?}");
        assert!(fitted.body_energy_j <= fitted.particle_energy_j * (1.0 + 1e-12));
        assert!(fitted.body_energy_j >= 0.95 * fitted.rigid_part_j);
        assert!(fitted.internal_energy_j() < 1e-12 * fitted.particle_energy_j);
    }

    #[test]
    fn particles_nearly_in_a_line_do_not_spin_up_from_noise() {
        let x = [0.0, 0.001, 0.002, 0.003].map(|d| Vector::new(0.01 + d, 0.06 + 1e-9 * d, 0.0));
        let v = [Vector::new(0.3, -2.0, 1.0), Vector::new(-0.5, 0.4, 0.0), Vector::ZERO, Vector::Y];
        let m = [2.2e-6; 4];
        let fitted = fit(&ParticleMotion { mass_kg: &m, position_m: &x, velocity_m_s: &v }, x[1], Matrix::ZERO);
        assert!(fitted.rigid_part_j <= fitted.particle_energy_j, "{fitted:?}");
    }

    #[test]
    fn a_body_of_rounding_inertia_does_not_spin_up() {
        let x = [Vector::new(0.1, 0.2, 0.3)];
        let v = [Vector::new(-9.9, 7.3, 6.8)];
        let inertia = Matrix::from_diagonal(Vector::new(0.0, 1e-39, 1e-39));
        let fitted = fit(
            &ParticleMotion { mass_kg: &[1e-3], position_m: &x, velocity_m_s: &v },
            x[0] + Vector::X * 1e-12,
            inertia,
        );
        assert!(fitted.body_energy_j <= fitted.particle_energy_j * (1.0 + 1e-12), "{fitted:?}");
    }

    #[test]
    fn one_particle_moves_without_spinning() {
        let particles =
            ParticleMotion { mass_kg: &[1.0], position_m: &[Vector::X], velocity_m_s: &[Vector::new(0.0, 2.0, 0.0)] };
        let fitted = fit(&particles, Vector::X, Matrix::ZERO);
        assert_eq!(fitted.linear_m_s, Vector::new(0.0, 2.0, 0.0));
        assert_eq!(fitted.angular_rad_s, Vector::ZERO);
        assert!((fitted.body_energy_j - 2.0).abs() < 1e-12);
    }
}
