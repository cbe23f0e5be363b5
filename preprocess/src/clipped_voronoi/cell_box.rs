//! The box every cell starts from: around the mesh and the sites, with the on-plane tolerance at
//! its scale.

use glam::DVec3;
use shatter_geometry::mesh::TriangleMesh;

/// The box's planes come first among a cell's planes.
pub(super) const BOX_PLANES: u32 = 6;

/// The box around the mesh and the sites grows by this fraction of its largest extent per side.
const BOX_MARGIN: f64 = 0.1;

/// Vertices within this fraction of the box's scale of a plane count as on it.
const ON_PLANE: f64 = 1e-12;

/// The box every cell starts from, and the on-plane tolerance at its scale.
#[derive(Debug, Clone, Copy)]
pub(super) struct Frame {
    pub(super) lo: DVec3,
    pub(super) hi: DVec3,
    pub(super) on_plane: f64,
}

impl Frame {
    pub(super) fn new(sites: &[DVec3], mesh: &TriangleMesh) -> Frame {
        let (lo, hi) = sites.iter().fold(mesh.bounds(), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let extent = (hi - lo).max_element();
        let margin = BOX_MARGIN * extent + f64::EPSILON * lo.abs().max(hi.abs()).max_element().max(1.0);
        let (lo, hi) = (lo - DVec3::splat(margin), hi + DVec3::splat(margin));
        Frame { lo, hi, on_plane: ON_PLANE * lo.abs().max(hi.abs()).max_element().max((hi - lo).max_element()) }
    }

    /// The box's planes, in the order of [`Polytope::cuboid`](super::polytope::Polytope::cuboid)'s faces.
    pub(super) fn planes(&self) -> [[f64; 4]; 6] {
        let (lo, hi) = (self.lo, self.hi);
        [
            [-1.0, 0.0, 0.0, -lo.x],
            [1.0, 0.0, 0.0, hi.x],
            [0.0, -1.0, 0.0, -lo.y],
            [0.0, 1.0, 0.0, hi.y],
            [0.0, 0.0, -1.0, -lo.z],
            [0.0, 0.0, 1.0, hi.z],
        ]
    }
}
