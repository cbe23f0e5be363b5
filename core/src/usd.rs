//! A USD (usda) export of the shot: one mesh per final piece, in the rest frame, with a
//! time-sampled transform per frame, so Blender, Houdini or usdview play the fracture. A piece's
//! transform at a frame is that of the fragment holding it then (pieces only ever split off).
//! A piece that broke again in the follow-through is drawn whole until it broke: a mesh of its
//! own, shown at those frames only, while the parts it broke into are hidden.

use std::fmt::Write as _;
use std::ops::Range;
use std::path::Path;

use glam::{DMat3, DQuat, DVec3};
use rayon::prelude::*;

use crate::debris_points::DebrisFrame;
use crate::fragments::FragmentFrame;
use crate::surfaces::SurfaceMesh;

/// A piece's rigid motion at one frame: x = R X + t.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PieceTransform {
    /// Rotation.
    pub rotation: DQuat,
    /// Translation, metres.
    pub translation: DVec3,
}

impl PieceTransform {
    /// The transforms at `frame` (a fragments file) of pieces each given by one of its
    /// elements: the motion of the fragment that holds that element then (pieces only ever
    /// split off, so it holds the whole piece).
    pub fn of_pieces(frame: &FragmentFrame, element_of_piece: &[u32]) -> Vec<PieceTransform> {
        element_of_piece
            .iter()
            .map(|&element| {
                let fragment = frame.fragment_of[element as usize] as usize;
                PieceTransform {
                    rotation: DQuat::from_array(frame.rotation[fragment].map(f64::from)).normalize(),
                    translation: DVec3::from_array(frame.translation_m[fragment]),
                }
            })
            .collect()
    }
}

/// One element of each of `pieces` pieces, `piece_of[element]` in 0..pieces (the first).
pub fn element_of_pieces(piece_of: &[u32], pieces: usize) -> Vec<u32> {
    let mut first = vec![u32::MAX; pieces];
    for (element, &piece) in piece_of.iter().enumerate().rev() {
        first[piece as usize] = element as u32;
    }
    first
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

/// A piece drawn whole over some frames before it broke again (the parts it broke into are
/// hidden then): `/Shatter/piece_<piece>_before_<frame>`, `frame` the first it is not shown at.
#[derive(Debug, Clone)]
pub struct WholeMesh {
    /// The id of the piece (its transform's column in `UsdShot::transforms`).
    pub piece: usize,
    /// The piece's outer faces while whole, in the rest frame.
    pub mesh: SurfaceMesh,
    /// The frames (indices into `UsdShot::transforms`) it is shown at.
    pub shown: Range<usize>,
}

/// A shot to write as USD.
#[derive(Debug, Clone, Copy)]
pub struct UsdShot<'a> {
    /// One mesh per piece, in the rest frame.
    pub meshes: &'a [SurfaceMesh],
    /// The frames (indices into `transforms`) at which each piece of `meshes` is hidden inside a
    /// whole of `wholes`; empty (for all, or a piece) when it is shown at every frame.
    pub hidden: &'a [Range<usize>],
    /// The pieces drawn whole before they broke again.
    pub wholes: &'a [WholeMesh],
    /// `transforms[frame index][piece]`.
    pub transforms: &'a [Vec<PieceTransform>],
    /// The time code of the first frame.
    pub first_frame: u32,
    /// Time codes per second.
    pub fps: f64,
    /// The debris emitter points of each frame.
    pub debris: &'a [DebrisFrame],
    /// The debris points' width, metres.
    pub width_m: f64,
    /// Physical seconds per playback second at each frame (for the debris velocities).
    pub velocity_scale: &'a [f64],
    /// Each frame's physical time since the shot's start, seconds, when the shot has its own
    /// clock (a lead-in or a timeline): written as `/Shatter.shatter:physicalTime`.
    pub physical_time_s: Option<&'a [f64]>,
}

/// Writes `path` (atomically): `shot.meshes[p]` with `shot.transforms[frame index][p]`, frames
/// numbered from `first_frame`, `fps` time codes per second, each frame's physical time (when
/// given) as the time-sampled attribute `shatter:physicalTime` of `/Shatter`, and the `debris`
/// emitter points of each frame as a `Points` prim (`/Shatter/debris`, points of `width_m`,
/// time-sampled: a frame without breaks holds none) with velocities (the debris' physical
/// velocities times the frame's `velocity_scale`, physical seconds per playback second, which
/// makes them metres per playback second as USD defines them) and the primvars `brokenBonds`,
/// `fragment`, `otherFragment`.
pub fn write_usda(path: &Path, shot: &UsdShot) -> std::io::Result<()> {
    let UsdShot {
        meshes,
        hidden,
        wholes,
        transforms,
        first_frame,
        fps,
        debris,
        width_m,
        velocity_scale,
        physical_time_s,
    } = *shot;
    let last_frame = first_frame + transforms.len().saturating_sub(1) as u32;
    let mut text = String::new();
    let _ = write!(
        text,
        "#usda 1.0\n(\n    defaultPrim = \"Shatter\"\n    metersPerUnit = 1\n    upAxis = \"Y\"\n    \
         startTimeCode = {first_frame}\n    endTimeCode = {last_frame}\n    timeCodesPerSecond = {fps}\n    \
         framesPerSecond = {fps}\n    doc = \"Fragments written by shatter post: one mesh per final piece, rest-frame \
         geometry, time-sampled rigid transforms\"\n)\n\ndef Xform \"Shatter\"\n{{\n"
    );
    if let Some(times) = physical_time_s {
        text.push_str("    custom double shatter:physicalTime.timeSamples = {\n");
        for (index, time) in times.iter().enumerate() {
            let _ = writeln!(text, "        {}: {time:e},", first_frame + index as u32);
        }
        text.push_str("    }\n");
    }
    let mut out = Vec::with_capacity(1 << 20);
    out.extend_from_slice(text.as_bytes());
    // Each piece's prim (and each frame of the debris) formatted in parallel, joined in order.
    let frames = FrameSpan { first_frame, count: transforms.len() };
    let prims: Vec<String> = meshes
        .par_iter()
        .enumerate()
        .map(|(piece, mesh)| {
            let hidden = hidden.get(piece).cloned().unwrap_or_default();
            let shown = |index: usize| !hidden.contains(&index);
            let visibility = if hidden.is_empty() { String::new() } else { frames.visibility(shown) };
            piece_prim(&format!("piece_{piece:05}"), mesh, piece, transforms, first_frame, &visibility)
        })
        .chain(wholes.par_iter().map(|whole| {
            let name = format!("piece_{:05}_before_{:04}", whole.piece, frames.frame(whole.shown.end));
            let visibility = frames.visibility(|index| whole.shown.contains(&index));
            piece_prim(&name, &whole.mesh, whole.piece, transforms, first_frame, &visibility)
        }))
        .collect();
    for prim in prims {
        out.extend_from_slice(prim.as_bytes());
    }
    out.extend_from_slice(LOOKS.as_bytes());
    if !debris.is_empty() {
        out.extend_from_slice(debris_prim(debris, first_frame, width_m, velocity_scale).as_bytes());
    }
    out.extend_from_slice(b"}\n");
    crate::atomic_file::write_atomically(path, &[&out])
}

/// The shot's frames: their count and the time code of the first.
#[derive(Debug, Clone, Copy)]
struct FrameSpan {
    first_frame: u32,
    count: usize,
}

impl FrameSpan {
    /// The time code of frame index `index`.
    fn frame(self, index: usize) -> u32 {
        self.first_frame + index as u32
    }

    /// A prim's `visibility`, time-sampled at the first frame and wherever `shown` changes.
    fn visibility(self, shown: impl Fn(usize) -> bool) -> String {
        let token = |index: usize| if shown(index) { "inherited" } else { "invisible" };
        let mut text = String::from("        token visibility.timeSamples = {\n");
        for index in (0..self.count).filter(|&index| index == 0 || shown(index) != shown(index - 1)) {
            let _ = writeln!(text, "            {}: \"{}\",", self.frame(index), token(index));
        }
        text.push_str("        }\n");
        text
    }
}

/// The prim `name`: `mesh` at rest, the transform of piece `piece` at each frame, the
/// `visibility` samples given (empty for none), its face subsets.
fn piece_prim(
    name: &str,
    mesh: &SurfaceMesh,
    piece: usize,
    transforms: &[Vec<PieceTransform>],
    first_frame: u32,
    visibility: &str,
) -> String {
    let mut prim = String::new();
    let _ = writeln!(prim, "    def Mesh \"{name}\"\n    {{");
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
    prim.push_str("        }\n        uniform token[] xformOpOrder = [\"xformOp:transform\"]\n");
    prim.push_str(visibility);
    prim.push_str(&face_subsets(mesh));
    prim.push_str("    }\n");
    prim
}

/// The materials the face subsets bind: neutral looks an artist rebinds (documented in
/// docs/FORMATS.md).
const LOOKS: &str = r#"    def Scope "Looks"
    {
        def Material "outer"
        {
            token outputs:surface.connect = </Shatter/Looks/outer/PreviewSurface.outputs:surface>
            def Shader "PreviewSurface"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor = (0.8, 0.8, 0.82)
                float inputs:roughness = 0.15
                token outputs:surface
            }
        }
        def Material "fracture"
        {
            token outputs:surface.connect = </Shatter/Looks/fracture/PreviewSurface.outputs:surface>
            def Shader "PreviewSurface"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor = (0.9, 0.82, 0.7)
                float inputs:roughness = 0.7
                token outputs:surface
            }
        }
    }
"#;

/// The mesh's faces as a `materialBind` partition of GeomSubsets: `outer` (the body's original
/// surface) and `fracture` (faces opened by cracks), each bound to its material under
/// `/Shatter/Looks` (an empty subset is left out).
fn face_subsets(mesh: &SurfaceMesh) -> String {
    let mut text = String::from("        uniform token subsetFamily:materialBind:familyType = \"partition\"\n");
    for (name, fracture) in [("outer", false), ("fracture", true)] {
        let faces: Vec<String> =
            (0..mesh.fracture.len()).filter(|&f| mesh.fracture[f] == fracture).map(|f| f.to_string()).collect();
        if faces.is_empty() {
            continue;
        }
        let _ = write!(
            text,
            "        def GeomSubset \"{name}\" (\n            prepend apiSchemas = [\"MaterialBindingAPI\"]\n        )\n        \
             {{\n            uniform token elementType = \"face\"\n            uniform token familyName = \"materialBind\"\n            \
             int[] indices = [{}]\n            rel material:binding = </Shatter/Looks/{name}>\n        }}\n",
            faces.join(", ")
        );
    }
    text
}

/// The `Points` prim of the debris: each attribute sampled at every frame.
fn debris_prim(debris: &[DebrisFrame], first_frame: u32, width_m: f64, velocity_scale: &[f64]) -> String {
    let mut prim = String::from("    def Points \"debris\"\n    {\n");
    let vector = |v: &[f32; 3]| format!("({}, {}, {})", v[0], v[1], v[2]);
    let mut samples = |kind: &str, name: &str, value: &(dyn Fn(usize, &DebrisFrame) -> Vec<String> + Sync)| {
        let _ = writeln!(prim, "        {kind} {name}.timeSamples = {{");
        let lines: Vec<String> = debris
            .par_iter()
            .enumerate()
            .map(|(index, frame)| {
                let mut line = format!("            {}: [", first_frame + index as u32);
                join(&mut line, value(index, frame).into_iter());
                line.push_str("],\n");
                line
            })
            .collect();
        prim.extend(lines);
        prim.push_str("        }\n");
    };
    samples("point3f[]", "points", &|_, f| f.position.iter().map(vector).collect());
    let scaled = |v: &[f32; 3], scale: f64| vector(&v.map(|c| (f64::from(c) * scale) as f32));
    samples("vector3f[]", "velocities", &|i, f| f.velocity.iter().map(|v| scaled(v, velocity_scale[i])).collect());
    samples("int[]", "primvars:brokenBonds", &|_, f| f.broken_bonds.iter().map(i32::to_string).collect());
    samples("int[]", "primvars:fragment", &|_, f| f.fragment.iter().map(i32::to_string).collect());
    samples("int[]", "primvars:otherFragment", &|_, f| f.other_fragment.iter().map(i32::to_string).collect());
    samples("float[]", "primvars:breakTime", &|_, f| f.time_s.iter().map(f32::to_string).collect());
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
