//! Helpers shared by the preprocessing test files (each uses a part of them).

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use glam::DVec3;
use shatter_core::config::PipelineConfig;
use shatter_geometry::mesh::TriangleMesh;
use shatter_preprocess::repair::repair;

/// The repository's mesh folder.
pub fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes")
}

/// A scene sampling `mesh` with `sampler` ("tet_shell" or "voronoi"), with extra `[geometry]`
/// lines (a transform) and lines for the sampler's own `[geometry.SAMPLER]` table.
pub fn mesh_config(
    sampler: &str,
    mesh: &str,
    spacing: f64,
    horizon: f64,
    seed: u64,
    geometry: &str,
    sampler_keys: &str,
) -> PipelineConfig {
    let text = format!(
        r#"
[scene]
name = "test"
output_dir = "out"
seed = {seed}
[geometry]
source = "meshes/{mesh}"
sampler = "{sampler}"
spacing_m = {spacing}
horizon_factor = {horizon}
{geometry}
[geometry.{sampler}]
{sampler_keys}
[material]
density_kg_m3 = 2000.0
bulk_modulus_pa = 2.94e9
"#
    );
    PipelineConfig::from_toml_str(&text, &assets().join("../pipeline.toml")).expect("test config is valid")
}

/// The mesh as the samplers see it: scaled (not recentred) and repaired.
pub fn load(name: &str, scale: f64) -> TriangleMesh {
    let (mut mesh, stats) = TriangleMesh::load_obj(&assets().join(name)).expect("test mesh loads");
    mesh.map_positions(|p| p * scale);
    repair(&mesh, stats, 1e-3).0
}

/// The vertices of {x : n.x <= d for every plane}: every feasible intersection of three planes.
pub fn polytope_vertices(planes: &[[f64; 4]], tolerance: f64) -> Vec<DVec3> {
    let normal = |p: &[f64; 4]| DVec3::new(p[0], p[1], p[2]);
    let mut vertices = Vec::new();
    for i in 0..planes.len() {
        for j in i + 1..planes.len() {
            for k in j + 1..planes.len() {
                let (a, b, c) = (normal(&planes[i]), normal(&planes[j]), normal(&planes[k]));
                let det = a.dot(b.cross(c));
                if det.abs() < 1e-9 {
                    continue;
                }
                let x = (b.cross(c) * planes[i][3] + c.cross(a) * planes[j][3] + a.cross(b) * planes[k][3]) / det;
                if planes.iter().all(|p| normal(p).dot(x) <= p[3] + tolerance) {
                    vertices.push(x);
                }
            }
        }
    }
    vertices
}
