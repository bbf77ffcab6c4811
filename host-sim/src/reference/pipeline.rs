//! §9 templates and the whole pipeline, [`detect`].

use image::GrayImage;

use super::contour::{area_centroid, borders, polygon_area, resample, RefBorder};
use super::descriptor::descriptor;
use super::imaging::{enhance, foreground_mask};
use super::matching::{cyclic_dp, RefMatch};
use super::pose::{angle_paper, angle_signed};
use super::{RefError, RefParams};

/// A template: `m` resampled border points at the reference pose (angle 0) and their
/// descriptor (computed with `k_t = max(1, round(k·m/n))`, §6).
#[derive(Debug, Clone, PartialEq)]
pub struct RefTemplate {
    /// The `m` resampled points of the template's outer border (§5).
    pub points: Vec<(f64, f64)>,
    /// The descriptor of [`RefTemplate::points`] (eq. 4.3).
    pub descriptor: Vec<f64>,
}

/// One part found by [`detect`].
#[derive(Debug, Clone, PartialEq)]
pub struct RefDetection {
    /// Index of the best template when its `f' < ε` (eq. 5.2), else `None` (unknown part).
    pub template: Option<usize>,
    /// Position `x` (§8: area centroid of the outer border minus its kept holes).
    pub x: f64,
    /// Position `y` (§8).
    pub y: f64,
    /// Signed rotation from the best template, degrees in `[0, 360)`, counter-clockwise on
    /// screen ([`angle_signed`]).
    pub angle_deg: f64,
    /// The paper's unsigned rotation estimate from the best template, degrees
    /// ([`angle_paper`], eq. 6.4).
    pub angle_paper_deg: f64,
    /// `f' = f_min / n` against the best template (eq. 5.1); `f64::INFINITY` with no templates.
    pub score: f64,
    /// Index of the part's outer border in the list returned by [`borders`].
    pub border_index: usize,
    /// The part's outer border points.
    pub border: Vec<(i32, i32)>,
}

fn to_f64(points: &[(i32, i32)]) -> Vec<(f64, f64)> {
    points.iter().map(|&(x, y)| (f64::from(x), f64::from(y))).collect()
}

/// Template from a silhouette image (§9): mask = pixels `> 127`, no clean-up; the outer border
/// with the largest polygon area (the first on ties; the `min_points` / `min_area` filter is
/// not applied) is resampled to `m` points and described with `k_t = max(1, round(k·m/n))`
/// and ω. Its pose is the reference pose (angle 0).
///
/// Errors: invalid parameters (`n ≥ 1`, `n ≤ m < 2n`, `k ≥ 1`, ω finite), no outer border, and the
/// errors of [`resample`] and [`descriptor`].
pub fn template_from_silhouette(img: &GrayImage, params: &RefParams) -> Result<RefTemplate, RefError> {
    params.check()?;
    let mut mask = GrayImage::new(img.width(), img.height());
    for (o, &v) in mask.iter_mut().zip(img.as_raw()) {
        *o = if v > 127 { 255 } else { 0 };
    }
    let all = borders(&mask);
    let mut best: Option<(&RefBorder, f64)> = None;
    for b in all.iter().filter(|b| !b.is_hole) {
        let area = polygon_area(&b.points);
        let larger = match best {
            None => true,
            Some((_, a)) => area > a,
        };
        if larger {
            best = Some((b, area));
        }
    }
    let (outer, _) = best.ok_or(RefError::NoOuterBorder)?;
    let points = resample(&to_f64(&outer.points), params.m)?;
    let descriptor = descriptor(&points, params.k_template(), params.omega)?;
    Ok(RefTemplate { points, descriptor })
}

/// The whole pipeline on one frame against a learned background `B` (§1–§8):
///
/// `enhance(frame, α)` → [`foreground_mask`] → [`borders`] → the kept outer borders (at least
/// `min_points` points and `min_area` px²) in border order → [`resample`] to `n` points →
/// [`descriptor`] with `k` → [`cyclic_dp`] against every template → the best template (lowest
/// `f'`, the first on ties); `template = Some(idx)` iff `f' < ε` (eq. 5.2). The angles come
/// from the best template's assignment, also for unknown parts. The position is the
/// [`area_centroid`] of the outer border minus its kept holes (kept hole borders whose parent
/// is that outer border); when that has no positive area, the outer polygon's centroid alone,
/// and failing that the mean of the border points.
///
/// A kept outer border with zero perimeter or a degenerate descriptor is skipped.
///
/// Errors: invalid parameters (`n ≥ 1`, `n ≤ m < 2n`, `k ≥ 1`, ω finite), frame and background of
/// different sizes, a template whose points and descriptor differ in length or whose length
/// `m_t` breaks `n ≤ m_t < 2n`, or non-finite template values.
pub fn detect(
    frame: &GrayImage,
    background: &GrayImage,
    templates: &[RefTemplate],
    params: &RefParams,
) -> Result<Vec<RefDetection>, RefError> {
    params.check()?;
    for (idx, t) in templates.iter().enumerate() {
        let mt = t.descriptor.len();
        if t.points.len() != mt || mt < params.n || mt >= params.n.saturating_mul(2) {
            return Err(RefError::InvalidParams(format!(
                "template {idx} has {} points and {mt} descriptor values; need equal counts m_t \
                 with n <= m_t < 2n (n = {})",
                t.points.len(),
                params.n
            )));
        }
    }

    let enhanced = enhance(frame, params.alpha);
    let mask = foreground_mask(&enhanced, background, params.threshold, params.polarity, params.cleanup)?;
    let all = borders(&mask);
    let kept: Vec<bool> = all
        .iter()
        .map(|b| b.points.len() >= params.min_points && polygon_area(&b.points) >= params.min_area)
        .collect();

    let mut detections = Vec::new();
    for (idx, outer) in all.iter().enumerate() {
        if outer.is_hole || !kept[idx] {
            continue;
        }
        // §5, §6: resample to n points and describe with k; skipped when degenerate.
        let Ok(points) = resample(&to_f64(&outer.points), params.n) else {
            continue;
        };
        let Ok(desc) = descriptor(&points, params.k, params.omega) else {
            continue;
        };

        // §7: the best template by f' (eq. 5.1), the first on ties.
        let mut best: Option<(usize, RefMatch)> = None;
        for (t_idx, t) in templates.iter().enumerate() {
            let found = cyclic_dp(&desc, &t.descriptor)?;
            let better = match &best {
                None => true,
                Some((_, b)) => found.normalized < b.normalized,
            };
            if better {
                best = Some((t_idx, found));
            }
        }

        // §8: rotation from the best template's correspondence, always computed.
        let (template, score, angle_deg, angle_paper_deg) = match &best {
            Some((t_idx, found)) => {
                let t_points = &templates[*t_idx].points;
                (
                    (found.normalized < params.epsilon).then_some(*t_idx), // eq. 5.2
                    found.normalized,
                    angle_signed(&points, t_points, &found.assignment),
                    angle_paper(&points, t_points, &found.assignment),
                )
            }
            None => (None, f64::INFINITY, 0.0, 0.0),
        };

        // §8: position, the outer polygon's area centroid minus its kept holes.
        let holes: Vec<&[(i32, i32)]> = all
            .iter()
            .enumerate()
            .filter(|(h_idx, h)| h.is_hole && kept[*h_idx] && h.parent == Some(idx))
            .map(|(_, h)| h.points.as_slice())
            .collect();
        let (x, y) = area_centroid(&outer.points, &holes)
            .or_else(|| area_centroid(&outer.points, &[]))
            .unwrap_or_else(|| vertex_mean(&outer.points));

        detections.push(RefDetection {
            template,
            x,
            y,
            angle_deg,
            angle_paper_deg,
            score,
            border_index: idx,
            border: outer.points.clone(),
        });
    }
    Ok(detections)
}

/// Mean of the border's points (the last-resort position); the caller's border is non-empty.
fn vertex_mean(points: &[(i32, i32)]) -> (f64, f64) {
    let n = points.len().max(1) as f64;
    let sx: f64 = points.iter().map(|p| f64::from(p.0)).sum();
    let sy: f64 = points.iter().map(|p| f64::from(p.1)).sum();
    (sx / n, sy / n)
}
