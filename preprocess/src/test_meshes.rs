//! Meshes the unit tests sample.

use glam::DVec3;
use shatter_geometry::TriangleMesh;

/// An axis-aligned cube with outward winding, corners at 0 and `size`.
pub(crate) fn cube(size: f64) -> TriangleMesh {
    let mut mesh = TriangleMesh::cuboid([size; 3]);
    mesh.map_positions(|p| p + DVec3::splat(0.5 * size));
    mesh
}
