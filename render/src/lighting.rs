//! Environment lighting: an equirectangular HDR map seen as background and through glass, its
//! diffuse irradiance from 9 spherical-harmonic coefficients (Ramamoorthi and Hanrahan 2001), and
//! a key light (the map's brightest region) for normalized Blinn-Phong highlights.
//!
//! Directions map to the map as u = 1/2 + atan2(x, -z) / 2 pi, v = acos(y) / pi: +Y is up (the top
//! row), -Z is the centre of the map. The twin of `shaders/lighting.wgsl`.

// Indexed loops mirror the shader this is the twin of.
#![allow(clippy::needless_range_loop)]
use std::f32::consts::PI;
use std::path::{Path, PathBuf};

/// Why an environment map could not be used.
#[derive(Debug, thiserror::Error)]
pub enum LightingError {
    /// The file could not be read or decoded.
    #[error("{path}: cannot read the environment map: {reason}")]
    Load {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
}

/// An equirectangular map of linear RGB radiance.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentMap {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Row-major radiance, top row first.
    pub texels: Vec<[f32; 3]>,
}

impl EnvironmentMap {
    /// Loads a Radiance .hdr or OpenEXR map, scaled by `intensity`.
    pub fn load(path: &Path, intensity: f32) -> Result<EnvironmentMap, LightingError> {
        let load_error = |reason: String| LightingError::Load { path: path.to_path_buf(), reason };
        let image = image::ImageReader::open(path)
            .map_err(|error| load_error(error.to_string()))?
            .with_guessed_format()
            .map_err(|error| load_error(error.to_string()))?
            .decode()
            .map_err(|error| load_error(error.to_string()))?
            .into_rgb32f();
        let (width, height) = (image.width() as usize, image.height() as usize);
        if width < 2 || height < 2 {
            return Err(load_error(format!("{width} x {height} pixels is too small")));
        }
        let texels: Vec<[f32; 3]> =
            image.pixels().map(|p| [p[0] * intensity, p[1] * intensity, p[2] * intensity]).collect();
        if texels.iter().flatten().any(|v| !v.is_finite() || *v < 0.0) {
            return Err(load_error("it holds negative or non-finite radiance".into()));
        }
        Ok(EnvironmentMap { width, height, texels })
    }

    /// A map of one constant radiance (tests, and scenes without a map).
    pub fn constant(radiance: [f32; 3]) -> EnvironmentMap {
        EnvironmentMap { width: 4, height: 2, texels: vec![radiance; 8] }
    }

    /// The direction at the centre of texel (x, y).
    pub fn direction(&self, x: usize, y: usize) -> [f32; 3] {
        let u = (x as f32 + 0.5) / self.width as f32;
        let v = (y as f32 + 0.5) / self.height as f32;
        direction_of(u, v)
    }

    /// Radiance seen in direction `d` (unit), bilinearly filtered.
    pub fn radiance(&self, d: [f32; 3]) -> [f32; 3] {
        let (u, v) = coordinates_of(d);
        let fx = u * self.width as f32 - 0.5;
        let fy = (v * self.height as f32 - 0.5).clamp(0.0, (self.height - 1) as f32);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (ax, ay) = (fx - x0, fy - y0);
        let texel = |x: f32, y: f32| {
            let xi = (x as i64).rem_euclid(self.width as i64) as usize;
            let yi = (y as usize).min(self.height - 1);
            self.texels[yi * self.width + xi]
        };
        let (a, b, c, e) = (texel(x0, y0), texel(x0 + 1.0, y0), texel(x0, y0 + 1.0), texel(x0 + 1.0, y0 + 1.0));
        [0, 1, 2].map(|k| (a[k] * (1.0 - ax) + b[k] * ax) * (1.0 - ay) + (c[k] * (1.0 - ax) + e[k] * ax) * ay)
    }
}

/// Map coordinates (u, v) in [0, 1) of a unit direction.
pub fn coordinates_of(d: [f32; 3]) -> (f32, f32) {
    let u = 0.5 + d[0].atan2(-d[2]) / (2.0 * PI);
    let v = d[1].clamp(-1.0, 1.0).acos() / PI;
    (u, v)
}

/// The unit direction of map coordinates (u, v).
pub fn direction_of(u: f32, v: f32) -> [f32; 3] {
    let phi = (u - 0.5) * 2.0 * PI;
    let theta = v * PI;
    [theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos()]
}

/// The 9 real spherical harmonics (bands 0 to 2) at a unit direction.
pub fn sh_basis(d: [f32; 3]) -> [f32; 9] {
    let [x, y, z] = d;
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

/// Per band: the convolution of the clamped cosine (pi, 2 pi / 3, pi / 4).
const BAND_WEIGHT: [f32; 9] =
    [PI, 2.0 * PI / 3.0, 2.0 * PI / 3.0, 2.0 * PI / 3.0, PI / 4.0, PI / 4.0, PI / 4.0, PI / 4.0, PI / 4.0];

/// The 9 RGB spherical-harmonic coefficients of the map's radiance.
pub fn sh_project(map: &EnvironmentMap) -> [[f32; 3]; 9] {
    let mut coefficients = [[0.0f64; 3]; 9];
    let texel_angle = (2.0 * std::f64::consts::PI / map.width as f64) * (std::f64::consts::PI / map.height as f64);
    for y in 0..map.height {
        let theta = (y as f64 + 0.5) / map.height as f64 * std::f64::consts::PI;
        let weight = texel_angle * theta.sin();
        for x in 0..map.width {
            let basis = sh_basis(map.direction(x, y));
            let radiance = map.texels[y * map.width + x];
            for (k, b) in basis.iter().enumerate() {
                for c in 0..3 {
                    coefficients[k][c] += weight * f64::from(*b) * f64::from(radiance[c]);
                }
            }
        }
    }
    coefficients.map(|c| c.map(|v| v as f32))
}

/// Irradiance at a surface with unit normal `n` from the projected radiance.
pub fn sh_irradiance(coefficients: &[[f32; 3]; 9], n: [f32; 3]) -> [f32; 3] {
    let basis = sh_basis(n);
    let mut e = [0.0f32; 3];
    for k in 0..9 {
        for c in 0..3 {
            e[c] += BAND_WEIGHT[k] * coefficients[k][c] * basis[k];
        }
    }
    e.map(|v| v.max(0.0))
}

/// A directional light standing for the map's brightest region.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeyLight {
    /// Unit direction towards the light.
    pub direction: [f32; 3],
    /// Irradiance it delivers to a surface facing it, W/m^2 per channel.
    pub irradiance: [f32; 3],
}

/// Half-angle of the cone around the brightest texel taken as the key light.
const KEY_CONE_RADIANS: f32 = 0.15;

/// The key light: the direction of the brightest texel (by luminance); its irradiance is the
/// radiance within a small cone around it, integrated.
pub fn key_light(map: &EnvironmentMap) -> KeyLight {
    let luminance = |c: [f32; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let brightest = (0..map.texels.len())
        .max_by(|a, b| luminance(map.texels[*a]).total_cmp(&luminance(map.texels[*b])))
        .unwrap_or(0);
    let direction = map.direction(brightest % map.width, brightest / map.width);
    let texel_angle = (2.0 * PI / map.width as f32) * (PI / map.height as f32);
    let mut irradiance = [0.0f32; 3];
    for y in 0..map.height {
        let theta = (y as f32 + 0.5) / map.height as f32 * PI;
        for x in 0..map.width {
            let d = map.direction(x, y);
            let cosine = crate::primitives::dot(d, direction);
            if cosine >= KEY_CONE_RADIANS.cos() {
                let radiance = map.texels[y * map.width + x];
                for c in 0..3 {
                    irradiance[c] += radiance[c] * texel_angle * theta.sin() * cosine;
                }
            }
        }
    }
    KeyLight { direction, irradiance }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_and_coordinates_invert() {
        for d in [[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [0.6, 0.0, 0.8], [-0.36, 0.48, -0.8]] {
            let (u, v) = coordinates_of(d);
            let back = direction_of(u, v);
            assert!((0..3).all(|k| (back[k] - d[k]).abs() < 1e-5), "{d:?} -> {back:?}");
        }
    }

    #[test]
    fn a_constant_environment_gives_irradiance_pi_l() {
        let map = EnvironmentMap { width: 64, height: 32, texels: vec![[2.0, 1.0, 0.5]; 64 * 32] };
        let coefficients = sh_project(&map);
        for n in [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.577, 0.577, 0.577]] {
            let e = sh_irradiance(&coefficients, n);
            for (c, l) in [2.0f32, 1.0, 0.5].iter().enumerate() {
                assert!((e[c] / (PI * l) - 1.0).abs() < 2e-3, "{e:?} for {n:?}");
            }
        }
    }

    #[test]
    fn a_single_bright_direction_gives_the_clamped_cosine_within_the_9_term_error() {
        // One bright texel near the top; all flux from one direction.
        let (width, height) = (256, 128);
        let mut map = EnvironmentMap { width, height, texels: vec![[0.0; 3]; width * height] };
        let (x, y) = (40, 30);
        map.texels[y * width + x] = [1.0; 3];
        let light = map.direction(x, y);
        let theta = (y as f32 + 0.5) / height as f32 * PI;
        let flux = (2.0 * PI / width as f32) * (PI / height as f32) * theta.sin();
        let coefficients = sh_project(&map);
        let mut worst = 0.0f32;
        let mut rng = shatter_core::random::SplitMix64::new(1);
        for _ in 0..500 {
            let n = direction_of(rng.next_f64() as f32, rng.next_f64() as f32);
            let cos_gamma = crate::primitives::dot(n, light);
            // The 9-term response: flux * sum_l A_l (2l + 1) / (4 pi) P_l(cos gamma).
            let p2 = 0.5 * (3.0 * cos_gamma * cos_gamma - 1.0);
            let truncated = flux
                * (PI / (4.0 * PI)
                    + (2.0 * PI / 3.0) * 3.0 / (4.0 * PI) * cos_gamma
                    + (PI / 4.0) * 5.0 / (4.0 * PI) * p2);
            let e = sh_irradiance(&coefficients, n)[0];
            assert!((e - truncated.max(0.0)).abs() < 1e-3 * flux, "SH pipeline vs analytic 9-term response");
            worst = worst.max((e - flux * cos_gamma.max(0.0)).abs() / flux);
        }
        // 9 terms miss the clamped cosine by at most 3/32 of the peak (at grazing: 1/4 - 5/32)
        assert!(worst < 0.095, "worst deviation from the clamped cosine {worst}");
    }

    #[test]
    fn the_key_light_points_at_the_brightest_region() {
        let (width, height) = (128, 64);
        let mut map = EnvironmentMap { width, height, texels: vec![[0.1; 3]; width * height] };
        map.texels[10 * width + 90] = [100.0; 3];
        let key = key_light(&map);
        let expected = map.direction(90, 10);
        assert!(crate::primitives::dot(key.direction, expected) > 0.9999);
        assert!(key.irradiance[0] > 0.0);
    }
}
