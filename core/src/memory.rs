//! Memory refused up front: before a stage allocates, its peak memory is estimated from the
//! config and compared with what this process may still allocate; a stage that would not fit
//! is refused with the estimate and the keys that drive it, instead of aborting part way with
//! "memory allocation failed".
//!
//! The estimates are linear models fitted to measured peaks (docs/DECISIONS.md) and err on the
//! high side. A particle count is known from the config alone only for the grid sampler on a
//! box ([`config_needs`]); preprocessing checks a mesh's grid fill once the mesh is loaded. The
//! tet-shell and Voronoi samplers are not estimated yet.

use crate::PipelineConfig;
use crate::config::{GeometrySource, Sampler};

/// What a process needs besides its data: code, thread stacks, allocator slack.
const BASE_BYTES: u64 = 16 << 20;

/// Why a stage was refused.
#[derive(Debug, thiserror::Error)]
#[error(
    "{keys}: {what} would take about {need} of memory, but this process may allocate only about {available}; lower \
     {keys} or run on a larger machine"
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
}

/// Bonds per particle at horizon factor `n`: the lattice sites within a sphere of radius n.
fn bonds_per_particle(n: f64) -> f64 {
    4.0 / 3.0 * std::f64::consts::PI * n.powi(3)
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

/// Preprocessing's peak for `particles` particles at horizon factor `n` (measured: 92 MB for
/// 50,000 cubes at N = 3, 310 MB at N = 6).
pub fn preprocess_bytes(particles: f64, n: f64) -> f64 {
    BASE_BYTES as f64 + particles * (1500.0 + 8.0 * bonds_per_particle(n))
}

/// The simulation's peak (measured: 273 MB for 50,000 cubes at N = 3).
pub fn sim_bytes(particles: f64, bonds_per_particle: f64) -> f64 {
    BASE_BYTES as f64 + particles * (2000.0 + 32.0 * bonds_per_particle)
}

/// Rendering's peak: the scene and its k-d tree, and the image buffers (measured: 241 MB for
/// 50,000 cubes at 480 x 270).
pub fn render_bytes(particles: f64, pixels: f64) -> f64 {
    BASE_BYTES as f64 + particles * 4500.0 + pixels * 200.0
}

/// What the stages of `config` need that the config alone determines: preprocessing and the
/// simulation of a grid-sampled box, the weakened paths' walks, the rendered image.
pub fn config_needs(config: &PipelineConfig) -> Vec<(&'static str, Need)> {
    let mut needs = Vec::new();
    let n = config.geometry.horizon_factor;
    if let Some(particles) = grid_box_particles(config) {
        let keys = "geometry.spacing_m and geometry.horizon_factor";
        let what = format!("preprocessing {particles:.3e} particles");
        needs.push(("preprocess", Need { bytes: preprocess_bytes(particles, n), keys, what }));
        let what = format!("simulating {particles:.3e} particles");
        needs.push(("sim", Need { bytes: sim_bytes(particles, bonds_per_particle(n)), keys, what }));
    }
    let walk_steps: f64 = config.sim.weakened_path.iter().map(|path| f64::from(path.steps)).sum();
    if walk_steps > 0.0 {
        // 24-byte vertices in a growing vector: up to twice that while it grows
        let what = format!("the weakened paths' {walk_steps:.3e} steps");
        needs.push((
            "sim",
            Need { bytes: BASE_BYTES as f64 + 48.0 * walk_steps, keys: "sim.weakened_path[].steps", what },
        ));
    }
    let [width, height] = config.render.resolution;
    let pixels = f64::from(width) * f64::from(height);
    let particles = grid_box_particles(config).unwrap_or(0.0);
    let what = format!("rendering {width} x {height} pixels");
    needs.push(("render", Need { bytes: render_bytes(particles, pixels), keys: "render.resolution", what }));
    needs
}

/// Refuses `need` when it exceeds what this process may allocate; passes when that is unknown.
pub fn check(need: &Need) -> Result<(), MemoryError> {
    match available_bytes() {
        Some(available) if need.bytes > available as f64 => Err(MemoryError {
            keys: need.keys.to_owned(),
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
/// address-space limit (`ulimit -v`) less its size. `None` where none of them can be read.
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
        limits.push(limit.saturating_sub(kib_field(&status, "VmSize:").unwrap_or(0)));
    }
    limits.into_iter().min()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_models_cover_the_measured_peaks() {
        let mib = f64::from(1u32 << 20);
        assert!((90.0..200.0).contains(&(preprocess_bytes(50_000.0, 3.0) / mib)));
        assert!((300.0..500.0).contains(&(preprocess_bytes(50_000.0, 6.0) / mib)));
        assert!((270.0..400.0).contains(&(sim_bytes(50_000.0, bonds_per_particle(3.0)) / mib)));
        assert!((235.0..400.0).contains(&(render_bytes(50_000.0, 480.0 * 270.0) / mib)));
    }

    #[test]
    fn a_need_beyond_any_machine_is_refused_and_a_small_one_passes() {
        if available_bytes().is_none() {
            return; // no way to know on this system: nothing is refused
        }
        let huge = Need { bytes: 1e18, keys: "geometry.spacing_m", what: "preprocessing 1e15 particles".into() };
        let message = check(&huge).expect_err("an exabyte").to_string();
        assert!(message.starts_with("geometry.spacing_m: preprocessing 1e15 particles would take about"), "{message}");
        let small = Need { bytes: 1e6, keys: "geometry.spacing_m", what: "a little".into() };
        assert!(check(&small).is_ok());
    }
}
