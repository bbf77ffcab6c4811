//! Writing the set: folders, PNG files and JSON files (`teach.json` among them), errors naming
//! the file.

use std::path::Path;

use image::GrayImage;
use serde::Serialize;
use serde_json::json;

use super::raster::Pose;
use super::scene::clearance;
use super::shapes::{inside, ring_moments, PartSpec, P};
use super::GenError;
use crate::truth::{FramesJson, PartJson};

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

/// Least distance of a teach point moved off the centroid from the part's border, px.
pub(crate) const TEACH_CLEARANCE_PX: f64 = 3.0;

/// Where a part of `spec` at `pose` is taught from (image px): its centroid when that lies
/// inside its outer border (holes included, as `vorl teach --at` takes it), else the point of
/// the part nearest the centroid at least [`TEACH_CLEARANCE_PX`] inside it (an L bracket's
/// centroid lies off the part), on a grid of about 200 steps across the part.
pub(crate) fn teach_point(spec: &PartSpec, pose: &Pose) -> P {
    let outer: Vec<Vec<P>> = spec
        .rings()
        .iter()
        .filter(|r| ring_moments(r).0 > 0.0)
        .cloned()
        .collect();
    if outer.iter().any(|r| inside(std::slice::from_ref(r), 0.0, 0.0)) {
        return pose.apply([0.0, 0.0]);
    }
    let b = spec.bbox_mm();
    let step = spec.radius_mm() / 100.0;
    let margin = TEACH_CLEARANCE_PX / pose.k;
    let mut best: Option<(f64, P, bool)> = None;
    let mut y = b[1];
    while y <= b[3] {
        let mut x = b[0];
        while x <= b[2] {
            if spec.coverage(x, y) {
                let deep = clearance(spec.rings(), [x, y]) >= margin;
                let d = x.hypot(y);
                // A deep point beats any shallow one; among equals, the nearer.
                if best.is_none_or(|(bd, _, bdeep)| (deep, -d) > (bdeep, -bd)) {
                    best = Some((d, [x, y], deep));
                }
            }
            x += step;
        }
        y += step;
    }
    pose.apply(best.map_or([0.0, 0.0], |(_, q, _)| q))
}

/// The `teach.json` of a set (DESIGN.md, "Contracts"): for each class of `classes`, the first
/// frame of `truth` (in name order, which is frame order) in which a part of that class lies
/// whole — not cut by the frame's edge, not touching another part, not upside down — as
/// `{"frame": "frames/<name>", "x", "y"}` with the point `point` gives for the part (its truth
/// centroid, or a point on the part: [`teach_point`]). Classes that never lie whole are left out.
pub(crate) fn teach(classes: &[String], truth: &FramesJson, point: impl Fn(&PartJson) -> P) -> serde_json::Value {
    let mut out = serde_json::Map::new();
    for class in classes {
        let first = truth.frames.iter().find_map(|(name, parts)| {
            parts
                .iter()
                .find(|p| {
                    p.class.as_deref() == Some(class.as_str())
                        && p.partial != Some(true)
                        && p.touching != Some(true)
                        && p.flipped != Some(true)
                })
                .map(|p| (name, p))
        });
        if let Some((name, p)) = first {
            let [x, y] = point(p);
            out.insert(
                class.clone(),
                json!({ "frame": format!("frames/{name}"), "x": x, "y": y }),
            );
        }
    }
    serde_json::Value::Object(out)
}

/// Writes [`teach`] of the set to `path`.
pub(crate) fn write_teach(
    path: &Path,
    classes: &[String],
    truth: &FramesJson,
    point: impl Fn(&PartJson) -> P,
) -> Result<(), GenError> {
    write_json(path, &teach(classes, truth, point))
}
