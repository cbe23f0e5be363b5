//! An EXR frame's pixel blocks, filled straight from the frame's layers and compressed on the
//! calling thread. The exr crate's image writer first copies every channel into a column of its
//! own, then copies each block's lines out of those columns, and for every frame builds a thread
//! pool and clones the header (with its Cryptomatte manifests) for every block it compresses:
//! together about a tenth of the default shot's render time. Through the crate's block API the
//! same header, blocks and chunks make the same bytes, with one pass over the pixels
//! (docs/DECISIONS.md#exr-blocks).

use std::io::Cursor;

use exr::block::writer::ChunksWriter;
use exr::block::{BlockIndex, UncompressedBlock};
use exr::meta::header::Header;
use exr::prelude::{AnyChannel, AnyChannels, FlatSamples, SampleType, SmallVec, f16};

use crate::integrator::Pixel;

/// Where one channel's samples come from.
#[derive(Clone, Copy)]
pub enum Source<'a> {
    /// A half channel of the pixels.
    Half(fn(&Pixel) -> f32),
    /// A float channel of the pixels.
    Float(fn(&Pixel) -> f32),
    /// The fragment ids (uint).
    Fragment,
    /// Component `k` of the motion pass (float).
    Motion(usize),
    /// A float column, one value per pixel (a Cryptomatte rank).
    Column(&'a [f32]),
}

impl Source<'_> {
    /// The sample type the channel is stored as.
    fn sample_type(&self) -> SampleType {
        match self {
            Source::Half(_) => SampleType::F16,
            Source::Fragment => SampleType::U32,
            Source::Float(_) | Source::Motion(_) | Source::Column(_) => SampleType::F32,
        }
    }
}

/// One channel: its name and where its samples come from.
pub struct Channel<'a> {
    /// The channel's name.
    pub name: String,
    /// Its samples.
    pub source: Source<'a>,
}

/// The channels' list for the header, in EXR's sorted order, with no samples (the header takes
/// only each channel's name and sample type).
pub fn header_channels(channels: &[Channel]) -> AnyChannels<FlatSamples> {
    let list = channels
        .iter()
        .map(|channel| {
            let samples = match channel.source.sample_type() {
                SampleType::F16 => FlatSamples::F16(Vec::new()),
                SampleType::F32 => FlatSamples::F32(Vec::new()),
                SampleType::U32 => FlatSamples::U32(Vec::new()),
            };
            AnyChannel::new(channel.name.as_str(), samples)
        })
        .collect();
    AnyChannels::sort(SmallVec::from_vec(list))
}

/// What the blocks are filled from: the frame's pixels and motion pass, row-major, `width` wide.
pub struct FrameSamples<'a> {
    /// The pixels.
    pub pixels: &'a [Pixel],
    /// The motion pass, one entry per pixel.
    pub motion: &'a [[f32; 4]],
    /// The image's width, pixels.
    pub width: usize,
}

/// The file's bytes: `headers` (one, as the exr crate infers it for these channels) and its blocks
/// filled from `samples` through `channels` (by name), compressed and written in increasing line
/// order, as the crate's image writer writes them.
pub fn exr_bytes(
    headers: SmallVec<[Header; 3]>,
    channels: &[Channel],
    samples: &FrameSamples,
) -> exr::error::Result<Vec<u8>> {
    let header = headers.first().ok_or_else(|| exr::error::Error::Invalid("no header".into()))?;
    let (count, size) = (samples.pixels.len(), header.layer_size);
    if count != size.area() || samples.width != size.width() {
        return Err(exr::error::Error::Invalid(
            format!("{count} pixels for a {} x {} frame", size.width(), size.height()).into(),
        ));
    }
    let short = |source: &Source| matches!(source, Source::Column(values) if values.len() != count);
    if samples.motion.len() != count || channels.iter().any(|channel| short(&channel.source)) {
        return Err(exr::error::Error::Invalid("a pass of another length than the pixels".into()));
    }
    // The sources in the header's channel order.
    let sources: Vec<Source> = header
        .channels
        .list
        .iter()
        .map(|description| {
            let name = description.name.to_string();
            let channel = channels.iter().find(|channel| channel.name == name);
            channel
                .map(|channel| channel.source)
                .ok_or_else(|| exr::error::Error::Invalid("a channel without samples".into()))
        })
        .collect::<exr::error::Result<_>>()?;
    let capacity = header.channels.bytes_per_pixel * samples.pixels.len() + (1 << 16);
    let mut bytes = Cursor::new(Vec::with_capacity(capacity));
    exr::block::write(&mut bytes, headers, true, |meta, writer| {
        let blocks = meta.collect_ordered_block_data(|block| block_bytes(block, &sources, samples));
        for (index, block) in blocks {
            writer.write_chunk(index, UncompressedBlock::compress_to_chunk(block, &meta.headers)?)?;
        }
        Ok(())
    })?;
    Ok(bytes.into_inner())
}

/// One block's uncompressed bytes: for each of its lines, each channel's samples of the line in
/// turn, little-endian.
fn block_bytes(block: BlockIndex, sources: &[Source], samples: &FrameSamples) -> Vec<u8> {
    let (x, y) = (block.pixel_position.x(), block.pixel_position.y());
    let (width, height) = (block.pixel_size.width(), block.pixel_size.height());
    let mut bytes = Vec::with_capacity(width * height * 4 * sources.len());
    for row in y..y + height {
        let start = row * samples.width + x;
        let (pixels, motion) = (&samples.pixels[start..start + width], &samples.motion[start..start + width]);
        for source in sources {
            match *source {
                Source::Half(value) => bytes.extend(pixels.iter().flat_map(|p| f16::from_f32(value(p)).to_le_bytes())),
                Source::Float(value) => bytes.extend(pixels.iter().flat_map(|p| value(p).to_le_bytes())),
                Source::Fragment => bytes.extend(pixels.iter().flat_map(|p| p.fragment.to_le_bytes())),
                Source::Motion(k) => bytes.extend(motion.iter().flat_map(|m| m[k].to_le_bytes())),
                Source::Column(values) => {
                    bytes.extend(values[start..start + width].iter().flat_map(|v| v.to_le_bytes()))
                }
            }
        }
    }
    bytes
}

#[cfg(test)]
mod tests {
    use exr::prelude::{Encoding, Image, Layer, LayerAttributes, LineOrder, WritableImage};
    use shatter_core::random::SplitMix64;

    use super::*;

    /// Random pixels, motion and one column for a `width` x `height` frame.
    fn random_frame(width: usize, height: usize, seed: u64) -> (Vec<Pixel>, Vec<[f32; 4]>, Vec<f32>) {
        let mut random = SplitMix64::new(seed);
        let mut value = move || (random.next_f64() * 8.0 - 4.0) as f32;
        let pixels = (0..width * height)
            .map(|_| Pixel {
                color: [value(), value(), value()],
                depth: value(),
                fragment: value().to_bits(),
                ..Pixel::EMPTY
            })
            .collect();
        let motion = (0..width * height).map(|_| [value(), value(), value(), value()]).collect();
        let column = (0..width * height).map(|_| value()).collect();
        (pixels, motion, column)
    }

    /// On frames whose edges cut the 64-pixel tiles, the blocks filled here make the bytes that the
    /// exr crate's image writer makes of the same channels held as columns.
    #[test]
    fn blocks_make_the_bytes_of_the_crates_image_writer() {
        for (width, height) in [(70, 37), (128, 64), (3, 130)] {
            let (pixels, motion, column) = random_frame(width, height, (width * height) as u64);
            let channels = [
                Channel { name: "R".into(), source: Source::Half(|p| p.color[0]) },
                Channel { name: "G".into(), source: Source::Half(|p| p.color[1]) },
                Channel { name: "Z".into(), source: Source::Float(|p| p.depth) },
                Channel { name: "id".into(), source: Source::Fragment },
                Channel { name: "v.Y".into(), source: Source::Motion(1) },
                Channel { name: "crypto".into(), source: Source::Column(&column) },
            ];
            let encoding = Encoding { line_order: LineOrder::Increasing, ..Encoding::FAST_LOSSLESS };
            let attributes = LayerAttributes::default();
            let layer = Layer::new((width, height), attributes.clone(), encoding, header_channels(&channels));
            let headers = Image::from_layer(layer).write().infer_meta_data();
            let samples = FrameSamples { pixels: &pixels, motion: &motion, width };
            let ours = exr_bytes(headers, &channels, &samples).expect("our blocks");

            let half = |f: fn(&Pixel) -> f32| FlatSamples::F16(pixels.iter().map(|p| f16::from_f32(f(p))).collect());
            let list = vec![
                AnyChannel::new("R", half(|p| p.color[0])),
                AnyChannel::new("G", half(|p| p.color[1])),
                AnyChannel::new("Z", FlatSamples::F32(pixels.iter().map(|p| p.depth).collect())),
                AnyChannel::new("id", FlatSamples::U32(pixels.iter().map(|p| p.fragment).collect())),
                AnyChannel::new("v.Y", FlatSamples::F32(motion.iter().map(|m| m[1]).collect())),
                AnyChannel::new("crypto", FlatSamples::F32(column.clone())),
            ];
            let columns = AnyChannels::sort(SmallVec::from_vec(list));
            let mut theirs = Cursor::new(Vec::new());
            Image::from_layer(Layer::new((width, height), attributes, encoding, columns))
                .write()
                .to_buffered(&mut theirs)
                .expect("the crate's image writer");
            assert_eq!(ours, theirs.into_inner(), "{width} x {height}");
        }
    }

    /// Passes shorter than the frame, or a frame of another size than the header's, are errors,
    /// not a panic.
    #[test]
    fn passes_of_another_length_are_refused() {
        let (pixels, motion, column) = random_frame(8, 4, 1);
        let headers = |width: usize, height: usize, channels: &[Channel]| {
            let encoding = Encoding { line_order: LineOrder::Increasing, ..Encoding::FAST_LOSSLESS };
            let layer = Layer::new((width, height), LayerAttributes::default(), encoding, header_channels(channels));
            Image::from_layer(layer).write().infer_meta_data()
        };
        let short = [Channel { name: "crypto".into(), source: Source::Column(&column[..31]) }];
        let samples = FrameSamples { pixels: &pixels, motion: &motion, width: 8 };
        assert!(exr_bytes(headers(8, 4, &short), &short, &samples).is_err());
        let depth = [Channel { name: "Z".into(), source: Source::Float(|p| p.depth) }];
        assert!(exr_bytes(headers(8, 5, &depth), &depth, &samples).is_err());
        let few = FrameSamples { pixels: &pixels, motion: &motion[..30], width: 8 };
        assert!(exr_bytes(headers(8, 4, &depth), &depth, &few).is_err());
        assert!(exr_bytes(headers(8, 4, &depth), &depth, &samples).is_ok());
    }
}
