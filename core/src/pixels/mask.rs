//! Foreground mask: `|I' − B| > τ`, then a 3×3 opening (and optionally closing) (paper sections
//! 3.2–3.3).
//!
//! The mask is written into the caller's label plane (`width·height` bytes, one per pixel:
//! 0 background, 1 foreground), which border following then labels in place. The threshold τ is
//! fixed or chosen by Otsu's method on the histogram of the difference (`docs/pipeline-spec.md`
//! §3). [`foreground_mask_spans`] also says where each row holds foreground ([`RowSpans`]), so
//! that the later whole-plane passes (the border scan, [`crate::borders::contour::clear_labels`]) keep to
//! those columns.
//!
//! The mask is built bit-packed inside the plane itself, in words of 64 pixels (`u64`) on
//! 64-bit targets and of 32 (`u32`) elsewhere (the Cortex-M4); the word size changes the cost,
//! never the mask:
//!
//! 1. **Threshold and pack.** With α = 1 (the default: `I' = I`) one pass reads frame and
//!    background and writes the packed mask; nothing else is stored. It tests a word's worth of
//!    bytes at a time (even and odd bytes in 16-bit lanes, where `0x7FFF − τ ± (a − b)` reaches
//!    bit 15 exactly when `|a − b| > τ`), so it is branch-free on a Cortex-M4. Where byte loops
//!    vectorise (SSE2, NEON) the same word comes from byte loops instead: 16 pixels per SIMD
//!    operation, each pixel's flag ANDed with its bit and the eight groups ORed. Otsu first
//!    reads frame and background once more for its histogram. With α < 1, `D = |I' − B|` first
//!    goes into the plane row by row (one Sobel per pixel dominates then), and is packed in
//!    place.
//! 2. **Clean-up.** The packed plane takes the first `⌈w/8⌉·h` bytes or so of the plane (an
//!    eighth of it; at most half); a second packed plane right after it is the scratch. Each
//!    erosion or dilation is a vertical pass (the AND or OR of each word with the words above
//!    and below it) into the scratch plane and a horizontal pass (each pixel with its left and
//!    right neighbours: shifts, plus the end bits of the neighbouring words) back. Both are
//!    flat loops over the whole plane that take no value from one word to the next, so SSE2
//!    and NEON do two 64-bit words per operation; the horizontal pass takes each word's
//!    neighbours in the plane, then sets right each row's two end pixels (a row's first and last
//!    word have a neighbour in another row). The Cortex-M4's form of the horizontal pass carries
//!    the neighbours in registers. Neighbours outside the image count as the operation's
//!    identity, i.e. they are ignored, so a part touching the border is not eaten from that
//!    side.
//! 3. **Expand and count.** The last pass writes the bytes back over the whole plane, last row
//!    first (row `y ≥ 1` lands past every packed row not yet read, row 0 expands in place from its
//!    last word), counts the foreground with `count_ones` and notes each row's first and last
//!    word that holds foreground: the spans. A word of background (most of a frame) is stored as
//!    zero bytes without expanding or counting it.
//!
//! In a word of `8·L` pixels (`L` bytes), pixel `Lq + i` (`q` 0–7, `i` 0–`L−1`) is bit `8i + q`:
//! the flags of `L` pixels (bit 7 of each byte) go in with one shift, and `L` pixels come out as
//! `(word >> q) & 0x0101…01`, one store. Images too narrow for two packed planes (narrower than
//! 16 pixels for 64-bit words, 8 for 32-bit ones) take 32-bit words, or under 8 pixels a
//! byte-wise path, with the same result.
//!
//! Time: `O(width·height)`. With α = 1 and a fixed τ, each pixel's bytes are read once (step 1)
//! and written once (step 3), and each operation of the clean-up adds two passes over the
//! packed planes, an eighth of the bytes each; Otsu adds one read of frame and background. (Measured
//! figures: `docs/performance.md`.) Memory: none beyond the plane and the spans, and the
//! 1 KiB histogram on the stack ([`foreground_mask`] also keeps its [`RowSpans`] there, 0.5 KiB).

use core::ops::{BitAnd, BitOr, Not, Range, Shl, Shr};

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
/// use vorl_core::{pixels::background::Background, pixels::enhance::Alpha, pixels::mask::{foreground_mask, Cleanup, Threshold}, Frame};
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
    let mut spans = RowSpans::new();
    foreground_mask_spans(frame, background, alpha, threshold, cleanup, labels, &mut spans)
}

/// [`foreground_mask`], also writing where each row holds foreground into `spans` (see
/// [`RowSpans`]; unchanged on an error).
///
/// ```
/// use vorl_core::{pixels::background::Background, pixels::enhance::Alpha, pixels::mask::{foreground_mask_spans, Cleanup, RowSpans, Threshold}, Frame};
/// // A 4×3 bright block at x = 40..44 on a 100×6 platform.
/// let bg_px = [50u8; 600];
/// let mut frame_px = [50u8; 600];
/// for y in 1..4 { for x in 40..44 { frame_px[y * 100 + x] = 200; } }
/// let mut bg = Background::new([0u8; 600], 100, 6).unwrap();
/// bg.set_from_frame(&Frame::new_checked(&bg_px[..], 100, 6).unwrap(), Alpha::ONE).unwrap();
/// let (mut labels, mut spans) = ([0u8; 600], RowSpans::new());
/// let frame = Frame::new_checked(&frame_px[..], 100, 6).unwrap();
/// foreground_mask_spans(&frame, &bg, Alpha::ONE, Threshold::Fixed(30), Cleanup::Open, &mut labels, &mut spans).unwrap();
/// assert_eq!(spans.row(2), 32..64);
/// assert!(spans.row(0).is_empty());
/// ```
///
/// # Errors
/// As [`foreground_mask`].
pub fn foreground_mask_spans<B: AsRef<[u8]>, S: AsRef<[u8]> + AsMut<[u8]>>(
    frame: &Frame<B>,
    background: &Background<S>,
    alpha: Alpha,
    threshold: Threshold,
    cleanup: Cleanup,
    labels: &mut [u8],
    spans: &mut RowSpans,
) -> Result<MaskStats> {
    mask_with::<WIDE, B, S>(frame, background, alpha, threshold, cleanup, labels, spans)
}

/// [`foreground_mask_spans`] with 64-bit words where they fit (`WIDE64`) or 32-bit ones.
fn mask_with<const WIDE64: bool, B: AsRef<[u8]>, S: AsRef<[u8]> + AsMut<[u8]>>(
    frame: &Frame<B>,
    background: &Background<S>,
    alpha: Alpha,
    threshold: Threshold,
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
    // With α = 1, I' = I: every pass reads the frame itself and D is never stored. Otherwise
    // D = |I' − B| goes into the plane first (one Sobel per pixel dominates then).
    let direct = alpha.get() >= 1.0;
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
                *d = d.abs_diff(b);
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

/// Whether packed words are 64 bits: on 64-bit targets, where a `u64` costs what a `u32` does.
const WIDE: bool = cfg!(target_pointer_width = "64");

/// Whether the target has 128-bit SIMD registers that LLVM's auto-vectoriser uses for loops
/// over bytes (x86_64's SSE2 baseline, AArch64's NEON, wasm `simd128`). Without them (the
/// Cortex-M4) the SWAR forms are leaner than byte loops.
pub(crate) const BYTE_SIMD: bool = cfg!(any(
    target_feature = "sse2",
    target_feature = "neon",
    target_feature = "simd128"
));

/// The background of the in-place pack (`D` against 0).
const ZEROS: [u8; 64] = [0; 64];

/// A packed word of `PX = 8·BYTES` pixels: pixel `x` is bit `8·(x mod BYTES) + x div BYTES`.
trait Word:
    Copy
    + Eq
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
    + Not<Output = Self>
    + Shl<u32, Output = Self>
    + Shr<u32, Output = Self>
{
    /// Bytes of the word.
    const BYTES: usize;
    /// Pixels of the word.
    const PX: usize = 8 * Self::BYTES;
    /// No bit.
    const ZERO: Self;
    /// Every bit.
    const ONES: Self;
    /// `0x01` in every byte.
    const LOW: Self;
    /// The word's first `PX / 2` pixels (bits 0–3 of every byte).
    const FIRST_HALF: Self;
    /// The little-endian word in the first bytes of `b` (0 when shorter).
    fn load(b: &[u8]) -> Self;
    /// Writes the word little-endian into the first bytes of `b` (nothing when shorter).
    fn store(self, b: &mut [u8]);
    /// Set bits.
    fn ones(self) -> usize;
    /// Wrapping sum.
    fn add(self, other: Self) -> Self;
    /// Wrapping difference.
    fn sub(self, other: Self) -> Self;
    /// `v` in every 16-bit lane.
    fn lanes(v: u16) -> Self;
    /// The same word as [`pack_swar`] from byte loops that LLVM vectorises (16 pixels per SSE2
    /// operation: `|f − b|` as `max − min`, the comparison, the bit of each pixel from a table,
    /// then an OR of the eight groups of `BYTES` bytes, which puts pixel `BYTES·q + i` at bit
    /// `8i + q`). 0 unless `f` and `b` hold `PX` pixels.
    fn pack_simd(f: &[u8], b: &[u8], tau: u8) -> Self;
    /// Writes the word's `PX` pixels as bytes (0 or 1) into `out` (nothing when shorter).
    fn expand(self, out: &mut [u8]);
    /// Writes `PX` zero bytes into `out` (nothing when shorter).
    fn clear(out: &mut [u8]);
}

/// The items of [`Word`] that the two word sizes share, written once: the word type, its
/// bytes, its pixels and the group-bit table of [`Word::pack_simd`].
macro_rules! shared_word_items {
    ($t:ty, $bytes:literal, $px:literal, $groups:expr) => {
        const BYTES: usize = $bytes;
        const ZERO: Self = 0;
        const ONES: Self = <$t>::MAX;
        const LOW: Self = <$t>::from_le_bytes([0x01; $bytes]);
        const FIRST_HALF: Self = <$t>::from_le_bytes([0x0F; $bytes]);
        #[inline(always)]
        fn load(b: &[u8]) -> Self {
            b.first_chunk::<$bytes>().map_or(0, |c| <$t>::from_le_bytes(*c))
        }
        #[inline(always)]
        fn store(self, b: &mut [u8]) {
            if let Some(c) = b.first_chunk_mut::<$bytes>() {
                *c = self.to_le_bytes();
            }
        }
        #[inline(always)]
        fn ones(self) -> usize {
            self.count_ones() as usize
        }
        #[inline(always)]
        fn add(self, other: Self) -> Self {
            self.wrapping_add(other)
        }
        #[inline(always)]
        fn sub(self, other: Self) -> Self {
            self.wrapping_sub(other)
        }
        #[inline(always)]
        fn pack_simd(f: &[u8], b: &[u8], tau: u8) -> Self {
            let (Some(f), Some(b)) = (f.first_chunk::<$px>(), b.first_chunk::<$px>()) else {
                return 0;
            };
            let mut m = [0u8; $px];
            for (((o, &f), &b), &s) in m.iter_mut().zip(f).zip(b).zip(&$groups) {
                *o = if f.abs_diff(b) > tau { s } else { 0 };
            }
            m.chunks_exact($bytes).fold(0, |acc, q| acc | <$t>::load(q))
        }
        #[inline(always)]
        fn clear(out: &mut [u8]) {
            if let Some(out) = out.first_chunk_mut::<$px>() {
                *out = [0; $px];
            }
        }
    };
}

impl Word for u32 {
    shared_word_items!(u32, 4, 32, GROUP_BIT32);
    #[inline(always)]
    fn lanes(v: u16) -> Self {
        u32::from(v) * 0x0001_0001
    }
    #[inline(always)]
    fn expand(self, out: &mut [u8]) {
        if cfg!(target_pointer_width = "64") {
            expand32_u64(out, self);
        } else {
            expand32(out, self);
        }
    }
}

impl Word for u64 {
    shared_word_items!(u64, 8, 64, GROUP_BIT64);
    #[inline(always)]
    fn lanes(v: u16) -> Self {
        u64::from(v) * 0x0001_0001_0001_0001
    }
    #[inline(always)]
    fn expand(self, out: &mut [u8]) {
        // Group q (pixels 8q..8q + 8) is bit q of each byte.
        if let Some(out) = out.first_chunk_mut::<64>() {
            for (group, q) in out.chunks_exact_mut(8).zip(0..8) {
                ((self >> q) & Self::LOW).store(group);
            }
        }
    }
}

/// Per pixel `x` of a 32-bit word, the bit it takes in its byte: [`bit`]`(x)` is
/// `1 << (x div 4)` in byte `x mod 4`.
const GROUP_BIT32: [u8; 32] = group_bits::<32>();

/// Per pixel `x` of a 64-bit word, the bit it takes in its byte: `1 << (x div 8)` in byte
/// `x mod 8`.
const GROUP_BIT64: [u8; 64] = group_bits::<64>();

/// `1 << (x div (N/8))` for each pixel `x` of an `N`-pixel word.
const fn group_bits<const N: usize>() -> [u8; N] {
    let mut s = [0u8; N];
    let mut x = 0;
    while x < N {
        s[x] = 1 << (x / (N / 8));
        x += 1;
    }
    s
}

/// Whether two packed planes of words `W` fit into the byte plane of a `w` pixels wide image:
/// `2·BYTES·⌈w/PX⌉ ≤ w` (from 8 pixels on for 32-bit words, 16 for 64-bit ones).
fn fits<W: Word>(w: usize) -> bool {
    2 * W::BYTES * w.div_ceil(W::PX) <= w
}

/// `0x7FFF − τ` in every 16-bit lane, for [`exceeds`].
#[inline(always)]
fn swar_bias<W: Word>(tau: u8) -> W {
    W::lanes(0x7FFF - u16::from(tau))
}

/// For a word's worth of pixels at once (one per byte of `a` and `b`): bit 7 of each byte is set
/// where `|a − b| > τ`, every other bit is clear; `k` is [`swar_bias`]`(τ)`.
///
/// Even and odd bytes go into 16-bit lanes, where `k + (a − b)` and `k − (a − b)` lie in
/// `0x7FFF − τ ± 255` (no carry between lanes) and reach bit 15 exactly when `a − b > τ` or
/// `b − a > τ`.
#[inline(always)]
fn exceeds<W: Word>(a: W, b: W, k: W) -> W {
    let lanes = W::lanes(0x00FF);
    let flags = W::lanes(0x8000);
    let even = (a & lanes).sub(b & lanes);
    let odd = ((a >> 8) & lanes).sub((b >> 8) & lanes);
    let even = (even.add(k) | k.sub(even)) & flags;
    let odd = (odd.add(k) | k.sub(odd)) & flags;
    (even >> 8) | odd
}

/// The bit of pixel `x` (`0..PX`) in its packed word: `8·(x mod BYTES) + x div BYTES`.
#[inline(always)]
fn bit<W: Word>(x: usize) -> W {
    let one = W::LOW & !(W::ONES << 8);
    one << ((x % W::BYTES) * 8 + (x / W::BYTES) % 8) as u32
}

/// The packed word of `PX` pixels: [`bit`]`(x)` set where `|f[x] − b[x]| > τ` (`k` is
/// [`swar_bias`]`(τ)`; 0 unless `f` and `b` hold `PX` pixels).
#[inline(always)]
fn pack_swar<W: Word>(f: &[u8], b: &[u8], k: W) -> W {
    let (Some(f), Some(b)) = (f.get(..W::PX), b.get(..W::PX)) else {
        return W::ZERO;
    };
    let mut bits = W::ZERO;
    // Group q's flags (bit 7 of each byte) move to bit q of each byte.
    for (q, (f, b)) in f.chunks_exact(W::BYTES).zip(b.chunks_exact(W::BYTES)).enumerate() {
        bits = bits | (exceeds(W::load(f), W::load(b), k) >> (7 - (q as u32 & 7)));
    }
    bits
}

/// The packed word of `PX` pixels (as [`pack_swar`]) in the target's cheaper form:
/// [`Word::pack_simd`] where byte loops vectorise, [`pack_swar`] otherwise. `k` is
/// [`swar_bias`]`(τ)`.
#[inline(always)]
fn pack_word<W: Word>(f: &[u8], b: &[u8], tau: u8, k: W) -> W {
    if BYTE_SIMD {
        W::pack_simd(f, b, tau)
    } else {
        pack_swar(f, b, k)
    }
}

/// The packed word of a row's last, partial word, pixel by pixel (at most `PX`).
fn pack_tail<W: Word>(f: &[u8], b: &[u8], tau: u8) -> W {
    f.iter().zip(b).take(W::PX).enumerate().fold(
        W::ZERO,
        |acc, (x, (&f, &b))| {
            if f.abs_diff(b) > tau {
                acc | bit::<W>(x)
            } else {
                acc
            }
        },
    )
}

/// The combination (AND for erosion, OR for dilation) of each pixel of `cur` with its left and
/// right neighbours; `prev` and `next` are the row's words before and after `cur`.
///
/// With pixel `x` at bit `8·(x mod L) + x div L` (`L` bytes), the left neighbours of bytes
/// `1..L` are one byte down, those of byte 0 (`x = Lq`) are byte `L − 1` one bit down
/// (`x = Lq − 1`) or, for `q = 0`, the last pixel of `prev`; the right neighbours mirror this.
#[inline(always)]
fn horizontal<W: Word, const ERODE: bool>(prev: W, cur: W, next: W) -> W {
    let n = W::PX as u32;
    // 0xFE in the lowest byte, 0x7F in the highest.
    let low7 = !(W::ONES << 8) & !W::LOW;
    let high7 = (W::ONES >> 1) & !(W::ONES >> 8);
    let left = (cur << 8) | ((cur >> (n - 9)) & low7) | (prev >> (n - 1));
    let right = (cur >> 8) | ((cur << (n - 9)) & high7) | (next << (n - 1));
    if ERODE {
        left & cur & right
    } else {
        left | cur | right
    }
}

/// The packed planes' shape.
struct Geometry<W> {
    w: usize,
    h: usize,
    /// Words per packed row.
    words: usize,
    /// Bytes per packed row.
    row_bytes: usize,
    /// Bytes of a packed plane.
    packed: usize,
    /// The bits of each row's last word that hold pixels.
    last_valid: W,
}

impl<W: Word> Geometry<W> {
    fn new(w: usize, h: usize) -> Self {
        let words = w.div_ceil(W::PX);
        let row_bytes = W::BYTES * words;
        let tail = w - (words.max(1) - 1) * W::PX;
        Geometry {
            w,
            h,
            words,
            row_bytes,
            packed: row_bytes * h,
            last_valid: (0..tail.min(W::PX)).fold(W::ZERO, |m, x| m | bit::<W>(x)),
        }
    }

    /// Packed row `y` of `plane` (empty when outside).
    fn row<'p>(&self, plane: &'p [u8], y: usize) -> &'p [u8] {
        plane
            .get(y * self.row_bytes..(y + 1) * self.row_bytes)
            .unwrap_or_default()
    }
}

/// The mask in packed words `W` ([`fits`] must hold): threshold and pack into plane A, the
/// clean-up, then the expansion over the whole plane, which writes the mask's spans. Returns
/// the foreground count.
fn packed_mask<W: Word, B: AsRef<[u8]>>(
    input: &Input<'_, B>,
    cleanup: Cleanup,
    labels: &mut [u8],
    spans: &mut RowSpans,
) -> usize {
    let g = Geometry::<W>::new(input.frame.width(), input.frame.height());
    pack(input, &g, labels);
    {
        let (a, rest) = labels.split_at_mut(g.packed.min(labels.len()));
        let b = rest.get_mut(..g.packed).unwrap_or_default();
        // Plane A → B → A for each operation.
        if cleanup != Cleanup::Off {
            packed_morph::<W, true>(a, b, &g);
            packed_morph::<W, false>(a, b, &g);
        }
        if cleanup == Cleanup::OpenClose {
            packed_morph::<W, false>(a, b, &g);
            packed_morph::<W, true>(a, b, &g);
        }
    }
    unpack(labels, &g, spans)
}

/// Threshold and pack: row `y`'s words go to bytes `y·row_bytes ..` of the plane (plane A).
/// (Not inlined: inside the whole mask function LLVM keeps the SIMD form's flag bytes on the
/// stack.)
#[inline(never)]
fn pack<W: Word, B: AsRef<[u8]>>(input: &Input<'_, B>, g: &Geometry<W>, labels: &mut [u8]) {
    let (frame, tau) = (input.frame, input.tau);
    let k = swar_bias::<W>(tau);
    if input.direct {
        let a = labels.get_mut(..g.packed).unwrap_or_default();
        for (y, (prow, brow)) in a
            .chunks_exact_mut(g.row_bytes.max(1))
            .zip(input.bg.chunks_exact(g.w.max(1)))
            .enumerate()
        {
            let mut words = prow.chunks_exact_mut(W::BYTES);
            let (mut fc, mut bc) = (frame.row(y).chunks_exact(W::PX), brow.chunks_exact(W::PX));
            // The full chunks first in the zip, so that the partial word is not consumed.
            for ((f, b), word) in fc.by_ref().zip(bc.by_ref()).zip(words.by_ref()) {
                pack_word(f, b, tau, k).store(word);
            }
            if let Some(word) = words.next() {
                pack_tail::<W>(fc.remainder(), bc.remainder(), tau).store(word);
            }
        }
    } else {
        // In place: word k of row y lands at or before the bytes it was read from.
        for y in 0..g.h {
            for i in 0..g.words {
                let src = y * g.w + i * W::PX;
                let end = (src + W::PX).min((y + 1) * g.w);
                let d = labels.get(src..end).unwrap_or_default();
                let bits = if d.len() == W::PX {
                    pack_word(d, &ZEROS, tau, k)
                } else {
                    pack_tail(d, &ZEROS, tau)
                };
                let dst = y * g.row_bytes + W::BYTES * i;
                if let Some(word) = labels.get_mut(dst..dst + W::BYTES) {
                    bits.store(word);
                }
            }
        }
    }
}

/// One 3×3 erosion (`ERODE`) or dilation of packed plane `a`, with `b` as the scratch: the
/// vertical pass (each word combined with the words above and below it) from A into B, then the
/// horizontal pass (each pixel with its left and right neighbours) from B back into A. Both are
/// flat loops over the whole plane, which SSE2 and NEON take two words at a time. Pixels outside
/// the image count as the operation's identity, i.e. they are ignored, so a part touching the
/// border is not eaten from that side.
fn packed_morph<W: Word, const ERODE: bool>(a: &mut [u8], b: &mut [u8], g: &Geometry<W>) {
    vertical::<W, ERODE>(a, b, g);
    horizontal_pass::<W, ERODE>(b, a, g);
}

/// The vertical pass: word `k` of row `y` of `dst` is the combination of word `k` of rows
/// `y − 1`, `y` and `y + 1` of `src` (a row outside the image left out).
#[inline(never)]
fn vertical<W: Word, const ERODE: bool>(src: &[u8], dst: &mut [u8], g: &Geometry<W>) {
    let op = |u: W, c: W, d: W| if ERODE { u & c & d } else { u | c | d };
    let (rb, len) = (g.row_bytes, g.packed);
    if g.h < 2 {
        if let (Some(d), Some(s)) = (dst.get_mut(..len), src.get(..len)) {
            d.copy_from_slice(s);
        }
        return;
    }
    // Rows 1 ..= h − 2 in one flat loop: up, at and below are the plane from rows 0, 1 and 2 on.
    if let (Some(up), Some(cur), Some(down), Some(out)) = (
        src.get(..len - 2 * rb),
        src.get(rb..len - rb),
        src.get(2 * rb..len),
        dst.get_mut(rb..len - rb),
    ) {
        for (((o, u), c), d) in out
            .chunks_exact_mut(W::BYTES)
            .zip(up.chunks_exact(W::BYTES))
            .zip(cur.chunks_exact(W::BYTES))
            .zip(down.chunks_exact(W::BYTES))
        {
            op(W::load(u), W::load(c), W::load(d)).store(o);
        }
    }
    // The first and last rows: themselves and their one neighbour.
    for (row, other) in [(0, rb), (len - rb, len - 2 * rb)] {
        if let (Some(c), Some(n), Some(out)) = (
            src.get(row..row + rb),
            src.get(other..other + rb),
            dst.get_mut(row..row + rb),
        ) {
            for ((o, c), n) in out
                .chunks_exact_mut(W::BYTES)
                .zip(c.chunks_exact(W::BYTES))
                .zip(n.chunks_exact(W::BYTES))
            {
                let (c, n) = (W::load(c), W::load(n));
                op(c, c, n).store(o);
            }
        }
    }
}

/// The horizontal pass: each pixel of `src` combined with its left and right neighbours
/// ([`horizontal`]) into `dst`. One flat loop takes each word with the words before and after
/// it in the plane; then each row's ends are set right, where those words belong to another
/// row: the first pixel's left neighbour and the last pixel's right one are outside the image
/// (the identity), and a partial last word takes the identity for its bits past the image.
#[inline(never)]
fn horizontal_pass<W: Word, const ERODE: bool>(src: &[u8], dst: &mut [u8], g: &Geometry<W>) {
    horizontal_form::<W, ERODE, BYTE_SIMD>(src, dst, g);
}

/// [`horizontal_pass`] with the flat loop vectorisable (`SIMD`: each word loads its neighbours)
/// or carrying the neighbours in registers (the Cortex-M4's form). `src` and `dst` are one
/// packed plane each (`g.packed` bytes).
#[inline(always)]
fn horizontal_form<W: Word, const ERODE: bool, const SIMD: bool>(src: &[u8], dst: &mut [u8], g: &Geometry<W>) {
    if g.row_bytes == 0 {
        // An empty plane (and no chunks of 0 bytes below).
        return;
    }
    let ident = if ERODE { W::ONES } else { W::ZERO };
    let len = g.packed;
    let n = len / W::BYTES;
    if n >= 3 {
        if SIMD {
            // dst[k] = f(src[k − 1], src[k], src[k + 1]) for k = 1 ..= n − 2, no value carried
            // from one word to the next: vectorised.
            if let (Some(prev), Some(cur), Some(next), Some(out)) = (
                src.get(..len - 2 * W::BYTES),
                src.get(W::BYTES..len - W::BYTES),
                src.get(2 * W::BYTES..len),
                dst.get_mut(W::BYTES..len - W::BYTES),
            ) {
                for (((o, p), c), n) in out
                    .chunks_exact_mut(W::BYTES)
                    .zip(prev.chunks_exact(W::BYTES))
                    .zip(cur.chunks_exact(W::BYTES))
                    .zip(next.chunks_exact(W::BYTES))
                {
                    horizontal::<W, ERODE>(W::load(p), W::load(c), W::load(n)).store(o);
                }
            }
        } else {
            // The same with the neighbours carried in registers (one load per word).
            let mut words = src.chunks_exact(W::BYTES).map(W::load);
            let (Some(mut p), Some(mut c)) = (words.next(), words.next()) else {
                return;
            };
            for (n, o) in words.zip(dst.get_mut(W::BYTES..).unwrap_or_default().chunks_exact_mut(W::BYTES)) {
                horizontal::<W, ERODE>(p, c, n).store(o);
                (p, c) = (c, n);
            }
        }
    }
    // The plane's first and last word as the flat loop would have them (their missing neighbour
    // taken as themselves, which the row ends below set right).
    let at = |k: usize| W::load(src.get(k * W::BYTES..).unwrap_or_default());
    if n >= 1 {
        let (c, v) = (at(0), at(1.min(n - 1)));
        horizontal::<W, ERODE>(c, c, v).store(dst);
        let (u, c) = (at(n.saturating_sub(2)), at(n - 1));
        horizontal::<W, ERODE>(u, c, c).store(dst.get_mut((n - 1) * W::BYTES..).unwrap_or_default());
    }
    // Each row's ends, where the flat loop took a word of another row: pixel 0's left neighbour
    // and pixel PX − 1's right one are outside the image (the identity), so each becomes the
    // combination of itself and its one neighbour in the row (pixel 1 is bit 8, pixel PX − 2 is
    // bit PX − 9). A partial last word is worked whole, with the identity past the image.
    let op = |a: W, b: W| if ERODE { a & b } else { a | b };
    let (bit0, top) = (one::<W>(), W::ONES << (W::PX as u32 - 1));
    let full = g.last_valid == W::ONES;
    let (rb, b) = (g.row_bytes, W::BYTES);
    for (srow, drow) in src.chunks_exact(rb).zip(dst.chunks_exact_mut(rb)) {
        let c = W::load(srow);
        let v = W::load(drow);
        ((v & !bit0) | (op(c, c >> 8) & bit0)).store(drow);
        let last = rb - b;
        let c = W::load(srow.get(last..).unwrap_or_default());
        let out = drow.get_mut(last..).unwrap_or_default();
        if full {
            let v = W::load(out);
            ((v & !top) | (op(c, c << 8) & top)).store(out);
        } else {
            let p = if g.words >= 2 {
                W::load(srow.get(last - b..).unwrap_or_default())
            } else {
                ident
            };
            let c = (c & g.last_valid) | (ident & !g.last_valid);
            (horizontal::<W, ERODE>(p, c, ident) & g.last_valid).store(out);
        }
    }
}

/// Bit 0 (pixel 0).
#[inline(always)]
fn one<W: Word>() -> W {
    W::LOW & !(W::ONES << 8)
}

/// Expands the packed plane at the start of `plane` into one byte per pixel over the whole
/// plane, last row first, and notes each row's extent (its first and last word that holds
/// foreground, to half a word) in `spans`. Row `y ≥ 1` lands at `y·w ≥ (y + 1)·row_bytes`,
/// past every packed row not yet read; row 0 is expanded in place, last word first. Returns the
/// number of set pixels.
#[inline(never)]
fn unpack<W: Word>(plane: &mut [u8], g: &Geometry<W>, spans: &mut RowSpans) -> usize {
    let (w, h) = (g.w, g.h);
    spans.clear(w, h);
    let mut foreground = 0usize;
    // The extent of a row's set words `i0 ..= i1` (`v0`, `v1` the end words) as pixels, to half a
    // word where that is finer than the spans' units.
    let note = |spans: &mut RowSpans, y: usize, (i0, v0): (usize, W), (i1, v1): (usize, W)| {
        let half = W::PX / 2;
        let (mut x0, mut x1) = (i0 * W::PX, (i1 + 1) * W::PX);
        if half >= SPAN_UNIT {
            if v0 & W::FIRST_HALF == W::ZERO {
                x0 += half;
            }
            if v1 & !W::FIRST_HALF == W::ZERO {
                x1 -= half;
            }
        }
        spans.include(y, x0, x1);
    };
    for y in (1..h).rev() {
        let (head, tail) = plane.split_at_mut((y * w).min(plane.len()));
        let src = g.row(head, y);
        let out = tail.get_mut(..w).unwrap_or_default();
        let mut outs = out.chunks_exact_mut(W::PX);
        let mut words = src.chunks_exact(W::BYTES);
        let (mut first, mut last) = ((usize::MAX, W::ZERO), (0, W::ZERO));
        for (k, (o, word)) in outs.by_ref().zip(words.by_ref()).enumerate() {
            let bits = W::load(word);
            if bits == W::ZERO {
                W::clear(o);
            } else {
                bits.expand(o);
                foreground += bits.ones();
                if first.0 == usize::MAX {
                    first = (k, bits);
                }
                last = (k, bits);
            }
        }
        if let Some(word) = words.next() {
            let bits = W::load(word) & g.last_valid;
            foreground += bits.ones();
            expand_tail(outs.into_remainder(), bits);
            if bits != W::ZERO {
                if first.0 == usize::MAX {
                    first = (g.words - 1, bits);
                }
                last = (g.words - 1, bits);
            }
        }
        if first.0 != usize::MAX {
            note(spans, y, first, last);
        }
    }
    // Row 0: word k expands onto bytes PX·k.., which hold only packed words ≥ k. The last set
    // word comes first.
    let (mut first, mut last) = ((0, W::ZERO), (usize::MAX, W::ZERO));
    for k in (0..g.words).rev() {
        let bits = W::load(plane.get(W::BYTES * k..).unwrap_or_default());
        let x0 = k * W::PX;
        let bits = if x0 + W::PX <= w {
            foreground += expand_word(plane.get_mut(x0..x0 + W::PX).unwrap_or_default(), bits);
            bits
        } else {
            let bits = bits & g.last_valid;
            foreground += bits.ones();
            expand_tail(plane.get_mut(x0..w).unwrap_or_default(), bits);
            bits
        };
        if bits != W::ZERO {
            if last.0 == usize::MAX {
                last = (k, bits);
            }
            first = (k, bits);
        }
    }
    if h > 0 && last.0 != usize::MAX {
        note(spans, 0, first, last);
    }
    foreground
}

/// Writes the `PX` pixels of a packed word as bytes (0 or 1) into `out` (`PX` bytes) and
/// returns how many are set. A word of background (most of a frame) is `PX` zero bytes, stored
/// as such.
#[inline(always)]
fn expand_word<W: Word>(out: &mut [u8], bits: W) -> usize {
    if bits == W::ZERO {
        W::clear(out);
        return 0;
    }
    bits.expand(out);
    bits.ones()
}

/// [`expand32`] with 64-bit words: quads `q` and `q + 1` at once from `bits` and `bits >> 1`
/// side by side (what `r >> q` moves from the upper half into the lower one lands at bit 26 or
/// above, never on a sampled bit).
#[inline(always)]
fn expand32_u64(out: &mut [u8], bits: u32) {
    let r = u64::from(bits) | (u64::from(bits >> 1) << 32);
    if let Some(out) = out.first_chunk_mut::<32>() {
        for (pair, q) in out.chunks_exact_mut(8).zip((0..8).step_by(2)) {
            ((r >> q) & u64::LOW).store(pair);
        }
    }
}

/// Writes the 32 pixels of a packed 32-bit word as bytes (0 or 1) into `out` (32 bytes).
#[inline(always)]
fn expand32(out: &mut [u8], mut bits: u32) {
    // Quad q (pixels 4q..4q + 4) is bit q of each byte.
    if let Some(out) = out.first_chunk_mut::<32>() {
        for quad in out.chunks_exact_mut(4) {
            (bits & u32::LOW).store(quad);
            bits >>= 1;
        }
    }
}

/// Writes the first `out.len()` (< `PX`) pixels of a packed word as bytes into `out`.
fn expand_tail<W: Word>(out: &mut [u8], bits: W) {
    for (x, p) in out.iter_mut().enumerate().take(W::PX) {
        *p = u8::from(bits & bit::<W>(x) != W::ZERO);
    }
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
        let mut want = [garbage; MAX_PX + 8];
        let want_stats = reference_mask(&frame, &bg, a, threshold, cleanup, &mut want[..n + 8]).unwrap();
        // The public entry, and each word size forced (32-bit words are the Cortex-M4's).
        for form in 0..3 {
            let mut got = [garbage; MAX_PX + 8];
            let mut spans = RowSpans::full(3, 3);
            let labels = &mut got[..n + 8];
            let got_stats = match form {
                0 => foreground_mask_spans(&frame, &bg, a, threshold, cleanup, labels, &mut spans),
                1 => mask_with::<false, _, _>(&frame, &bg, a, threshold, cleanup, labels, &mut spans),
                _ => mask_with::<true, _, _>(&frame, &bg, a, threshold, cleanup, labels, &mut spans),
            }
            .unwrap();
            assert_eq!(
                got_stats, want_stats,
                "{w}×{h} α={alpha} {threshold:?} {cleanup:?} form {form}"
            );
            if got[..n + 8] != want[..n + 8] {
                let i = got.iter().zip(&want).position(|(g, w)| g != w).unwrap();
                panic!(
                    "{w}×{h} α={alpha} {threshold:?} {cleanup:?} form {form}: first difference at ({}, {}): {} vs {}",
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
            foreground_mask(&frame, &bg, a, Threshold::Otsu, Cleanup::Open, &mut labels),
            Err(Error::NoBackground)
        );
        let mut bg = bg;
        bg.set_from_frame(&frame, a).unwrap();
        assert!(matches!(
            foreground_mask(&frame, &bg, a, Threshold::Otsu, Cleanup::Open, &mut labels[..39]),
            Err(Error::BufferTooSmall { needed: 40, got: 39 })
        ));
        let small = Frame::new_checked(&frame_px[..], 8, 4).unwrap();
        assert!(matches!(
            foreground_mask(&small, &bg, a, Threshold::Otsu, Cleanup::Open, &mut labels),
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
                    let g = foreground_mask(&frame, &bg, a, threshold, cleanup, &mut got).unwrap();
                    let r = reference_mask(&frame, &bg, a, threshold, cleanup, &mut want).unwrap();
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
                cleanup,
                &mut got,
                &mut spans,
            );
            let r = reference_mask(&frame, &bg, Alpha::ONE, Threshold::Fixed(50), cleanup, &mut want);
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
