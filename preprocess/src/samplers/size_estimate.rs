//! How large a sample will be, before it is made: the particle count and bonds per particle each
//! sampler makes of a mesh, from its volume and area alone, so that preprocessing can refuse a
//! spacing whose particles would not fit in memory before it allocates them
//! ([`shatter_core::memory`]).
//!
//! The estimates lean high, but not by much: a refused run must really not have fitted. The test
//! below holds them against the counts of the shipped scenes.

use shatter_core::config::{GeometryConfig, Sampler};
use shatter_core::memory::{self, SetSize};
use shatter_core::particles::ElementType;

use crate::samplers::blue_noise::POISSON_DENSITY;

/// Points the thinning keeps per `r^2` of a layer's area (measured about 0.6; see
/// [`super::tet_shell::CANDIDATE_DENSITY`]).
const LAYER_POINTS_PER_AREA: f64 = 0.6;

/// Tets per point of a layered point set, between the layers (a random 3D point set has about
/// 6.5; the kept shell tets of the vase came to 4.2 to 5.0 per point of a layer pair).
const TETS_PER_POINT: f64 = 5.8;

/// Tets per point of a filled core (Delaunay of random points).
const CORE_TETS_PER_POINT: f64 = 6.5;

/// Bytes of a tet-shell candidate while its layer is thinned (point, normal, order).
const CANDIDATE_BYTES: f64 = 64.0;

/// What a mesh of `volume_m3` and `area_m2` enclosing `mesh_triangles` triangles turns into under
/// `geometry`'s sampler, and the sampler's working memory besides the particles (the mesh and its
/// queries, the tet shell's candidates), bytes.
pub fn estimate(geometry: &GeometryConfig, volume_m3: f64, area_m2: f64, mesh_triangles: f64) -> (SetSize, f64) {
    let r = geometry.spacing_m;
    let n = geometry.horizon_factor;
    let mesh_bytes = memory::MESH_BYTES_PER_TRIANGLE * mesh_triangles;
    // particles spread over `occupied_m3`, bonded to those within n lambda
    let neighbours = |particles: f64, occupied_m3: f64, lambda: f64, thickness: f64| {
        let delta = n * lambda;
        let sphere = 4.0 / 3.0 * std::f64::consts::PI * delta.powi(3);
        // a shell thinner than the horizon holds less of the sphere: a slab twice its thickness
        let slab = 2.0 * std::f64::consts::PI * delta * delta * thickness;
        (particles / occupied_m3.max(f64::MIN_POSITIVE) * sphere.min(slab)).min((particles - 1.0).max(0.0))
    };
    match geometry.sampler {
        Sampler::Grid => {
            let particles = volume_m3 / r.powi(3);
            let size = SetSize::estimated(ElementType::Cube, particles, memory::bulk_neighbours(n).min(particles), 0.0);
            (size, mesh_bytes)
        }
        Sampler::Voronoi => {
            let particles = match geometry.voronoi.particles {
                Some(count) => count as f64,
                None => POISSON_DENSITY * volume_m3 / r.powi(3),
            };
            let lambda = (volume_m3 / particles.max(1.0)).cbrt();
            let bonds = neighbours(particles, volume_m3, lambda, f64::INFINITY);
            // every mesh triangle survives, cut into pieces by the cells
            let size = SetSize::estimated(ElementType::Trimtope, particles, bonds, 2.0 * mesh_triangles);
            (size, mesh_bytes)
        }
        Sampler::TetShell => {
            let layers = f64::from(geometry.tet_shell_layers());
            let h = geometry.tet_shell_layer_spacing_m();
            let layer_points = LAYER_POINTS_PER_AREA * area_m2 / (r * r);
            let shell_m3 = (area_m2 * (layers - 1.0) * h).min(volume_m3);
            let (particles, occupied_m3) = if geometry.tet_shell.filled_core {
                let core_points = POISSON_DENSITY * (volume_m3 - shell_m3).max(0.0) / r.powi(3);
                (TETS_PER_POINT * layer_points * layers + CORE_TETS_PER_POINT * core_points, volume_m3)
            } else {
                (TETS_PER_POINT * layer_points * (layers - 1.0), shell_m3)
            };
            let thickness = if geometry.tet_shell.filled_core { f64::INFINITY } else { volume_m3 / area_m2 };
            let bonds = neighbours(particles, occupied_m3, r, thickness);
            let candidates = super::tet_shell::CANDIDATE_DENSITY * area_m2 / (r * r);
            let size = SetSize::estimated(ElementType::Tet, particles, bonds, 0.0);
            (size, mesh_bytes + CANDIDATE_BYTES * candidates)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shatter_core::config::PipelineConfig;

    /// The vase (volume and area of `smooth_vase.obj`) and the dragon (`dragon_small`'s volume,
    /// 457,345 triangles) as the shipped scenes and finer variants sample them, with the counts
    /// and bonds per particle preprocessing made.
    #[test]
    fn the_estimates_cover_the_measured_counts_within_a_factor_of_two() {
        let vase = |spacing: f64| {
            format!(
                "[geometry]\nsource = \"box\"\nbox_size_m = [1.0, 1.0, 1.0]\nsampler = \"tet_shell\"\nspacing_m = {spacing}\n\
                 horizon_factor = 2.0\n[geometry.tet_shell]\nlayers = 3\nlayer_spacing_m = 0.0015\n"
            )
        };
        let dragon = |particles: u32, n: f64| {
            format!(
                "[geometry]\nsource = \"box\"\nbox_size_m = [1.0, 1.0, 1.0]\nsampler = \"voronoi\"\nspacing_m = 0.004\n\
                 horizon_factor = {n}\n[geometry.voronoi]\nparticles = {particles}\n"
            )
        };
        let cases = [
            (vase(0.006), 0.000963, 0.3465, 10_296.0, 43_160.0, 110.4),
            (vase(0.004), 0.000963, 0.3465, 10_296.0, 108_225.0, 117.0),
            (vase(0.003), 0.000963, 0.3465, 10_296.0, 225_878.0, 125.7),
            (dragon(3_000, 6.0), 0.000216, 0.0, 457_345.0, 2_988.0, 246.0),
            (dragon(10_000, 3.0), 0.000216, 0.0, 457_345.0, 10_087.0, 56.4),
            (dragon(30_000, 3.0), 0.000216, 0.0, 457_345.0, 30_265.0, 62.2),
        ];
        for (text, volume, area, triangles, particles, bonds) in cases {
            let text = format!(
                "[scene]\nname = \"t\"\noutput_dir = \"out\"\nseed = 1\n[material]\ndensity_kg_m3 = 2200.0\n\
                 bulk_modulus_pa = 2.94e9\n{text}"
            );
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../pipeline.toml");
            let config = PipelineConfig::from_toml_str(&text, &path).expect("config");
            let (size, _) = estimate(&config.geometry, volume, area, triangles);
            let particle_ratio = size.particles / particles;
            let bytes_ratio = size.particles * size.neighbours / (particles * bonds);
            assert!((0.95..2.0).contains(&particle_ratio), "{text}: {particle_ratio:.2} x the particles");
            assert!((0.95..4.0).contains(&bytes_ratio), "{text}: {bytes_ratio:.2} x the bonds");
        }
    }
}
