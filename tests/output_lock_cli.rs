//! One writer per output folder: a second writing command fails at once (exit code 1) naming the
//! folder and the holder's process id, readers are never blocked, a killed holder leaves no
//! stale lock, and two runs started together end with the outputs of one uninterrupted run.

use crate::support;

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use shatter_core::OutputLayout;
use shatter_core::output_lock::{Access, OutputLock};
use support::{folder_files, shatter};

const CONFIG: &str = r#"
[scene]
name = "locked"
output_dir = "out"
seed = 3
[geometry]
source = "box"
box_size_m = [0.016, 0.016, 0.004]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
[sim]
frames = 6
steps_per_frame = 2000
gravity_m_s2 = [0.0, 0.0, 0.0]
[[sim.projectile]]
center_m = [0.0, 0.0, 0.0067]
velocity_m_s = [0.0, 0.0, -150.0]
radius_m = 0.003
stiffness_pa = 3e7
"#;

fn spawn(args: &[&str], dir: &Path) -> Child {
    Command::new(env!("CARGO_BIN_EXE_shatter"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start shatter")
}

fn scene() -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("pipeline.toml"), CONFIG).expect("write config");
    dir
}

fn layout(dir: &Path) -> OutputLayout {
    OutputLayout::new(dir.join("out"), "locked")
}

#[test]
fn every_writing_command_is_refused_while_another_holds_the_folder() {
    let dir = scene();
    assert!(shatter(&["run", "--until", "preprocess"], dir.path()).status.success());
    let particles = std::fs::read(layout(dir.path()).particles()).expect("particles");

    let held = OutputLock::acquire(&layout(dir.path()), Access::Exclusive).expect("the test holds the folder");
    let holder = format!("pid {}", std::process::id());
    for args in [&["preprocess"][..], &["sim"], &["post"], &["render"], &["run"]] {
        let output = shatter(args, dir.path());
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(&holder) && stderr.contains("out: another shatter process"), "{args:?}: {stderr}");
    }
    // readers need no lock
    let particles_path = layout(dir.path()).particles();
    let inspect = shatter(&["inspect", particles_path.to_str().expect("utf-8 path")], dir.path());
    assert!(inspect.status.success(), "{}", String::from_utf8_lossy(&inspect.stderr));
    assert_eq!(std::fs::read(&particles_path).expect("particles"), particles, "the refused commands wrote nothing");

    drop(held);
    let output = shatter(&["run", "--until", "preprocess"], dir.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
}

#[test]
fn renders_of_frame_chunks_share_the_folder_and_keep_writers_out() {
    let dir = scene();
    assert!(shatter(&["run", "--until", "post"], dir.path()).status.success());
    // a render of other frames holds the folder, as a farm's chunk would
    let render = OutputLock::acquire(&layout(dir.path()), Access::Shared).expect("a render holds the folder");
    let output = shatter(&["render", "--frames", "1-2"], dir.path());
    assert!(output.status.success(), "a render beside it: {}", String::from_utf8_lossy(&output.stderr));
    for args in [&["sim"][..], &["post"], &["run"]] {
        let output = shatter(args, dir.path());
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{args:?} beside a render: {stderr}");
        assert!(stderr.contains("renders sharing the folder"), "{args:?}: {stderr}");
    }
    drop(render);
}

#[test]
fn a_killed_holder_leaves_no_stale_lock() {
    let dir = scene();
    let mut child = spawn(&["run", "--until", "sim"], dir.path());
    let lock = layout(dir.path()).lock();
    let started = Instant::now();
    while std::fs::read_to_string(&lock).map_or(true, |text| text != format!("pid {}\n", child.id())) {
        assert!(started.elapsed() < Duration::from_secs(60), "the run never took the lock");
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().expect("SIGKILL");
    child.wait().expect("reap");
    let output = shatter(&["run", "--until", "sim"], dir.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
}

#[test]
fn two_runs_started_together_end_as_one_uninterrupted_run() {
    let reference = scene();
    let output = shatter(&["run", "--until", "sim"], reference.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let expected = folder_files(&layout(reference.path()).frames_dir());

    let mut overlapped = 0;
    for trial in 0..20 {
        let dir = scene();
        let started = Instant::now();
        let mut first = spawn(&["run", "--until", "sim"], dir.path());
        std::thread::sleep(Duration::from_millis(500).saturating_sub(started.elapsed()));
        let first_done_before = first.try_wait().expect("poll").is_some();
        let second = spawn(&["run", "--until", "sim"], dir.path()).wait_with_output().expect("second run");
        let first = first.wait_with_output().expect("first run");
        assert!(first.status.success(), "trial {trial}: {}", String::from_utf8_lossy(&first.stderr));
        if !first_done_before {
            let stderr = String::from_utf8_lossy(&second.stderr);
            // the first run held the folder the whole time the second looked at it
            if second.status.code() == Some(1) {
                assert!(stderr.contains("another shatter process"), "trial {trial}: {stderr}");
                overlapped += 1;
            } else {
                assert!(second.status.success(), "trial {trial}: {stderr}");
            }
        }
        assert!(
            folder_files(&layout(dir.path()).frames_dir()) == expected,
            "trial {trial}: the outputs differ from an uninterrupted run's"
        );
    }
    assert!(overlapped >= 10, "only {overlapped} of 20 trials overlapped: make the scene slower");
}
