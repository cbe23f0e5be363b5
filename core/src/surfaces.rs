//! The outer surface of a piece made of elements, in the rest frame: each element's faces except
//! those it shares with an adjacent element of the same piece, each marked as the body's original
//! surface or as a fracture face (a face it shares at rest with an element of another piece).

use crate::particles::{Elements, ParticleSet};
use glam::{Quat, Vec3};

/// A polygon mesh: `face_sizes[f]` corners of face f are the next entries of `indices`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SurfaceMesh {
    /// Vertex positions, metres.
    pub points: Vec<[f32; 3]>,
    /// Corners per face.
    pub face_sizes: Vec<u32>,
    /// Vertex indices, face after face, counter-clockwise seen from outside.
    pub indices: Vec<u32>,
    /// Per face: true for a fracture face, false for the original surface.
    pub fracture: Vec<bool>,
}

impl SurfaceMesh {
    fn push_face(&mut self, corners: &[Vec3], fracture: bool) {
        self.fracture.push(fracture);
        let base = self.points.len() as u32;
        self.points.extend(corners.iter().map(|c| c.to_array()));
        self.face_sizes.push(corners.len() as u32);
        self.indices.extend(base..base + corners.len() as u32);
    }

    /// Total area of the faces, m^2 (polygons fanned from their first corner).
    pub fn area(&self) -> f64 {
        let mut start = 0usize;
        let mut area = 0.0;
        for &size in &self.face_sizes {
            let corner = |k: usize| Vec3::from_array(self.points[self.indices[start + k] as usize]).as_dvec3();
            for k in 1..size as usize - 1 {
                area += 0.5 * (corner(k) - corner(0)).cross(corner(k + 1) - corner(0)).length();
            }
            start += size as usize;
        }
        area
    }
}

/// One surface mesh per piece: `piece_of[element]` in 0..pieces.
pub fn piece_surfaces(particles: &ParticleSet, piece_of: &[u32], pieces: usize) -> Vec<SurfaceMesh> {
    let n = particles.len();
    // As bit masks per element: faces shared at rest with an adjacent element, and those of them
    // hidden because that element is in the same piece.
    let (mut shared, mut hidden) = (vec![0u8; n], vec![0u8; n]);
    for &[a, b] in &particles.adjacency {
        let (a, b) = (a as usize, b as usize);
        for (from, to) in [(a, b), (b, a)] {
            if let Some(face) = particles.shared_face(from, to) {
                shared[from] |= 1 << face;
                if piece_of[a] == piece_of[b] {
                    hidden[from] |= 1 << face;
                }
            }
        }
    }
    let across = plane_neighbours(particles);
    let position = |i: usize| Vec3::from_array(particles.rest_position_m[i]);
    let mut meshes = vec![SurfaceMesh::default(); pieces];
    for element in 0..n {
        let mesh = &mut meshes[piece_of[element] as usize];
        match &particles.elements {
            Elements::Cubes { half_size_m, orientation } => {
                let orientation = Quat::from_array(*orientation);
                let h = half_size_m[element];
                let centre = position(element);
                for axis in 0..3 {
                    for positive in [false, true] {
                        let bit = 1 << (2 * axis + usize::from(!positive));
                        if hidden[element] & bit != 0 {
                            continue;
                        }
                        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                        let sign = if positive { 1.0 } else { -1.0 };
                        let corner = |a: f32, b: f32| {
                            let mut local = Vec3::ZERO;
                            local[axis] = sign * h;
                            local[u] = a * h;
                            local[v] = b * h;
                            centre + orientation * local
                        };
                        // (u, v, axis) is right-handed: u then v is counter-clockwise about +axis
                        let mut quad = [corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)];
                        if !positive {
                            quad.reverse();
                        }
                        mesh.push_face(&quad, shared[element] & bit != 0);
                    }
                }
            }
            Elements::Tets { vertices_m } => {
                let corners = vertices_m[element].map(Vec3::from_array);
                let centre = corners.iter().copied().sum::<Vec3>() / 4.0;
                for k in 0..4 {
                    if hidden[element] & (1 << k) != 0 {
                        continue;
                    }
                    let mut face = [corners[(k + 1) % 4], corners[(k + 2) % 4], corners[(k + 3) % 4]];
                    let normal = (face[1] - face[0]).cross(face[2] - face[0]);
                    if normal.dot(face[0] - centre) < 0.0 {
                        face.swap(1, 2);
                    }
                    mesh.push_face(&face, shared[element] & (1 << k) != 0);
                }
            }
            Elements::Trimtopes {
                plane_offsets,
                triangle_offsets,
                triangles_m,
                face_offsets,
                face_triangles_m,
                face_planes,
                ..
            } => {
                let range = triangle_offsets[element] as usize..triangle_offsets[element + 1] as usize;
                for triangle in &triangles_m[range] {
                    mesh.push_face(&triangle.map(Vec3::from_array), false);
                }
                let faces = face_offsets[element] as usize..face_offsets[element + 1] as usize;
                for (triangle, &plane) in face_triangles_m[faces.clone()].iter().zip(&face_planes[faces]) {
                    let other = across[plane_offsets[element] as usize + plane as usize];
                    if other == NONE || piece_of[other as usize] != piece_of[element] {
                        mesh.push_face(&triangle.map(Vec3::from_array), true);
                    }
                }
            }
        }
    }
    meshes
}

/// No element.
const NONE: u32 = u32::MAX;

/// For each trimtope plane (index into the particle file's planes), the adjacent cell on its
/// other side, or [`NONE`]: a shared face is one bisector, stored exactly negated in the two
/// cells. Empty for other elements.
fn plane_neighbours(particles: &ParticleSet) -> Vec<u32> {
    let Elements::Trimtopes { plane_offsets, planes, .. } = &particles.elements else {
        return Vec::new();
    };
    let mut across = vec![NONE; planes.len()];
    let range = |e: u32| plane_offsets[e as usize] as usize..plane_offsets[e as usize + 1] as usize;
    for &[a, b] in &particles.adjacency {
        for k in range(a) {
            let opposite = planes[k].map(|c| -c);
            if let Some(j) = range(b).find(|&j| planes[j] == opposite) {
                across[k] = b;
                across[j] = a;
            }
        }
    }
    across
}
