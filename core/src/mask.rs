//! Foreground mask: `|I' − B| > τ`, then a 3×3 opening (and optionally closing) (paper sections
//! 3.2–3.3).
//!
//! The mask is written into the caller's label plane (`width·height` bytes, one per pixel:
//! 0 background, 1 foreground), which border following then labels in place. The threshold τ is
//! fixed or chosen by Otsu's method on the histogram of the difference (`docs/pipeline-spec.md`
//! §3).
//!
//! The mask is built bit-packed, 32 pixels to a `u32` word, inside the plane itself:
//!
//! 1. **Threshold and pack.** With α = 1 (the default: `I' = I`) one pass reads frame and
//!    background and writes the packed mask; nothing else is stored. It tests four pixels at a
//!    time in a 32-bit word (even and odd bytes in 16-bit lanes, where `0x7FFF − τ ± (a − b)`
//!    reaches bit 15 exactly when `|a − b| > τ`), so it is branch-free on a Cortex-M4. Where
//!    byte loops vectorise (SSE2, NEON) the same word comes from byte loops instead: 16 pixels
//!    per SIMD operation, each pixel's flag ANDed with its bit and the eight quads ORed. Otsu
//!    first reads frame and background once more for its histogram.
//!    With α < 1, `D = |I' − B|` first goes into the plane row by row (one Sobel per pixel
//!    dominates then), and is packed in place.
//! 2. **Clean-up.** The packed plane takes the first `4·⌈w/32⌉·h` bytes of the plane (about an
//!    eighth of it; at most half for `w ≥ 8`); a second packed plane right after it is the
//!    scratch. Each erosion or dilation is a horizontal pass within the words (shifts, plus the
//!    end bits of the neighbouring words) and a vertical pass (AND or OR of three rows' words)
//!    into the other plane: 32 pixels per operation. Neighbours outside the image count as the
//!    operation's identity, i.e. they are ignored, so a part touching the border is not eaten
//!    from that side.
//! 3. **Expand and count.** The last pass writes the bytes back over the whole plane, last row
//!    first (row `y ≥ 1` lands past every packed row not yet read, row 0 expands in place from its
//!    last word), and counts the foreground with `count_ones`. A word of background (most of a
//!    frame) is stored as 32 zero bytes without expanding or counting it.
//!
//! In a word, pixel `4q + i` (`q` 0–7, `i` 0–3) is bit `8i + q`: the flags of four pixels
//! (bit 7 of each byte) go in with one shift, and four pixels come out as
//! `(word >> q) & 0x0101_0101`, one store. Images narrower than 8 pixels, where two packed
//! planes do not fit, take a byte-wise path with the same result.
//!
//! Time: `O(width·height)`. With α = 1 and a fixed τ, each pixel's bytes are touched twice (read
//! in step 1, written in step 3), and the opening (with the closing) adds two (four) passes over
//! the packed planes, an eighth of the bytes each; Otsu adds one read of frame and background.
//! On a Cortex-M4 that is about 7.9 instructions per pixel for τ fixed with the opening (QEMU,
//! QVGA: 0.61 M per frame), of which step 1 is about 5.5. On x86_64 about 2.7 per pixel
//! (callgrind, `vorl detect` on the bench set: 0.84 M per 640×480 frame, 1.67 M before the
//! SIMD pack and the zero words; step 1 0.34 M, the opening 0.33 M, step 3 0.18 M). Memory:
//! none beyond the plane, and the 1 KiB histogram on the stack.

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
    let Some(labels) = labels.get_mut(..n) else {
        return Err(Error::BufferTooSmall {
            needed: n,
            got: labels.len(),
        });
    };
    let otsu = threshold == Threshold::Otsu;
    if n == 0 {
        // Unreachable through `Frame` (no empty frames), but keeps `chunks_exact(0)` out.
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
            for (y, brow) in bg.chunks_exact(w).enumerate() {
                for (&f, &b) in frame.row(y).iter().zip(brow) {
                    hist[f.abs_diff(b) as usize] += 1;
                }
            }
        }
    } else {
        for (y, (row, brow)) in labels.chunks_exact_mut(w).zip(bg.chunks_exact(w)).enumerate() {
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
    let words = w.div_ceil(WORD_BITS);
    let row_bytes = 4 * words;
    // Two bit-packed planes (`row_bytes` per row) fit into the byte plane when 8·⌈w/32⌉ ≤ w,
    // i.e. for every width from 8 on.
    if 8 * words > w {
        return Ok(MaskStats {
            threshold: tau,
            foreground: narrow_mask(frame, bg, direct, tau, cleanup, labels),
        });
    }
    // Threshold and pack: row y's bits go to bytes `y·row_bytes ..` of the plane (plane A).
    let packed = row_bytes * h;
    if direct {
        let a = labels.get_mut(..packed).unwrap_or_default();
        let k = swar_bias(tau);
        for (y, (prow, brow)) in a.chunks_exact_mut(row_bytes).zip(bg.chunks_exact(w)).enumerate() {
            let mut words = prow.chunks_exact_mut(4);
            let (mut fc, mut bc) = (frame.row(y).chunks_exact(WORD_BITS), brow.chunks_exact(WORD_BITS));
            // The full chunks first in the zip, so that the partial word is not consumed.
            for ((f, b), word) in fc.by_ref().zip(bc.by_ref()).zip(words.by_ref()) {
                store(word, pack_word(f, b, tau, k));
            }
            if let Some(word) = words.next() {
                store(word, pack_tail(fc.remainder(), bc.remainder(), tau));
            }
        }
    } else {
        // In place: word k of row y lands at or before the bytes it was read from.
        for y in 0..h {
            for k in 0..words {
                let src = y * w + k * WORD_BITS;
                let end = (src + WORD_BITS).min((y + 1) * w);
                let d = labels.get(src..end).unwrap_or_default();
                let bits = if d.len() == WORD_BITS {
                    pack_word(d, &ZEROS, tau, swar_bias(tau))
                } else {
                    pack_tail(d, &ZEROS, tau)
                };
                let dst = y * row_bytes + 4 * k;
                if let Some(word) = labels.get_mut(dst..dst + 4) {
                    store(word, bits);
                }
            }
        }
    }
    // The bits of each row's last word that hold pixels.
    let tail = w - (words - 1) * WORD_BITS;
    let last_valid = (0..tail).fold(0, |m, x| m | bit(x));
    {
        let (a, rest) = labels.split_at_mut(packed.min(n));
        let b = rest.get_mut(..packed).unwrap_or_default();
        // Plane A → B → A (→ B → A): each step a horizontal pass in place, then a vertical
        // pass into the other plane.
        if cleanup != Cleanup::Off {
            packed_step::<true>(a, b, row_bytes, last_valid);
            packed_step::<false>(b, a, row_bytes, last_valid);
        }
        if cleanup == Cleanup::OpenClose {
            packed_step::<false>(a, b, row_bytes, last_valid);
            packed_step::<true>(b, a, row_bytes, last_valid);
        }
    }
    let foreground = unpack(labels, w, h, row_bytes, last_valid);
    Ok(MaskStats {
        threshold: tau,
        foreground,
    })
}

/// The mask of an image narrower than 8 pixels (too narrow for two packed planes), byte by
/// byte: threshold, then the byte-wise clean-up. `labels` holds `D` unless `direct`. Returns the
/// foreground count.
fn narrow_mask<B: AsRef<[u8]>>(
    frame: &Frame<B>,
    bg: &[u8],
    direct: bool,
    tau: u8,
    cleanup: Cleanup,
    labels: &mut [u8],
) -> usize {
    let (w, h) = (frame.width(), frame.height());
    if direct {
        for (y, (row, brow)) in labels.chunks_exact_mut(w).zip(bg.chunks_exact(w)).enumerate() {
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
    labels.iter().filter(|&&v| v != 0).count()
}

/// Pixels per packed word.
const WORD_BITS: usize = 32;

/// The background of the in-place pack (`D` against 0).
const ZEROS: [u8; WORD_BITS] = [0; WORD_BITS];

/// `0x7FFF − τ` in both 16-bit halves, for [`exceeds4`].
#[inline(always)]
fn swar_bias(tau: u8) -> u32 {
    (0x7FFF - u32::from(tau)) * 0x0001_0001
}

/// For four pixels at once (one per byte of `a` and `b`): bit 7 of each byte is set where
/// `|a − b| > τ`, every other bit is clear; `k` is [`swar_bias`]`(τ)`.
///
/// Even and odd bytes go into 16-bit lanes, where `k + (a − b)` and `k − (a − b)` lie in
/// `0x7FFF − τ ± 255` (no carry between lanes) and reach bit 15 exactly when `a − b > τ` or
/// `b − a > τ`.
#[inline(always)]
fn exceeds4(a: u32, b: u32, k: u32) -> u32 {
    const LANES: u32 = 0x00FF_00FF;
    const FLAGS: u32 = 0x8000_8000;
    let even = (a & LANES).wrapping_sub(b & LANES);
    let odd = ((a >> 8) & LANES).wrapping_sub((b >> 8) & LANES);
    let even = (even.wrapping_add(k) | k.wrapping_sub(even)) & FLAGS;
    let odd = (odd.wrapping_add(k) | k.wrapping_sub(odd)) & FLAGS;
    (even >> 8) | odd
}

/// The bit of pixel `x` (0..32) in its packed word: `8·(x mod 4) + x div 4`.
#[inline(always)]
fn bit(x: usize) -> u32 {
    1 << ((x & 3) * 8 + ((x >> 2) & 7))
}

/// The packed word of 32 pixels: [`bit`]`(x)` set where `|f[x] − b[x]| > τ` (`k` is
/// [`swar_bias`]`(τ)`; 0 unless `f` and `b` hold 32 pixels).
#[inline(always)]
fn pack32(f: &[u8], b: &[u8], k: u32) -> u32 {
    let (Some(f), Some(b)) = (f.first_chunk::<WORD_BITS>(), b.first_chunk::<WORD_BITS>()) else {
        return 0;
    };
    let mut bits = 0u32;
    // Quad q's flags (bit 7 of each byte) move to bit q of each byte.
    for (q, (f, b)) in f.chunks_exact(4).zip(b.chunks_exact(4)).enumerate() {
        bits |= exceeds4(load(f), load(b), k) >> (7 - (q & 7));
    }
    bits
}

/// Whether the target has 128-bit SIMD registers that LLVM's auto-vectoriser uses for loops
/// over bytes (x86_64's SSE2 baseline, AArch64's NEON, wasm `simd128`). Without them (the
/// Cortex-M4) the 32-bit SWAR forms are leaner than byte loops.
const BYTE_SIMD: bool = cfg!(any(
    target_feature = "sse2",
    target_feature = "neon",
    target_feature = "simd128"
));

/// The packed word of 32 pixels (as [`pack32`]) in the target's cheaper form: [`pack32_simd`]
/// where byte loops vectorise, [`pack32`] otherwise. `k` is [`swar_bias`]`(τ)`.
#[inline(always)]
fn pack_word(f: &[u8], b: &[u8], tau: u8, k: u32) -> u32 {
    if BYTE_SIMD {
        pack32_simd(f, b, tau)
    } else {
        pack32(f, b, k)
    }
}

/// Per pixel `x` of a word, the bit it takes in its byte: [`bit`]`(x)` is `1 << (x div 4)` in
/// byte `x mod 4`.
const QUAD_BIT: [u8; WORD_BITS] = {
    let mut s = [0u8; WORD_BITS];
    let mut x = 0;
    while x < WORD_BITS {
        s[x] = 1 << (x / 4);
        x += 1;
    }
    s
};

/// The same word as [`pack32`], as byte loops that LLVM vectorises (16 pixels per SSE2
/// operation: `|f − b|` as `max − min`, the comparison, the bit of each pixel from
/// [`QUAD_BIT`], then an OR of the eight little-endian quads, which puts pixel `4q + i` at bit
/// `8i + q`). 0 unless `f` and `b` hold 32 pixels.
#[inline(always)]
fn pack32_simd(f: &[u8], b: &[u8], tau: u8) -> u32 {
    let (Some(f), Some(b)) = (f.first_chunk::<WORD_BITS>(), b.first_chunk::<WORD_BITS>()) else {
        return 0;
    };
    let mut m = [0u8; WORD_BITS];
    for (((o, &f), &b), &s) in m.iter_mut().zip(f).zip(b).zip(&QUAD_BIT) {
        *o = if f.abs_diff(b) > tau { s } else { 0 };
    }
    m.chunks_exact(4).fold(0, |acc, q| acc | load(q))
}

/// The packed word of a row's last, partial word, pixel by pixel (at most 32).
fn pack_tail(f: &[u8], b: &[u8], tau: u8) -> u32 {
    f.iter().zip(b).take(WORD_BITS).enumerate().fold(
        0u32,
        |acc, (x, (&f, &b))| if f.abs_diff(b) > tau { acc | bit(x) } else { acc },
    )
}

/// The little-endian word in the first four bytes of `b` (0 when shorter).
#[inline(always)]
fn load(b: &[u8]) -> u32 {
    b.first_chunk::<4>().map_or(0, |c| u32::from_le_bytes(*c))
}

/// Writes `v` little-endian into the first four bytes of `b` (nothing when shorter).
#[inline(always)]
fn store(b: &mut [u8], v: u32) {
    if let Some(c) = b.first_chunk_mut::<4>() {
        *c = v.to_le_bytes();
    }
}

/// The combination (AND for erosion, OR for dilation) of each pixel of `cur` with its left and
/// right neighbours; `prev` and `next` are the row's words before and after `cur`.
///
/// With pixel `x` at bit `8·(x mod 4) + x div 4`, the left neighbours of bytes 1–3 are one byte
/// down, those of byte 0 (`x = 4q`) are byte 3 one bit down (`x = 4q − 1`) or, for `q = 0`, the
/// last pixel of `prev`; the right neighbours mirror this.
#[inline(always)]
fn horizontal<const ERODE: bool>(prev: u32, cur: u32, next: u32) -> u32 {
    let left = (cur << 8) | ((cur >> 23) & 0x0000_00FE) | (prev >> 31);
    let right = (cur >> 8) | ((cur << 23) & 0x7F00_0000) | (next << 31);
    if ERODE {
        left & cur & right
    } else {
        left | cur | right
    }
}

/// One 3×3 erosion (`ERODE`) or dilation of the bit-packed plane `src` (`row_bytes` per row) into
/// `dst`: a horizontal pass in place over `src`, then the vertical pass into `dst`. Pixels
/// outside the image count as the operation's identity (1 for erosion, 0 for dilation), so they
/// are ignored; `last_valid` marks the pixels of each row's last word.
fn packed_step<const ERODE: bool>(src: &mut [u8], dst: &mut [u8], row_bytes: usize, last_valid: u32) {
    let ident = if ERODE { u32::MAX } else { 0 };
    for row in src.chunks_exact_mut(row_bytes) {
        let mut words = row.chunks_exact_mut(4);
        let Some(mut cur_w) = words.next() else {
            continue;
        };
        let (mut prev, mut cur) = (ident, load(cur_w));
        for next_w in words {
            let next = load(next_w);
            store(cur_w, horizontal::<ERODE>(prev, cur, next));
            (prev, cur, cur_w) = (cur, next, next_w);
        }
        let cur = (cur & last_valid) | (ident & !last_valid);
        store(cur_w, horizontal::<ERODE>(prev, cur, ident));
    }
    // Vertical: the row above the first and below the last are the row itself (identity).
    let mut rows = src.chunks_exact(row_bytes);
    let Some(mut cur) = rows.next() else {
        return;
    };
    let mut up = cur;
    for drow in dst.chunks_exact_mut(row_bytes) {
        let next = rows.next();
        let down = next.unwrap_or(cur);
        for (d, ((u, c), l)) in drow
            .chunks_exact_mut(4)
            .zip(up.chunks_exact(4).zip(cur.chunks_exact(4)).zip(down.chunks_exact(4)))
        {
            let (u, c, l) = (load(u), load(c), load(l));
            store(d, if ERODE { u & c & l } else { u | c | l });
        }
        let Some(next) = next else {
            break;
        };
        (up, cur) = (cur, next);
    }
}

/// Expands the bit-packed plane at the start of `plane` (`row_bytes` per row, `2·row_bytes ≤ w`)
/// into one byte per pixel over the whole plane, last row first. Row `y ≥ 1` lands at
/// `y·w ≥ (y + 1)·row_bytes`, past every packed row not yet read; row 0 is expanded in place,
/// last word first. Returns the number of set pixels.
fn unpack(plane: &mut [u8], w: usize, h: usize, row_bytes: usize, last_valid: u32) -> usize {
    let mut foreground = 0usize;
    for y in (1..h).rev() {
        let (head, tail) = plane.split_at_mut((y * w).min(plane.len()));
        let src = head.get(y * row_bytes..(y + 1) * row_bytes).unwrap_or_default();
        let out = tail.get_mut(..w).unwrap_or_default();
        let mut outs = out.chunks_exact_mut(WORD_BITS);
        let mut words = src.chunks_exact(4);
        for (o, word) in outs.by_ref().zip(words.by_ref()) {
            foreground += expand_word(o, load(word));
        }
        if let Some(word) = words.next() {
            let bits = load(word) & last_valid;
            foreground += bits.count_ones() as usize;
            expand_tail(outs.into_remainder(), bits);
        }
    }
    // Row 0: word k expands onto bytes 32k.., which hold only packed words ≥ k.
    for k in (0..row_bytes / 4).rev() {
        let bits = load(plane.get(4 * k..).unwrap_or_default());
        let x0 = k * WORD_BITS;
        if x0 + WORD_BITS <= w {
            foreground += expand_word(plane.get_mut(x0..x0 + WORD_BITS).unwrap_or_default(), bits);
        } else {
            let bits = bits & last_valid;
            foreground += bits.count_ones() as usize;
            expand_tail(plane.get_mut(x0..w).unwrap_or_default(), bits);
        }
    }
    foreground
}

/// Writes the 32 pixels of a packed word as bytes (0 or 1) into `out` (32 bytes) and returns
/// how many are set. A word of background (most of a frame) is 32 zero bytes, stored as such.
#[inline(always)]
fn expand_word(out: &mut [u8], bits: u32) -> usize {
    if bits == 0 {
        if let Some(out) = out.first_chunk_mut::<WORD_BITS>() {
            *out = [0; WORD_BITS];
        }
        return 0;
    }
    if cfg!(target_pointer_width = "64") {
        expand32_u64(out, bits);
    } else {
        expand32(out, bits);
    }
    bits.count_ones() as usize
}

/// [`expand32`] with 64-bit words: quads `q` and `q + 1` at once from `bits` and `bits >> 1`
/// side by side (what `r >> q` moves from the upper half into the lower one lands at bit 26 or
/// above, never on a sampled bit).
#[inline(always)]
fn expand32_u64(out: &mut [u8], bits: u32) {
    let r = u64::from(bits) | (u64::from(bits >> 1) << 32);
    for (pair, q) in out.chunks_exact_mut(8).zip((0..8).step_by(2)) {
        if let Some(pair) = pair.first_chunk_mut::<8>() {
            *pair = ((r >> q) & 0x0101_0101_0101_0101).to_le_bytes();
        }
    }
}

/// Writes the 32 pixels of a packed word as bytes (0 or 1) into `out` (32 bytes).
#[inline(always)]
fn expand32(out: &mut [u8], mut bits: u32) {
    // Quad q (pixels 4q..4q + 4) is bit q of each byte.
    for quad in out.chunks_exact_mut(4) {
        store(quad, bits & 0x0101_0101);
        bits >>= 1;
    }
}

/// Writes the first `out.len()` (< 32) pixels of a packed word as bytes into `out`.
fn expand_tail(out: &mut [u8], bits: u32) {
    for (x, p) in out.iter_mut().enumerate().take(WORD_BITS) {
        *p = u8::from(bits & bit(x) != 0);
    }
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
        let mut got = [garbage; MAX_PX + 8];
        let mut want = [garbage; MAX_PX + 8];
        let got_stats = foreground_mask(&frame, &bg, a, threshold, cleanup, &mut got[..n + 8]).unwrap();
        let want_stats = reference_mask(&frame, &bg, a, threshold, cleanup, &mut want[..n + 8]).unwrap();
        assert_eq!(got_stats, want_stats, "{w}×{h} α={alpha} {threshold:?} {cleanup:?}");
        if got[..n + 8] != want[..n + 8] {
            let i = got.iter().zip(&want).position(|(g, w)| g != w).unwrap();
            panic!(
                "{w}×{h} α={alpha} {threshold:?} {cleanup:?}: first difference at ({}, {}): {} vs {}",
                i % w,
                i / w,
                got[i],
                want[i]
            );
        }
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
            let h = 1 + rng.below((MAX_PX / w).min(48) as u64) as usize;
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

    /// The four-pixel threshold against the scalar one for every `(a, b, τ)` in every byte
    /// position, next to varied neighbours (a carry between lanes would show).
    #[test]
    fn exceeds4_matches_scalar_for_every_pair_and_threshold() {
        for tau in 0..=255u8 {
            let k = swar_bias(tau);
            for a in 0..=255u8 {
                for b in 0..=255u8 {
                    let fa = [a, b, 255 - a, a ^ 0x5a];
                    let fb = [b, a, b.wrapping_add(tau), 0];
                    for r in 0..4 {
                        let (av, bv) = (
                            u32::from_le_bytes(fa).rotate_left(8 * r),
                            u32::from_le_bytes(fb).rotate_left(8 * r),
                        );
                        let want = (0..4).fold(0u32, |m, i| {
                            let (x, y) = ((av >> (8 * i)) as u8, (bv >> (8 * i)) as u8);
                            m | (u32::from(x.abs_diff(y) > tau) << (8 * i + 7))
                        });
                        assert_eq!(exceeds4(av, bv, k), want, "a={a} b={b} τ={tau} r={r}");
                    }
                }
            }
        }
    }

    /// Packing and expanding a word round-trips every pixel through the interleaved layout.
    #[test]
    fn packed_layout_round_trips() {
        let mut rng = Rng(11);
        for _ in 0..1000 {
            let f: [u8; 32] = core::array::from_fn(|_| if rng.below(2) == 1 { 200 } else { 0 });
            let bits = pack32(&f, &ZEROS, swar_bias(100));
            assert_eq!(bits, pack_tail(&f, &ZEROS, 100));
            let mut out = [9u8; 32];
            expand32(&mut out, bits);
            assert_eq!(out.map(|v| v * 200), f);
            assert_eq!(bits.count_ones() as usize, f.iter().filter(|&&v| v != 0).count());
        }
    }

    /// Both forms of the threshold and pack (the SIMD one runs on the host, the SWAR one on the
    /// Cortex-M4) give the same word, and both expansions give the same bytes, on random
    /// pixels and thresholds (differences near τ included) and on every single-pixel word.
    #[test]
    fn pack_and_expand_forms_agree() {
        let mut rng = Rng(0x5eed);
        for case in 0..20_000 {
            let tau = rng.below(256) as u8;
            let b: [u8; 32] = core::array::from_fn(|_| rng.below(256) as u8);
            let f: [u8; 32] = core::array::from_fn(|i| match case % 3 {
                0 => rng.below(256) as u8,
                // Differences of exactly τ, τ + 1 and τ − 1 either way.
                1 => {
                    let d = (tau as i32 + rng.below(3) as i32 - 1) * if rng.below(2) == 0 { 1 } else { -1 };
                    (b[i] as i32 + d).clamp(0, 255) as u8
                }
                _ => b[i].wrapping_add(rng.below(3) as u8),
            });
            let want = pack32(&f, &b, swar_bias(tau));
            assert_eq!(pack32_simd(&f, &b, tau), want, "τ={tau} f={f:?} b={b:?}");
            assert_eq!(pack_word(&f, &b, tau, swar_bias(tau)), want);
            assert_eq!(pack_tail(&f, &b, tau), want);
            let (mut wide, mut narrow, mut word) = ([7u8; 32], [9u8; 32], [5u8; 32]);
            expand32_u64(&mut wide, want);
            expand32(&mut narrow, want);
            assert_eq!(expand_word(&mut word, want), want.count_ones() as usize);
            assert_eq!(wide, narrow);
            assert_eq!(word, narrow);
        }
        for x in 0..32 {
            let mut f = [0u8; 32];
            f[x] = 1;
            assert_eq!(pack32_simd(&f, &ZEROS, 0), bit(x));
            let (mut wide, mut narrow) = ([7u8; 32], [9u8; 32]);
            expand32_u64(&mut wide, bit(x));
            expand32(&mut narrow, bit(x));
            assert_eq!((wide, narrow), (f, f));
        }
        let mut zeros = [3u8; 32];
        assert_eq!(expand_word(&mut zeros, 0), 0);
        assert_eq!(zeros, [0; 32]);
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
