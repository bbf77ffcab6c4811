//! Reading images and fixture sets, with one-line errors that name the file.

use std::fmt;
use std::path::{Path, PathBuf};

use image::{DynamicImage, GrayImage};

/// A problem with one input file: the path and what is wrong, printable as one line.
#[derive(Debug, Clone, PartialEq)]
pub struct InputError {
    /// The file.
    pub path: PathBuf,
    /// What is wrong with it.
    pub problem: String,
}

impl InputError {
    /// An error about `path`.
    pub fn new(path: impl Into<PathBuf>, problem: impl Into<String>) -> Self {
        InputError {
            path: path.into(),
            problem: problem.into(),
        }
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.problem)
    }
}

impl std::error::Error for InputError {}

/// An 8-bit gray image and, when it had to be converted, a note saying from what.
#[derive(Debug, Clone)]
pub struct LoadedImage {
    /// The pixels.
    pub image: GrayImage,
    /// `Some("converted from RGB8 to 8-bit gray")` and the like.
    pub note: Option<String>,
}

/// Loads an image file as 8-bit gray (PNG, GIF or BMP; the format is read from the content).
/// RGB, RGBA, 16-bit and gray-alpha images are converted, with a note.
///
/// # Errors
/// Missing or unreadable file, an unknown or unsupported format, a truncated or corrupt image —
/// each as an [`InputError`] naming the file.
pub fn load_gray(path: &Path) -> Result<LoadedImage, InputError> {
    let bytes = std::fs::read(path).map_err(|e| InputError::new(path, io_problem(&e)))?;
    if bytes.is_empty() {
        return Err(InputError::new(path, "empty file, not an image"));
    }
    let format = image::guess_format(&bytes)
        .map_err(|_| InputError::new(path, "not a PNG, GIF or BMP image (unrecognised content)"))?;
    let kind = format!("{format:?}").to_uppercase();
    let img = image::load_from_memory_with_format(&bytes, format).map_err(|e| {
        let what = match e {
            image::ImageError::Decoding(_) | image::ImageError::IoError(_) => {
                format!("corrupt or truncated {kind} image ({e})")
            }
            image::ImageError::Unsupported(_) => format!("unsupported {kind} image ({e})"),
            _ => format!("cannot decode {kind} image ({e})"),
        };
        InputError::new(path, what)
    })?;
    Ok(to_gray(img))
}

fn to_gray(img: DynamicImage) -> LoadedImage {
    let kind = match &img {
        DynamicImage::ImageLuma8(_) => None,
        DynamicImage::ImageLuma16(_) => Some("16-bit gray"),
        DynamicImage::ImageLumaA8(_) => Some("8-bit gray with alpha"),
        DynamicImage::ImageLumaA16(_) => Some("16-bit gray with alpha"),
        DynamicImage::ImageRgb8(_) => Some("8-bit RGB"),
        DynamicImage::ImageRgba8(_) => Some("8-bit RGBA"),
        DynamicImage::ImageRgb16(_) => Some("16-bit RGB"),
        DynamicImage::ImageRgba16(_) => Some("16-bit RGBA"),
        _ => Some("another pixel format"),
    };
    match (kind, img) {
        (None, DynamicImage::ImageLuma8(g)) => LoadedImage { image: g, note: None },
        (kind, img) => LoadedImage {
            image: img.to_luma8(),
            note: Some(format!(
                "converted from {} to 8-bit gray",
                kind.unwrap_or("another format")
            )),
        },
    }
}

/// A friendlier text for an I/O error.
pub fn io_problem(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".to_string(),
        std::io::ErrorKind::PermissionDenied => "permission denied".to_string(),
        _ => format!("cannot read ({e})"),
    }
}

/// Files in `dir` whose extension is one of `exts` (lower case), sorted by name.
///
/// # Errors
/// The folder is missing or unreadable.
pub fn list_files(dir: &Path, exts: &[&str]) -> Result<Vec<PathBuf>, InputError> {
    let rd = std::fs::read_dir(dir).map_err(|e| InputError::new(dir, io_problem(&e)))?;
    let mut out: Vec<PathBuf> = rd
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.is_file())
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| exts.iter().any(|x| x.eq_ignore_ascii_case(e)))
        })
        .collect();
    out.sort();
    Ok(out)
}

/// The file name of `path` as a string (`"?"` when it has none).
pub fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "?".into())
}

/// The file stem of `path` as a string.
pub fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "?".into())
}
