//! Part of a particle set as a particle set of its own: the particles of some pieces, with the
//! bonds between them that still hold. A piece that goes back to the simulation
//! ([`crate::reentry`]) is simulated as such a set; its particles keep their rest positions, so
//! the fragments found in it move from the same rest frame as the whole shot's.

use crate::particles::{Bonds, Elements, ParticleSet};

impl ParticleSet {
    /// The particles `members` (ascending, distinct, in range), renumbered 0.. in that order,
    /// with the bonds between two members whose canonical entry (its index in row min(i, j))
    /// `intact` keeps, and the adjacency pairs of those bonds.
    pub fn subset(&self, members: &[u32], intact: impl Fn(usize) -> bool) -> ParticleSet {
        let mut local = vec![u32::MAX; self.len()];
        for (new, &old) in members.iter().enumerate() {
            local[old as usize] = new as u32;
        }
        let kept = |i: usize, k: usize| {
            let j = self.bonds.neighbor[k] as usize;
            let canonical = if i < j { k } else { self.bonds.find(j, i as u32).unwrap_or(k) };
            local[j] != u32::MAX && intact(canonical)
        };
        let mut bonds = Bonds { offsets: vec![0], ..Bonds::default() };
        for &old in members {
            let i = old as usize;
            for k in self.bonds.row(i).filter(|&k| kept(i, k)) {
                bonds.neighbor.push(local[self.bonds.neighbor[k] as usize]);
                bonds.rest_length_m.push(self.bonds.rest_length_m[k]);
                bonds.threshold.push(self.bonds.threshold[k]);
            }
            bonds.offsets.push(bonds.neighbor.len() as u64);
        }
        let pick = |values: &[f32]| members.iter().map(|&i| values[i as usize]).collect::<Vec<f32>>();
        let mut subset = ParticleSet {
            meta: self.meta.clone(),
            rest_position_m: members.iter().map(|&i| self.rest_position_m[i as usize]).collect(),
            volume_m3: pick(&self.volume_m3),
            mass_kg: pick(&self.mass_kg),
            elements: subset_elements(&self.elements, members),
            bonds,
            adjacency: Vec::new(),
        };
        subset.adjacency = self
            .adjacency
            .iter()
            .map(|&[a, b]| [local[a as usize], local[b as usize]])
            .filter(|&[a, b]| a != u32::MAX && b != u32::MAX && subset.bonds.find(a as usize, b).is_some())
            .map(|[a, b]| if a < b { [a, b] } else { [b, a] })
            .collect();
        subset.adjacency.sort_unstable();
        subset
    }
}

/// The elements of `members`, in that order.
fn subset_elements(elements: &Elements, members: &[u32]) -> Elements {
    match elements {
        Elements::Cubes { half_size_m, orientation } => Elements::Cubes {
            half_size_m: members.iter().map(|&i| half_size_m[i as usize]).collect(),
            orientation: *orientation,
        },
        Elements::Tets { vertices_m } => {
            Elements::Tets { vertices_m: members.iter().map(|&i| vertices_m[i as usize]).collect() }
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
            // a face triangle's plane goes with it (the same rows)
            let (_, face_planes) = subset_rows(face_offsets, face_planes, members);
            let (plane_offsets, planes) = subset_rows(plane_offsets, planes, members);
            let (triangle_offsets, triangles_m) = subset_rows(triangle_offsets, triangles_m, members);
            let (face_offsets, face_triangles_m) = subset_rows(face_offsets, face_triangles_m, members);
            Elements::Trimtopes {
                plane_offsets,
                planes,
                triangle_offsets,
                triangles_m,
                face_offsets,
                face_triangles_m,
                face_planes,
            }
        }
    }
}

/// The rows `members` of a CSR table (`offsets` into `values`), renumbered in that order.
fn subset_rows<T: Copy>(offsets: &[u64], values: &[T], members: &[u32]) -> (Vec<u64>, Vec<T>) {
    let mut new_offsets = Vec::with_capacity(members.len() + 1);
    new_offsets.push(0);
    let mut new_values = Vec::new();
    for &i in members {
        let i = i as usize;
        new_values.extend_from_slice(&values[offsets[i] as usize..offsets[i + 1] as usize]);
        new_offsets.push(new_values.len() as u64);
    }
    (new_offsets, new_values)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use crate::particles::ParticleSet;

    /// A row of four cubes, each bonded to the next two, and face-adjacent to the next.
    fn row_of_four() -> ParticleSet {
        let mut set = ParticleSet::unbonded(
            (0..4).map(|i| [i as f32, 0.0, 0.0]).collect(),
            crate::particles::Elements::Cubes { half_size_m: vec![0.5; 4], orientation: [0.0, 0.0, 0.0, 1.0] },
            1.0,
        );
        set.bonds.offsets = vec![0];
        for i in 0..4u32 {
            set.bonds.neighbor.extend((0..4u32).filter(|&j| j != i && i.abs_diff(j) <= 2));
            set.bonds.offsets.push(set.bonds.neighbor.len() as u64);
        }
        let entries = set.bonds.neighbor.len();
        set.bonds.rest_length_m = vec![1.0; entries];
        set.bonds.threshold = vec![0.01; entries];
        set.adjacency = vec![[0, 1], [1, 2], [2, 3]];
        set
    }

    #[test]
    fn a_subset_keeps_its_members_intact_bonds_and_their_faces() {
        let set = row_of_four();
        set.validate().expect("the test set is valid");
        // bond {1, 2} broken: its canonical entry is in row 1
        let broken = set.bonds.find(1, 2).expect("bonded");
        let subset = set.subset(&[1, 2, 3], |entry| entry != broken);
        subset.validate().expect("the subset is valid");
        assert_eq!(subset.rest_position_m, vec![[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0]]);
        // local 0 (old 1) keeps {1, 3}; {1, 2} is broken and {0, 1} left with particle 0
        assert_eq!(subset.bonds.neighbor[subset.bonds.row(0)], [2]);
        assert_eq!(subset.bonds.neighbor[subset.bonds.row(1)], [2]);
        assert_eq!(subset.bonds.neighbor[subset.bonds.row(2)], [0, 1]);
        assert_eq!(subset.adjacency, vec![[1, 2]]);
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("subset.shp");
        subset.write(&path).expect("write");
        assert_eq!(ParticleSet::read(Path::new(&path)).expect("read"), subset);
    }
}
