//! One clipped cell: its polytope cut from the box by the bisectors with its Voronoi neighbours,
//! the mesh triangles clipped to it, its volume inside the mesh and the neighbours it shares a face
//! with there (see the [module documentation](super)).

use glam::DVec3;

use super::cell_box::{BOX_PLANES, Frame};
use super::cell_volume::{cone_volume, curve_ends, fan, green, place_crossings, polygon_area, stretch_levels};
use super::clipping::{Corner, MESH_EDGE, clip_triangle, plane_parts};
use super::diagram::{ClippedCell, bisector};
use super::face_inside::region_triangles;
use super::polytope::{NONE, Polytope};
use crate::mesh_query::MeshQuery;
use shatter_geometry::mesh::TriangleMesh;

/// A face shares a non-zero area inside the mesh when the inside part exceeds this fraction of it.
const SHARED_AREA: f64 = 1e-10;

/// What one cell needs to know.
pub(super) struct CellInput<'a> {
    pub(super) index: usize,
    pub(super) sites: &'a [DVec3],
    pub(super) neighbours: &'a [u32],
    pub(super) frame: &'a Frame,
    pub(super) mesh: &'a TriangleMesh,
    pub(super) query: &'a MeshQuery,
}

/// The surface inside a cell: clipped pieces, each a run of corners.
#[derive(Debug, Default)]
struct Pieces {
    corners: Vec<Corner<DVec3>>,
    /// Start and length of each piece in `corners`.
    spans: Vec<(usize, usize)>,
}

impl Pieces {
    fn iter(&self) -> impl Iterator<Item = &[Corner<DVec3>]> {
        self.spans.iter().map(|&(start, len)| &self.corners[start..start + len])
    }
}

impl CellInput<'_> {
    /// The clipped cell and the higher-numbered cells it shares a face with inside the mesh, or
    /// `None` when the polytope degenerates.
    pub(super) fn clip(&self) -> Option<(ClippedCell, Vec<u32>)> {
        let site = self.sites[self.index];
        let (planes, across) = self.candidate_planes();
        let mut polytope = Polytope::cuboid(self.frame.lo, self.frame.hi);
        for (id, plane) in planes.iter().enumerate().skip(BOX_PLANES as usize) {
            polytope.clip(id as u32, plane, self.frame.on_plane)?;
        }
        let pieces = self.clip_surface(&polytope, &planes);
        let cut_curves = cut_curves(&pieces, &polytope, planes.len());
        let whole_cell_winding = pieces.spans.is_empty().then(|| self.winding_at(site));

        let mut volume: f64 = pieces.iter().map(|piece| cone_volume(site, piece)).sum();
        let mut shared = Vec::new();
        let (mut face_triangles, mut face_of_triangle) = (Vec::new(), Vec::new());
        for (f, (face, cut_curve)) in polytope.faces.iter().zip(&cut_curves).enumerate() {
            let (normal, offset) = plane_parts(&planes[face.plane as usize]);
            let face_loop = polytope.face_loop(face);
            let (inside_area, triangles) = match whole_cell_winding {
                Some(winding) => {
                    let whole = if winding >= 1 { face_fan(&face_loop) } else { Vec::new() };
                    (f64::from(winding) * polygon_area(normal, &face_loop), whole)
                }
                None if face.plane < BOX_PLANES => (0.0, Vec::new()), // the box lies outside the mesh
                None => self.inside_part(normal, &face_loop, cut_curve),
            };
            face_of_triangle.extend(std::iter::repeat_n(f as u32, triangles.len()));
            face_triangles.extend(triangles);
            volume += (offset - normal.dot(site)) * inside_area / 3.0;
            let neighbour = across[face.plane as usize];
            if neighbour != NONE
                && neighbour > self.index as u32
                && inside_area > SHARED_AREA * polygon_area(normal, &face_loop)
            {
                shared.push(neighbour);
            }
        }
        shared.sort_unstable();
        let cell = ClippedCell {
            planes: polytope.faces.iter().map(|face| planes[face.plane as usize]).collect(),
            triangles: pieces.iter().flat_map(fan).collect(),
            face_triangles,
            face_of_triangle,
            volume,
        };
        Some((cell, shared))
    }

    /// The box's planes, then the bisectors with the Voronoi neighbours, nearest first; and the
    /// site across each plane ([`NONE`] for the box).
    fn candidate_planes(&self) -> (Vec<[f64; 4]>, Vec<u32>) {
        let site = self.sites[self.index];
        let mut order = self.neighbours.to_vec();
        let distance = |j: u32| self.sites[j as usize].distance_squared(site);
        order.sort_by(|&a, &b| distance(a).total_cmp(&distance(b)).then(a.cmp(&b)));
        let mut planes = self.frame.planes().to_vec();
        let mut across = vec![NONE; planes.len()];
        for j in order {
            planes.push(bisector(self.sites, self.index as u32, j));
            across.push(j);
        }
        (planes, across)
    }

    /// The mesh triangles near the polytope clipped to it, in the order of their mesh index.
    fn clip_surface(&self, polytope: &Polytope, planes: &[[f64; 4]]) -> Pieces {
        let cutting: Vec<(u32, [f64; 4])> = polytope
            .faces
            .iter()
            .filter(|face| face.plane >= BOX_PLANES)
            .map(|face| (face.plane, planes[face.plane as usize]))
            .collect();
        let (lo, hi) = polytope.bounds();
        let pad = DVec3::splat(self.frame.on_plane);
        let mut near = Vec::new();
        self.query.triangles_in_box(lo - pad, hi + pad, &mut near);
        near.sort_unstable();
        let mut pieces = Pieces::default();
        let (mut piece, mut scratch) = (Vec::new(), Vec::new());
        for &t in &near {
            if clip_triangle(self.mesh.corners(t as usize), &cutting, &mut piece, &mut scratch) {
                pieces.spans.push((pieces.corners.len(), piece.len()));
                pieces.corners.extend_from_slice(&piece);
            }
        }
        pieces
    }

    /// A face's part inside the mesh: its area (counted with its winding number), by Green's
    /// theorem on its boundary: the cut curve (segments as the boundary runs) and the stretches
    /// of the face's edges, each as many times as its winding number; and the part triangulated
    /// from that boundary (each triangle as many times as its winding number).
    fn inside_part(&self, normal: DVec3, face_loop: &[DVec3], cut_curve: &[(DVec3, DVec3)]) -> (f64, Vec<[DVec3; 3]>) {
        let origin = face_loop[0];
        let mut twice_area: f64 = cut_curve.iter().map(|&(a, b)| green(normal, origin, a, b)).sum();
        let stretches = stretch_levels(&place_crossings(face_loop, &curve_ends(cut_curve)));
        let base = self.base_level(&stretches);
        twice_area +=
            stretches.iter().map(|&(a, b, level)| f64::from(level + base) * green(normal, origin, a, b)).sum::<f64>();
        let mut boundary = cut_curve.to_vec();
        for &(a, b, level) in stretches.iter().filter(|s| s.0 != s.1) {
            let times = (level + base).unsigned_abs() as usize;
            boundary.extend(std::iter::repeat_n(if level + base > 0 { (a, b) } else { (b, a) }, times));
        }
        (0.5 * twice_area, region_triangles(normal, &boundary))
    }

    /// The winding number of the stretches at level 0, from the exact winding number at the
    /// middle of the longest stretch.
    fn base_level(&self, stretches: &[(DVec3, DVec3, i32)]) -> i32 {
        let length = |s: &&(DVec3, DVec3, i32)| s.0.distance_squared(s.1);
        stretches
            .iter()
            .max_by(|x, y| length(x).total_cmp(&length(y)))
            .map_or(0, |&(a, b, level)| self.winding_at((a + b) * 0.5) - level)
    }

    /// The winding number about `p`; where the mesh's holes leave it undefined, 1 inside and 0
    /// outside.
    fn winding_at(&self, p: DVec3) -> i32 {
        self.query.winding_number(p).unwrap_or_else(|| i32::from(self.query.contains(p)))
    }
}

/// Per polytope face: its cut curve, the piece edges on its plane taken backwards (as the
/// boundary of the face's part inside the mesh runs).
fn cut_curves(pieces: &Pieces, polytope: &Polytope, plane_count: usize) -> Vec<Vec<(DVec3, DVec3)>> {
    let mut face_of_plane = vec![NONE; plane_count];
    for (f, face) in polytope.faces.iter().enumerate() {
        face_of_plane[face.plane as usize] = f as u32;
    }
    let mut curves = vec![Vec::new(); polytope.faces.len()];
    for piece in pieces.iter() {
        for (k, corner) in piece.iter().enumerate() {
            if corner.across != MESH_EDGE {
                let next = piece[(k + 1) % piece.len()];
                curves[face_of_plane[corner.across as usize] as usize].push((next.at, corner.at));
            }
        }
    }
    curves
}

/// A convex face's fan triangles from its first corner (its loop runs counter-clockwise about
/// its outward normal, and so do they).
fn face_fan(face_loop: &[DVec3]) -> Vec<[DVec3; 3]> {
    (1..face_loop.len().saturating_sub(1)).map(|k| [face_loop[0], face_loop[k], face_loop[k + 1]]).collect()
}
