//! The shutter: how the pieces move while it is open (3D motion blur). Each camera ray carries a
//! time in the shutter interval, in frames from the frame's centre; the elements stay placed at
//! the centre, and a ray at another time is carried into the centre's placement of the elements
//! it tests by the inverse of their motion from the centre to its time ([`ToCentre`]). The twin
//! of `shaders/shutter.wgsl`.
//!
//! The elements move in groups: those with one fragment at the previous, this and the next
//! frame. A group's motion over the shutter interpolates its poses at those frames: its pivot
//! (the group's rest centroid) along the straight line between the frames' places, its rotation
//! about the pivot by the slerp between the frames' rotations. Between two frames that is, per
//! frame of time, a velocity and a rotation vector (axis times angle) in world space; the
//! half-interval before the frame's centre follows the previous frame's segment, the half after
//! it the next one's. A frame with no neighbour on one side takes the other side's segment.
//!
//! A group's pose at time `tau` (frames) is x = c(tau) + R(tau) q0 (X - P), with c(tau) = c0 +
//! tau v and R(tau) the rotation by the vector tau w: the slerp from the rotation q0 towards the
//! neighbour's q1 is (q1 q0^-1)^tau q0, and q1 q0^-1 is the rotation by w.

use std::collections::HashMap;

use bytemuck::{Pod, Zeroable};
use glam::{DQuat, DVec3};

use crate::element_kdtree::Aabb;
use crate::motion::{Motions, motion_of};

/// One group's motion: its centre at the frame's time and its two segments.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GroupMotion {
    /// The pivot at the frame's time, metres; w unused.
    pub centre_m: [f32; 4],
    /// Before the centre, then after it: the velocity (metres per frame) and the rotation vector
    /// (radians per frame, world axes), w unused.
    pub segments: [[[f32; 4]; 2]; 2],
}

/// The scene's motion over the shutter.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneMotion {
    /// The shutter's open time, frames.
    pub shutter: f32,
    /// The group of each element.
    pub group_of: Vec<u32>,
    /// Each group's motion.
    pub groups: Vec<GroupMotion>,
}

/// A frame's poses with its neighbours': `current` this frame's motions, `previous` and `next`
/// its neighbours' (None where the shot has no such frame), as [`crate::motion::motion_vectors`]
/// takes them.
#[derive(Debug, Clone, Copy)]
pub struct FramePoses<'a> {
    /// This frame's motions.
    pub current: Motions<'a>,
    /// The previous frame's, if any.
    pub previous: Option<Motions<'a>>,
    /// The next frame's, if any.
    pub next: Option<Motions<'a>>,
}

/// The fragment of `element` at a frame (0 at rest).
fn fragment_at(frame: Motions, element: usize) -> u32 {
    frame.map_or(0, |frame| frame.fragment_of[element])
}

/// The rotation vector (axis times angle, the shorter way) of the unit quaternion `q`.
fn rotation_vector(q: DQuat) -> DVec3 {
    let q = if q.w < 0.0 { -q } else { q };
    let (axis, angle) = q.to_axis_angle();
    if angle.is_finite() && angle > 0.0 { axis * angle } else { DVec3::ZERO }
}

/// The segment (velocity, rotation vector) from pose `from` to pose `to` of a group pivoting
/// about rest point `pivot`.
fn segment(pivot: DVec3, from: (DQuat, DVec3), to: (DQuat, DVec3)) -> [[f32; 4]; 2] {
    let velocity = (to.0 * pivot + to.1) - (from.0 * pivot + from.1);
    let rotation = rotation_vector(to.0 * from.0.inverse());
    let lane = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32, 0.0];
    [lane(velocity), lane(rotation)]
}

impl SceneMotion {
    /// The motion of `rest_position_m`'s elements over a shutter open `shutter` frames, posed by
    /// `poses`; None when the shutter is closed or nothing moves.
    pub fn new(rest_position_m: &[[f32; 3]], poses: FramePoses, shutter: f64) -> Option<SceneMotion> {
        if shutter <= 0.0 || (poses.previous.is_none() && poses.next.is_none()) {
            return None;
        }
        // groups in order of their first element
        let key = |e: usize| {
            let side = |frame: Option<Motions>| frame.map_or(u32::MAX, |frame| fragment_at(frame, e));
            (side(poses.previous), fragment_at(poses.current, e), side(poses.next))
        };
        let mut index: HashMap<(u32, u32, u32), u32> = HashMap::new();
        let mut first = Vec::new();
        let mut sums: Vec<(DVec3, f64)> = Vec::new();
        let group_of: Vec<u32> = (0..rest_position_m.len())
            .map(|e| {
                let g = *index.entry(key(e)).or_insert_with(|| {
                    first.push(e);
                    sums.push((DVec3::ZERO, 0.0));
                    (sums.len() - 1) as u32
                });
                let sum = &mut sums[g as usize];
                sum.0 += DVec3::from_array(rest_position_m[e].map(f64::from));
                sum.1 += 1.0;
                g
            })
            .collect();
        let groups: Vec<GroupMotion> =
            first.iter().zip(&sums).map(|(&e, &(sum, count))| group_motion(sum / count, e, poses)).collect();
        let still = |g: &GroupMotion| g.segments.iter().flatten().all(|lane| lane.iter().all(|v| *v == 0.0));
        if groups.iter().all(still) {
            return None;
        }
        Some(SceneMotion { shutter: shutter as f32, group_of, groups })
    }

    /// Element `e`'s box `bounds` at the frame's centre widened to hold the element at every
    /// time of the shutter, and by `margin_m` more (the rounding of the rays' maps).
    pub fn swept(&self, e: usize, bounds: Aabb, margin_m: f32) -> Aabb {
        let group = &self.groups[self.group_of[e] as usize];
        let half = 0.5 * self.shutter;
        let centre = [0, 1, 2].map(|a| group.centre_m[a]);
        // the farthest corner from the pivot bounds how far a turn moves any point
        let reach = (0..8)
            .map(|corner| {
                let p: [f32; 3] =
                    std::array::from_fn(|a| if corner >> a & 1 == 1 { bounds.max[a] } else { bounds.min[a] });
                length(std::array::from_fn(|a| p[a] - centre[a]))
            })
            .fold(0.0f32, f32::max);
        let mut swept = bounds;
        let mut turn = 0.0f32;
        for (segment, sign) in group.segments.iter().zip([-1.0f32, 1.0]) {
            let shift: [f32; 3] = std::array::from_fn(|a| sign * half * segment[0][a]);
            let moved = Aabb {
                min: [0, 1, 2].map(|a| bounds.min[a] + shift[a]),
                max: [0, 1, 2].map(|a| bounds.max[a] + shift[a]),
            };
            swept = swept.union(&moved);
            turn = turn.max(half * length([segment[1][0], segment[1][1], segment[1][2]]));
        }
        let grow = turn * reach + margin_m;
        Aabb { min: swept.min.map(|v| v - grow), max: swept.max.map(|v| v + grow) }
    }

    /// The map of a ray at `time` (frames from the centre) into the centre's placement of
    /// element `e`'s group; None for the identity (the centre's time, or a group at rest).
    pub fn to_centre(&self, e: usize, time: f32) -> Option<ToCentre> {
        self.group_to_centre(self.group_of[e], time)
    }

    /// [`SceneMotion::to_centre`] for the elements of group `group`.
    pub fn group_to_centre(&self, group: u32, time: f32) -> Option<ToCentre> {
        ToCentre::of(&self.groups[group as usize], time)
    }
}

/// A group's pose from this frame's and its neighbours' motions, pivoting about rest point
/// `pivot` (its elements' centroid), read from its first element `e`.
fn group_motion(pivot: DVec3, e: usize, poses: FramePoses) -> GroupMotion {
    let now = motion_of(poses.current, e);
    let before = poses.previous.map(|frame| segment(pivot, motion_of(frame, e), now));
    let after = poses.next.map(|frame| segment(pivot, now, motion_of(frame, e)));
    let zero = [[0.0; 4]; 2];
    let (before, after) = match (before, after) {
        (Some(b), Some(a)) => (b, a),
        (Some(b), None) => (b, b),
        (None, Some(a)) => (a, a),
        (None, None) => (zero, zero),
    };
    let centre = now.0 * pivot + now.1;
    GroupMotion { centre_m: [centre.x as f32, centre.y as f32, centre.z as f32, 0.0], segments: [before, after] }
}

fn length(v: [f32; 3]) -> f32 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// A rigid map from a ray's time to the frame's centre: x -> R (x - pivot_at_time) +
/// pivot_at_centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToCentre {
    /// The rotation, rows.
    rows: [[f32; 3]; 3],
    /// The pivot at the ray's time.
    pivot_at_time: [f32; 3],
    /// The pivot at the centre.
    pivot_at_centre: [f32; 3],
}

impl ToCentre {
    /// The map of `group` at `time` (frames from the centre); None for the identity.
    pub fn of(group: &GroupMotion, time: f32) -> Option<ToCentre> {
        if time == 0.0 {
            return None;
        }
        let [velocity, rotation] = group.segments[usize::from(time > 0.0)];
        if velocity[..3].iter().chain(&rotation[..3]).all(|v| *v == 0.0) {
            return None;
        }
        let pivot_at_centre = [group.centre_m[0], group.centre_m[1], group.centre_m[2]];
        let pivot_at_time = std::array::from_fn(|a| pivot_at_centre[a] + time * velocity[a]);
        // back from the ray's time: the rotation by -time w (Rodrigues)
        let phi: [f32; 3] = std::array::from_fn(|a| -time * rotation[a]);
        Some(ToCentre { rows: rotation_rows(phi), pivot_at_time, pivot_at_centre })
    }

    /// A point at the ray's time, placed at the centre.
    pub fn point(&self, p: [f32; 3]) -> [f32; 3] {
        let d = std::array::from_fn(|a| p[a] - self.pivot_at_time[a]);
        let r = self.vector(d);
        std::array::from_fn(|a| r[a] + self.pivot_at_centre[a])
    }

    /// A direction at the ray's time, turned to the centre.
    pub fn vector(&self, d: [f32; 3]) -> [f32; 3] {
        self.rows.map(|row| row[0] * d[0] + row[1] * d[1] + row[2] * d[2])
    }

    /// A direction at the centre (a normal found there), turned back to the ray's time.
    pub fn vector_back(&self, n: [f32; 3]) -> [f32; 3] {
        let r = &self.rows;
        std::array::from_fn(|a| r[0][a] * n[0] + r[1][a] * n[1] + r[2][a] * n[2])
    }
}

/// The rows of the rotation by the vector `phi` (axis times angle).
fn rotation_rows(phi: [f32; 3]) -> [[f32; 3]; 3] {
    let angle = length(phi);
    if angle == 0.0 {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    let k = phi.map(|v| v / angle);
    let (s, c) = (angle.sin(), angle.cos());
    let t = 1.0 - c;
    [
        [c + t * k[0] * k[0], t * k[0] * k[1] - s * k[2], t * k[0] * k[2] + s * k[1]],
        [t * k[1] * k[0] + s * k[2], c + t * k[1] * k[1], t * k[1] * k[2] - s * k[0]],
        [t * k[2] * k[0] - s * k[1], t * k[2] * k[1] + s * k[0], c + t * k[2] * k[2]],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use shatter_core::fragments::{FragmentFrame, FragmentMeta};

    fn frame(q: DQuat, t: [f64; 3]) -> FragmentFrame {
        FragmentFrame {
            meta: FragmentMeta { frame: 2, step: 0, time_s: 0.0, smoothed: false, inputs: None },
            fragment_of: vec![0, 0],
            rotation: vec![q.as_quat().to_array()],
            translation_m: vec![t],
            elements: vec![2],
            mass_kg: vec![1.0],
            element_affine: None,
        }
    }

    fn place(f: &FragmentFrame, p: [f32; 3]) -> [f32; 3] {
        let (q, t) = motion_of(Some(f), 0);
        (q * DVec3::from_array(p.map(f64::from)) + t).as_vec3().to_array()
    }

    #[test]
    fn a_ray_at_a_neighbours_time_is_carried_onto_the_centre_placement() {
        let rest = [[0.3f32, 0.1, 0.0], [0.5, -0.1, 0.2]];
        let before = frame(DQuat::from_rotation_y(-0.4), [0.1, 0.5, 0.0]);
        let now = frame(DQuat::from_rotation_y(0.1), [0.2, 0.4, 0.1]);
        let after = frame(DQuat::from_axis_angle(DVec3::new(1.0, 1.0, 0.0).normalize(), 0.7), [0.5, 0.2, 0.1]);
        let poses = FramePoses { current: Some(&now), previous: Some(Some(&before)), next: Some(Some(&after)) };
        let motion = SceneMotion::new(&rest, poses, 1.0).expect("moving");
        assert_eq!(motion.group_of, vec![0, 0]);
        // one frame back and one forward: each neighbour's placement of a point maps onto the centre's
        for (time, neighbour) in [(-1.0f32, &before), (1.0, &after)] {
            let map = motion.to_centre(0, time).expect("moves");
            for p in [rest[0], [0.0, 0.0, 0.0], [-0.2, 0.3, 0.1]] {
                let (there, here) = (place(neighbour, p), place(&now, p));
                let mapped = map.point(there);
                assert!((0..3).all(|a| (mapped[a] - here[a]).abs() < 1e-5), "{time}: {mapped:?} vs {here:?}");
            }
            let n = map.vector_back(map.vector([0.6, 0.0, 0.8]));
            assert!((n[0] - 0.6).abs() < 1e-6 && (n[2] - 0.8).abs() < 1e-6);
        }
        assert!(motion.to_centre(0, 0.0).is_none(), "the centre's time is the identity");
        // the swept box holds the element at every time of the shutter
        let b = Aabb { min: [0.15, 0.35, 0.05], max: [0.35, 0.55, 0.25] };
        let swept = motion.swept(0, b, 0.0);
        for k in 0..=20 {
            let time = -0.5 + k as f32 / 20.0;
            let back = ToCentre::of(&motion.groups[0], time);
            for c in 0..8 {
                let corner: [f32; 3] = std::array::from_fn(|a| if c >> a & 1 == 1 { b.max[a] } else { b.min[a] });
                // the centre's corner at this time: the inverse of the map, found by its rows
                let p = match back {
                    Some(map) => {
                        let d: [f32; 3] = std::array::from_fn(|a| corner[a] - map.pivot_at_centre[a]);
                        let r = map.vector_back(d);
                        std::array::from_fn(|a| r[a] + map.pivot_at_time[a])
                    }
                    None => corner,
                };
                assert!((0..3).all(|a| p[a] >= swept.min[a] - 1e-6 && p[a] <= swept.max[a] + 1e-6), "{time}: {p:?}");
            }
        }
    }

    #[test]
    fn a_closed_shutter_or_a_still_scene_has_no_motion() {
        let rest = [[0.0f32; 3]];
        let f = frame(DQuat::IDENTITY, [0.0; 3]);
        let moved = frame(DQuat::IDENTITY, [0.1, 0.0, 0.0]);
        let poses = FramePoses { current: Some(&f), previous: Some(Some(&f)), next: Some(Some(&moved)) };
        assert!(SceneMotion::new(&rest, poses, 0.0).is_none());
        assert!(SceneMotion::new(&rest, FramePoses { next: Some(Some(&f)), ..poses }, 0.5).is_none());
        // the last frame of a shot takes the segment before it
        let last =
            SceneMotion::new(&rest, FramePoses { current: Some(&moved), previous: Some(Some(&f)), next: None }, 0.5)
                .expect("moving");
        assert_eq!(last.groups[0].segments[0], last.groups[0].segments[1]);
    }
}
