//! A rendered frame read back for review (`shatter preview` on a scene with outputs): its passes
//! as 8-bit pictures, and the Cryptomatte pick, the names under a pixel by their coverage, read
//! as a compositor reads them: each matte's ranks and its header's manifest.

use std::collections::HashMap;
use std::io::Cursor;
use std::path::Path;

use exr::prelude::{AttributeValue, read_all_flat_layers_from_file};

use crate::image_out::{ImageError, tonemapped_srgb};

/// A pass of a frame, drawn for the eye.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReviewPass {
    /// RGB, tonemapped (Reinhard) and sRGB-encoded.
    Beauty,
    /// ViewLayer.Depth.Z, nearest white, farthest of the frame's surfaces dark, none black.
    Depth,
    /// ViewLayer.Normal, each axis from [-1, 1] to [0, 1].
    Normal,
    /// ViewLayer.Vector's X and Y as red and green about grey, scaled by the frame's largest.
    Motion,
}

impl ReviewPass {
    /// The pass named `name` (`beauty`, `depth`, `normal`, `motion`).
    pub fn parse(name: &str) -> Option<ReviewPass> {
        match name {
            "beauty" => Some(ReviewPass::Beauty),
            "depth" => Some(ReviewPass::Depth),
            "normal" => Some(ReviewPass::Normal),
            "motion" => Some(ReviewPass::Motion),
            _ => None,
        }
    }
}

/// One matte's header entries: its name and its manifest, by id bits.
#[derive(Debug, Clone, PartialEq)]
struct MatteManifest {
    name: String,
    names: HashMap<u32, String>,
}

/// A frame's channels and mattes.
#[derive(Debug, Clone)]
pub struct RenderedFrame {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    channels: HashMap<String, Vec<f32>>,
    mattes: Vec<MatteManifest>,
}

impl RenderedFrame {
    /// Reads the EXR at `path` (its first layer).
    pub fn read(path: &Path) -> Result<RenderedFrame, ImageError> {
        let format = |what: String| ImageError::Format { path: path.to_path_buf(), what };
        let image = read_all_flat_layers_from_file(path).map_err(|error| format(error.to_string()))?;
        let layer = image.layer_data.first().ok_or_else(|| format("no layer".into()))?;
        let channels = layer
            .channel_data
            .list
            .iter()
            .map(|channel| (channel.name.to_string(), channel.sample_data.values_as_f32().collect()))
            .collect();
        let text = |key: &str| match layer.attributes.other.get(&exr::prelude::Text::from(key)) {
            Some(AttributeValue::Text(text)) => Some(text.to_string()),
            _ => None,
        };
        let mut mattes = Vec::new();
        for attribute in layer.attributes.other.keys().map(ToString::to_string) {
            let Some(key) = attribute.strip_prefix("cryptomatte/").and_then(|rest| rest.strip_suffix("/name")) else {
                continue;
            };
            let name = text(&attribute).unwrap_or_default();
            let manifest = text(&format!("cryptomatte/{key}/manifest")).unwrap_or_else(|| "{}".into());
            let entries: HashMap<String, String> = serde_json::from_str(&manifest)
                .map_err(|error| format(format!("the manifest of Cryptomatte {name}: {error}")))?;
            let names = entries
                .into_iter()
                .filter_map(|(name, hex)| u32::from_str_radix(&hex, 16).ok().map(|bits| (bits, name)))
                .collect();
            mattes.push(MatteManifest { name, names });
        }
        Ok(RenderedFrame { width: layer.size.0, height: layer.size.1, channels, mattes })
    }

    fn channel(&self, name: &str) -> Option<&[f32]> {
        self.channels.get(name).map(Vec::as_slice)
    }

    /// `pass` as an 8-bit RGB PNG; None when the frame lacks its channels.
    pub fn pass_png(&self, pass: ReviewPass) -> Option<Vec<u8>> {
        let rgb = match pass {
            ReviewPass::Beauty => self.mapped(["R", "G", "B"], |v| tonemapped_srgb(v.max(0.0)))?,
            ReviewPass::Depth => {
                let depth = self.channel("ViewLayer.Depth.Z")?;
                let finite = depth.iter().copied().filter(|d| d.is_finite());
                let (near, far) = finite.fold((f32::INFINITY, 0.0f32), |(lo, hi), d| (lo.min(d), hi.max(d)));
                let span = (far - near).max(f32::MIN_POSITIVE);
                depth
                    .iter()
                    .flat_map(|&d| [if d.is_finite() { 1.0 - 0.8 * (d - near) / span } else { 0.0 }; 3])
                    .collect()
            }
            ReviewPass::Normal => {
                let axes = ["ViewLayer.Normal.X", "ViewLayer.Normal.Y", "ViewLayer.Normal.Z"];
                self.mapped(axes, |v| 0.5 + 0.5 * v)?
            }
            ReviewPass::Motion => {
                let (x, y) = (self.channel("ViewLayer.Vector.X")?, self.channel("ViewLayer.Vector.Y")?);
                let largest = x.iter().chain(y).fold(0.0f32, |m, v| m.max(v.abs())).max(f32::MIN_POSITIVE);
                x.iter().zip(y).flat_map(|(x, y)| [0.5 + 0.5 * x / largest, 0.5 + 0.5 * y / largest, 0.5]).collect()
            }
        };
        let bytes: Vec<u8> = rgb.iter().map(|v: &f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8).collect();
        let image = image::RgbImage::from_raw(self.width as u32, self.height as u32, bytes)?;
        let mut png = Cursor::new(Vec::new());
        image.write_to(&mut png, image::ImageFormat::Png).ok()?;
        Some(png.into_inner())
    }

    /// The three channels `names` per pixel through `map`, interleaved.
    fn mapped(&self, names: [&str; 3], map: impl Fn(f32) -> f32) -> Option<Vec<f32>> {
        let channels = names.map(|name| self.channel(name));
        let [a, b, c] = [channels[0]?, channels[1]?, channels[2]?];
        Some((0..a.len()).flat_map(|i| [map(a[i]), map(b[i]), map(c[i])]).collect())
    }

    /// The names matte `matte` holds at pixel (x, y), from the top-left, with their coverage,
    /// most covered first; empty where it holds none (or the frame has no such matte).
    pub fn pick(&self, matte: &str, x: usize, y: usize) -> Vec<(String, f32)> {
        let Some(manifest) = self.mattes.iter().find(|m| m.name == matte) else {
            return Vec::new();
        };
        if x >= self.width || y >= self.height {
            return Vec::new();
        }
        let pixel = y * self.width + x;
        let mut found = Vec::new();
        for layer in 0.. {
            let rank =
                |channel: &str| self.channel(&format!("{matte}{layer:02}.{channel}")).map(|values| values[pixel]);
            let Some([r, g, b, a]) = ["R", "G", "B", "A"]
                .map(rank)
                .into_iter()
                .collect::<Option<Vec<f32>>>()
                .and_then(|values| <[f32; 4]>::try_from(values).ok())
            else {
                break;
            };
            for (id, coverage) in [(r, g), (b, a)] {
                if coverage > 0.0 {
                    let name =
                        manifest.names.get(&id.to_bits()).cloned().unwrap_or_else(|| format!("{:08x}", id.to_bits()));
                    found.push((name, coverage));
                }
            }
        }
        found.sort_by(|a, b| b.1.total_cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        found
    }
}
