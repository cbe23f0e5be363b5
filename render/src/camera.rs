//! The camera: a pinhole's rays through image points, or a thin lens's (depth of field), where
//! world points land on the image, and OpenEXR's camera matrices. The twin of
//! `shaders/camera.wgsl`.

use glam::{DQuat, DVec3};

use crate::element_kdtree::Aabb;

/// A thin lens: its aperture and the plane it focuses on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lens {
    /// Radius of the aperture, metres.
    pub radius_m: f32,
    /// Distance of the plane in focus along the view, metres.
    pub focus_distance_m: f32,
}

impl Lens {
    /// The thin lens of f-number `f_stop` focused at `focus_distance_m`, on a camera whose
    /// vertical field of view `fov_deg` spans a sensor `sensor_height_mm` high: the sensor sits
    /// where the focused plane images (v = h / (2 tan(fov / 2))), so the focal length is
    /// 1 / (1 / v + 1 / s) and the aperture's diameter the focal length over the f-number.
    pub fn of(f_stop: f64, focus_distance_m: f64, fov_deg: f64, sensor_height_mm: f64) -> Lens {
        let focal_length_m = Lens::focal_length_m(focus_distance_m, fov_deg, sensor_height_mm);
        Lens { radius_m: (0.5 * focal_length_m / f_stop) as f32, focus_distance_m: focus_distance_m as f32 }
    }

    /// The focal length, metres, of [`Lens::of`]'s lens.
    pub fn focal_length_m(focus_distance_m: f64, fov_deg: f64, sensor_height_mm: f64) -> f64 {
        let image_distance_m = 0.5e-3 * sensor_height_mm / (0.5 * fov_deg.to_radians()).tan();
        1.0 / (1.0 / image_distance_m + 1.0 / focus_distance_m)
    }
}

/// A point of the unit disk for (u, v) in [0, 1)^2, by Shirley and Chiu's concentric map (equal
/// areas to equal areas, so stratified samples stay stratified).
pub fn concentric_disk(u: f32, v: f32) -> [f32; 2] {
    let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let quarter = std::f32::consts::FRAC_PI_4;
    let (r, theta) = if a.abs() > b.abs() { (a, quarter * (b / a)) } else { (b, 2.0 * quarter - quarter * (a / b)) };
    [r * theta.cos(), r * theta.sin()]
}

/// A camera: a pinhole, or a thin lens about the pinhole's eye.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub origin: [f32; 3],
    /// Unit view direction.
    pub forward: [f32; 3],
    /// Unit right vector, scaled by tan(fov / 2) times the aspect ratio.
    pub right: [f32; 3],
    /// Unit up vector, scaled by tan(fov / 2).
    pub up: [f32; 3],
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The thin lens, or None for a pinhole.
    pub lens: Option<Lens>,
}

impl Camera {
    /// A camera at `eye` looking at `target` with vertical field of view `fov_deg`.
    pub fn look_at(eye: DVec3, target: DVec3, up: DVec3, fov_deg: f64, width: u32, height: u32) -> Camera {
        let forward = (target - eye).normalize();
        let mut right = forward.cross(up);
        if right.length() < 1e-9 {
            right = forward.any_orthonormal_vector();
        }
        let right = right.normalize();
        let true_up = right.cross(forward);
        let tan = (fov_deg.to_radians() * 0.5).tan();
        let aspect = f64::from(width) / f64::from(height);
        Camera {
            origin: eye.as_vec3().to_array(),
            forward: forward.as_vec3().to_array(),
            right: (right * tan * aspect).as_vec3().to_array(),
            up: (true_up * tan).as_vec3().to_array(),
            width,
            height,
            lens: None,
        }
    }

    /// A camera framing `bounds` from the front (+Z) and a little above, looking at their centre.
    pub fn framing(bounds: &Aabb, fov_deg: f64, width: u32, height: u32) -> Camera {
        let lo = DVec3::from_array(bounds.min.map(f64::from));
        let hi = DVec3::from_array(bounds.max.map(f64::from));
        let centre = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(1e-6);
        let distance = radius / (fov_deg.to_radians() * 0.5).sin() * 1.1;
        let direction = DQuat::from_rotation_x(-0.3) * DVec3::Z;
        Camera::look_at(centre + direction * distance, centre, DVec3::Y, fov_deg, width, height)
    }

    /// OpenEXR's `worldToCamera`: world points to the camera's left-handed space (x right, y up,
    /// z along the view, the origin at the eye), as an Imath row-vector matrix (p' = p M, the
    /// translation in the last row), row-major.
    pub fn world_to_camera(&self) -> [f32; 16] {
        let unit = |v: [f32; 3]| DVec3::from_array(v.map(f64::from)).normalize();
        let (right, up, forward) = (unit(self.right), unit(self.up), unit(self.forward));
        let eye = DVec3::from_array(self.origin.map(f64::from));
        let m = [
            [right.x, up.x, forward.x, 0.0],
            [right.y, up.y, forward.y, 0.0],
            [right.z, up.z, forward.z, 0.0],
            [-right.dot(eye), -up.dot(eye), -forward.dot(eye), 1.0],
        ];
        m.concat().iter().map(|v| *v as f32).collect::<Vec<f32>>().try_into().unwrap_or([0.0; 16])
    }

    /// OpenEXR's `worldToNDC`: world points to the image plane, (0, 0) the display window's upper
    /// left corner and (1, 1) its lower right, x right and y down, after the division by the
    /// last component (p' = p M; NDC = (p'x / p'w, p'y / p'w)). NDC times the image size is the
    /// pixel position, pixel (i, j) covering [i, i + 1) x [j, j + 1).
    pub fn world_to_ndc(&self) -> [f32; 16] {
        let length = |v: [f32; 3]| DVec3::from_array(v.map(f64::from)).length();
        // the camera-space point (x, y, z) lands at sx = x / (z |right|), sy = y / (z |up|) in
        // [-1, 1] (y up), so NDC = ((sx + 1) / 2, (1 - sy) / 2)
        let (a, b) = (0.5 / length(self.right), 0.5 / length(self.up));
        let projection = [[a, 0.0, 0.0, 0.0], [0.0, -b, 0.0, 0.0], [0.5, 0.5, 1.0, 1.0], [0.0, 0.0, 0.0, 0.0]];
        let camera = self.world_to_camera().map(f64::from);
        let mut m = [0.0f32; 16];
        for row in 0..4 {
            for column in 0..4 {
                m[4 * row + column] = (0..4).map(|k| camera[4 * row + k] * projection[k][column]).sum::<f64>() as f32;
            }
        }
        m
    }

    /// Where world point `p` lands on the image, in pixels (x right, y down, as
    /// [`Camera::direction`] takes them); None behind the eye.
    pub fn pixel_of(&self, p: DVec3) -> Option<[f64; 2]> {
        let v = |a: [f32; 3]| DVec3::from_array(a.map(f64::from));
        let (forward, right, up) = (v(self.forward), v(self.right), v(self.up));
        let d = p - v(self.origin);
        let z = d.dot(forward);
        if z <= 0.0 {
            return None;
        }
        let sx = d.dot(right) / (z * right.length_squared());
        let sy = d.dot(up) / (z * up.length_squared());
        Some([(sx + 1.0) * 0.5 * f64::from(self.width), (1.0 - sy) * 0.5 * f64::from(self.height)])
    }

    /// The ray through image point (px, py) in pixels (y down) from the point of the lens that
    /// `disk` (in the unit disk, see [`concentric_disk`]) names: (origin, unit direction). The
    /// ray meets the pinhole's ray through the same image point on the plane in focus; a
    /// pinhole's is that ray itself.
    pub fn lens_ray(&self, px: f32, py: f32, disk: [f32; 2]) -> ([f32; 3], [f32; 3]) {
        let pinhole = self.direction(px, py);
        let Some(lens) = self.lens else { return (self.origin, pinhole) };
        let unit = |v: [f32; 3]| {
            let length = crate::primitives::dot(v, v).sqrt();
            v.map(|c| c / length)
        };
        let (right, up) = (unit(self.right), unit(self.up));
        let along = crate::primitives::dot(pinhole, self.forward);
        let focus: [f32; 3] = std::array::from_fn(|k| self.origin[k] + pinhole[k] * (lens.focus_distance_m / along));
        let origin: [f32; 3] =
            std::array::from_fn(|k| self.origin[k] + lens.radius_m * (disk[0] * right[k] + disk[1] * up[k]));
        (origin, unit(std::array::from_fn(|k| focus[k] - origin[k])))
    }

    /// The angle a pixel spans at the image's centre, radians: a camera ray's cone's spread.
    pub fn pixel_spread_rad(&self) -> f32 {
        2.0 * crate::primitives::dot(self.up, self.up).sqrt() / self.height as f32
    }

    /// The unit direction through image point (px, py) in pixels (y down).
    pub fn direction(&self, px: f32, py: f32) -> [f32; 3] {
        let sx = 2.0 * px / self.width as f32 - 1.0;
        let sy = 1.0 - 2.0 * py / self.height as f32;
        let d = [0, 1, 2].map(|k| self.forward[k] + sx * self.right[k] + sy * self.up[k]);
        let length = crate::primitives::dot(d, d).sqrt();
        d.map(|v| v / length)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Projects `p` with a row-vector matrix and divides: (x / w, y / w).
    fn project(m: &[f32; 16], p: DVec3) -> (f64, f64) {
        let v = [p.x, p.y, p.z, 1.0];
        let column = |c: usize| (0..4).map(|r| v[r] * f64::from(m[4 * r + c])).sum::<f64>();
        (column(0) / column(3), column(1) / column(3))
    }

    #[test]
    fn world_to_ndc_sends_a_point_on_a_pixel_ray_to_that_pixel() {
        let camera = Camera::look_at(DVec3::new(0.3, 0.4, 0.9), DVec3::new(0.0, 0.05, 0.0), DVec3::Y, 35.0, 320, 180);
        let eye = DVec3::from_array(camera.origin.map(f64::from));
        for (px, py, t) in [(0.5, 0.5, 0.7), (160.0, 90.0, 1.0), (319.5, 12.25, 1.4), (33.0, 179.5, 0.3)] {
            let direction = DVec3::from_array(camera.direction(px as f32, py as f32).map(f64::from));
            let (x, y) = project(&camera.world_to_ndc(), eye + direction * t);
            assert!((x * 320.0 - px).abs() < 1e-3 && (y * 180.0 - py).abs() < 1e-3, "({px}, {py}) -> ({x}, {y})");
            // camera space: x right, y up, z the distance along the view
            let m = camera.world_to_camera();
            let p = eye + direction * t;
            let z = (0..3).map(|k| [p.x, p.y, p.z][k] * f64::from(m[4 * k + 2])).sum::<f64>() + f64::from(m[14]);
            let forward = DVec3::from_array(camera.forward.map(f64::from));
            assert!((z - t * direction.dot(forward)).abs() < 1e-5);
        }
    }
}
