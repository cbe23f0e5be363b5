//! Pieces that break again (`[rigid.secondary_fracture]`): a glass slab dropped on its edge goes
//! back to the simulation when it lands faster than its material's critical impact speed, and
//! comes back in pieces; dropped well below that speed it lands whole without going back. The
//! handoffs both ways keep momentum and never add kinetic energy; the pieces keep their ids (in
//! the fragments files, the USD and the Cryptomatte); a
//! run killed during a re-entry ends as one never killed, at any thread count.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use shatter_core::fragments::FragmentFrame;
use shatter_core::frames::{BreakLog, PointFrame};
use shatter_core::lead_in::LeadIn;
use shatter_core::particles::ParticleSet;
use shatter_core::reentry::Reentry;
use shatter_render::cryptomatte::FRAGMENT_MATTE;
use shatter_render::frame_review::RenderedFrame;
use shatter_rigid::mass::{element_mass_props, piece_mass_props};
use support::{figure, shatter, stderr, tree_files};

use crate::support;

const GRAVITY_M_S2: f64 = 9.81;
const BULK_MODULUS_PA: f64 = 14.9e9;
const DENSITY_KG_M3: f64 = 2200.0;
const FRACTURE_ENERGY_J_M2: f64 = 8.0;
const HORIZON_M: f64 = 0.006;
/// Half the diagonal of the slab's 4 cm square face: it stands on a corner edge.
const HALF_DIAGONAL_M: f64 = 0.028_284_271_247_461_9;

/// The critical impact speed of the rule (docs/DECISIONS.md#secondary-fracture): the mean
/// critical stretch sqrt(5 G / (9 K delta)) times the P-wave speed sqrt(1.8 K / rho).
fn critical_speed_m_s() -> f64 {
    let stretch = (5.0 * FRACTURE_ENERGY_J_M2 / (9.0 * BULK_MODULUS_PA * HORIZON_M)).sqrt();
    stretch * (1.8 * BULK_MODULUS_PA / DENSITY_KG_M3).sqrt()
}

/// The scenes' glass, its simulation (three short frames, the floor at 0) and a follow-through
/// of `follow_through_s` whose pieces break again.
fn physics(follow_through_s: f64) -> String {
    format!(
        r#"[material]
density_kg_m3 = {DENSITY_KG_M3}
bulk_modulus_pa = {BULK_MODULUS_PA}
fracture_energy_j_m2 = {FRACTURE_ENERGY_J_M2}
[sim]
frames = 3
steps_per_frame = 20
gravity_m_s2 = [0.0, -{GRAVITY_M_S2}, 0.0]
[sim.floor]
height_m = 0.0
[rigid]
follow_through_s = {follow_through_s}
[rigid.secondary_fracture]
min_elements = 64
"#
    )
}

/// A 4 x 4 x 0.6 cm slab of 2 mm cubes at the horizon factor `horizon_factor`, turned to stand
/// on an edge, its box's lowest edge `height_m` above the floor: the `[scene]` and `[geometry]`.
fn slab_geometry(name: &str, horizon_factor: f64, height_m: f64) -> String {
    format!(
        r#"
[scene]
name = "{name}"
output_dir = "out"
seed = 3
[geometry]
source = "box"
box_size_m = [0.04, 0.04, 0.006]
sampler = "grid"
spacing_m = 0.002
horizon_factor = {horizon_factor}
[geometry.transform]
rotate_deg = [0.0, 0.0, 45.0]
translate_m = [0.0, {}, 0.0]
"#,
        height_m + HALF_DIAGONAL_M
    )
}

/// The glass slab, whose lowest edge falls onto the floor at `speed_m_s`.
fn scene(dir: &Path, speed_m_s: f64) {
    let height_m = speed_m_s * speed_m_s / (2.0 * GRAVITY_M_S2);
    let text = format!(
        r#"{}{}
[render]
backend = "cpu"
resolution = [256, 192]
samples_per_pixel = 2
[render.camera]
position_m = [0.0, 0.1, 0.45]
look_at_m = [0.0, 0.08, 0.0]
fov_deg = 40.0
"#,
        slab_geometry("slab", 3.0, height_m),
        physics((2.0 * height_m / GRAVITY_M_S2).sqrt() + 0.25)
    );
    std::fs::write(dir.join("pipeline.toml"), text).expect("config");
}

fn last_rigid_frame(out: &Path) -> FragmentFrame {
    let mut frames: Vec<_> = std::fs::read_dir(out.join("rigid"))
        .expect("rigid folder")
        .map(|entry| entry.expect("entry").path())
        .filter(|path| path.file_name().is_some_and(|name| name.to_string_lossy().starts_with("fragments.")))
        .collect();
    frames.sort();
    FragmentFrame::read(frames.last().expect("a rigid frame")).expect("fragments")
}

/// The visibility check of the shot's USD, in Python with `pxr`: the slab's whole
/// (`piece_00000_before_<landed>`) is shown at the frame before it landed and not from then on,
/// nor in the first frame (the simulation's, where the last frame's pieces are drawn); each of
/// the pieces is hidden at the frame before and shown at the frame it landed and the first.
const VISIBILITY_CHECK: &str = r#"
import sys
from pxr import Usd, UsdGeom
stage = Usd.Stage.Open(sys.argv[1])
landed, pieces = int(sys.argv[2]), int(sys.argv[3])
def shown(name, frame):
    prim = stage.GetPrimAtPath("/Shatter/" + name)
    assert prim and prim.IsA(UsdGeom.Mesh), name
    return UsdGeom.Imageable(prim).ComputeVisibility(frame) != UsdGeom.Tokens.invisible
whole = "piece_00000_before_%04d" % landed
assert shown(whole, landed - 1) and not shown(whole, landed) and not shown(whole, 1), whole
for name in ["piece_%05d" % k for k in range(pieces)]:
    assert shown(name, 1) and not shown(name, landed - 1) and shown(name, landed), name
print("visibility ok")
"#;

#[test]
fn a_slab_breaks_again_when_it_lands_above_its_critical_speed_and_not_below() {
    let critical = critical_speed_m_s();
    let hard = tempfile::tempdir().expect("tempdir");
    scene(hard.path(), 4.0 * critical);
    let output = shatter(&["--threads", "2", "run", "--until", "rigid"], hard.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let out = hard.path().join("out");
    let particles = ParticleSet::read(&out.join("particles.shp")).expect("particles");
    let reentry = Reentry::read(&out.join("rigid/reentry.001.shp")).expect("the slab went back");
    assert!(!out.join("rigid/reentry.002.shp").exists(), "one hard landing, one re-entry");
    // the threshold is the rule's, from the particle file's critical stretch
    let rule = particles.meta.mean_critical_stretch * (1.8 * BULK_MODULUS_PA / DENSITY_KG_M3).sqrt();
    assert!((reentry.meta.threshold_m_s - rule).abs() <= 1e-12 * rule, "{:?}", reentry.meta);
    assert!((reentry.meta.threshold_m_s - critical).abs() <= 1e-9 * critical, "{:?}", reentry.meta);
    assert_eq!(reentry.meta.hit, "floor");
    assert_eq!(reentry.meta.pieces, vec![0]);
    let speed = reentry.meta.impact_speed_m_s;
    assert!((speed / (4.0 * critical) - 1.0).abs() < 0.05, "landed at {speed} m/s, not {}", 4.0 * critical);
    assert_eq!(reentry.members.len(), particles.len());

    // it came back in pieces: the largest keeps id 0, the new ones follow
    let before = FragmentFrame::read(&out.join(format!("rigid/fragments.{:04}.shp", reentry.meta.frame - 1)))
        .expect("the frame before");
    assert_eq!(before.fragment_count(), 1);
    let after = last_rigid_frame(&out);
    assert!(after.fragment_count() > 1, "the slab landed whole: {stdout}");
    let largest = after.elements.iter().copied().max().expect("pieces");
    assert_eq!(after.elements[0], largest, "piece 0 keeps its id on its largest part");
    assert!(largest as usize > particles.len() / 2, "the slab chipped at its edge, not shattered");
    // the shot's USD names a prim for each piece by its id (as Cryptomatte names piece_<id>):
    // piece 0, the slab before and its largest part after, and the new pieces
    let usd = std::fs::read_to_string(out.join("rigid/shot.usda")).expect("the shot's USD");
    for id in 0..after.fragment_count() {
        assert!(usd.contains(&format!("def Mesh \"piece_{id:05}\"")), "no prim for piece {id}");
    }
    assert!(!usd.contains(&format!("def Mesh \"piece_{:05}\"", after.fragment_count())));
    // the slab is drawn whole until the frame it landed in, its parts from then on (and in the
    // simulation's frames, as for the first fracture): read by Pixar's usd-core
    let landed = reentry.meta.frame;
    let usd_path = out.join("rigid/shot.usda");
    let args = [landed, after.fragment_count() as u32].map(|n| n.to_string());
    let check = Command::new("python3")
        .args(["-c", VISIBILITY_CHECK, &usd_path.to_string_lossy(), &args[0], &args[1]])
        .output()
        .expect("python3 runs");
    assert!(check.status.success(), "{}", String::from_utf8_lossy(&check.stderr));
    // the Cryptomatte of the pieces names them by the same ids: the slab in the frame before it
    // landed, its parts in the frame it landed in
    let frames = format!("{},{landed}", landed - 1);
    let output = shatter(&["render", "--frames", &frames], hard.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let names = |frame: u32| {
        let path = out.join(format!("render/slab.{frame:04}.exr"));
        let image = RenderedFrame::read(&path).expect("a rendered frame");
        let mut names = std::collections::BTreeSet::new();
        for y in 0..image.height {
            for x in 0..image.width {
                names.extend(image.pick(FRAGMENT_MATTE, x, y).into_iter().map(|(name, _)| name));
            }
        }
        names
    };
    assert_eq!(names(reentry.meta.frame - 1).into_iter().collect::<Vec<_>>(), vec!["piece_00000".to_string()]);
    let parts = names(landed);
    assert!(parts.contains("piece_00000") && parts.len() > 1, "{parts:?}");
    let ids: Vec<String> = (0..after.fragment_count()).map(|id| format!("piece_{id:05}")).collect();
    assert!(parts.iter().all(|name| ids.contains(name)), "{parts:?} are not the pieces' ids");
    // and its debris points: the re-entry's, at the frame its pieces came back by, none before
    let points = &usd[usd.find("point3f[] points.timeSamples").expect("debris points")..];
    let sample = |frame: u32| {
        let at = points.find(&format!("\n            {frame}: [")).expect("a sample per frame");
        points[at..].lines().nth(1).expect("the sample").trim().to_string()
    };
    let frame = reentry.meta.frame;
    assert_eq!(sample(frame - 1), format!("{}: [],", frame - 1));
    assert!(sample(frame).starts_with(&format!("{frame}: [(")), "no debris at frame {frame}: {}", sample(frame));
    // it cracked where it hit: the re-entry's first broken bonds lie at the edge it landed on
    // (it falls without turning, so that edge is the lowest in the rest frame, which
    // preprocess turned already)
    let pass_particles = ParticleSet::read(&out.join("reentry/001/particles.shp")).expect("re-entry particles");
    let blocks = BreakLog::read(&out.join("reentry/001/frames/breaks.log")).expect("re-entry break log");
    let first = blocks.iter().find(|block| !block.events.is_empty()).expect("the re-entry broke bonds");
    let lowest = particles.rest_position_m.iter().map(|p| p[1]).fold(f32::INFINITY, f32::min);
    for event in &first.events {
        let entry = event.bond;
        let row = pass_particles.bonds.offsets.partition_point(|&offset| offset <= entry) - 1;
        let height = pass_particles.rest_position_m[row][1] - lowest;
        assert!(height < 0.01, "a first crack {height} m above the edge it landed on");
    }

    // the re-entry's line: momentum kept and no energy gained at its return
    let line = stdout.lines().find(|line| line.contains("re-entry 1: piece 0")).expect("the re-entry's line");
    assert!(figure(line, "momentum kept to") <= 1e-6, "{line}");
    assert!(figure(line, "angular momentum to") <= 1e-6, "{line}");
    let particle_energy = figure(line, "kinetic energy");
    let body_energy = figure(line, "J in the particles,");
    assert!(body_energy <= particle_energy * 1.01, "the bodies gained energy: {line}");

    // and at its start: the particles move as the body did
    let pass = out.join("reentry/001");
    let start = LeadIn::read(&pass.join("rigid/lead_in.shp")).expect("start");
    let first = PointFrame::read(&pass.join("frames/points.0001.ply")).expect("first frame");
    let body = body_energy_of(&particles, &start);
    let (momentum, energy) = particle_momentum_and_energy(&particles, &first);
    let expected: Vec<f64> = start.velocity_m_s.iter().map(|v| v * body.0).collect();
    let error = (0..3).map(|a| (momentum[a] - expected[a]).powi(2)).sum::<f64>().sqrt();
    assert!(error <= 1e-6 * norm(&expected), "momentum {momentum:?} against the body's {expected:?}");
    assert!(energy <= body.1 * 1.01 && energy >= body.1 * 0.95, "particles {energy} J, body {} J", body.1);

    // well below the speed, no re-entry, and the slab lands whole
    let soft = tempfile::tempdir().expect("tempdir");
    scene(soft.path(), 0.5 * critical);
    let output = shatter(&["run", "--until", "rigid"], soft.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let out = soft.path().join("out");
    assert!(!out.join("rigid/reentry.001.shp").exists(), "a soft landing went back to the simulation");
    assert!(!out.join("reentry").exists());
    assert_eq!(last_rigid_frame(&out).fragment_count(), 1);
}

/// The slab's mass and the kinetic energy of its body moving as `start` says, J.
fn body_energy_of(particles: &ParticleSet, start: &LeadIn) -> (f64, f64) {
    let elements = element_mass_props(particles, DENSITY_KG_M3);
    let rest = piece_mass_props(&elements, &vec![0; particles.len()], 1)[0];
    let [x, y, z, w] = start.rotation;
    let rotation = glam::DQuat::from_xyzw(x, y, z, w);
    let r = glam::DMat3::from_quat(rotation);
    // (rapier's glam and ours may differ in version: through arrays)
    let rest_inertia = glam::DMat3::from_cols_array(&rest.inertia().to_cols_array());
    let inertia = r * rest_inertia * r.transpose();
    let omega = glam::DVec3::from_array(start.angular_velocity_rad_s);
    let v = glam::DVec3::from_array(start.velocity_m_s);
    (rest.mass_kg, 0.5 * rest.mass_kg * v.length_squared() + 0.5 * omega.dot(inertia * omega))
}

fn particle_momentum_and_energy(particles: &ParticleSet, frame: &PointFrame) -> ([f64; 3], f64) {
    let mut momentum = [0.0; 3];
    let mut energy = 0.0;
    for i in 0..particles.len() {
        let m = f64::from(particles.volume_m3[i]) * DENSITY_KG_M3;
        let v = [0, 1, 2].map(|a| f64::from(frame.velocity[a][i]));
        for a in 0..3 {
            momentum[a] += m * v[a];
        }
        energy += 0.5 * m * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    }
    (momentum, energy)
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|c| c * c).sum::<f64>().sqrt()
}

#[test]
fn a_run_killed_during_a_reentry_ends_as_one_never_killed_at_any_thread_count() {
    let speed = 4.0 * critical_speed_m_s();
    let reference = tempfile::tempdir().expect("tempdir");
    scene(reference.path(), speed);
    let output = shatter(&["--threads", "2", "run", "--until", "rigid"], reference.path());
    assert!(output.status.success(), "{}", stderr(&output));
    // (the simulation's checkpoints name their backend, thread count included)
    let skip = ["stamps.json", "shatter.lock", "sim.checkpoint.shp"];
    let expected = tree_files(&reference.path().join("out"), &skip);
    assert!(expected.iter().any(|(name, _)| name.starts_with("reentry/001/fragments/")), "the slab went back");

    let single = tempfile::tempdir().expect("tempdir");
    scene(single.path(), speed);
    let output = shatter(&["--threads", "1", "run", "--until", "rigid"], single.path());
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(tree_files(&single.path().join("out"), &skip) == expected, "1 and 2 threads differ");

    let killed = tempfile::tempdir().expect("tempdir");
    scene(killed.path(), speed);
    let mut child = Command::new(env!("CARGO_BIN_EXE_shatter"))
        .args(["--threads", "2", "run", "--until", "rigid"])
        .current_dir(killed.path())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn");
    // kill mid-way through the re-entry's simulation
    let mid = killed.path().join("out/reentry/001/frames/points.0012.ply");
    let started = Instant::now();
    while !mid.exists() && child.try_wait().expect("wait").is_none() && started.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(2));
    }
    let was_running = child.try_wait().expect("wait").is_none();
    child.kill().expect("SIGKILL");
    child.wait().expect("reap");
    assert!(was_running, "the run ended before its re-entry was half simulated");
    assert!(!killed.path().join("out/rigid/fragments.0017.shp").exists(), "killed before the follow-through ended");
    let output = shatter(&["--threads", "2", "run", "--until", "rigid"], killed.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let resumed = tree_files(&killed.path().join("out"), &skip);
    let names = |files: &[(String, Vec<u8>)]| files.iter().map(|(name, _)| name.clone()).collect::<Vec<_>>();
    assert_eq!(names(&resumed), names(&expected));
    for ((name, bytes), (_, expected_bytes)) in resumed.iter().zip(&expected) {
        assert!(bytes == expected_bytes, "{name} differs after kill -9 and resume");
    }
}

/// The OBJ of a box of half-sizes `half` about `centre`, turned by `turn_rad` about z, its
/// vertices numbered from `first` + 1, its faces wound outward.
fn obj_box(centre: [f64; 3], half: [f64; 3], turn_rad: f64, first: usize) -> String {
    let mut text = String::new();
    let (sin, cos) = turn_rad.sin_cos();
    for corner in 0..8 {
        let offset = [0, 1, 2].map(|axis| if corner >> axis & 1 == 1 { half[axis] } else { -half[axis] });
        let x = centre[0] + cos * offset[0] - sin * offset[1];
        let y = centre[1] + sin * offset[0] + cos * offset[1];
        text.push_str(&format!("v {x} {y} {}\n", centre[2] + offset[2]));
    }
    // corners by bits (x, y, z); each face's quad wound counter-clockwise from outside
    for quad in [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]] {
        let [a, b, c, d] = quad.map(|k| k + first + 1);
        text.push_str(&format!("f {a} {b} {c}\nf {a} {c} {d}\n"));
    }
    text
}

/// Two glass bodies of 2 mm cubes: a 6 x 0.6 x 6 cm plate lying on the floor, and the 4 x 4 x
/// 0.6 cm slab standing on a corner edge above its middle, high enough that it lands on the plate
/// at `speed_m_s`; one re-entry at most.
fn two_slabs_scene(dir: &Path, speed_m_s: f64) {
    let plate_top_m = 0.0065;
    let height_m = speed_m_s * speed_m_s / (2.0 * GRAVITY_M_S2);
    let plate = obj_box([0.0, 0.5 * (0.0005 + plate_top_m), 0.0], [0.03, 0.5 * (plate_top_m - 0.0005), 0.03], 0.0, 0);
    let centre_m = plate_top_m + height_m + HALF_DIAGONAL_M;
    let slab = obj_box([0.0, centre_m, 0.0], [0.02, 0.02, 0.003], std::f64::consts::FRAC_PI_4, 8);
    std::fs::write(dir.join("two_slabs.obj"), plate + &slab).expect("mesh");
    let text = format!(
        r#"
[scene]
name = "two_slabs"
output_dir = "out"
seed = 3
[geometry]
source = "two_slabs.obj"
sampler = "grid"
spacing_m = 0.002
horizon_factor = 3.0
{}max_reentries = 1
"#,
        physics((2.0 * height_m / GRAVITY_M_S2).sqrt() + 0.05)
    );
    std::fs::write(dir.join("pipeline.toml"), text).expect("config");
}

#[test]
fn two_pieces_that_meet_hard_go_back_together_and_keep_their_ids() {
    // between two pieces the velocity jump is shared: hard at twice the critical speed
    let hard_m_s = 2.0 * critical_speed_m_s();
    let dir = tempfile::tempdir().expect("tempdir");
    two_slabs_scene(dir.path(), 2.0 * hard_m_s);
    let output = shatter(&["--threads", "2", "run", "--until", "rigid"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let out = dir.path().join("out");
    let particles = ParticleSet::read(&out.join("particles.shp")).expect("particles");
    let handoff = FragmentFrame::read(&out.join("fragments/fragments.0001.shp")).expect("the first frame");
    assert_eq!(handoff.fragment_count(), 2, "two bodies from the start");
    // which of the two is the slab that falls: the higher one
    let height = |piece: u32| {
        let ys = (0..particles.len()).filter(|&i| handoff.fragment_of[i] == piece);
        ys.map(|i| particles.rest_position_m[i][1]).fold(f32::NEG_INFINITY, f32::max)
    };
    let slab = u32::from(height(1) > height(0));
    let reentry = Reentry::read(&out.join("rigid/reentry.001.shp")).expect("the two went back");
    assert_eq!(reentry.meta.pieces, vec![0, 1], "both pieces in the contact go back");
    assert_eq!(reentry.meta.hit, "piece 1");
    assert!((reentry.meta.threshold_m_s - hard_m_s).abs() <= 1e-9 * hard_m_s, "{:?}", reentry.meta);
    let speed = reentry.meta.impact_speed_m_s;
    assert!((speed / (2.0 * hard_m_s) - 1.0).abs() < 0.05, "met at {speed} m/s, not {}", 2.0 * hard_m_s);
    assert_eq!(reentry.members.len(), particles.len());

    // each body's particles start with its own motion: the plate at rest, the slab falling
    let pass = out.join("reentry/001");
    let start = LeadIn::read(&pass.join("rigid/lead_in.shp")).expect("start");
    assert_eq!(start.others.len(), 1);
    // inspect reads the start, with each body's particles
    let output = shatter(&["inspect", "--json", "out/reentry/001/rigid/lead_in.shp"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let summary: serde_json::Value = serde_json::from_slice(&output.stdout).expect("json");
    let per_body = |body: u32| start.body_of.iter().filter(|&&b| b == body).count();
    assert_eq!(summary["particles_per_body"], serde_json::json!([per_body(0), per_body(1)]));
    let first = PointFrame::read(&pass.join("frames/points.0001.ply")).expect("first frame");
    let start_velocity = |body: u32| {
        let motion = if body == 0 { start.motion() } else { start.others[0] };
        motion.velocity_m_s[1]
    };
    // (body k is piece k: the pieces go back in ascending order)
    for body in 0..2 {
        let expected = if body == slab { -2.0 * hard_m_s } else { 0.0 };
        assert!(
            (start_velocity(body) - expected).abs() < 0.05 * 2.0 * hard_m_s,
            "body {body}: {}",
            start_velocity(body)
        );
        let mean = (0..particles.len())
            .filter(|&i| start.body_of[i] == body)
            .map(|i| f64::from(first.velocity[1][i]))
            .sum::<f64>()
            / start.body_of.iter().filter(|&&b| b == body).count() as f64;
        assert!((mean - expected).abs() < 0.1 * 2.0 * hard_m_s, "body {body}'s particles move at {mean} m/s");
    }

    // they come back: momentum kept, no energy gained; each keeps its id, new ones after 1
    let line = stdout.lines().find(|line| line.contains("re-entry 1: piece 0 hit piece 1")).expect("the line");
    assert!(figure(line, "momentum kept to") <= 1e-6, "{line}");
    assert!(figure(line, "angular momentum to") <= 1e-6, "{line}");
    let (particle_energy, body_energy) = (figure(line, "kinetic energy"), figure(line, "J in the particles,"));
    assert!(body_energy <= particle_energy * 1.01, "the bodies gained energy: {line}");
    let after = last_rigid_frame(&out);
    assert!(after.fragment_count() > 2, "the slab landed on the plate whole: {stdout}");
    // every new piece lies within one of the two (no bond joined them), and each of the two
    // keeps its id on its largest part
    let mut within = std::collections::BTreeMap::new();
    for (&new, &old) in after.fragment_of.iter().zip(&handoff.fragment_of) {
        assert_eq!(*within.entry(new).or_insert(old), old, "piece {new} spans both bodies");
    }
    for (&part, &piece) in &within {
        let (size, kept) = (after.elements[part as usize], after.elements[piece as usize]);
        assert!(size <= kept, "piece {piece} kept its id on {kept} elements, its part {part} has {size}");
    }
    // one thread gives the same files (the checkpoints name their thread count)
    let single = tempfile::tempdir().expect("tempdir");
    two_slabs_scene(single.path(), 2.0 * hard_m_s);
    let output = shatter(&["--threads", "1", "run", "--until", "rigid"], single.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let skip = ["stamps.json", "shatter.lock", "sim.checkpoint.shp"];
    assert!(tree_files(&single.path().join("out"), &skip) == tree_files(&out, &skip), "1 and 2 threads differ");

    // well below the speed the slab lands on the plate without going back
    let soft = tempfile::tempdir().expect("tempdir");
    two_slabs_scene(soft.path(), 0.5 * hard_m_s);
    let output = shatter(&["run", "--until", "rigid"], soft.path());
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(!soft.path().join("out/rigid/reentry.001.shp").exists(), "a soft landing went back");
    assert_eq!(last_rigid_frame(&soft.path().join("out")).fragment_count(), 2);
}

/// The elastoplastic material of [`plastic_slab_scene`]: a soft polymer-like solid that yields
/// well before it breaks (yield strain 1e-3, critical stretch 2e-3).
const PLASTIC_YOUNGS_PA: f64 = 2e9;
const PLASTIC_POISSON: f64 = 0.35;
const PLASTIC_DENSITY_KG_M3: f64 = 1200.0;
const PLASTIC_CRITICAL_STRETCH: f64 = 0.002;
/// The artist's scale on the rule: the slab's second, softer landing is hard.
const PLASTIC_THRESHOLD_SCALE: f64 = 0.1;

/// The rule's critical speed of the elastoplastic material: s0 sqrt(M / rho), with the P-wave
/// modulus M = E (1 - nu) / ((1 + nu) (1 - 2 nu)).
fn plastic_critical_speed_m_s() -> f64 {
    let nu = PLASTIC_POISSON;
    let p_wave = PLASTIC_YOUNGS_PA * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu));
    PLASTIC_CRITICAL_STRETCH * (p_wave / PLASTIC_DENSITY_KG_M3).sqrt()
}

/// The slab of [`slab_geometry`] in the elastoplastic material, its lowest particles 0.4 mm above the
/// floor (its box's edge 1 mm below their centres' edge) and falling at `speed_m_s`: the
/// simulation holds its first landing, which dents its edge plastically; it bounces, and its
/// second landing is hard at [`PLASTIC_THRESHOLD_SCALE`].
fn plastic_slab_scene(dir: &Path, speed_m_s: f64) {
    let text = format!(
        r#"{}[material]
model = "elastoplastic"
density_kg_m3 = {PLASTIC_DENSITY_KG_M3}
youngs_modulus_pa = {PLASTIC_YOUNGS_PA}
poisson_ratio = {PLASTIC_POISSON}
yield_stress_pa = 2e6
critical_stretch = {PLASTIC_CRITICAL_STRETCH}
[sim]
frames = 40
steps_per_frame = 100
initial_velocity_m_s = [0.0, -{speed_m_s}, 0.0]
gravity_m_s2 = [0.0, -{GRAVITY_M_S2}, 0.0]
[sim.floor]
height_m = 0.0
[rigid]
follow_through_s = 0.3
[rigid.secondary_fracture]
min_elements = 64
threshold_scale = {PLASTIC_THRESHOLD_SCALE}
max_reentries = 1
"#,
        slab_geometry("plastic_slab", 2.5, -0.001),
    );
    std::fs::write(dir.join("pipeline.toml"), text).expect("config");
}

/// The largest difference between the lengths of `particles`' bonds with particle i at `a(i)`
/// and with it at `b(i)`, metres.
fn bond_length_change_m(particles: &ParticleSet, a: impl Fn(usize) -> [f64; 3], b: impl Fn(usize) -> [f64; 3]) -> f64 {
    let length = |p: [f64; 3], q: [f64; 3]| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt();
    let mut most: f64 = 0.0;
    for i in 0..particles.len() {
        for k in particles.bonds.row(i) {
            let j = particles.bonds.neighbor[k] as usize;
            most = most.max((length(a(i), a(j)) - length(b(i), b(j))).abs());
        }
    }
    most
}

#[test]
fn an_elastoplastic_piece_goes_back_with_its_dent_and_plastic_extensions() {
    let critical = plastic_critical_speed_m_s();
    let dir = tempfile::tempdir().expect("tempdir");
    plastic_slab_scene(dir.path(), 0.7 * critical);
    let output = shatter(&["--threads", "2", "run", "--until", "rigid"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let out = dir.path().join("out");
    let particles = ParticleSet::read(&out.join("particles.shp")).expect("particles");
    let reentry = Reentry::read(&out.join("rigid/reentry.001.shp"))
        .unwrap_or_else(|error| panic!("the slab did not go back ({error}): {stdout}"));
    assert_eq!(reentry.meta.hit, "floor");
    // the rule's threshold with this model's own P-wave modulus, K + 4 mu / 3
    let threshold = PLASTIC_THRESHOLD_SCALE * critical;
    assert!((reentry.meta.threshold_m_s / threshold - 1.0).abs() <= 1e-9, "{:?} against {threshold}", reentry.meta);

    // the start carries each bond's plastic extension as the simulation's last frame left it
    let pass = out.join("reentry/001");
    let pass_particles = ParticleSet::read(&pass.join("particles.shp")).expect("re-entry particles");
    let start = LeadIn::read(&pass.join("rigid/lead_in.shp")).expect("start");
    let plastic = start.plastic.as_ref().expect("the start carries the plastic state");
    assert_eq!(plastic.shape_m.len(), pass_particles.len());
    assert_eq!(plastic.extension_m.len(), pass_particles.bonds.neighbor.len());
    let (_, shot_state) = shatter_core::checkpoint::read(&out.join("sim.checkpoint.shp")).expect("the checkpoint");
    let members = &reentry.members;
    for i in 0..pass_particles.len() {
        for k in pass_particles.bonds.row(i) {
            let j = members[pass_particles.bonds.neighbor[k] as usize];
            let entry = particles.bonds.find(members[i] as usize, j).expect("a bond of the shot");
            assert_eq!(plastic.extension_m[k].to_bits(), shot_state.bond_state[entry].to_bits(), "entry {k}");
        }
    }
    let flowed = plastic.extension_m.iter().filter(|e| **e != 0.0).count();
    assert!(flowed > 0, "the first landing left no plastic extension");
    // inspect reads it, with how many bonds have flowed
    let output = shatter(&["inspect", "--json", "out/reentry/001/rigid/lead_in.shp"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let summary: serde_json::Value = serde_json::from_slice(&output.stdout).expect("json");
    assert_eq!(summary["plastic_bond_entries"], serde_json::json!(flowed));

    // and its shape: the re-entry's particles start as the shot's were at the handoff, moved
    // rigidly, their dent kept (the rest shape would have every bond at its rest length)
    let handoff = shatter_core::rigid_checkpoint::RigidCheckpoint::read(&out.join("rigid/rigid.checkpoint.shp"))
        .expect("rigid checkpoint")
        .meta
        .handoff_frame;
    let at_handoff = PointFrame::read(&out.join(format!("frames/points.{handoff:04}.ply"))).expect("handoff frame");
    let first = PointFrame::read(&pass.join("frames/points.0001.ply")).expect("first frame");
    let point = |frame: &PointFrame, i: usize| [0, 1, 2].map(|a| f64::from(frame.position[a][i]));
    let kept = bond_length_change_m(&pass_particles, |i| point(&first, i), |i| point(&at_handoff, members[i] as usize));
    let rest = |i: usize| pass_particles.rest_position_m[i].map(f64::from);
    let dent = bond_length_change_m(&pass_particles, |i| point(&at_handoff, members[i] as usize), rest);
    let shape = bond_length_change_m(&pass_particles, |i| plastic.shape_m[i].map(f64::from), rest);
    assert!(kept <= 1e-8, "bond lengths changed by {kept} m from the handoff to the re-entry's start");
    assert!(dent >= 100.0 * kept.max(1e-9) && (shape / dent - 1.0).abs() < 1e-3, "dent {dent} m, shape {shape} m");

    // it comes back: momentum kept, no kinetic energy gained
    let line = stdout.lines().find(|line| line.contains("re-entry 1: piece 0")).expect("the re-entry's line");
    assert!(figure(line, "momentum kept to") <= 1e-6, "{line}");
    assert!(figure(line, "angular momentum to") <= 1e-6, "{line}");
    let (particle_energy, body_energy) = (figure(line, "kinetic energy"), figure(line, "J in the particles,"));
    assert!(body_energy <= particle_energy * 1.01, "the bodies gained energy: {line}");
}
