//! Mass, centre of mass and inertia tensor of each element and of each piece, exactly from the
//! elements' closed surfaces (divergence theorem over their triangles): the piece a rigid body
//! stands for weighs what its particles weigh, and turns as its elements' volume does.

use rapier3d_f64::math::{Matrix, Vector};
use shatter_core::ParticleSet;
use shatter_core::particles::Elements;

/// Mass properties of one element or piece in the rest frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProps {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Centre of mass, metres (rest frame).
    pub centre_m: Vector,
    /// Second moment of the mass about the centre, kg m^2: the integral of r r^T dm.
    pub second_moment: Matrix,
}

impl MassProps {
    /// Nothing.
    pub const ZERO: MassProps = MassProps { mass_kg: 0.0, centre_m: Vector::ZERO, second_moment: Matrix::ZERO };

    /// The inertia tensor about the centre of mass, kg m^2: tr(C) 1 - C.
    pub fn inertia(&self) -> Matrix {
        let c = self.second_moment;
        Matrix::from_diagonal(Vector::splat(c.x_axis.x + c.y_axis.y + c.z_axis.z)) - c
    }

    /// The union of two bodies (parallel-axis theorem).
    pub fn combine(&self, other: &MassProps) -> MassProps {
        let mass_kg = self.mass_kg + other.mass_kg;
        if mass_kg <= 0.0 {
            return MassProps::ZERO;
        }
        let centre_m = (self.centre_m * self.mass_kg + other.centre_m * other.mass_kg) / mass_kg;
        let shifted = |p: &MassProps| {
            let d = p.centre_m - centre_m;
            p.second_moment + outer(d, d) * p.mass_kg
        };
        MassProps { mass_kg, centre_m, second_moment: shifted(self) + shifted(other) }
    }
}

/// The outer product a b^T.
pub(crate) fn outer(a: Vector, b: Vector) -> Matrix {
    Matrix::from_cols(a * b.x, a * b.y, a * b.z)
}

/// Volume, centroid and second moment (per unit density) of the solid a closed, outward-wound
/// triangle surface bounds, integrated about `origin` for accuracy and returned about the
/// centroid. None when the surface encloses no volume.
pub fn solid_of_triangles(triangles: &[[Vector; 3]], origin: Vector) -> Option<(f64, Vector, Matrix)> {
    let mut volume = 0.0;
    let mut first = Vector::ZERO;
    let mut second = Matrix::ZERO;
    for t in triangles {
        let [a, b, c] = t.map(|v| v - origin);
        let v = a.dot(b.cross(c)) / 6.0;
        let sum = a + b + c;
        volume += v;
        first += sum * (v / 4.0);
        second += (outer(a, a) + outer(b, b) + outer(c, c) + outer(sum, sum)) * (v / 20.0);
    }
    if !(volume.is_finite() && volume > 0.0) {
        return None;
    }
    let centroid = first / volume;
    let about_centroid = second - outer(centroid, centroid) * volume;
    Some((volume, origin + centroid, about_centroid))
}

/// The closed, outward-wound triangle surface of element `element` in the rest frame.
pub fn element_triangles(particles: &ParticleSet, element: usize, out: &mut Vec<[Vector; 3]>) {
    out.clear();
    let vector = |p: [f32; 3]| Vector::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
    match &particles.elements {
        Elements::Cubes { half_size_m, orientation } => {
            let centre = vector(particles.rest_position_m[element]);
            let q = rapier3d_f64::math::Rotation::from_xyzw(
                f64::from(orientation[0]),
                f64::from(orientation[1]),
                f64::from(orientation[2]),
                f64::from(orientation[3]),
            )
            .normalize();
            let h = f64::from(half_size_m[element]);
            let corner = |i: usize| {
                let sign = |bit: usize| if i & bit != 0 { h } else { -h };
                centre + q * Vector::new(sign(1), sign(2), sign(4))
            };
            // each face as two triangles, outward (corner index bits: x = 1, y = 2, z = 4)
            const FACES: [[usize; 4]; 6] =
                [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
            for [a, b, c, d] in FACES {
                out.push([corner(a), corner(b), corner(c)]);
                out.push([corner(a), corner(c), corner(d)]);
            }
        }
        Elements::Tets { vertices_m } => {
            out.extend(tet_triangles(vertices_m[element].map(vector)));
        }
        Elements::Trimtopes { triangle_offsets, triangles_m, face_offsets, face_triangles_m, .. } => {
            let range = |offsets: &[u64]| offsets[element] as usize..offsets[element + 1] as usize;
            let surface = triangles_m[range(triangle_offsets)].iter();
            let faces = face_triangles_m[range(face_offsets)].iter();
            out.extend(surface.chain(faces).map(|t| t.map(vector)));
        }
    }
}

/// The four faces of a tetrahedron, wound outward whichever its vertices' orientation.
pub fn tet_triangles([v0, v1, v2, v3]: [Vector; 4]) -> [[Vector; 3]; 4] {
    if (v1 - v0).dot((v2 - v0).cross(v3 - v0)) >= 0.0 {
        [[v1, v2, v3], [v0, v3, v2], [v0, v1, v3], [v0, v2, v1]]
    } else {
        [[v1, v3, v2], [v0, v2, v3], [v0, v3, v1], [v0, v1, v2]]
    }
}

/// The mass properties of every element: the particle's mass (volume times `density_kg_m3`,
/// as the simulation weighs it) spread over the element's own shape. An element whose surface
/// encloses nothing counts as a point mass at its particle.
pub fn element_mass_props(particles: &ParticleSet, density_kg_m3: f64) -> Vec<MassProps> {
    let mut triangles = Vec::new();
    (0..particles.len())
        .map(|element| {
            let mass_kg = f64::from(particles.volume_m3[element]) * density_kg_m3;
            let p = particles.rest_position_m[element];
            let origin = Vector::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
            element_triangles(particles, element, &mut triangles);
            match solid_of_triangles(&triangles, origin) {
                Some((volume, centre_m, second)) => {
                    MassProps { mass_kg, centre_m, second_moment: second * (mass_kg / volume) }
                }
                None => MassProps { mass_kg, centre_m: origin, second_moment: Matrix::ZERO },
            }
        })
        .collect()
}

/// The mass properties of each piece: the union of its elements'.
pub fn piece_mass_props(elements: &[MassProps], piece_of: &[u32], pieces: usize) -> Vec<MassProps> {
    let mut mass = vec![0.0; pieces];
    let mut weighted = vec![Vector::ZERO; pieces];
    for (element, &piece) in elements.iter().zip(piece_of) {
        mass[piece as usize] += element.mass_kg;
        weighted[piece as usize] += element.centre_m * element.mass_kg;
    }
    let centre: Vec<Vector> =
        mass.iter().zip(&weighted).map(|(m, w)| if *m > 0.0 { *w / *m } else { Vector::ZERO }).collect();
    let mut second = vec![Matrix::ZERO; pieces];
    for (element, &piece) in elements.iter().zip(piece_of) {
        let d = element.centre_m - centre[piece as usize];
        second[piece as usize] += element.second_moment + outer(d, d) * element.mass_kg;
    }
    (0..pieces).map(|p| MassProps { mass_kg: mass[p], centre_m: centre[p], second_moment: second[p] }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn box_triangles(half: Vector, centre: Vector) -> Vec<[Vector; 3]> {
        let corner = |i: usize| {
            centre
                + Vector::new(
                    if i & 1 != 0 { half.x } else { -half.x },
                    if i & 2 != 0 { half.y } else { -half.y },
                    if i & 4 != 0 { half.z } else { -half.z },
                )
        };
        const FACES: [[usize; 4]; 6] =
            [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
        FACES
            .iter()
            .flat_map(|[a, b, c, d]| [[corner(*a), corner(*b), corner(*c)], [corner(*a), corner(*c), corner(*d)]])
            .collect()
    }

    #[test]
    fn a_box_has_its_textbook_volume_centre_and_inertia() {
        let half = Vector::new(0.5, 1.0, 1.5);
        let centre = Vector::new(3.0, -2.0, 7.0);
        let (volume, c, second) = solid_of_triangles(&box_triangles(half, centre), Vector::ZERO).expect("solid");
        assert!((volume - 6.0).abs() < 1e-12);
        assert!((c - centre).length() < 1e-12);
        let mass = 2.0;
        let props = MassProps { mass_kg: mass, centre_m: c, second_moment: second * (mass / volume) };
        let [a, b, d] = [1.0, 2.0, 3.0];
        let expected = Vector::new(b * b + d * d, a * a + d * d, a * a + b * b) * (mass / 12.0);
        let inertia = props.inertia();
        let diagonal = Vector::new(inertia.x_axis.x, inertia.y_axis.y, inertia.z_axis.z);
        assert!((diagonal - expected).length() < 1e-12, "{diagonal:?} vs {expected:?}");
        assert!(inertia.x_axis.y.abs() < 1e-12 && inertia.x_axis.z.abs() < 1e-12 && inertia.y_axis.z.abs() < 1e-12);
    }

    #[test]
    fn a_tet_of_either_orientation_has_its_volume_and_centroid() {
        let corners = [Vector::ZERO, Vector::X, Vector::Y, Vector::Z].map(|v| v * 0.006 + Vector::new(0.1, 0.2, 0.3));
        for vertices in [corners, [corners[0], corners[2], corners[1], corners[3]]] {
            let (volume, centroid, second) = solid_of_triangles(&tet_triangles(vertices), vertices[0]).expect("solid");
            assert!((volume - 0.006f64.powi(3) / 6.0).abs() < 1e-18, "{volume}");
            let expected = vertices.iter().fold(Vector::ZERO, |c, v| c + *v) / 4.0;
            assert!((centroid - expected).length() < 1e-15);
            let props = MassProps { mass_kg: 1.0, centre_m: centroid, second_moment: second / volume };
            let eigen = rapier3d_f64::math::SymmetricEigen::new(props.inertia());
            assert!(eigen.eigenvalues.min_element() > 1e-7, "a real tet turns: {:?}", eigen.eigenvalues);
        }
    }

    #[test]
    fn two_halves_combine_into_the_whole() {
        let half = Vector::new(0.25, 1.0, 1.5);
        let whole =
            solid_of_triangles(&box_triangles(Vector::new(0.5, 1.0, 1.5), Vector::ZERO), Vector::ZERO).expect("whole");
        let part = |x: f64| {
            let (v, c, s) =
                solid_of_triangles(&box_triangles(half, Vector::new(x, 0.0, 0.0)), Vector::ZERO).expect("half");
            MassProps { mass_kg: v, centre_m: c, second_moment: s }
        };
        let combined = part(-0.25).combine(&part(0.25));
        assert!((combined.mass_kg - whole.0).abs() < 1e-12);
        assert!(combined.centre_m.length() < 1e-12);
        assert!((combined.second_moment - whole.2).abs().to_cols_array().iter().all(|d| *d < 1e-12));
    }
}
