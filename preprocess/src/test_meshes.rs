//! Meshes the unit tests sample.

use glam::DVec3;
use shatter_geometry::TriangleMesh;

/// An axis-aligned cube with outward winding, corners at 0 and `size`.
pub(crate) fn cube(size: f64) -> TriangleMesh {
    let mut mesh = TriangleMesh::cuboid([size; 3]);
    mesh.map_positions(|p| p + DVec3::splat(0.5 * size));
    mesh
}

/// An octahedron with corners on the axes at `radius`, each face split into `n * n`
/// triangles whose vertices are pushed onto the sphere of that radius when `round` is set
/// (a sphere-like mesh), outward winding.
pub(crate) fn octahedron(n: usize, radius: f64, round: bool) -> TriangleMesh {
    let mut mesh = TriangleMesh::default();
    for signs in 0..8 {
        let sign = DVec3::new(
            if signs & 1 == 0 { 1.0 } else { -1.0 },
            if signs & 2 == 0 { 1.0 } else { -1.0 },
            if signs & 4 == 0 { 1.0 } else { -1.0 },
        );
        let point = |i: usize, j: usize| {
            let p = DVec3::new(i as f64, j as f64, (n - i - j) as f64) * sign / n as f64;
            if round { p.normalize() * radius } else { p * radius }
        };
        let flip = sign.x * sign.y * sign.z < 0.0;
        let mut add = |a: DVec3, b: DVec3, c: DVec3| {
            let base = mesh.positions.len() as u32;
            mesh.positions.extend([a, b, c]);
            mesh.triangles.push(if flip { [base, base + 2, base + 1] } else { [base, base + 1, base + 2] });
        };
        for i in 0..n {
            for j in 0..n - i {
                add(point(i, j), point(i + 1, j), point(i, j + 1));
                if i + j + 1 < n {
                    add(point(i + 1, j), point(i + 1, j + 1), point(i, j + 1));
                }
            }
        }
    }
    mesh.weld();
    mesh
}
