//! A fixture set folder (DESIGN.md): background.png, templates/, frames/, truth.json.

use std::path::{Path, PathBuf};

use image::GrayImage;

use crate::engine::{load_silhouettes, NamedSilhouette};
use crate::io::{list_files, load_gray, InputError};

/// The files of a fixture set.
#[derive(Debug, Clone)]
pub struct FixtureSet {
    /// The set's folder.
    pub root: PathBuf,
    /// `background.png`, when the set has an empty shot (otherwise the platform is estimated
    /// from each frame).
    pub background: Option<PathBuf>,
    /// Extra captures of the empty platform (`backgrounds/*.png`), learned with the background.
    pub backgrounds: Vec<PathBuf>,
    /// `templates/`.
    pub templates: PathBuf,
    /// `frames/*.png`, sorted.
    pub frames: Vec<PathBuf>,
    /// `truth.json`, when present.
    pub truth: Option<PathBuf>,
}

impl FixtureSet {
    /// Opens a set folder.
    ///
    /// # Errors
    /// The folder or its frames folder are missing; `background.png` or `truth.json` is there
    /// but is a directory.
    pub fn open(root: &Path) -> Result<Self, InputError> {
        if root.is_file() {
            return Err(InputError::new(
                root,
                "is a file, not a fixture set folder (for single frames use --background BG --templates DIR FRAME…)",
            ));
        }
        if !root.is_dir() {
            return Err(InputError::new(root, "not a fixture set folder (no such folder)"));
        }
        let background = optional_file(root, "background.png")?;
        let bg_dir = root.join("backgrounds");
        let backgrounds = if bg_dir.is_dir() && background.is_some() {
            list_files(&bg_dir, &["png"])?
        } else {
            Vec::new()
        };
        let frames = list_files(&root.join("frames"), &["png"])?;
        let truth = optional_file(root, "truth.json")?;
        Ok(FixtureSet {
            root: root.to_path_buf(),
            background,
            backgrounds,
            templates: root.join("templates"),
            frames,
            truth,
        })
    }

    /// The background frames: `background.png` then `backgrounds/*.png` (none without an
    /// empty shot).
    ///
    /// # Errors
    /// One cannot be read, or they differ in size.
    pub fn load_backgrounds(&self) -> Result<Vec<GrayImage>, InputError> {
        load_background_frames(self.background.iter().chain(&self.backgrounds))
    }

    /// `vorl.toml`: the set's own parameters, when present.
    ///
    /// # Errors
    /// `vorl.toml` is there but is a directory (or another non-file).
    pub fn config(&self) -> Result<Option<PathBuf>, InputError> {
        optional_file(&self.root, "vorl.toml")
    }

    /// The template silhouettes.
    ///
    /// # Errors
    /// As [`load_silhouettes`].
    pub fn load_templates(&self) -> Result<Vec<NamedSilhouette>, InputError> {
        load_silhouettes(&self.templates)
    }
}

/// `root/name` when it is a file, `None` when nothing of that name is there.
///
/// # Errors
/// Something of that name is there but is not a file (a directory): it is not silently ignored.
pub fn optional_file(root: &Path, name: &str) -> Result<Option<PathBuf>, InputError> {
    let p = root.join(name);
    if p.is_file() {
        Ok(Some(p))
    } else if p.exists() {
        let what = if p.is_dir() {
            "a directory"
        } else {
            "not a regular file"
        };
        Err(InputError::new(p, format!("is {what}, not a file")))
    } else {
        Ok(None)
    }
}

/// Loads background frames, all of one size (a conversion to 8-bit gray is noted on stderr).
///
/// # Errors
/// A file cannot be read or its size differs from the first's.
pub fn load_background_frames<'a>(paths: impl IntoIterator<Item = &'a PathBuf>) -> Result<Vec<GrayImage>, InputError> {
    let mut out: Vec<GrayImage> = Vec::new();
    for p in paths {
        let loaded = load_gray(p)?;
        if let Some(n) = &loaded.note {
            eprintln!("note: {}: {n}", p.display());
        }
        let img = loaded.image;
        if let Some(first) = out.first() {
            if first.dimensions() != img.dimensions() {
                return Err(InputError::new(
                    p,
                    format!(
                        "background is {}×{} but the first background is {}×{}",
                        img.width(),
                        img.height(),
                        first.width(),
                        first.height()
                    ),
                ));
            }
        }
        out.push(img);
    }
    Ok(out)
}
