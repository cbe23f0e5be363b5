//! The `shatter` command line as users meet it: exit codes, messages, files written and kept.

use std::path::{Path, PathBuf};
use std::process::Command;

use support::{SMALL_PLATE as GOOD, shatter, stderr};

use crate::support;

fn mesh_path(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/meshes").join(name);
    path.display().to_string()
}

/// The good scene on the spot mesh instead of the box.
fn spot_scene() -> String {
    GOOD.replace("source = \"box\"", &format!("source = {:?}", mesh_path("spot_triangulated.obj")))
        .replace("box_size_m = [0.01, 0.01, 0.004]\n", "")
}

/// A temporary folder holding `pipeline.toml` with `text`.
fn scene(text: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("tempdir");
    let config = dir.path().join("pipeline.toml");
    std::fs::write(&config, text).expect("write config");
    (dir, config)
}

#[test]
fn bad_configs_name_the_key_and_exit_with_2() {
    let garbage_dir = tempfile::tempdir().expect("tempdir");
    let garbage = garbage_dir.path().join("garbage.obj");
    std::fs::write(&garbage, b"\x00\x9f\x92\x96 this is not a mesh \xff\xfe").expect("write");
    let not_obj = garbage_dir.path().join("text.obj");
    std::fs::write(&not_obj, "hello world\nv 1 2\n").expect("write");
    let with_mesh = |path: &str| GOOD.replace("source = \"box\"", &format!("source = {path:?}"));
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "unknown key",
            GOOD.replace("seed = 1", "seed = 1\ncolour = \"red\""),
            vec!["scene.colour", "unknown field `colour`"],
        ),
        (
            "negative density",
            GOOD.replace("2200.0", "-2200.0"),
            vec!["material.density_kg_m3 = -2200", "greater than 0"],
        ),
        (
            "horizon factor 0",
            GOOD.replace("horizon_factor = 3.0", "horizon_factor = 0"),
            vec!["geometry.horizon_factor = 0", "between 1 and 8"],
        ),
        (
            "missing mesh file",
            with_mesh("no/such/mesh.obj"),
            vec!["geometry.source", "no/such/mesh.obj", "mesh file not found"],
        ),
        (
            "garbage mesh file",
            with_mesh(&garbage.display().to_string()),
            vec!["geometry.source", "garbage.obj", "cannot read the mesh"],
        ),
        (
            "text that is not OBJ",
            with_mesh(&not_obj.display().to_string()),
            vec!["geometry.source", "text.obj", "not a valid Wavefront OBJ file"],
        ),
        (
            "wrong type",
            GOOD.replace("spacing_m = 0.001", "spacing_m = \"fine\""),
            vec!["geometry.spacing_m", "invalid type: string \"fine\", expected f64"],
        ),
        (
            "unknown sampler",
            GOOD.replace("\"grid\"", "\"hexagonal\""),
            vec!["geometry.sampler", "unknown variant `hexagonal`", "`tet_shell`"],
        ),
        ("missing key", GOOD.replace("spacing_m = 0.001\n", ""), vec!["geometry", "missing field `spacing_m`"]),
        ("not TOML", "[scene\nname = ".to_string(), vec!["pipeline.toml", "TOML parse error"]),
        (
            "box without size",
            GOOD.replace("box_size_m = [0.01, 0.01, 0.004]\n", ""),
            vec!["geometry.box_size_m", "needs box_size_m"],
        ),
        (
            "zero spacing",
            GOOD.replace("spacing_m = 0.001", "spacing_m = 0.0"),
            vec!["geometry.spacing_m = 0", "greater than 0"],
        ),
        ("negative seed", GOOD.replace("seed = 1", "seed = -1"), vec!["scene.seed", "expected u64"]),
        ("bad name", GOOD.replace("\"glass_plate\"", "\"a/b\""), vec!["scene.name", "letters, digits"]),
        (
            "stretch and energy",
            GOOD.replace("14.9e9", "14.9e9\ncritical_stretch = 0.001\nfracture_energy_j_m2 = 8.0"),
            vec!["not both"],
        ),
        (
            "huge jitter",
            GOOD.replace("14.9e9", "14.9e9\nthreshold_jitter = 0.5"),
            vec!["material.threshold_jitter = 0.5"],
        ),
        ("unknown table", format!("{GOOD}\n[camera]\nfov_deg = 40\n"), vec!["unknown field `camera`"]),
        (
            "spacing too fine for the box",
            GOOD.replace("spacing_m = 0.001", "spacing_m = 1e-7"),
            vec!["geometry.spacing_m = 0.0000001", "lattice would have"],
        ),
        (
            "a fourth box side",
            GOOD.replace("box_size_m = [0.01, 0.01, 0.004]", "box_size_m = [0.01, 0.01, 0.004, 0.1]"),
            vec!["geometry.box_size_m", "expected an array of 3 entries, found 4"],
        ),
        (
            "a projectile centre of four entries",
            format!(
                "{GOOD}[[sim.projectile]]\ncenter_m = [0.0, 0.0, 0.01, 0.0]\nvelocity_m_s = [0.0, 0.0, -1.0]\nradius_m = 0.001\nstiffness_pa = 1e7\n"
            ),
            vec!["sim.projectile[0].center_m", "expected an array of 3 entries, found 4"],
        ),
        (
            "no output folder",
            GOOD.replace("output_dir = \"out\"", "output_dir = \"\""),
            vec!["scene.output_dir = \"\"", "must name a folder"],
        ),
        (
            "scene named .",
            GOOD.replace("name = \"glass_plate\"", "name = \".\""),
            vec!["scene.name = \".\"", "not starting with '.'"],
        ),
        (
            "scene named ..",
            GOOD.replace("name = \"glass_plate\"", "name = \"..\""),
            vec!["scene.name = \"..\"", "not starting with '.'"],
        ),
        (
            "a scene name too long for a file name",
            GOOD.replace("name = \"glass_plate\"", &format!("name = \"{}\"", "a".repeat(201))),
            vec!["scene.name", "1 to 200"],
        ),
        (
            "a bulk modulus no bond force can hold",
            GOOD.replace("bulk_modulus_pa = 14.9e9", "bulk_modulus_pa = 1e300"),
            vec!["material.bulk_modulus_pa = 1e300", "beyond single precision"],
        ),
        (
            "a density no mass can hold",
            GOOD.replace("density_kg_m3 = 2200.0", "density_kg_m3 = 1e-40"),
            vec!["material.density_kg_m3 = 1e-40", "mass would be"],
        ),
        (
            "a fracture energy that makes bonds unbreakable",
            GOOD.replace("bulk_modulus_pa = 14.9e9", "bulk_modulus_pa = 14.9e9\nfracture_energy_j_m2 = 1e308"),
            vec!["material.fracture_energy_j_m2 = 1e308", "mean critical stretch would be"],
        ),
        (
            "a critical stretch below single precision",
            GOOD.replace("bulk_modulus_pa = 14.9e9", "bulk_modulus_pa = 14.9e9\ncritical_stretch = 1e-30"),
            vec!["material.critical_stretch = 1e-30", "at least 1e-6"],
        ),
        (
            "a scene too far from the origin for single precision",
            GOOD.replace(
                "horizon_factor = 3.0",
                "horizon_factor = 3.0\n[geometry.transform]\ntranslate_m = [1e30, 0.0, 0.0]",
            ),
            vec!["geometry.transform.translate_m = [1e30, 0, 0]", "place the scene nearer the origin"],
        ),
        (
            "an 8-bit environment map",
            format!("{GOOD}[render]\nenvironment = {:?}\n", mesh_path("../textures/rosewood_veneer1_diff_1k.jpg")),
            vec!["render.environment", "must be a Radiance .hdr or OpenEXR .exr map"],
        ),
        (
            "an environment intensity past single precision",
            format!("{GOOD}[render]\nenvironment_intensity = 1e38\n"),
            vec!["render.environment_intensity = 100000000000000000000000000000000000000", "from 0 to 1e6"],
        ),
        (
            "a box thinner than the spacing",
            GOOD.replace("box_size_m = [0.01, 0.01, 0.004]", "box_size_m = [0.01, 0.0005, 0.004]"),
            vec!["geometry.box_size_m = [0.01, 0.0005, 0.004]", "at least geometry.spacing_m = 0.001"],
        ),
    ];
    for (what, text, expected) in cases {
        let (dir, _) = scene(&text);
        let output = shatter(&["preprocess"], dir.path());
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{what}: exit code; stderr:\n{message}");
        for fragment in expected {
            assert!(message.contains(fragment), "{what}: expected {fragment:?} in:\n{message}");
        }
        assert!(!message.contains("panicked"), "{what}: {message}");
        assert!(!dir.path().join("out/particles.shp").exists(), "{what}: nothing written");
    }
}

#[test]
fn worker_threads_are_capped() {
    let (dir, _) = scene(GOOD);
    for threads in ["0", "100000", "many"] {
        let output = shatter(&["sim", "--threads", threads], dir.path());
        assert_eq!(output.status.code(), Some(2), "--threads {threads}: {}", stderr(&output));
        assert!(stderr(&output).contains("from 1 to 1024"), "--threads {threads}: {}", stderr(&output));
    }
}

#[test]
fn a_missing_config_file_is_exit_2() {
    let dir = tempfile::tempdir().expect("tempdir");
    let output = shatter(&["preprocess", "--config", "nowhere.toml"], dir.path());
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("nowhere.toml: cannot read the config file"), "{}", stderr(&output));
}

#[test]
fn preprocess_writes_a_file_inspect_can_read() {
    let (dir, _) = scene(GOOD);
    let output = shatter(&["preprocess"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let file = dir.path().join("out/particles.shp");
    assert!(file.is_file());

    let output = shatter(&["inspect", file.to_str().expect("utf-8 path"), "--json"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let summary: serde_json::Value = serde_json::from_slice(&output.stdout).expect("JSON");
    assert_eq!(summary["kind"], "particles");
    assert_eq!(summary["particles"], 10 * 10 * 4);
    assert_eq!(summary["element_type"], "cube");
    // four layers: a particle in the second sees offsets dz = -1 ..= 2 of the 122
    assert_eq!(summary["bonds_per_particle"]["max"], 99);
    for key in ["bonds", "lambda_m", "delta_m", "total_volume_m3", "total_mass_kg", "adjacency_edges"] {
        assert!(summary[key].is_number(), "{key} missing from {summary}");
    }
    for key in ["min", "max", "mean"] {
        assert!(summary["bonds_per_particle"][key].is_number());
    }
    assert!((summary["total_volume_m3"].as_f64().expect("number") - 400e-9).abs() < 1e-12);
    assert_eq!(summary["adjacency_edges"], 9 * 10 * 4 * 2 + 10 * 10 * 3);

    let text = shatter(&["inspect", file.to_str().expect("utf-8 path")], dir.path());
    let text = String::from_utf8_lossy(&text.stdout).into_owned();
    assert!(text.contains("particles            400") && text.contains("\"cube\""), "{text}");
}

#[test]
fn inspect_into_a_pipe_closed_early_exits_quietly() {
    // as `shatter inspect FILE | head -1`: the reader is gone before the summary is written
    let (dir, _) = scene(GOOD);
    assert!(shatter(&["preprocess"], dir.path()).status.success());
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_shatter"))
        .args(["inspect", "out/particles.shp"])
        .current_dir(dir.path())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("shatter runs");
    drop(child.stdout.take());
    let output = child.wait_with_output().expect("shatter ends");
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(!stderr(&output).contains("panicked"), "{}", stderr(&output));
}

#[test]
fn a_failed_run_keeps_the_good_output_and_corruption_is_reported() {
    let (dir, config) = scene(GOOD);
    assert!(shatter(&["preprocess"], dir.path()).status.success());
    let file = dir.path().join("out/particles.shp");
    let good = std::fs::read(&file).expect("read");

    std::fs::write(&config, GOOD.replace("source = \"box\"", &format!("source = {:?}", mesh_path("../PROVENANCE.md"))))
        .expect("write");
    let output = shatter(&["preprocess"], dir.path());
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert_eq!(std::fs::read(&file).expect("read"), good, "the good file is untouched");
    std::fs::write(&config, GOOD.replace("bulk_modulus_pa = 14.9e9", "bulk_modulus_pa = 1e300")).expect("write");
    let output = shatter(&["preprocess"], dir.path());
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert_eq!(std::fs::read(&file).expect("read"), good, "the good file is untouched");

    let mut corrupted = good.clone();
    let middle = corrupted.len() / 2;
    corrupted[middle] ^= 0x10;
    let bad = dir.path().join("bad.shp");
    std::fs::write(&bad, &corrupted).expect("write");
    let output = shatter(&["inspect", "bad.shp"], dir.path());
    assert_eq!(output.status.code(), Some(1));
    assert!(stderr(&output).contains("bad.shp: corrupted: checksum mismatch"), "{}", stderr(&output));
    std::fs::write(&bad, &good[..good.len() - 100]).expect("write");
    let output = shatter(&["inspect", "bad.shp"], dir.path());
    assert!(stderr(&output).contains("truncated"), "{}", stderr(&output));
}

#[test]
fn every_sampler_fills_a_box() {
    for (sampler, element) in [("grid", "cube"), ("tet_shell", "tet"), ("voronoi", "trimtope")] {
        let (dir, _) =
            scene(&GOOD.replace("\"grid\"", &format!("{sampler:?}")).replace("spacing_m = 0.001", "spacing_m = 0.002"));
        let output = shatter(&["preprocess"], dir.path());
        assert!(output.status.success(), "{sampler}: {}", stderr(&output));
        let file = dir.path().join("out/particles.shp");
        let summary = shatter(&["inspect", file.to_str().expect("utf-8"), "--json"], dir.path());
        let summary: serde_json::Value = serde_json::from_slice(&summary.stdout).expect("json");
        assert_eq!(summary["element_type"], element, "{sampler}");
        let volume = summary["total_volume_m3"].as_f64().expect("volume");
        assert!(volume > 0.0 && volume <= 400e-9 * 1.001, "{sampler}: volume {volume}");
    }
}

#[test]
fn relative_mesh_paths_start_at_the_config_folder() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().expect("tempdir");
    let text = GOOD
        .replace("source = \"box\"", "source = \"../assets/meshes/spot_triangulated.obj\"")
        .replace("box_size_m = [0.01, 0.01, 0.004]\n", "")
        .replace("spacing_m = 0.001", "spacing_m = 0.05")
        .replace("output_dir = \"out\"", &format!("output_dir = {:?}", dir.path().join("out").display().to_string()));
    let config = root.join("target/spot-test-pipeline.toml");
    std::fs::create_dir_all(root.join("target")).expect("target folder");
    std::fs::write(&config, text).expect("write config");
    let output = shatter(&["preprocess", "--config", config.to_str().expect("utf-8")], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(String::from_utf8_lossy(&output.stdout).contains("mesh: 5856 triangles"));
    assert!(dir.path().join("out/particles.shp").is_file());
}

#[test]
fn a_stage_run_before_the_one_it_needs_is_exit_2_naming_that_stage() {
    let (dir, _) = scene(GOOD);
    // (command, what it asks for) in an empty output folder, then after preprocess
    let empty = [
        ("sim", "run `shatter preprocess` first"),
        ("post", "run `shatter preprocess` first"),
        ("render", "run `shatter preprocess` first"),
    ];
    let preprocessed = [("post", "run `shatter sim` first"), ("render", "run `shatter post` first")];
    for (stage, asks) in empty {
        let output = shatter(&[stage], dir.path());
        assert_eq!(output.status.code(), Some(2), "{stage}: {}", stderr(&output));
        assert!(
            stderr(&output).contains(asks) && stderr(&output).contains("particles.shp: missing"),
            "{stage}: {}",
            stderr(&output)
        );
    }
    assert!(shatter(&["preprocess"], dir.path()).status.success());
    for (stage, asks) in preprocessed {
        let output = shatter(&[stage], dir.path());
        assert_eq!(output.status.code(), Some(2), "{stage}: {}", stderr(&output));
        assert!(stderr(&output).contains(asks), "{stage}: {}", stderr(&output));
    }
}

#[test]
fn what_cannot_fit_in_memory_is_refused_before_it_is_allocated() {
    // (what, the scene, the command, a fragment of the message); under a 2 GiB address-space
    // limit, so that the outcome does not depend on the machine
    let cases = [
        (
            "a fine spacing",
            GOOD.replace("spacing_m = 0.001", "spacing_m = 0.00005"),
            "preprocess",
            "geometry.spacing_m and geometry.horizon_factor: preprocessing",
        ),
        (
            "a long weakened path",
            format!(
                "{GOOD}[[sim.weakened_path]]\nstart_m = [0.0, 0.0, 0.0]\ndirection = [1.0, 0.0, 0.0]\nsteps = 4000000000\nstep_length_m = 0.0001\nradius_m = 0.0005\nthreshold_factor = 0.5\n"
            ),
            "sim",
            "sim.weakened_path[].steps",
        ),
        (
            "a mesh filled finely",
            spot_scene().replace("spacing_m = 0.001", "spacing_m = 0.005"),
            "preprocess",
            "geometry.spacing_m and geometry.horizon_factor: sampling the mesh into about 5.746e6 cube particles",
        ),
        (
            "a tet shell sampled finely",
            spot_scene()
                .replace("sampler = \"grid\"", "sampler = \"tet_shell\"")
                .replace("spacing_m = 0.001", "spacing_m = 0.002"),
            "preprocess",
            "tet particles (tet_shell sampler) would take about",
        ),
        (
            "many Voronoi cells",
            spot_scene()
                .replace("sampler = \"grid\"", "sampler = \"voronoi\"")
                .replace("horizon_factor = 3.0", "horizon_factor = 3.0\n[geometry.voronoi]\nparticles = 100000000"),
            "preprocess",
            "geometry.voronoi.particles and geometry.horizon_factor: sampling the mesh into about 1.000e8 trimtope",
        ),
        (
            "a huge image",
            format!("{GOOD}[render]\nresolution = [16384, 16384]\nsamples_per_pixel = 4096\n"),
            "render",
            "and render.resolution: rendering 4.000e2 particles at 16384 x 16384 pixels",
        ),
    ];
    for (what, text, command, message) in cases {
        let (dir, _) = scene(&text);
        let script = format!("ulimit -v 2000000; exec {:?} {command}", env!("CARGO_BIN_EXE_shatter"));
        let output = Command::new("sh").args(["-c", &script]).current_dir(dir.path()).output().expect("sh runs");
        assert_eq!(output.status.code(), Some(2), "{what}: {}", stderr(&output));
        assert!(
            stderr(&output).contains(message) && stderr(&output).contains("of memory"),
            "{what}: {}",
            stderr(&output)
        );
        let run = Command::new("sh").args(["-c", &script.replace(command, "run")]).current_dir(dir.path()).output();
        let run = run.expect("sh runs");
        assert_eq!(run.status.code(), Some(2), "{what}, run: {}", stderr(&run));
        assert!(!dir.path().join("out/particles.shp").exists(), "{what}: refused before anything was written");
    }
    let output = shatter(&["preprocess", "--config", "/dev/zero"], Path::new("."));
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("/dev/zero: cannot read the config file: the file is over"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn later_stages_refuse_a_particle_file_too_large_for_memory() {
    // 26,625 cubes filling the spot mesh: a 35 MB particle file whose simulation needs about 200
    // MiB and whose render about 250 MiB, under a 450 MB address-space limit that leaves about 100
    // MiB after the (debug) process's own libraries and its threads' heap arenas
    let text = spot_scene().replace("spacing_m = 0.001", "spacing_m = 0.03");
    let (dir, _) = scene(&format!("{text}[sim]\nframes = 2\nsteps_per_frame = 2\n"));
    assert!(shatter(&["preprocess"], dir.path()).status.success());
    for (command, message) in [
        ("sim", "geometry.spacing_m and geometry.horizon_factor: simulating 2.662e4 particles would take about"),
        ("render", "geometry.spacing_m and render.resolution: rendering 2.662e4 particles at 960 x 540 pixels"),
    ] {
        let script = format!("ulimit -v 450000; exec {:?} {command}", env!("CARGO_BIN_EXE_shatter"));
        let output = Command::new("sh").args(["-c", &script]).current_dir(dir.path()).output().expect("sh runs");
        assert_eq!(output.status.code(), Some(2), "{command}: {}", stderr(&output));
        assert!(stderr(&output).contains(message), "{command}: {}", stderr(&output));
        assert!(stderr(&output).contains("raise geometry.spacing_m"), "{command}: {}", stderr(&output));
    }
    assert!(!dir.path().join("out/frames").exists() && !dir.path().join("out/render").exists());
}

#[test]
fn more_shards_than_particles_is_exit_2() {
    let (dir, _) = scene(&format!("{GOOD}[sim]\nframes = 2\nsteps_per_frame = 2\n[sim.shards]\ncount = 100000\n"));
    let output = shatter(&["run", "--until", "sim"], dir.path());
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("sim.shards.count = 100000: more shards than the particle file's 400 particles"),
        "{}",
        stderr(&output)
    );
}
