//! The bad-input corpus, generated: every value of a small but complete scene replaced by hostile
//! values (negative, zero, huge, NaN, wrong types, too many entries) or removed, and every stage
//! file of a finished run damaged (flipped bytes in its header, payload and trailer, cut short,
//! lengthened, emptied, swapped for another stage's file) and handed to each stage that reads it.
//!
//! The standard: no panic, no abort, no signal; a refusal exits 2 (or 1 for I/O) naming the
//! file or key; an exit 0 is a correct result. For a config, correct means every stage file it
//! wrote reads back whole (`shatter inspect`) and every frame was rendered; for a damaged stage
//! file, it means the stage wrote exactly what it writes from the undamaged file.

use std::path::{Path, PathBuf};
use std::process::Output;

use support::{shatter, stderr, tree_files};

use crate::support;

/// A small scene that sets every section: a struck plate that breaks, a floor, a weakened path,
/// shards, post and render settings.
const SCENE: &str = r#"[scene]
name = "corpus"
output_dir = "out"
seed = 11

[geometry]
source = "box"
box_size_m = [0.008, 0.008, 0.003]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0

[geometry.transform]
rotate_deg = [0.0, 10.0, 0.0]
translate_m = [0.0, 0.01, 0.0]

[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
critical_stretch = 0.001

[sim]
backend = "cpu"
dt_s = 1.1920928955078125e-7
frames = 3
steps_per_frame = 80
checkpoint_every_frames = 1
gravity_m_s2 = [0.0, -9.81, 0.0]

[sim.floor]
height_m = 0.0
restitution = 0.5

[[sim.projectile]]
center_m = [0.0, 0.01, 0.0052]
velocity_m_s = [0.0, 0.0, -300.0]
radius_m = 0.002
stiffness_pa = 3e6

[[sim.weakened_path]]
start_m = [-0.004, 0.01, 0.0]
direction = [1.0, 0.0, 0.0]
steps = 20
step_length_m = 0.0004
radius_m = 0.0005
threshold_factor = 0.5

[post]
smoothing_frames = 1.0

[render]
backend = "cpu"
resolution = [24, 16]
samples_per_pixel = 1
max_bounces = 4
environment_intensity = 1.0
shutter = 0.5
texture_filter = "anisotropic"
denoising_passes = true

[render.camera]
position_m = [0.02, 0.03, 0.04]
look_at_m = [0.0, 0.01, 0.0]
fov_deg = 40.0
f_stop = 2.8
focus_distance_m = 0.05
sensor_height_mm = 24.0
"#;

/// Values no key of the scene takes as they are (or takes only within its range).
const HOSTILE: &[&str] = &[
    "-1",
    "0",
    "1e308",
    "nan",
    "-inf",
    "4294967296",
    "\"\"",
    "\"a\\u0000b\"",
    "true",
    "[]",
    "[1e30, -1e30, 1e30, 1e30]",
    "{ x = 1 }",
];

/// A folder holding `pipeline.toml` with `text`.
fn scene(text: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), text).expect("config");
    dir
}

/// What is wrong with how a command ended, if anything: a panic, an abort, a signal, an exit code
/// other than 0, 1 or 2, an error that names none of `names`.
fn misbehaviour(output: &Output, names: &[&str]) -> Option<String> {
    let message = stderr(output);
    match output.status.code() {
        None => Some(format!("killed by a signal: {message}")),
        Some(_) if message.contains("panicked") || message.contains("RUST_BACKTRACE") => {
            Some(format!("panicked: {message}"))
        }
        Some(0) => None,
        Some(1 | 2) if !message.contains("error:") => Some(format!("failed without an error line: {message}")),
        Some(1 | 2) if !names.iter().any(|name| message.contains(name)) => {
            Some(format!("the error names none of {names:?}: {message}"))
        }
        Some(1 | 2) => None,
        Some(code) => Some(format!("exit {code}: {message}")),
    }
}

/// The scene's leaf keys, as (line index, dotted key), from its text: `key = value` lines under
/// `[table]` or `[[array]]` headers.
fn leaf_lines(text: &str) -> Vec<(usize, String)> {
    let mut table = String::new();
    let mut keys = Vec::new();
    for (index, line) in text.lines().enumerate() {
        let line = line.trim();
        if let Some(header) = line.strip_prefix("[[").and_then(|rest| rest.strip_suffix("]]")) {
            table = header.to_owned();
        } else if let Some(header) = line.strip_prefix('[').and_then(|rest| rest.strip_suffix(']')) {
            table = header.to_owned();
        } else if let Some((key, _)) = line.split_once(" = ") {
            keys.push((index, format!("{table}.{key}")));
        }
    }
    keys
}

/// After an exit 0: every stage file reads back whole and every frame of the shot has its image
/// (the lead-in's, the simulation's up to the handoff and the follow-through's).
fn outputs_are_sound(dir: &Path) -> Result<(), String> {
    let out = dir.join("out");
    let mut files: Vec<PathBuf> = vec![out.join("particles.shp"), out.join("sim.checkpoint.shp")];
    let listing = |folder: &str, prefix: &str| -> Result<Vec<PathBuf>, String> {
        let entries = std::fs::read_dir(out.join(folder)).map_err(|error| format!("{folder}: {error}"))?;
        let mut paths: Vec<PathBuf> = entries
            .map(|entry| entry.expect("entry").path())
            .filter(|path| path.extension().is_some_and(|extension| extension == "ply" || extension == "shp"))
            .filter(|path| path.file_name().is_some_and(|name| name.to_string_lossy().starts_with(prefix)))
            .collect();
        paths.sort();
        Ok(paths)
    };
    files.extend(listing("frames", "")?);
    files.extend(listing("fragments", "")?);
    let simulated = listing("frames", "points.")?.len();
    let shot_frames = if out.join("rigid").is_dir() {
        let lead_in = listing("rigid", "lead_in.0")?;
        let follow_through = listing("rigid", "fragments.")?;
        files.extend(listing("rigid", "")?);
        // the follow-through's frames are numbered on from the simulation's handoff frame
        let last = match follow_through.last() {
            Some(path) => {
                let stem = path.file_stem().expect("stem").to_string_lossy().into_owned();
                stem.rsplit('.').next().and_then(|n| n.parse::<usize>().ok()).expect("frame number")
            }
            None => simulated,
        };
        lead_in.len() + last
    } else {
        simulated
    };
    for file in &files {
        let output = shatter(&["inspect", &file.display().to_string()], dir);
        if !output.status.success() {
            return Err(format!("{}: {}", file.display(), stderr(&output)));
        }
    }
    let images = std::fs::read_dir(out.join("render")).map_err(|error| format!("render: {error}"))?;
    let exrs = images.filter(|entry| entry.as_ref().is_ok_and(|e| e.path().extension().is_some_and(|x| x == "exr")));
    match exrs.count() {
        count if count == shot_frames => Ok(()),
        count => Err(format!("{count} images for {shot_frames} frames")),
    }
}

/// Runs `cases` on two threads (the machines have two cores) and gathers what went wrong.
fn sweep<T: Sync>(cases: &[T], check: impl Fn(&T) -> Option<String> + Sync) -> Vec<String> {
    let half = cases.len().div_ceil(2);
    std::thread::scope(|scope| {
        let handles: Vec<_> = cases
            .chunks(half.max(1))
            .map(|chunk| scope.spawn(|| chunk.iter().filter_map(&check).collect::<Vec<_>>()))
            .collect();
        handles.into_iter().flat_map(|handle| handle.join().expect("no panic in the sweep")).collect()
    })
}

/// Runs `text` whole, then every hostile value (and the removal) of each of its keys in one of
/// `tables` (all with an empty list), and asserts each is refused by name or runs soundly.
fn hostile_values_of(text: &str, tables: &[&str], at_least: usize) {
    let reference = scene(text);
    let output = shatter(&["run"], reference.path());
    assert!(output.status.success(), "the corpus scene runs: {}", stderr(&output));
    outputs_are_sound(reference.path()).expect("the corpus scene's outputs are sound");

    let lines: Vec<&str> = text.lines().collect();
    let mut cases = Vec::new();
    for (index, key) in leaf_lines(text) {
        let table = key.rsplit_once('.').map_or("", |(table, _)| table);
        if !tables.is_empty() && !tables.contains(&table) {
            continue;
        }
        let name = lines[index].split_once(" = ").expect("a key line").0.trim().to_owned();
        for value in HOSTILE.iter().map(|value| Some(*value)).chain([None]) {
            let mut mutated: Vec<String> = lines.iter().map(|line| (*line).to_owned()).collect();
            mutated[index] = value.map_or(String::new(), |value| format!("{name} = {value}"));
            cases.push((key.clone(), name.clone(), value, mutated.join("\n")));
        }
    }
    assert!(cases.len() >= at_least, "{} cases", cases.len());
    let failures = sweep(&cases, |(key, name, value, text)| {
        let dir = scene(text);
        let output = shatter(&["run"], dir.path());
        let what = format!("{key} = {}", value.unwrap_or("(removed)"));
        let table = key.rsplit('.').nth(1).unwrap_or_default();
        if let Some(wrong) = misbehaviour(&output, &[name, table, "pipeline.toml"]) {
            return Some(format!("{what}: {wrong}"));
        }
        if output.status.success()
            && let Err(wrong) = outputs_are_sound(dir.path())
        {
            return Some(format!("{what}: exit 0, but {wrong}"));
        }
        None
    });
    assert!(failures.is_empty(), "{} of {} configs misbehave:\n{}", failures.len(), cases.len(), failures.join("\n"));
}

#[test]
fn every_hostile_config_value_is_refused_by_name_or_runs_soundly() {
    hostile_values_of(SCENE, &[], 400);
}

/// A shot with every phase: a small block dropped 2 cm (lead-in), broken in slow motion (the
/// simulation) and played on as rigid bodies (follow-through), on a timeline.
const SHOT: &str = r#"[scene]
name = "shot"
output_dir = "out"
seed = 4

[geometry]
source = "box"
box_size_m = [0.006, 0.006, 0.006]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0

[geometry.transform]
translate_m = [0.0, 0.0035, 0.0]

[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
critical_stretch = 0.001

[lead_in]
translate_m = [0.0, 0.02, 0.0]
rotate_axis = [1.0, 0.0, 1.0]
rotate_deg = 20.0
velocity_m_s = [0.1, 0.0, 0.0]
angular_velocity_rad_s = [0.0, 1.0, 0.0]
handoff_gap_m = 0.003
max_step_s = 1e-4
max_duration_s = 1.0

[sim]
backend = "cpu"

[sim.floor]
height_m = 0.0

[rigid]
handoff_quiet_frames = 1
handoff_internal_energy_ratio = 0.1
handoff_rest_speed_m_s = 0.01
max_fracture_duration_s = 1.5e-5
max_step_s = 0.001
solver_iterations = 4
floor_friction = 0.6
floor_restitution = 0.2
piece_friction = 0.5
piece_restitution = 0.1
hull_volume_factor = 1.15
dust_max_elements = 1
sleep_speed_m_s = 0.02
sleep_after_s = 0.5
checkpoint_every_frames = 2

[timeline]
fps = 24.0
duration_s = 0.25
speed = 1.0

[timeline.slow_motion]
speed = 2.5e-4
lead_s = 0.0
hold_s = 0.2
ramp_in_s = 0.05
ramp_out_s = 0.0

[render]
backend = "cpu"
resolution = [24, 16]
samples_per_pixel = 1
"#;

#[test]
fn every_hostile_value_of_a_shots_phases_is_refused_by_name_or_runs_soundly() {
    hostile_values_of(SHOT, &["lead_in", "rigid", "timeline", "timeline.slow_motion"], 350);
}

/// Ways to damage a file of `len` bytes: (what, the damaged bytes).
fn damages(bytes: &[u8], other_kind: &[u8]) -> Vec<(String, Vec<u8>)> {
    let len = bytes.len();
    let mut out = Vec::new();
    let positions =
        [0, 9, 13, 17, 21, 30, 45, 60, 75, 90, 105, 120, 135, len / 3, len / 2, 2 * len / 3, len - 9, len - 5, len - 1];
    for position in positions {
        let mut flipped = bytes.to_vec();
        flipped[position] ^= 0x10;
        out.push((format!("byte {position} flipped"), flipped));
    }
    for cut in [0, 7, 24, len / 2, len - 8, len - 1] {
        out.push((format!("cut to {cut} bytes"), bytes[..cut].to_vec()));
    }
    out.push(("one byte appended".into(), [bytes, b"\0"].concat()));
    out.push(("a kilobyte of garbage appended".into(), [bytes, &[0xA5; 1024]].concat()));
    out.push(("another stage's file".into(), other_kind.to_vec()));
    out
}

/// A stage file, a file of another kind to swap in, and the commands that read it.
type Reader<'a> = (&'a str, &'a str, &'a [&'a [&'a str]]);

#[test]
fn every_damaged_stage_file_is_refused_by_name_or_changes_nothing() {
    damaged_files_of(
        SCENE,
        &[
            ("particles.shp", "sim.checkpoint.shp", &[&["sim"], &["post"], &["render"]]),
            ("sim.checkpoint.shp", "particles.shp", &[&["sim", "--resume"]]),
            ("frames/points.0002.ply", "fragments/fragments.0002.shp", &[&["post"]]),
            ("frames/breaks.log", "frames/points.0002.ply", &[&["post"], &["sim", "--resume"]]),
            ("fragments/fragments.0002.shp", "frames/points.0002.ply", &[&["render"]]),
            ("fragments/fragments.0003.shp", "particles.shp", &[&["render", "--frames", "3"]]),
        ],
    );
}

#[test]
fn every_damaged_file_of_a_shots_phases_is_refused_by_name_or_changes_nothing() {
    damaged_files_of(
        SHOT,
        &[
            ("rigid/lead_in.shp", "rigid/rigid.checkpoint.shp", &[&["sim"], &["post"], &["rigid"], &["render"]]),
            ("rigid/lead_in.0001.shp", "particles.shp", &[&["render", "--frames", "1"]]),
            ("rigid/rigid.checkpoint.shp", "rigid/lead_in.shp", &[&["rigid", "--resume"], &["render"]]),
            ("rigid/fragments.0005.shp", "rigid/lead_in.shp", &[&["render", "--frames", "6"]]),
        ],
    );
}

/// Runs `text` whole, then damages each of `files` in every way, runs each command that reads
/// it on a copy of the outputs, and asserts it refuses by name or writes what it would have.
fn damaged_files_of(text: &str, files: &[Reader]) {
    let reference = scene(text);
    let output = shatter(&["run"], reference.path());
    assert!(output.status.success(), "the corpus scene runs: {}", stderr(&output));
    let expected = tree_files(&reference.path().join("out"), &["shatter.lock", "stamps.json"]);
    let out = reference.path().join("out");
    let mut cases = Vec::new();
    for &(file, other, commands) in files {
        let bytes = std::fs::read(out.join(file)).expect("stage file");
        let other = std::fs::read(out.join(other)).expect("other stage file");
        for (damage, damaged) in damages(&bytes, &other) {
            // inspect summarises any stage file: another stage's is no damage to it
            let inspect = (damage != "another stage's file").then(|| vec!["inspect", file]);
            for command in commands.iter().map(|command| command.to_vec()).chain(inspect) {
                cases.push((file, damage.clone(), damaged.clone(), command));
            }
        }
    }
    assert!(cases.len() >= 25 * files.len(), "{} cases", cases.len());
    let failures = sweep(&cases, |(file, damage, damaged, command)| {
        let dir = scene(text);
        for (name, bytes) in &expected {
            let path = dir.path().join("out").join(name);
            std::fs::create_dir_all(path.parent().expect("parent")).expect("folder");
            std::fs::write(&path, bytes).expect("copy");
        }
        std::fs::write(dir.path().join("out").join(file), damaged).expect("damage");
        let mut args = command.clone();
        let inspected;
        if args[0] == "inspect" {
            inspected = format!("out/{file}");
            args[1] = &inspected;
        }
        let output = shatter(&args, dir.path());
        let what = format!("{file}, {damage}, `{}`", command.join(" "));
        let base_name = Path::new(file).file_name().expect("name").to_string_lossy().into_owned();
        if let Some(wrong) = misbehaviour(&output, &[&base_name]) {
            return Some(format!("{what}: {wrong}"));
        }
        if output.status.success() {
            if args[0] == "inspect" {
                return Some(format!("{what}: inspect read the damaged file without complaint"));
            }
            let after = tree_files(&dir.path().join("out"), &["shatter.lock", "stamps.json"]);
            let changed: Vec<&String> = after
                .iter()
                .filter(|(name, bytes)| {
                    name != file && expected.iter().find(|(n, _)| n == name).is_none_or(|(_, b)| b != bytes)
                })
                .map(|(name, _)| name)
                .collect();
            if !changed.is_empty() {
                return Some(format!("{what}: exit 0 with different outputs: {changed:?}"));
            }
        }
        None
    });
    assert!(failures.is_empty(), "{} of {} cases misbehave:\n{}", failures.len(), cases.len(), failures.join("\n"));
}
