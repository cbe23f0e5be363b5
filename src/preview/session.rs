//! The preview's session: the scene as edited, and its current run.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::preview_config::{Edits, PreviewScene};
use super::preview_run::PreviewRun;
use super::resolution::Resolution;
use super::run_folder::RunFolder;
use shatter_core::OutputLayout;

/// The start of a preview's scratch folder's name, followed by its process id.
const SCRATCH_PREFIX: &str = "shatter-preview-";

/// The fewest and the most particles the page may ask a preview for.
const PARTICLES: std::ops::RangeInclusive<u64> = 500..=2_000_000;

/// An edit from the page: keys and values (JSON), and the particle count to aim at.
#[derive(Debug, Deserialize)]
pub struct EditRequest {
    /// Dotted keys and their new values; the keys not named keep their edited values.
    #[serde(default)]
    pub edits: serde_json::Map<String, serde_json::Value>,
    /// The particles to aim at (the scene's preview spacing follows).
    pub particles: Option<u64>,
}

/// The scene, its edits, and the run of them.
#[derive(Debug)]
pub struct Session {
    /// The scene's config file and its text as read at the start.
    scene_text: String,
    /// The edits so far.
    edits: Edits,
    /// The scene with them.
    pub scene: PreviewScene,
    /// Particles the preview aims at.
    pub target: u64,
    /// The current run, if one could start.
    pub run: Option<PreviewRun>,
    /// The scene's own output folder, offered for review (read, never written or locked).
    pub review: RunFolder,
    /// Why the last run could not start.
    pub error: Option<String>,
    /// The runs' folder (removed with the session).
    scratch: tempfile::TempDir,
    generations: u64,
    /// The spacing of the preview's resolution, found once per geometry and count (a mesh is
    /// read, a shell preprocessed on trial, once, not at every edit).
    resolution: Resolution,
}

impl Session {
    /// A session on the scene at `path`, starting its first run at `target` particles.
    pub fn start(path: PathBuf, target: u64) -> Result<Session, String> {
        let scene_text = std::fs::read_to_string(&path).map_err(|error| format!("{}: {error}", path.display()))?;
        let scene = PreviewScene::new(&path, &scene_text, &Edits::new())?;
        remove_abandoned_scratch();
        let scratch = tempfile::Builder::new()
            .prefix(&format!("{SCRATCH_PREFIX}{}-", std::process::id()))
            .tempdir()
            .map_err(|error| format!("cannot make the preview's scratch folder: {error}"))?;
        let review = RunFolder::new(OutputLayout::of(&scene.config), scene.config.material.density_kg_m3);
        let mut session = Session {
            review,
            scene_text,
            edits: Edits::new(),
            scene,
            target,
            run: None,
            error: None,
            scratch,
            generations: 0,
            resolution: Resolution::default(),
        };
        session.restart();
        Ok(session)
    }

    /// Applies `edit` if the scene takes it and restarts the run: the new run's generation, or
    /// the reason it was refused (the config check's message), the session left as it was.
    pub fn apply(&mut self, edit: EditRequest) -> Result<u64, String> {
        let mut edits = self.edits.clone();
        for (key, value) in edit.edits {
            let value = toml::Value::try_from(value).map_err(|error| format!("{key}: {error}"))?;
            edits.insert(key.clone(), self.scene.typed_like_scene(&key, value));
        }
        let target = edit.particles.unwrap_or(self.target);
        if !PARTICLES.contains(&target) {
            return Err(format!("particles: {target} is outside {} to {}", PARTICLES.start(), PARTICLES.end()));
        }
        let scene = PreviewScene::new(&self.scene.path, &self.scene_text, &edits)?;
        (self.edits, self.scene, self.target) = (edits, scene, target);
        self.restart();
        self.error.clone().map_or(Ok(self.generations), Err)
    }

    /// The scene's file as "Save" would write it, and the diff from what it holds now.
    pub fn save_preview(&self) -> Result<(String, String), String> {
        let saved = super::scene_file::saved_text(&self.scene_text, &self.edits)?;
        let label = self.scene.path.display().to_string();
        Ok((super::scene_file::diff(&label, &self.scene_text, &saved), saved))
    }

    /// Writes the edits into the scene's file (atomically; the edits are then the file's own).
    pub fn save(&mut self) -> Result<PathBuf, String> {
        let (_, saved) = self.save_preview()?;
        let path = self.scene.path.clone();
        shatter_core::atomic_file::write_atomically(&path, &[saved.as_bytes()])
            .map_err(|error| format!("{}: {error}", path.display()))?;
        (self.scene_text, self.edits) = (saved, Edits::new());
        Ok(path)
    }

    /// Stops the current run and starts the next.
    fn restart(&mut self) {
        self.run = None;
        self.generations += 1;
        let started = self.resolution.spacing_m(&self.scene, self.target).and_then(|spacing_m| {
            PreviewRun::start(&self.scene, (spacing_m, self.target), self.scratch.path(), self.generations)
        });
        match started {
            Ok(run) => (self.run, self.error) = (Some(run), None),
            Err(message) => self.error = Some(message),
        }
    }
}

/// Removes the scratch folders of previews that were killed (their process is gone; a preview
/// that ends normally removes its own). Only where /proc tells which processes live (Linux).
fn remove_abandoned_scratch() {
    if !Path::new("/proc/self").is_dir() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let pid = name.strip_prefix(SCRATCH_PREFIX).and_then(|rest| rest.split('-').next()?.parse::<u32>().ok());
        if let Some(pid) = pid
            && !Path::new(&format!("/proc/{pid}")).exists()
        {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}
