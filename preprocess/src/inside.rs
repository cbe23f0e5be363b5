//! Which lattice cell centres lie inside a triangle mesh.
//!
//! Each line of cell centres parallel to an axis is cut by the mesh's triangles; the cuts, sorted
//! along the line, give the winding number of every centre on it. The point-in-triangle tests use
//! exact orientation predicates (the `robust` crate) with a symbolic perturbation of the line
//! (simulation of simplicity), so a line through a shared edge or vertex is counted exactly once:
//! on a closed mesh the count is exact. A line whose winding does not return to zero at its end
//! has passed through a hole; centres on such lines are decided by the lines along the other two
//! axes (a majority of the ones that are not leaky), so a few open or non-manifold edges do not
//! spill the fill.

use rayon::prelude::*;
use robust::{Coord, orient2d};

use crate::lattice::Lattice;
use shatter_geometry::mesh::TriangleMesh;

/// How a winding number decides inside.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FillRule {
    /// Inside where the winding number is not zero (consistently wound meshes).
    NonZero,
    /// Inside where the line has crossed the surface an odd number of times.
    EvenOdd,
}

impl FillRule {
    fn inside(self, winding: i32, crossings: u32) -> bool {
        match self {
            FillRule::NonZero => winding != 0,
            FillRule::EvenOdd => crossings % 2 == 1,
        }
    }
}

/// The result of an inside test over a lattice.
#[derive(Debug, Clone, PartialEq)]
pub struct InsideCells {
    /// Per cell (lattice linear order): is its centre inside?
    pub inside: Vec<bool>,
    /// Lines (along any axis) that passed through a hole.
    pub leaky_lines: usize,
    /// Cells whose answer came from a vote because their z line leaked.
    pub voted_cells: usize,
}

const OUTSIDE: u8 = 0;
const INSIDE: u8 = 1;
const LEAKY: u8 = 2;

/// Tests every cell centre of `lattice` against `mesh`.
pub fn inside_cells(mesh: &TriangleMesh, lattice: &Lattice, rule: FillRule) -> InsideCells {
    let (along_z, leaky_z) = axis_pass(mesh, lattice, 2, rule);
    if leaky_z == 0 {
        let inside = along_z.iter().map(|state| *state == INSIDE).collect();
        return InsideCells { inside, leaky_lines: 0, voted_cells: 0 };
    }
    let (along_x, leaky_x) = axis_pass(mesh, lattice, 0, rule);
    let (along_y, leaky_y) = axis_pass(mesh, lattice, 1, rule);
    let mut voted_cells = 0;
    let inside = (0..lattice.cell_count())
        .map(|cell| {
            let states = [along_z[cell], along_x[cell], along_y[cell]];
            if states[0] & LEAKY == 0 {
                return states[0] == INSIDE;
            }
            voted_cells += 1;
            let sound: Vec<u8> = states.iter().copied().filter(|s| s & LEAKY == 0).collect();
            match sound.len() {
                0 => states.iter().filter(|s| *s & INSIDE != 0).count() >= 2,
                _ => sound.iter().filter(|s| **s == INSIDE).count() * 2 >= sound.len(),
            }
        })
        .collect();
    InsideCells { inside, leaky_lines: leaky_z + leaky_x + leaky_y, voted_cells }
}

/// One cut of a line by a triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Crossing {
    line: u32,
    along: f64,
    /// +1 entering (the triangle faces against the line's direction), -1 leaving.
    winding: i8,
}

/// Classifies every cell along lines parallel to `axis`: INSIDE or OUTSIDE, plus LEAKY when the
/// line passed through a hole. Returns the states in lattice order and the number of leaky lines.
fn axis_pass(mesh: &TriangleMesh, lattice: &Lattice, axis: usize, rule: FillRule) -> (Vec<u8>, usize) {
    // (u, v, axis) is a right-handed cyclic permutation of (x, y, z).
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let (nu, nv, na) = (lattice.dims[u], lattice.dims[v], lattice.dims[axis]);
    let mut crossings: Vec<Crossing> = (0..mesh.triangles.len())
        .into_par_iter()
        .fold(Vec::new, |mut found, t| {
            cut_lines(&mesh.corners(t).map(|p| p.to_array()), lattice, (u, v, axis), &mut found);
            found
        })
        .flatten()
        .collect();
    crossings.par_sort_unstable_by(|a, b| {
        a.line.cmp(&b.line).then(a.along.total_cmp(&b.along)).then(a.winding.cmp(&b.winding))
    });

    // Each line's cells, contiguous: line-major order, then scattered to lattice order.
    let mut line_start = vec![0usize; nu * nv + 1];
    for crossing in &crossings {
        line_start[crossing.line as usize + 1] += 1;
    }
    for line in 0..nu * nv {
        line_start[line + 1] += line_start[line];
    }
    let mut by_line = vec![OUTSIDE; nu * nv * na];
    let leaky: usize = by_line
        .par_chunks_mut(na)
        .enumerate()
        .map(|(line, cells)| {
            let cuts = &crossings[line_start[line]..line_start[line + 1]];
            let (mut winding, mut count, mut next) = (0i32, 0u32, 0usize);
            for (k, cell) in cells.iter_mut().enumerate() {
                let centre = lattice.centre_along(axis, k);
                while next < cuts.len() && cuts[next].along < centre {
                    winding += i32::from(cuts[next].winding);
                    count += 1;
                    next += 1;
                }
                *cell = if rule.inside(winding, count) { INSIDE } else { OUTSIDE };
            }
            let total: i32 = cuts.iter().map(|c| i32::from(c.winding)).sum();
            let leaks = match rule {
                FillRule::NonZero => total != 0,
                FillRule::EvenOdd => cuts.len() % 2 == 1,
            };
            if leaks {
                cells.iter_mut().for_each(|cell| *cell |= LEAKY);
            }
            usize::from(leaks)
        })
        .sum();

    let mut states = vec![OUTSIDE; lattice.cell_count()];
    for (index, state) in states.iter_mut().enumerate() {
        let cell = lattice.cell(index);
        *state = by_line[(cell[u] + nu * cell[v]) * na + cell[axis]];
    }
    (states, leaky)
}

/// Appends the cuts of triangle `corners` with every lattice line along `axis` that it covers.
fn cut_lines(
    corners: &[[f64; 3]; 3],
    lattice: &Lattice,
    (u, v, axis): (usize, usize, usize),
    found: &mut Vec<Crossing>,
) {
    let flat = corners.map(|p| Coord { x: p[u], y: p[v] });
    let area = orient2d(flat[0], flat[1], flat[2]);
    if area == 0.0 {
        return; // parallel to the lines: a perturbed line never meets it
    }
    let range = |dim: usize, lo: f64, hi: f64| {
        let first = ((lo - lattice.origin[dim]) / lattice.spacing).floor().max(0.0) as usize;
        let last = ((hi - lattice.origin[dim]) / lattice.spacing).ceil() + 1.0;
        first..(last.max(0.0) as usize).min(lattice.dims[dim])
    };
    let bounds = |coordinate: fn(&Coord<f64>) -> f64| {
        let values = flat.iter().map(coordinate);
        (values.clone().fold(f64::INFINITY, f64::min), values.fold(f64::NEG_INFINITY, f64::max))
    };
    let ((lo_u, hi_u), (lo_v, hi_v)) = (bounds(|c| c.x), bounds(|c| c.y));
    let nu = lattice.dims[u];
    for j in range(v, lo_v, hi_v) {
        for i in range(u, lo_u, hi_u) {
            let q = Coord { x: lattice.centre_along(u, i), y: lattice.centre_along(v, j) };
            let weights = [
                perturbed_orient(flat[1], flat[2], q),
                perturbed_orient(flat[2], flat[0], q),
                perturbed_orient(flat[0], flat[1], q),
            ];
            if weights.iter().all(|w| w.signum() == area.signum()) {
                let total: f64 = weights.iter().sum();
                let along = (0..3).map(|k| weights[k] * corners[k][axis]).sum::<f64>() / total;
                let winding = if area > 0.0 { -1 } else { 1 };
                found.push(Crossing { line: (i + nu * j) as u32, along, winding });
            }
        }
    }
}

/// orient2d(a, b, q) with q moved by (eps, eps^2) for an infinitesimal eps: never zero for a != b.
/// Its sign is exact; its magnitude is the plain orientation (used as a barycentric weight).
fn perturbed_orient(a: Coord<f64>, b: Coord<f64>, q: Coord<f64>) -> f64 {
    let exact = orient2d(a, b, q);
    if exact != 0.0 {
        return exact;
    }
    // d/d(eps) of (b - a) x (q + (eps, eps^2) - a) = -(b.y - a.y) eps + (b.x - a.x) eps^2.
    let sign = if b.y != a.y {
        if a.y > b.y { 1.0 } else { -1.0 }
    } else if b.x > a.x {
        1.0
    } else {
        -1.0
    };
    sign * f64::MIN_POSITIVE
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::test_meshes::cube;

    fn count(cells: &InsideCells) -> usize {
        cells.inside.iter().filter(|inside| **inside).count()
    }

    #[test]
    fn a_lattice_aligned_cube_fills_exactly_even_through_edges_and_vertices() {
        // Cube corners lie exactly on lattice lines: every line through an edge or a vertex must
        // be counted once, not twice or never.
        let mut mesh = cube(4.0);
        mesh.map_positions(|p| p - DVec3::splat(0.5));
        let lattice = Lattice { origin: DVec3::splat(-1.0), spacing: 0.5, dims: [12, 12, 12] };
        let result = inside_cells(&mesh, &lattice, FillRule::NonZero);
        assert_eq!(result.leaky_lines, 0);
        for (index, inside) in result.inside.iter().enumerate() {
            let centre = lattice.centre(lattice.cell(index));
            let strictly_inside = centre.cmpgt(DVec3::splat(-0.5)).all() && centre.cmplt(DVec3::splat(3.5)).all();
            let strictly_outside = centre.cmplt(DVec3::splat(-0.5)).any() || centre.cmpgt(DVec3::splat(3.5)).any();
            if strictly_inside {
                assert!(inside, "{centre} should be inside");
            }
            if strictly_outside {
                assert!(!inside, "{centre} should be outside");
            }
        }
    }

    #[test]
    fn a_hole_is_voted_away() {
        let mut mesh = cube(1.0);
        mesh.triangles.remove(0); // a hole in the z = 0 face
        let lattice = Lattice::covering(DVec3::splat(0.0), DVec3::splat(1.0), 0.1);
        let result = inside_cells(&mesh, &lattice, FillRule::NonZero);
        assert!(result.leaky_lines > 0);
        assert!(result.voted_cells > 0);
        assert_eq!(count(&result), 1000);
    }

    #[test]
    fn even_odd_fills_a_misoriented_cube() {
        let mut mesh = cube(1.0);
        mesh.triangles[3].swap(1, 2);
        let lattice = Lattice::covering(DVec3::splat(0.0), DVec3::splat(1.0), 0.25);
        assert_eq!(count(&inside_cells(&mesh, &lattice, FillRule::EvenOdd)), 64);
    }
}
