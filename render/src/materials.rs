//! The look of a shot: what the renderer needs besides the geometry (the environment and its
//! light, glass and opaque materials, the floor and its texture).

use crate::lighting::{EnvironmentMap, KeyLight, key_light, sh_project};
use crate::texture_filter::MipChain;

/// What the renderer needs besides the geometry.
#[derive(Debug, Clone)]
pub struct Look {
    /// The environment.
    pub environment: EnvironmentMap,
    /// Its 9 SH coefficients.
    pub sh: [[f32; 3]; 9],
    /// Its key light.
    pub key: KeyLight,
    /// Show it as background.
    pub show_environment: bool,
    /// Glass index of refraction.
    pub ior: f32,
    /// Glass absorption per metre.
    pub absorption: [f32; 3],
    /// Opaque albedo.
    pub albedo: [f32; 3],
    /// Opaque albedo of fracture faces.
    pub fracture_albedo: [f32; 3],
    /// Highlight strength.
    pub specular: f32,
    /// Highlight exponent.
    pub shininess: f32,
    /// The floor, if any.
    pub floor: Option<FloorLook>,
    /// Longest glass path: a path still going after this many events takes the environment's
    /// radiance along its last direction.
    pub max_bounces: u32,
    /// Glass interface events (counted along a path from the camera) at which both the reflected
    /// and the refracted branch are followed, weighted by Fresnel; later events pick one at random.
    pub glass_split_events: u32,
    /// Cubes are opaque (as tetrahedra and trimtopes are) instead of glass.
    pub opaque_cubes: bool,
}

impl Look {
    /// A look lit by `environment` (its SH light and key light), shown behind the scene: opaque
    /// cubes of albedo 0.7 without a highlight, glass of index 1.5 that absorbs nothing, no floor,
    /// 4 bounces. Callers change what they need (`Look { max_bounces: 8, ..Look::under(sky) }`).
    pub fn under(environment: EnvironmentMap) -> Look {
        Look {
            sh: sh_project(&environment),
            key: key_light(&environment),
            environment,
            show_environment: true,
            ior: 1.5,
            absorption: [0.0; 3],
            albedo: [0.7; 3],
            fracture_albedo: [0.7; 3],
            specular: 0.0,
            shininess: 16.0,
            floor: None,
            max_bounces: 4,
            glass_split_events: 0,
            opaque_cubes: true,
        }
    }
}

/// A floor plane with a tiled albedo texture.
#[derive(Debug, Clone)]
pub struct FloorLook {
    /// Height, metres.
    pub height: f32,
    /// Tile size, metres.
    pub tile: f32,
    /// Texture width and height (1 x 1 for a plain albedo).
    pub size: [usize; 2],
    /// Albedo texels, row-major.
    pub texels: FloorTexels,
    /// The texture's mip chain when it is filtered over each ray's footprint
    /// (`render.texture_filter`); None: point sampled, the texel under the point.
    pub mips: Option<MipChain>,
}

impl FloorLook {
    /// The albedo at `p` on the floor: the texel under it, tiled.
    pub(crate) fn albedo(&self, p: [f32; 3]) -> [f32; 3] {
        // x - floor(x) is rem_euclid(x, 1) without its library call: the same real number
        // rounded once (exactly, for x >= 0), but +0 for -0 and whole negative x (texel 0 either way).
        let fraction = |x: f32| x - x.floor();
        let (u, v) = (fraction(p[0] / self.tile), fraction(p[2] / self.tile));
        let x = ((u * self.size[0] as f32) as usize).min(self.size[0] - 1);
        let y = ((v * self.size[1] as f32) as usize).min(self.size[1] - 1);
        self.texels.linear_at(y * self.size[0] + x)
    }
}

/// A floor's albedo texels, row-major.
#[derive(Debug, Clone)]
pub enum FloorTexels {
    /// Linear albedo.
    Linear(Vec<[f32; 3]>),
    /// 8-bit sRGB (an image file's), decoded through a table of the 256 values' linear albedo:
    /// the same linear values bit for bit, in a quarter of the bytes, so that more of a large
    /// texture stays in cache (the floor's texel loads were most of its shading time).
    Srgb8 {
        /// The texels as stored.
        texels: Vec<[u8; 3]>,
        /// Linear albedo of each 8-bit value.
        linear: Box<[f32; 256]>,
    },
}

impl FloorTexels {
    /// 8-bit sRGB texels.
    pub fn srgb8(texels: Vec<[u8; 3]>) -> FloorTexels {
        let linear = Box::new(std::array::from_fn(|v| srgb_to_linear(v as u8)));
        FloorTexels::Srgb8 { texels, linear }
    }

    /// Number of texels.
    pub fn len(&self) -> usize {
        match self {
            FloorTexels::Linear(texels) => texels.len(),
            FloorTexels::Srgb8 { texels, .. } => texels.len(),
        }
    }

    /// True without texels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Texel `i`'s linear albedo.
    pub fn linear_at(&self, i: usize) -> [f32; 3] {
        match self {
            FloorTexels::Linear(texels) => texels[i],
            FloorTexels::Srgb8 { texels, linear } => texels[i].map(|v| linear[usize::from(v)]),
        }
    }
}

/// The linear value of an 8-bit sRGB value (IEC 61966-2-1's decoding).
fn srgb_to_linear(v: u8) -> f32 {
    let c = f32::from(v) / 255.0;
    if c <= 0.040_45 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_srgb8_floor_texel_decodes_to_the_standards_linear_value() {
        let texels = FloorTexels::srgb8((0..=255u8).map(|v| [v, 255 - v, v / 2]).collect());
        assert_eq!(texels.len(), 256);
        for v in 0..=255u8 {
            let reference = |v: u8| {
                let c = f64::from(v) / 255.0;
                if c <= 0.040_45 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
            };
            let got = texels.linear_at(usize::from(v));
            for (channel, byte) in [v, 255 - v, v / 2].into_iter().enumerate() {
                let want = reference(byte);
                assert!((f64::from(got[channel]) - want).abs() <= 1e-6 * want.max(1e-3), "{byte}: {got:?} vs {want}");
            }
        }
        assert_eq!(texels.linear_at(0)[0], 0.0);
        assert_eq!(texels.linear_at(255)[0], 1.0);
        // the floor looks the texel up where the point falls in its tile
        let floor = FloorLook { height: 0.0, tile: 1.0, size: [16, 16], texels, mips: None };
        assert_eq!(floor.albedo([0.5 / 16.0, 0.0, 1.5 / 16.0]), floor.texels.linear_at(16));
        assert_eq!(floor.albedo([-0.5 / 16.0, 0.0, 0.0]), floor.texels.linear_at(15));
    }
}
