//! One frame file through the engine, and its parts in the `truth.json` shape: what `vorl
//! detect`, `vorl eval` and their stereo runs ([`crate::cli::stereo`]) share.

use std::path::Path;

use crate::engine::{Engine, FrameResult};
use crate::io::load_gray;
use crate::truth::PartJson;

/// Loads and runs one frame; a one-line error naming the file on failure.
///
/// # Errors
/// Unreadable frame, or a size that differs from the background's.
pub fn run_frame(engine: &mut Engine, path: &Path) -> Result<(FrameResult, image::GrayImage, Option<String>), String> {
    let loaded = load_gray(path).map_err(|e| e.to_string())?;
    if let Some(bg) = engine.background().filter(|_| !engine.auto_background()) {
        let (w, h) = (loaded.image.width() as usize, loaded.image.height() as usize);
        if (w, h) != (bg.width(), bg.height()) {
            return Err(format!(
                "{}: frame is {w}×{h} but the background is {}×{}",
                path.display(),
                bg.width(),
                bg.height()
            ));
        }
    }
    let note = loaded.note.map(|n| format!("{}: {n}", path.display()));
    let result = engine
        .detect(&loaded.image)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok((result, loaded.image, note))
}

/// The prediction JSON of one frame's result.
pub fn to_json(result: &FrameResult) -> Vec<PartJson> {
    result
        .detections
        .iter()
        .map(|d| {
            let mut extra = std::collections::BTreeMap::new();
            extra.insert(
                "angle_paper_deg".into(),
                serde_json::json!(round6(d.core.angle_paper_deg as f64)),
            );
            extra.insert(
                "angle_dp_deg".into(),
                serde_json::json!(round6(d.core.angle_dp_deg as f64)),
            );
            extra.insert(
                "polygon_centroid".into(),
                serde_json::json!([
                    round6(d.core.polygon_centroid[0] as f64),
                    round6(d.core.polygon_centroid[1] as f64)
                ]),
            );
            if d.core.verify.is_finite() {
                extra.insert("verify_px".into(), serde_json::json!(round6(d.core.verify as f64)));
                extra.insert("scale".into(), serde_json::json!(round6(d.core.scale as f64)));
                extra.insert(
                    "verify_limit".into(),
                    serde_json::json!(round6(d.core.verify_limit as f64)),
                );
            }
            if d.core.holes.expected > 0 {
                extra.insert(
                    "holes".into(),
                    serde_json::json!({"expected": d.core.holes.expected, "found": d.core.holes.found}),
                );
            }
            if let Some(b) = &d.best_class {
                extra.insert("best_class".into(), serde_json::json!(b));
            }
            extra.insert("searches".into(), serde_json::json!(d.core.searches));
            if d.core.touching || d.core.visible_fraction < 1.0 {
                extra.insert(
                    "visible_fraction".into(),
                    serde_json::json!(round6(d.core.visible_fraction as f64)),
                );
            }
            if d.core.position_from_pose {
                extra.insert("position".into(), serde_json::json!("pose"));
            }
            PartJson {
                class: d.class.clone(),
                x: round6(d.core.x as f64),
                y: round6(d.core.y as f64),
                angle_deg: round6(d.core.angle_deg as f64),
                symmetry: None,
                score: d.core.score.is_finite().then_some(round6(d.core.score as f64)),
                partial: d.core.touches_edge.then_some(true),
                flipped: (d.core.flipped && d.class.is_some()).then_some(true),
                touching: d.core.touching.then_some(true),
                extra,
            }
        })
        .collect()
}

fn round6(v: f64) -> f64 {
    (v * 1e6).round() / 1e6
}
