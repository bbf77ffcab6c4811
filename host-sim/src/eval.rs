//! Scoring predictions against truth (the `truth.json` contract).
//!
//! Parts are paired per frame greedily by centroid distance (closest pair first, at most
//! [`MATCH_RADIUS_PX`] apart). Then:
//! - detection recall: paired truth parts / truth parts; precision: paired predictions /
//!   predictions (parts cut by the frame border count only when paired, never against recall,
//!   and a prediction touching the frame's edge that pairs with nothing is left out);
//! - classification accuracy: paired known truth parts (not partial) whose class is right;
//! - unknown rejection: paired truth parts that are not templates and were called unknown;
//! - angle error: correctly classified known parts, taken modulo `360/symmetry` (symmetry 0 —
//!   a round part — has no angle and is left out);
//! - position error: every paired part not cut by the border.
//! - parts of a template class upside down (truth `"flipped": true`): their own recall and
//!   classification (an untaught part upside down counts with the unknown parts); and
//!   over every correctly classified part, whether the prediction's `flipped` (absent: false)
//!   is the truth's (absent: false) — reported when either side says a part is flipped.
//! - parts touching or lying over another (truth `"touching": true`), the parts that touch
//!   nothing in a set that has such parts, and parts cut by the frame's edge that show at
//!   least half their area (`"partial": true`, `visible_fraction` ≥ 0.5): each group's own
//!   recall, classification (of its known parts, unpaired ones counting as wrong), angle and
//!   position errors (a cut part's truth is the whole part's centroid, which a pose from the
//!   aligned template gives).
//! - stereo (truth with `disparity_px`): disparity error `|d − d_truth|` of the refined
//!   disparity (`disparity_px`), of the paper's centroid disparity (`disparity_centroid_px`)
//!   and of the border polygons' centroids (`disparity_polygon_px`), in px; depth error
//!   `|z − z_truth|` in mm and in % of `z_truth`; parts without depth are counted. Predictions
//!   found only in the right image (`"view": "right"`, positions in the right image) are not
//!   paired with the truth (positions in the left image) and are counted apart.

use serde::Serialize;

use crate::truth::{FramesJson, PartJson};

/// Furthest a prediction may lie from a truth part and still be paired with it, px.
pub const MATCH_RADIUS_PX: f64 = 15.0;

/// Median, 95th percentile and maximum of a list of errors.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Spread {
    /// Values.
    pub count: usize,
    /// Median.
    pub median: f64,
    /// 95th percentile (nearest rank).
    pub p95: f64,
    /// Maximum.
    pub max: f64,
}

impl Spread {
    /// Whether it holds no value.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The spread of `values` (all zero when empty).
    pub fn of(values: &[f64]) -> Spread {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return Spread::default();
        }
        v.sort_by(f64::total_cmp);
        let rank = |q: f64| v[((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
        Spread {
            count: v.len(),
            median: rank(0.5),
            p95: rank(0.95),
            max: v[v.len() - 1],
        }
    }
}

/// Counts and error spreads over a set.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Scores {
    /// Frames scored.
    pub frames: usize,
    /// Truth parts (not partial).
    pub truth_parts: usize,
    /// Predictions.
    pub predictions: usize,
    /// Truth parts paired with a prediction.
    pub detected: usize,
    /// Predictions paired with a truth part.
    pub true_predictions: usize,
    /// Known truth parts paired.
    pub known: usize,
    /// … of which classified right.
    pub known_correct: usize,
    /// Unknown truth parts paired.
    pub unknown: usize,
    /// … of which called unknown.
    pub unknown_rejected: usize,
    /// Angle errors of the reported angle, degrees.
    pub angle: Spread,
    /// Angle errors of the paper's estimator (eq. 6.4) where predictions carry it.
    pub angle_paper: Spread,
    /// Position errors, px.
    pub position: Spread,
    /// Stereo: error of the refined disparity (`disparity_px`), px.
    #[serde(skip_serializing_if = "Spread::is_empty")]
    pub disparity: Spread,
    /// Stereo: error of the paper's centroid disparity (`disparity_centroid_px`), px.
    #[serde(skip_serializing_if = "Spread::is_empty")]
    pub disparity_centroid: Spread,
    /// Stereo: error of the border polygons' centroid disparity (`disparity_polygon_px`), px.
    #[serde(skip_serializing_if = "Spread::is_empty")]
    pub disparity_polygon: Spread,
    /// Stereo: depth error (`z_mm`), mm.
    #[serde(skip_serializing_if = "Spread::is_empty")]
    pub depth_mm: Spread,
    /// Stereo: depth error in % of the true depth.
    #[serde(skip_serializing_if = "Spread::is_empty")]
    pub depth_pct: Spread,
    /// Stereo: paired truth parts (not partial) whose prediction has no depth.
    #[serde(skip_serializing_if = "is_zero")]
    pub stereo_without_depth: usize,
    /// Stereo: predictions found only in the right image (not scored).
    #[serde(skip_serializing_if = "is_zero")]
    pub right_only: usize,
    /// Truth parts of a template class lying upside down (not partial; an untaught part upside
    /// down counts with the unknown parts).
    #[serde(skip_serializing_if = "is_zero")]
    pub flipped: usize,
    /// … of which paired with a prediction.
    #[serde(skip_serializing_if = "is_zero")]
    pub flipped_detected: usize,
    /// … of which classified right.
    #[serde(skip_serializing_if = "is_zero")]
    pub flipped_correct: usize,
    /// Correctly classified parts whose side was judged: every one, when any truth or
    /// prediction of the set says `flipped` (else 0).
    #[serde(skip_serializing_if = "is_zero")]
    pub flip_judged: usize,
    /// … of which the prediction's `flipped` is the truth's.
    #[serde(skip_serializing_if = "is_zero")]
    pub flip_right: usize,
    /// Parts touching or lying over another (truth `"touching": true`, not partial).
    #[serde(skip_serializing_if = "Group::is_empty")]
    pub touching: Group,
    /// Parts that touch nothing, in a set that has touching parts.
    #[serde(skip_serializing_if = "Group::is_empty")]
    pub apart: Group,
    /// Parts cut by the frame's edge with at least half of their area visible (truth
    /// `"partial": true`, `visible_fraction` ≥ 0.5).
    #[serde(skip_serializing_if = "Group::is_empty")]
    pub cut_half: Group,
    /// Predictions from blobs the truth leaves unscored ([`is_unscored_blob`]): counted in
    /// neither recall nor precision.
    #[serde(skip_serializing_if = "is_zero")]
    pub unscored: usize,
    /// Confusions: (truth class, predicted class or "unknown", count).
    pub confusions: Vec<(String, String, usize)>,
}

/// Recall, classification, angle and position over one group of truth parts.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Group {
    /// Truth parts in the group.
    pub parts: usize,
    /// … paired with a prediction.
    pub detected: usize,
    /// … of them templates.
    pub known: usize,
    /// … of those, classified right.
    pub correct: usize,
    /// Angle error over those classified right (symmetry ≠ 0), degrees.
    pub angle: Spread,
    /// Position error over the paired parts, px.
    pub position: Spread,
    #[serde(skip)]
    angles: Vec<f64>,
    #[serde(skip)]
    positions: Vec<f64>,
}

impl Group {
    /// Whether the group has no part.
    pub fn is_empty(&self) -> bool {
        self.parts == 0
    }

    /// Recall of the group.
    pub fn recall(&self) -> f64 {
        ratio(self.detected, self.parts)
    }

    /// Classification of the group's known parts (unpaired ones count as wrong).
    pub fn classification(&self) -> f64 {
        ratio(self.correct, self.known)
    }

    fn add(&mut self, t: &PartJson, p: Option<&PartJson>) {
        self.parts += 1;
        self.known += t.class.is_some() as usize;
        let Some(p) = p else {
            return;
        };
        self.detected += 1;
        self.positions.push(((t.x - p.x).powi(2) + (t.y - p.y).powi(2)).sqrt());
        if let Some(tc) = &t.class {
            if p.class.as_deref() == Some(tc.as_str()) {
                self.correct += 1;
                let sym = t.symmetry.unwrap_or(1);
                if sym != 0 {
                    self.angles.push(angle_error(p.angle_deg, t.angle_deg, sym));
                }
            }
        }
    }

    fn finish(&mut self) {
        self.angle = Spread::of(&self.angles);
        self.position = Spread::of(&self.positions);
    }
}

impl Scores {
    /// Detection recall.
    pub fn recall(&self) -> f64 {
        ratio(self.detected, self.truth_parts)
    }
    /// Detection precision.
    pub fn precision(&self) -> f64 {
        ratio(self.true_predictions, self.predictions)
    }
    /// Classification accuracy over known parts.
    pub fn classification(&self) -> f64 {
        ratio(self.known_correct, self.known)
    }
    /// Unknown-rejection rate.
    pub fn rejection(&self) -> f64 {
        ratio(self.unknown_rejected, self.unknown)
    }
    /// Share of correctly classified parts whose side (upside down or not) was reported right.
    pub fn flip_accuracy(&self) -> f64 {
        ratio(self.flip_right, self.flip_judged)
    }
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        f64::NAN
    } else {
        a as f64 / b as f64
    }
}

/// Angle error modulo `360/symmetry` (symmetry 1 or missing: modulo 360), in `[0, period/2]`.
pub fn angle_error(pred: f64, truth: f64, symmetry: u32) -> f64 {
    let period = 360.0 / symmetry.max(1) as f64;
    let d = (pred - truth).rem_euclid(period);
    d.min(period - d)
}

/// Scores `pred` against `truth` over the frames present in both (frames missing from the
/// predictions count as frames with no detection).
pub fn score(truth: &FramesJson, pred: &FramesJson) -> Scores {
    let mut s = Scores::default();
    let mut angle = Vec::new();
    let mut angle_paper = Vec::new();
    let mut position = Vec::new();
    let (mut disparity, mut disparity_centroid, mut disparity_polygon) = (Vec::new(), Vec::new(), Vec::new());
    let (mut depth_mm, mut depth_pct) = (Vec::new(), Vec::new());
    let mut confusions: std::collections::BTreeMap<(String, String), usize> = Default::default();
    let empty = Vec::new();
    let flipped = |p: &PartJson| p.flipped == Some(true);
    // An untaught part upside down counts with the unknown parts.
    let known_flipped = |p: &PartJson| p.class.is_some() && flipped(p);
    let sides_reported = truth.frames.values().flatten().any(flipped) || pred.frames.values().flatten().any(flipped);
    for (name, truth_parts) in &truth.frames {
        let all = pred.frames.get(name).unwrap_or(&empty);
        let right_only = |p: &PartJson| p.extra.get("view").and_then(|v| v.as_str()) == Some("right");
        s.right_only += all.iter().filter(|p| right_only(p)).count();
        let kept: Vec<PartJson>;
        let preds = if all.iter().any(right_only) {
            kept = all.iter().filter(|p| !right_only(p)).cloned().collect();
            &kept
        } else {
            all
        };
        s.frames += 1;
        // Blobs the truth leaves unscored are taken out before pairing ([`is_unscored_blob`]).
        let (blobs, scored): (Vec<&PartJson>, Vec<&PartJson>) = truth_parts.iter().partition(|t| is_unscored_blob(t));
        let scored: Vec<PartJson> = scored.into_iter().cloned().collect();
        let truth_parts = &scored;
        let pairs = pair(truth_parts, preds);
        let paired = |pi: usize| pairs.iter().any(|&(_, q)| q == pi);
        // A prediction touching the frame's edge that pairs with nothing is a cut part whose
        // visible piece lies far from the full part's truth centroid: not counted against
        // precision. Nor is one that pairs with nothing and comes from a blob the truth leaves
        // unscored.
        let in_blob = |p: &PartJson| blobs.iter().any(|b| from_blob(p, b));
        s.unscored += preds
            .iter()
            .enumerate()
            .filter(|&(pi, p)| !paired(pi) && in_blob(p))
            .count();
        s.predictions += preds
            .iter()
            .enumerate()
            .filter(|&(pi, p)| paired(pi) || (p.partial != Some(true) && !in_blob(p)))
            .count();
        s.truth_parts += truth_parts.iter().filter(|t| t.partial != Some(true)).count();
        s.flipped += truth_parts
            .iter()
            .filter(|t| t.partial != Some(true) && known_flipped(t))
            .count();
        let any_touching = truth.frames.values().flatten().any(|t| t.touching == Some(true));
        for (ti, t) in truth_parts.iter().enumerate() {
            let p = pairs.iter().find(|&&(a, _)| a == ti).map(|&(_, b)| &preds[b]);
            let visible = t.extra.get("visible_fraction").and_then(|v| v.as_f64()).unwrap_or(1.0);
            if t.partial == Some(true) {
                if visible >= 0.5 {
                    s.cut_half.add(t, p);
                }
            } else if t.touching == Some(true) {
                s.touching.add(t, p);
            } else if any_touching {
                s.apart.add(t, p);
            }
        }
        for (ti, pi) in pairs {
            let (t, p) = (&truth_parts[ti], &preds[pi]);
            s.true_predictions += 1;
            if t.partial == Some(true) {
                continue;
            }
            s.detected += 1;
            s.flipped_detected += known_flipped(t) as usize;
            position.push(((t.x - p.x).powi(2) + (t.y - p.y).powi(2)).sqrt());
            let num = |part: &PartJson, k: &str| part.extra.get(k).and_then(|v| v.as_f64());
            if let Some(d_true) = num(t, "disparity_px") {
                for (key, list) in [
                    ("disparity_px", &mut disparity),
                    ("disparity_centroid_px", &mut disparity_centroid),
                    ("disparity_polygon_px", &mut disparity_polygon),
                ] {
                    if let Some(d) = num(p, key) {
                        list.push((d - d_true).abs());
                    }
                }
                match (num(t, "z_mm"), num(p, "z_mm")) {
                    (Some(z_true), Some(z)) => {
                        depth_mm.push((z - z_true).abs());
                        depth_pct.push(100.0 * (z - z_true).abs() / z_true);
                    }
                    _ => s.stereo_without_depth += 1,
                }
            }
            match &t.class {
                Some(tc) => {
                    s.known += 1;
                    if p.class.as_deref() == Some(tc.as_str()) {
                        s.known_correct += 1;
                        s.flipped_correct += flipped(t) as usize;
                        if sides_reported {
                            s.flip_judged += 1;
                            s.flip_right += (flipped(t) == flipped(p)) as usize;
                        }
                        let sym = t.symmetry.unwrap_or(1);
                        if sym != 0 {
                            angle.push(angle_error(p.angle_deg, t.angle_deg, sym));
                            if let Some(a) = p.extra.get("angle_paper_deg").and_then(|v| v.as_f64()) {
                                angle_paper.push(angle_error(a, t.angle_deg, sym));
                            }
                        }
                    } else {
                        let got = p.class.clone().unwrap_or_else(|| "unknown".into());
                        *confusions.entry((tc.clone(), got)).or_default() += 1;
                    }
                }
                None => {
                    s.unknown += 1;
                    if p.class.is_none() {
                        s.unknown_rejected += 1;
                    } else {
                        let got = p.class.clone().unwrap_or_default();
                        *confusions.entry(("(not a template)".into(), got)).or_default() += 1;
                    }
                }
            }
        }
    }
    s.angle = Spread::of(&angle);
    s.angle_paper = Spread::of(&angle_paper);
    s.position = Spread::of(&position);
    s.disparity = Spread::of(&disparity);
    s.disparity_centroid = Spread::of(&disparity_centroid);
    s.disparity_polygon = Spread::of(&disparity_polygon);
    s.depth_mm = Spread::of(&depth_mm);
    s.depth_pct = Spread::of(&depth_pct);
    s.confusions = confusions.into_iter().map(|((a, b), n)| (a, b, n)).collect();
    for g in [&mut s.touching, &mut s.apart, &mut s.cut_half] {
        g.finish();
    }
    s
}

/// Greedy pairing by distance: (truth index, prediction index).
/// Whether a truth entry marks a blob of several parts whose parts the truth does not list (a
/// real set's `"partial": true` without a class or a `visible_fraction`: "several parts touching
/// or overlapping in one blob: don't care for the scorer", `../shared/datasets/real/README.md`).
/// Such a blob counts against neither recall nor precision, whatever is found in it. A cut part
/// of a generated set has its `visible_fraction` and is scored.
pub fn is_unscored_blob(t: &PartJson) -> bool {
    t.partial == Some(true) && t.class.is_none() && !t.extra.contains_key("visible_fraction")
}

/// Whether prediction `p` comes from the blob truth entry `blob` marks: it lies within
/// [`MATCH_RADIUS_PX`] of the blob's centroid, or its blob's border does (`polygon_centroid`,
/// the same for every part found along one blob).
fn from_blob(p: &PartJson, blob: &PartJson) -> bool {
    let near = |x: f64, y: f64| (x - blob.x).hypot(y - blob.y) <= MATCH_RADIUS_PX;
    let polygon = p
        .extra
        .get("polygon_centroid")
        .and_then(|v| v.as_array())
        .and_then(|a| {
            let x = a.first()?.as_f64()?;
            let y = a.get(1)?.as_f64()?;
            Some((x, y))
        });
    near(p.x, p.y) || polygon.is_some_and(|(x, y)| near(x, y))
}

fn pair(truth: &[PartJson], pred: &[PartJson]) -> Vec<(usize, usize)> {
    let mut cands: Vec<(f64, usize, usize)> = Vec::new();
    for (ti, t) in truth.iter().enumerate() {
        for (pi, p) in pred.iter().enumerate() {
            let d = ((t.x - p.x).powi(2) + (t.y - p.y).powi(2)).sqrt();
            if d <= MATCH_RADIUS_PX {
                cands.push((d, ti, pi));
            }
        }
    }
    cands.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (mut tu, mut pu) = (vec![false; truth.len()], vec![false; pred.len()]);
    let mut out = Vec::new();
    for (_, ti, pi) in cands {
        if !tu[ti] && !pu[pi] {
            tu[ti] = true;
            pu[pi] = true;
            out.push((ti, pi));
        }
    }
    out
}

/// The scores plus timing, as printed by `--json`.
#[derive(Debug, Serialize)]
pub struct EvalReport {
    /// The set.
    pub set: String,
    /// Frames that could not be processed.
    pub failed_frames: usize,
    /// Mean core time per frame, ms.
    pub ms_per_frame: f64,
    /// The scores.
    #[serde(flatten)]
    pub scores: Scores,
    /// Detection recall.
    pub recall: f64,
    /// Detection precision.
    pub precision: f64,
    /// Classification accuracy.
    pub classification: f64,
    /// Unknown-rejection rate.
    pub unknown_rejection: f64,
    /// Without an empty shot: frames whose platform was estimated from the frame itself, and
    /// frames that kept an earlier frame's estimate (both 0 with an empty shot, and for stereo
    /// sets, which are not counted).
    pub platform_estimated: usize,
    /// See [`Self::platform_estimated`].
    pub platform_kept: usize,
    /// Problems with the set that are not one frame's (a stereo set's `camera.json`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub setup_errors: Vec<String>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(class: Option<&str>, x: f64, y: f64, a: f64, sym: Option<u32>) -> PartJson {
        PartJson {
            class: class.map(String::from),
            x,
            y,
            angle_deg: a,
            symmetry: sym,
            score: None,
            partial: None,
            flipped: None,
            touching: None,
            extra: Default::default(),
        }
    }

    #[test]
    fn angle_error_respects_symmetry() {
        assert!((angle_error(359.0, 1.0, 1) - 2.0).abs() < 1e-12);
        assert!((angle_error(95.0, 5.0, 4) - 0.0).abs() < 1e-12);
        assert!((angle_error(50.0, 5.0, 4) - 45.0).abs() < 1e-12);
    }

    #[test]
    fn an_untaught_part_upside_down_counts_with_the_unknown_parts() {
        let frames = |parts: Vec<PartJson>| FramesJson {
            frames: [("a.png".to_string(), parts)].into_iter().collect(),
        };
        let upside_down = |class: Option<&str>, x: f64| {
            let mut p = part(class, x, 100.0, 0.0, Some(1));
            p.flipped = Some(true);
            p
        };
        // A hook upside down, named; a blob of no class upside down, rejected.
        let truth = frames(vec![upside_down(Some("hook"), 100.0), upside_down(None, 300.0)]);
        let pred = frames(vec![
            upside_down(Some("hook"), 100.2),
            part(None, 300.1, 100.0, 0.0, None),
        ]);
        let s = score(&truth, &pred);
        assert_eq!((s.flipped, s.flipped_detected, s.flipped_correct), (1, 1, 1));
        assert_eq!((s.unknown, s.unknown_rejected), (1, 1));
    }

    #[test]
    fn a_blob_the_truth_does_not_score_counts_against_nothing() {
        let frames = |parts: Vec<PartJson>| FramesJson {
            frames: [("a.png".to_string(), parts)].into_iter().collect(),
        };
        // A real set's blob of two overlapping parts (partial, no class, no visible share) and
        // one isolated part.
        let mut blob = part(None, 400.0, 180.0, 0.0, Some(0));
        blob.partial = Some(true);
        let truth = frames(vec![blob.clone(), part(Some("gear"), 100.0, 100.0, 0.0, Some(12))]);
        // Two parts found along the blob, 50 px from its centroid but with its border's
        // centroid; the gear; and a phantom far from both.
        let along = |x: f64| {
            let mut p = part(Some("clip"), x, 170.0, 0.0, None);
            p.touching = Some(true);
            p.extra
                .insert("polygon_centroid".into(), serde_json::json!([401.0, 181.0]));
            p
        };
        let pred = frames(vec![
            along(350.0),
            along(450.0),
            part(Some("gear"), 100.5, 100.0, 0.0, None),
            part(Some("clip"), 250.0, 300.0, 0.0, None),
        ]);
        let s = score(&truth, &pred);
        assert_eq!((s.truth_parts, s.detected), (1, 1), "the blob is not a part to find");
        assert_eq!((s.predictions, s.true_predictions, s.unscored), (2, 1, 2));
        assert!(s.cut_half.is_empty(), "the blob is not a cut part");
        // The whole blob reported as one unknown part at its centroid is unscored too.
        let whole = frames(vec![
            part(None, 400.5, 180.0, 0.0, None),
            part(Some("gear"), 100.5, 100.0, 0.0, None),
        ]);
        let s = score(&truth, &whole);
        assert_eq!((s.predictions, s.true_predictions, s.unscored), (1, 1, 1));
        // A generated set's cut part (with its visible share) stays scored.
        let mut cut = blob;
        cut.class = Some("clip".into());
        cut.extra.insert("visible_fraction".into(), serde_json::json!(0.7));
        let s = score(&frames(vec![cut]), &whole);
        assert_eq!((s.cut_half.parts, s.unscored), (1, 0));
    }

    #[test]
    fn stereo_errors_and_right_only_parts() {
        let with = |mut p: PartJson, kv: &[(&str, serde_json::Value)]| {
            for (k, v) in kv {
                p.extra.insert(k.to_string(), v.clone());
            }
            p
        };
        let mut truth = FramesJson::default();
        truth.frames.insert(
            "f.png".into(),
            vec![
                with(
                    part(Some("gear"), 10.0, 10.0, 0.0, Some(1)),
                    &[("disparity_px", 60.0.into()), ("z_mm", 800.0.into())],
                ),
                with(
                    part(None, 100.0, 100.0, 0.0, Some(1)),
                    &[("disparity_px", 64.0.into()), ("z_mm", 750.0.into())],
                ),
            ],
        );
        let mut pred = FramesJson::default();
        pred.frames.insert(
            "f.png".into(),
            vec![
                with(
                    part(Some("gear"), 10.0, 10.0, 0.0, None),
                    &[
                        ("disparity_px", 60.01.into()),
                        ("disparity_centroid_px", 60.05.into()),
                        ("z_mm", 799.8.into()),
                    ],
                ),
                // Found in the left view only: no depth.
                with(
                    part(None, 100.0, 100.0, 0.0, None),
                    &[("stereo", "left image only".into())],
                ),
                // Found in the right view only, right-image position near a truth part: not
                // scored.
                with(part(None, 10.0, 12.0, 0.0, None), &[("view", "right".into())]),
            ],
        );
        let s = score(&truth, &pred);
        assert_eq!((s.predictions, s.true_predictions, s.right_only), (2, 2, 1));
        assert_eq!(
            (s.disparity.count, s.disparity_centroid.count, s.depth_mm.count),
            (1, 1, 1)
        );
        assert!((s.disparity.median - 0.01).abs() < 1e-9);
        assert!((s.disparity_centroid.median - 0.05).abs() < 1e-9);
        assert!((s.depth_mm.median - 0.2).abs() < 1e-9);
        assert!((s.depth_pct.median - 0.025).abs() < 1e-9);
        assert_eq!(s.stereo_without_depth, 1);
        // Mono scores leave the stereo fields out of the JSON.
        let mono = serde_json::to_value(score(&FramesJson::default(), &FramesJson::default())).unwrap();
        assert!(mono.get("disparity").is_none() && mono.get("right_only").is_none());
    }

    #[test]
    fn scores_count_what_they_say() {
        let mut truth = FramesJson::default();
        truth.frames.insert(
            "a.png".into(),
            vec![
                part(Some("gear"), 10.0, 10.0, 30.0, Some(1)),
                part(None, 100.0, 100.0, 0.0, Some(1)),
                part(Some("nut"), 200.0, 50.0, 10.0, Some(6)),
            ],
        );
        let mut pred = FramesJson::default();
        pred.frames.insert(
            "a.png".into(),
            vec![
                part(Some("gear"), 10.3, 10.4, 31.0, None),
                part(Some("gear"), 101.0, 100.0, 0.0, None),
                part(Some("bracket"), 400.0, 400.0, 0.0, None),
            ],
        );
        let s = score(&truth, &pred);
        assert_eq!(
            (s.truth_parts, s.detected, s.predictions, s.true_predictions),
            (3, 2, 3, 2)
        );
        assert_eq!((s.known, s.known_correct, s.unknown, s.unknown_rejected), (1, 1, 1, 0));
        assert!((s.position.median - 0.5).abs() < 1e-9);
        assert!((s.angle.max - 1.0).abs() < 1e-9);
        assert_eq!(s.confusions, vec![("(not a template)".into(), "gear".into(), 1)]);
    }
}
