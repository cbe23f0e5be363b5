//! Collision shapes of the pieces, in the rest frame (a body's frame is its piece's rest
//! frame: its pose is the Kabsch motion x = R X + t).
//!
//! A piece whose convex hull is at most `hull_volume_factor` times its own volume collides as
//! that hull (every small shard). A concave piece is split in two at the median of its
//! elements along its longest extent, and each half again, until each part is close enough to
//! its hull: a convex decomposition made of the piece's own elements, which never reaches
//! further than the elements' hulls do and so neither explodes on contact nor misses one.

use rapier3d_f64::geometry::SharedShape;
use rapier3d_f64::math::{Pose, Vector};
use rapier3d_f64::parry::transformation::try_convex_hull;
use shatter_core::ParticleSet;

use crate::mass::{element_triangles, solid_of_triangles};

/// The most hulls one piece is split into.
pub const MAX_HULLS_PER_PIECE: usize = 256;

/// A piece's collision shape: its convex parts, each as the points it is the hull of.
#[derive(Debug, Clone, PartialEq)]
pub struct PieceShape {
    /// Points of each convex part, metres (rest frame).
    pub hulls: Vec<Vec<Vector>>,
}

impl PieceShape {
    /// The shape rapier collides: one hull, or a compound of them. None when no part has a
    /// hull (degenerate elements).
    pub fn shared_shape(&self) -> Option<SharedShape> {
        let mut parts: Vec<SharedShape> =
            self.hulls.iter().filter_map(|points| SharedShape::convex_hull(points)).collect();
        match parts.len() {
            0 => None,
            1 => parts.pop(),
            _ => Some(SharedShape::compound(parts.into_iter().map(|part| (Pose::IDENTITY, part)).collect())),
        }
    }
}

/// The element vertices and volumes a piece's shape is made from.
pub struct ElementGeometry {
    vertices: Vec<Vec<Vector>>,
    centroid: Vec<Vector>,
    volume: Vec<f64>,
}

impl ElementGeometry {
    /// The vertices, centroid and volume of every element.
    pub fn of(particles: &ParticleSet) -> ElementGeometry {
        let mut triangles = Vec::new();
        let mut geometry =
            ElementGeometry { vertices: Vec::with_capacity(particles.len()), centroid: Vec::new(), volume: Vec::new() };
        for element in 0..particles.len() {
            element_triangles(particles, element, &mut triangles);
            let mut points: Vec<Vector> = triangles.iter().flatten().copied().collect();
            points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)).then(a.z.total_cmp(&b.z)));
            points.dedup();
            let p = particles.rest_position_m[element];
            let origin = Vector::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
            let (volume, centroid) = solid_of_triangles(&triangles, origin)
                .map_or((0.0, origin), |(volume, centroid, _)| (volume, centroid));
            geometry.vertices.push(points);
            geometry.centroid.push(centroid);
            geometry.volume.push(volume);
        }
        geometry
    }

    /// The collision shape of the piece made of `elements`.
    pub fn piece_shape(&self, elements: &[u32], hull_volume_factor: f64) -> PieceShape {
        let mut hulls = Vec::new();
        let mut pending = vec![elements.to_vec()];
        while let Some(mut part) = pending.pop() {
            let points: Vec<Vector> = part.iter().flat_map(|&e| self.vertices[e as usize].iter().copied()).collect();
            let volume: f64 = part.iter().map(|&e| self.volume[e as usize]).sum();
            let convex_enough = part.len() == 1
                || hulls.len() + pending.len() + 1 >= MAX_HULLS_PER_PIECE
                || hull_volume(&points).is_some_and(|hull| hull <= hull_volume_factor * volume);
            if convex_enough {
                hulls.push(points);
                continue;
            }
            let axis = self.longest_axis(&part);
            part.sort_by(|&a, &b| {
                self.centroid[a as usize][axis].total_cmp(&self.centroid[b as usize][axis]).then(a.cmp(&b))
            });
            let upper = part.split_off(part.len() / 2);
            pending.push(upper);
            pending.push(part);
        }
        PieceShape { hulls }
    }

    fn longest_axis(&self, part: &[u32]) -> usize {
        let mut low = Vector::splat(f64::INFINITY);
        let mut high = Vector::splat(f64::NEG_INFINITY);
        for &e in part {
            low = low.min(self.centroid[e as usize]);
            high = high.max(self.centroid[e as usize]);
        }
        let extent = high - low;
        if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        }
    }
}

/// The volume of the convex hull of `points`; None when they span no volume.
pub fn hull_volume(points: &[Vector]) -> Option<f64> {
    let (vertices, faces) = try_convex_hull(points).ok()?;
    let triangles: Vec<[Vector; 3]> = faces.iter().map(|f| f.map(|i| vertices[i as usize])).collect();
    let origin = vertices.first().copied()?;
    solid_of_triangles(&triangles, origin).map(|(volume, _, _)| volume)
}
