//! Edge-enhanced intensity, paper eq. 3.1: `I' = α·I + (1 − α)·|∇I|`.
//!
//! The gradient is the 3×3 Sobel operator with replicated borders; its magnitude is divided by
//! `4·√2`, which maps the largest possible magnitude (`4·255·√2`) onto 255, so `I'` stays in the
//! intensity range. The result is rounded to the nearest integer and clamped to `[0, 255]`
//! (see `docs/pipeline-spec.md` §1).
//!
//! Time: one Sobel (8 loads, one `sqrt`) per pixel; with `α = 1` the gradient is skipped and
//! `I' = I`. Memory: none beyond the caller's output row.

use crate::math;
use crate::pixels::frame::Frame;

/// `1 / (4·√2)`: Sobel magnitude into the intensity range.
const GRADIENT_SCALE: f32 = 0.176_776_69;

/// Weight of intensity against gradient in eq. 3.1, checked to lie in `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alpha(f32);

impl Alpha {
    /// `α`, or `None` when it is not in `[0, 1]` (NaN included).
    pub fn new(alpha: f32) -> Option<Self> {
        if (0.0..=1.0).contains(&alpha) {
            Some(Alpha(alpha))
        } else {
            None
        }
    }

    /// `α = 1`: intensity only (`I' = I`).
    pub const ONE: Alpha = Alpha(1.0);

    /// The value.
    pub fn get(self) -> f32 {
        self.0
    }
}

/// Writes row `y` of `I'` into `out` (which must hold `frame.width()` bytes; a shorter `out`
/// receives only its first `out.len()` pixels).
///
/// ```
/// use vorl_core::{pixels::enhance::{enhance_row, Alpha}, Frame};
/// // A vertical step edge from 0 to 100.
/// let px = [0u8, 0, 100, 100, 0, 0, 100, 100, 0, 0, 100, 100];
/// let frame = Frame::new_checked(&px[..], 4, 3).unwrap();
/// let mut row = [0u8; 4];
/// enhance_row(&frame, 1, Alpha::new(1.0).unwrap(), &mut row);
/// assert_eq!(row, [0, 0, 100, 100]);
/// enhance_row(&frame, 1, Alpha::new(0.0).unwrap(), &mut row);
/// // Sobel gx = 400 at the edge: 400 / (4·√2) = 70.7 → 71.
/// assert_eq!(row, [0, 71, 71, 0]);
/// ```
pub fn enhance_row<B: AsRef<[u8]>>(frame: &Frame<B>, y: usize, alpha: Alpha, out: &mut [u8]) {
    enhance_span(frame, y, 0, alpha, out);
}

/// Writes `I'` of pixels `x0 .. x0 + out.len()` of row `y` into `out` (pixels past the row's end
/// are left alone).
pub fn enhance_span<B: AsRef<[u8]>>(frame: &Frame<B>, y: usize, x0: usize, alpha: Alpha, out: &mut [u8]) {
    let w = frame.width();
    let a = alpha.get();
    let cur = frame.row(y);
    if a >= 1.0 {
        for (o, &p) in out.iter_mut().zip(cur.iter().skip(x0)) {
            *o = p;
        }
        return;
    }
    let up = frame.row(y.saturating_sub(1));
    let down = frame.row(if y + 1 < frame.height() { y + 1 } else { y });
    let b = (1.0 - a) * GRADIENT_SCALE;
    for (x, o) in (x0..w).zip(out.iter_mut()) {
        let xl = x.saturating_sub(1);
        let xr = if x + 1 < w { x + 1 } else { x };
        let (Some(&ul), Some(&uc), Some(&ur)) = (up.get(xl), up.get(x), up.get(xr)) else {
            return;
        };
        let (Some(&cl), Some(&cc), Some(&cr)) = (cur.get(xl), cur.get(x), cur.get(xr)) else {
            return;
        };
        let (Some(&dl), Some(&dc), Some(&dr)) = (down.get(xl), down.get(x), down.get(xr)) else {
            return;
        };
        let gx = (ur as i32 + 2 * cr as i32 + dr as i32) - (ul as i32 + 2 * cl as i32 + dl as i32);
        let gy = (dl as i32 + 2 * dc as i32 + dr as i32) - (ul as i32 + 2 * uc as i32 + ur as i32);
        let g = math::sqrt((gx * gx + gy * gy) as f32);
        *o = to_u8(a * cc as f32 + b * g);
    }
}

/// Rounds half away from zero and clamps into `[0, 255]`.
#[inline]
fn to_u8(v: f32) -> u8 {
    let r = math::floor(v + 0.5);
    if r <= 0.0 {
        0
    } else if r >= 255.0 {
        255
    } else {
        r as u8
    }
}

/// `I'` of a whole frame into `out` (row-packed, `width·height` bytes).
///
/// Returns the number of rows written (fewer than the height when `out` is short).
pub fn enhance<B: AsRef<[u8]>>(frame: &Frame<B>, alpha: Alpha, out: &mut [u8]) -> usize {
    let w = frame.width();
    let mut rows = 0;
    for (y, row) in out.chunks_exact_mut(w.max(1)).take(frame.height()).enumerate() {
        enhance_row(frame, y, alpha, row);
        rows += 1;
    }
    rows
}
