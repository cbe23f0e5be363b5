//! Defects of real meshes: separate bodies, open and non-manifold edges, inconsistent or inverted
//! winding. Found, reported, and repaired where that is safe.
//!
//! Policy: bodies (edge-connected parts) enclosing less than `min_body_volume_fraction` of the
//! largest body's volume are dropped; an inside-out mesh is flipped; open and non-manifold edges
//! are reported and tolerated (the inside test votes around them); a mesh whose kept bodies are
//! not consistently wound is filled with the even-odd rule instead of the non-zero rule.

use crate::inside::FillRule;
use shatter_core::disjoint_sets::DisjointSets;
use shatter_geometry::mesh::{LoadStats, TriangleMesh};

/// One edge-connected part of a mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyReport {
    /// Triangles in the body.
    pub triangles: usize,
    /// Signed enclosed volume, m^3 (negative for a cavity or an inside-out body).
    pub volume_m3: f64,
    /// Edges used by one triangle only (holes).
    pub open_edges: usize,
    /// Edges used by more than two triangles.
    pub nonmanifold_edges: usize,
    /// Edges whose two triangles run them the same way (inconsistent winding).
    pub misoriented_edges: usize,
    /// False when the body was dropped as too small.
    pub kept: bool,
}

/// What was found in a mesh and what was done about it.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshReport {
    /// Counts from loading.
    pub load: LoadStats,
    /// Every body, largest enclosed volume first.
    pub bodies: Vec<BodyReport>,
    /// True when the whole mesh was inside out and has been flipped.
    pub flipped: bool,
    /// The rule the inside test uses.
    pub fill_rule: FillRule,
}

impl MeshReport {
    /// Human-readable lines for the CLI: one summary line, then one line per defect kind.
    pub fn lines(&self) -> Vec<String> {
        let kept: Vec<&BodyReport> = self.bodies.iter().filter(|b| b.kept).collect();
        let dropped: Vec<&BodyReport> = self.bodies.iter().filter(|b| !b.kept).collect();
        let sum = |bodies: &[&BodyReport], f: fn(&BodyReport) -> usize| bodies.iter().map(|b| f(b)).sum::<usize>();
        let mut lines = vec![format!(
            "mesh: {} triangles, {} vertices ({} welded), {} {}; kept {} ({} triangles, {:.4e} m^3)",
            self.load.file_triangles,
            self.load.file_vertices,
            self.load.welded_vertices,
            self.bodies.len(),
            if self.bodies.len() == 1 { "body" } else { "bodies" },
            kept.len(),
            sum(&kept, |b| b.triangles),
            kept.iter().map(|b| b.volume_m3).sum::<f64>(),
        )];
        if !dropped.is_empty() {
            lines.push(format!(
                "dropped {} small {} ({} triangles, {:.3e} m^3 in all)",
                dropped.len(),
                if dropped.len() == 1 { "body" } else { "bodies" },
                sum(&dropped, |b| b.triangles),
                dropped.iter().map(|b| b.volume_m3.abs()).sum::<f64>(),
            ));
        }
        if self.load.degenerate_triangles > 0 {
            lines.push(format!("dropped {} degenerate triangles", self.load.degenerate_triangles));
        }
        type Count = fn(&BodyReport) -> usize;
        let defects: [(&str, Count); 3] = [
            ("open", |b| b.open_edges),
            ("non-manifold", |b| b.nonmanifold_edges),
            ("inconsistently wound", |b| b.misoriented_edges),
        ];
        for (name, count) in defects {
            let (in_kept, in_dropped) = (sum(&kept, count), sum(&dropped, count));
            if in_kept + in_dropped > 0 {
                lines.push(format!(
                    "{} {name} edges ({in_kept} in kept bodies, {in_dropped} in dropped ones)",
                    in_kept + in_dropped
                ));
            }
        }
        if self.flipped {
            lines.push("the mesh was inside out: flipped".to_string());
        }
        if self.fill_rule == FillRule::EvenOdd {
            lines.push("winding is inconsistent: filling with the even-odd rule".to_string());
        }
        lines
    }
}

/// Splits `mesh` into bodies, measures them, drops the small ones, and fixes inside-out winding.
/// Returns the repaired mesh (kept triangles only) and the report. Volumes are in the mesh's
/// units cubed (m^3 once the mesh is scaled to metres).
pub fn repair(mesh: &TriangleMesh, load: LoadStats, min_body_volume_fraction: f64) -> (TriangleMesh, MeshReport) {
    let body_of_triangle = label_bodies(mesh);
    let body_count = body_of_triangle.iter().map(|b| *b as usize + 1).max().unwrap_or(0);
    let mut triangles_of_body = vec![Vec::new(); body_count];
    for (t, &body) in body_of_triangle.iter().enumerate() {
        triangles_of_body[body as usize].push(t);
    }
    let mut bodies: Vec<BodyReport> = triangles_of_body
        .iter()
        .map(|triangles| BodyReport {
            triangles: triangles.len(),
            volume_m3: mesh.signed_volume_of(triangles.iter().copied()),
            open_edges: 0,
            nonmanifold_edges: 0,
            misoriented_edges: 0,
            kept: true,
        })
        .collect();
    count_edge_defects(mesh, &body_of_triangle, &mut bodies);

    let largest = bodies.iter().map(|b| b.volume_m3.abs()).fold(0.0, f64::max);
    for body in &mut bodies {
        body.kept = body.volume_m3.abs() >= min_body_volume_fraction * largest && body.volume_m3 != 0.0;
    }
    let mut repaired = TriangleMesh {
        positions: mesh.positions.clone(),
        triangles: body_of_triangle
            .iter()
            .zip(&mesh.triangles)
            .filter(|(body, _)| bodies[**body as usize].kept)
            .map(|(_, triangle)| *triangle)
            .collect(),
    };
    let flipped = repaired.signed_volume() < 0.0;
    if flipped {
        repaired.flip();
        for body in &mut bodies {
            body.volume_m3 = -body.volume_m3;
        }
    }
    let consistent = bodies.iter().filter(|b| b.kept).all(|b| b.misoriented_edges == 0);
    let fill_rule = if consistent { FillRule::NonZero } else { FillRule::EvenOdd };
    bodies.sort_by(|a, b| b.volume_m3.abs().total_cmp(&a.volume_m3.abs()));
    (repaired, MeshReport { load, bodies, flipped, fill_rule })
}

/// Body index of every triangle: triangles sharing a vertex are in the same body. Bodies are
/// numbered in order of their first triangle.
fn label_bodies(mesh: &TriangleMesh) -> Vec<u32> {
    let mut sets = DisjointSets::new(mesh.positions.len());
    for &[a, b, c] in &mesh.triangles {
        sets.join(a, b);
        sets.join(b, c);
    }
    let mut body_of_root = vec![u32::MAX; mesh.positions.len()];
    let mut bodies = 0;
    mesh.triangles
        .iter()
        .map(|triangle| {
            let r = sets.root(triangle[0]) as usize;
            if body_of_root[r] == u32::MAX {
                body_of_root[r] = bodies;
                bodies += 1;
            }
            body_of_root[r]
        })
        .collect()
}

/// Counts open, non-manifold and misoriented edges per body.
fn count_edge_defects(mesh: &TriangleMesh, body_of_triangle: &[u32], bodies: &mut [BodyReport]) {
    // (undirected edge key, runs from lower to higher vertex, body)
    let mut edges: Vec<(u64, bool, u32)> = Vec::with_capacity(mesh.triangles.len() * 3);
    for (triangle, &body) in mesh.triangles.iter().zip(body_of_triangle) {
        for k in 0..3 {
            let (a, b) = (triangle[k], triangle[(k + 1) % 3]);
            let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
            edges.push((key, a < b, body));
        }
    }
    edges.sort_unstable();
    for group in edges.chunk_by(|x, y| x.0 == y.0) {
        let body = &mut bodies[group[0].2 as usize];
        match group.len() {
            1 => body.open_edges += 1,
            2 if group[0].1 == group[1].1 => body.misoriented_edges += 1,
            2 => {}
            _ => body.nonmanifold_edges += 1,
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::test_meshes::cube;

    fn two_bodies(big: f64, small: f64) -> TriangleMesh {
        let mut mesh = cube(big);
        let speck = cube(small);
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(speck.positions.iter().map(|p| *p + DVec3::splat(3.0 * big)));
        mesh.triangles.extend(speck.triangles.iter().map(|t| t.map(|v| v + base)));
        mesh
    }

    #[test]
    fn small_bodies_are_dropped_and_reported() {
        let mesh = two_bodies(1.0, 0.01);
        let (repaired, report) = repair(&mesh, LoadStats::default(), 1e-3);
        assert_eq!(report.bodies.len(), 2);
        assert!(report.bodies[0].kept && !report.bodies[1].kept);
        assert_eq!(repaired.triangles.len(), 12);
        assert!((repaired.signed_volume() - 1.0).abs() < 1e-12);
        assert!(report.lines().iter().any(|line| line.contains("dropped 1 small body")));
    }

    #[test]
    fn inside_out_meshes_are_flipped_and_holes_counted() {
        let mut mesh = cube(1.0);
        mesh.flip();
        mesh.triangles.pop();
        let (repaired, report) = repair(&mesh, LoadStats::default(), 1e-3);
        assert!(report.flipped);
        assert!(repaired.signed_volume() > 0.0);
        assert_eq!(report.bodies[0].open_edges, 3);
        assert_eq!(report.fill_rule, FillRule::NonZero);
    }

    #[test]
    fn inconsistent_winding_switches_to_even_odd() {
        let mut mesh = cube(1.0);
        mesh.triangles[0].swap(1, 2);
        let (_, report) = repair(&mesh, LoadStats::default(), 1e-3);
        assert_eq!(report.bodies[0].misoriented_edges, 3);
        assert_eq!(report.fill_rule, FillRule::EvenOdd);
    }
}
