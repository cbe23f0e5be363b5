//! Shading at a surface: reflection, refraction and Fresnel at glass interfaces, opaque surfaces
//! under the SH irradiance and the key light's highlight, and the floor. The twin of
//! `shaders/shading.wgsl`.

use crate::lighting::sh_irradiance;
use crate::materials::Look;
use crate::primitives::dot;
use crate::texture_filter::{Footprint, filtered_albedo};

pub(crate) fn reflect(d: [f32; 3], n: [f32; 3]) -> [f32; 3] {
    let k = 2.0 * dot(d, n);
    [d[0] - k * n[0], d[1] - k * n[1], d[2] - k * n[2]]
}

/// Refraction of unit `d` at unit normal `n` facing against it, index ratio `eta` = n1 / n2;
/// None on total internal reflection.
pub(crate) fn refract(d: [f32; 3], n: [f32; 3], eta: f32) -> Option<[f32; 3]> {
    let cos_i = -dot(d, n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t > 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let k = eta * cos_i - cos_t;
    Some([eta * d[0] + k * n[0], eta * d[1] + k * n[1], eta * d[2] + k * n[2]])
}

/// Schlick's Fresnel reflectance for cosine `cos_i` between media of index ratio n1 / n2 = `eta`.
pub(crate) fn fresnel(cos_i: f32, eta: f32) -> f32 {
    let r0 = ((1.0 - eta) / (1.0 + eta)).powi(2);
    r0 + (1.0 - r0) * (1.0 - cos_i.clamp(0.0, 1.0)).powi(5)
}

pub(crate) fn floor_t(look: &Look, origin: [f32; 3], direction: [f32; 3]) -> f32 {
    match &look.floor {
        Some(floor) if direction[1] < 0.0 && origin[1] > floor.height => (floor.height - origin[1]) / direction[1],
        _ => f32::INFINITY,
    }
}

/// Albedo of the floor at `p`, filtered over `footprint` where the floor's texture is.
pub(crate) fn floor_albedo(look: &Look, p: [f32; 3], footprint: Footprint) -> [f32; 3] {
    match &look.floor {
        Some(floor) => match &floor.mips {
            Some(mips) => filtered_albedo(floor, mips, p, footprint),
            None => floor.albedo(p),
        },
        None => [0.5; 3],
    }
}

/// Radiance of the floor, of albedo `albedo` where it is seen, along `d`.
pub(crate) fn floor_radiance(look: &Look, albedo: [f32; 3], d: [f32; 3]) -> [f32; 3] {
    shade_opaque(look, albedo, [0.0, 1.0, 0.0], d, 0.0)
}

/// Diffuse irradiance from the SH plus a normalized Blinn-Phong highlight of the key light.
pub(crate) fn shade_opaque(look: &Look, albedo: [f32; 3], normal: [f32; 3], view: [f32; 3], specular: f32) -> [f32; 3] {
    let irradiance = sh_irradiance(&look.sh, normal);
    let l = look.key.direction;
    // A matte surface (specular +0, as the floor) has no highlight: +0 (a positive shininess
    // keeps the power finite, so the product would be +0 too).
    let highlight = if specular.to_bits() != 0 && dot(normal, l) > 0.0 {
        let v = [l[0] - view[0], l[1] - view[1], l[2] - view[2]];
        let length = dot(v, v).sqrt().max(1e-12);
        let h = v.map(|c| c / length);
        specular * (look.shininess + 8.0) / (8.0 * std::f32::consts::PI) * dot(normal, h).max(0.0).powf(look.shininess)
    } else {
        0.0
    };
    [0, 1, 2].map(|c| albedo[c] / std::f32::consts::PI * irradiance[c] + highlight * look.key.irradiance[c])
}
