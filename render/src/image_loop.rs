//! The image loop: every pixel of a camera's image traced with its samples, in bands of rows in
//! parallel and tiles whose camera rays find their first surfaces as one packet; and the pixels'
//! nearest hits without shading. The twin of `shaders/image_loop.wgsl` (one pixel per
//! invocation there).

use rayon::iter::Either;
use rayon::prelude::*;

use crate::camera::{Camera, concentric_disk};
use crate::floor_albedos::{FloorAlbedos, Slots, tile_slots};
use crate::hit_search::{Hit, closest_hit, closest_hits};
use crate::integrator::{CameraRay, FirstSurface, Pixel, first_layers, trace_ray};
use crate::materials::Look;
use crate::mattes::MatteCounts;
use crate::packet_traversal::PACKET;
use crate::primitives::along;
use crate::sampling::{lens_sample, sample_offset, sample_time};
use crate::scene_geometry::SceneGeometry;
use crate::shading::{floor_albedo, floor_t};
use crate::texture_filter::Footprint;

/// A rendered image: its pixels (row-major, top row first) and their matte counts.
#[derive(Debug, Clone, PartialEq)]
pub struct Rendered {
    /// The pixels.
    pub pixels: Vec<Pixel>,
    /// Each pixel's matte counts over its samples.
    pub mattes: Vec<MatteCounts>,
}

/// The floor's albedo where each camera ray of a packet meets it, for those that meet it before
/// their nearest hit (`hits`); the others' are left as they are. Looked up in one pass, the
/// texel loads of a packet overlap, where each ray's trace would otherwise wait on its own. The
/// rays' cones spread `spread_rad` (the pixel's angle). With `kept` (one slot per ray, see
/// [`FloorAlbedos`]), a ray's albedo is read from its slot once looked up, and kept there.
fn first_floor_albedos(
    look: &Look,
    (origin, spread_rad): ([f32; 3], f32),
    (directions, hits): (&[[f32; 3]], &[Hit]),
    out: &mut [[f32; 3]],
    mut kept: Option<Slots>,
) {
    for (k, ((d, hit), albedo)) in directions.iter().zip(hits).zip(out).enumerate() {
        let t_floor = floor_t(look, origin, *d);
        if t_floor < hit.t {
            let footprint = Footprint { direction: *d, width_m: spread_rad * t_floor };
            let look_up = || floor_albedo(look, along(origin, *d, t_floor), footprint);
            *albedo = match kept.as_deref_mut() {
                Some(kept) => *kept[k].get_or_insert_with(look_up),
                None => look_up(),
            };
        }
    }
}

/// Traces every pixel of `camera`'s image with `samples` samples each (the first through the
/// pixel centre gives the depth, normal and fragment layers), counting each sample's first
/// surface in the pixel's mattes. Bands of [`TILE_ROWS`] rows in parallel; each sample's camera
/// rays of a tile find their first surfaces as one packet. Deterministic: each
/// pixel's samples are summed in order, whatever the bands and threads.
///
/// With the scene's motion over an open shutter, each sample's ray is traced at its own time
/// ([`sample_time`]) for the colour and coverage; the layers and mattes are those of the same
/// rays at the frame's centre. Through a thin lens, each sample's ray leaves its own point of
/// the lens ([`lens_sample`]), one at a time; the mattes count those rays, and the layers are
/// the pinhole's ray's through the pixel centre.
pub fn render(scene: &SceneGeometry, look: &Look, camera: &Camera, samples: u32) -> Rendered {
    render_keeping(scene, look, camera, samples, None)
}

/// [`render`], reading the floor's albedo of each camera sample from `floor` where an earlier
/// image of the same camera looked it up, and keeping there those it looks up (the same images,
/// to the bit).
pub fn render_keeping(
    scene: &SceneGeometry,
    look: &Look,
    camera: &Camera,
    samples: u32,
    floor: Option<&mut FloorAlbedos>,
) -> Rendered {
    let (width, height) = (camera.width as usize, camera.height as usize);
    let mut pixels = vec![Pixel::EMPTY; width * height];
    let mut mattes = vec![MatteCounts::default(); width * height];
    let band = width * TILE_ROWS;
    let kept = match floor.and_then(|floor| floor.slots(camera, samples)) {
        Some(slots) => Either::Left(slots.par_chunks_mut(band * samples as usize).map(Some)),
        None => Either::Right((0..height.div_ceil(TILE_ROWS)).into_par_iter().map(|_| None)),
    };
    let bands = pixels.par_chunks_mut(band).zip(mattes.par_chunks_mut(band)).zip(kept);
    bands.enumerate().for_each(|(b, ((rows, matte_rows), mut kept))| {
        let top = b * TILE_ROWS;
        let mut packet = Packet::default();
        for tile in Tile::across(width, top, rows.len() / width) {
            let count = tile.len();
            packet.sums[..count].fill(Sums::default());
            for sample in 0..samples {
                let start = tile_slots(tile.left, tile.height, (sample, samples), count);
                let slots = kept.as_deref_mut().map(|kept| &mut kept[start..start + count]);
                packet.trace(scene, look, camera, tile, ((sample, samples), slots));
                for k in 0..count {
                    let (x, y) = tile.pixel(k);
                    let local = (y - top) * width + x;
                    if sample == 0 {
                        rows[local] = if camera.lens.is_some() { packet.pinhole[k] } else { packet.layers[k] };
                    }
                    matte_rows[local].add(packet.layers[k].fragment, packet.layers[k].surface);
                }
            }
            for k in 0..count {
                let (x, y) = tile.pixel(k);
                packet.sums[k].average_into(&mut rows[(y - top) * width + x], samples);
            }
        }
    });
    Rendered { pixels, mattes }
}

/// A tile's camera rays of one sample, and its pixels' sums so far.
struct Packet {
    directions: [[f32; 3]; PACKET],
    /// Each ray's nearest hit at the frame's centre.
    hits: [Hit; PACKET],
    /// With motion over the shutter: each ray's time, and its nearest hit then.
    times: [f32; PACKET],
    moved_hits: [Hit; PACKET],
    floor_albedos: [[f32; 3]; PACKET],
    /// Each ray's first-surface layers (at the frame's centre).
    layers: [Pixel; PACKET],
    /// Through a lens, the layers of the pinhole's rays through the pixel centres.
    pinhole: [Pixel; PACKET],
    sums: [Sums; PACKET],
}

/// A pixel's sums over its samples of what is averaged: colour, alpha and the denoising guides.
#[derive(Debug, Default, Clone, Copy)]
struct Sums {
    color: [f32; 3],
    alpha: f32,
    albedo: [f32; 3],
    normal: [f32; 3],
}

impl Sums {
    /// Adds one sample.
    fn add(&mut self, traced: &Pixel) {
        for k in 0..3 {
            self.color[k] += traced.color[k];
            self.albedo[k] += traced.denoising_albedo[k];
            self.normal[k] += traced.denoising_normal[k];
        }
        self.alpha += traced.alpha;
    }

    /// Writes the averages of `samples` samples into `out`.
    fn average_into(&self, out: &mut Pixel, samples: u32) {
        let n = samples as f32;
        out.color = self.color.map(|v| v / n);
        out.alpha = self.alpha / n;
        out.denoising_albedo = self.albedo.map(|v| v / n);
        out.denoising_normal = self.normal.map(|v| v / n);
    }
}

impl Default for Packet {
    fn default() -> Packet {
        Packet {
            directions: [[0.0; 3]; PACKET],
            hits: [Hit::MISS; PACKET],
            times: [0.0; PACKET],
            moved_hits: [Hit::MISS; PACKET],
            floor_albedos: [[0.0; 3]; PACKET],
            layers: [Pixel::EMPTY; PACKET],
            pinhole: [Pixel::EMPTY; PACKET],
            sums: [Sums::default(); PACKET],
        }
    }
}

impl Packet {
    /// Traces sample `sample` (of `samples`) of `tile`'s rays: adds each one's colour, coverage
    /// and denoising guides to the sums and leaves its layers; `kept` holds the rays' kept floor
    /// albedos, if any.
    fn trace(
        &mut self,
        scene: &SceneGeometry,
        look: &Look,
        camera: &Camera,
        tile: Tile,
        (sample, kept): ((u32, u32), Option<Slots>),
    ) {
        if camera.lens.is_some() {
            self.trace_through_lens(scene, look, camera, tile, sample);
            return;
        }
        let count = tile.len();
        let origin = camera.origin;
        tile.first_hits(scene, camera, sample, &mut self.directions, &mut self.hits);
        let moving = scene.motion.as_ref().map(|motion| {
            for (k, time) in self.times[..count].iter_mut().enumerate() {
                let (x, y) = tile.pixel(k);
                *time = sample_time((y * camera.width as usize + x) as u32, sample.0, motion.shutter);
            }
            let times = Some(&self.times[..count]);
            closest_hits(scene, origin, &self.directions[..count], times, &mut self.moved_hits[..count]);
            &self.moved_hits
        });
        let hits = moving.unwrap_or(&self.hits);
        let cone = (origin, camera.pixel_spread_rad());
        let rays = (&self.directions[..count], &hits[..count]);
        first_floor_albedos(look, cone, rays, &mut self.floor_albedos, kept);
        for (k, &hit) in hits[..count].iter().enumerate() {
            let (x, y) = tile.pixel(k);
            let pixel = (y * camera.width as usize + x) as u32;
            let (direction, floor_albedo) = (self.directions[k], self.floor_albedos[k]);
            let time = if moving.is_some() { self.times[k] } else { 0.0 };
            let ray = CameraRay { origin, direction, pixel, sample: sample.0, time, spread_rad: cone.1 };
            let traced = trace_ray(scene, look, ray, FirstSurface { hit, floor_albedo });
            self.layers[k] =
                if moving.is_some() { first_layers(scene, look, origin, direction, self.hits[k]) } else { traced };
            self.sums[k].add(&traced);
        }
    }
}

impl Packet {
    /// [`Packet::trace`] through a thin lens: each ray from its own point of the lens, alone.
    fn trace_through_lens(
        &mut self,
        scene: &SceneGeometry,
        look: &Look,
        camera: &Camera,
        tile: Tile,
        sample: (u32, u32),
    ) {
        let shutter = scene.motion.as_ref().map(|motion| motion.shutter);
        for k in 0..tile.len() {
            let (x, y) = tile.pixel(k);
            let pixel = (y * camera.width as usize + x) as u32;
            let (jx, jy) = sample_offset(pixel, sample.0, sample.1);
            let (u, v) = lens_sample(pixel, sample.0);
            let (origin, direction) = camera.lens_ray(x as f32 + jx, y as f32 + jy, concentric_disk(u, v));
            let centre = closest_hit(scene, origin, direction, 0.0, 0.0);
            self.layers[k] = first_layers(scene, look, origin, direction, centre);
            let time = shutter.map_or(0.0, |shutter| sample_time(pixel, sample.0, shutter));
            let hit = if time == 0.0 { centre } else { closest_hit(scene, origin, direction, 0.0, time) };
            let mut floor_albedo = [0.0; 3];
            let cone = (origin, camera.pixel_spread_rad());
            first_floor_albedos(look, cone, (&[direction], &[hit]), std::slice::from_mut(&mut floor_albedo), None);
            let ray = CameraRay { origin, direction, pixel, sample: sample.0, time, spread_rad: cone.1 };
            self.sums[k].add(&trace_ray(scene, look, ray, FirstSurface { hit, floor_albedo }));
        }
        if sample.0 == 0 {
            tile.first_hits(scene, camera, (0, 1), &mut self.directions, &mut self.hits);
            for k in 0..tile.len() {
                self.pinhole[k] = first_layers(scene, look, camera.origin, self.directions[k], self.hits[k]);
            }
        }
    }
}

/// A tile of image pixels: `width` columns from `left`, `height` rows from `top`; its rays are
/// numbered row by row.
#[derive(Clone, Copy)]
struct Tile {
    left: usize,
    top: usize,
    width: usize,
    height: usize,
}

impl Tile {
    /// The tiles of the band of `height` rows from `top` across an image `image_width` wide.
    fn across(image_width: usize, top: usize, height: usize) -> impl Iterator<Item = Tile> {
        (0..image_width).step_by(PACKET / TILE_ROWS).map(move |left| Tile {
            left,
            top,
            width: (PACKET / TILE_ROWS).min(image_width - left),
            height,
        })
    }

    /// Number of rays.
    fn len(&self) -> usize {
        self.width * self.height
    }

    /// Image column and row of ray `k`.
    fn pixel(&self, k: usize) -> (usize, usize) {
        (self.left + k % self.width, self.top + k / self.width)
    }

    /// Sample `sample` (of `samples`) of the tile's camera rays, into `directions`, and each
    /// one's nearest hit, into `hits`, as one packet.
    fn first_hits(
        &self,
        scene: &SceneGeometry,
        camera: &Camera,
        (sample, samples): (u32, u32),
        directions: &mut [[f32; 3]; PACKET],
        hits: &mut [Hit; PACKET],
    ) {
        let count = self.len();
        for (k, direction) in directions[..count].iter_mut().enumerate() {
            let (x, y) = self.pixel(k);
            let (jx, jy) = sample_offset((y * camera.width as usize + x) as u32, sample, samples);
            *direction = camera.direction(x as f32 + jx, y as f32 + jy);
        }
        closest_hits(scene, camera.origin, &directions[..count], None, &mut hits[..count]);
    }
}

/// Rows of the tiles whose camera rays [`render`] and [`pixel_hits`] trace as one packet
/// ([`PACKET`] / `TILE_ROWS` columns each).
pub const TILE_ROWS: usize = 2;

/// The nearest element surface along each pixel's centre ray (row-major, top row first), each
/// exactly what [`crate::hit_search::closest_hit`] gives it, traced in packets as [`render`] traces first surfaces:
/// what a ray-casting query answers, without shading.
pub fn pixel_hits(scene: &SceneGeometry, camera: &Camera) -> Vec<Hit> {
    let width = camera.width as usize;
    let mut hits = vec![Hit::MISS; width * camera.height as usize];
    hits.par_chunks_mut(width * TILE_ROWS).enumerate().for_each(|(b, rows)| {
        let (top, mut directions, mut tile_hits) = (b * TILE_ROWS, [[0.0f32; 3]; PACKET], [Hit::MISS; PACKET]);
        for tile in Tile::across(width, top, rows.len() / width) {
            // sample 0 of 1 goes through the pixel's centre
            tile.first_hits(scene, camera, (0, 1), &mut directions, &mut tile_hits);
            for (k, hit) in tile_hits[..tile.len()].iter().enumerate() {
                let (x, y) = tile.pixel(k);
                rows[(y - top) * width + x] = *hit;
            }
        }
    });
    hits
}
