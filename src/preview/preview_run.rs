//! One preview run: `shatter run --until rigid` of the preview's config, as a child process in a
//! folder of its own under the preview's scratch folder. An edit kills it and starts the next
//! (a killed run leaves nothing another reads: each run has its own folder, removed when it is
//! replaced).

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Instant, SystemTime};

use shatter_core::{OutputLayout, PipelineConfig};

use super::preview_config::PreviewScene;
use super::run_folder::RunFolder;

/// How a run stands.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RunStatus {
    /// Still running.
    Running,
    /// Done: every stage up to the follow-through ran.
    Finished,
    /// Ended with an error: the run log's last lines.
    Failed(String),
}

/// A preview run and its folder.
#[derive(Debug)]
pub struct PreviewRun {
    /// Counts the runs of this preview: the page asks for a generation's frames.
    pub generation: u64,
    /// The spacing it runs at, metres.
    pub spacing_m: f64,
    /// The output folder it writes.
    pub folder: RunFolder,
    /// When it started.
    started: Instant,
    /// The same, on the clock files are stamped by.
    started_at: SystemTime,
    /// Seconds from its start to its end, once it has ended.
    seconds_to_end: Option<f64>,
    /// Seconds from its start to the first frame with a broken bond, once one has been seen.
    pub first_break_s: Option<f64>,
    dir: PathBuf,
    child: Child,
    status: RunStatus,
}

impl PreviewRun {
    /// Starts run `generation` of `scene` at `spacing_m` (a Voronoi scene: `target` cells) in
    /// `scratch`/run-N.
    pub fn start(
        scene: &PreviewScene,
        (spacing_m, target): (f64, u64),
        scratch: &Path,
        generation: u64,
    ) -> Result<PreviewRun, String> {
        let dir = scratch.join(format!("run-{generation}"));
        std::fs::create_dir_all(&dir).map_err(|error| format!("{}: {error}", dir.display()))?;
        let config_path = dir.join("pipeline.toml");
        let text = scene.preview_text(spacing_m, target, &dir.join("out"))?;
        std::fs::write(&config_path, &text).map_err(|error| format!("{}: {error}", config_path.display()))?;
        let config = PipelineConfig::from_toml_str(&text, &config_path).map_err(|error| error.to_string())?;
        let log = std::fs::File::create(dir.join("run.log")).map_err(|error| format!("{}: {error}", dir.display()))?;
        let log_err = log.try_clone().map_err(|error| error.to_string())?;
        let exe = std::env::current_exe().map_err(|error| format!("cannot find the shatter binary: {error}"))?;
        let child = Command::new(exe)
            .args(["run", "--until", "rigid", "--config"])
            .arg(&config_path)
            .stdin(Stdio::null())
            .stdout(log)
            .stderr(log_err)
            .spawn()
            .map_err(|error| format!("cannot start the preview run: {error}"))?;
        Ok(PreviewRun {
            generation,
            spacing_m,
            folder: RunFolder::new(OutputLayout::of(&config), config.material.density_kg_m3),
            started: Instant::now(),
            started_at: SystemTime::now(),
            seconds_to_end: None,
            first_break_s: None,
            dir,
            child,
            status: RunStatus::Running,
        })
    }

    /// Seconds it has run (to its end, once it has ended).
    pub fn seconds(&self) -> f64 {
        self.seconds_to_end.unwrap_or_else(|| self.started.elapsed().as_secs_f64())
    }

    /// Notes the bonds broken so far (`broken`, per frame from frame 2): once any are, how long
    /// the run took to write the first frame that shows them.
    pub fn saw_broken_bonds(&mut self, broken: &[u64]) {
        if self.first_break_s.is_some() {
            return;
        }
        let Some(first) = broken.iter().position(|&count| count > 0) else {
            return;
        };
        let written = self.folder.frame_written(first as u32 + 2);
        self.first_break_s = written.and_then(|at| at.duration_since(self.started_at).ok()).map(|d| d.as_secs_f64());
    }

    /// How it stands now.
    pub fn status(&mut self) -> RunStatus {
        if self.status == RunStatus::Running
            && let Ok(Some(exit)) = self.child.try_wait()
        {
            self.seconds_to_end = Some(self.started.elapsed().as_secs_f64());
            self.status = if exit.success() {
                RunStatus::Finished
            } else {
                let log = std::fs::read_to_string(self.dir.join("run.log")).unwrap_or_default();
                let tail: Vec<&str> = log.lines().filter(|line| !line.starts_with('[')).collect();
                RunStatus::Failed(tail[tail.len().saturating_sub(4)..].join("\n"))
            };
        }
        self.status.clone()
    }
}

impl Drop for PreviewRun {
    /// Stops the run and removes its folder.
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}
