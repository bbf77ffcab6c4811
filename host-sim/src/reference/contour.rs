//! §4, §5 and the position of §8: border following, polygon area, arc-length resampling and
//! the area centroid.

use image::GrayImage;
use imageproc::contours::{find_contours, BorderType};

use super::RefError;

/// One border found by Suzuki–Abe border following (§4, section 3.3).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RefBorder {
    /// The border's pixel centres `(x, y)` in traced order (a pixel may repeat at
    /// one-pixel-wide necks).
    pub points: Vec<(i32, i32)>,
    /// `true` for a hole border, `false` for an outer border.
    pub is_hole: bool,
    /// Index (into the list returned by [`borders`]) of the parent border in the Suzuki–Abe
    /// hierarchy; `None` when the parent is the image frame.
    pub parent: Option<usize>,
}

/// All borders of the mask (non-zero = foreground), in the order Suzuki–Abe finds them (§4).
///
/// Uses `imageproc::contours::find_contours` on the mask padded with one pixel of 0 on every
/// side (so that every pixel outside the image counts as 0, and an outer border may start at
/// `x = 0`), then shifts the points back by `(−1, −1)`. Parent indices refer to the returned
/// list. A mask with a zero dimension, or too large for `i32` coordinates, has no borders.
pub fn borders(mask: &GrayImage) -> Vec<RefBorder> {
    let (w, h) = mask.dimensions();
    if w == 0 || h == 0 {
        return Vec::new();
    }
    let limit = (i32::MAX - 2) as u32;
    if w > limit || h > limit {
        return Vec::new();
    }
    let mut padded = GrayImage::new(w + 2, h + 2);
    for (x, y, p) in mask.enumerate_pixels() {
        if p.0[0] != 0 {
            padded.put_pixel(x + 1, y + 1, image::Luma([255]));
        }
    }
    find_contours::<i32>(&padded)
        .into_iter()
        .map(|c| RefBorder {
            points: c.points.iter().map(|p| (p.x - 1, p.y - 1)).collect(),
            is_hole: c.border_type == BorderType::Hole,
            parent: c.parent,
        })
        .collect()
}

/// Twice the signed shoelace area `Σ (x_i·y_{i+1} − x_{i+1}·y_i)` of a closed polygon.
fn twice_signed_area(points: &[(f64, f64)]) -> f64 {
    let len = points.len();
    (0..len)
        .map(|i| {
            let (x0, y0) = points[i];
            let (x1, y1) = points[(i + 1) % len];
            x0 * y1 - x1 * y0
        })
        .sum()
}

/// The points as `f64`, relative to `origin`.
fn to_f64(points: &[(i32, i32)], origin: (i32, i32)) -> Vec<(f64, f64)> {
    points
        .iter()
        .map(|&(x, y)| (f64::from(x) - f64::from(origin.0), f64::from(y) - f64::from(origin.1)))
        .collect()
}

/// Absolute shoelace area of the closed polygon through `points` (§4): `|Σ (x_i·y_{i+1} −
/// x_{i+1}·y_i)| / 2`, indices cyclic. Fewer than three points give 0.
pub fn polygon_area(points: &[(i32, i32)]) -> f64 {
    // Exact in i128, then one conversion.
    let len = points.len();
    let twice: i128 = (0..len)
        .map(|i| {
            let (x0, y0) = points[i];
            let (x1, y1) = points[(i + 1) % len];
            i128::from(x0) * i128::from(y1) - i128::from(x1) * i128::from(y0)
        })
        .sum();
    twice.unsigned_abs() as f64 / 2.0
}

/// Arc-length resampling of §5 (eq. 4.5's point sets): the closed polygon `p_0 … p_{L−1}`
/// (closing edge `p_{L−1} → p_0`) with perimeter `P` gives `count` points `q_k` at arc length
/// `k·P/count` from `p_0` along the traced order, linearly interpolated on the edge that
/// contains it.
///
/// Errors: no points or `count = 0` ([`RefError::Empty`]), a non-finite coordinate
/// ([`RefError::NonFinite`]), `P = 0` or not finite ([`RefError::ZeroPerimeter`]).
pub fn resample(points: &[(f64, f64)], count: usize) -> Result<Vec<(f64, f64)>, RefError> {
    if points.is_empty() || count == 0 {
        return Err(RefError::Empty);
    }
    if points.iter().any(|&(x, y)| !x.is_finite() || !y.is_finite()) {
        return Err(RefError::NonFinite);
    }
    let len = points.len();
    // cum[e] = arc length from p_0 to p_e; edge e runs p_e → p_{(e+1) mod L}.
    let mut cum = Vec::with_capacity(len + 1);
    cum.push(0.0);
    for e in 0..len {
        let (x0, y0) = points[e];
        let (x1, y1) = points[(e + 1) % len];
        let last = cum[e];
        cum.push(last + (x1 - x0).hypot(y1 - y0));
    }
    let perimeter = cum[len];
    if perimeter <= 0.0 || !perimeter.is_finite() {
        return Err(RefError::ZeroPerimeter);
    }
    let mut out = Vec::with_capacity(count);
    let mut e = 0;
    for k in 0..count {
        let s = k as f64 * perimeter / count as f64;
        // Move to the edge containing arc length s (zero-length edges are passed over).
        while e + 1 < len && cum[e + 1] <= s {
            e += 1;
        }
        let (x0, y0) = points[e];
        let (x1, y1) = points[(e + 1) % len];
        let edge = cum[e + 1] - cum[e];
        let t = if edge > 0.0 {
            ((s - cum[e]) / edge).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push((x0 + t * (x1 - x0), y0 + t * (y1 - y0)));
    }
    Ok(out)
}

/// Area and first moments `(A, Mx, My)` of a polygon, normalised to a positive orientation
/// (so `A ≥ 0`): `A = ½ Σ cross_i`, `Mx = ⅙ Σ (x_i + x_{i+1})·cross_i`, `My` likewise, with
/// `cross_i = x_i·y_{i+1} − x_{i+1}·y_i`.
fn area_moments(points: &[(f64, f64)]) -> (f64, f64, f64) {
    let len = points.len();
    let mut mx = 0.0;
    let mut my = 0.0;
    for i in 0..len {
        let (x0, y0) = points[i];
        let (x1, y1) = points[(i + 1) % len];
        let cross = x0 * y1 - x1 * y0;
        mx += (x0 + x1) * cross;
        my += (y0 + y1) * cross;
    }
    let a = twice_signed_area(points) / 2.0;
    let (mx, my) = (mx / 6.0, my / 6.0);
    if a < 0.0 {
        (-a, -mx, -my)
    } else {
        (a, mx, my)
    }
}

/// Position of §8: the area centroid of the outer border's polygon (shoelace centroid over its
/// points) with the holes' polygons subtracted by area:
/// `C = (A_o·C_o − Σ A_h·C_h) / (A_o − Σ A_h)`, every area taken positive.
///
/// `None` when the remaining area is not positive (e.g. a line, or a one-pixel-wide ring whose
/// hole border runs through the same pixel centres as its outer border).
pub fn area_centroid(outer: &[(i32, i32)], holes: &[&[(i32, i32)]]) -> Option<(f64, f64)> {
    // Moments are taken about the outer border's first point, for precision.
    let origin = outer.first().copied().unwrap_or((0, 0));
    let (mut a, mut mx, mut my) = area_moments(&to_f64(outer, origin));
    for hole in holes {
        let (ah, mxh, myh) = area_moments(&to_f64(hole, origin));
        a -= ah;
        mx -= mxh;
        my -= myh;
    }
    if a > 1e-12 && a.is_finite() {
        Some((f64::from(origin.0) + mx / a, f64::from(origin.1) + my / a))
    } else {
        None
    }
}
