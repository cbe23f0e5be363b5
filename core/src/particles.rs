//! The particle file (`particles.shp`): what `shatter preprocess` makes and every later stage reads.
//!
//! Particles carry rest positions, volumes and masses, the geometry of the element each one
//! stands for (cube, tetrahedron or trimtope, in the rest frame), their bonds in CSR form and the
//! element adjacency graph. [`ParticleSet::read`] checks the file whole and then every structural
//! rule ([`ParticleSet::validate`]), so later stages may index without further checks.

use std::path::Path;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

pub use crate::particle_summary::{CountStats, ParticleSummary, ValueStats};
use crate::stage_file::{StageFileError, StageKind, StageReader, StageWriter};

/// Scalars describing how a particle set was made.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticleMeta {
    /// `scene.name` of the config that made it.
    pub scene_name: String,
    /// `geometry.source` as given ("box" or a mesh path).
    pub source: String,
    /// The sampler's name ("grid", "tet_shell", "voronoi").
    pub sampler: String,
    /// lambda: the minimum distance between particles, in metres.
    pub lambda_m: f64,
    /// N in delta = N * lambda.
    pub horizon_factor: f64,
    /// delta: the bond horizon, in metres.
    pub delta_m: f64,
    /// Density used for the masses, kg/m^3.
    pub density_kg_m3: f64,
    /// Bulk modulus the thresholds were derived with, Pa.
    pub bulk_modulus_pa: f64,
    /// The mean critical stretch s0 before jitter.
    pub mean_critical_stretch: f64,
    /// The jitter's standard deviation as a fraction of s0.
    pub threshold_jitter: f64,
    /// `scene.seed`.
    pub seed: u64,
}

/// The geometric element each particle stands for, in the rest frame (world coordinates).
#[derive(Debug, Clone, PartialEq)]
pub enum Elements {
    /// Cubes centred on the particles, all with the same orientation.
    Cubes {
        /// Half the edge length of each cube, metres.
        half_size_m: Vec<f32>,
        /// Rotation from the cube's axes to the world, as a unit quaternion [x, y, z, w].
        orientation: [f32; 4],
    },
    /// Tetrahedra whose barycentres are the particles; vertices in positive orientation.
    Tets {
        /// The four vertices of each tetrahedron, metres.
        vertices_m: Vec<[[f32; 3]; 4]>,
    },
    /// Clipped Voronoi cells with the surface triangles they contain.
    Trimtopes {
        /// CSR offsets into `planes`, one more than there are particles.
        plane_offsets: Vec<u64>,
        /// Cell planes [nx, ny, nz, d] with unit outward normal n: inside where n . x <= d.
        planes: Vec<[f32; 4]>,
        /// CSR offsets into `triangles_m`, one more than there are particles.
        triangle_offsets: Vec<u64>,
        /// The mesh triangles clipped to each cell, metres, outward winding.
        triangles_m: Vec<[[f32; 3]; 3]>,
        /// CSR offsets into `face_triangles_m`, one more than there are particles.
        face_offsets: Vec<u64>,
        /// The parts of each cell's faces inside the mesh, triangulated, metres, outward winding:
        /// where a crack separates two cells, their fracture faces.
        face_triangles_m: Vec<[[f32; 3]; 3]>,
        /// The plane (index among the cell's own planes) each of `face_triangles_m` lies on.
        face_planes: Vec<u32>,
    },
}

/// The element types, as named in files and summaries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ElementType {
    /// [`Elements::Cubes`].
    Cube,
    /// [`Elements::Tets`].
    Tet,
    /// [`Elements::Trimtopes`].
    Trimtope,
}

impl ElementType {
    /// The name used in files and summaries: "cube", "tet" or "trimtope".
    pub fn name(self) -> &'static str {
        match self {
            ElementType::Cube => "cube",
            ElementType::Tet => "tet",
            ElementType::Trimtope => "trimtope",
        }
    }
}

impl Elements {
    /// Which kind of element these are.
    pub fn element_type(&self) -> ElementType {
        match self {
            Elements::Cubes { .. } => ElementType::Cube,
            Elements::Tets { .. } => ElementType::Tet,
            Elements::Trimtopes { .. } => ElementType::Trimtope,
        }
    }
}

/// Bonds in CSR form, both directions stored: row i lists i's neighbours in increasing order.
/// The entry of bond {i, j} in row min(i, j) is its canonical index (its id in break logs).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Bonds {
    /// Row offsets, one more than there are particles.
    pub offsets: Vec<u64>,
    /// Neighbour particle of each entry.
    pub neighbor: Vec<u32>,
    /// Rest length of each entry: the f32 length of X_j - X_i from the stored f32 positions.
    pub rest_length_m: Vec<f32>,
    /// Critical stretch of each entry (equal in both directions), jitter included.
    pub threshold: Vec<f32>,
}

impl Bonds {
    /// Number of particles (rows).
    pub fn rows(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// The entry range of row `i`.
    pub fn row(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i] as usize..self.offsets[i + 1] as usize
    }

    /// Number of unique bonds (half the entries).
    pub fn unique_count(&self) -> usize {
        self.neighbor.len() / 2
    }

    /// The entry index of bond (i, j) in row i, if i and j are bonded.
    pub fn find(&self, i: usize, j: u32) -> Option<usize> {
        let range = self.row(i);
        self.neighbor[range.clone()].binary_search(&j).ok().map(|k| range.start + k)
    }
}

/// Everything `shatter preprocess` produces.
#[derive(Debug, Clone, PartialEq)]
pub struct ParticleSet {
    /// How it was made.
    pub meta: ParticleMeta,
    /// Rest positions X_i, metres.
    pub rest_position_m: Vec<[f32; 3]>,
    /// Volumes V_i, m^3.
    pub volume_m3: Vec<f32>,
    /// Masses m_i = rho V_i, kg.
    pub mass_kg: Vec<f32>,
    /// The element each particle stands for.
    pub elements: Elements,
    /// The bond network.
    pub bonds: Bonds,
    /// Pairs (a, b), a < b, sorted, of elements that share a face; every pair is also a bond.
    pub adjacency: Vec<[u32; 2]>,
}

/// Every bond entry (i, j) of `bonds` (rows sorted, neighbours valid) has a twin (j, i) with the
/// same rest length and threshold, in one pass over the entries: the rows are walked in order,
/// and row j's entries below j are the twins of the earlier rows' entries (i, j), met in the
/// order of i, so a cursor per row finds each where it must be (a binary search per entry read
/// the whole set again in random order).
fn validate_twins(bonds: &Bonds, n: usize) -> Result<(), String> {
    let mut cursor: Vec<usize> = bonds.offsets[..n].iter().map(|&offset| offset as usize).collect();
    for i in 0..n {
        let row = bonds.row(i);
        // the entries below i were all met as twins of earlier rows
        if let Some(&m) = bonds.neighbor[cursor[i]..row.end].first().filter(|&&m| (m as usize) < i) {
            return Err(format!("bond ({i}, {m}) has no twin entry ({m}, {i})"));
        }
        for k in row {
            let j = bonds.neighbor[k] as usize;
            if j < i {
                continue;
            }
            let twin = cursor[j];
            match bonds.neighbor[twin..bonds.offsets[j + 1] as usize].first() {
                Some(&m) if (m as usize) < i => return Err(format!("bond ({j}, {m}) has no twin entry ({m}, {j})")),
                Some(&m) if m as usize == i => {}
                _ => return Err(format!("bond ({i}, {j}) has no twin entry ({j}, {i})")),
            }
            if bonds.threshold[twin] != bonds.threshold[k] || bonds.rest_length_m[twin] != bonds.rest_length_m[k] {
                return Err(format!("bond ({i}, {j}) differs from its twin ({j}, {i})"));
            }
            cursor[j] += 1;
        }
    }
    Ok(())
}

impl ParticleSet {
    /// `elements` at `positions`, `lambda_m` apart (the horizon one spacing), each of unit volume
    /// and mass, with no bonds and no adjacency: a scene for the tracer alone, as the render
    /// tests and benches build theirs.
    pub fn unbonded(positions: Vec<[f32; 3]>, elements: Elements, lambda_m: f64) -> ParticleSet {
        let n = positions.len();
        ParticleSet {
            meta: ParticleMeta {
                scene_name: "t".into(),
                source: "box".into(),
                sampler: "grid".into(),
                lambda_m,
                horizon_factor: 1.0,
                delta_m: lambda_m,
                density_kg_m3: 1.0,
                bulk_modulus_pa: 1.0,
                mean_critical_stretch: 0.01,
                threshold_jitter: 0.0,
                seed: 0,
            },
            rest_position_m: positions,
            volume_m3: vec![1.0; n],
            mass_kg: vec![1.0; n],
            elements,
            bonds: Bonds { offsets: vec![0; n + 1], ..Bonds::default() },
            adjacency: Vec::new(),
        }
    }

    /// The face of element `from` that it shares with the adjacent element `to` (an adjacency
    /// pair), numbered as the renderer numbers an element's planes: for a cube, 2 k for the face on
    /// the positive side of its own axis k and 2 k + 1 for the negative side; for a tetrahedron, k
    /// for the face opposite vertex k (None if the two share no face). Trimtopes: None (every cell
    /// plane is shared; their outer surface is their triangles).
    pub fn shared_face(&self, from: usize, to: usize) -> Option<usize> {
        match &self.elements {
            Elements::Cubes { orientation, .. } => {
                let (a, b) = (self.rest_position_m[from], self.rest_position_m[to]);
                let [x, y, z, w] = *orientation;
                let d = rotate([-x, -y, -z, w], [b[0] - a[0], b[1] - a[1], b[2] - a[2]]);
                let axis = (0..3).fold(0, |best, k| if d[k].abs() > d[best].abs() { k } else { best });
                Some(2 * axis + usize::from(d[axis] <= 0.0))
            }
            Elements::Tets { vertices_m } => (0..4).find(|&k| !vertices_m[to].contains(&vertices_m[from][k])),
            Elements::Trimtopes { .. } => None,
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.rest_position_m.len()
    }

    /// True when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.rest_position_m.is_empty()
    }

    /// Writes the set to `path` atomically.
    pub fn write(&self, path: &Path) -> Result<(), StageFileError> {
        let mut out = StageWriter::create(path, StageKind::Particles)?;
        out.write_json("meta", &self.meta)?;
        out.write_json("element_type", &self.elements.element_type())?;
        out.write_rows("rest_position", &self.rest_position_m)?;
        out.write_rows("volume", &self.volume_m3)?;
        out.write_rows("mass", &self.mass_kg)?;
        match &self.elements {
            Elements::Cubes { half_size_m, orientation } => {
                out.write_rows("cube_half_size", half_size_m)?;
                out.write_rows("cube_orientation", std::slice::from_ref(orientation))?;
            }
            Elements::Tets { vertices_m } => out.write_rows("tet_vertices", vertices_m)?,
            Elements::Trimtopes {
                plane_offsets,
                planes,
                triangle_offsets,
                triangles_m,
                face_offsets,
                face_triangles_m,
                face_planes,
            } => {
                out.write_rows("plane_offsets", plane_offsets)?;
                out.write_rows("planes", planes)?;
                out.write_rows("triangle_offsets", triangle_offsets)?;
                out.write_rows("triangles", triangles_m)?;
                out.write_rows("face_offsets", face_offsets)?;
                out.write_rows("face_triangles", face_triangles_m)?;
                out.write_rows("face_planes", face_planes)?;
            }
        }
        out.write_rows("bond_offsets", &self.bonds.offsets)?;
        out.write_rows("bond_neighbor", &self.bonds.neighbor)?;
        out.write_rows("bond_rest_length", &self.bonds.rest_length_m)?;
        out.write_rows("bond_threshold", &self.bonds.threshold)?;
        out.write_rows("adjacency", &self.adjacency)?;
        out.finish()
    }

    /// Reads and fully validates a particle file.
    pub fn read(path: &Path) -> Result<ParticleSet, StageFileError> {
        Ok(ParticleSet::read_with_checksum(path)?.0)
    }

    /// Reads and fully validates a particle file; also returns its payload checksum, which
    /// identifies its content (later stages record it to notice a changed input).
    pub fn read_with_checksum(path: &Path) -> Result<(ParticleSet, u32), StageFileError> {
        let mut input = StageReader::open(path, StageKind::Particles)?;
        let checksum = input.checksum();
        let meta = input.read_json("meta")?;
        let element_type: ElementType = input.read_json("element_type")?;
        let rest_position_m = input.read_rows("rest_position")?;
        let volume_m3 = input.read_rows("volume")?;
        let mass_kg = input.read_rows("mass")?;
        let elements = match element_type {
            ElementType::Cube => {
                let half_size_m = input.read_rows("cube_half_size")?;
                let orientation: Vec<[f32; 4]> = input.read_rows("cube_orientation")?;
                let [orientation] = orientation[..] else {
                    return Err(input.malformed("cube_orientation must hold exactly one quaternion".into()));
                };
                Elements::Cubes { half_size_m, orientation }
            }
            ElementType::Tet => Elements::Tets { vertices_m: input.read_rows("tet_vertices")? },
            ElementType::Trimtope => Elements::Trimtopes {
                plane_offsets: input.read_rows("plane_offsets")?,
                planes: input.read_rows("planes")?,
                triangle_offsets: input.read_rows("triangle_offsets")?,
                triangles_m: input.read_rows("triangles")?,
                face_offsets: input.read_rows("face_offsets")?,
                face_triangles_m: input.read_rows("face_triangles")?,
                face_planes: input.read_rows("face_planes")?,
            },
        };
        let bonds = Bonds {
            offsets: input.read_rows("bond_offsets")?,
            neighbor: input.read_rows("bond_neighbor")?,
            rest_length_m: input.read_rows("bond_rest_length")?,
            threshold: input.read_rows("bond_threshold")?,
        };
        let adjacency = input.read_rows("adjacency")?;
        let set = ParticleSet { meta, rest_position_m, volume_m3, mass_kg, elements, bonds, adjacency };
        set.validate().map_err(|what| input.malformed(what))?;
        input.finish()?;
        Ok((set, checksum))
    }

    /// Checks every structural rule of the format; returns what is broken.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.len();
        if u32::try_from(n).is_err() {
            return Err(format!("{n} particles: at most {} are supported", u32::MAX));
        }
        if self.volume_m3.len() != n || self.mass_kg.len() != n {
            return Err(format!(
                "{n} positions but {} volumes and {} masses",
                self.volume_m3.len(),
                self.mass_kg.len()
            ));
        }
        if let Some(i) = self.rest_position_m.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
            return Err(format!("particle {i} has a non-finite rest position"));
        }
        let positive = |v: &f32| v.is_finite() && *v > 0.0;
        if let Some(i) = self.volume_m3.iter().position(|v| !positive(v)) {
            return Err(format!("particle {i} has volume {}, not a positive number", self.volume_m3[i]));
        }
        if let Some(i) = self.mass_kg.iter().position(|m| !positive(m)) {
            return Err(format!("particle {i} has mass {}, not a positive number", self.mass_kg[i]));
        }
        let meta = &self.meta;
        let scalars_ok = [meta.lambda_m, meta.delta_m, meta.horizon_factor, meta.mean_critical_stretch]
            .iter()
            .all(|v| v.is_finite() && *v > 0.0);
        if !scalars_ok {
            return Err("lambda_m, delta_m, horizon_factor and mean_critical_stretch must be positive".into());
        }
        self.validate_elements()?;
        self.validate_bonds()?;
        self.validate_adjacency()
    }

    fn validate_elements(&self) -> Result<(), String> {
        let n = self.len();
        match &self.elements {
            Elements::Cubes { half_size_m, orientation } => {
                if half_size_m.len() != n {
                    return Err(format!("{} cube sizes for {n} particles", half_size_m.len()));
                }
                if half_size_m.iter().any(|h| !(h.is_finite() && *h > 0.0)) {
                    return Err("a cube half size is not a positive number".into());
                }
                let norm_sq: f32 = orientation.iter().map(|c| c * c).sum();
                if !norm_sq.is_finite() || (norm_sq - 1.0).abs() > 1e-4 {
                    return Err(format!("cube orientation {orientation:?} is not a unit quaternion"));
                }
            }
            Elements::Tets { vertices_m } => {
                if vertices_m.len() != n {
                    return Err(format!("{} tetrahedra for {n} particles", vertices_m.len()));
                }
                if vertices_m.iter().flatten().flatten().any(|c| !c.is_finite()) {
                    return Err("a tetrahedron vertex is not finite".into());
                }
            }
            Elements::Trimtopes {
                plane_offsets,
                planes,
                triangle_offsets,
                triangles_m,
                face_offsets,
                face_triangles_m,
                face_planes,
            } => {
                validate_offsets("plane_offsets", plane_offsets, n, planes.len())?;
                validate_offsets("triangle_offsets", triangle_offsets, n, triangles_m.len())?;
                validate_offsets("face_offsets", face_offsets, n, face_triangles_m.len())?;
                if planes.iter().flatten().any(|c| !c.is_finite()) {
                    return Err("a trimtope plane is not finite".into());
                }
                if triangles_m.iter().chain(face_triangles_m).flatten().flatten().any(|c| !c.is_finite()) {
                    return Err("a trimtope triangle vertex is not finite".into());
                }
                if face_planes.len() != face_triangles_m.len() {
                    return Err(format!(
                        "{} face triangles but {} face planes",
                        face_triangles_m.len(),
                        face_planes.len()
                    ));
                }
                for i in 0..n {
                    let cell_planes = plane_offsets[i + 1] - plane_offsets[i];
                    let range = face_offsets[i] as usize..face_offsets[i + 1] as usize;
                    if let Some(plane) = face_planes[range].iter().find(|&&k| u64::from(k) >= cell_planes) {
                        return Err(format!("a face triangle of cell {i} lies on plane {plane} of {cell_planes}"));
                    }
                }
            }
        }
        Ok(())
    }

    fn validate_bonds(&self) -> Result<(), String> {
        let bonds = &self.bonds;
        let n = self.len();
        validate_offsets("bond_offsets", &bonds.offsets, n, bonds.neighbor.len())?;
        let entries = bonds.neighbor.len();
        if bonds.rest_length_m.len() != entries || bonds.threshold.len() != entries {
            return Err(format!(
                "{entries} bond neighbours but {} rest lengths and {} thresholds",
                bonds.rest_length_m.len(),
                bonds.threshold.len()
            ));
        }
        (0..n).into_par_iter().try_for_each(|i| {
            let row = bonds.row(i);
            let neighbors = &bonds.neighbor[row.clone()];
            if neighbors.windows(2).any(|pair| pair[0] >= pair[1]) {
                return Err(format!("bond row {i} is not strictly increasing"));
            }
            for (k, &j) in row.zip(neighbors) {
                if j as usize >= n || j as usize == i {
                    return Err(format!("particle {i} is bonded to invalid particle {j}"));
                }
                let length = bonds.rest_length_m[k];
                let threshold = bonds.threshold[k];
                if !(length.is_finite() && length > 0.0 && threshold.is_finite() && threshold > 0.0) {
                    return Err(format!("bond ({i}, {j}) has rest length {length} and threshold {threshold}"));
                }
            }
            Ok(())
        })?;
        validate_twins(bonds, n)
    }

    fn validate_adjacency(&self) -> Result<(), String> {
        if let Some(pair) = self.adjacency.windows(2).find(|pair| pair[0] >= pair[1]) {
            return Err(format!("adjacency is not sorted and unique at {:?}", pair[1]));
        }
        for &[a, b] in &self.adjacency {
            if a >= b || b as usize >= self.len() {
                return Err(format!("adjacency pair ({a}, {b}) is not a < b < particles"));
            }
            if self.bonds.find(a as usize, b).is_none() {
                return Err(format!("adjacent elements {a} and {b} are not bonded"));
            }
        }
        Ok(())
    }
}

fn validate_offsets(name: &str, offsets: &[u64], rows: usize, entries: usize) -> Result<(), String> {
    if offsets.len() != rows + 1 {
        return Err(format!("{name} has {} entries for {rows} particles", offsets.len()));
    }
    if offsets[0] != 0 || offsets[rows] != entries as u64 {
        return Err(format!("{name} must run from 0 to {entries}"));
    }
    if offsets.windows(2).any(|pair| pair[0] > pair[1]) {
        return Err(format!("{name} decreases"));
    }
    Ok(())
}

/// `v` rotated by the unit quaternion `q` = [x, y, z, w].
fn rotate(q: [f32; 4], v: [f32; 3]) -> [f32; 3] {
    let cross =
        |a: [f32; 3], b: [f32; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let u = [q[0], q[1], q[2]];
    let t = cross(u, v).map(|c| 2.0 * c);
    let s = cross(u, t);
    [0, 1, 2].map(|k| v[k] + q[3] * t[k] + s[k])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three particles in a row, bonded 0-1 and 1-2, adjacent 0-1.
    fn sample(elements: Elements) -> ParticleSet {
        ParticleSet {
            meta: ParticleMeta {
                scene_name: "t".into(),
                source: "box".into(),
                sampler: "grid".into(),
                lambda_m: 1.0,
                horizon_factor: 1.0,
                delta_m: 1.0,
                density_kg_m3: 2.0,
                bulk_modulus_pa: 3.0,
                mean_critical_stretch: 0.01,
                threshold_jitter: 0.0,
                seed: 5,
            },
            rest_position_m: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            volume_m3: vec![1.0; 3],
            mass_kg: vec![2.0; 3],
            elements,
            bonds: Bonds {
                offsets: vec![0, 1, 3, 4],
                neighbor: vec![1, 0, 2, 1],
                rest_length_m: vec![1.0; 4],
                threshold: vec![0.01, 0.01, 0.02, 0.02],
            },
            adjacency: vec![[0, 1]],
        }
    }

    fn all_element_kinds() -> Vec<Elements> {
        let tet = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        vec![
            Elements::Cubes { half_size_m: vec![0.5; 3], orientation: [0.0, 0.0, 0.0, 1.0] },
            Elements::Tets { vertices_m: vec![tet; 3] },
            Elements::Trimtopes {
                plane_offsets: vec![0, 1, 1, 2],
                planes: vec![[1.0, 0.0, 0.0, 0.5], [0.0, 1.0, 0.0, 0.5]],
                triangle_offsets: vec![0, 0, 1, 1],
                triangles_m: vec![[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]],
                face_offsets: vec![0, 1, 1, 1],
                face_triangles_m: vec![[[0.5, 0.0, 0.0], [0.5, 1.0, 0.0], [0.5, 0.0, 1.0]]],
                face_planes: vec![0],
            },
        ]
    }

    #[test]
    fn every_element_kind_round_trips() {
        let dir = tempfile::tempdir().expect("tempdir");
        for elements in all_element_kinds() {
            let set = sample(elements);
            set.validate().expect("sample is valid");
            let path = dir.path().join("p.shp");
            set.write(&path).expect("write");
            assert_eq!(ParticleSet::read(&path).expect("read"), set);
        }
    }

    #[test]
    fn structural_defects_are_named() {
        let mut asymmetric = sample(all_element_kinds().remove(0));
        asymmetric.bonds.threshold[0] = 0.5;
        assert!(asymmetric.validate().expect_err("twin").contains("differs from its twin"));
        let mut out_of_range = sample(all_element_kinds().remove(0));
        out_of_range.bonds.neighbor[3] = 7;
        assert!(out_of_range.validate().is_err());
        let mut unbonded = sample(all_element_kinds().remove(0));
        unbonded.adjacency = vec![[0, 2]];
        assert!(unbonded.validate().expect_err("adjacency").contains("not bonded"));
    }

    /// The one-pass twin check finds what a search for every entry's twin finds: on random
    /// bond sets, whole, with an entry dropped, and with an entry's threshold changed, it fails
    /// exactly when the search does, naming an entry the search finds without its twin.
    #[test]
    fn the_twin_check_finds_what_a_search_for_each_twin_finds() {
        let without_twin = |bonds: &Bonds| -> Vec<(usize, u32)> {
            (0..bonds.rows())
                .flat_map(|i| bonds.row(i).map(move |k| (i, k)))
                .filter(|&(i, k)| {
                    let j = bonds.neighbor[k] as usize;
                    bonds.find(j, i as u32).is_none_or(|twin| {
                        bonds.threshold[twin] != bonds.threshold[k]
                            || bonds.rest_length_m[twin] != bonds.rest_length_m[k]
                    })
                })
                .map(|(i, k)| (i, bonds.neighbor[k]))
                .collect()
        };
        let mut failures = 0;
        for seed in 0..40 {
            let mut rng = crate::random::SplitMix64::new(seed);
            let n = 30;
            let mut rows: Vec<Vec<(u32, f32)>> = vec![Vec::new(); n];
            for _ in 0..120 {
                let (i, j) = ((rng.next_u64() % n as u64) as usize, (rng.next_u64() % n as u64) as usize);
                if i != j && !rows[i].iter().any(|e| e.0 == j as u32) {
                    let threshold = 0.5 + rng.next_f64() as f32;
                    rows[i].push((j as u32, threshold));
                    rows[j].push((i as u32, threshold));
                }
            }
            match seed % 3 {
                1 => {
                    let i = (rng.next_u64() % n as u64) as usize;
                    if !rows[i].is_empty() {
                        let k = (rng.next_u64() % rows[i].len() as u64) as usize;
                        rows[i].remove(k);
                    }
                }
                2 => {
                    let i = (rng.next_u64() % n as u64) as usize;
                    if let Some(entry) = rows[i].first_mut() {
                        entry.1 += 0.25;
                    }
                }
                _ => {}
            }
            let mut bonds = Bonds { offsets: vec![0], ..Bonds::default() };
            for row in &mut rows {
                row.sort_by_key(|e| e.0);
                for &(j, threshold) in row.iter() {
                    bonds.neighbor.push(j);
                    bonds.threshold.push(threshold);
                    bonds.rest_length_m.push(1.0);
                }
                bonds.offsets.push(bonds.neighbor.len() as u64);
            }
            let lonely = without_twin(&bonds);
            match validate_twins(&bonds, n) {
                Ok(()) => assert!(lonely.is_empty(), "seed {seed}: {lonely:?} passed"),
                Err(message) => {
                    failures += 1;
                    let named = lonely.iter().any(|(i, j)| message.starts_with(&format!("bond ({i}, {j}) ")));
                    assert!(named, "seed {seed}: {message:?} names none of {lonely:?}");
                }
            }
        }
        assert!(failures >= 20, "only {failures} defective sets");
        // a last row's entry below it whose twin no row holds, and no later row would meet
        let lone = Bonds {
            offsets: vec![0, 1, 2, 3],
            neighbor: vec![1, 0, 1],
            rest_length_m: vec![1.0; 3],
            threshold: vec![1.0; 3],
        };
        assert_eq!(validate_twins(&lone, 3), Err("bond (2, 1) has no twin entry (1, 2)".to_string()));
    }

    #[test]
    fn summary_counts_unique_bonds() {
        let summary = sample(all_element_kinds().remove(0)).summary();
        assert_eq!(summary.bonds, 2);
        assert_eq!(summary.bonds_per_particle.min, 1);
        assert_eq!(summary.bonds_per_particle.max, 2);
        assert!((summary.bonds_per_particle.mean - 4.0 / 3.0).abs() < 1e-12);
        assert_eq!(summary.total_mass_kg, 6.0);
    }
}
