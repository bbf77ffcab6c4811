//! §6: the mixed distance / angle contour descriptor of eqs. 4.1–4.3.

use super::RefError;

/// Mean of the points, `C = (1/N) Σ q_i`. The caller ensures `points` is not empty.
pub(super) fn centroid(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    let sx: f64 = points.iter().map(|p| p.0).sum();
    let sy: f64 = points.iter().map(|p| p.1).sum();
    (sx / n, sy / n)
}

/// The descriptor `c_0 … c_{N−1}` of already resampled points `q_0 … q_{N−1}` (§6, indices
/// cyclic), with `C` the mean of the points:
///
/// * eq. 4.1: `d_i = r_i / mean(r)`, `r_i = |q_i − C|`;
/// * eq. 4.2: `a_i = cos_i / A`, `cos_i = u·w / (|u|·|w|)` with `u = q_{i−k} − C`,
///   `w = q_{i+k} − C` (`cos_i = 1` when `|u|·|w| < 1e-12`), `A = mean(cos)`, replaced by
///   `±0.05` (the sign of `A`, `+` for 0) when `|A| < 0.05`;
/// * eq. 4.3: `c_i = ω·a_i + (1 − ω)·d_i`.
///
/// Errors: no points ([`RefError::Empty`]), `k = 0` ([`RefError::InvalidParams`]), a
/// non-finite coordinate ([`RefError::NonFinite`]), `mean(r) < 1e-9`
/// ([`RefError::Degenerate`]).
pub fn descriptor(points: &[(f64, f64)], k: usize, omega: f64) -> Result<Vec<f64>, RefError> {
    if points.is_empty() {
        return Err(RefError::Empty);
    }
    if k == 0 {
        return Err(RefError::InvalidParams("k must be at least 1".into()));
    }
    if points.iter().any(|&(x, y)| !x.is_finite() || !y.is_finite()) {
        return Err(RefError::NonFinite);
    }
    let len = points.len();
    let (cx, cy) = centroid(points);
    let offset = |i: usize| (points[i].0 - cx, points[i].1 - cy);

    // eq. 4.1: relative distance to the centroid.
    let r: Vec<f64> = (0..len)
        .map(|i| {
            let (x, y) = offset(i);
            x.hypot(y)
        })
        .collect();
    let mean_r = r.iter().sum::<f64>() / len as f64;
    if !mean_r.is_finite() {
        return Err(RefError::NonFinite);
    }
    if mean_r < 1e-9 {
        return Err(RefError::Degenerate);
    }
    let d: Vec<f64> = r.iter().map(|&ri| ri / mean_r).collect();

    // eq. 4.2: cosine of the angle P_{i−k} C P_{i+k}, relative to its mean.
    let step = k % len;
    let cos: Vec<f64> = (0..len)
        .map(|i| {
            let (ux, uy) = offset((i + len - step) % len);
            let (wx, wy) = offset((i + step) % len);
            let norms = ux.hypot(uy) * wx.hypot(wy);
            if norms < 1e-12 {
                1.0
            } else {
                (ux * wx + uy * wy) / norms
            }
        })
        .collect();
    let mut mean_cos = cos.iter().sum::<f64>() / len as f64;
    if mean_cos.abs() < 0.05 {
        mean_cos = if mean_cos < 0.0 { -0.05 } else { 0.05 };
    }

    // eq. 4.3: c_i = ω·a_i + (1 − ω)·d_i.
    Ok((0..len)
        .map(|i| omega * (cos[i] / mean_cos) + (1.0 - omega) * d[i])
        .collect())
}
