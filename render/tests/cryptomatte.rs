//! Cryptomatte, decoded by a decoder written here from the specification (not from the
//! encoder): ids and coverages read back from an EXR's rank layers and named through the header's
//! manifest. For a synthetic scene of two fragments over a floor: the material matte's coverage
//! sums to alpha, the fragment matte's never exceeds it, each fragment's matte is 1 inside its
//! pixels and, at edges, matches the pixel area it covers (a dense grid of primary rays).

use crate::support;

use std::collections::HashMap;

use exr::prelude::{AttributeValue, FlatSamples, read_all_flat_layers_from_file};
use glam::DVec3;
use shatter_core::particles::Elements;
use shatter_render::camera::Camera;
use shatter_render::cryptomatte::{fragment_matte, material_matte};
use shatter_render::frame_review::{RenderedFrame, ReviewPass};
use shatter_render::hit_search::{NONE, closest_hit};
use shatter_render::image_loop::render;
use shatter_render::image_out::{FrameHeader, FrameLayers, write_exr};
use shatter_render::lighting::EnvironmentMap;
use shatter_render::materials::{FloorLook, FloorTexels, Look};
use shatter_render::scene_geometry::SceneGeometry;

const FLOOR_Y: f32 = -0.5;

fn scene() -> SceneGeometry {
    // two unit cubes side by side with a gap, each its own fragment, standing on the floor
    let positions = vec![[-0.7f32, 0.0, 0.0], [0.7, 0.0, 0.3]];
    let elements = Elements::Cubes { half_size_m: vec![0.5; 2], orientation: [0.0, 0.0, 0.0, 1.0] };
    let particles = support::particle_set(positions, elements, 1.0, Vec::new());
    let mut scene = SceneGeometry::build(&particles, None);
    scene.fragment = vec![4, 9];
    scene
}

fn look() -> Look {
    Look {
        albedo: [0.8; 3],
        fracture_albedo: [0.8; 3],
        shininess: 32.0,
        floor: Some(FloorLook {
            height: FLOOR_Y,
            tile: 1.0,
            size: [1, 1],
            texels: FloorTexels::Linear(vec![[0.5; 3]]),
            mips: None,
        }),
        max_bounces: 2,
        opaque_cubes: false,
        ..Look::under(EnvironmentMap::constant([0.5; 3]))
    }
}

/// A decoded Cryptomatte: per pixel, coverage by name.
struct Decoded {
    coverage: Vec<HashMap<String, f32>>,
}

/// Reads the matte named `name` from `path` as the specification lays it out.
fn decode(path: &std::path::Path, name: &str) -> Decoded {
    let image = read_all_flat_layers_from_file(path).expect("EXR reads");
    let layer = &image.layer_data[0];
    let text = |value: &AttributeValue| match value {
        AttributeValue::Text(text) => text.to_string(),
        other => panic!("not text: {other:?}"),
    };
    // find the matte's key through its name entry
    let attributes = &layer.attributes.other;
    let key = attributes
        .iter()
        .find_map(|(attribute, value)| {
            let attribute = attribute.to_string();
            (attribute.starts_with("cryptomatte/") && attribute.ends_with("/name") && text(value) == name)
                .then(|| attribute.trim_end_matches("/name").to_string())
        })
        .expect("the matte is in the header");
    let entry = |field: &str| {
        text(attributes.get(&exr::prelude::Text::from(format!("{key}/{field}").as_str())).expect("entry"))
    };
    assert_eq!(entry("hash"), "MurmurHash3_32");
    assert_eq!(entry("conversion"), "uint32_to_float32");
    let manifest: HashMap<String, String> = serde_json::from_str(&entry("manifest")).expect("manifest JSON");
    let by_bits: HashMap<u32, String> =
        manifest.into_iter().map(|(name, hex)| (u32::from_str_radix(&hex, 16).expect("hex id"), name)).collect();
    let channel = |suffix: &str| {
        let full = format!("{name}{suffix}");
        let found = layer.channel_data.list.iter().find(|c| c.name.to_string() == full).expect("rank channel");
        match &found.sample_data {
            FlatSamples::F32(values) => values.clone(),
            _ => panic!("{full} is not 32-bit float"),
        }
    };
    let pixels = layer.size.0 * layer.size.1;
    let mut coverage = vec![HashMap::new(); pixels];
    let mut layer_index = 0;
    while layer.channel_data.list.iter().any(|c| c.name.to_string() == format!("{name}{layer_index:02}.R")) {
        let rgba: Vec<Vec<f32>> =
            ["R", "G", "B", "A"].iter().map(|c| channel(&format!("{layer_index:02}.{c}"))).collect();
        for (p, cov) in coverage.iter_mut().enumerate() {
            for (id, amount) in [(rgba[0][p], rgba[1][p]), (rgba[2][p], rgba[3][p])] {
                if amount > 0.0 {
                    let name = by_bits.get(&id.to_bits()).expect("every id is in the manifest");
                    *cov.entry(name.clone()).or_insert(0.0) += amount;
                }
            }
        }
        layer_index += 1;
    }
    assert!(layer_index >= 2, "at least 3 rank pairs (2 layers of 2 pairs)");
    Decoded { coverage }
}

#[test]
fn cryptomattes_decode_to_the_covered_areas() {
    let scene = scene();
    let look = look();
    let (width, height, samples) = (48u32, 32u32, 256u32);
    let camera = Camera::look_at(DVec3::new(0.4, 1.2, 4.0), DVec3::new(0.0, -0.1, 0.0), DVec3::Y, 45.0, width, height);
    let rendered = render(&scene, &look, &camera, samples);
    let mattes = [fragment_matte(&rendered.mattes, &[4, 9]), material_matte(&rendered.mattes)];
    let motion = vec![[0.0f32; 4]; rendered.pixels.len()];
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("shot.0001.exr");
    let header = FrameHeader {
        comment: "test".into(),
        world_to_camera: camera.world_to_camera(),
        world_to_ndc: camera.world_to_ndc(),
        frames_per_second: 24.0,
        simulation_time_s: 0.0,
        shutter_s: 0.0,
        lens: None,
    };
    let layers = FrameLayers { pixels: &rendered.pixels, motion: &motion, mattes: &mattes, denoising: false };
    write_exr(&path, width as usize, height as usize, &layers, &header).expect("write");

    let fragments = decode(&path, "ViewLayer.CryptoObject");
    let materials = decode(&path, "ViewLayer.CryptoMaterial");
    let (w, h) = (width as usize, height as usize);
    let (mut interior, mut edges, mut edge_error) = (0, 0, 0.0f64);
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            let alpha = rendered.pixels[p].alpha;
            let total = |d: &Decoded| d.coverage[p].values().sum::<f32>();
            assert!((total(&materials) - alpha).abs() <= 1.0 / 255.0, "({x}, {y}): materials sum to alpha");
            assert!(total(&fragments) <= alpha + 1.0 / 255.0, "({x}, {y}): fragments exceed alpha");
            // the pixel's area, 16 x 16 primary rays: which fragment or the floor each sees
            let mut area: HashMap<String, f32> = HashMap::new();
            for j in 0..16 {
                for i in 0..16 {
                    let d = camera.direction(x as f32 + (i as f32 + 0.5) / 16.0, y as f32 + (j as f32 + 0.5) / 16.0);
                    let hit = closest_hit(&scene, camera.origin, d, 0.0, 0.0);
                    let floor_t = if d[1] < 0.0 { (FLOOR_Y - camera.origin[1]) / d[1] } else { f32::INFINITY };
                    let (fragment, material) = if hit.element != NONE && hit.t < floor_t {
                        (Some(format!("piece_{:05}", scene.fragment[hit.element as usize])), "outer")
                    } else if floor_t.is_finite() {
                        (None, "floor")
                    } else {
                        (None, "")
                    };
                    if let Some(fragment) = fragment {
                        *area.entry(fragment).or_insert(0.0) += 1.0 / 256.0;
                    }
                    if !material.is_empty() {
                        *area.entry(format!("material {material}")).or_insert(0.0) += 1.0 / 256.0;
                    }
                }
            }
            // interior: the id pass shows the same fragment here and in all 8 neighbours
            let id = rendered.pixels[p].fragment;
            let same_around = x > 0 && y > 0 && x + 1 < w && y + 1 < h && id != 0 && {
                (y - 1..=y + 1).all(|j| (x - 1..=x + 1).all(|i| rendered.pixels[j * w + i].fragment == id))
            };
            if same_around {
                interior += 1;
                let name = format!("piece_{:05}", id - 1);
                assert_eq!(
                    fragments.coverage[p].get(&name).copied(),
                    Some(1.0),
                    "({x}, {y}): {name} inside its pixels"
                );
            }
            for name in ["piece_00004", "piece_00009"] {
                let decoded = fragments.coverage[p].get(name).copied().unwrap_or(0.0);
                let expected = area.get(name).copied().unwrap_or(0.0);
                if expected == 1.0 {
                    assert!(decoded > 0.98, "({x}, {y}): {name} covers its whole pixel: {decoded}");
                } else if expected > 0.0 {
                    edges += 1;
                    edge_error += f64::from((decoded - expected).abs());
                    assert!((decoded - expected).abs() < 0.15, "({x}, {y}): {name} {decoded} vs area {expected}");
                } else {
                    assert_eq!(decoded, 0.0, "({x}, {y}): {name} where it is not");
                }
            }
            let floor = materials.coverage[p].get("floor").copied().unwrap_or(0.0);
            let expected_floor = area.get("material floor").copied().unwrap_or(0.0);
            assert!((floor - expected_floor).abs() < 0.15, "({x}, {y}): floor {floor} vs {expected_floor}");
        }
    }
    assert!(interior > 100 && edges > 20, "{interior} interior and {edges} edge pixels");
    let mean = edge_error / edges as f64;
    assert!(mean < 0.03, "mean coverage error at edges {mean}");

    // the review's reader (`shatter preview`) picks what this decoder reads, most covered first,
    // and draws the passes at the frame's size
    let frame = RenderedFrame::read(&path).expect("the review reads the frame");
    for (p, decoded) in fragments.coverage.iter().enumerate() {
        let picked = frame.pick("ViewLayer.CryptoObject", p % w, p / w);
        let as_map: HashMap<String, f32> = picked.iter().cloned().collect();
        assert_eq!(&as_map, decoded, "pixel {p}");
        assert!(picked.windows(2).all(|pair| pair[0].1 >= pair[1].1), "pixel {p}: {picked:?}");
    }
    for pass in ["beauty", "depth", "normal", "motion"] {
        let png = frame.pass_png(ReviewPass::parse(pass).expect("a pass")).expect("the pass's channels");
        let image = image::load_from_memory(&png).expect("a PNG").to_rgb8();
        assert_eq!(image.dimensions(), (width, height), "{pass}");
    }
}
