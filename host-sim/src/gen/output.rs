//! Writing the set: folders, PNG files and JSON files, errors naming the file.

use std::path::Path;

use image::GrayImage;
use serde::Serialize;

use super::GenError;

/// Creates a folder and its parents.
pub(crate) fn create_dir(dir: &Path) -> Result<(), GenError> {
    std::fs::create_dir_all(dir).map_err(|source| GenError::Io {
        path: dir.to_path_buf(),
        source,
    })
}

/// Writes an 8-bit gray PNG.
pub(crate) fn write_png(path: &Path, img: &GrayImage) -> Result<(), GenError> {
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|source| GenError::Image {
            path: path.to_path_buf(),
            source,
        })
}

/// Writes a value as pretty JSON with a final newline.
pub(crate) fn write_json(path: &Path, value: &impl Serialize) -> Result<(), GenError> {
    let mut text = serde_json::to_string_pretty(value).map_err(|source| GenError::Json {
        path: path.to_path_buf(),
        source,
    })?;
    text.push('\n');
    std::fs::write(path, text).map_err(|source| GenError::Io {
        path: path.to_path_buf(),
        source,
    })
}
