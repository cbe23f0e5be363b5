//! Geometry that more than one shatter stage needs: preprocessing samples meshes and bonds
//! particles by range queries; the simulation reads seam meshes and finds the particles near them.
//!
//! - [`mesh`]: indexed triangle meshes in double precision (Wavefront OBJ loading, welding,
//!   volume and area).
//! - [`point_kdtree`]: a k-d tree over points for radius and nearest-neighbour queries.

pub mod mesh;
mod point_kdtree;

pub use mesh::{MeshError, TriangleMesh};
pub use point_kdtree::PointKdTree;
