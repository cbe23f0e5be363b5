//! `shatter run` on a farm: with stderr going to a file, every stage writes plain progress lines,
//! one at each frame and at least one every `SHATTER_LOG_EVERY_S` (10 s unless set; 0.25 s
//! here, so that a short run shows the promise), each stamped with the seconds since the start,
//! and nothing else: no driver noise from the GPU probe.

use std::process::{Command, Stdio};

use support::SMALL_PLATE;

use crate::support;

#[test]
fn a_run_logged_to_a_file_writes_a_line_per_frame_and_at_least_every_interval() {
    let dir = tempfile::tempdir().expect("tempdir");
    let text = format!(
        "{SMALL_PLATE}[sim]\nframes = 6\nsteps_per_frame = 4000\n[render]\nbackend = \"cpu\"\nresolution = [96, 64]\n\
         samples_per_pixel = 2\n"
    );
    std::fs::write(dir.path().join("pipeline.toml"), text).expect("config");
    let log = std::fs::File::create(dir.path().join("run.log")).expect("log file");
    let status = Command::new(env!("CARGO_BIN_EXE_shatter"))
        .arg("run")
        .env("SHATTER_LOG_EVERY_S", "0.25")
        // as on a farm node without a display: the GPU probe must not print driver noise
        .env_remove("XDG_RUNTIME_DIR")
        .current_dir(dir.path())
        .stdout(Stdio::null())
        .stderr(log)
        .status()
        .expect("shatter runs");
    assert!(status.success());
    let log = std::fs::read_to_string(dir.path().join("run.log")).expect("log");
    let stamps: Vec<f64> =
        log.lines().filter_map(|line| line.strip_prefix('[')?.split_once(" s]")?.0.trim().parse().ok()).collect();
    assert!(stamps.len() > 10, "{log}");
    let largest_gap = stamps.windows(2).map(|pair| pair[1] - pair[0]).fold(0.0, f64::max);
    assert!(largest_gap <= 0.25 + 0.5, "a {largest_gap:.2} s gap between lines:\n{log}");
    let span = stamps.last().expect("lines") - stamps[0];
    assert!(span > 1.0, "the run outlasts several intervals ({span:.2} s), so the ticker is tested");
    for frame in 2..=6 {
        assert!(log.contains(&format!("frame {frame}/6,")), "a sim line for frame {frame}:\n{log}");
        assert!(log.contains(&format!("; frame {frame}\n")), "a render line for frame {frame}:\n{log}");
    }
    assert!(log.contains("sim: done in") && log.contains("render: done in"), "{log}");
    assert!(log.lines().all(|line| line.starts_with('[')), "every line is a progress line, no driver noise:\n{log}");
}

#[test]
fn every_stage_takes_threads_and_gives_the_same_bytes_on_any_count() {
    let text = format!(
        "{SMALL_PLATE}[sim]\nframes = 3\nsteps_per_frame = 20\n[render]\nbackend = \"cpu\"\nresolution = [48, 32]\n\
         samples_per_pixel = 2\n"
    );
    let outputs: Vec<_> = [["--threads", "1", "run"], ["run", "--threads", "2"]]
        .iter()
        .map(|args| {
            let dir = tempfile::tempdir().expect("tempdir");
            std::fs::write(dir.path().join("pipeline.toml"), &text).expect("config");
            let output = support::shatter(args, dir.path());
            assert!(output.status.success(), "{args:?}: {}", support::stderr(&output));
            // the checkpoint records which backend ran it, with its thread count
            support::tree_files(&dir.path().join("out"), &["shatter.lock", "stamps.json", "sim.checkpoint.shp"])
        })
        .collect();
    assert!(outputs[0].len() > 10 && outputs[0] == outputs[1], "one thread and two give the same files");
}

#[test]
fn inspect_reads_every_file_a_run_writes() {
    let dir = tempfile::tempdir().expect("tempdir");
    let text = format!(
        "{SMALL_PLATE}[sim]\nframes = 2\nsteps_per_frame = 10\n[render]\nbackend = \"cpu\"\nresolution = [32, 24]\n\
         samples_per_pixel = 1\n"
    );
    std::fs::write(dir.path().join("pipeline.toml"), text).expect("config");
    assert!(support::shatter(&["run"], dir.path()).status.success());
    // every file but the lock, the stamps and the PNG previews (which are for eyes, not tools)
    let files = support::tree_files(&dir.path().join("out"), &["shatter.lock", "stamps.json"]);
    let inspected: Vec<&String> = files.iter().map(|(name, _)| name).filter(|name| !name.ends_with(".png")).collect();
    assert!(inspected.len() >= 12, "{inspected:?}");
    for name in inspected {
        let path = dir.path().join("out").join(name);
        let output = support::shatter(&["inspect", &path.display().to_string()], dir.path());
        assert!(output.status.success(), "inspect {name}: {}", support::stderr(&output));
    }
}
