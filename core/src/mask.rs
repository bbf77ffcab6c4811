//! Foreground mask: `|I' − B| > τ`, then a 3×3 opening (and optionally closing) (paper sections
//! 3.2–3.3).
//!
//! The mask is written into the caller's label plane (`width·height` bytes, one per pixel:
//! 0 background, 1 foreground), which border following then labels in place. The threshold τ is
//! fixed or chosen by Otsu's method on the histogram of the difference (`docs/pipeline-spec.md`
//! §3). With a fixed τ, enhancement, difference and threshold are one pass over the frame; Otsu
//! needs a second pass over the stored differences.
//!
//! The clean-up works on two bits of the same plane (bit 0 the mask, bit 1 scratch) with
//! separable 3×3 passes, so it needs no second frame-sized buffer. Neighbours outside the image
//! are ignored, so a part touching the border is not eaten from that side.
//!
//! Time: `O(width·height)`, about 6 passes over the plane with clean-up. Memory: none extra.

use crate::background::Background;
use crate::enhance::{enhance_row, Alpha};
use crate::error::{Error, Result};
use crate::frame::Frame;

/// How the foreground threshold τ is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Threshold {
    /// A fixed τ: foreground where `|I' − B| > τ`.
    Fixed(u8),
    /// Otsu's level of this frame's difference histogram.
    Otsu,
}

/// The 3×3 clean-up of the mask.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cleanup {
    /// None.
    Off,
    /// An opening (erode, then dilate): removes specks and one-pixel bridges (default). It
    /// keeps holes and gaps a few pixels wide that the blur leaves barely above τ.
    Open,
    /// An opening followed by a closing (dilate, then erode): also fills pinholes, and with them
    /// holes and gaps narrower than about 3 px.
    OpenClose,
}

/// What [`foreground_mask`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MaskStats {
    /// The τ used (the Otsu level, or the fixed value).
    pub threshold: u8,
    /// Foreground pixels after clean-up.
    pub foreground: usize,
}

/// Writes the foreground mask of `frame` against `background` into `labels` (0/1 per pixel).
///
/// ```
/// use vorl_core::{background::Background, enhance::Alpha, mask::{foreground_mask, Cleanup, Threshold}, Frame};
/// // A 3×3 bright block on a 7×7 platform.
/// let bg_px = [50u8; 49];
/// let mut frame_px = [50u8; 49];
/// for y in 2..5 { for x in 2..5 { frame_px[y * 7 + x] = 200; } }
/// let a = Alpha::new(1.0).unwrap();
/// let mut bg = Background::new([0u8; 49], 7, 7).unwrap();
/// bg.set_from_frame(&Frame::new_checked(&bg_px[..], 7, 7).unwrap(), a).unwrap();
/// let mut labels = [0u8; 49];
/// let frame = Frame::new_checked(&frame_px[..], 7, 7).unwrap();
/// let stats = foreground_mask(&frame, &bg, a, Threshold::Fixed(30), Cleanup::OpenClose, &mut labels).unwrap();
/// assert_eq!(stats.foreground, 9);
/// assert_eq!(labels[3 * 7 + 3], 1);
/// assert_eq!(labels[0], 0);
/// ```
///
/// # Errors
/// [`Error::NoBackground`], [`Error::FrameSize`] when frame and background differ in size,
/// [`Error::BufferTooSmall`] when `labels` is shorter than the frame.
pub fn foreground_mask<B: AsRef<[u8]>, S: AsRef<[u8]> + AsMut<[u8]>>(
    frame: &Frame<B>,
    background: &Background<S>,
    alpha: Alpha,
    threshold: Threshold,
    cleanup: Cleanup,
    labels: &mut [u8],
) -> Result<MaskStats> {
    if !background.is_ready() {
        return Err(Error::NoBackground);
    }
    let (w, h) = (frame.width(), frame.height());
    if background.width() != w || background.height() != h {
        return Err(Error::FrameSize {
            expected_width: background.width(),
            expected_height: background.height(),
            width: w,
            height: h,
        });
    }
    let n = w * h;
    if labels.len() < n {
        return Err(Error::BufferTooSmall {
            needed: n,
            got: labels.len(),
        });
    }
    let labels = &mut labels[..n];
    let bg = background.plane();
    // Pass 1: D = |I' − B| into the plane (and its histogram for Otsu).
    let mut hist = [0u32; 256];
    for (y, (row, brow)) in labels.chunks_exact_mut(w).zip(bg.chunks_exact(w)).enumerate() {
        enhance_row(frame, y, alpha, row);
        for (d, &b) in row.iter_mut().zip(brow) {
            *d = d.abs_diff(b);
        }
        if threshold == Threshold::Otsu {
            for &d in row.iter() {
                hist[d as usize] += 1;
            }
        }
    }
    let tau = match threshold {
        Threshold::Fixed(t) => t,
        Threshold::Otsu => otsu_level(&hist),
    };
    for d in labels.iter_mut() {
        *d = (*d > tau) as u8;
    }
    if cleanup != Cleanup::Off {
        erode(labels, w, h);
        dilate(labels, w, h);
    }
    if cleanup == Cleanup::OpenClose {
        dilate(labels, w, h);
        erode(labels, w, h);
    }
    let foreground = labels.iter().filter(|&&v| v != 0).count();
    Ok(MaskStats {
        threshold: tau,
        foreground,
    })
}

/// Otsu's level of a 256-bin histogram: the `t` that maximises `w0·w1·(μ0 − μ1)²` with class 0
/// the values `≤ t`; the first such `t`, 0 when none gives a positive value.
///
/// ```
/// let mut hist = [0u32; 256];
/// hist[10] = 100;
/// hist[200] = 50;
/// let t = vorl_core::mask::otsu_level(&hist);
/// assert!((10..200).contains(&t));
/// ```
pub fn otsu_level(hist: &[u32; 256]) -> u8 {
    let total: f64 = hist.iter().map(|&c| c as f64).sum();
    let total_sum: f64 = hist.iter().enumerate().map(|(v, &c)| v as f64 * c as f64).sum();
    let (mut w0, mut sum0) = (0.0f64, 0.0f64);
    let (mut best, mut best_t) = (0.0f64, 0u8);
    for (t, &c) in hist.iter().enumerate() {
        w0 += c as f64;
        sum0 += t as f64 * c as f64;
        let w1 = total - w0;
        if w0 == 0.0 {
            continue;
        }
        if w1 == 0.0 {
            break;
        }
        let mu0 = sum0 / w0;
        let mu1 = (total_sum - sum0) / w1;
        let v = w0 * w1 * (mu0 - mu1) * (mu0 - mu1);
        if v > best {
            best = v;
            best_t = t as u8;
        }
    }
    best_t
}

/// Bit 0 of every pixel becomes the AND (erode) or OR (dilate) of bit 0 over its in-image 3×3
/// neighbourhood; bit 1 is scratch and is cleared afterwards.
fn morph(plane: &mut [u8], w: usize, h: usize, erode: bool) {
    if w == 0 || h == 0 {
        return;
    }
    // Horizontal pass: bit 1 = combination of bit 0 at x−1, x, x+1.
    for row in plane.chunks_exact_mut(w).take(h) {
        let mut prev = row.first().map_or(0, |v| v & 1);
        let len = row.len();
        for x in 0..len {
            let cur = row.get(x).map_or(0, |v| v & 1);
            let next = if x + 1 < len {
                row.get(x + 1).map_or(0, |v| v & 1)
            } else {
                cur
            };
            let v = if erode { prev & cur & next } else { prev | cur | next };
            if let Some(p) = row.get_mut(x) {
                *p = (*p & 1) | (v << 1);
            }
            prev = cur;
        }
    }
    // Vertical pass: bit 0 = combination of bit 1 at y−1, y, y+1.
    for y in 0..h {
        let (before, rest) = plane.split_at_mut(y * w);
        let (cur, after) = rest.split_at_mut(w.min(rest.len()));
        let up = if y > 0 { before.get((y - 1) * w..) } else { None };
        let down = if y + 1 < h { after.get(..w) } else { None };
        for (x, p) in cur.iter_mut().enumerate() {
            let c = (*p >> 1) & 1;
            let u = up.and_then(|r| r.get(x)).map_or(c, |v| (v >> 1) & 1);
            let d = down.and_then(|r| r.get(x)).map_or(c, |v| (v >> 1) & 1);
            let v = if erode { u & c & d } else { u | c | d };
            // Keep bit 1 for the next row's pass; it is cleared below.
            *p = (*p & 2) | v;
        }
    }
    for p in plane.iter_mut() {
        *p &= 1;
    }
}

fn erode(plane: &mut [u8], w: usize, h: usize) {
    morph(plane, w, h, true);
}

fn dilate(plane: &mut [u8], w: usize, h: usize) {
    morph(plane, w, h, false);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane(rows: &[&str]) -> ([u8; 64], usize, usize) {
        let mut p = [0u8; 64];
        let w = rows[0].len();
        for (y, r) in rows.iter().enumerate() {
            for (x, c) in r.bytes().enumerate() {
                p[y * w + x] = (c == b'#') as u8;
            }
        }
        (p, w, rows.len())
    }

    fn show(p: &[u8], w: usize, h: usize) -> [[u8; 8]; 8] {
        let mut out = [[b'.'; 8]; 8];
        for y in 0..h {
            for x in 0..w {
                if p[y * w + x] != 0 {
                    out[y][x] = b'#';
                }
            }
        }
        out
    }

    #[test]
    fn opening_removes_speck_and_keeps_block_at_border() {
        let (mut p, w, h) = plane(&["##....", "##....", "......", "....#.", "......"]);
        erode(&mut p, w, h);
        dilate(&mut p, w, h);
        let (want, _, _) = plane(&["##....", "##....", "......", "......", "......"]);
        assert_eq!(show(&p, w, h), show(&want, w, h));
    }

    #[test]
    fn closing_fills_pinhole() {
        let (mut p, w, h) = plane(&["#####", "#####", "##.##", "#####", "#####"]);
        dilate(&mut p, w, h);
        erode(&mut p, w, h);
        let (want, _, _) = plane(&["#####", "#####", "#####", "#####", "#####"]);
        assert_eq!(show(&p, w, h), show(&want, w, h));
    }
}
