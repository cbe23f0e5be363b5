//! Memory refused up front: before a stage allocates, its peak memory is estimated from the
//! config and compared with what this process may still allocate; a stage that would not fit
//! is refused with the estimate and the keys that drive it, instead of aborting part way with
//! "memory allocation failed".
//!
//! The estimates are linear models fitted to measured peaks (docs/DECISIONS.md#memory-estimates)
//! and err on the high side. A particle count is known from the config alone only for the grid sampler on a
//! box ([`config_needs`]); preprocessing estimates every sampler's count once the mesh is loaded,
//! and the later stages check their need once the particle file's header and sizes are read
//! ([`load_need`], then [`SetSize::of`]).

use std::path::Path;

use crate::PipelineConfig;
use crate::config::{GeometrySource, Sampler};
use crate::particles::{ElementType, Elements, ParticleSet};

/// What a process needs besides its data: code, thread stacks, allocator slack.
const BASE_BYTES: u64 = 16 << 20;

/// What a process that may open a GPU device needs besides its data: the Vulkan driver's
/// libraries and heaps (measured about 60 MB for Mesa's lavapipe).
const SIM_BASE_BYTES: u64 = 80 << 20;

/// Why a stage was refused.
#[derive(Debug, thiserror::Error)]
#[error(
    "{keys}: {what} would take about {need} of memory, but this process may allocate only about {available}; \
     {advice}, or run on a larger machine"
)]
pub struct MemoryError {
    /// The keys that drive the estimate.
    pub keys: String,
    /// What needs the memory.
    pub what: String,
    /// The estimate, human-readable.
    pub need: String,
    /// What is available, human-readable.
    pub available: String,
    /// Which way to change the keys.
    pub advice: String,
}

/// A stage's estimated peak memory and what drives it.
#[derive(Debug, Clone, PartialEq)]
pub struct Need {
    /// Bytes at the stage's peak.
    pub bytes: f64,
    /// The config keys that drive it, for the message.
    pub keys: &'static str,
    /// What needs it, for the message.
    pub what: String,
    /// Which way to change the keys so that it needs less.
    pub advice: &'static str,
}

/// Neighbours per particle at horizon factor `n` in the bulk of a solid of particles spaced
/// lambda apart: the particles within a sphere of radius n lambda.
pub fn bulk_neighbours(n: f64) -> f64 {
    4.0 / 3.0 * std::f64::consts::PI * n.powi(3)
}

/// The sizes of a particle set that the stages' peaks follow: exact once a particle file is
/// loaded ([`SetSize::of`]), estimated before it exists ([`SetSize::estimated`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SetSize {
    /// What the particles stand for.
    pub element: ElementType,
    /// Particles.
    pub particles: f64,
    /// Bonds per particle (each bond counted at both ends, as the file stores them).
    pub neighbours: f64,
    /// Bytes of the set in memory (about the particle file's size).
    pub bytes: f64,
    /// Surface triangles carried by trimtopes (0 for other elements).
    pub triangles: f64,
}

impl SetSize {
    /// The sizes of a loaded set.
    pub fn of(set: &ParticleSet) -> SetSize {
        fn bytes<T>(rows: &[T]) -> f64 {
            std::mem::size_of_val(rows) as f64
        }
        let (element_bytes, triangles) = match &set.elements {
            Elements::Cubes { half_size_m, .. } => (bytes(half_size_m), 0.0),
            Elements::Tets { vertices_m } => (bytes(vertices_m), 0.0),
            Elements::Trimtopes {
                plane_offsets,
                planes,
                triangle_offsets,
                triangles_m,
                face_offsets,
                face_triangles_m,
                face_planes,
            } => (
                bytes(plane_offsets)
                    + bytes(planes)
                    + bytes(triangle_offsets)
                    + bytes(triangles_m)
                    + bytes(face_offsets)
                    + bytes(face_triangles_m)
                    + bytes(face_planes),
                triangles_m.len() as f64,
            ),
        };
        let bonds = &set.bonds;
        let particles = set.len() as f64;
        SetSize {
            element: set.elements.element_type(),
            particles,
            neighbours: bonds.neighbor.len() as f64 / particles.max(1.0),
            bytes: bytes(&set.rest_position_m)
                + bytes(&set.volume_m3)
                + bytes(&set.mass_kg)
                + element_bytes
                + bytes(&bonds.offsets)
                + bytes(&bonds.neighbor)
                + bytes(&bonds.rest_length_m)
                + bytes(&bonds.threshold)
                + bytes(&set.adjacency),
            triangles,
        }
    }

    /// The sizes of a set of `particles` `element`s with `neighbours` bonds each, before it is
    /// made; trimtopes carry about `triangles` surface triangles.
    pub fn estimated(element: ElementType, particles: f64, neighbours: f64, triangles: f64) -> SetSize {
        let per_element = match element {
            ElementType::Cube => 4.0,
            ElementType::Tet => 48.0,
            // planes and offsets, and the faces' parts inside the mesh as triangles (2.1 to 3.4 kB
            // a cell measured on the dragon)
            ElementType::Trimtope => 2800.0,
        };
        SetSize {
            element,
            particles,
            neighbours,
            // position, volume, mass, adjacency; 12 bytes a bond entry; 36 a triangle
            bytes: particles * (40.0 + per_element + 12.0 * neighbours) + 36.0 * triangles,
            triangles,
        }
    }

    /// Bond entries: bonds counted at both ends.
    fn bond_entries(&self) -> f64 {
        self.particles * self.neighbours
    }
}

/// The keys that drive the size of a particle set, for the messages.
const SET_KEYS: &str = "geometry.spacing_m and geometry.horizon_factor";

/// Which way [`SET_KEYS`] make a set smaller.
const SET_ADVICE: &str = "raise geometry.spacing_m or lower geometry.horizon_factor";

/// Bytes a loaded mesh takes with its queries (bounding-volume hierarchy, winding numbers), per
/// triangle.
pub const MESH_BYTES_PER_TRIANGLE: f64 = 400.0;

/// Preprocessing's peak for `size` with `scratch_bytes` of the sampler's own working memory
/// (the mesh and its queries, candidates). Measured: 92 MB for 50,000 cubes at N = 3 and 310 MB at N = 6; 107, 295 and 702 MB for
/// 43,160, 108,225 and 225,878 tets (110 to 126 bonds each) of a 10,296-triangle vase; 179 to
/// 280 MB for 3,000 to 30,000 trimtopes of a 457,345-triangle dragon.
pub fn preprocess_need(size: &SetSize, scratch_bytes: f64, what: String) -> Need {
    let (per_particle, per_bond) = match size.element {
        ElementType::Cube => (1500.0, 8.0),
        ElementType::Tet => (1500.0, 14.0),
        // trimtopes: cells, their clipped surface and their faces triangulated (measured peaks 215,
        // 326 and 525 MB for 2,988, 10,087 and 30,265 dragon cells)
        ElementType::Trimtope => (14000.0, 12.0),
    };
    let bytes = BASE_BYTES as f64 + scratch_bytes + size.particles * per_particle + size.bond_entries() * per_bond;
    Need { bytes, keys: SET_KEYS, what, advice: SET_ADVICE }
}

/// The simulation's peak: the set, the backend's state and its bond layout (measured: 274 MB for
/// 50,000 cubes with 4.6M bond entries, 272 MB and 1.2 GB for 43,160 and 225,878 tets with 4.8M
/// and 28M, 113 MB for 2,988 trimtopes).
pub fn sim_need(size: &SetSize) -> Need {
    let bytes = SIM_BASE_BYTES as f64 + size.bytes + 1000.0 * size.particles + 22.0 * size.bond_entries();
    Need { bytes, keys: SET_KEYS, what: format!("simulating {:.3e} particles", size.particles), advice: SET_ADVICE }
}

/// Post-processing's peak: the set, fragment surfaces of trimtopes (measured: 80 MB for 50,000
/// cubes, 411 MB for 225,878 tets, 253 MB for 2,988 trimtopes carrying 600,000 triangles).
pub fn post_need(size: &SetSize) -> Need {
    let bytes = 2.0 * BASE_BYTES as f64 + 1.15 * size.bytes + 360.0 * size.triangles;
    let what = format!("finding the fragments of {:.3e} particles", size.particles);
    Need { bytes, keys: SET_KEYS, what, advice: SET_ADVICE }
}

/// Rendering's peak: the scene and its k-d tree, and the image buffers (measured: 217 MB for
/// 50,000 cubes at 480 x 270, 533 MB for 225,878 tets, 168 MB for 2,988 trimtopes). The CPU
/// tracer's kept floor albedos add 16 bytes a camera sample, at most 32 MiB (the default shot:
/// 274 MB measured against this model's 317 MB).
pub fn render_need(size: &SetSize, resolution: [u32; 2]) -> Need {
    let [width, height] = resolution;
    let pixels = f64::from(width) * f64::from(height);
    let per_particle = match size.element {
        ElementType::Tet => 2800.0,
        ElementType::Cube | ElementType::Trimtope => 4500.0,
    };
    // per pixel: the traced pixel and its matte counts, the motion pass, two Cryptomattes' ranks
    // and channels, the EXR's other channels and its encoding (345 bytes measured at 1080p)
    let bytes = SIM_BASE_BYTES as f64 / 2.0 + per_particle * size.particles + 150.0 * size.triangles + 400.0 * pixels;
    Need {
        bytes,
        keys: "geometry.spacing_m and render.resolution",
        advice: "lower render.resolution or raise geometry.spacing_m",
        what: format!("rendering {:.3e} particles at {width} x {height} pixels", size.particles),
    }
}

/// What reading the stage file at `path` needs: what it holds, about its size.
pub fn load_need(path: &Path) -> Need {
    let bytes = std::fs::metadata(path).map_or(0.0, |meta| meta.len() as f64);
    let what = format!("reading {}", path.display());
    Need { bytes: BASE_BYTES as f64 + bytes, keys: SET_KEYS, what, advice: SET_ADVICE }
}

/// The particle count of a grid-sampled box, before preprocessing: None for other geometry, and
/// for counts beyond the particle file's limit (preprocessing refuses those with its own message).
fn grid_box_particles(config: &PipelineConfig) -> Option<f64> {
    let geometry = &config.geometry;
    match (&geometry.source, geometry.sampler, geometry.box_size_m) {
        (GeometrySource::Box, Sampler::Grid, Some(size)) => {
            let particles: f64 = size.iter().map(|side| (side / geometry.spacing_m).round().max(1.0)).product();
            (particles <= f64::from(u32::MAX)).then_some(particles)
        }
        _ => None,
    }
}

/// What the stages of `config` need that the config alone determines: every stage of a
/// grid-sampled box, the weakened paths' walks, the rendered image. Stages on a mesh are checked
/// again once their particle count is known (preprocessing once the mesh is loaded, later stages
/// once the particle file is).
pub fn config_needs(config: &PipelineConfig) -> Vec<(&'static str, Need)> {
    let mut needs = Vec::new();
    let box_size = grid_box_particles(config).map(|particles| {
        SetSize::estimated(ElementType::Cube, particles, bulk_neighbours(config.geometry.horizon_factor), 0.0)
    });
    if let Some(size) = &box_size {
        let what = format!("preprocessing {:.3e} particles", size.particles);
        needs.push(("preprocess", preprocess_need(size, 0.0, what)));
        needs.push(("sim", sim_need(size)));
        needs.push(("post", post_need(size)));
    }
    let walk_steps: f64 = config.sim.weakened_path.iter().map(|path| f64::from(path.steps)).sum();
    if walk_steps > 0.0 {
        // 24-byte vertices in a growing vector: up to twice that while it grows
        let what = format!("the weakened paths' {walk_steps:.3e} steps");
        needs.push((
            "sim",
            Need {
                bytes: BASE_BYTES as f64 + 48.0 * walk_steps,
                keys: "sim.weakened_path[].steps",
                what,
                advice: "lower sim.weakened_path[].steps",
            },
        ));
    }
    let size = box_size.unwrap_or_else(|| SetSize::estimated(ElementType::Cube, 0.0, 0.0, 0.0));
    needs.push(("render", render_need(&size, config.render.resolution)));
    needs
}

/// Refuses `need` when it exceeds what this process may allocate; passes when that is unknown.
pub fn check(need: &Need) -> Result<(), MemoryError> {
    match available_bytes() {
        Some(available) if need.bytes > available as f64 => Err(MemoryError {
            keys: need.keys.to_owned(),
            advice: need.advice.to_owned(),
            what: need.what.clone(),
            need: human(need.bytes),
            available: human(available as f64),
        }),
        _ => Ok(()),
    }
}

fn human(bytes: f64) -> String {
    let gib = bytes / f64::from(1u32 << 30);
    if gib >= 1.0 { format!("{gib:.1} GiB") } else { format!("{:.0} MiB", bytes / f64::from(1u32 << 20)) }
}

/// Bytes this process may still allocate: the least of the system's available memory
/// (`MemAvailable`), its control group's limit less its usage (cgroup v2 and v1), and its
/// address-space limit (`ulimit -v`) less its size and the heap arenas its threads will reserve.
/// `None` where none of them can be read.
pub fn available_bytes() -> Option<u64> {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    let number = |text: Option<String>| text.and_then(|t| t.trim().parse::<u64>().ok());
    let kib_field = |text: &str, field: &str| {
        text.lines()
            .find_map(|line| line.strip_prefix(field))
            .and_then(|rest| rest.split_whitespace().next())
            .and_then(|kib| kib.parse::<u64>().ok())
            .map(|kib| kib * 1024)
    };
    let mut limits = Vec::new();
    if let Some(meminfo) = read("/proc/meminfo") {
        limits.extend(kib_field(&meminfo, "MemAvailable:"));
    }
    let group = read("/proc/self/cgroup")
        .and_then(|text| text.lines().find_map(|line| line.strip_prefix("0::").map(str::to_owned)))
        .unwrap_or_default();
    let v2 = format!("/sys/fs/cgroup{}", group.trim_end_matches('/'));
    let cgroups = [
        (format!("{v2}/memory.max"), format!("{v2}/memory.current")),
        (
            "/sys/fs/cgroup/memory/memory.limit_in_bytes".to_owned(),
            "/sys/fs/cgroup/memory/memory.usage_in_bytes".to_owned(),
        ),
    ];
    for (limit, usage) in cgroups {
        if let (Some(limit), Some(usage)) = (number(read(&limit)), number(read(&usage))) {
            limits.push(limit.saturating_sub(usage));
        }
    }
    let address_space = read("/proc/self/limits").and_then(|text| {
        text.lines()
            .find_map(|line| line.strip_prefix("Max address space"))
            .and_then(|rest| rest.split_whitespace().next())
            .and_then(|soft| soft.parse::<u64>().ok())
    });
    if let (Some(limit), Some(status)) = (address_space, read("/proc/self/status")) {
        // Address space is reserved ahead of use: glibc reserves a 64 MiB heap arena for each
        // thread that allocates (measured: a sim whose heap fitted 214 MiB of headroom failed).
        let arenas = (64u64 << 20) * rayon::current_num_threads() as u64;
        limits.push(limit.saturating_sub(kib_field(&status, "VmSize:").unwrap_or(0)).saturating_sub(arenas));
    }
    limits.into_iter().min()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A measured case: the loaded set's sizes, the mesh's triangles, and the peaks (KiB, from
    /// `/usr/bin/time -f %M`, release build, 2-core AMD EPYC) of preprocess, sim, post and render
    /// at 480 x 270 (0 where not measured).
    struct Measured {
        name: &'static str,
        size: SetSize,
        mesh_triangles: f64,
        peaks_kib: [f64; 4],
    }

    fn measured() -> Vec<Measured> {
        let case = |name, element, particles, neighbours, bytes, triangles, mesh_triangles, peaks_kib| Measured {
            name,
            size: SetSize { element, particles, neighbours, bytes, triangles },
            mesh_triangles,
            peaks_kib,
        };
        use ElementType::{Cube, Tet, Trimtope};
        vec![
            case("pipeline.toml", Cube, 50_000.0, 91.8, 57.8e6, 0.0, 0.0, [95_324.0, 273_988.0, 80_420.0, 217_248.0]),
            case(
                "vase_small",
                Tet,
                43_160.0,
                110.4,
                61.1e6,
                0.0,
                10_296.0,
                [107_568.0, 272_492.0, 76_532.0, 163_144.0],
            ),
            case("vase 4 mm", Tet, 108_225.0, 117.0, 161.8e6, 0.0, 10_296.0, [295_252.0, 0.0, 0.0, 0.0]),
            case(
                "vase 3 mm",
                Tet,
                225_878.0,
                125.7,
                361.2e6,
                0.0,
                10_296.0,
                [702_088.0, 1_215_856.0, 410_944.0, 532_856.0],
            ),
            case(
                "dragon_small",
                Trimtope,
                2_988.0,
                246.0,
                42.6e6,
                625_778.0,
                457_345.0,
                [214_528.0, 113_424.0, 253_068.0, 168_416.0],
            ),
            case(
                "dragon 10,000 N=3",
                Trimtope,
                10_087.0,
                56.4,
                61.7e6,
                732_646.0,
                457_345.0,
                [325_992.0, 0.0, 0.0, 0.0],
            ),
            case(
                "dragon 30,000 N=3",
                Trimtope,
                30_265.0,
                62.2,
                128.7e6,
                888_390.0,
                457_345.0,
                [525_280.0, 186_444.0, 386_044.0, 235_196.0],
            ),
        ]
    }

    #[test]
    fn the_models_cover_the_measured_peaks_without_refusing_twice_as_much() {
        for case in measured() {
            let size = &case.size;
            let needs = [
                preprocess_need(size, MESH_BYTES_PER_TRIANGLE * case.mesh_triangles, String::new()),
                sim_need(size),
                post_need(size),
                render_need(size, [480, 270]),
            ];
            for (stage, (need, peak_kib)) in
                ["preprocess", "sim", "post", "render"].iter().zip(needs.iter().zip(case.peaks_kib))
            {
                if peak_kib == 0.0 {
                    continue;
                }
                let ratio = need.bytes / (peak_kib * 1024.0);
                assert!(
                    (1.0..2.0).contains(&ratio),
                    "{} {stage}: the model is {ratio:.2} x the measured peak",
                    case.name
                );
            }
        }
    }

    #[test]
    fn an_estimated_set_is_about_as_large_as_the_loaded_one() {
        for case in measured() {
            let size = &case.size;
            let estimate = SetSize::estimated(size.element, size.particles, size.neighbours, size.triangles);
            let ratio = estimate.bytes / size.bytes;
            assert!((0.9..1.25).contains(&ratio), "{}: {ratio:.2}", case.name);
        }
    }

    #[test]
    fn a_need_beyond_any_machine_is_refused_and_a_small_one_passes() {
        if available_bytes().is_none() {
            return; // no way to know on this system: nothing is refused
        }
        let what = "preprocessing 1e15 particles".into();
        let huge = Need { bytes: 1e18, keys: "geometry.spacing_m", what, advice: "raise geometry.spacing_m" };
        let message = check(&huge).expect_err("an exabyte").to_string();
        assert!(message.starts_with("geometry.spacing_m: preprocessing 1e15 particles would take about"), "{message}");
        let small = Need { bytes: 1e6, keys: "geometry.spacing_m", what: "a little".into(), advice: "" };
        assert!(check(&small).is_ok());
    }
}
