//! Regular lattices of cell centres.

use glam::DVec3;

/// A regular lattice: cell (i, j, k) has its centre at `origin + (i, j, k) * spacing`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lattice {
    /// Centre of cell (0, 0, 0).
    pub origin: DVec3,
    /// Distance between neighbouring centres.
    pub spacing: f64,
    /// Cells along x, y and z.
    pub dims: [usize; 3],
}

impl Lattice {
    /// The lattice of cells of side `spacing` anchored at the origin (centres at
    /// `(k + 0.5) * spacing`) that covers the box `[lo, hi]`.
    pub fn covering(lo: DVec3, hi: DVec3, spacing: f64) -> Lattice {
        let first = (lo / spacing).floor();
        let last = (hi / spacing).ceil().max(first + 1.0);
        let dims = (last - first).to_array().map(|n| n as usize);
        Lattice { origin: (first + 0.5) * spacing, spacing, dims }
    }

    /// `counts` cells of side `spacing` per axis, centred on the origin.
    pub fn centred(counts: [usize; 3], spacing: f64) -> Lattice {
        let half_extent = DVec3::from_array(counts.map(|n| (n as f64 - 1.0) * 0.5));
        Lattice { origin: -half_extent * spacing, spacing, dims: counts }
    }

    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        self.dims.iter().product()
    }

    /// Linear index of cell (i, j, k), x fastest.
    pub fn linear(&self, cell: [usize; 3]) -> usize {
        cell[0] + self.dims[0] * (cell[1] + self.dims[1] * cell[2])
    }

    /// Cell (i, j, k) of a linear index.
    pub fn cell(&self, linear: usize) -> [usize; 3] {
        let [nx, ny, _] = self.dims;
        [linear % nx, (linear / nx) % ny, linear / (nx * ny)]
    }

    /// Coordinate of the centres of cells with index `k` along `axis`.
    pub fn centre_along(&self, axis: usize, k: usize) -> f64 {
        self.origin[axis] + k as f64 * self.spacing
    }

    /// Centre of a cell.
    pub fn centre(&self, cell: [usize; 3]) -> DVec3 {
        self.origin + DVec3::from_array(cell.map(|k| k as f64)) * self.spacing
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn covering_lattice_contains_the_box() {
        let lattice = Lattice::covering(DVec3::new(-0.3, 0.0, 1.05), DVec3::new(0.3, 0.1, 1.25), 0.1);
        assert_eq!(lattice.dims, [6, 1, 3]);
        assert!((lattice.centre([0, 0, 0]) - DVec3::new(-0.25, 0.05, 1.05)).length() < 1e-12);
        assert_eq!(lattice.cell(lattice.linear([4, 0, 2])), [4, 0, 2]);
    }

    #[test]
    fn centred_lattice_is_symmetric() {
        let lattice = Lattice::centred([3, 2, 1], 1.0);
        assert_eq!(lattice.centre([0, 0, 0]), DVec3::new(-1.0, -0.5, 0.0));
        assert_eq!(lattice.centre([2, 1, 0]), DVec3::new(1.0, 0.5, 0.0));
    }
}
