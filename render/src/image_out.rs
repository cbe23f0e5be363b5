//! Writing frames: multi-layer OpenEXR (linear RGBA half, depth, normals, fragment ids) and
//! tonemapped PNG previews, both atomically.

use std::io::Cursor;
use std::path::{Path, PathBuf};

use exr::prelude::{
    AttributeValue, Encoding, FlatSamples, Image, Layer, LayerAttributes, LineOrder, Text, WritableImage,
    read_all_flat_layers_from_file,
};

use crate::cryptomatte::{Matte, matte_key};
use crate::exr_blocks::{Channel, FrameSamples, Source, exr_bytes, header_channels};
use crate::integrator::Pixel;

/// Why an image could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// Encoding or decoding failed.
    #[error("{path}: {what}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        what: String,
    },
    /// The file could not be written.
    #[error("{path}: cannot write: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// The channels of a shatter EXR frame besides the Cryptomattes, in the sorted order EXR stores
/// them: RGBA (Nuke's rgba, Blender's Combined), then Blender's ViewLayer.Pass.Channel names.
pub const EXR_CHANNELS: [&str; 13] = [
    "A",
    "B",
    "G",
    "R",
    "ViewLayer.Depth.Z",
    "ViewLayer.FragmentIndex.X",
    "ViewLayer.Normal.X",
    "ViewLayer.Normal.Y",
    "ViewLayer.Normal.Z",
    "ViewLayer.Vector.W",
    "ViewLayer.Vector.X",
    "ViewLayer.Vector.Y",
    "ViewLayer.Vector.Z",
];

/// The denoising passes' channels, as Blender names its Denoising Data passes (its Denoise node
/// and OIDN take them as guides), in EXR's sorted order; written with `render.denoising_passes`.
pub const DENOISING_CHANNELS: [&str; 6] = [
    "ViewLayer.Denoising Albedo.B",
    "ViewLayer.Denoising Albedo.G",
    "ViewLayer.Denoising Albedo.R",
    "ViewLayer.Denoising Normal.X",
    "ViewLayer.Denoising Normal.Y",
    "ViewLayer.Denoising Normal.Z",
];

/// What an EXR's header says of its frame besides the pixels: the camera (OpenEXR's standard
/// `worldToCamera` and `worldToNDC`, see [`crate::camera::Camera::world_to_ndc`]), the playback rate
/// (`framesPerSecond`), and the frame's simulated time (`shatterSimulationTime`, seconds).
#[derive(Debug, Clone, PartialEq)]
pub struct FrameHeader {
    /// A human-readable comment.
    pub comment: String,
    /// World to camera, Imath row-vector matrix, row-major.
    pub world_to_camera: [f32; 16],
    /// World to normalized device coordinates, likewise.
    pub world_to_ndc: [f32; 16],
    /// Playback frames per second.
    pub frames_per_second: f64,
    /// Simulated time at the frame, seconds.
    pub simulation_time_s: f64,
    /// How long the shutter is open, seconds of playback (OpenEXR's `exposure`; 0: still).
    pub shutter_s: f64,
    /// The thin lens, if any (OpenEXR's `aperture` and `focus`, and shatter's focal length and
    /// sensor height).
    pub lens: Option<HeaderLens>,
}

/// The lens as a frame's header names it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeaderLens {
    /// f-number.
    pub f_stop: f64,
    /// Distance of the plane in focus, metres.
    pub focus_m: f64,
    /// Focal length, millimetres.
    pub focal_length_mm: f64,
    /// Sensor height, millimetres.
    pub sensor_height_mm: f64,
}

/// A frame's layers: the traced pixels, their motion pass and their Cryptomattes.
#[derive(Debug, Clone, Copy)]
pub struct FrameLayers<'a> {
    /// The pixels, row-major, top row first.
    pub pixels: &'a [Pixel],
    /// The motion pass ([`crate::motion`]), one entry per pixel.
    pub motion: &'a [[f32; 4]],
    /// The Cryptomattes.
    pub mattes: &'a [Matte],
    /// Also write the denoising passes ([`DENOISING_CHANNELS`]).
    pub denoising: bool,
}

/// A frame rate as OpenEXR's rational: whole rates exactly, NTSC's 24000/1001 family by their
/// usual fractions, anything else to a thousandth.
fn rational(rate: f64) -> (i32, u32) {
    let ntsc = rate * 1001.0 / 1000.0;
    if (rate - rate.round()).abs() < 1e-9 {
        (rate.round() as i32, 1)
    } else if (ntsc - ntsc.round()).abs() < 1e-6 {
        ((ntsc.round() * 1000.0) as i32, 1001)
    } else {
        ((rate * 1000.0).round() as i32, 1000)
    }
}

/// Writes `layers` as an EXR: R, G, B, A (half, linear); ViewLayer.Depth.Z (float: distance along
/// the camera ray to the first surface; infinity where there is none); ViewLayer.Normal.X, .Y,
/// .Z (float: world-space unit normal there); ViewLayer.Vector.X, .Y, .Z, .W (float: the motion
/// pass); ViewLayer.FragmentIndex.X (uint: fragment id + 1 of the first element seen, 0 for none);
/// each Cryptomatte's ranks (float) with its header entries; and, asked for, the denoising passes
/// ViewLayer.Denoising Albedo.R, .G, .B and ViewLayer.Denoising Normal.X, .Y, .Z (half). `header`
/// goes into the header.
pub fn write_exr(
    path: &Path,
    width: usize,
    height: usize,
    layers: &FrameLayers,
    header: &FrameHeader,
) -> Result<(), ImageError> {
    let format_error = |what: String| ImageError::Format { path: path.to_path_buf(), what };
    let matte_columns: Vec<(String, Vec<f32>)> = layers.mattes.iter().flat_map(Matte::channels).collect();
    let channels = frame_channels(layers.denoising, &matte_columns);
    // Increasing line order: the blocks are written in order, so the same pixels always make the
    // same bytes (FAST_LOSSLESS alone leaves the order unspecified).
    let encoding = Encoding { line_order: LineOrder::Increasing, ..Encoding::FAST_LOSSLESS };
    let layer =
        Layer::new((width, height), frame_attributes(header, layers.mattes), encoding, header_channels(&channels));
    let headers = Image::from_layer(layer).write().infer_meta_data();
    let samples = FrameSamples { pixels: layers.pixels, motion: layers.motion, width };
    let mut bytes = exr_bytes(headers, &channels, &samples).map_err(|error| format_error(error.to_string()))?;
    sort_header_attributes(&mut bytes).map_err(|what| format_error(what.into()))?;
    shatter_core::atomic_file::write_atomically(path, &[&bytes])
        .map_err(|source| ImageError::Io { path: path.to_path_buf(), source })
}

/// A frame's channels (see [`write_exr`]), the Cryptomattes' from `matte_columns`.
fn frame_channels(denoising: bool, matte_columns: &[(String, Vec<f32>)]) -> Vec<Channel<'_>> {
    let pixel_channels: [(&str, Source); 8] = [
        ("R", Source::Half(|p| p.color[0])),
        ("G", Source::Half(|p| p.color[1])),
        ("B", Source::Half(|p| p.color[2])),
        ("A", Source::Half(|p| p.alpha)),
        ("ViewLayer.Depth.Z", Source::Float(|p| p.depth)),
        ("ViewLayer.Normal.X", Source::Float(|p| p.normal[0])),
        ("ViewLayer.Normal.Y", Source::Float(|p| p.normal[1])),
        ("ViewLayer.Normal.Z", Source::Float(|p| p.normal[2])),
    ];
    let motion = ["X", "Y", "Z", "W"]
        .into_iter()
        .enumerate()
        .map(|(k, axis)| (format!("ViewLayer.Vector.{axis}"), Source::Motion(k)));
    let denoising_channels: [(&str, Source); 6] = [
        ("ViewLayer.Denoising Albedo.R", Source::Half(|p| p.denoising_albedo[0])),
        ("ViewLayer.Denoising Albedo.G", Source::Half(|p| p.denoising_albedo[1])),
        ("ViewLayer.Denoising Albedo.B", Source::Half(|p| p.denoising_albedo[2])),
        ("ViewLayer.Denoising Normal.X", Source::Half(|p| p.denoising_normal[0])),
        ("ViewLayer.Denoising Normal.Y", Source::Half(|p| p.denoising_normal[1])),
        ("ViewLayer.Denoising Normal.Z", Source::Half(|p| p.denoising_normal[2])),
    ];
    let denoising = denoising_channels.into_iter().filter(|_| denoising);
    let mattes = matte_columns.iter().map(|(name, values)| (name.clone(), Source::Column(values)));
    pixel_channels
        .into_iter()
        .chain(denoising)
        .map(|(name, source)| (name.to_string(), source))
        .chain(motion)
        .chain([("ViewLayer.FragmentIndex.X".to_string(), Source::Fragment)])
        .chain(mattes)
        .map(|(name, source)| Channel { name, source })
        .collect()
}

/// A frame's header attributes: `header`'s, and each of `mattes`' Cryptomatte entries.
fn frame_attributes(header: &FrameHeader, mattes: &[Matte]) -> LayerAttributes {
    let mut attributes = LayerAttributes {
        comments: Some(Text::from(header.comment.as_str())),
        software_name: Some(Text::from("shatter")),
        world_to_camera: Some(header.world_to_camera),
        world_to_normalized_device: Some(header.world_to_ndc),
        frames_per_second: Some(rational(header.frames_per_second)),
        ..LayerAttributes::default()
    };
    attributes.other.insert(Text::from("shatterSimulationTime"), AttributeValue::F64(header.simulation_time_s));
    if header.shutter_s > 0.0 {
        attributes.exposure = Some(header.shutter_s as f32);
    }
    if let Some(lens) = header.lens {
        attributes.aperture = Some(lens.f_stop as f32);
        attributes.focus = Some(lens.focus_m as f32);
        attributes.other.insert(Text::from("shatterFocalLength"), AttributeValue::F64(lens.focal_length_mm));
        attributes.other.insert(Text::from("shatterSensorHeight"), AttributeValue::F64(lens.sensor_height_mm));
    }
    for matte in mattes {
        let key = format!("cryptomatte/{}/", matte_key(&matte.name));
        for (entry, value) in [
            ("name", matte.name.clone()),
            ("hash", "MurmurHash3_32".to_string()),
            ("conversion", "uint32_to_float32".to_string()),
            ("manifest", matte.manifest_json()),
        ] {
            attributes
                .other
                .insert(Text::from(format!("{key}{entry}").as_str()), AttributeValue::Text(Text::from(value.as_str())));
        }
    }
    attributes
}

/// Puts the attributes of a single-part EXR's header in name order, in place. The exr crate
/// writes custom attributes in hash-map order, and the same frame must always make the same
/// bytes; OpenEXR gives attribute order no meaning, and the header keeps its length, so the
/// offset table after it stays right.
fn sort_header_attributes(bytes: &mut [u8]) -> Result<(), &'static str> {
    const MULTIPART: u8 = 0x10; // bit 12 of the version field
    if bytes.len() < 8 || bytes[..4] != [0x76, 0x2f, 0x31, 0x01] || bytes[5] & MULTIPART != 0 {
        return Err("not a single-part OpenEXR file");
    }
    let zero_after = |from: usize| bytes[from..].iter().position(|&b| b == 0).map(|k| from + k);
    let mut attributes: Vec<(usize, usize, usize)> = Vec::new(); // (start, name end, end)
    let mut at = 8;
    loop {
        let name_end = zero_after(at).ok_or("header without an end")?;
        if name_end == at {
            break;
        }
        let type_end = zero_after(name_end + 1).ok_or("attribute without a type")?;
        let size_at = type_end + 1;
        let size = bytes.get(size_at..size_at + 4).ok_or("attribute without a size")?;
        let size = u32::from_le_bytes([size[0], size[1], size[2], size[3]]) as usize;
        let end = size_at + 4 + size;
        if end > bytes.len() {
            return Err("attribute past the end of the file");
        }
        attributes.push((at, name_end, end));
        at = end;
    }
    let start = 8;
    let mut sorted: Vec<&(usize, usize, usize)> = attributes.iter().collect();
    sorted.sort_by(|a, b| bytes[a.0..a.1].cmp(&bytes[b.0..b.1]));
    let header: Vec<u8> = sorted.iter().flat_map(|&&(from, _, to)| bytes[from..to].to_vec()).collect();
    bytes[start..start + header.len()].copy_from_slice(&header);
    Ok(())
}

/// One channel of an EXR read back.
#[derive(Debug, Clone, PartialEq)]
pub struct ExrChannel {
    /// Channel name.
    pub name: String,
    /// "f16", "f32" or "u32".
    pub sample_type: &'static str,
    /// Values as f32 (u32 converted).
    pub values: Vec<f32>,
}

/// Reads every channel of the first layer of an EXR (tests, tools): (width, height, channels).
pub fn read_exr(path: &Path) -> Result<(usize, usize, Vec<ExrChannel>), ImageError> {
    let image = read_all_flat_layers_from_file(path)
        .map_err(|error| ImageError::Format { path: path.to_path_buf(), what: error.to_string() })?;
    let layer = image
        .layer_data
        .first()
        .ok_or_else(|| ImageError::Format { path: path.to_path_buf(), what: "no layer".into() })?;
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|channel| {
            let sample_type = match &channel.sample_data {
                FlatSamples::F16(_) => "f16",
                FlatSamples::F32(_) => "f32",
                FlatSamples::U32(_) => "u32",
            };
            ExrChannel {
                name: channel.name.to_string(),
                sample_type,
                values: channel.sample_data.values_as_f32().collect(),
            }
        })
        .collect();
    Ok((layer.size.0, layer.size.1, channels))
}

/// A linear value tonemapped (Reinhard) and sRGB-encoded, as the PNG previews show it.
pub(crate) fn tonemapped_srgb(linear: f32) -> f32 {
    let mapped = linear / (1.0 + linear);
    if mapped <= 0.003_130_8 { 12.92 * mapped } else { 1.055 * mapped.powf(1.0 / 2.4) - 0.055 }
}

/// Writes a tonemapped sRGB PNG preview: exposure, a filmic curve, sRGB encoding.
pub fn write_png(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[Pixel],
    exposure_stops: f32,
) -> Result<(), ImageError> {
    let scale = exposure_stops.exp2();
    let encode = |linear: f32| (tonemapped_srgb(linear * scale).clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    let mut rgb = Vec::with_capacity(width * height * 3);
    for p in pixels {
        rgb.extend(p.color.map(encode));
    }
    let image = image::RgbImage::from_raw(width as u32, height as u32, rgb)
        .ok_or_else(|| ImageError::Format { path: path.to_path_buf(), what: "image size mismatch".into() })?;
    let mut bytes = Cursor::new(Vec::new());
    image
        .write_to(&mut bytes, image::ImageFormat::Png)
        .map_err(|error| ImageError::Format { path: path.to_path_buf(), what: error.to_string() })?;
    shatter_core::atomic_file::write_atomically(path, &[bytes.get_ref()])
        .map_err(|source| ImageError::Io { path: path.to_path_buf(), source })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use exr::prelude::f16;
    use glam::DVec3;

    fn test_header() -> FrameHeader {
        let camera = Camera::look_at(DVec3::new(0.0, 0.2, 1.0), DVec3::ZERO, DVec3::Y, 40.0, 4, 3);
        FrameHeader {
            comment: "frame 1".into(),
            world_to_camera: camera.world_to_camera(),
            world_to_ndc: camera.world_to_ndc(),
            frames_per_second: 24.0,
            simulation_time_s: 1.25e-4,
            shutter_s: 0.0,
            lens: None,
        }
    }

    #[test]
    fn the_header_carries_the_camera_the_rate_and_the_time() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("shot.0001.exr");
        let pixels = vec![Pixel { color: [0.5; 3], alpha: 1.0, depth: 1.0, fragment: 1, ..Pixel::EMPTY }; 12];
        let header = test_header();
        write_exr(&path, 4, 3, &layers(&pixels, &[[0.0; 4]; 12], &[]), &header).expect("write");
        let meta = exr::meta::MetaData::read_from_file(&path, false).expect("header");
        let attributes = &meta.headers[0].own_attributes;
        assert_eq!(attributes.world_to_camera, Some(header.world_to_camera));
        assert_eq!(attributes.world_to_normalized_device, Some(header.world_to_ndc));
        assert_eq!(attributes.frames_per_second, Some((24, 1)));
        let time = attributes.other.get(&Text::from("shatterSimulationTime"));
        assert_eq!(time, Some(&AttributeValue::F64(1.25e-4)));
        assert_eq!((attributes.exposure, attributes.aperture, attributes.focus), (None, None, None), "still, pinhole");
        // a blurred frame through a lens names its shutter and its lens
        let lens = HeaderLens { f_stop: 2.8, focus_m: 1.5, focal_length_mm: 35.0, sensor_height_mm: 24.0 };
        let shot = FrameHeader { shutter_s: 0.5 / 24.0, lens: Some(lens), ..header };
        write_exr(&path, 4, 3, &layers(&pixels, &[[0.0; 4]; 12], &[]), &shot).expect("write");
        let meta = exr::meta::MetaData::read_from_file(&path, false).expect("header");
        let attributes = &meta.headers[0].own_attributes;
        assert_eq!(
            (attributes.exposure, attributes.aperture, attributes.focus),
            (Some(0.5 / 24.0), Some(2.8), Some(1.5))
        );
        let focal = attributes.other.get(&Text::from("shatterFocalLength"));
        assert_eq!(focal, Some(&AttributeValue::F64(35.0)));
        assert_eq!(rational(23.976023976023978), (24000, 1001));
        assert_eq!(rational(29.97002997002997), (30000, 1001));
        assert_eq!(rational(12.5), (12500, 1000));
    }

    fn layers<'a>(pixels: &'a [Pixel], motion: &'a [[f32; 4]], mattes: &'a [Matte]) -> FrameLayers<'a> {
        FrameLayers { pixels, motion, mattes, denoising: false }
    }

    #[test]
    fn exr_frames_read_back_with_their_layers_and_channel_types() {
        let pixels: Vec<Pixel> = (0..12)
            .map(|i| Pixel {
                color: [i as f32 * 0.1, 0.5, 2.0],
                alpha: if i % 2 == 0 { 1.0 } else { 0.0 },
                depth: if i % 2 == 0 { 1.5 + i as f32 } else { f32::INFINITY },
                normal: [0.0, 1.0, 0.0],
                fragment: (i % 3) as u32,
                ..Pixel::EMPTY
            })
            .collect();
        let motion: Vec<[f32; 4]> = (0..12).map(|i| [i as f32, -1.0, 0.5, 2.0]).collect();
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("shot.0001.exr");
        write_exr(&path, 4, 3, &layers(&pixels, &motion, &[]), &test_header()).expect("write");
        let (width, height, channels) = read_exr(&path).expect("read");
        assert_eq!((width, height), (4, 3));
        let names: Vec<&str> = channels.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, EXR_CHANNELS);
        let guided = dir.path().join("shot.0002.exr");
        let with_guides: Vec<Pixel> = pixels
            .iter()
            .map(|p| Pixel { denoising_albedo: [0.25, 0.5, 0.75], denoising_normal: [0.0, 0.6, -0.8], ..*p })
            .collect();
        let denoising = FrameLayers { denoising: true, ..layers(&with_guides, &motion, &[]) };
        write_exr(&guided, 4, 3, &denoising, &test_header()).expect("write");
        let (_, _, guides) = read_exr(&guided).expect("read");
        let mut expected: Vec<&str> = EXR_CHANNELS.iter().chain(&DENOISING_CHANNELS).copied().collect();
        expected.sort_unstable();
        assert_eq!(guides.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(), expected);
        let guide = |name: &str| guides.iter().find(|c| c.name == name).expect("channel").values[5];
        assert_eq!(guide("ViewLayer.Denoising Albedo.B"), 0.75);
        assert_eq!(guide("ViewLayer.Denoising Normal.Z"), f16::from_f32(-0.8).to_f32(), "half precision");
        let channel = |name: &str| channels.iter().find(|c| c.name == name).expect("channel");
        assert_eq!(channel("R").sample_type, "f16");
        let (depth, fragment) = ("ViewLayer.Depth.Z", "ViewLayer.FragmentIndex.X");
        assert_eq!(channel(depth).sample_type, "f32");
        assert_eq!(channel(fragment).sample_type, "u32");
        assert_eq!(channel(depth).values[2], 3.5);
        assert!(channel(depth).values[1].is_infinite());
        assert_eq!(channel(fragment).values[5], 2.0);
        assert_eq!(channel("ViewLayer.Vector.X").values[7], 7.0);
        assert_eq!(channel("ViewLayer.Vector.W").values[7], 2.0);
        assert!((channel("R").values[7] - 0.7).abs() < 1e-3);
        let png = dir.path().join("shot.0001.png");
        write_png(&png, 4, 3, &pixels, 0.0).expect("png");
        assert_eq!(image::open(&png).expect("png reads").width(), 4);
    }

    /// Blocks are compressed in parallel; the file's bytes must not depend on which finished
    /// first (render farms and `shatter run` compare frames byte for byte).
    #[test]
    fn the_same_pixels_always_make_the_same_exr_bytes() {
        let (width, height) = (96, 200);
        let pixels: Vec<Pixel> = (0..width * height)
            .map(|i| Pixel {
                color: [(i % 97) as f32 * 0.01, (i % 13) as f32, 0.25],
                alpha: 1.0,
                depth: 1.0 + (i % 31) as f32,
                normal: [0.0, 0.0, 1.0],
                fragment: (i / 500) as u32,
                ..Pixel::EMPTY
            })
            .collect();
        let motion = vec![[0.25f32; 4]; width * height];
        let mut counts = vec![crate::mattes::MatteCounts::default(); width * height];
        for (i, c) in counts.iter_mut().enumerate() {
            c.add((i / 500) as u32 + 1, crate::mattes::SURFACE_OUTER);
            c.add(0, crate::mattes::SURFACE_FLOOR);
        }
        let ids: Vec<u32> = (0..40).collect();
        let mattes = [crate::cryptomatte::fragment_matte(&counts, &ids), crate::cryptomatte::material_matte(&counts)];
        let dir = tempfile::tempdir().expect("tempdir");
        let bytes: Vec<Vec<u8>> = (0..6)
            .map(|k| {
                let path = dir.path().join(format!("shot.{k:04}.exr"));
                write_exr(&path, width, height, &layers(&pixels, &motion, &mattes), &test_header()).expect("write");
                std::fs::read(&path).expect("read")
            })
            .collect();
        assert!(bytes.windows(2).all(|pair| pair[0] == pair[1]));
    }
}
