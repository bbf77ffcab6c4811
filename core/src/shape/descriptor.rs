//! Per-point shape descriptor, paper eqs. 4.1–4.3: `c_i = ω·a_i + (1 − ω)·d_i`.
//!
//! For resampled points `q_i` with centroid `C` (their mean):
//! - `d_i = |q_i − C| / mean|q − C|` (eq. 4.1), the relative distance to the centroid;
//! - `a_i = cos∠(q_{i−k} − C, q_{i+k} − C) / mean(cos)` (eq. 4.2), the relative cosine of the
//!   angle that the neighbours `k` steps back and ahead subtend at the centroid.
//!
//! Both are invariant to translation, rotation and scale. Guards (`docs/pipeline-spec.md` §6):
//! a point pair at the centroid has cosine 1; the mean cosine is kept at least 0.05 in magnitude
//! (it approaches 0 when `k` nears `n/4`, and dividing by it would blow the term up); a contour
//! whose points all sit on the centroid is degenerate.
//!
//! Time `O(n)`, memory: the output only.

use crate::error::{Error, Result};
use crate::math;

/// Smallest magnitude of the mean cosine that eq. 4.2 divides by.
pub const MEAN_COS_GUARD: f32 = 0.05;

/// Descriptor parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DescriptorParams {
    /// Neighbourhood `k` of the angle term, in resampled points.
    pub k: usize,
    /// Weight `ω ∈ [0, 1]` of the angle term.
    pub omega: f32,
}

/// The neighbourhood for a contour of `points` points when parts of `n` points use `k`:
/// `round(k·points/n)`, at least 1 (so both span the same fraction of the outline); `k` (at
/// least 1) for `n = 0` or counts so large that `2·k·points + n` or `2n` overflow.
pub fn scaled_k(k: usize, n: usize, points: usize) -> usize {
    let num = k
        .checked_mul(points)
        .and_then(|v| v.checked_mul(2))
        .and_then(|v| v.checked_add(n));
    let den = n.checked_mul(2);
    num.zip(den).and_then(|(a, b)| a.checked_div(b)).unwrap_or(k).max(1)
}

/// Writes `c_i` for the resampled points into `out` (same length) and returns the centroid.
///
/// ```
/// use vorl_core::shape::descriptor::{describe, DescriptorParams};
/// // A regular 16-gon: every point looks the same, so every c_i is 1.
/// let pts: Vec<[f32; 2]> = (0..16)
///     .map(|i| { let t = i as f32 * core::f32::consts::PI / 8.0; [10.0 * t.cos(), 10.0 * t.sin()] })
///     .collect();
/// let mut c = [0.0f32; 16];
/// let centroid = describe(&pts, DescriptorParams { k: 1, omega: 0.5 }, &mut c).unwrap();
/// assert!(centroid[0].abs() < 1e-4);
/// assert!(c.iter().all(|v| (v - 1.0).abs() < 1e-4));
/// ```
///
/// # Errors
/// [`Error::DegenerateContour`] for fewer than 3 points or all points on the centroid,
/// [`Error::BufferTooSmall`] when `out` is shorter than `points`,
/// [`Error::Parameter`] for `ω` outside `[0, 1]`.
pub fn describe(points: &[[f32; 2]], params: DescriptorParams, out: &mut [f32]) -> Result<[f32; 2]> {
    let n = points.len();
    if n < 3 {
        return Err(Error::DegenerateContour { points: n });
    }
    if out.len() < n {
        return Err(Error::BufferTooSmall {
            needed: n,
            got: out.len(),
        });
    }
    if !(0.0..=1.0).contains(&params.omega) {
        return Err(Error::Parameter {
            name: "omega",
            value: params.omega,
        });
    }
    let out = &mut out[..n];
    let c = centroid(points);
    let mut mean_r = 0.0f32;
    for (o, p) in out.iter_mut().zip(points) {
        let r = math::hypot(p[0] - c[0], p[1] - c[1]);
        *o = r;
        mean_r += r;
    }
    mean_r /= n as f32;
    if !(mean_r > 1e-9) {
        return Err(Error::DegenerateContour { points: n });
    }
    // Cosines, then their mean.
    let k = params.k % n;
    let at = |i: usize| points.get(i % n).copied().unwrap_or(c);
    let mut sum_cos = 0.0f32;
    // Two passes over the points to avoid a second buffer: the first sums the cosines.
    for i in 0..n {
        sum_cos += cos_at(at(i + n - k), at(i + k), c);
    }
    let mut mean_cos = sum_cos / n as f32;
    if mean_cos.abs() < MEAN_COS_GUARD {
        mean_cos = if mean_cos < 0.0 {
            -MEAN_COS_GUARD
        } else {
            MEAN_COS_GUARD
        };
    }
    let w = params.omega;
    for (i, o) in out.iter_mut().enumerate() {
        let d = *o / mean_r;
        let a = cos_at(at(i + n - k), at(i + k), c) / mean_cos;
        *o = w * a + (1.0 - w) * d;
    }
    Ok(c)
}

/// Mean of the points.
pub fn centroid(points: &[[f32; 2]]) -> [f32; 2] {
    let mut s = [0.0f32; 2];
    for p in points {
        s[0] += p[0];
        s[1] += p[1];
    }
    let n = points.len().max(1) as f32;
    [s[0] / n, s[1] / n]
}

#[inline]
fn cos_at(p: [f32; 2], q: [f32; 2], c: [f32; 2]) -> f32 {
    let (ux, uy) = (p[0] - c[0], p[1] - c[1]);
    let (wx, wy) = (q[0] - c[0], q[1] - c[1]);
    let den = math::hypot(ux, uy) * math::hypot(wx, wy);
    if den < 1e-12 {
        1.0
    } else {
        ((ux * wx + uy * wy) / den).clamp(-1.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_k_rounds_the_ratio() {
        assert_eq!(scaled_k(4, 64, 96), 6);
        assert_eq!(scaled_k(4, 64, 64), 4);
        assert_eq!(scaled_k(3, 64, 80), 4); // 3.75
        assert_eq!(scaled_k(1, 64, 8), 1); // 0.125, at least 1
        assert_eq!(scaled_k(0, 64, 96), 1);
        assert_eq!(scaled_k(5, 0, 96), 5);
    }

    /// Found by the panic-never link (`panic-never/`): with `n > usize::MAX / 2` the divisor `2n`
    /// wrapped to 0 in release builds (a division by zero) and overflowed in debug builds;
    /// `2·k·points + n` overflowed for huge `k` or `points`. Now neither panics.
    #[test]
    fn scaled_k_never_overflows() {
        let huge = usize::MAX / 2 + 1;
        assert_eq!(scaled_k(4, huge, 96), 4);
        assert_eq!(scaled_k(4, usize::MAX, 96), 4);
        assert_eq!(scaled_k(usize::MAX, 64, 96), usize::MAX);
        assert_eq!(scaled_k(4, 64, usize::MAX), 4);
        assert_eq!(scaled_k(0, usize::MAX, usize::MAX), 1);
    }
}
