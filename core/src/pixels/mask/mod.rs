//! Foreground mask: `|I' − B| > τ`, then a 3×3 opening (and optionally closing) (paper sections
//! 3.2–3.3).
//!
//! The mask is written into the caller's label plane (`width·height` bytes, one per pixel:
//! 0 background, 1 foreground), which border following then labels in place. The threshold τ is
//! fixed or chosen by Otsu's method on the histogram of the difference (`docs/pipeline-spec.md`
//! §3). [`foreground_mask_spans`] also says where each row holds foreground ([`RowSpans`]), so
//! that the later whole-plane passes (the border scan,
//! [`crate::borders::contour::clear_labels`]) keep to those columns.
//!
//! This file is the definition: the difference, the threshold and the 3×3 clean-up byte by
//! byte (`narrow_mask`, `morph`), which the tests hold the fast path to. The fast path,
//! [`packed`], builds the same mask bit-packed inside the plane itself, in words of 64 pixels
//! (`u64`) on 64-bit targets and of 32 (`u32`) elsewhere (the Cortex-M4); the word size changes
//! the cost, never the mask. Every image of eight pixels or more a row takes the fast path.
//!
//! Time: `O(width·height)`. On the fast path with α = 1 and a fixed τ, each pixel's bytes are
//! read once and written once, and each operation of the clean-up adds two passes over the
//! packed planes, an eighth of the bytes each; Otsu adds one read of frame and background
//! (measured figures: `docs/performance.md`). Memory: none beyond the plane and the spans, and
//! the 1 KiB histogram on the stack ([`foreground_mask`] also keeps its [`RowSpans`] there,
//! 0.5 KiB).

pub mod packed;

use core::ops::Range;

pub(crate) use packed::BYTE_SIMD;
use packed::{fits, packed_mask, WIDE};

use crate::error::{Error, Result};
use crate::pixels::background::Background;
use crate::pixels::enhance::{enhance_row, Alpha};
use crate::pixels::frame::Frame;

/// How the foreground threshold τ is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Threshold {
    /// A fixed τ: foreground where `|I' − B| > τ`.
    Fixed(u8),
    /// Otsu's level of this frame's difference histogram.
    Otsu,
}

/// Which side of the platform a part lies on: the sign of `I' − B` that counts as foreground.
///
/// A part front-lit on a mat is brighter than the platform and throws a shadow darker than it
/// beside itself; with [`Polarity::Brighter`] the shadow is not part (and neither is a dark
/// facet or bore inside the part: it becomes a hole or a notch, the same in the taught template
/// and in every frame). `vorl teach` measures the polarity of the taught part.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Polarity {
    /// `|I' − B| > τ`: parts darker or brighter than the platform (default). The recognizer
    /// then cuts a bright part's shadow off it blob by blob ([`crate::pixels::shadow`]).
    #[default]
    Either,
    /// `B − I' > τ`: parts darker than the platform (dark parts on a backlight).
    Darker,
    /// `I' − B > τ`: parts brighter than the platform (front-lit metal on a dark mat).
    Brighter,
}

impl Polarity {
    /// The difference this polarity thresholds: `|i − b|`, `b − i` or `i − b`, saturated at 0.
    ///
    /// ```
    /// use vorl_core::pixels::mask::Polarity;
    /// assert_eq!(Polarity::Either.difference(10, 50), 40);
    /// assert_eq!(Polarity::Darker.difference(10, 50), 40);
    /// assert_eq!(Polarity::Brighter.difference(10, 50), 0);
    /// assert_eq!(Polarity::Brighter.difference(90, 50), 40);
    /// ```
    #[inline(always)]
    pub fn difference(self, i: u8, b: u8) -> u8 {
        match self {
            Polarity::Either => i.abs_diff(b),
            Polarity::Darker => b.saturating_sub(i),
            Polarity::Brighter => i.saturating_sub(b),
        }
    }
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

impl Cleanup {
    /// The narrowest stroke, px, the clean-up leaves in the mask: 3 after a 3×3 opening (a
    /// thinner one has no pixel whose 3×3 neighbourhood is all foreground), 1 without one.
    ///
    /// ```
    /// use vorl_core::pixels::mask::Cleanup;
    /// assert_eq!(Cleanup::Open.narrowest_kept(), 3.0);
    /// assert_eq!(Cleanup::Off.narrowest_kept(), 1.0);
    /// ```
    pub fn narrowest_kept(self) -> f32 {
        match self {
            Cleanup::Off => 1.0,
            Cleanup::Open | Cleanup::OpenClose => 3.0,
        }
    }
}

/// What [`foreground_mask`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MaskStats {
    /// The τ used (the Otsu level, or the fixed value).
    pub threshold: u8,
    /// Foreground pixels after clean-up.
    pub foreground: usize,
}

/// Row groups a [`RowSpans`] holds: a plane of up to this many rows has a span per row, a
/// taller one a span per group of `2^s` rows (the fewest that make at most this many groups).
pub const SPAN_GROUPS: usize = 256;

/// Pixels per unit of a span's bounds.
const SPAN_UNIT: usize = 32;

/// A span's end that reaches the row's end, however wide the plane (and the empty start).
const SPAN_END: u8 = u8::MAX;

/// Where the rows of a `width × height` plane hold non-zero bytes: per row (per group of rows in
/// a plane of more than [`SPAN_GROUPS`] rows) a range of columns outside which the row is 0.
///
/// [`foreground_mask_spans`] writes them for its mask: a group's span is the hull of the
/// group's foreground, widened to multiples of 32 px (to the row's end from 8160 px on, where
/// the bounds saturate), and empty when the group holds none. Border following labels only
/// foreground pixels, so the spans stay true for the labelled plane:
/// [`crate::borders::contour::trace_borders_in`] scans only inside them and
/// [`crate::borders::contour::clear_labels`] turns labels back into the 0/1 mask only there.
/// `2·SPAN_GROUPS` bytes and three words.
///
/// ```
/// use vorl_core::pixels::mask::RowSpans;
/// let all = RowSpans::full(100, 3);
/// assert_eq!(all.row(2), 0..100);
/// assert!(all.row(3).is_empty());
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RowSpans {
    width: usize,
    height: usize,
    /// Rows per group: `1 << shift`.
    shift: u32,
    /// Per group: the first unit of [`SPAN_UNIT`] pixels and one past the last ([`SPAN_END`]:
    /// to the row's end). Empty when the columns they give are.
    groups: [[u8; 2]; SPAN_GROUPS],
}

impl Default for RowSpans {
    fn default() -> Self {
        Self::new()
    }
}

impl RowSpans {
    /// The spans of a plane of no pixels (`const`, for `static` use).
    pub const fn new() -> Self {
        RowSpans {
            width: 0,
            height: 0,
            shift: 0,
            groups: [[SPAN_END, 0]; SPAN_GROUPS],
        }
    }

    /// Every column of every row of a `width × height` plane (nothing known).
    pub fn full(width: usize, height: usize) -> Self {
        let mut spans = Self::new();
        spans.clear(width, height);
        spans.groups = [[0, SPAN_END]; SPAN_GROUPS];
        spans
    }

    /// No column of a `width × height` plane.
    pub(crate) fn clear(&mut self, width: usize, height: usize) {
        let mut shift = 0;
        while shift < usize::BITS - 1 && (height.saturating_sub(1) >> shift) >= SPAN_GROUPS {
            shift += 1;
        }
        self.width = width;
        self.height = height;
        self.shift = shift;
        self.groups = [[SPAN_END, 0]; SPAN_GROUPS];
    }

    /// The plane's width.
    pub fn width(&self) -> usize {
        self.width
    }

    /// The plane's height.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The columns of row `y` outside which the row is 0 (empty for a row outside the plane).
    #[inline]
    pub fn row(&self, y: usize) -> Range<usize> {
        if y >= self.height {
            return 0..0;
        }
        let [lo, hi] = self.groups.get(y >> self.shift).copied().unwrap_or([0, SPAN_END]);
        let x0 = (lo as usize * SPAN_UNIT).min(self.width);
        let x1 = if hi == SPAN_END {
            self.width
        } else {
            (hi as usize * SPAN_UNIT).min(self.width)
        };
        x0..x1.max(x0)
    }

    /// Adds columns `x0..x1` of row `y` to its group's span.
    #[inline]
    pub(crate) fn include(&mut self, y: usize, x0: usize, x1: usize) {
        if x0 >= x1 {
            return;
        }
        if let Some([lo, hi]) = self.groups.get_mut(y >> self.shift) {
            *lo = (*lo).min((x0 / SPAN_UNIT).min(SPAN_END as usize) as u8);
            *hi = (*hi).max(x1.div_ceil(SPAN_UNIT).min(SPAN_END as usize) as u8);
        }
    }
}

/// Writes the foreground mask of `frame` against `background` into `labels` (0/1 per pixel).
///
/// ```
/// use vorl_core::{pixels::background::Background, pixels::enhance::Alpha, pixels::mask::{foreground_mask, Cleanup, Polarity, Threshold}, Frame};
/// // A 3×3 bright block on a 7×7 platform.
/// let bg_px = [50u8; 49];
/// let mut frame_px = [50u8; 49];
/// for y in 2..5 { for x in 2..5 { frame_px[y * 7 + x] = 200; } }
/// let a = Alpha::new(1.0).unwrap();
/// let mut bg = Background::new([0u8; 49], 7, 7).unwrap();
/// bg.set_from_frame(&Frame::new_checked(&bg_px[..], 7, 7).unwrap(), a).unwrap();
/// let mut labels = [0u8; 49];
/// let frame = Frame::new_checked(&frame_px[..], 7, 7).unwrap();
/// let stats = foreground_mask(&frame, &bg, a, Threshold::Fixed(30), Polarity::Either, Cleanup::OpenClose, &mut labels).unwrap();
/// assert_eq!(stats.foreground, 9);
/// assert_eq!(labels[3 * 7 + 3], 1);
/// assert_eq!(labels[0], 0);
/// // The block is brighter than the platform: not foreground for parts darker than it.
/// let stats = foreground_mask(&frame, &bg, a, Threshold::Fixed(30), Polarity::Darker, Cleanup::OpenClose, &mut labels).unwrap();
/// assert_eq!(stats.foreground, 0);
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
    polarity: Polarity,
    cleanup: Cleanup,
    labels: &mut [u8],
) -> Result<MaskStats> {
    let mut spans = RowSpans::new();
    foreground_mask_spans(
        frame, background, alpha, threshold, polarity, cleanup, labels, &mut spans,
    )
}

/// [`foreground_mask`], also writing where each row holds foreground into `spans` (see
/// [`RowSpans`]; unchanged on an error).
///
/// ```
/// use vorl_core::{pixels::background::Background, pixels::enhance::Alpha, pixels::mask::{foreground_mask_spans, Cleanup, Polarity, RowSpans, Threshold}, Frame};
/// // A 4×3 bright block at x = 40..44 on a 100×6 platform.
/// let bg_px = [50u8; 600];
/// let mut frame_px = [50u8; 600];
/// for y in 1..4 { for x in 40..44 { frame_px[y * 100 + x] = 200; } }
/// let mut bg = Background::new([0u8; 600], 100, 6).unwrap();
/// bg.set_from_frame(&Frame::new_checked(&bg_px[..], 100, 6).unwrap(), Alpha::ONE).unwrap();
/// let (mut labels, mut spans) = ([0u8; 600], RowSpans::new());
/// let frame = Frame::new_checked(&frame_px[..], 100, 6).unwrap();
/// foreground_mask_spans(&frame, &bg, Alpha::ONE, Threshold::Fixed(30), Polarity::Either, Cleanup::Open, &mut labels, &mut spans).unwrap();
/// assert_eq!(spans.row(2), 32..64);
/// assert!(spans.row(0).is_empty());
/// ```
///
/// # Errors
/// As [`foreground_mask`].
#[allow(clippy::too_many_arguments)]
pub fn foreground_mask_spans<B: AsRef<[u8]>, S: AsRef<[u8]> + AsMut<[u8]>>(
    frame: &Frame<B>,
    background: &Background<S>,
    alpha: Alpha,
    threshold: Threshold,
    polarity: Polarity,
    cleanup: Cleanup,
    labels: &mut [u8],
    spans: &mut RowSpans,
) -> Result<MaskStats> {
    mask_with::<WIDE, B, S>(frame, background, alpha, threshold, polarity, cleanup, labels, spans)
}

/// [`foreground_mask_spans`] with 64-bit words where they fit (`WIDE64`) or 32-bit ones.
#[allow(clippy::too_many_arguments)]
fn mask_with<const WIDE64: bool, B: AsRef<[u8]>, S: AsRef<[u8]> + AsMut<[u8]>>(
    frame: &Frame<B>,
    background: &Background<S>,
    alpha: Alpha,
    threshold: Threshold,
    polarity: Polarity,
    cleanup: Cleanup,
    labels: &mut [u8],
    spans: &mut RowSpans,
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
    let Some(labels) = labels.get_mut(..n) else {
        return Err(Error::BufferTooSmall {
            needed: n,
            got: labels.len(),
        });
    };
    let otsu = threshold == Threshold::Otsu;
    if n == 0 {
        // Unreachable through `Frame` (no empty frames), but keeps `chunks_exact(0)` out.
        spans.clear(w, h);
        let threshold = if let Threshold::Fixed(t) = threshold { t } else { 0 };
        return Ok(MaskStats {
            threshold,
            foreground: 0,
        });
    }
    let bg = background.plane();
    // With α = 1 and either polarity, I' = I: every pass reads the frame itself and D is never
    // stored. Otherwise D (`|I' − B|`, or its one side: [`Polarity::difference`]) goes into the
    // plane first (one Sobel per pixel dominates then; a one-sided D costs one more pass).
    let direct = alpha.get() >= 1.0 && polarity == Polarity::Either;
    let mut hist = [0u32; 256];
    if direct {
        if otsu {
            for (y, brow) in bg.chunks_exact(w.max(1)).enumerate() {
                for (&f, &b) in frame.row(y).iter().zip(brow) {
                    hist[f.abs_diff(b) as usize] += 1;
                }
            }
        }
    } else {
        for (y, (row, brow)) in labels
            .chunks_exact_mut(w.max(1))
            .zip(bg.chunks_exact(w.max(1)))
            .enumerate()
        {
            enhance_row(frame, y, alpha, row);
            for (d, &b) in row.iter_mut().zip(brow) {
                *d = polarity.difference(*d, b);
            }
            if otsu {
                for &d in row.iter() {
                    hist[d as usize] += 1;
                }
            }
        }
    }
    let tau = match threshold {
        Threshold::Fixed(t) => t,
        Threshold::Otsu => otsu_level(&hist),
    };
    let input = Input { frame, bg, direct, tau };
    let foreground = if WIDE64 && fits::<u64>(w) {
        packed_mask::<u64, B>(&input, cleanup, labels, spans)
    } else if fits::<u32>(w) {
        packed_mask::<u32, B>(&input, cleanup, labels, spans)
    } else {
        narrow_mask(&input, cleanup, labels, spans)
    };
    Ok(MaskStats {
        threshold: tau,
        foreground,
    })
}

/// What the mask is made from: the frame and background (`direct`, α = 1) or `D` in the plane,
/// and τ.
struct Input<'a, B> {
    frame: &'a Frame<B>,
    bg: &'a [u8],
    direct: bool,
    tau: u8,
}

/// The mask of an image too narrow for two packed planes of 32-bit words (under 8 pixels), byte
/// by byte: threshold, then the byte-wise clean-up. `labels` holds `D` unless `direct`. Returns
/// the foreground count.
fn narrow_mask<B: AsRef<[u8]>>(
    input: &Input<'_, B>,
    cleanup: Cleanup,
    labels: &mut [u8],
    spans: &mut RowSpans,
) -> usize {
    let (frame, bg, tau) = (input.frame, input.bg, input.tau);
    let (w, h) = (frame.width(), frame.height());
    if input.direct {
        for (y, (row, brow)) in labels
            .chunks_exact_mut(w.max(1))
            .zip(bg.chunks_exact(w.max(1)))
            .enumerate()
        {
            for (o, (&f, &b)) in row.iter_mut().zip(frame.row(y).iter().zip(brow)) {
                *o = u8::from(f.abs_diff(b) > tau);
            }
        }
    } else {
        for d in labels.iter_mut() {
            *d = u8::from(*d > tau);
        }
    }
    if cleanup != Cleanup::Off {
        erode(labels, w, h);
        dilate(labels, w, h);
    }
    if cleanup == Cleanup::OpenClose {
        dilate(labels, w, h);
        erode(labels, w, h);
    }
    spans.clear(w, h);
    for (y, row) in labels.chunks_exact(w.max(1)).enumerate() {
        if let (Some(x0), Some(x1)) = (row.iter().position(|&v| v != 0), row.iter().rposition(|&v| v != 0)) {
            spans.include(y, x0, x1 + 1);
        }
    }
    labels.iter().filter(|&&v| v != 0).count()
}

/// Otsu's level of a 256-bin histogram: the `t` that maximises `w0·w1·(μ0 − μ1)²` with class 0
/// the values `≤ t`; the first such `t`, 0 when none gives a positive value.
///
/// ```
/// let mut hist = [0u32; 256];
/// hist[10] = 100;
/// hist[200] = 50;
/// let t = vorl_core::pixels::mask::otsu_level(&hist);
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
/// neighbourhood; bit 1 is scratch and is cleared afterwards. The clean-up of images narrower
/// than 8 pixels (see [`narrow_mask`]).
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
        let Some((before, rest)) = plane.split_at_mut_checked(y * w) else {
            break;
        };
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
    use super::packed::*;
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

    /// The implementation before the bit-packed clean-up (commit 4e286b2) as the oracle: D into
    /// the plane, threshold, byte-wise separable erosion and dilation.
    fn reference_mask<B: AsRef<[u8]>, S: AsRef<[u8]> + AsMut<[u8]>>(
        frame: &Frame<B>,
        background: &Background<S>,
        alpha: Alpha,
        threshold: Threshold,
        polarity: Polarity,
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
        let mut hist = [0u32; 256];
        for (y, (row, brow)) in labels.chunks_exact_mut(w).zip(bg.chunks_exact(w)).enumerate() {
            enhance_row(frame, y, alpha, row);
            for (d, &b) in row.iter_mut().zip(brow) {
                // Written out rather than through `Polarity::difference`: the oracle's own.
                *d = match polarity {
                    Polarity::Either => d.abs_diff(b),
                    Polarity::Darker => (b as i16 - *d as i16).max(0) as u8,
                    Polarity::Brighter => (*d as i16 - b as i16).max(0) as u8,
                };
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
        // The byte-wise passes of that implementation live on unchanged as `morph` (the
        // clean-up of images narrower than 8 pixels).
        if cleanup != Cleanup::Off {
            morph(labels, w, h, true);
            morph(labels, w, h, false);
        }
        if cleanup == Cleanup::OpenClose {
            morph(labels, w, h, false);
            morph(labels, w, h, true);
        }
        let foreground = labels.iter().filter(|&&v| v != 0).count();
        Ok(MaskStats {
            threshold: tau,
            foreground,
        })
    }

    use crate::test_rng::XorShiftStar as Rng;

    const MAX_PX: usize = 160 * 48;

    /// Runs both implementations on the same inputs (the label buffer pre-filled with garbage and
    /// longer than the frame) and asserts identical buffers and stats.
    #[allow(clippy::too_many_arguments)]
    fn assert_same(
        frame_px: &[u8],
        bg_px: &[u8],
        w: usize,
        h: usize,
        alpha: f32,
        threshold: Threshold,
        cleanup: Cleanup,
        garbage: u8,
    ) {
        let a = Alpha::new(alpha).unwrap();
        let frame = Frame::new_checked(frame_px, w, h).unwrap();
        let mut bg = Background::new([0u8; MAX_PX], w, h).unwrap();
        bg.set_from_frame(&Frame::new_checked(bg_px, w, h).unwrap(), a).unwrap();
        let n = w * h;
        for polarity in [Polarity::Either, Polarity::Darker, Polarity::Brighter] {
            let mut want = [garbage; MAX_PX + 8];
            let want_stats = reference_mask(&frame, &bg, a, threshold, polarity, cleanup, &mut want[..n + 8]).unwrap();
            // The public entry, and each word size forced (32-bit words are the Cortex-M4's).
            for form in 0..3 {
                let mut got = [garbage; MAX_PX + 8];
                let mut spans = RowSpans::full(3, 3);
                let labels = &mut got[..n + 8];
                let got_stats = match form {
                    0 => foreground_mask_spans(&frame, &bg, a, threshold, polarity, cleanup, labels, &mut spans),
                    1 => mask_with::<false, _, _>(&frame, &bg, a, threshold, polarity, cleanup, labels, &mut spans),
                    _ => mask_with::<true, _, _>(&frame, &bg, a, threshold, polarity, cleanup, labels, &mut spans),
                }
                .unwrap();
                assert_eq!(
                    got_stats, want_stats,
                    "{w}×{h} α={alpha} {threshold:?} {polarity:?} {cleanup:?} form {form}"
                );
                if got[..n + 8] != want[..n + 8] {
                    let i = got.iter().zip(&want).position(|(g, w)| g != w).unwrap();
                    panic!(
                    "{w}×{h} α={alpha} {threshold:?} {polarity:?} {cleanup:?} form {form}: first difference at ({}, {}): {} vs {}",
                    i % w,
                    i / w,
                    got[i],
                    want[i]
                );
                }
                assert_spans(&want[..n], w, h, &spans);
                if form == 0 {
                    assert_spans_serve_borders(&want[..n], w, h, &spans);
                }
            }
        }
    }

    /// The mask's spans serve border following: the scan within them gives what the whole
    /// plane's scan gives, and clearing the labels within them leaves the mask again.
    fn assert_spans_serve_borders(mask: &[u8], w: usize, h: usize, spans: &RowSpans) {
        use crate::borders::contour::{clear_labels, trace_borders, trace_borders_in, BorderFilter, ContourStore};
        let filter = BorderFilter {
            min_points: 1,
            min_area: 0.0,
        };
        let n = mask.len();
        let (mut within, mut whole) = ([0u8; MAX_PX], [0u8; MAX_PX]);
        within[..n].copy_from_slice(mask);
        whole[..n].copy_from_slice(mask);
        let (mut a, mut b) = (ContourStore::<1024, 64>::new(), ContourStore::<1024, 64>::new());
        let got = trace_borders_in(&mut within[..n], w, h, spans, filter, &mut a);
        let want = trace_borders(&mut whole[..n], w, h, filter, &mut b);
        assert_eq!(got, want, "{w}×{h}");
        assert!(within[..n] == whole[..n], "{w}×{h}: labels");
        assert_eq!(a.contours(), b.contours());
        for i in 0..a.contours().len() {
            assert_eq!(a.points(i), b.points(i));
        }
        clear_labels(&mut within[..n], w, h, spans);
        assert!(within[..n] == *mask, "{w}×{h}: cleared labels");
    }

    /// `spans` are those of the 0/1 plane `labels`: per group of rows (`2^s` rows, the fewest
    /// that make at most [`SPAN_GROUPS`] groups), the hull of its foreground widened to
    /// multiples of 32 px (to the row's end when that lies at or past 255·32), empty without
    /// foreground.
    fn assert_spans(labels: &[u8], w: usize, h: usize, spans: &RowSpans) {
        assert_eq!((spans.width(), spans.height()), (w, h));
        let rows = (1usize..)
            .find(|&g| g.is_power_of_two() && h.div_ceil(g) <= SPAN_GROUPS)
            .unwrap();
        for g0 in (0..h).step_by(rows) {
            let group = g0..(g0 + rows).min(h);
            let (mut lo, mut hi) = (usize::MAX, 0);
            for y in group.clone() {
                for (x, &v) in labels[y * w..(y + 1) * w].iter().enumerate() {
                    if v != 0 {
                        (lo, hi) = (lo.min(x), hi.max(x + 1));
                    }
                }
            }
            for y in group {
                let got = spans.row(y);
                if lo == usize::MAX {
                    assert!(got.is_empty(), "{w}×{h} row {y}: {got:?} for no foreground");
                } else {
                    let end = if hi.div_ceil(32) >= 255 {
                        w
                    } else {
                        (hi.div_ceil(32) * 32).min(w)
                    };
                    assert_eq!(
                        got,
                        (lo / 32 * 32).min(8160)..end,
                        "{w}×{h} row {y}: foreground {lo}..{hi}"
                    );
                }
            }
        }
        assert!(spans.row(h).is_empty());
    }

    #[test]
    fn packed_mask_equals_reference_on_random_frames() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut frame_px = [0u8; MAX_PX];
        let mut bg_px = [0u8; MAX_PX];
        let widths = [
            1usize, 2, 3, 5, 7, 8, 9, 15, 16, 31, 32, 33, 63, 64, 65, 96, 100, 127, 129, 160,
        ];
        for case in 0..3000 {
            let w = if case % 2 == 0 {
                widths[rng.below(widths.len() as u64) as usize]
            } else {
                1 + rng.below(160) as usize
            };
            // Every fourth frame as tall as fits: over 256 rows the spans are per group of rows.
            let tall = if case % 4 == 3 {
                MAX_PX / w
            } else {
                (MAX_PX / w).min(48)
            };
            let h = 1 + rng.below(tall as u64) as usize;
            let n = w * h;
            // Background: noise around a level; frame: the background plus noise, with a few
            // rectangles and scattered specks far from it (density varies per case).
            let level = rng.below(256) as u8;
            let spread = 1 + rng.below(40) as u8;
            for p in bg_px[..n].iter_mut() {
                *p = level.saturating_add((rng.below(spread as u64)) as u8);
            }
            let noise = 1 + rng.below(30);
            for (f, &b) in frame_px[..n].iter_mut().zip(&bg_px[..n]) {
                let d = rng.below(noise) as i32 - (noise / 2) as i32;
                *f = (b as i32 + d).clamp(0, 255) as u8;
            }
            let specks = rng.below(1 + n as u64 / 4);
            for _ in 0..specks {
                let i = rng.below(n as u64) as usize;
                frame_px[i] = rng.below(256) as u8;
            }
            for _ in 0..rng.below(6) {
                let (x0, y0) = (rng.below(w as u64) as usize, rng.below(h as u64) as usize);
                let (rw, rh) = (1 + rng.below(12) as usize, 1 + rng.below(12) as usize);
                let v = rng.below(256) as u8;
                for y in y0..(y0 + rh).min(h) {
                    for x in x0..(x0 + rw).min(w) {
                        frame_px[y * w + x] = v;
                    }
                }
            }
            let alpha = match rng.below(6) {
                0 => 0.0,
                1 => 0.5,
                2 => rng.below(1000) as f32 / 1000.0,
                _ => 1.0,
            };
            let threshold = match rng.below(4) {
                0 => Threshold::Otsu,
                1 => Threshold::Fixed(rng.below(256) as u8),
                _ => Threshold::Fixed(rng.below(40) as u8),
            };
            let garbage = rng.below(256) as u8;
            for cleanup in [Cleanup::Off, Cleanup::Open, Cleanup::OpenClose] {
                assert_same(&frame_px[..n], &bg_px[..n], w, h, alpha, threshold, cleanup, garbage);
            }
        }
    }

    /// Every mask of up to 16 pixels on the shapes where packing starts (w = 8..16) and on the
    /// narrow ones, through all three clean-ups.
    #[test]
    fn packed_mask_equals_reference_on_every_small_mask() {
        let bg_px = [0u8; 16];
        let mut frame_px = [0u8; 16];
        for (w, h) in [
            (8, 1),
            (8, 2),
            (9, 1),
            (12, 1),
            (16, 1),
            (1, 8),
            (2, 8),
            (3, 5),
            (4, 4),
            (7, 2),
            (1, 1),
        ] {
            let n: usize = w * h;
            for bits in 0u32..1 << n {
                for (i, f) in frame_px[..n].iter_mut().enumerate() {
                    *f = if bits >> i & 1 == 1 { 200 } else { 0 };
                }
                for cleanup in [Cleanup::Off, Cleanup::Open, Cleanup::OpenClose] {
                    assert_same(
                        &frame_px[..n],
                        &bg_px[..n],
                        w,
                        h,
                        1.0,
                        Threshold::Fixed(100),
                        cleanup,
                        0xAA,
                    );
                }
            }
        }
    }

    #[test]
    fn mask_errors_and_short_buffers() {
        let a = Alpha::ONE;
        let frame_px = [9u8; 40];
        let frame = Frame::new_checked(&frame_px[..], 10, 4).unwrap();
        let bg = Background::new([0u8; 40], 10, 4).unwrap();
        let mut labels = [0u8; 40];
        assert_eq!(
            foreground_mask(
                &frame,
                &bg,
                a,
                Threshold::Otsu,
                Polarity::Either,
                Cleanup::Open,
                &mut labels
            ),
            Err(Error::NoBackground)
        );
        let mut bg = bg;
        bg.set_from_frame(&frame, a).unwrap();
        assert!(matches!(
            foreground_mask(
                &frame,
                &bg,
                a,
                Threshold::Otsu,
                Polarity::Either,
                Cleanup::Open,
                &mut labels[..39]
            ),
            Err(Error::BufferTooSmall { needed: 40, got: 39 })
        ));
        let small = Frame::new_checked(&frame_px[..], 8, 4).unwrap();
        assert!(matches!(
            foreground_mask(
                &small,
                &bg,
                a,
                Threshold::Otsu,
                Polarity::Either,
                Cleanup::Open,
                &mut labels
            ),
            Err(Error::FrameSize { .. })
        ));
        assert!(Frame::new_checked(&frame_px[..], 0, 4).is_err());
    }

    /// A frame with a stride wider than its width reads only the pixels of each row.
    #[test]
    fn strided_frame_equals_reference() {
        let (w, h, stride) = (40usize, 6usize, 47usize);
        let mut px = [0u8; 47 * 6];
        let mut rng = Rng(7);
        for p in px.iter_mut() {
            *p = rng.below(256) as u8;
        }
        let frame = Frame::with_stride(&px[..], w, h, stride).unwrap();
        let mut bg = Background::new([0u8; 240], w, h).unwrap();
        bg.set_from_frame(&Frame::new_checked(&[100u8; 240][..], w, h).unwrap(), Alpha::ONE)
            .unwrap();
        for alpha in [1.0, 0.3] {
            for threshold in [Threshold::Fixed(60), Threshold::Otsu] {
                for cleanup in [Cleanup::Off, Cleanup::Open, Cleanup::OpenClose] {
                    let a = Alpha::new(alpha).unwrap();
                    let (mut got, mut want) = ([3u8; 240], [3u8; 240]);
                    let g = foreground_mask(&frame, &bg, a, threshold, Polarity::Either, cleanup, &mut got).unwrap();
                    let r = reference_mask(&frame, &bg, a, threshold, Polarity::Either, cleanup, &mut want).unwrap();
                    assert_eq!((g, got), (r, want));
                }
            }
        }
    }

    /// [`exceeds`] on the bytes `fa` and `fb` (the first `W::BYTES`) against the scalar test.
    fn check_exceeds<W: Word>(fa: [u8; 8], fb: [u8; 8], tau: u8) {
        let mut got = [0u8; 8];
        exceeds(W::load(&fa), W::load(&fb), swar_bias::<W>(tau)).store(&mut got);
        for i in 0..W::BYTES {
            let want = if fa[i].abs_diff(fb[i]) > tau { 0x80 } else { 0 };
            assert_eq!(got[i], want, "{} bytes: a={fa:?} b={fb:?} τ={tau}", W::BYTES);
        }
    }

    /// The four-pixel threshold against the scalar one for every `(a, b, τ)` in every byte
    /// position, next to varied neighbours (a carry between lanes would show).
    #[test]
    fn exceeds4_matches_scalar_for_every_pair_and_threshold() {
        for tau in 0..=255u8 {
            for a in 0..=255u8 {
                for b in 0..=255u8 {
                    let fa = [a, b, 255 - a, a ^ 0x5a];
                    let fb = [b, a, b.wrapping_add(tau), 0];
                    for r in 0..4 {
                        let (mut x, mut y) = ([0u8; 8], [0u8; 8]);
                        for i in 0..4 {
                            (x[(i + r) % 4], y[(i + r) % 4]) = (fa[i], fb[i]);
                        }
                        check_exceeds::<u32>(x, y, tau);
                    }
                }
            }
        }
    }

    /// The eight-pixel threshold (64-bit words) against the scalar one for every `(a, τ)`, with
    /// `b` at and around `a ± τ`, the ends and at random, in every byte position.
    #[test]
    fn exceeds8_matches_scalar_around_every_threshold() {
        let mut rng = Rng(0xe8);
        for tau in 0..=255u8 {
            for a in 0..=255u8 {
                let (up, down) = (a.saturating_add(tau), a.saturating_sub(tau));
                let near = [
                    up,
                    up.saturating_add(1),
                    up.saturating_sub(1),
                    down,
                    down.saturating_add(1),
                ];
                let far = [
                    down.saturating_sub(1),
                    0,
                    255,
                    a,
                    rng.below(256) as u8,
                    rng.below(256) as u8,
                ];
                for (j, &b) in near.iter().chain(&far).enumerate() {
                    let r = j % 8;
                    let mut x: [u8; 8] = core::array::from_fn(|_| rng.below(256) as u8);
                    let mut y: [u8; 8] = core::array::from_fn(|_| rng.below(256) as u8);
                    (x[r], y[r]) = (a, b);
                    (x[(r + 1) % 8], y[(r + 1) % 8]) = (b, a);
                    check_exceeds::<u64>(x, y, tau);
                }
            }
        }
    }

    /// Packing and expanding a word round-trips every pixel through the interleaved layout:
    /// pixel `x` at bit `8·(x mod BYTES) + x div BYTES`.
    fn layout_round_trips<W: Word>(seed: u64) {
        let mut rng = Rng(seed);
        for x in 0..W::PX {
            let mut want = [0u8; 8];
            want[x % W::BYTES] = 1 << (x / W::BYTES);
            let mut got = [0u8; 8];
            bit::<W>(x).store(&mut got);
            assert_eq!(got, want, "{} px: pixel {x}", W::PX);
        }
        for _ in 0..1000 {
            let f: [u8; 64] = core::array::from_fn(|_| if rng.below(2) == 1 { 200 } else { 0 });
            let f = &f[..W::PX];
            let bits = pack_swar::<W>(f, &ZEROS, swar_bias(100));
            assert!(bits == pack_tail(f, &ZEROS, 100));
            for (x, &v) in f.iter().enumerate() {
                assert_eq!(bits & bit::<W>(x) != W::ZERO, v != 0);
            }
            let mut out = [9u8; 64];
            bits.expand(&mut out);
            assert!(out[..W::PX].iter().zip(f).all(|(&o, &v)| o * 200 == v));
            assert!(out[W::PX..].iter().all(|&o| o == 9));
            let len = rng.below(W::PX as u64) as usize;
            let mut tail = [9u8; 64];
            expand_tail(&mut tail[..len], bits);
            assert_eq!(tail[..len], out[..len]);
            assert_eq!(bits.ones(), f.iter().filter(|&&v| v != 0).count());
        }
    }

    #[test]
    fn packed_layout_round_trips() {
        layout_round_trips::<u32>(11);
        layout_round_trips::<u64>(12);
    }

    /// Both forms of the threshold and pack (the SIMD one runs on the host, the SWAR one on the
    /// Cortex-M4) give the same word, and the expansions give the same bytes, on random pixels
    /// and thresholds (differences near τ included) and on every single-pixel word.
    fn forms_agree<W: Word>(seed: u64) {
        let mut rng = Rng(seed);
        for case in 0..20_000 {
            let tau = rng.below(256) as u8;
            let b: [u8; 64] = core::array::from_fn(|_| rng.below(256) as u8);
            let f: [u8; 64] = core::array::from_fn(|i| match case % 3 {
                0 => rng.below(256) as u8,
                // Differences of exactly τ, τ + 1 and τ − 1 either way.
                1 => {
                    let d = (tau as i32 + rng.below(3) as i32 - 1) * if rng.below(2) == 0 { 1 } else { -1 };
                    (b[i] as i32 + d).clamp(0, 255) as u8
                }
                _ => b[i].wrapping_add(rng.below(3) as u8),
            });
            let (f, b) = (&f[..W::PX], &b[..W::PX]);
            let want = pack_swar::<W>(f, b, swar_bias(tau));
            assert!(W::pack_simd(f, b, tau) == want, "τ={tau} f={f:?} b={b:?}");
            assert!(pack_word(f, b, tau, swar_bias::<W>(tau)) == want);
            assert!(pack_tail::<W>(f, b, tau) == want);
            let (mut word, mut expanded) = ([5u8; 65], [7u8; 64]);
            want.expand(&mut expanded);
            assert_eq!(expand_word(&mut word, want), want.ones());
            assert_eq!(word[..W::PX], expanded[..W::PX]);
            assert!(word[W::PX..].iter().all(|&v| v == 5));
        }
        for x in 0..W::PX {
            let mut f = [0u8; 64];
            f[x] = 1;
            assert!(W::pack_simd(&f, &ZEROS, 0) == bit(x));
            let mut out = [7u8; 64];
            bit::<W>(x).expand(&mut out);
            assert_eq!(out[..W::PX], f[..W::PX]);
        }
        let mut word = [3u8; 65];
        assert_eq!(expand_word(&mut word, W::ZERO), 0);
        assert!(word[..W::PX].iter().all(|&v| v == 0) && word[W::PX] == 3);
    }

    #[test]
    fn pack_and_expand_forms_agree() {
        forms_agree::<u32>(0x5eed);
        forms_agree::<u64>(0x5eee);
        // The 32-bit expansions of 64-bit hosts and of the Cortex-M4.
        let mut rng = Rng(5);
        for _ in 0..10_000 {
            let bits = rng.below(1 << 32) as u32;
            let (mut wide, mut narrow) = ([7u8; 32], [9u8; 32]);
            expand32_u64(&mut wide, bits);
            expand32(&mut narrow, bits);
            assert_eq!(wide, narrow);
        }
    }

    /// [`horizontal`] against its definition pixel by pixel: each pixel combined with its left
    /// and right neighbours, the last pixel of `prev` and the first of `next` at the ends.
    fn horizontal_matches_definition<W: Word>(seed: u64) {
        let mut rng = Rng(seed);
        let px = |v: W, x: usize| v & bit::<W>(x) != W::ZERO;
        for _ in 0..5000 {
            let mut word = || {
                let mut b = [0u8; 8];
                for v in b.iter_mut() {
                    *v = rng.below(256) as u8;
                }
                W::load(&b)
            };
            let (prev, cur, next) = (word(), word(), word());
            let (e, d) = (
                horizontal::<W, true>(prev, cur, next),
                horizontal::<W, false>(prev, cur, next),
            );
            for x in 0..W::PX {
                let left = if x == 0 { px(prev, W::PX - 1) } else { px(cur, x - 1) };
                let right = if x + 1 == W::PX { px(next, 0) } else { px(cur, x + 1) };
                assert_eq!(px(e, x), left && px(cur, x) && right, "{} px: erode pixel {x}", W::PX);
                assert_eq!(px(d, x), left || px(cur, x) || right, "{} px: dilate pixel {x}", W::PX);
            }
        }
    }

    #[test]
    fn horizontal_pass_matches_definition() {
        horizontal_matches_definition::<u32>(21);
        horizontal_matches_definition::<u64>(22);
    }

    /// A packed plane of `W` words for a `w × h` image, random bits in every pixel and 0 past
    /// the image (as the pack leaves it).
    fn random_plane<W: Word>(rng: &mut Rng, g: &Geometry<W>, density: u64) -> [u8; 4096] {
        let mut p = [0u8; 4096];
        for y in 0..g.h {
            for x in 0..g.w {
                if rng.below(100) < density {
                    let i = y * g.row_bytes + (x / W::PX) * W::BYTES;
                    let word = W::load(&p[i..]) | bit::<W>(x % W::PX);
                    word.store(&mut p[i..]);
                }
            }
        }
        p
    }

    /// Pixel `(x, y)` of a packed plane.
    fn pixel<W: Word>(p: &[u8], g: &Geometry<W>, x: usize, y: usize) -> bool {
        W::load(&p[y * g.row_bytes + (x / W::PX) * W::BYTES..]) & bit::<W>(x % W::PX) != W::ZERO
    }

    /// The vertical pass and both forms of the horizontal pass (the SIMD one runs on the host,
    /// the carried one on the Cortex-M4) against their definitions pixel by pixel, for both word
    /// sizes and operations, on random planes of every shape from one word to several per row
    /// (row ends inside and at the end of a word), 1 to 12 rows.
    fn passes_match_definition<W: Word>(seed: u64) {
        let mut rng = Rng(seed);
        for case in 0..3000 {
            let w = 1 + rng.below(4 * W::PX as u64) as usize;
            let h = 1 + rng.below(12) as usize;
            let g = Geometry::<W>::new(w, h);
            let density = [5, 50, 95][case % 3];
            let src = random_plane::<W>(&mut rng, &g, density);
            for erode in [true, false] {
                let op = |a: bool, b: bool| if erode { a && b } else { a || b };
                let (mut vert, mut simd, mut carried) = ([7u8; 4096], [9u8; 4096], [11u8; 4096]);
                let len = g.packed;
                let (plane, v, s, c) = (&src[..len], &mut vert[..len], &mut simd[..len], &mut carried[..len]);
                if erode {
                    vertical::<W, true>(plane, v, &g);
                    horizontal_form::<W, true, true>(plane, s, &g);
                    horizontal_form::<W, true, false>(plane, c, &g);
                } else {
                    vertical::<W, false>(plane, v, &g);
                    horizontal_form::<W, false, true>(plane, s, &g);
                    horizontal_form::<W, false, false>(plane, c, &g);
                }
                assert_eq!(simd[..g.packed], carried[..g.packed], "{w}×{h} erode={erode}");
                assert!(simd[g.packed..].iter().all(|&v| v == 9) && carried[g.packed..].iter().all(|&v| v == 11));
                for y in 0..h {
                    for x in 0..w {
                        let at = |x: usize, y: usize| pixel::<W>(&src, &g, x, y);
                        let (up, down) = (
                            if y > 0 { at(x, y - 1) } else { at(x, y) },
                            if y + 1 < h { at(x, y + 1) } else { at(x, y) },
                        );
                        assert_eq!(
                            pixel::<W>(&vert, &g, x, y),
                            op(op(up, at(x, y)), down),
                            "vertical {w}×{h} ({x}, {y})"
                        );
                        let (left, right) = (
                            if x > 0 { at(x - 1, y) } else { at(x, y) },
                            if x + 1 < w { at(x + 1, y) } else { at(x, y) },
                        );
                        assert_eq!(
                            pixel::<W>(&simd, &g, x, y),
                            op(op(left, at(x, y)), right),
                            "horizontal {w}×{h} ({x}, {y}) erode={erode}"
                        );
                    }
                    // Nothing past the image in the horizontal pass's rows.
                    let last = y * g.row_bytes + (g.words - 1) * W::BYTES;
                    assert!(W::load(&simd[last..]) & !g.last_valid == W::ZERO);
                }
            }
        }
    }

    #[test]
    fn packed_passes_match_definition() {
        passes_match_definition::<u32>(31);
        passes_match_definition::<u64>(32);
    }

    /// Spans of planes wider than 255·32 px: the start saturates (never past the foreground),
    /// an end at or past 255·32 px reaches the row's end; tall planes group their rows.
    #[test]
    fn spans_saturate_and_group() {
        let mut s = RowSpans::new();
        s.clear(9000, 3);
        s.include(0, 8200, 8300);
        s.include(1, 100, 8130);
        s.include(2, 8100, 8128);
        assert_eq!((s.row(0), s.row(1), s.row(2)), (8160..9000, 96..9000, 8096..8128));
        s.include(2, 10, 20);
        assert_eq!(s.row(2), 0..8128);
        assert!(s.row(3).is_empty());
        s.clear(40, 600);
        s.include(301, 33, 34);
        // 600 rows: groups of 4.
        assert_eq!((s.row(300), s.row(303)), (32..40, 32..40));
        assert!(s.row(299).is_empty() && s.row(304).is_empty());
        assert_eq!(RowSpans::full(40, 600).row(599), 0..40);
        // A wide frame through the mask: two blocks at the ends of one row.
        let (w, h) = (8300usize, 2usize);
        let mut frame_px = [10u8; 8300 * 2];
        for y in 0..h {
            for x in (5..12).chain(8250..8290) {
                frame_px[y * w + x] = 200;
            }
        }
        let bg_px = [10u8; 8300 * 2];
        let mut bg = Background::new([0u8; 8300 * 2], w, h).unwrap();
        bg.set_from_frame(&Frame::new_checked(&bg_px[..], w, h).unwrap(), Alpha::ONE)
            .unwrap();
        let frame = Frame::new_checked(&frame_px[..], w, h).unwrap();
        for cleanup in [Cleanup::Off, Cleanup::Open, Cleanup::OpenClose] {
            let (mut got, mut want) = ([1u8; 8300 * 2], [2u8; 8300 * 2]);
            let mut spans = RowSpans::new();
            let g = foreground_mask_spans(
                &frame,
                &bg,
                Alpha::ONE,
                Threshold::Fixed(50),
                Polarity::Either,
                cleanup,
                &mut got,
                &mut spans,
            );
            let r = reference_mask(
                &frame,
                &bg,
                Alpha::ONE,
                Threshold::Fixed(50),
                Polarity::Either,
                cleanup,
                &mut want,
            );
            assert_eq!(g, r);
            assert!(
                got == want,
                "{cleanup:?}: first difference at {:?}",
                got.iter().zip(&want).position(|(a, b)| a != b)
            );
            assert_eq!(g.unwrap().foreground, 2 * 47);
            assert_eq!(spans.row(1), 0..8300);
            assert_spans(&want, w, h, &spans);
        }
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
