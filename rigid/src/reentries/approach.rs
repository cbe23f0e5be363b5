//! Where a re-entry starts: the pieces flown freely from the step before their hard contact to
//! just short of it, so the simulation does not spend a rigid step's flight closing the gap. A
//! piece bound for the floor stops with its lowest particle a tenth of a spacing above it; two
//! pieces that meet stop with their nearest particles a tenth of a spacing beyond the contact
//! distance, where the simulation's contact force starts.

use std::collections::HashMap;

use rapier3d_f64::math::{Rotation, Vector};
use shatter_core::ParticleSet;

/// A rigid body's pose and motion.
#[derive(Debug, Clone, Copy)]
pub(super) struct BodyState {
    pub(super) rotation: Rotation,
    pub(super) translation: Vector,
    pub(super) centre: Vector,
    pub(super) linear: Vector,
    pub(super) angular: Vector,
}

impl BodyState {
    /// The body after `time_s` of free flight under `gravity` (m/s^2), turning at its angular
    /// velocity.
    pub(super) fn after(&self, time_s: f64, gravity: Vector) -> BodyState {
        let centre = self.centre + self.linear * time_s + gravity * (0.5 * time_s * time_s);
        let turn = Rotation::from_scaled_axis(self.angular * time_s);
        let rotation = (turn * self.rotation).normalize();
        // the centre of mass is fixed in the body: x = R X + t
        let rest_centre = self.rotation.inverse() * (self.centre - self.translation);
        BodyState {
            rotation,
            translation: centre - rotation * rest_centre,
            centre,
            linear: self.linear + gravity * time_s,
            angular: self.angular,
        }
    }

    /// Where the particles `members` are in this pose, each at `shape_m` in the rest frame.
    fn positions(&self, shape_m: &[[f32; 3]], members: &[u32]) -> Vec<Vector> {
        members
            .iter()
            .map(|&i| self.rotation * Vector::from_array(shape_m[i as usize].map(f64::from)) + self.translation)
            .collect()
    }
}

/// The pieces of a re-entry in flight: their particles and their bodies before the contact.
pub(super) struct Approach<'a> {
    pub(super) particles: &'a ParticleSet,
    /// Each particle's place in its piece's rest frame: its rest position, or where an
    /// elastoplastic piece was deformed for good.
    pub(super) shape_m: &'a [[f32; 3]],
    /// Each piece's particles.
    pub(super) members: &'a [Vec<u32>],
    /// Each piece's body.
    pub(super) bodies: &'a [BodyState],
    pub(super) gravity: Vector,
    /// The longest rigid step, seconds: the contact lies within one.
    pub(super) max_step_s: f64,
}

impl Approach<'_> {
    /// How long the only piece flies freely before its lowest particle is a tenth of a spacing
    /// above the floor at `floor_height_m` (0 when it is there already), seconds.
    pub(super) fn to_floor_s(&self, floor_height_m: f64) -> f64 {
        let target_m = floor_height_m + 0.1 * self.particles.meta.lambda_m;
        let lowest = |time_s: f64| {
            let at = self.bodies[0].after(time_s, self.gravity);
            at.positions(self.shape_m, &self.members[0]).iter().map(|x| x.y).fold(f64::INFINITY, f64::min)
        };
        self.last_before(|time_s| lowest(time_s) <= target_m)
    }

    /// How long two pieces fly freely before any two of their particles come within the
    /// contact distance `contact_m` and a tenth of a spacing, seconds (0 when never within a
    /// second). Negative when they are that close already (a rigid step can carry a fast piece
    /// more than a spacing): their flight is followed back to where they were not yet.
    pub(super) fn to_each_other_s(&self, contact_m: f64) -> f64 {
        let reach_m = contact_m + 0.1 * self.particles.meta.lambda_m;
        let close = |time_s: f64| {
            let [a, b] = [0, 1].map(|k| self.bodies[k].after(time_s, self.gravity));
            within(&a.positions(self.shape_m, &self.members[0]), &b.positions(self.shape_m, &self.members[1]), reach_m)
        };
        let direction = if close(0.0) { -1.0 } else { 1.0 };
        self.last_apart(|time_s| !close(time_s), direction)
    }

    /// The latest time before `reached` first holds, seconds (0 when it holds at once or not
    /// within a second).
    fn last_before(&self, reached: impl Fn(f64) -> bool) -> f64 {
        if reached(0.0) {
            return 0.0;
        }
        self.last_apart(|time_s| !reached(time_s), 1.0)
    }

    /// Going from 0 in `direction` (1 ahead, -1 back) until `apart` changes from what it is at
    /// 0 (doubling from the longest step, then bisecting), the latest time at which it holds
    /// next to that change, seconds; 0 when it does not change within a second.
    fn last_apart(&self, apart: impl Fn(f64) -> bool, direction: f64) -> f64 {
        let at_start = apart(0.0);
        let mut far_s = direction * self.max_step_s;
        while apart(far_s) == at_start {
            far_s *= 2.0;
            if far_s.abs() > 1.0 {
                return 0.0;
            }
        }
        let (mut near_s, mut changed_s) = (0.0, far_s);
        for _ in 0..48 {
            let mid_s = 0.5 * (near_s + changed_s);
            if apart(mid_s) == at_start { near_s = mid_s } else { changed_s = mid_s }
        }
        if at_start { near_s } else { changed_s }
    }
}

/// Whether a point of `a` lies within `reach_m` of a point of `b`: `b` binned in cells of that
/// size, each point of `a` tested against its cell's 27 neighbours.
fn within(a: &[Vector], b: &[Vector], reach_m: f64) -> bool {
    let cell = |x: Vector| [x.x, x.y, x.z].map(|c| (c / reach_m).floor() as i64);
    let mut cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (k, &x) in b.iter().enumerate() {
        cells.entry(cell(x)).or_default().push(k);
    }
    a.iter().any(|&x| {
        let [i, j, k] = cell(x);
        (-1..=1).any(|di| {
            (-1..=1).any(|dj| {
                (-1..=1).any(|dk| {
                    cells
                        .get(&[i + di, j + dj, k + dk])
                        .is_some_and(|near| near.iter().any(|&n| (b[n] - x).length() <= reach_m))
                })
            })
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_flight_follows_the_parabola_and_turns_about_the_centre_of_mass() {
        let rotation = Rotation::from_rotation_y(0.3);
        let rest_centre = Vector::new(0.01, 0.02, -0.03);
        let translation = Vector::new(0.5, 1.0, 0.0);
        let body = BodyState {
            rotation,
            translation,
            centre: rotation * rest_centre + translation,
            linear: Vector::new(1.0, 2.0, 0.0),
            angular: Vector::new(0.0, 0.0, 4.0),
        };
        let gravity = Vector::new(0.0, -9.81, 0.0);
        let later = body.after(0.1, gravity);
        let expected = body.centre + Vector::new(0.1, 0.2 - 0.5 * 9.81 * 0.01, 0.0);
        assert!((later.centre - expected).length() < 1e-12);
        assert!((later.linear - Vector::new(1.0, 2.0 - 0.981, 0.0)).length() < 1e-12);
        // the rest centre still maps to the centre of mass, and the turn is 0.4 rad about z
        assert!((later.rotation * rest_centre + later.translation - later.centre).length() < 1e-12);
        assert!((rotation.angle_between(later.rotation) - 0.4).abs() < 1e-9);
    }

    #[test]
    fn points_within_reach_are_found_across_cells_and_farther_ones_are_not() {
        let a = [Vector::new(0.0, 0.0, 0.0), Vector::new(5.0, 5.0, 5.0)];
        // 0.99 apart across a cell boundary on every axis
        let near = [Vector::new(-0.5716, -0.5716, -0.5716)];
        assert!(within(&a, &near, 1.0));
        let far = [Vector::new(-0.58, -0.58, -0.58), Vector::new(3.0, 3.0, 3.0)];
        assert!(!within(&a, &far, 1.0));
    }
}
