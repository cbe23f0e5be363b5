//! Triangle meshes: loading Wavefront OBJ files, welding, measuring.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::DVec3;

/// Why a mesh file could not be used. The CLI treats these as bad input (exit code 2).
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The file could not be read or parsed as OBJ.
    #[error("{path}: cannot read the mesh: {reason}")]
    Load {
        /// The mesh file.
        path: PathBuf,
        /// What the OBJ reader reported.
        reason: String,
    },
    /// The file parsed but holds no usable triangle.
    #[error("{path}: the mesh has no triangles (is it a Wavefront OBJ file with `f` lines?)")]
    NoTriangles {
        /// The mesh file.
        path: PathBuf,
    },
    /// A vertex coordinate is NaN or infinite.
    #[error("{path}: vertex {index} has a non-finite coordinate")]
    NonFinite {
        /// The mesh file.
        path: PathBuf,
        /// Zero-based vertex index.
        index: usize,
    },
    /// The mesh encloses no volume, so nothing can be filled with particles.
    #[error("{path}: {reason}")]
    NoVolume {
        /// The mesh file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

/// An indexed triangle mesh in double precision.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Triangles as vertex indices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

/// What loading a mesh found and changed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LoadStats {
    /// Vertices in the file.
    pub file_vertices: usize,
    /// Triangles in the file (after splitting polygons).
    pub file_triangles: usize,
    /// Vertices merged into an identical earlier one.
    pub welded_vertices: usize,
    /// Triangles dropped because two of their corners were the same vertex.
    pub degenerate_triangles: usize,
}

impl TriangleMesh {
    /// Loads every object of an OBJ file as one mesh (positions only; materials, normals and
    /// texture coordinates are ignored), welds identical positions and drops triangles whose
    /// corners coincide.
    pub fn load_obj(path: &Path) -> Result<(TriangleMesh, LoadStats), MeshError> {
        let load_error = |reason: String| MeshError::Load { path: path.to_path_buf(), reason };
        let file = std::fs::File::open(path).map_err(|error| load_error(error.to_string()))?;
        let options =
            tobj::LoadOptions { triangulate: true, ignore_points: true, ignore_lines: true, ..Default::default() };
        let (models, _materials) =
            tobj::load_obj_buf(&mut std::io::BufReader::new(file), &options, |_| Err(tobj::LoadError::OpenFileFailed))
                .map_err(|error| load_error(describe_obj_error(&error)))?;

        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for model in &models {
            let mesh = &model.mesh;
            if mesh.positions.len() % 3 != 0 || mesh.indices.len() % 3 != 0 {
                return Err(load_error("malformed position or face data".to_string()));
            }
            let base = positions.len();
            let count = mesh.positions.len() / 3;
            positions.extend(mesh.positions.chunks_exact(3).map(|p| DVec3::new(p[0], p[1], p[2])));
            for face in mesh.indices.chunks_exact(3) {
                let mut triangle = [0u32; 3];
                for (corner, &index) in triangle.iter_mut().zip(face) {
                    if index as usize >= count {
                        return Err(load_error(format!("a face refers to vertex {} of {count}", index + 1)));
                    }
                    *corner = u32::try_from(base + index as usize)
                        .map_err(|_| load_error("more than 4 billion vertices".to_string()))?;
                }
                triangles.push(triangle);
            }
        }
        if let Some(index) = positions.iter().position(|p| !p.is_finite()) {
            return Err(MeshError::NonFinite { path: path.to_path_buf(), index });
        }
        let mut stats =
            LoadStats { file_vertices: positions.len(), file_triangles: triangles.len(), ..Default::default() };
        let mut mesh = TriangleMesh { positions, triangles };
        stats.welded_vertices = mesh.weld();
        stats.degenerate_triangles = mesh.drop_degenerate_triangles();
        if mesh.triangles.is_empty() {
            return Err(MeshError::NoTriangles { path: path.to_path_buf() });
        }
        Ok((mesh, stats))
    }

    /// Merges vertices with bit-identical positions and drops unused ones; returns how many
    /// vertices were merged away.
    pub fn weld(&mut self) -> usize {
        let mut first_of: HashMap<[u64; 3], u32> = HashMap::with_capacity(self.positions.len());
        let mut remap = Vec::with_capacity(self.positions.len());
        let mut welded = Vec::with_capacity(self.positions.len());
        for p in &self.positions {
            // -0.0 and 0.0 are the same point.
            let key = (*p + DVec3::ZERO).to_array().map(f64::to_bits);
            let index = *first_of.entry(key).or_insert_with(|| {
                welded.push(*p);
                (welded.len() - 1) as u32
            });
            remap.push(index);
        }
        let merged = self.positions.len() - welded.len();
        for triangle in &mut self.triangles {
            *triangle = triangle.map(|v| remap[v as usize]);
        }
        self.positions = welded;
        merged
    }

    /// Drops triangles with a repeated corner; returns how many.
    pub fn drop_degenerate_triangles(&mut self) -> usize {
        let before = self.triangles.len();
        self.triangles.retain(|[a, b, c]| a != b && b != c && a != c);
        before - self.triangles.len()
    }

    /// An axis-aligned box of edge lengths `size`, centred on the origin, wound outward.
    pub fn cuboid(size: [f64; 3]) -> TriangleMesh {
        let half = DVec3::from_array(size) * 0.5;
        let positions = (0..8)
            .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64) * 2.0 * half - half)
            .collect();
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let triangles = quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
        TriangleMesh { positions, triangles }
    }

    /// The corners of triangle `t`.
    pub fn corners(&self, t: usize) -> [DVec3; 3] {
        self.triangles[t].map(|v| self.positions[v as usize])
    }

    /// Axis-aligned bounds of the vertices used by triangles, as (min, max).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.triangles.iter().flatten().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &v| {
            let p = self.positions[v as usize];
            (lo.min(p), hi.max(p))
        })
    }

    /// Signed volume enclosed by the given triangles (positive for outward winding), by the
    /// divergence theorem about the bounds' centre to limit cancellation.
    pub fn signed_volume_of(&self, triangles: impl Iterator<Item = usize>) -> f64 {
        let (lo, hi) = self.bounds();
        let origin = (lo + hi) * 0.5;
        triangles
            .map(|t| {
                let [a, b, c] = self.corners(t).map(|p| p - origin);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// Signed volume enclosed by the whole mesh.
    pub fn signed_volume(&self) -> f64 {
        self.signed_volume_of(0..self.triangles.len())
    }

    /// Total triangle area.
    pub fn area(&self) -> f64 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                (b - a).cross(c - a).length() * 0.5
            })
            .sum()
    }

    /// Applies `f` to every vertex.
    pub fn map_positions(&mut self, f: impl Fn(DVec3) -> DVec3) {
        for p in &mut self.positions {
            *p = f(*p);
        }
    }

    /// Reverses every triangle's winding (turns an inside-out mesh right side out).
    pub fn flip(&mut self) {
        for triangle in &mut self.triangles {
            triangle.swap(1, 2);
        }
    }
}

fn describe_obj_error(error: &tobj::LoadError) -> String {
    match error {
        tobj::LoadError::OpenFileFailed => "the file cannot be opened".to_string(),
        tobj::LoadError::ReadError => "it cannot be read as text (a binary file?)".to_string(),
        _ => format!("not a valid Wavefront OBJ file ({error})"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An axis-aligned cube with outward winding, corners at 0 and `size`.
    fn cube(size: f64) -> TriangleMesh {
        let mut mesh = TriangleMesh::cuboid([size; 3]);
        mesh.map_positions(|p| p + DVec3::splat(0.5 * size));
        mesh
    }

    #[test]
    fn cube_volume_and_area() {
        let mesh = cube(2.0);
        assert!((mesh.signed_volume() - 8.0).abs() < 1e-12);
        assert!((mesh.area() - 24.0).abs() < 1e-12);
        let mut flipped = mesh.clone();
        flipped.flip();
        assert!((flipped.signed_volume() + 8.0).abs() < 1e-12);
    }

    #[test]
    fn welding_merges_identical_positions() {
        let mut mesh = cube(1.0);
        // Split every triangle onto its own vertices, as STL files store them.
        let mut split = TriangleMesh::default();
        for t in 0..mesh.triangles.len() {
            let base = split.positions.len() as u32;
            split.positions.extend(mesh.corners(t));
            split.triangles.push([base, base + 1, base + 2]);
        }
        assert_eq!(split.weld(), 36 - 8);
        assert_eq!(split.positions.len(), 8);
        mesh.triangles.push([0, 0, 1]);
        assert_eq!(mesh.drop_degenerate_triangles(), 1);
    }
}
