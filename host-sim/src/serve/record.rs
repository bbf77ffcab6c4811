//! `vorl serve --record DIR`: every frame and its result written as a fixture set that `vorl
//! detect`, `eval` and `check` replay. Frames are `frames/r000001.png` and on (a replay that
//! loops would repeat file names); `truth.json` holds each frame's result as served (the
//! predictions, so `vorl eval DIR` measures agreement with the live run), rewritten every
//! [`FLUSH_EVERY`] frames and at the end; templates, `background.png`, `backgrounds/` and
//! `vorl.toml` are those in force at the end.

use std::path::{Path, PathBuf};

use image::GrayImage;

use crate::config::Config;
use crate::truth::{FramesJson, PartJson};

/// `truth.json` is rewritten after this many frames (and at the end).
pub const FLUSH_EVERY: usize = 10;

/// A recording in progress.
pub struct Recorder {
    dir: PathBuf,
    truth: FramesJson,
    count: usize,
    set: PathBuf,
}

impl Recorder {
    /// Starts a recording into `dir` (created; it must not hold frames already).
    ///
    /// # Errors
    /// The folder cannot be created, or already holds a recording.
    pub fn start(dir: &Path, set: &Path) -> Result<Self, String> {
        let frames = dir.join("frames");
        if frames.is_dir()
            && std::fs::read_dir(&frames)
                .map(|mut d| d.next().is_some())
                .unwrap_or(false)
        {
            return Err(format!(
                "--record {}: holds frames already; give a new folder",
                dir.display()
            ));
        }
        std::fs::create_dir_all(&frames).map_err(|e| format!("{}: cannot create folder: {e}", frames.display()))?;
        Ok(Recorder {
            dir: dir.to_path_buf(),
            truth: FramesJson::default(),
            count: 0,
            set: set.to_path_buf(),
        })
    }

    /// Adds a frame and its result.
    ///
    /// # Errors
    /// A file cannot be written.
    pub fn add(&mut self, image: &GrayImage, parts: &[PartJson]) -> Result<(), String> {
        self.count += 1;
        let name = format!("r{:06}.png", self.count);
        let path = self.dir.join("frames").join(&name);
        image
            .save(&path)
            .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
        let parts = parts
            .iter()
            .cloned()
            .map(|mut p| {
                // Robot coordinates are not the set's: a replay adds them again with --calibration.
                p.extra.remove("robot");
                p.extra.remove("robot_note");
                p
            })
            .collect();
        self.truth.frames.insert(name, parts);
        if self.count % FLUSH_EVERY == 0 {
            self.write_truth()?;
        }
        Ok(())
    }

    fn write_truth(&self) -> Result<(), String> {
        let path = self.dir.join("truth.json");
        let tmp = self.dir.join("truth.json.tmp");
        let text = serde_json::to_string_pretty(&self.truth).map_err(|e| e.to_string())?;
        std::fs::write(&tmp, text + "\n").map_err(|e| format!("{}: cannot write: {e}", tmp.display()))?;
        std::fs::rename(&tmp, &path).map_err(|e| format!("{}: cannot write: {e}", path.display()))
    }

    /// Writes `truth.json`, the templates, the background captures and `vorl.toml`; prints
    /// what was recorded.
    ///
    /// # Errors
    /// A file cannot be written.
    pub fn finish(self, templates: &Path, config: &Config, background: Option<&Path>) -> Result<(), String> {
        self.write_truth()?;
        super::worker::copy_tree(templates, &self.dir.join("templates"))?;
        if let Some(bg) = background {
            let to = self.dir.join("background.png");
            std::fs::copy(bg, &to).map_err(|e| format!("{}: cannot copy: {e}", bg.display()))?;
            let more = self.set.join("backgrounds");
            if more.is_dir() {
                super::worker::copy_tree(&more, &self.dir.join("backgrounds"))?;
            }
        }
        super::worker::write_config(&self.dir.join("vorl.toml"), config)?;
        println!("recorded {} frame(s) to {}", self.count, self.dir.display());
        Ok(())
    }
}
