//! The one place that names `libm`: every floating-point function the core uses.
//!
//! The core runs in `f32` (a Cortex-M4F has a single-precision FPU). `libm` gives correctly
//! rounded or near-correctly rounded results on every target, so host and MCU agree bit for bit
//! on the same inputs.

/// Square root.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}

/// Four-quadrant arctangent of `y / x`, radians in `(−π, π]`.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    libm::atan2f(y, x)
}

/// Arccosine, radians. The argument is clamped to `[−1, 1]` first: a normalised dot product
/// can exceed 1 by a few ulps, and `acos(1 + ε)` would be NaN (paper eq. 6.1 guard).
#[inline]
pub fn acos_clamped(x: f32) -> f32 {
    libm::acosf(x.clamp(-1.0, 1.0))
}

/// Sine and cosine of an angle in radians.
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    libm::sincosf(x)
}

/// `x` to the power `y`.
#[inline]
pub fn powf(x: f32, y: f32) -> f32 {
    libm::powf(x, y)
}

/// The natural logarithm of `x` (NaN for a negative `x`, −∞ at 0).
#[inline]
pub fn ln(x: f32) -> f32 {
    libm::logf(x)
}

/// Round half away from zero.
#[inline]
pub fn round(x: f32) -> f32 {
    libm::roundf(x)
}

/// Largest integer not above `x`.
#[inline]
pub fn floor(x: f32) -> f32 {
    libm::floorf(x)
}

/// Euclidean length of `(x, y)`, as `√(x² + y²)` in `f32`.
///
/// Not `libm::hypotf`: that one computes in `f64`, which a Cortex-M4F emulates in software
/// (about ten times the instructions). The core's arguments are pixel offsets and descriptor
/// terms, far from where `x²` overflows (`|x| > 1.8·10¹⁹`).
#[inline]
pub fn hypot(x: f32, y: f32) -> f32 {
    sqrt(x * x + y * y)
}

/// Length of the closed polygon through `points` (the last point joined to the first); 0 for
/// none.
///
/// ```
/// use vorl_core::math::perimeter;
/// let square = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
/// assert_eq!(perimeter(square.into_iter()), 8.0);
/// ```
pub fn perimeter(points: impl Iterator<Item = [f32; 2]> + Clone) -> f32 {
    let mut it = points.clone();
    let Some(first) = it.next() else {
        return 0.0;
    };
    let (mut len, mut last) = (0.0f32, first);
    for p in it.chain(core::iter::once(first)) {
        len += hypot(p[0] - last[0], p[1] - last[1]);
        last = p;
    }
    len
}

/// Whether the closed polygon through `points` holds `q`: a ray from `q` along +x crosses it
/// an odd number of times (an edge counts where its ends lie on either side of `q`'s row, an
/// end on the row counting as below it). False for no points.
///
/// ```
/// use vorl_core::math::polygon_holds;
/// let square = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
/// assert!(polygon_holds(square.into_iter(), [1.0, 1.0]));
/// assert!(!polygon_holds(square.into_iter(), [3.0, 1.0]));
/// ```
pub fn polygon_holds(points: impl Iterator<Item = [f32; 2]> + Clone, q: [f32; 2]) -> bool {
    let Some(mut a) = points.clone().last() else {
        return false;
    };
    let [x, y] = q;
    let mut inside = false;
    for b in points {
        let ([x0, y0], [x1, y1]) = (a, b);
        if (y0 > y) != (y1 > y) && x < x0 + (y - y0) / (y1 - y0) * (x1 - x0) {
            inside = !inside;
        }
        a = b;
    }
    inside
}

/// Degrees from radians.
#[inline]
pub fn degrees(rad: f32) -> f32 {
    rad * (180.0 / core::f32::consts::PI)
}

/// Radians from degrees.
#[inline]
pub fn radians(deg: f32) -> f32 {
    deg * (core::f32::consts::PI / 180.0)
}

/// An angle in degrees taken into `[0, 360)`.
#[inline]
pub fn wrap_degrees(deg: f32) -> f32 {
    if !deg.is_finite() {
        return 0.0;
    }
    let mut a = deg - 360.0 * floor(deg / 360.0);
    // `deg` just below 0 can round to exactly 360.0.
    if a >= 360.0 {
        a -= 360.0;
    }
    if a < 0.0 {
        a = 0.0;
    }
    a
}

/// `f32::clamp` without its panic: the same value for every `x` (NaN stays NaN) when
/// `lo ≤ hi`; crossed or NaN bounds do not panic (then `x` below `lo` is `lo`, else above `hi` is
/// `hi`).
#[inline]
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn acos_is_clamped() {
        assert_eq!(acos_clamped(1.000_001), 0.0);
        assert!((acos_clamped(-1.5) - core::f32::consts::PI).abs() < 1e-6);
    }

    #[test]
    fn clamp_is_f32_clamp_without_the_panic() {
        let values = [
            f32::NAN,
            f32::NEG_INFINITY,
            -3.0,
            -2.0,
            -0.0,
            0.0,
            0.5,
            7.0,
            8.0,
            f32::INFINITY,
        ];
        for x in values {
            for (lo, hi) in [(-2.0f32, 7.0f32), (0.0, 0.0), (-0.0, 0.0)] {
                assert_eq!(
                    clamp(x, lo, hi).to_bits(),
                    x.clamp(lo, hi).to_bits(),
                    "{x} in [{lo}, {hi}]"
                );
            }
        }
        // Crossed and NaN bounds: a value, not a panic.
        assert_eq!(clamp(1.0, 2.0, -1.0), 2.0);
        assert_eq!(clamp(1.0, f32::NAN, f32::NAN), 1.0);
    }

    #[test]
    fn wrap_degrees_range() {
        for d in [-720.0f32, -360.0, -1e-7, 0.0, 359.9999, 360.0, 725.0, f32::NAN] {
            let w = wrap_degrees(d);
            assert!((0.0..360.0).contains(&w), "{d} -> {w}");
        }
        assert!((wrap_degrees(-90.0) - 270.0).abs() < 1e-4);
    }
}

/// The `k`-th smallest (0-based) finite value of `values`, without sorting or moving them:
/// bisection on the value between the least and the largest (32 halvings, then the largest
/// element at or below the bound found), so `O(32·len)` and no panic path. `None` when fewer
/// than `k + 1` values are finite.
pub fn nth_smallest(values: &[f32], k: usize) -> Option<f32> {
    let (mut lo, mut hi, mut finite) = (f32::INFINITY, f32::NEG_INFINITY, 0usize);
    for &v in values.iter().filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
        finite += 1;
    }
    if finite <= k {
        return None;
    }
    let at_most = |t: f32| values.iter().filter(|&&v| v <= t).count();
    // Invariant: fewer than k + 1 values are ≤ lo_bound (or lo_bound < lo), at least k + 1 are ≤ hi.
    let (mut a, mut b) = (lo, hi);
    if at_most(a) > k {
        return Some(a);
    }
    for _ in 0..32 {
        let mid = a + 0.5 * (b - a);
        if !(mid > a && mid < b) {
            break;
        }
        if at_most(mid) > k {
            b = mid;
        } else {
            a = mid;
        }
    }
    // The element itself: the largest value at or below b.
    values
        .iter()
        .copied()
        .filter(|&v| v <= b && v.is_finite())
        .reduce(f32::max)
}

/// The `k`-th smallest (0-based) finite value of `values`, reordering them: quickselect with a
/// three-way partition around the median of three. Each round puts at least the pivot's equals
/// in their final place, so at most `len` rounds; `O(len)` expected. The values left after the
/// first `finite` places are the non-finite ones. Gives the same value as [`nth_smallest`]
/// (which leaves `values` alone) and costs a few passes instead of 33.
///
/// ```
/// let mut v = [3.0, f32::NAN, 1.0, 2.0, 1.0];
/// assert_eq!(vorl_core::math::select_nth(&mut v, 2), Some(2.0));
/// assert_eq!(vorl_core::math::select_nth(&mut v, 4), None); // only four are finite
/// ```
pub fn select_nth(values: &mut [f32], k: usize) -> Option<f32> {
    // The finite values to the front.
    let mut n = 0;
    for i in 0..values.len() {
        if values.get(i).is_some_and(|v| v.is_finite()) {
            swap(values, i, n);
            n += 1;
        }
    }
    if k >= n {
        return None;
    }
    let at = |v: &[f32], i: usize| v.get(i).copied().unwrap_or(0.0);
    let (mut lo, mut hi) = (0usize, n - 1);
    // Invariant: the k-th smallest of the finite values is the (k − lo)-th of `lo..=hi`.
    for _ in 0..n {
        if lo >= hi {
            break;
        }
        let (a, b, c) = (at(values, lo), at(values, lo + (hi - lo) / 2), at(values, hi));
        let pivot = a.max(b).min(a.min(b).max(c));
        // `lo..lt` < pivot, `lt..i` = pivot, `gt+1..=hi` > pivot.
        let (mut lt, mut i, mut gt) = (lo, lo, hi);
        while i <= gt {
            let v = at(values, i);
            if v < pivot {
                swap(values, lt, i);
                lt += 1;
                i += 1;
            } else if v > pivot {
                swap(values, i, gt);
                // The pivot is an element, so `gt` stays at or above the first equal one.
                match gt.checked_sub(1) {
                    Some(g) => gt = g,
                    None => break,
                }
            } else {
                i += 1;
            }
        }
        if k < lt {
            hi = lt.saturating_sub(1);
        } else if k > gt {
            lo = gt + 1;
        } else {
            return Some(pivot);
        }
    }
    Some(at(values, k))
}

/// Swaps two elements of `v` when both are in it.
fn swap(v: &mut [f32], i: usize, j: usize) {
    if i < v.len() && j < v.len() {
        v.swap(i, j);
    }
}

#[cfg(test)]
mod nth_tests {
    use super::{nth_smallest, select_nth};

    /// Against sorting, on values with ties, NaN and infinities.
    #[test]
    fn nth_smallest_is_the_sorted_kth() {
        let mut x = 0x2545_f491u32;
        for len in [1usize, 2, 3, 7, 64, 200] {
            let values: [f32; 200] = core::array::from_fn(|i| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                match i % 23 {
                    5 => f32::NAN,
                    7 => f32::INFINITY,
                    _ => (x % 50) as f32 * 0.25 - 3.0,
                }
            });
            let v = &values[..len];
            let mut sorted: [f32; 200] = [0.0; 200];
            let mut n = 0;
            for &f in v.iter().filter(|f| f.is_finite()) {
                sorted[n] = f;
                n += 1;
            }
            sorted[..n].sort_by(f32::total_cmp);
            for k in 0..len {
                assert_eq!(nth_smallest(v, k), sorted[..n].get(k).copied(), "len {len} k {k}");
                let mut w = [0.0f32; 200];
                w[..len].copy_from_slice(v);
                let got = select_nth(&mut w[..len], k);
                assert_eq!(got, sorted[..n].get(k).copied(), "select: len {len} k {k}");
            }
        }
    }
}
