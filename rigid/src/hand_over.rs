//! From particles to rigid bodies: each piece becomes one body with its elements' exact mass
//! properties, the pose post fitted, and the rigid velocity that keeps its particles' momentum
//! and angular momentum. The first handoff makes every piece so; a re-entry's return makes the
//! pieces it broke into so.

use rapier3d_f64::math::{Matrix, Rotation, Vector};
use shatter_core::config::RigidConfig;
use shatter_core::fragments::FragmentFrame;
use shatter_core::frames::PointFrame;
use shatter_core::{ParticleSet, PipelineConfig};

use crate::handoff::members_of_pieces;
use crate::mass::{MassProps, element_mass_props, piece_mass_props};
use crate::rigid_driver::{Conservation, kinematic_spheres, world_settings};
use crate::shapes::ElementGeometry;
use crate::velocity_fit::{ParticleMotion, fit, momenta};
use crate::world::{PieceBody, RigidWorld};

/// A point frame's positions and velocities as vectors.
pub(crate) fn vectors(points: &PointFrame) -> (Vec<Vector>, Vec<Vector>) {
    let vector = |c: &[Vec<f32>; 3], i: usize| Vector::new(f64::from(c[0][i]), f64::from(c[1][i]), f64::from(c[2][i]));
    let n = points.damage.len();
    ((0..n).map(|i| vector(&points.position, i)).collect(), (0..n).map(|i| vector(&points.velocity, i)).collect())
}

/// What makes a piece's body: the elements' mass properties and geometry.
pub(crate) struct PieceMaker {
    /// Each element's mass properties.
    pub(crate) elements: Vec<MassProps>,
    geometry: ElementGeometry,
    hull_volume_factor: f64,
    dust_max_elements: u32,
}

/// A piece's particles as they move: each one's position and velocity, in the order of its
/// members.
pub(crate) struct MemberMotion<'a> {
    /// The piece's elements (indices into the shot's particle file), ascending.
    pub(crate) members: &'a [u32],
    /// Positions, metres.
    pub(crate) position_m: &'a [Vector],
    /// Velocities, m/s.
    pub(crate) velocity_m_s: &'a [Vector],
}

impl PieceMaker {
    /// The maker of `particles`' pieces at `density_kg_m3`.
    pub(crate) fn new(particles: &ParticleSet, density_kg_m3: f64, rigid: &RigidConfig) -> PieceMaker {
        PieceMaker {
            elements: element_mass_props(particles, density_kg_m3),
            geometry: ElementGeometry::of(particles),
            hull_volume_factor: rigid.hull_volume_factor,
            dust_max_elements: rigid.dust_max_elements,
        }
    }

    /// The rest mass properties of the piece of `members`.
    pub(crate) fn rest_of(&self, members: &[u32]) -> MassProps {
        let elements: Vec<MassProps> = members.iter().map(|&i| self.elements[i as usize]).collect();
        piece_mass_props(&elements, &vec![0; members.len()], 1)[0]
    }

    /// The body of a piece at rest mass properties `rest`, posed at `pose` (rotation [x, y, z,
    /// w], translation), moving as `motion` says; with its bookkeeping of the momenta.
    pub(crate) fn body(
        &self,
        rest: &MassProps,
        pose: ([f32; 4], [f64; 3]),
        motion: &MemberMotion,
    ) -> (PieceBody, Balance) {
        let q = pose.0.map(f64::from);
        let rotation = Rotation::from_xyzw(q[0], q[1], q[2], q[3]).normalize();
        let translation = Vector::from_array(pose.1);
        let r = Matrix::from_quat(rotation);
        let centre = rotation * rest.centre_m + translation;
        let inertia = r * rest.inertia() * r.transpose();
        let m: Vec<f64> = motion.members.iter().map(|&i| self.elements[i as usize].mass_kg).collect();
        let particles =
            ParticleMotion { mass_kg: &m, position_m: motion.position_m, velocity_m_s: motion.velocity_m_s };
        let fitted = fit(&particles, centre, inertia);
        let (p, l) = momenta(&particles);
        let body_p = fitted.linear_m_s * rest.mass_kg;
        let body_l = inertia * fitted.angular_rad_s + centre.cross(body_p);
        let body = PieceBody {
            mass: *rest,
            rotation,
            translation_m: translation,
            linear_m_s: fitted.linear_m_s,
            angular_rad_s: fitted.angular_rad_s,
            shape: self.geometry.piece_shape(motion.members, self.hull_volume_factor).shared_shape(),
            dust: motion.members.len() <= self.dust_max_elements as usize,
        };
        let energies_j = [fitted.particle_energy_j, fitted.rigid_part_j, fitted.body_energy_j];
        (body, Balance { particles: (p, l), body: (body_p, body_l), energies_j })
    }
}

/// A piece's momentum and angular momentum (about the origin) as particles and as a body, and
/// its kinetic energies: the particles', their best rigid motion's, the body's, J.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Balance {
    particles: (Vector, Vector),
    body: (Vector, Vector),
    energies_j: [f64; 3],
}

/// How well the bodies of `parts` keep their particles' momenta and energy, together.
pub(crate) fn conservation(parts: &[Balance]) -> Conservation {
    let (mut particle_p, mut particle_l, mut body_p, mut body_l) =
        (Vector::ZERO, Vector::ZERO, Vector::ZERO, Vector::ZERO);
    let mut energies_j = [0.0; 3];
    for part in parts {
        particle_p += part.particles.0;
        particle_l += part.particles.1;
        body_p += part.body.0;
        body_l += part.body.1;
        for (sum, energy) in energies_j.iter_mut().zip(part.energies_j) {
            *sum += energy;
        }
    }
    let relative = |a: Vector, b: Vector| if b.length() > 0.0 { (a - b).length() / b.length() } else { a.length() };
    Conservation {
        momentum_error: relative(body_p, particle_p),
        angular_momentum_error: relative(body_l, particle_l),
        particle_energy_j: energies_j[0],
        rigid_part_j: energies_j[1],
        body_energy_j: energies_j[2],
    }
}

/// The rigid world at the handoff: one body per fragment of `handoff` (posed as it says), with
/// the momenta of the particles in `points`; and how well they were kept.
pub fn hand_over(
    config: &PipelineConfig,
    rigid: &RigidConfig,
    particles: &ParticleSet,
    handoff: &FragmentFrame,
    points: &PointFrame,
) -> (RigidWorld, Conservation) {
    let maker = PieceMaker::new(particles, config.material.density_kg_m3, rigid);
    let pieces = handoff.fragment_count();
    let rest = piece_mass_props(&maker.elements, &handoff.fragment_of, pieces);
    let (position, velocity) = vectors(points);
    let members = members_of_pieces(&handoff.fragment_of, pieces);
    let mut bodies = Vec::with_capacity(pieces);
    let mut parts = Vec::with_capacity(pieces);
    for (piece, members) in members.iter().enumerate() {
        let x: Vec<Vector> = members.iter().map(|&i| position[i as usize]).collect();
        let v: Vec<Vector> = members.iter().map(|&i| velocity[i as usize]).collect();
        let motion = MemberMotion { members, position_m: &x, velocity_m_s: &v };
        let pose = (handoff.rotation[piece], handoff.translation_m[piece]);
        let (body, part) = maker.body(&rest[piece], pose, &motion);
        bodies.push(body);
        parts.push(part);
    }
    let spheres = kinematic_spheres(config, handoff.meta.time_s);
    let settings = world_settings(config, rigid, particles.meta.lambda_m);
    let floor = config.sim.floor.as_ref().map(|floor| floor.height_m);
    (RigidWorld::new(&settings, floor, &spheres, &bodies), conservation(&parts))
}
