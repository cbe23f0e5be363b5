//! Optional smoothing of sudden transform changes: the PD controller Levine et al. propose. Each
//! fragment's rendered centre of mass and rotation follow the measured ones like a critically
//! damped spring with time constant `tau` frames, so a fragment that jumps between frames (a
//! Kabsch fit of a fragment that just split, say) glides instead. Off by default.

use glam::{DQuat, DVec3};

/// The smoothed state of one fragment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmoothState {
    /// Smoothed centre of mass, metres.
    pub centre: DVec3,
    /// Its velocity, metres per frame.
    pub velocity: DVec3,
    /// Smoothed rotation.
    pub rotation: DQuat,
    /// Its angular velocity, radians per frame (axis times rate).
    pub spin: DVec3,
}

impl SmoothState {
    /// A state at rest on the target.
    pub fn at(centre: DVec3, rotation: DQuat) -> SmoothState {
        SmoothState { centre, velocity: DVec3::ZERO, rotation, spin: DVec3::ZERO }
    }

    /// The state of a part of this fragment whose centre, under the smoothed transform, is
    /// `centre`: same rotation and spin, the rigid-body velocity at that point.
    pub fn part_at(&self, centre: DVec3) -> SmoothState {
        SmoothState {
            centre,
            velocity: self.velocity + self.spin.cross(centre - self.centre),
            rotation: self.rotation,
            spin: self.spin,
        }
    }

    /// Advances one frame towards the target with time constant `tau_frames` (critically damped:
    /// a = w^2 (target - x) - 2 w v with w = 1 / tau), in substeps for stability.
    pub fn follow(&mut self, target_centre: DVec3, target_rotation: DQuat, tau_frames: f64) {
        let omega = 1.0 / tau_frames;
        let substeps = 8;
        let h = 1.0 / substeps as f64;
        for _ in 0..substeps {
            let pull = omega * omega * (target_centre - self.centre) - 2.0 * omega * self.velocity;
            self.velocity += h * pull;
            self.centre += h * self.velocity;
            let mut error = target_rotation * self.rotation.inverse();
            if error.w < 0.0 {
                error = -error;
            }
            let (axis, angle) = error.to_axis_angle();
            let twist = pull_of(axis * angle, self.spin, omega);
            self.spin += h * twist;
            let turn = self.spin * h;
            if turn.length() > 0.0 {
                self.rotation = (DQuat::from_scaled_axis(turn) * self.rotation).normalize();
            }
        }
    }
}

fn pull_of(error: DVec3, rate: DVec3, omega: f64) -> DVec3 {
    omega * omega * error - 2.0 * omega * rate
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_jump_is_smoothed_and_the_target_reached() {
        let mut state = SmoothState::at(DVec3::ZERO, DQuat::IDENTITY);
        let target = DVec3::new(1.0, 0.0, 0.0);
        let turn = DQuat::from_rotation_y(1.0);
        state.follow(target, turn, 2.0);
        assert!(state.centre.x > 0.05 && state.centre.x < 0.6, "first frame moves part way: {}", state.centre.x);
        for _ in 0..40 {
            state.follow(target, turn, 2.0);
        }
        assert!((state.centre - target).length() < 1e-3);
        assert!(state.rotation.dot(turn).abs() > 1.0 - 1e-6);
    }
}
