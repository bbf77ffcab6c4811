//! Stereo sets on the host: both views through the core, parts paired, the disparity refined,
//! depth and the 3-D position in the left camera's frame (`DESIGN.md`, "Stereo" and
//! "Contracts").
//!
//! A stereo set is a fixture set with `camera.json` or `frames/left_*.png`. Each pair
//! `frames/left_<name>.png` / `frames/right_<name>.png` is run through two engines with the same
//! templates and parameters: the left one learns `background_left.png` (or `background.png`)
//! and `backgrounds/*.png`, the right one `background_right.png` and `backgrounds_right/*.png`.
//! The parts are paired by [`vorl_core::location::stereo::pair_parts`] (class, row, positive disparity);
//! the centroid disparity seeds [`vorl_core::location::stereo::refine_disparity`], which aligns the left
//! part's border onto the right image along the row; the refined disparity gives the depth and
//! the 3-D point by [`StereoRig`].
//!
//! Each part is reported under `<name>.png` with its position in the left image and, in the
//! part's `extra` fields: `disparity_px` (refined), `disparity_centroid_px` (the paper's:
//! `x_left − x_right` of the paired positions, the seed), `disparity_polygon_px` (the same for
//! the border polygons' area centroids), `disparity_refined` (false when the seed was kept, with
//! `disparity_note` saying why), `disparity_rms_px`, `disparity_points` and
//! `disparity_iterations` (the fit's residual, points used and Gauss–Newton steps), then `z_mm` and
//! `position_mm` `[X, Y, Z]`. A part found in one view only is still reported, with no depth and
//! `"stereo": "<reason>"`; one found only in the right image also carries `"view": "right"` and
//! its position in the right image.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use image::GrayImage;
use serde::Deserialize;
use serde_json::json;
use vorl_core::location::stereo::{
    pair_parts, refine_disparity, DisparityFit, DisparityParams, DisparityStatus, PairOutcome, PairParams, StereoPart,
    StereoRig, Unpaired,
};
use vorl_core::pose::refine::Difference;
use vorl_core::Frame;

use crate::cli::calibrate::Calibration;
use crate::cli::params::ParamArgs;
use crate::engine::{frame_notes, load_silhouettes, Engine, FrameResult};
use crate::eval::{score, EvalReport};
use crate::io::{file_name, list_files};
use crate::run::{run_frame, to_json};
use crate::set::load_background_frames;
use crate::truth::{FramesJson, PartJson};

/// Whether the folder is a stereo set: it holds `camera.json` or `frames/left_*.png`.
pub fn is_stereo_set(root: &Path) -> bool {
    root.join("camera.json").is_file()
        || list_files(&root.join("frames"), &["png"])
            .map(|f| f.iter().any(|p| file_name(p).starts_with("left_")))
            .unwrap_or(false)
}

/// `camera.json` as written by `vorl gen --variant stereo` (other fields are ignored).
#[derive(Debug, Deserialize)]
struct CameraJson {
    f_px: f64,
    baseline_mm: f64,
    cx: f64,
    cy: f64,
}

/// Reads `camera.json` into a rig.
///
/// # Errors
/// One line naming the file: missing, unreadable, not JSON of that shape, or a focal length or
/// baseline that is zero, negative or not finite.
pub fn load_camera(path: &Path) -> Result<StereoRig, String> {
    let text =
        std::fs::read_to_string(path).map_err(|e| format!("{}: {}", path.display(), crate::io::io_problem(&e)))?;
    let c: CameraJson = serde_json::from_str(&text).map_err(|e| {
        format!(
            "{}: does not parse as camera JSON {{\"f_px\", \"baseline_mm\", \"cx\", \"cy\"}}: {e}",
            path.display()
        )
    })?;
    for (name, v) in [("f_px", c.f_px), ("baseline_mm", c.baseline_mm)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(format!(
                "{}: {name} is {v}; it must be a positive number",
                path.display()
            ));
        }
    }
    StereoRig::new(c.f_px as f32, c.baseline_mm as f32, c.cx as f32, c.cy as f32)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// One stereo frame of a set: its name (`<name>.png`, the key of truth and predictions) and
/// the two files, either of which may be missing.
#[derive(Debug, Clone, PartialEq)]
pub struct StereoPair {
    /// `<name>.png`.
    pub name: String,
    /// `frames/left_<name>.png`, when present.
    pub left: Option<PathBuf>,
    /// `frames/right_<name>.png`, when present.
    pub right: Option<PathBuf>,
}

/// The pairs of `frames/`, sorted by name; other PNG files there are returned apart.
///
/// # Errors
/// The frames folder is missing or unreadable.
pub fn list_pairs(root: &Path) -> Result<(Vec<StereoPair>, Vec<PathBuf>), String> {
    let files = list_files(&root.join("frames"), &["png"]).map_err(|e| e.to_string())?;
    let mut pairs: BTreeMap<String, StereoPair> = BTreeMap::new();
    let mut other = Vec::new();
    for p in files {
        let f = file_name(&p);
        let (name, left) = if let Some(n) = f.strip_prefix("left_") {
            (n.to_string(), true)
        } else if let Some(n) = f.strip_prefix("right_") {
            (n.to_string(), false)
        } else {
            other.push(p);
            continue;
        };
        let e = pairs.entry(name.clone()).or_insert(StereoPair {
            name,
            left: None,
            right: None,
        });
        if left {
            e.left = Some(p);
        } else {
            e.right = Some(p);
        }
    }
    Ok((pairs.into_values().collect(), other))
}

/// Both engines, the frame pairs and the camera of a stereo set.
pub struct StereoInputs {
    /// The set's folder.
    pub root: PathBuf,
    /// The left view's engine.
    pub left: Engine,
    /// The right view's engine (same templates and parameters, its own background).
    pub right: Engine,
    /// The frame pairs.
    pub pairs: Vec<StereoPair>,
    /// PNG files in `frames/` that belong to no pair.
    pub other_frames: Vec<PathBuf>,
    /// The rig, or why `camera.json` cannot be used (then parts get no depth).
    pub camera: Result<StereoRig, String>,
    /// How the disparity is refined.
    pub disparity: DisparityParams,
}

/// The background files of one view: the first that exists of `mains`, then `extra_dir/*.png`.
fn view_backgrounds(root: &Path, mains: &[&str], extra_dir: &str) -> Result<Vec<GrayImage>, String> {
    let main = mains
        .iter()
        .map(|m| root.join(m))
        .find(|p| p.is_file())
        .ok_or_else(|| {
            format!(
                "{}: no such file (a stereo set needs each view's empty platform)",
                root.join(mains[0]).display()
            )
        })?;
    let dir = root.join(extra_dir);
    let extra = if dir.is_dir() {
        list_files(&dir, &["png"]).map_err(|e| e.to_string())?
    } else {
        Vec::new()
    };
    load_background_frames(std::iter::once(&main).chain(&extra)).map_err(|e| e.to_string())
}

impl StereoInputs {
    /// Opens a stereo set: templates, both backgrounds, the pairs and the camera.
    ///
    /// # Errors
    /// A background or template that cannot be used, or no frames folder. A bad `camera.json`
    /// is not an error here (see [`StereoInputs::camera`]).
    pub fn open(root: &Path, params: &ParamArgs) -> Result<StereoInputs, String> {
        if !root.is_dir() {
            return Err(format!("{}: not a fixture set folder (no such folder)", root.display()));
        }
        let params = params.params()?;
        let mut left = Engine::new(params)?;
        let mut right = Engine::new(params)?;
        left.learn_background(&view_backgrounds(
            root,
            &["background_left.png", "background.png"],
            "backgrounds",
        )?)?;
        right.learn_background(&view_backgrounds(root, &["background_right.png"], "backgrounds_right")?)?;
        let templates = load_silhouettes(&root.join("templates")).map_err(|e| e.to_string())?;
        for t in &templates {
            if let Some(n) = &t.note {
                eprintln!("note: {n}");
            }
        }
        for n in left.add_silhouettes(&templates)? {
            eprintln!("note: {n}");
        }
        right.add_silhouettes(&templates)?;
        let (pairs, other_frames) = list_pairs(root)?;
        Ok(StereoInputs {
            root: root.to_path_buf(),
            left,
            right,
            pairs,
            other_frames,
            camera: load_camera(&root.join("camera.json")),
            disparity: DisparityParams::DEFAULT,
        })
    }

    /// Runs one pair: both views, pairing, refined disparity, depth.
    ///
    /// # Errors
    /// One line naming the file: a missing or unreadable frame, a frame whose size differs from
    /// its background's, or a right frame whose size differs from the left one's.
    pub fn run_pair(&mut self, pair: &StereoPair) -> Result<StereoFrame, String> {
        let frames = self.root.join("frames");
        let left_path = pair
            .left
            .clone()
            .unwrap_or_else(|| frames.join(format!("left_{}", pair.name)));
        let right_path = pair
            .right
            .clone()
            .unwrap_or_else(|| frames.join(format!("right_{}", pair.name)));
        match (&pair.left, &pair.right) {
            (None, _) => {
                return Err(format!(
                    "{}: no such file (the left view of {})",
                    left_path.display(),
                    right_path.display()
                ))
            }
            (_, None) => {
                return Err(format!(
                    "{}: no such file (the right view of {})",
                    right_path.display(),
                    left_path.display()
                ))
            }
            _ => {}
        }
        let (left, left_image, left_note) = run_frame(&mut self.left, &left_path)?;
        let loaded = crate::io::load_gray(&right_path).map_err(|e| e.to_string())?;
        if loaded.image.dimensions() != left_image.dimensions() {
            return Err(format!(
                "{}: frame is {}×{} but the left frame {} is {}×{}",
                right_path.display(),
                loaded.image.width(),
                loaded.image.height(),
                left_path.display(),
                left_image.width(),
                left_image.height()
            ));
        }
        let (right, right_image, right_note) = run_frame(&mut self.right, &right_path)?;
        let notes = [left_note, right_note].into_iter().flatten().collect();
        let parts = self.combine(&left, &left_image, &right, &right_image)?;
        Ok(StereoFrame {
            seconds: left.seconds + right.seconds,
            parts,
            left,
            right,
            left_image,
            right_image,
            notes,
        })
    }

    /// Pairs the parts of both views and reports each, with depth where paired.
    fn combine(
        &self,
        left: &FrameResult,
        left_image: &GrayImage,
        right: &FrameResult,
        right_image: &GrayImage,
    ) -> Result<Vec<PartJson>, String> {
        let (w, h) = (left_image.width() as usize, left_image.height() as usize);
        let lp: Vec<StereoPart> = left.detections.iter().map(|d| StereoPart::from(&d.core)).collect();
        let rp: Vec<StereoPart> = right.detections.iter().map(|d| StereoPart::from(&d.core)).collect();
        let rules = PairParams {
            max_disparity_px: w as f32,
            ..PairParams::DEFAULT
        };
        let mut outcomes = vec![PairOutcome::Unpaired(Unpaired::NoRightParts); lp.len()];
        pair_parts(&lp, &rp, &rules, &mut outcomes).map_err(|e| format!("pairing the views: {e}"))?;
        let alpha = self.left.params().alpha();
        let (bl, br) = match (self.left.background(), self.right.background()) {
            (Some(l), Some(r)) => (l.plane(), r.plane()),
            _ => return Err("no background set".into()),
        };
        let fl = Frame::new_checked(left_image.as_raw().as_slice(), w, h).map_err(|e| e.to_string())?;
        let fr = Frame::new_checked(right_image.as_raw().as_slice(), w, h).map_err(|e| e.to_string())?;
        let dl = Difference::new(&fl, bl, alpha);
        let dr = Difference::new(&fr, br, alpha);
        let mut parts = to_json(left);
        let right_json = to_json(right);
        let mut right_used = vec![false; rp.len()];
        for ((part, det), outcome) in parts.iter_mut().zip(&left.detections).zip(&outcomes) {
            let x = &mut part.extra;
            let (j, seed) = match *outcome {
                PairOutcome::Paired { right, disparity } => (right, disparity),
                PairOutcome::Unpaired(why) => {
                    x.insert(
                        "stereo".into(),
                        json!(format!("left image only: {}", unpaired_text(why))),
                    );
                    continue;
                }
            };
            if let Some(u) = right_used.get_mut(j) {
                *u = true;
            }
            x.insert("disparity_centroid_px".into(), json!(round6(seed)));
            if let Some(r) = right.detections.get(j) {
                x.insert(
                    "disparity_polygon_px".into(),
                    json!(round6(det.core.polygon_centroid[0] - r.core.polygon_centroid[0])),
                );
            }
            let outline: Vec<[f32; 2]> = det.border.iter().map(|&(a, b)| [f32::from(a), f32::from(b)]).collect();
            let fit = refine_disparity(&dl, &dr, &outline, seed, &self.disparity).unwrap_or(DisparityFit {
                disparity: seed,
                seed,
                status: DisparityStatus::NotFinite,
                points_used: 0,
                rms_px: f32::INFINITY,
                iterations: 0,
            });
            let d = fit.disparity;
            x.insert("disparity_px".into(), json!(round6(d)));
            x.insert("disparity_refined".into(), json!(fit.is_refined()));
            if !fit.is_refined() {
                x.insert(
                    "disparity_note".into(),
                    json!(format!("centroid disparity kept: {}", status_text(fit.status))),
                );
            }
            if fit.rms_px.is_finite() {
                x.insert("disparity_rms_px".into(), json!(round6(fit.rms_px)));
            }
            x.insert("disparity_points".into(), json!(fit.points_used));
            x.insert("disparity_iterations".into(), json!(fit.iterations));
            match &self.camera {
                Ok(rig) => match rig.point(det.core.x, det.core.y, d) {
                    Ok([px, py, pz]) => {
                        x.insert("z_mm".into(), json!(round6(pz)));
                        x.insert("position_mm".into(), json!([round6(px), round6(py), round6(pz)]));
                    }
                    Err(e) => {
                        x.insert("stereo".into(), json!(format!("no depth: {e}")));
                    }
                },
                Err(_) => {
                    x.insert("stereo".into(), json!("no depth: camera.json cannot be used"));
                }
            }
        }
        for (j, mut part) in right_json.into_iter().enumerate() {
            if right_used.get(j).copied().unwrap_or(true) {
                continue;
            }
            part.extra.insert("view".into(), json!("right"));
            part.extra.insert(
                "stereo".into(),
                json!("right image only: no partner in the left image (position in the right image)"),
            );
            parts.push(part);
        }
        Ok(parts)
    }
}

/// What one stereo pair gave.
pub struct StereoFrame {
    /// The parts, as in `vorl detect --json`.
    pub parts: Vec<PartJson>,
    /// The left view's result.
    pub left: FrameResult,
    /// The right view's result.
    pub right: FrameResult,
    /// The left frame.
    pub left_image: GrayImage,
    /// The right frame.
    pub right_image: GrayImage,
    /// Time spent in the core for both views (not the disparity), seconds.
    pub seconds: f64,
    /// Conversion notes of the two frames.
    pub notes: Vec<String>,
}

fn round6(v: f32) -> f64 {
    (f64::from(v) * 1e6).round() / 1e6
}

/// Why a left part has no partner, in words.
pub fn unpaired_text(u: Unpaired) -> &'static str {
    match u {
        Unpaired::NonFinite => "its position is not finite",
        Unpaired::NoRightParts => "no part was found in the right image",
        Unpaired::ClassMismatch => "no part of the same class in the right image",
        Unpaired::RowMismatch => "no part of the same class on the same row in the right image",
        Unpaired::NonPositiveDisparity => "parts of the same class on the same row only at zero or negative disparity",
        Unpaired::DisparityTooLarge => "parts of the same class on the same row only beyond the largest disparity",
        Unpaired::Taken => "its partner in the right image fits another part better",
        _ => "no partner in the right image",
    }
}

/// Why the refinement kept the seed, in words.
pub fn status_text(s: DisparityStatus) -> String {
    match s {
        DisparityStatus::Refined => "refined".into(),
        DisparityStatus::TooFewPoints { usable, needed } => {
            format!("{usable} border points have an edge in both views, {needed} are needed")
        }
        DisparityStatus::ShiftTooLarge { shift } => format!("the fit moved {shift:.2} px from the seed"),
        DisparityStatus::NotFinite => "the fit did not converge".into(),
        _ => "not refined".into(),
    }
}

/// What a stereo run over a set gave.
pub struct StereoRun {
    /// The predictions by `<name>.png`.
    pub frames: FramesJson,
    /// Pairs that could not be processed (reported as errors).
    pub failed: usize,
    /// Pairs processed.
    pub done: usize,
    /// Core time, seconds, over the processed pairs.
    pub seconds: f64,
    /// Problems with the set that are not one frame's: the camera file.
    pub setup_errors: Vec<String>,
}

impl StereoInputs {
    /// Runs every pair, in name order, mapping the parts into the robot's frame when a
    /// calibration is given, and calls `each` with the name and the result (or the one-line
    /// error) of each pair. Files in `frames/` that belong to no pair are noted on stderr. A bad
    /// `camera.json` is in [`StereoRun::setup_errors`] (the caller reports it).
    ///
    /// # Errors
    /// The set holds no pair at all.
    pub fn run_all(
        &mut self,
        calibration: Option<&Calibration>,
        mut each: impl FnMut(&str, &Result<StereoFrame, String>),
    ) -> Result<StereoRun, String> {
        let mut run = StereoRun {
            frames: FramesJson::default(),
            failed: 0,
            done: 0,
            seconds: 0.0,
            setup_errors: Vec::new(),
        };
        if let Err(e) = &self.camera {
            run.setup_errors.push(e.clone());
        }
        for p in &self.other_frames {
            eprintln!(
                "note: {}: not part of a stereo pair (left_<name>.png, right_<name>.png): skipped",
                p.display()
            );
        }
        if self.pairs.is_empty() {
            return Err(format!(
                "{}: no stereo frames (frames/left_<name>.png and frames/right_<name>.png)",
                self.root.join("frames").display()
            ));
        }
        for pair in self.pairs.clone() {
            let mut result = self.run_pair(&pair);
            if let (Ok(frame), Some(c)) = (&mut result, calibration) {
                c.apply_all(&mut frame.parts);
            }
            each(&pair.name, &result);
            match result {
                Ok(frame) => {
                    run.done += 1;
                    run.seconds += frame.seconds;
                    run.frames.frames.insert(pair.name.clone(), frame.parts);
                }
                Err(_) => run.failed += 1,
            }
        }
        Ok(run)
    }
}

/// `vorl detect` on a stereo set.
///
/// # Errors
/// Set-up problems, as [`StereoInputs::open`]; frame problems and a bad `camera.json` are
/// reported on stderr and make the exit code 1.
pub fn run_detect(
    root: &Path,
    params: &ParamArgs,
    overlay: Option<&Path>,
    json: bool,
    calibration: Option<&Calibration>,
) -> Result<ExitCode, String> {
    if let Some(dir) = overlay {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create folder: {e}", dir.display()))?;
    }
    let mut inputs = StereoInputs::open(root, params)?;
    if let Err(e) = &inputs.camera {
        eprintln!("error: {e} (parts get no depth)");
    }
    let mut overlay_errors = 0usize;
    let run = inputs.run_all(calibration, |name, result| {
        let frame = match result {
            Ok(f) => f,
            Err(e) => {
                eprintln!("error: {e}");
                return;
            }
        };
        for n in &frame.notes {
            eprintln!("note: {n}");
        }
        for (view, r) in [("left", &frame.left), ("right", &frame.right)] {
            for n in frame_notes(r) {
                eprintln!("note: {view}_{name}: {n}");
            }
        }
        if let Some(dir) = overlay {
            for (view, r, img) in [
                ("left", &frame.left, &frame.left_image),
                ("right", &frame.right, &frame.right_image),
            ] {
                let target = dir.join(format!("{view}_{name}"));
                if let Err(e) = crate::overlay::draw(img, r).save(&target) {
                    eprintln!("error: {}: cannot write overlay: {e}", target.display());
                    overlay_errors += 1;
                }
            }
        }
        if !json {
            print_human(name, frame);
        }
    })?;
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&run.frames).map_err(|e| e.to_string())?
        );
    }
    let failed = run.failed + overlay_errors;
    if failed > 0 {
        eprintln!("{failed} frame(s) failed");
    }
    Ok(if failed > 0 || !run.setup_errors.is_empty() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

fn print_human(name: &str, frame: &StereoFrame) {
    let paired = frame
        .parts
        .iter()
        .filter(|p| p.extra.contains_key("disparity_px"))
        .count();
    println!(
        "{name}: {} part(s) left, {} right, {paired} paired, in {:.1} ms",
        frame.left.detections.len(),
        frame.right.detections.len(),
        frame.seconds * 1e3
    );
    for p in &frame.parts {
        let class = p.class.as_deref().unwrap_or("unknown");
        let num = |k: &str| p.extra.get(k).and_then(|v| v.as_f64());
        let mut line = format!("  {class:<14} x {:8.2}  y {:8.2}  angle {:7.2}°", p.x, p.y, p.angle_deg);
        if let Some(d) = num("disparity_px") {
            line += &format!(
                "  d {d:.3} px (centroid {:.3})",
                num("disparity_centroid_px").unwrap_or(f64::NAN)
            );
        }
        if let Some(pos) = p.extra.get("position_mm").and_then(|v| v.as_array()) {
            let v: Vec<f64> = pos.iter().filter_map(|v| v.as_f64()).collect();
            if let [x, y, z] = v[..] {
                line += &format!("  X {x:.2} Y {y:.2} Z {z:.2} mm");
            }
        }
        if let Some(r) = crate::cli::calibrate::robot_text(p) {
            line += &format!("  {r}");
        }
        if let Some(s) = p.extra.get("stereo").and_then(|v| v.as_str()) {
            line += &format!("  [{s}]");
        }
        println!("{line}");
    }
}

/// `vorl eval` on a stereo set: detect on every pair, then score against `truth.json` (keyed
/// by `<name>.png`, positions in the left image), with the disparity and depth errors.
///
/// # Errors
/// The set, its truth, backgrounds or templates cannot be read.
pub fn evaluate(set: &Path, params: &ParamArgs, overlay: Option<&Path>) -> Result<EvalReport, String> {
    let truth_path = set.join("truth.json");
    if !truth_path.is_file() {
        return Err(format!(
            "{}: no such file (eval needs the set's truth)",
            truth_path.display()
        ));
    }
    let truth = FramesJson::load(&truth_path)?;
    let mut inputs = StereoInputs::open(set, params)?;
    if let Err(e) = &inputs.camera {
        eprintln!("error: {e} (parts get no depth)");
    }
    if let Some(dir) = overlay {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create folder: {e}", dir.display()))?;
    }
    let bar = crate::io::progress(inputs.pairs.len(), "eval", "stereo pairs");
    let run = inputs.run_all(None, |name, result| {
        match result {
            Ok(frame) => {
                for n in &frame.notes {
                    bar.suspend(|| eprintln!("note: {n}"));
                }
                if let Some(dir) = overlay {
                    for (view, r, img) in [
                        ("left", &frame.left, &frame.left_image),
                        ("right", &frame.right, &frame.right_image),
                    ] {
                        let target = dir.join(format!("{view}_{name}"));
                        if let Err(e) = crate::overlay::draw(img, r).save(&target) {
                            bar.suspend(|| eprintln!("error: {}: cannot write overlay: {e}", target.display()));
                        }
                    }
                }
            }
            Err(e) => bar.suspend(|| eprintln!("error: {e}")),
        }
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    let mut scored_truth = truth.clone();
    scored_truth.frames.retain(|k, _| run.frames.frames.contains_key(k));
    let missing: Vec<&String> = truth
        .frames
        .keys()
        .filter(|k| !inputs.pairs.iter().any(|p| &p.name == *k))
        .collect();
    if let Some(first) = missing.first() {
        eprintln!(
            "warning: {} frame(s) in truth.json have no stereo pair in frames/ (first: {first})",
            missing.len()
        );
    }
    let scores = score(&scored_truth, &run.frames);
    Ok(EvalReport {
        set: set.display().to_string(),
        failed_frames: run.failed,
        ms_per_frame: if run.done > 0 {
            run.seconds * 1e3 / run.done as f64
        } else {
            f64::NAN
        },
        recall: scores.recall(),
        precision: scores.precision(),
        classification: scores.classification(),
        unknown_rejection: scores.rejection(),
        scores,
        platform_estimated: 0,
        platform_kept: 0,
        setup_errors: run.setup_errors,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> PathBuf {
        let p = std::env::temp_dir().join(format!("vorl-stereo-unit-{}-{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(p.join("frames")).expect("mkdir");
        p
    }

    #[test]
    fn camera_file_checks() {
        let d = scratch("camera");
        let f = d.join("camera.json");
        std::fs::write(&f, r#"{"f_px": 800, "baseline_mm": 60, "cx": 319.5, "cy": 239.5}"#).unwrap();
        let rig = load_camera(&f).unwrap();
        assert_eq!(rig.f_px(), 800.0);
        for (text, needle) in [
            (r#"{"f_px": 0, "baseline_mm": 60, "cx": 1, "cy": 1}"#, "f_px is 0"),
            (
                r#"{"f_px": 800, "baseline_mm": -5, "cx": 1, "cy": 1}"#,
                "baseline_mm is -5",
            ),
            (r#"{"f_px": 800}"#, "does not parse"),
            ("not json", "does not parse"),
        ] {
            std::fs::write(&f, text).unwrap();
            let e = load_camera(&f).unwrap_err();
            assert!(e.contains("camera.json") && e.contains(needle), "{e}");
            assert!(!e.contains('\n'), "{e}");
        }
        let e = load_camera(&d.join("missing.json")).unwrap_err();
        assert!(e.contains("missing.json: no such file"), "{e}");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn pairs_by_name() {
        let d = scratch("pairs");
        for f in ["left_a.png", "right_a.png", "left_b.png", "right_c.png", "x.png"] {
            std::fs::write(d.join("frames").join(f), b"").unwrap();
        }
        assert!(is_stereo_set(&d));
        let (pairs, other) = list_pairs(&d).unwrap();
        let names: Vec<(&str, bool, bool)> = pairs
            .iter()
            .map(|p| (p.name.as_str(), p.left.is_some(), p.right.is_some()))
            .collect();
        assert_eq!(
            names,
            [("a.png", true, true), ("b.png", true, false), ("c.png", false, true)]
        );
        assert_eq!(other.len(), 1);
        let _ = std::fs::remove_dir_all(&d);
    }
}
