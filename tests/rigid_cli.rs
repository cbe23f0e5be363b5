//! `shatter rigid`, the follow-through: a struck plate hands its pieces to rigid bodies with
//! their momentum, they fall and come to rest on the floor; the same at any thread count and
//! after kill -9 and `--resume`; a scene without `[rigid]` is told what is missing.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use shatter_core::fragments::FragmentFrame;
use shatter_core::particles::{Elements, ParticleSet};
use shatter_core::rigid_checkpoint::RigidCheckpoint;
use support::{figure, shatter, stderr, tree_files};

use crate::support;

const SCENE: &str = r#"
[scene]
name = "struck"
output_dir = "out"
seed = 5
[geometry]
source = "box"
box_size_m = [0.024, 0.024, 0.004]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0
[geometry.transform]
translate_m = [0.0, 0.03, 0.0]
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
[sim]
frames = 16
steps_per_frame = 40
[sim.floor]
height_m = 0.0
[[sim.projectile]]
center_m = [0.0, 0.03, 0.0067]
velocity_m_s = [0.0, 0.0, -150.0]
radius_m = 0.003
stiffness_pa = 3e6
[rigid]
follow_through_s = 2.0
checkpoint_every_frames = 4
bounds_m = [[-1.0, -1.0, -1.0], [1.0, 10.0, 1.0]]
[render]
backend = "cpu"
resolution = [64, 48]
samples_per_pixel = 2
"#;

fn scene(dir: &Path, text: &str) {
    std::fs::write(dir.join("pipeline.toml"), text).expect("config");
}

/// The height at `frame` of a point `c` of the piece `piece`'s rest frame, metres.
fn height(frame: &FragmentFrame, piece: u32, c: [f64; 3]) -> f64 {
    let [x, y, z, w] = frame.rotation[piece as usize].map(f64::from);
    // y of R c for the unit quaternion (x, y, z, w)
    let ry = 2.0 * (x * y + w * z) * c[0] + (1.0 - 2.0 * (x * x + z * z)) * c[1] + 2.0 * (y * z - w * x) * c[2];
    ry + frame.translation_m[piece as usize][1]
}

/// The lowest point of every element at `frame`, metres.
fn lowest_point(particles: &ParticleSet, frame: &FragmentFrame) -> f64 {
    let Elements::Cubes { half_size_m, .. } = &particles.elements else { panic!("a grid makes cubes") };
    let mut lowest = f64::INFINITY;
    for (element, &piece) in frame.fragment_of.iter().enumerate() {
        let p = particles.rest_position_m[element].map(f64::from);
        let h = f64::from(half_size_m[element]);
        for corner in 0..8 {
            let c = [0, 1, 2].map(|a| p[a] + if corner & (1 << a) != 0 { h } else { -h });
            lowest = lowest.min(height(frame, piece, c));
        }
    }
    lowest
}

/// The median height at `frame` of the particles whose pieces are within `half_width_m` of the
/// origin across (the plate's rest frame is centred there within millimetres), metres.
fn median_height(particles: &ParticleSet, frame: &FragmentFrame, half_width_m: f64) -> f64 {
    let within = |piece: u32| {
        let t = frame.translation_m[piece as usize];
        t[0].abs() <= half_width_m && t[2].abs() <= half_width_m
    };
    let mut heights: Vec<f64> = (0..frame.fragment_of.len())
        .filter(|&element| within(frame.fragment_of[element]))
        .map(|element| height(frame, frame.fragment_of[element], particles.rest_position_m[element].map(f64::from)))
        .collect();
    heights.sort_by(f64::total_cmp);
    heights[heights.len() / 2]
}

#[test]
fn a_struck_plate_hands_over_falls_and_comes_to_rest_the_same_at_any_thread_count() {
    let dir = tempfile::tempdir().expect("tempdir");
    scene(dir.path(), SCENE);
    let output = shatter(&["--threads", "2", "run", "--until", "rigid"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(figure(&stdout, "momentum kept to") <= 1e-6, "{stdout}");
    assert!(figure(&stdout, "angular momentum to") <= 1e-6, "{stdout}");
    let particles_energy = figure(&stdout, "kinetic energy");
    let rigid_part = figure(&stdout, "J in the particles (");
    let bodies = figure(&stdout, "J rigid), ");
    assert!(bodies <= particles_energy * (1.0 + 1e-9), "rigid bodies gained energy: {stdout}");
    assert!(bodies >= 0.95 * rigid_part, "rigid bodies lost too much of the rigid motion: {stdout}");
    assert!(figure(&stdout, "deepest overlap at the end") <= 1.0, "a piece ends inside another or the floor: {stdout}");

    let out = dir.path().join("out");
    let checkpoint = RigidCheckpoint::read(&out.join("rigid/rigid.checkpoint.shp")).expect("checkpoint");
    assert_eq!(checkpoint.meta.last_frame, 16 + 48);
    assert_eq!(checkpoint.meta.frame, checkpoint.meta.last_frame);
    assert!(checkpoint.meta.asleep, "every piece sleeps at the end of the shot");
    let particles = ParticleSet::read(&out.join("particles.shp")).expect("particles");
    let handoff = checkpoint.meta.handoff_frame;
    let start = FragmentFrame::read(&out.join(format!("fragments/fragments.{handoff:04}.shp"))).expect("handoff");
    let end = FragmentFrame::read(&out.join("rigid/fragments.0064.shp")).expect("last frame");
    assert_eq!(start.fragment_of, end.fragment_of, "the pieces are the handoff's");
    assert!(lowest_point(&particles, &start) > 0.002, "the plate starts above the floor");
    let lowest = lowest_point(&particles, &end);
    assert!(lowest > -1e-3, "a piece ends {lowest} m below the floor");
    assert!(median_height(&particles, &start, 1.0) > 0.025, "the plate starts at its height");
    // those in the region (pieces thrown out of it may hang where they were retired)
    let resting = median_height(&particles, &end, 1.0);
    assert!(resting < 0.002, "the pieces fell and lie on the floor: median height {resting} m");
    let before_end = FragmentFrame::read(&out.join("rigid/fragments.0063.shp")).expect("frame 63");
    let moved = before_end
        .translation_m
        .iter()
        .zip(&end.translation_m)
        .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    assert!(moved < 1e-3, "a piece still moved {moved} m in the last frame");

    // one thread: the very same files
    let single = tempfile::tempdir().expect("tempdir");
    scene(single.path(), SCENE);
    let output = shatter(&["--threads", "1", "run", "--until", "rigid"], single.path());
    assert!(output.status.success(), "{}", stderr(&output));
    // (the simulation's checkpoint names its backend, thread count included)
    let skip = ["stamps.json", "shatter.lock", "sim.checkpoint.shp"];
    assert!(tree_files(&out, &skip) == tree_files(&single.path().join("out"), &skip), "1 and 2 threads differ");

    // the shot renders through the handoff into the follow-through
    let output = shatter(&["render", "--frames", "16-17,64"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(out.join("render/struck.0064.exr").is_file());
}

#[test]
fn a_follow_through_killed_and_resumed_ends_identical() {
    let reference = tempfile::tempdir().expect("tempdir");
    scene(reference.path(), SCENE);
    let output = shatter(&["run", "--until", "rigid"], reference.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let expected = tree_files(&reference.path().join("out/rigid"), &[]);

    let killed = tempfile::tempdir().expect("tempdir");
    scene(killed.path(), SCENE);
    let output = shatter(&["run", "--until", "post"], killed.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let checkpoint = killed.path().join("out/rigid/rigid.checkpoint.shp");
    let reached = || RigidCheckpoint::read(&checkpoint).map_or(0, |c| c.meta.frame);
    let mut kills = 0;
    for attempt in 0..3 {
        let mut child = Command::new(env!("CARGO_BIN_EXE_shatter"))
            .args(if attempt == 0 { vec!["rigid"] } else { vec!["rigid", "--resume"] })
            .current_dir(killed.path())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn");
        // kill a little after the run has saved a checkpoint past the last one: mid-way
        // between checkpoints, with frames written that the resumed run writes again
        let before = reached();
        let started = Instant::now();
        while reached() <= before
            && child.try_wait().expect("wait").is_none()
            && started.elapsed() < Duration::from_secs(60)
        {
            std::thread::sleep(Duration::from_millis(5));
        }
        std::thread::sleep(Duration::from_millis(40 * (attempt + 1)));
        if child.try_wait().expect("wait").is_none() {
            child.kill().expect("SIGKILL");
            kills += 1;
        }
        child.wait().expect("reap");
    }
    assert!(kills >= 2, "most runs were killed mid-way ({kills} of 3)");
    let output = shatter(&["rigid", "--resume"], killed.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let resumed = tree_files(&killed.path().join("out/rigid"), &[]);
    assert_eq!(resumed.len(), expected.len());
    for ((name, bytes), (expected_name, expected_bytes)) in resumed.iter().zip(&expected) {
        assert_eq!(name, expected_name);
        assert!(bytes == expected_bytes, "{name} differs after kill -9 and resume");
    }
}

#[test]
fn a_scene_without_rigid_is_told_so_and_renders_as_before() {
    let dir = tempfile::tempdir().expect("tempdir");
    let text = SCENE.split("[rigid]").next().expect("head").to_string()
        + "[render]\nbackend = \"cpu\"\nresolution = [64, 48]\nsamples_per_pixel = 2\n";
    scene(dir.path(), &text);
    let output = shatter(&["rigid"], dir.path());
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("pipeline.toml: no [rigid] table"), "{}", stderr(&output));
    let output = shatter(&["run"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(dir.path().join("out/render/struck.0016.exr").is_file());
    assert!(!dir.path().join("out/render/struck.0017.exr").exists(), "no follow-through frames");
    assert!(!dir.path().join("out/rigid").exists());
}

const DROP: &str = r#"
[scene]
name = "drop"
output_dir = "out"
seed = 3
[geometry]
source = "box"
box_size_m = [0.012, 0.012, 0.012]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0
[geometry.transform]
translate_m = [0.0, 0.0065, 0.0]
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
[lead_in]
translate_m = [0.0, 0.05, 0.0]
velocity_m_s = [0.1, 0.0, 0.0]
rotate_axis = [1.0, 0.0, 1.0]
rotate_deg = 30.0
[sim]
frames = 6
steps_per_frame = 100
[sim.floor]
height_m = 0.0
[rigid]
follow_through_s = 0.25
[render]
backend = "cpu"
resolution = [32, 24]
samples_per_pixel = 1
"#;

#[test]
fn a_dropped_block_flies_the_parabola_and_the_simulation_takes_over_from_there() {
    use shatter_core::frames::PointFrame;
    use shatter_core::lead_in::LeadIn;

    let dir = tempfile::tempdir().expect("tempdir");
    scene(dir.path(), DROP);
    let output = shatter(&["run"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let out = dir.path().join("out");
    let lead_in = LeadIn::read(&out.join("rigid/lead_in.shp")).expect("lead-in");
    let g = -9.81;
    let t_c = lead_in.handoff_time_s;
    // the block's lowest corner starts 50.5 mm up and the simulation starts a horizon (3 mm)
    // above the floor: about 0.1 s of flight, on the parabola
    assert!((0.08..0.11).contains(&t_c), "handoff at {t_c} s");
    let start = [0.0, 0.0565, 0.0];
    let expected = [start[0] + 0.1 * t_c, start[1] + 0.5 * g * t_c * t_c, start[2]];
    let drop = start[1] - expected[1];
    for a in 0..3 {
        assert!(
            (lead_in.centre_m[a] - expected[a]).abs() <= 1e-6 * drop,
            "centre {:?} vs {expected:?}",
            lead_in.centre_m
        );
    }
    let v = lead_in.velocity_m_s;
    assert!((v[0] - 0.1).abs() < 1e-9 && (v[1] - g * t_c).abs() < 1e-9 && v[2].abs() < 1e-9, "velocity {v:?}");
    // every lead-in frame on the same parabola, one frame of the shot's rate apart
    for frame in 1..=lead_in.frames {
        let fragments = FragmentFrame::read(&out.join(format!("rigid/lead_in.{frame:04}.shp"))).expect("frame");
        let time = f64::from(frame - 1) / 24.0;
        assert_eq!(fragments.meta.time_s, time);
        let y = fragments.translation_m[0][1] - lead_in.translation_m[1];
        let analytic = 0.5 * g * (time * time - t_c * t_c);
        assert!((y - analytic).abs() <= 1e-6 * drop, "frame {frame}: {y} vs {analytic}");
    }
    // the simulation's first frame is the body at the handoff, every particle moving with it
    let particles = ParticleSet::read(&out.join("particles.shp")).expect("particles");
    let first = PointFrame::read(&out.join("frames/points.0001.ply")).expect("frame 1");
    let [x, y, z, w] = lead_in.rotation;
    for (i, rest) in particles.rest_position_m.iter().enumerate().step_by(97) {
        let p = rest.map(f64::from);
        let ry = 2.0 * (x * y + w * z) * p[0] + (1.0 - 2.0 * (x * x + z * z)) * p[1] + 2.0 * (y * z - w * x) * p[2];
        let now = f64::from(first.position[1][i]);
        assert!((now - (ry + lead_in.translation_m[1])).abs() < 1e-6, "particle {i} at {now}");
        assert!((f64::from(first.velocity[1][i]) - v[1]).abs() < 1e-5);
    }
    // the shot: lead-in, simulation, follow-through, rendered in one numbering
    let last = lead_in.frames + 6 + 6;
    assert!(out.join(format!("render/drop.{last:04}.exr")).is_file(), "the shot's last frame is rendered");
    assert!(!out.join(format!("render/drop.{:04}.exr", last + 1)).exists());
    let inspect = shatter(&["inspect", "out/rigid/lead_in.shp"], dir.path());
    assert!(String::from_utf8_lossy(&inspect.stdout).contains("handoff_time_s"));
}

/// Where the rest-frame point `c` of fragment `piece` is at `frame`: R c + t.
fn place(frame: &FragmentFrame, piece: u32, c: [f64; 3]) -> [f64; 3] {
    let [x, y, z, w] = frame.rotation[piece as usize].map(f64::from);
    let r = [
        [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
    ];
    let t = frame.translation_m[piece as usize];
    [0, 1, 2].map(|a| r[a][0] * c[0] + r[a][1] * c[1] + r[a][2] * c[2] + t[a])
}

/// The shot USD's check, in Python with `pxr`: it opens; frames 1 to N at 24 fps; one mesh per
/// piece, each sampled at every frame; some mesh's transform at frame 1 and at frame N takes
/// the rest point given to the positions given (within 1e-5 m, the files' single precision);
/// `/Shatter.shatter:physicalTime` at frames 1 and N is the physical time given (within half a
/// simulation step, 6e-8 s).
const SHOT_USD_CHECK: &str = r#"
import sys
from pxr import Usd, UsdGeom, Gf
path, pieces, frames = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rest, first, last = [Gf.Vec3d(*[float(v) for v in sys.argv[4 + 3 * k:7 + 3 * k]]) for k in range(3)]
stage = Usd.Stage.Open(path)
assert stage, "the stage does not open"
assert (stage.GetStartTimeCode(), stage.GetEndTimeCode(), stage.GetTimeCodesPerSecond()) == (1, frames, 24)
meshes = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
assert len(meshes) == pieces, (len(meshes), pieces)
for prim in meshes:
    samples = prim.GetAttribute("xformOp:transform").GetTimeSamples()
    assert list(samples) == [float(f) for f in range(1, frames + 1)], samples
for frame, expected in [(1, first), (frames, last)]:
    error = min((UsdGeom.Xformable(p).GetLocalTransformation(frame).Transform(rest) - expected).GetLength() for p in meshes)
    assert error < 1e-5, (frame, error)
clock = stage.GetPrimAtPath("/Shatter").GetAttribute("shatter:physicalTime")
for frame, expected in [(1, float(sys.argv[13])), (frames, float(sys.argv[14]))]:
    # the follow-through counts from the handoff frame's step, the nearest to the curve's time
    assert abs(clock.Get(frame) - expected) <= 1e-7, (frame, clock.Get(frame), expected)
print("shot usd ok", len(meshes))
"#;

#[test]
fn a_timeline_puts_every_frame_of_the_shot_where_its_speed_curve_says() {
    use shatter_core::PipelineConfig;
    use shatter_core::frames::PointFrame;
    use shatter_core::lead_in::LeadIn;
    use shatter_core::timeline::Timeline;

    // the drop at real speed, easing into 4000x slow motion for the impact (about 100 steps a
    // frame) and back out for the follow-through
    let timed = DROP
        .replace("frames = 6\nsteps_per_frame = 100\n", "")
        .replace("[rigid]\nfollow_through_s = 0.25", "[rigid]\nmax_fracture_duration_s = 6e-5")
        .replace(
            "[render]",
            "[timeline]\nfps = 24.0\nduration_s = 0.75\n[timeline.slow_motion]\nspeed = 2.5e-4\nlead_s = 0.05\n\
             hold_s = 0.2\nramp_in_s = 0.1\nramp_out_s = 0.1\n[render]",
        );
    let dir = tempfile::tempdir().expect("tempdir");
    scene(dir.path(), &timed);
    let output = shatter(&["run"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let out = dir.path().join("out");
    let config = PipelineConfig::load(&dir.path().join("pipeline.toml")).expect("config");
    let lead_in = LeadIn::read(&out.join("rigid/lead_in.shp")).expect("lead-in");
    let timeline = Timeline::new(config.timeline.as_ref().expect("timeline"), lead_in.handoff_time_s);
    assert_eq!(timeline.frames(), 18);
    assert_eq!(lead_in.frames, timeline.impact_frame() - 1);
    assert!(lead_in.frames >= 3, "the fall takes frames: {}", lead_in.frames);
    // the lead-in's frames on the parabola at the timeline's times, easing into slow motion
    let g = -9.81;
    let t_c = lead_in.handoff_time_s;
    for frame in 1..=lead_in.frames {
        let fragments = FragmentFrame::read(&out.join(format!("rigid/lead_in.{frame:04}.shp"))).expect("frame");
        let time = timeline.time_s(frame);
        assert_eq!(fragments.meta.time_s, time);
        let y = fragments.translation_m[0][1] - lead_in.translation_m[1];
        let analytic = 0.5 * g * (time * time - t_c * t_c);
        assert!((y - analytic).abs() <= 1e-6 * 0.05, "frame {frame}: {y} vs {analytic}");
    }
    // the simulation's frames on the steps nearest the timeline's times, from the impact on
    // the step the simulation took (the scene leaves sim.dt_s unset), as its frames record it
    let dt = shatter_core::time_step::recorded_s(&shatter_core::OutputLayout::of(&config)).expect("step");
    let mut sim_frames = 0;
    while out.join(format!("frames/points.{:04}.ply", sim_frames + 1)).is_file() {
        sim_frames += 1;
        let points = PointFrame::read(&out.join(format!("frames/points.{sim_frames:04}.ply"))).expect("frame");
        let since = timeline.since_impact_s(lead_in.frames + sim_frames);
        assert!((points.time_s - since).abs() <= 0.5 * dt + 1e-15, "frame {sim_frames}: {} vs {since}", points.time_s);
    }
    assert!(sim_frames >= 5, "the fracture spans the held window's frames: {sim_frames}");
    // the follow-through's frames at the timeline's times to the shot's end
    let checkpoint = RigidCheckpoint::read(&out.join("rigid/rigid.checkpoint.shp")).expect("checkpoint");
    let meta = checkpoint.meta;
    assert_eq!(lead_in.frames + meta.last_frame, timeline.frames());
    for frame in meta.handoff_frame + 1..=meta.last_frame {
        let fragments = FragmentFrame::read(&out.join(format!("rigid/fragments.{frame:04}.shp"))).expect("frame");
        let since = timeline.since_impact_s(lead_in.frames + frame);
        assert!((fragments.meta.time_s - since).abs() <= 0.5 * dt + 1e-12, "rigid frame {frame}");
    }
    // rendered in one numbering: exactly the timeline's frames
    assert!(out.join("render/drop.0018.exr").is_file() && !out.join("render/drop.0019.exr").exists());
    // and the USD of the whole shot, read by Pixar's usd-core: one mesh per rigid body, every
    // frame sampled, element 0 where the lead-in's first and the follow-through's last frames
    // put it; post's USD holds the lead-in and the simulation at their shot time codes
    let particles = ParticleSet::read(&out.join("particles.shp")).expect("particles");
    let rest = particles.rest_position_m[0].map(f64::from);
    let first = FragmentFrame::read(&out.join("rigid/lead_in.0001.shp")).expect("lead-in frame");
    let last_path = out.join(format!("rigid/fragments.{:04}.shp", meta.last_frame));
    let last = FragmentFrame::read(&last_path).expect("last frame");
    let place = |frame: &FragmentFrame| place(frame, frame.fragment_of[0], rest).map(|c| c.to_string());
    let script = dir.path().join("check_shot_usd.py");
    std::fs::write(&script, SHOT_USD_CHECK).expect("script");
    let mut args = vec![script.display().to_string(), out.join("rigid/shot.usda").display().to_string()];
    args.extend([last.fragment_count().to_string(), "18".to_string()]);
    args.extend(rest.map(|c| c.to_string()).into_iter().chain(place(&first)).chain(place(&last)));
    args.extend([timeline.time_s(1), timeline.time_s(18)].map(|t| t.to_string()));
    let check = Command::new("python3").args(&args).output().expect("python3 runs");
    let said = format!("{}{}", String::from_utf8_lossy(&check.stdout), String::from_utf8_lossy(&check.stderr));
    assert!(check.status.success(), "shot USD check failed (needs usd-core):\n{said}");
    let post_usd = std::fs::read_to_string(out.join("fragments/fragments.usda")).expect("post's USD");
    let post_end = lead_in.frames + sim_frames;
    assert!(post_usd.contains(&format!("endTimeCode = {post_end}\n")), "post's USD ends at frame {post_end}");

    // a shot too short to reach the impact is refused by name, before the simulation
    let short = timed.replace("duration_s = 0.75", "duration_s = 0.05");
    scene(dir.path(), &short);
    let output = shatter(&["lead-in"], dir.path());
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("timeline.duration_s = 0.05"), "{}", stderr(&output));
}

#[test]
fn bad_lead_in_and_rigid_values_are_refused_by_name() {
    let cases = [
        ("[rigid]\nfollow_through_s = 0.25", "[rigid]\nfollow_through_s = -1", "rigid.follow_through_s"),
        ("[rigid]\nfollow_through_s = 0.25", "[rigid]\nfloor_restitution = 2.0", "rigid.floor_restitution"),
        ("[rigid]\nfollow_through_s = 0.25", "[rigid]\nsolver_iterations = 0", "rigid.solver_iterations"),
        ("[rigid]\nfollow_through_s = 0.25", "[rigid]\nmax_step_s = nan", "rigid.max_step_s"),
        ("[rigid]\nfollow_through_s = 0.25", "[rigid]\nfollow_through_s = 4000.0", "rigid.follow_through_s"),
        ("[rigid]\nfollow_through_s = 0.25", "[rigid]\nbounce = 1", "bounce"),
        ("rotate_axis = [1.0, 0.0, 1.0]", "rotate_axis = [0.0, 0.0, 0.0]", "lead_in.rotate_axis"),
        ("rotate_deg = 30.0", "rotate_deg = inf", "lead_in.rotate_deg"),
        ("velocity_m_s = [0.1, 0.0, 0.0]", "velocity_m_s = [0.1, 0.0]", "lead_in.velocity_m_s"),
        ("[lead_in]", "[lead_in]\nhandoff_gap_m = 0.0", "lead_in.handoff_gap_m"),
        ("[lead_in]", "[lead_in]\nmax_duration_s = 1e308", "lead_in.max_duration_s"),
        ("[sim.floor]\nheight_m = 0.0", "", "lead_in"),
        ("seed = 3", "seed = 3\nframes_per_second = 1e308", "scene.frames_per_second"),
        ("seed = 3", "seed = 3\nframes_per_second = 1000.0\n", "rigid.follow_through_s"),
    ];
    for (from, to, key) in cases {
        assert!(DROP.contains(from), "{from}");
        let dir = tempfile::tempdir().expect("tempdir");
        let mut text = DROP.replacen(from, to, 1);
        if to.contains("frames_per_second = 1000.0") {
            // 1,000 fps for 1,200 s: more frames than a follow-through may add
            text = text.replace("follow_through_s = 0.25", "follow_through_s = 1200.0");
        }
        scene(dir.path(), &text);
        let output = shatter(&["run"], dir.path());
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{to}: {message}");
        assert!(message.contains("pipeline.toml") && message.contains(key), "{to}: {message}");
        assert!(!message.contains("panicked"), "{to}: {message}");
    }
}
