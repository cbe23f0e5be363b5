//! The motion pass: per pixel, where the surface seen through the pixel centre was one playback
//! frame before and will be one frame after, from its fragment's rigid motions, in pixels.
//!
//! Convention (Blender's Vector pass, which Cycles writes and Blender's Vector Blur node reads):
//! X, Y is the motion from the previous frame to this one (this position minus the previous),
//! Z, W from this frame to the next (next minus this), in pixels with y up. Nuke's VectorBlur
//! takes the forward motion Z, W as its `forward.u`, `forward.v` (and -X, -Y as `backward`).
//! The floor, the background and frames with no neighbour on a side hold zero.

use glam::{DQuat, DVec3};
use rayon::prelude::*;
use shatter_core::fragments::FragmentFrame;

use crate::camera::Camera;
use crate::hit_search::NONE;
use crate::integrator::Pixel;

/// A frame's rigid motions: None is the rest state.
pub type Motions<'a> = Option<&'a FragmentFrame>;

/// Element `element`'s rigid motion (rotation, translation) at a frame.
pub(crate) fn motion_of(frame: Motions, element: usize) -> (DQuat, DVec3) {
    match frame {
        Some(frame) => {
            let f = frame.fragment_of[element] as usize;
            (DQuat::from_array(frame.rotation[f].map(f64::from)).normalize(), DVec3::from_array(frame.translation_m[f]))
        }
        None => (DQuat::IDENTITY, DVec3::ZERO),
    }
}

/// The motion pass of `pixels` (this frame's, traced through `camera`): `current` holds this
/// frame's motions, `previous` and `next` its neighbours' (each `None` for the rest state, and
/// the outer `None` where there is no such frame).
pub fn motion_vectors(
    camera: &Camera,
    pixels: &[Pixel],
    current: Motions,
    previous: Option<Motions>,
    next: Option<Motions>,
) -> Vec<[f32; 4]> {
    let width = camera.width as usize;
    let eye = DVec3::from_array(camera.origin.map(f64::from));
    pixels
        .par_iter()
        .enumerate()
        .map(|(index, pixel)| {
            if pixel.element == NONE || !pixel.depth.is_finite() {
                return [0.0; 4];
            }
            let (x, y) = ((index % width) as f32 + 0.5, (index / width) as f32 + 0.5);
            let direction = DVec3::from_array(camera.direction(x, y).map(f64::from));
            let seen = eye + direction * f64::from(pixel.depth);
            let element = pixel.element as usize;
            let (rotation, translation) = motion_of(current, element);
            let rest = rotation.inverse() * (seen - translation);
            let here = [f64::from(x), f64::from(y)];
            // (from - to) in pixels, y up
            let shift = |frame: Option<Motions>, sign: f64| -> [f32; 2] {
                let Some(frame) = frame else { return [0.0; 2] };
                let (q, t) = motion_of(frame, element);
                match camera.pixel_of(q * rest + t) {
                    Some(there) => [(sign * (here[0] - there[0])) as f32, (sign * (there[1] - here[1])) as f32],
                    None => [0.0; 2],
                }
            };
            let [bx, by] = shift(previous, 1.0);
            let [fx, fy] = shift(next, -1.0);
            [bx, by, fx, fy]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::Pixel;
    use shatter_core::fragments::FragmentMeta;

    fn frame(translation: [f64; 3]) -> FragmentFrame {
        FragmentFrame {
            meta: FragmentMeta { frame: 1, step: 0, time_s: 0.0, smoothed: false, inputs: None },
            fragment_of: vec![0],
            rotation: vec![[0.0, 0.0, 0.0, 1.0]],
            translation_m: vec![translation],
            elements: vec![1],
            mass_kg: vec![1.0],
            element_affine: None,
        }
    }

    #[test]
    fn a_translating_fragment_moves_by_its_projected_motion() {
        let camera = Camera::look_at(DVec3::new(0.0, 0.0, 2.0), DVec3::ZERO, DVec3::Y, 40.0, 64, 48);
        let (before, now, after) = (frame([-0.1, 0.0, 0.0]), frame([0.0; 3]), frame([0.1, 0.05, 0.0]));
        // the pixel at (10, 20) sees a point of the element 2 m away along its ray
        let d = DVec3::from_array(camera.direction(10.5, 20.5).map(f64::from));
        let depth = 1.9;
        let mut pixels = vec![Pixel::EMPTY; 64 * 48];
        pixels[20 * 64 + 10] = Pixel { element: 0, depth: depth as f32, ..Pixel::EMPTY };
        let vectors = motion_vectors(&camera, &pixels, Some(&now), Some(Some(&before)), Some(Some(&after)));
        let p = DVec3::new(0.0, 0.0, 2.0) + d * depth;
        let at = |shift: DVec3| camera.pixel_of(p + shift).expect("in front");
        let (prev, next) = (at(DVec3::new(-0.1, 0.0, 0.0)), at(DVec3::new(0.1, 0.05, 0.0)));
        let v = vectors[20 * 64 + 10];
        assert!((f64::from(v[0]) - (10.5 - prev[0])).abs() < 1e-3);
        assert!((f64::from(v[1]) - (prev[1] - 20.5)).abs() < 1e-3);
        assert!((f64::from(v[2]) - (next[0] - 10.5)).abs() < 1e-3);
        assert!((f64::from(v[3]) - (20.5 - next[1])).abs() < 1e-3);
        assert!(v[0] > 0.0 && v[2] > 0.0 && v[3] > 0.0, "moving right and up: {v:?}");
        assert_eq!(vectors[0], [0.0; 4]);
        let edges = motion_vectors(&camera, &pixels, Some(&now), None, None);
        assert_eq!(edges[20 * 64 + 10], [0.0; 4]);
    }
}
