//! The floor's filtered albedo at each camera sample's ray, kept from frame to frame. Where a
//! camera ray meets the floor, and its footprint there, depend on the camera, the sample and the
//! floor only, not on what stands in front of the floor; so a render of many frames through one
//! camera filters each sample's floor texels once, and looks the albedo up in later frames. The
//! images are the same, to the bit, with it or without.

use crate::camera::Camera;

/// Most camera samples (pixels times samples per pixel) whose floor albedos are kept: 16 bytes
/// each, 32 MiB in all. Larger images filter each frame's floor afresh.
pub const MAX_KEPT_SAMPLES: usize = 1 << 21;

/// Kept floor albedos, one slot per camera sample's ray: the albedo once looked up.
pub type Slots<'a> = &'a mut [Option<[f32; 3]>];

/// The kept floor albedos of one look's images (the holder keeps one per look).
#[derive(Debug, Default)]
pub struct FloorAlbedos {
    /// The camera and samples per pixel they were looked up for.
    key: Option<(Camera, u32)>,
    /// In the order the image loop traces them: per band of [`crate::image_loop::TILE_ROWS`] rows, per tile of the
    /// band, per sample, per ray of the tile's packet: the albedo once looked up.
    albedo: Vec<Option<[f32; 3]>>,
}

impl FloorAlbedos {
    /// The kept albedos for an image of `camera` at `samples` per pixel (emptied when the camera
    /// or the sample count differs from the last image's); None where none are kept: through a
    /// lens (each sample's ray leaves from its own point of the lens, one at a time), or past
    /// [`MAX_KEPT_SAMPLES`].
    pub(crate) fn slots(&mut self, camera: &Camera, samples: u32) -> Option<Slots<'_>> {
        let count = camera.width as usize * camera.height as usize * samples as usize;
        if camera.lens.is_some() || count > MAX_KEPT_SAMPLES {
            return None;
        }
        if self.key != Some((*camera, samples)) {
            self.key = Some((*camera, samples));
            self.albedo = vec![None; count];
        }
        Some(&mut self.albedo)
    }
}

/// Where a band's kept albedos of one tile's rays at one sample start: after the tiles before
/// it in the band (`left` columns of `rows` rows, each ray with its `samples` samples), then
/// this tile's earlier samples (`count` rays each).
pub(crate) fn tile_slots(left: usize, rows: usize, (sample, samples): (u32, u32), count: usize) -> usize {
    left * rows * samples as usize + sample as usize * count
}
