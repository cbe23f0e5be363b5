//! Clipped Voronoi cells: the Voronoi diagram of a set of sites, cut to the inside of a closed
//! triangle mesh (the paper's "trimtopes": a convex polytope and the surface triangles inside it),
//! with the parts of their faces inside the mesh triangulated (where a crack opens, the faces of
//! the pieces on either side).
//!
//! # Cells
//!
//! A site's Voronoi neighbours are its neighbours in the Delaunay tetrahedralization of the sites
//! ([`crate::delaunay`]; every pair of sites when there are fewer than four or all are coplanar).
//! Its cell starts as a box around the mesh and the sites (10% larger on every side) and is cut by
//! the bisector plane of each neighbour, nearest first. The polytope is kept as shared vertices
//! and faces whose edges name the face across them; a plane cuts it by Sutherland-Hodgman on each
//! face, with vertices within 1e-12 of the box's size of the plane counted as on it, and the new
//! face is chained from the cut edges. Planes that leave no face are dropped; box faces remain
//! only where the cell reaches the box (always where it would be unbounded). The bisector of two
//! sites is computed once for the pair, so the two cells see exactly opposite planes.
//!
//! # Surface
//!
//! Each triangle whose bounding box meets the cell's is clipped by the cell's face planes
//! (Sutherland-Hodgman with the exact sign of the floating-point plane offset, so two cells split a
//! triangle along their shared plane at the same points up to rounding). Every edge of a clipped
//! piece remembers the face plane it lies on, if any. The pieces of all cells tile the surface.
//!
//! # Volume
//!
//! The region R = C ∩ M (C the cell, M the mesh interior) is bounded by the clipped pieces and by
//! the parts of C's faces that lie inside M. By the divergence theorem about the site s,
//!
//! V(R) = Σ over pieces of the signed volume of the cone from s over the piece
//!      + Σ over faces f of d_f · area(f ∩ M) / 3,
//!
//! with d_f the distance from s to f's plane. The area of f ∩ M is exact by Green's theorem on the
//! face: its boundary is the cut curve (the pieces' edges on f, taken against the pieces' own
//! orientation) and the stretches of f's edges inside M. The cut curve's segments meet at
//! bit-identical points (neighbouring pieces cut a shared mesh edge at the same point), so its
//! loose ends are exactly where the surface crosses the face's edges (each is put on the nearest
//! edge of the face, in order along it): an end where more segments
//! arrive than leave is where the boundary goes on along an edge into M (the winding number
//! rises by one going round the face), and the opposite end is where it leaves M. Walking round
//! the face from corner and crossing to the next gives every stretch's winding number relative to
//! the first; one exact winding number query ([`MeshQuery::winding_number`]) at the middle of the
//! longest stretch fixes them all, and each stretch counts as many times as its winding number. A
//! cell that no piece reaches is wholly inside or outside: one query at its site decides.
//!
//! Every term is thus exact up to rounding, and so is the total: the cells' volumes add up to
//! [`TriangleMesh::signed_volume`] and their pieces to the mesh's area. Where the surface overlaps
//! itself (the repaired Welsh dragon has a few tiny inverted folds, pockets of winding number -1)
//! volume counts with its winding number, as [`TriangleMesh::signed_volume`] counts it. Where the
//! mesh has holes, the winding number is undefined and stretches count 1 inside (by
//! [`MeshQuery::contains`]'s vote) and 0 outside.
//!
//! # Files
//!
//! The diagram and its Voronoi neighbours are in `diagram.rs`; the box every cell starts from in
//! `cell_box.rs`; one cell's construction in `clipped_cell.rs`; its polytope in `polytope.rs`;
//! Sutherland-Hodgman clipping of faces and triangles in `clipping.rs`; the volume terms in
//! `cell_volume.rs`; the faces' parts inside the mesh as triangles (the boundary the area comes
//! from, triangulated by spade's constrained Delaunay triangulation) in `face_inside.rs`; the
//! tests in `tests.rs`.
//!
//! [`MeshQuery::winding_number`]: crate::mesh_query::MeshQuery::winding_number
//! [`MeshQuery::contains`]: crate::mesh_query::MeshQuery::contains
//! [`TriangleMesh::signed_volume`]: shatter_geometry::mesh::TriangleMesh::signed_volume

mod cell_box;
mod cell_volume;
mod clipped_cell;
mod clipping;
mod diagram;
mod face_inside;
mod polytope;
#[cfg(test)]
mod tests;

pub use diagram::{ClippedCell, ClippedVoronoi, VoronoiError, bisector, clipped_voronoi};
