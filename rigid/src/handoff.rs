//! When the fracture has quieted: the handoff rule.
//!
//! The handoff frame is the first frame f at which either
//! - the cracks have stopped and the pieces move as rigid bodies: some bond broke, none broke
//!   in the last `handoff_quiet_frames` frames, and in every piece of two or more particles
//!   the kinetic energy of the motion that is not rigid is at most
//!   `handoff_internal_energy_ratio` times the rigid motion's (or its rms speed is below
//!   `handoff_rest_speed_m_s`); or
//! - `max_fracture_duration_s` of simulated time has passed since frame 1;
//!
//! and the last simulated frame when neither happens first.

use rapier3d_f64::math::Vector;
use shatter_core::config::RigidConfig;

use crate::velocity_fit::{ParticleMotion, fit};

/// Whether the cracks have stopped at frame `frame` (1-based): a bond broke at some frame up
/// to `frame - quiet_frames`, and none after it up to `frame`.
pub fn cracks_stopped(breaks_per_frame: &[u64], frame: u32, quiet_frames: u32) -> bool {
    let frame = frame as usize;
    if frame == 0 || frame > breaks_per_frame.len() || (quiet_frames as usize) >= frame {
        return false;
    }
    let quiet_from = frame - quiet_frames as usize; // frames quiet_from+1 ..= frame must be quiet
    let broke_before = breaks_per_frame[..quiet_from].iter().any(|&b| b > 0);
    broke_before && breaks_per_frame[quiet_from..frame].iter().all(|&b| b == 0)
}

/// Whether every piece of two or more particles moves rigidly enough (see the module docs).
/// `piece_of` gives each particle's piece; `mass_kg`, `position_m` and `velocity_m_s` are per
/// particle.
pub fn pieces_calm(
    config: &RigidConfig,
    piece_of: &[u32],
    pieces: usize,
    mass_kg: &[f64],
    position_m: &[Vector],
    velocity_m_s: &[Vector],
) -> bool {
    for members in members_of_pieces(piece_of, pieces) {
        if members.len() < 2 {
            continue;
        }
        let mass: Vec<f64> = members.iter().map(|&i| mass_kg[i as usize]).collect();
        let position: Vec<Vector> = members.iter().map(|&i| position_m[i as usize]).collect();
        let velocity: Vec<Vector> = members.iter().map(|&i| velocity_m_s[i as usize]).collect();
        let motion = ParticleMotion { mass_kg: &mass, position_m: &position, velocity_m_s: &velocity };
        let total: f64 = mass.iter().sum();
        let centre = position.iter().zip(&mass).fold(Vector::ZERO, |c, (x, m)| c + *x * *m) / total;
        let fitted = fit(&motion, centre, rapier3d_f64::math::Matrix::ZERO);
        let internal = fitted.internal_energy_j();
        let resting = internal <= 0.5 * total * config.handoff_rest_speed_m_s.powi(2);
        if !(resting || internal <= config.handoff_internal_energy_ratio * fitted.rigid_part_j) {
            return false;
        }
    }
    true
}

/// The particles of each piece, in particle order.
pub fn members_of_pieces(piece_of: &[u32], pieces: usize) -> Vec<Vec<u32>> {
    let mut members = vec![Vec::new(); pieces];
    for (particle, &piece) in piece_of.iter().enumerate() {
        members[piece as usize].push(particle as u32);
    }
    members
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cracks_stop_after_some_broke_and_then_none_for_the_quiet_frames() {
        let breaks = [0, 0, 5, 2, 0, 0, 0, 1, 0, 0, 0, 0];
        let stopped: Vec<u32> = (1..=12).filter(|&f| cracks_stopped(&breaks, f, 3)).collect();
        assert_eq!(stopped, vec![7, 11, 12]);
        assert!(!cracks_stopped(&[0, 0, 0, 0, 0], 5, 2), "nothing broke yet: a falling body is not quiet");
        assert!(cracks_stopped(&[0, 3], 2, 0), "no quiet frames asked: the cracks stop at once");
    }

    #[test]
    fn ringing_pieces_are_not_calm_and_rigid_ones_are() {
        let config = RigidConfig::default();
        let position = [Vector::ZERO, Vector::X * 0.01, Vector::Y * 0.01, Vector::Z * 0.01];
        let mass = [1e-3; 4];
        let rigid: Vec<Vector> =
            position.iter().map(|x| Vector::new(1.0, 0.0, 0.0) + Vector::Z.cross(*x) * 30.0).collect();
        assert!(pieces_calm(&config, &[0; 4], 1, &mass, &position, &rigid));
        let mut ringing = rigid.clone();
        ringing[0] += Vector::Y * 0.8;
        ringing[1] -= Vector::Y * 0.8;
        assert!(!pieces_calm(&config, &[0; 4], 1, &mass, &position, &ringing));
        assert!(
            pieces_calm(&config, &[0, 1, 2, 3], 4, &mass, &position, &ringing),
            "single particles are never ringing"
        );
    }
}
