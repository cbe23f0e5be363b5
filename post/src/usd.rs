//! A USD (usda) export of the shot: one mesh per final piece, in the rest frame, with a
//! time-sampled transform per frame, so Blender, Houdini or usdview play the fracture. A piece's
//! transform at a frame is that of the fragment holding it then (pieces only ever split off).

use std::fmt::Write as _;
use std::path::Path;

use glam::{DMat3, DQuat, DVec3};

use super::debris::DebrisFrame;
use super::surfaces::SurfaceMesh;

/// A piece's rigid motion at one frame: x = R X + t.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PieceTransform {
    /// Rotation.
    pub rotation: DQuat,
    /// Translation, metres.
    pub translation: DVec3,
}

/// The USD 4 x 4 matrix (row vectors: the translation is the last row) of a transform.
fn matrix(transform: &PieceTransform) -> [[f64; 4]; 4] {
    let r = DMat3::from_quat(transform.rotation);
    let t = transform.translation;
    let column = |k: usize| r.col(k);
    [
        [column(0).x, column(0).y, column(0).z, 0.0],
        [column(1).x, column(1).y, column(1).z, 0.0],
        [column(2).x, column(2).y, column(2).z, 0.0],
        [t.x, t.y, t.z, 1.0],
    ]
}

/// Writes `path` (atomically): `meshes[p]` with `transforms[frame index][p]`, frames numbered from
/// `first_frame`, `fps` time codes per second, and the `debris` emitter points of each frame as a
/// `Points` prim (`/Shatter/debris`, points of `width_m`, time-sampled: a frame without breaks
/// holds none) with velocities and the primvars `brokenBonds`, `fragment`, `otherFragment`.
pub fn write_usda(
    path: &Path,
    meshes: &[SurfaceMesh],
    transforms: &[Vec<PieceTransform>],
    first_frame: u32,
    fps: f64,
    debris: &[DebrisFrame],
    width_m: f64,
) -> std::io::Result<()> {
    let last_frame = first_frame + transforms.len().saturating_sub(1) as u32;
    let mut text = String::new();
    let _ = write!(
        text,
        "#usda 1.0\n(\n    defaultPrim = \"Shatter\"\n    metersPerUnit = 1\n    upAxis = \"Y\"\n    \
         startTimeCode = {first_frame}\n    endTimeCode = {last_frame}\n    timeCodesPerSecond = {fps}\n    \
         framesPerSecond = {fps}\n    doc = \"Fragments written by shatter post: one mesh per final piece, rest-frame \
         geometry, time-sampled rigid transforms\"\n)\n\ndef Xform \"Shatter\"\n{{\n"
    );
    let mut out = Vec::with_capacity(1 << 20);
    out.extend_from_slice(text.as_bytes());
    for (piece, mesh) in meshes.iter().enumerate() {
        let mut prim = String::new();
        let _ = writeln!(prim, "    def Mesh \"piece_{piece:05}\"\n    {{");
        prim.push_str("        uniform token subdivisionScheme = \"none\"\n");
        prim.push_str("        uniform bool doubleSided = 0\n");
        prim.push_str("        int[] faceVertexCounts = [");
        join(&mut prim, mesh.face_sizes.iter().map(|c| c.to_string()));
        prim.push_str("]\n        int[] faceVertexIndices = [");
        join(&mut prim, mesh.indices.iter().map(|c| c.to_string()));
        prim.push_str("]\n        point3f[] points = [");
        join(&mut prim, mesh.points.iter().map(|p| format!("({}, {}, {})", p[0], p[1], p[2])));
        prim.push_str("]\n        matrix4d xformOp:transform.timeSamples = {\n");
        for (index, frame_transforms) in transforms.iter().enumerate() {
            let m = matrix(&frame_transforms[piece]);
            let rows: Vec<String> =
                m.iter().map(|row| format!("({}, {}, {}, {})", row[0], row[1], row[2], row[3])).collect();
            let _ = writeln!(prim, "            {}: ({}),", first_frame + index as u32, rows.join(", "));
        }
        prim.push_str("        }\n        uniform token[] xformOpOrder = [\"xformOp:transform\"]\n    }\n");
        out.extend_from_slice(prim.as_bytes());
    }
    if !debris.is_empty() {
        out.extend_from_slice(debris_prim(debris, width_m).as_bytes());
    }
    out.extend_from_slice(b"}\n");
    shatter_core::atomic_file::write_atomically(path, &[&out])
}

/// The `Points` prim of the debris: each attribute sampled at every frame.
fn debris_prim(debris: &[DebrisFrame], width_m: f64) -> String {
    let mut prim = String::from("    def Points \"debris\"\n    {\n");
    let vector = |v: &[f32; 3]| format!("({}, {}, {})", v[0], v[1], v[2]);
    let mut samples = |kind: &str, name: &str, value: &dyn Fn(&DebrisFrame) -> Vec<String>| {
        let _ = writeln!(prim, "        {kind} {name}.timeSamples = {{");
        for frame in debris {
            let _ = write!(prim, "            {}: [", frame.frame);
            join(&mut prim, value(frame).into_iter());
            prim.push_str("],\n");
        }
        prim.push_str("        }\n");
    };
    samples("point3f[]", "points", &|f| f.position.iter().map(vector).collect());
    samples("vector3f[]", "velocities", &|f| f.velocity.iter().map(vector).collect());
    samples("int[]", "primvars:brokenBonds", &|f| f.broken_bonds.iter().map(i32::to_string).collect());
    samples("int[]", "primvars:fragment", &|f| f.fragment.iter().map(i32::to_string).collect());
    samples("int[]", "primvars:otherFragment", &|f| f.other_fragment.iter().map(i32::to_string).collect());
    samples("float[]", "primvars:breakTime", &|f| f.time_s.iter().map(f32::to_string).collect());
    let _ =
        writeln!(prim, "        float[] widths = [{width_m}] (\n            interpolation = \"constant\"\n        )");
    prim.push_str("    }\n");
    prim
}

fn join(out: &mut String, items: impl Iterator<Item = String>) {
    for (k, item) in items.enumerate() {
        if k > 0 {
            out.push_str(", ");
        }
        out.push_str(&item);
    }
}
