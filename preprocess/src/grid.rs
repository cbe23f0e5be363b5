//! The grid sampler (the paper's glass plate): cubes of side lambda on a regular lattice, filling
//! a box or the inside of a closed mesh; adjacent cubes share a face.

use glam::DVec3;

use crate::inside::{FillRule, InsideCells, inside_cells};
use crate::lattice::Lattice;
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

/// Interleaves the low 21 bits of each coordinate: x in bit 0, y in bit 1, z in bit 2, ...
pub(crate) fn morton_code(cell: [usize; 3]) -> u64 {
    fn spread(v: usize) -> u64 {
        let mut x = (v as u64) & 0x1f_ffff;
        x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
        x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
        x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
        x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
        (x | (x << 2)) & 0x1249_2492_4924_9249
    }
    spread(cell[0]) | (spread(cell[1]) << 1) | (spread(cell[2]) << 2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_meshes::cube;

    #[test]
    fn morton_code_interleaves_bits() {
        assert_eq!(morton_code([1, 0, 0]), 1);
        assert_eq!(morton_code([0, 1, 0]), 2);
        assert_eq!(morton_code([0, 0, 1]), 4);
        assert_eq!(morton_code([3, 3, 3]), 63);
        assert_eq!(morton_code([(1 << 21) - 1, 0, 0]), 0x1249_2492_4924_9249);
    }

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

    #[test]
    fn absurd_spacings_are_refused() {
        assert!(fill_box([1.0, 1.0, 1.0], 1e-6).is_err());
    }
}
