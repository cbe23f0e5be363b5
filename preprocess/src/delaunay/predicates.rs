//! The exact geometric predicates the tetrahedralization decides with: Shewchuk's adaptive
//! [`robust::orient3d`] and [`robust::insphere`] on [`DVec3`] points.

use glam::DVec3;
use robust::{Coord3D, orient3d};

/// Exactly: do `a`, `b`, `c` lie on one line? (All three axis-plane projections are collinear.)
pub(super) fn collinear(a: DVec3, b: DVec3, c: DVec3) -> bool {
    let projected = |p: DVec3, x: usize, y: usize| robust::Coord { x: p[x], y: p[y] };
    [(0, 1), (1, 2), (2, 0)]
        .iter()
        .all(|&(x, y)| robust::orient2d(projected(a, x, y), projected(b, x, y), projected(c, x, y)) == 0.0)
}

pub(super) fn coord(p: DVec3) -> Coord3D<f64> {
    Coord3D { x: p.x, y: p.y, z: p.z }
}

/// [`robust::orient3d`] on vectors.
pub(super) fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    orient3d(coord(a), coord(b), coord(c), coord(d))
}
