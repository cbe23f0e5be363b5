//! `shatter post` end to end, and its USD checked by Pixar's own parser (usd-core).

use std::path::Path;
use std::process::{Command, Output};

fn shatter(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shatter")).args(args).current_dir(dir).output().expect("shatter runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

const SCENE: &str = r#"
[scene]
name = "struck"
output_dir = "out"
seed = 2
[geometry]
source = "box"
box_size_m = [0.012, 0.012, 0.004]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
[sim]
frames = 6
steps_per_frame = 60
gravity_m_s2 = [0.0, 0.0, 0.0]
[[sim.projectile]]
center_m = [0.0, 0.0, 0.0067]
velocity_m_s = [0.0, 0.0, -150.0]
radius_m = 0.003
stiffness_pa = 3e7
"#;

/// What the USD check verifies, in Python with `pxr` (pip install usd-core):
/// the stage opens; its time range is frames 1..=6 at 24 fps; it has exactly as many Mesh prims
/// as the last frame has fragments; every mesh has points, face counts summing to its index
/// count, indices within its points; every mesh's transform is sampled at each frame; and the
/// transform of the piece holding element 0 at frame 6 maps its rest position (first point of the
/// piece's mesh is not used: the test passes the expected position in); the debris Points prim
/// is sampled at every frame, with as many velocities and primvars as points, and its
/// `brokenBonds` over all frames add up to the bond ends the test passes in; every mesh's faces
/// are partitioned into `outer` and `fracture` GeomSubsets bound to the materials of
/// `/Shatter/Looks`, and the broken plate has fracture faces.
const USD_CHECK: &str = r#"
import sys
from pxr import Usd, UsdGeom, UsdShade, Gf
path, fragments, rest, expected = sys.argv[1], int(sys.argv[2]), [float(v) for v in sys.argv[3:6]], [float(v) for v in sys.argv[6:9]]
bond_ends = int(sys.argv[9])
stage = Usd.Stage.Open(path)
assert stage, "the stage does not open"
assert stage.GetStartTimeCode() == 1 and stage.GetEndTimeCode() == 6, (stage.GetStartTimeCode(), stage.GetEndTimeCode())
assert stage.GetTimeCodesPerSecond() == 24
meshes = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
assert len(meshes) == fragments, (len(meshes), fragments)
fracture_faces = 0
for prim in meshes:
    mesh = UsdGeom.Mesh(prim)
    points = mesh.GetPointsAttr().Get()
    counts = mesh.GetFaceVertexCountsAttr().Get()
    indices = mesh.GetFaceVertexIndicesAttr().Get()
    assert len(points) > 0 and sum(counts) == len(indices), prim.GetPath()
    assert max(indices) < len(points), prim.GetPath()
    samples = prim.GetAttribute("xformOp:transform").GetTimeSamples()
    assert list(samples) == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0], samples
    valid, reason = UsdGeom.Subset.ValidateFamily(mesh, UsdGeom.Tokens.face, "materialBind")
    assert valid, (prim.GetPath(), reason)
    covered = 0
    for subset in UsdGeom.Subset.GetGeomSubsets(mesh, UsdGeom.Tokens.face, "materialBind"):
        material, _ = UsdShade.MaterialBindingAPI(subset.GetPrim()).ComputeBoundMaterial()
        name = subset.GetPrim().GetName()
        assert material and material.GetPath() == "/Shatter/Looks/" + name, (subset.GetPath(), material)
        covered += len(subset.GetIndicesAttr().Get())
        if name == "fracture":
            fracture_faces += len(subset.GetIndicesAttr().Get())
    assert covered == len(counts), (prim.GetPath(), covered, len(counts))
assert fracture_faces > 0, "no fracture faces in a broken plate"
best = None
for prim in meshes:
    m = UsdGeom.Xformable(prim).GetLocalTransformation(6)
    moved = m.Transform(Gf.Vec3d(*rest))
    error = (moved - Gf.Vec3d(*expected)).GetLength()
    best = error if best is None else min(best, error)
assert best < 1e-5, best
debris = UsdGeom.Points(stage.GetPrimAtPath("/Shatter/debris"))
assert debris, "no debris points"
assert list(debris.GetPointsAttr().GetTimeSamples()) == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
total = 0
for frame in range(1, 7):
    points = debris.GetPointsAttr().Get(frame)
    assert len(debris.GetVelocitiesAttr().Get(frame)) == len(points), frame
    counts = UsdGeom.PrimvarsAPI(debris).GetPrimvar("brokenBonds").Get(frame)
    assert len(counts) == len(points), frame
    total += sum(counts)
assert total == bond_ends, (total, bond_ends)
print("usd ok", len(meshes), "debris", total)
"#;

#[test]
fn post_writes_fragments_point_caches_and_a_usd_that_usd_reads() {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), SCENE).expect("config");
    let output = shatter(&["run", "--until", "post"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("post: 6 frames"), "{stdout}");

    let last = dir.path().join("out/fragments/fragments.0006.shp");
    let summary = shatter(&["inspect", last.to_str().expect("utf-8"), "--json"], dir.path());
    let summary: serde_json::Value = serde_json::from_slice(&summary.stdout).expect("json");
    let fragments = summary["fragments"].as_u64().expect("fragment count");
    assert!(fragments > 1, "the projectile should break the plate: {summary}");
    assert!(dir.path().join("out/fragments/points.0006.ply").is_file());

    // Element 0's rest and frame-6 positions, from the particle file and the frame's point cache.
    let particles =
        shatter_core::particles::ParticleSet::read(&dir.path().join("out/particles.shp")).expect("particles");
    let frame = shatter_core::frames::PointFrame::read(&dir.path().join("out/frames/points.0006.ply")).expect("frame");
    let rest = particles.rest_position_m[0];
    let now = [frame.position[0][0], frame.position[1][0], frame.position[2][0]];
    let script = dir.path().join("check_usd.py");
    std::fs::write(&script, USD_CHECK).expect("script");
    let mut args = vec![
        script.display().to_string(),
        dir.path().join("out/fragments/fragments.usda").display().to_string(),
        fragments.to_string(),
    ];
    args.extend(rest.iter().chain(&now).map(|v| v.to_string()));
    // every broken bond emits from both its ends, in its frame's debris file and the USD
    let broken: usize = shatter_core::frames::BreakLog::read(&dir.path().join("out/frames/breaks.log"))
        .expect("break log")
        .iter()
        .map(|block| block.events.len())
        .sum();
    assert!(broken > 10, "the plate breaks");
    let debris_ends: i64 = (1..=6)
        .map(|frame| {
            let path = dir.path().join(format!("out/fragments/debris.{frame:04}.ply"));
            let cache = shatter_core::ply::PointCache::read(&path).expect("debris points");
            cache.ints("broken_bonds").expect("counts").iter().map(|c| i64::from(*c)).sum::<i64>()
        })
        .sum();
    assert_eq!(debris_ends, 2 * broken as i64);
    args.push((2 * broken).to_string());
    let check = Command::new("python3").args(&args).output().expect("python3 runs");
    assert!(
        check.status.success(),
        "USD check failed (needs Pixar's usd-core: pip install usd-core):\n{}{}",
        String::from_utf8_lossy(&check.stdout),
        String::from_utf8_lossy(&check.stderr)
    );
}

#[test]
fn post_before_sim_says_what_to_run() {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), SCENE).expect("config");
    assert!(shatter(&["preprocess"], dir.path()).status.success());
    let output = shatter(&["post"], dir.path());
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("run `shatter sim` first"), "{}", stderr(&output));
}

/// A folder whose simulation and post ran to the end.
fn simulated_and_posted() -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), SCENE).expect("config");
    for stage in ["preprocess", "sim", "post"] {
        let output = shatter(&[stage], dir.path());
        assert!(output.status.success(), "{stage}: {}", stderr(&output));
    }
    dir
}

#[test]
fn damaged_or_misplaced_frame_files_are_refused_by_what_reads_them() {
    // (what, the damage, the stage that reads it, a fragment of its message)
    type Damage = Box<dyn Fn(&Path)>;
    let rename = |from: &str, to: &str| -> Damage {
        let (from, to) = (from.to_owned(), to.to_owned());
        Box::new(move |out: &Path| std::fs::copy(out.join(&from), out.join(&to)).map(drop).expect("copy"))
    };
    let cases: Vec<(&str, Damage, &str, &str)> = vec![
        (
            "a flipped bit in the last block's frame field",
            Box::new(|out: &Path| {
                let log = out.join("frames/breaks.log");
                let mut bytes = std::fs::read(&log).expect("log");
                let last_block = last_block_start(&bytes);
                bytes[last_block] ^= 1;
                std::fs::write(&log, bytes).expect("write");
            }),
            "post",
            "fails its checksum",
        ),
        (
            "a log cut at a block boundary",
            Box::new(|out: &Path| {
                let log = out.join("frames/breaks.log");
                let bytes = std::fs::read(&log).expect("log");
                std::fs::write(&log, &bytes[..last_block_start(&bytes)]).expect("write");
            }),
            "post",
            "ends at frame 5, but the simulation wrote frame 6",
        ),
        (
            "a point cache under another frame's name",
            rename("frames/points.0003.ply", "frames/points.0004.ply"),
            "post",
            "holds frame 3, not 4",
        ),
        (
            "a fragments file under another frame's name",
            rename("fragments/fragments.0005.shp", "fragments/fragments.0002.shp"),
            "render",
            "holds frame 5, not 2",
        ),
    ];
    for (what, damage, stage, message) in cases {
        let dir = simulated_and_posted();
        damage(&dir.path().join("out"));
        let output = shatter(&[stage], dir.path());
        assert_eq!(output.status.code(), Some(1), "{what}: {}", stderr(&output));
        assert!(stderr(&output).contains(message), "{what}: {}", stderr(&output));
    }
}

/// The byte offset of the last block of a break log (blocks: 16-byte header, 16-byte records).
fn last_block_start(bytes: &[u8]) -> usize {
    let mut at = 16;
    let mut last = at;
    while at < bytes.len() {
        last = at;
        let count = u32::from_le_bytes([bytes[at + 4], bytes[at + 5], bytes[at + 6], bytes[at + 7]]) as usize;
        at += 16 + 16 * count;
    }
    last
}
