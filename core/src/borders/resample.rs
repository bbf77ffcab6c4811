//! Arc-length resampling of a closed border to a fixed number of points (paper eq. 4.5).
//!
//! The border `p_0 … p_{L−1}` is a closed polygon; point `q_k` of `count` lies at arc length
//! `k·P/count` from `p_0` along the border, linearly interpolated (`docs/pipeline-spec.md` §5).
//! Parts get `n` points and templates `m`, `n ≤ m < 2n`.
//!
//! Time `O(L + count)`, no memory beyond the output.

use crate::borders::contour::Point;
use crate::error::{Error, Result};
use crate::math;

/// Resamples the closed polygon `border` to `out.len()` points.
///
/// ```
/// use vorl_core::{borders::contour::Point, borders::resample::resample};
/// let square = [Point { x: 0, y: 0 }, Point { x: 0, y: 2 }, Point { x: 2, y: 2 }, Point { x: 2, y: 0 }];
/// let mut out = [[0.0f32; 2]; 8];
/// resample(&square, &mut out).unwrap();
/// assert_eq!(out[1], [0.0, 1.0]);
/// assert_eq!(out[3], [1.0, 2.0]);
/// ```
///
/// # Errors
/// [`Error::DegenerateContour`] when the border has no length or `out` is empty.
pub fn resample(border: &[Point], out: &mut [[f32; 2]]) -> Result<()> {
    let count = out.len();
    let len = border.len();
    let pt = |i: usize| -> [f32; 2] {
        let p = border.get(i % len.max(1)).copied().unwrap_or_default();
        [p.x as f32, p.y as f32]
    };
    let mut perimeter = 0.0f32;
    for i in 0..len {
        let (a, b) = (pt(i), pt(i + 1));
        perimeter += math::hypot(b[0] - a[0], b[1] - a[1]);
    }
    if count == 0 || len == 0 || !(perimeter > 0.0) {
        return Err(Error::DegenerateContour { points: len });
    }
    let step = perimeter / count as f32;
    // Walk the edges once; `walked` is the arc length at the start of edge `edge`.
    let mut edge = 0usize;
    let mut walked = 0.0f32;
    let (mut a, mut b) = (pt(0), pt(1));
    let mut edge_len = math::hypot(b[0] - a[0], b[1] - a[1]);
    for (k, q) in out.iter_mut().enumerate() {
        let target = k as f32 * step;
        while walked + edge_len < target && edge + 1 < len {
            walked += edge_len;
            edge += 1;
            a = pt(edge);
            b = pt(edge + 1);
            edge_len = math::hypot(b[0] - a[0], b[1] - a[1]);
        }
        let t = if edge_len > 0.0 {
            ((target - walked) / edge_len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        *q = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
    }
    Ok(())
}

/// Checks the point counts of eq. 4.5: `1 ≤ n ≤ m < 2n`.
///
/// # Errors
/// [`Error::PointCounts`].
pub fn check_counts(n: usize, m: usize) -> Result<()> {
    if n == 0 || n > m || m - n >= n {
        return Err(Error::PointCounts { n, m });
    }
    Ok(())
}
