//! The grid sampler (the paper's glass plate): cubes of side lambda on a regular lattice, filling
//! a box or the inside of a closed mesh; adjacent cubes share a face.

use glam::DVec3;
use shatter_core::Progress;
use shatter_core::config::PipelineConfig;
use shatter_core::particles::{Elements, ParticleSet};

use crate::inside::{FillRule, InsideCells, inside_cells};
use crate::lattice::Lattice;
use crate::order::morton_code;
use crate::preprocess_driver::PreprocessError;
use crate::samplers::particle_assembly::{Placement, Sampled, assemble};
use shatter_geometry::mesh::TriangleMesh;

/// The largest lattice (in cells, filled or not) the grid sampler will allocate.
pub const MAX_LATTICE_CELLS: usize = 1 << 32;
/// Morton codes interleave 21 bits per axis.
const MAX_CELLS_PER_AXIS: usize = 1 << 21;

/// Why a grid cannot be made at the requested spacing.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum GridError {
    /// The lattice would be too large: the message says how large.
    TooLarge(String),
}

/// Particles on a lattice.
#[derive(Debug, Clone, PartialEq)]
pub struct GridSample {
    /// The lattice the particles sit on (in the sampling frame).
    pub lattice: Lattice,
    /// Each particle's cell, in Morton (Z-curve) order for memory locality.
    pub cells: Vec<[usize; 3]>,
    /// Particles whose cubes share a face: (a, b) with a < b, sorted.
    pub adjacency: Vec<[u32; 2]>,
}

impl GridSample {
    /// Cell centres in the sampling frame.
    pub fn points(&self) -> Vec<DVec3> {
        self.cells.iter().map(|&cell| self.lattice.centre(cell)).collect()
    }
}

/// Fills a box of `size` (centred on the origin) with cubes of side `spacing`. The box is snapped
/// to a whole number of cubes per axis (at least one); returns the sample and the snapped size.
pub fn fill_box(size: [f64; 3], spacing: f64) -> Result<(GridSample, [f64; 3]), GridError> {
    let counts = size.map(|extent| (extent / spacing).round().max(1.0));
    check_size(counts.map(|n| n as usize))?;
    let counts = counts.map(|n| n as usize);
    let lattice = Lattice::centred(counts, spacing);
    let snapped = counts.map(|n| n as f64 * spacing);
    Ok((sample_cells(lattice, |_| true), snapped))
}

/// Fills the inside of `mesh` with cubes of side `spacing` on the origin-anchored lattice.
pub fn fill_mesh(mesh: &TriangleMesh, spacing: f64, rule: FillRule) -> Result<(GridSample, InsideCells), GridError> {
    let (lo, hi) = mesh.bounds();
    let lattice = Lattice::covering(lo, hi, spacing);
    check_size(lattice.dims)?;
    let inside = inside_cells(mesh, &lattice, rule);
    Ok((sample_cells(lattice, |cell| inside.inside[cell]), inside))
}

fn check_size(dims: [usize; 3]) -> Result<(), GridError> {
    let cells = dims.iter().try_fold(1usize, |product, n| product.checked_mul(*n));
    if dims.iter().any(|n| *n > MAX_CELLS_PER_AXIS) || cells.is_none_or(|cells| cells > MAX_LATTICE_CELLS) {
        return Err(GridError::TooLarge(format!(
            "the lattice would have {} x {} x {} cells; at most {MAX_CELLS_PER_AXIS} per axis and \
             {MAX_LATTICE_CELLS} in all are supported",
            dims[0], dims[1], dims[2]
        )));
    }
    Ok(())
}

/// Collects the cells for which `keep` holds, orders them along the Z-curve and finds the pairs
/// that share a face.
fn sample_cells(lattice: Lattice, keep: impl Fn(usize) -> bool) -> GridSample {
    let mut cells: Vec<[usize; 3]> = (0..lattice.cell_count()).filter(|&c| keep(c)).map(|c| lattice.cell(c)).collect();
    cells.sort_by_cached_key(|cell| morton_code(*cell));
    let mut particle_at = vec![u32::MAX; lattice.cell_count()];
    for (particle, cell) in cells.iter().enumerate() {
        particle_at[lattice.linear(*cell)] = particle as u32;
    }
    let mut adjacency = Vec::with_capacity(cells.len() * 3);
    for (particle, cell) in cells.iter().enumerate() {
        for axis in 0..3 {
            let mut next = *cell;
            next[axis] += 1;
            if next[axis] < lattice.dims[axis] {
                let other = particle_at[lattice.linear(next)];
                if other != u32::MAX {
                    let a = particle as u32;
                    adjacency.push([a.min(other), a.max(other)]);
                }
            }
        }
    }
    adjacency.sort_unstable();
    GridSample { lattice, cells, adjacency }
}

// The sample as particles, for the dispatch in `samplers/sampler_dispatch.rs`.

/// A lattice too large for the spacing, as an error of the `geometry.spacing_m` setting.
pub(super) fn spacing_error(spacing: f64) -> impl Fn(GridError) -> PreprocessError {
    move |GridError::TooLarge(message)| PreprocessError::Setting {
        key: "geometry.spacing_m",
        value: spacing.to_string(),
        message,
    }
}

/// Cube particles on the lattice: world positions, volumes, masses, bonds and face adjacency.
/// Where the lattice's axes are the world's, the stored positions sit on a lattice that f32 holds
/// exactly ([`exact_lattice_positions`]).
pub(super) fn grid_particles(
    config: &PipelineConfig,
    sample: &GridSample,
    progress: &dyn Progress,
    notes: &mut Vec<String>,
) -> ParticleSet {
    let lambda = config.geometry.spacing_m;
    let points = sample.points();
    let n = points.len();
    let placement = Placement::new(&config.geometry.transform);
    let stored =
        exact_lattice_positions(&points, &placement, lambda).unwrap_or_else(|| placement.stored_positions(&points));
    let elements = Elements::Cubes {
        half_size_m: vec![(lambda * 0.5) as f32; n],
        orientation: placement.rotation.as_quat().to_array(),
    };
    let volumes = vec![lambda.powi(3); n];
    let sampled = Sampled {
        lambda_m: lambda,
        points: &points,
        rest_position_m: stored,
        volume_m3: &volumes,
        elements,
        adjacency: sample.adjacency.clone(),
    };
    assemble(config, sampled, progress, notes)
}

/// Largest change of the spacing between stored positions that [`exact_lattice_positions`]
/// makes, relative to the spacing.
const MAX_SPACING_CHANGE: f64 = 1e-4;

/// The world positions of lattice `points` (sampling frame) rounded to a lattice that f32 holds
/// exactly, if the placement keeps the lattice's axes along the world's (no rotation, or quarter
/// turns): the centre and half the spacing rounded to multiples of one power of two, fine enough
/// for every position below the largest to be an f32. Laid out from its centre, the lattice keeps
/// the mirror symmetry about it that rounding each position kept. Every bond at one lattice
/// offset then has the same f32 rest vector, bit for bit, on every backend, which lets the CPU's
/// lattice layout keep one rest vector per eight bonds. The spacing between positions moves by at most
/// [`MAX_SPACING_CHANGE`] of itself (2e-6 for the default plate); volumes, cube sizes and bonds
/// keep the configured spacing. `None` (positions as placed) where the axes turn or no such
/// lattice is close enough.
fn exact_lattice_positions(points: &[DVec3], placement: &Placement, spacing: f64) -> Option<Vec<[f32; 3]>> {
    let world: Vec<DVec3> = points.iter().map(|p| placement.world_f64(*p)).collect();
    let corner = world.iter().fold(DVec3::INFINITY, |low, w| low.min(*w));
    let far = world.iter().fold(DVec3::NEG_INFINITY, |high, w| high.max(*w));
    let reach = corner.abs().max(far.abs()).max_element() + spacing;
    // Below 2^e, the multiples of 2^(e - 24) are all f32 values.
    let unit = 2f64.powi(reach.log2().floor() as i32 + 1 - 24);
    // Sites sit at whole or half spacings from the centre: the half spacing is a multiple of the
    // unit, and the lattice stays mirror-symmetric about its centre, as rounding kept it.
    let half = (0.5 * spacing / unit).round() * unit;
    if !(half > 0.0 && (2.0 * half - spacing).abs() <= MAX_SPACING_CHANGE * spacing) {
        return None;
    }
    let centre = (0.5 * (corner + far) / unit).round() * unit;
    let middle = ((far - corner) / spacing).round() * 0.5;
    world
        .iter()
        .map(|w| {
            let steps = (*w - corner) / spacing;
            let site = steps.round();
            if (steps - site).abs().max_element() > 1e-6 {
                return None; // the axes are turned
            }
            let exact = centre + (site - middle) * (2.0 * half);
            let stored = exact.as_vec3();
            (stored.as_dvec3() == exact).then_some(stored.to_array())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_meshes::cube;

    #[test]
    fn a_box_snaps_to_whole_cubes_and_knows_its_faces() {
        let (sample, snapped) = fill_box([0.0101, 0.004, 0.0021], 0.001).expect("small box");
        assert_eq!(sample.lattice.dims, [10, 4, 2]);
        assert_eq!(snapped, [0.01, 0.004, 0.002]);
        assert_eq!(sample.cells.len(), 80);
        // faces between neighbours along x, y, z
        assert_eq!(sample.adjacency.len(), 9 * 4 * 2 + 10 * 3 * 2 + 10 * 4);
        let points = sample.points();
        for [a, b] in &sample.adjacency {
            assert!((points[*a as usize].distance(points[*b as usize]) - 0.001).abs() < 1e-12);
        }
    }

    #[test]
    fn a_mesh_cube_fills_to_its_volume() {
        let mut mesh = cube(0.01);
        mesh.map_positions(|p| p + DVec3::splat(0.0003));
        let (sample, inside) = fill_mesh(&mesh, 0.001, FillRule::NonZero).expect("fill");
        assert_eq!(inside.leaky_lines, 0);
        assert_eq!(sample.cells.len(), 1000);
    }

    /// The f32 difference of every pair of particles one lattice offset apart, per offset.
    fn rest_vectors(points: &[DVec3], stored: &[[f32; 3]], spacing: f64) -> Vec<([i64; 3], [u32; 3])> {
        let mut vectors = Vec::new();
        for (i, a) in points.iter().enumerate() {
            for (j, b) in points.iter().enumerate() {
                let offset = ((*b - *a) / spacing).round().as_i64vec3().to_array();
                if offset.iter().all(|d| d.abs() <= 2) {
                    vectors.push((offset, [0, 1, 2].map(|k| (stored[j][k] - stored[i][k]).to_bits())));
                }
            }
        }
        vectors.sort_unstable();
        vectors.dedup();
        vectors
    }

    #[test]
    fn stored_positions_sit_on_a_lattice_that_f32_holds_exactly() {
        let (sample, _) = fill_box([0.012, 0.006, 0.003], 0.001).expect("small box");
        let points = sample.points();
        let transform = |rotate_deg: [f64; 3]| shatter_core::config::TransformConfig {
            translate_m: [0.0137, 0.06, -0.3],
            rotate_deg,
            ..Default::default()
        };
        for rotate_deg in [[0.0; 3], [90.0, 0.0, 0.0], [0.0, -90.0, 180.0]] {
            let placement = Placement::new(&transform(rotate_deg));
            let stored = exact_lattice_positions(&points, &placement, 0.001).expect("axes kept");
            // one rest vector per offset, bit for bit
            let vectors = rest_vectors(&points, &stored, 0.001);
            assert!(vectors.windows(2).all(|pair| pair[0].0 != pair[1].0), "{rotate_deg:?}");
            // the positions moved by a thousandth of the spacing at most
            let placed = placement.stored_positions(&points);
            for (a, b) in stored.iter().zip(&placed) {
                assert!((0..3).all(|k| (a[k] - b[k]).abs() < 1e-6), "{a:?} {b:?}");
            }
        }
        // placed as they are: the positions' rounding gives one offset several rest vectors
        let placement = Placement::new(&transform([0.0; 3]));
        let placed = placement.stored_positions(&points);
        let vectors = rest_vectors(&points, &placed, 0.001);
        assert!(vectors.windows(2).any(|pair| pair[0].0 == pair[1].0));
        // a box about the origin stays mirror-symmetric about it, as rounding each position kept it
        let centred = Placement::new(&shatter_core::config::TransformConfig::default());
        let stored_centred = exact_lattice_positions(&points, &centred, 0.001).expect("axes kept");
        let mut sorted: Vec<[u32; 3]> = stored_centred.iter().map(|p| p.map(|x| (x + 0.0).to_bits())).collect();
        sorted.sort_unstable();
        for p in &stored_centred {
            assert!(sorted.binary_search(&p.map(|x| (-x + 0.0).to_bits())).is_ok(), "{p:?} has no mirror image");
        }
        // a turned lattice is left as placed
        assert_eq!(exact_lattice_positions(&points, &Placement::new(&transform([30.0, 0.0, 0.0])), 0.001), None);
    }

    #[test]
    fn absurd_spacings_are_refused() {
        assert!(fill_box([1.0, 1.0, 1.0], 1e-6).is_err());
    }
}
