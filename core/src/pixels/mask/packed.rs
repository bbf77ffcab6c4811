//! The fast path of the foreground mask ([`super::foreground_mask_spans`]): the same mask as the
//! byte-wise definition in [`super`], built bit-packed inside the plane itself, in words of 64
//! pixels (`u64`) on 64-bit targets and of 32 (`u32`) elsewhere (the Cortex-M4); the word size
//! changes the cost, never the mask (the tests hold every form to the definition).
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

use core::ops::{BitAnd, BitOr, Not, Shl, Shr};

use super::{Cleanup, Input, RowSpans, SPAN_UNIT};

/// Whether packed words are 64 bits: on 64-bit targets, where a `u64` costs what a `u32` does.
pub(super) const WIDE: bool = cfg!(target_pointer_width = "64");

/// Whether the target has 128-bit SIMD registers that LLVM's auto-vectoriser uses for loops
/// over bytes (x86_64's SSE2 baseline, AArch64's NEON, wasm `simd128`). Without them (the
/// Cortex-M4) the SWAR forms are leaner than byte loops.
pub(crate) const BYTE_SIMD: bool = cfg!(any(
    target_feature = "sse2",
    target_feature = "neon",
    target_feature = "simd128"
));

/// The background of the in-place pack (`D` against 0).
pub(super) const ZEROS: [u8; 64] = [0; 64];

/// A packed word of `PX = 8·BYTES` pixels: pixel `x` is bit `8·(x mod BYTES) + x div BYTES`.
pub(super) trait Word:
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
pub(super) fn fits<W: Word>(w: usize) -> bool {
    2 * W::BYTES * w.div_ceil(W::PX) <= w
}

/// `0x7FFF − τ` in every 16-bit lane, for [`exceeds`].
#[inline(always)]
pub(super) fn swar_bias<W: Word>(tau: u8) -> W {
    W::lanes(0x7FFF - u16::from(tau))
}

/// For a word's worth of pixels at once (one per byte of `a` and `b`): bit 7 of each byte is set
/// where `|a − b| > τ`, every other bit is clear; `k` is [`swar_bias`]`(τ)`.
///
/// Even and odd bytes go into 16-bit lanes, where `k + (a − b)` and `k − (a − b)` lie in
/// `0x7FFF − τ ± 255` (no carry between lanes) and reach bit 15 exactly when `a − b > τ` or
/// `b − a > τ`.
#[inline(always)]
pub(super) fn exceeds<W: Word>(a: W, b: W, k: W) -> W {
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
pub(super) fn bit<W: Word>(x: usize) -> W {
    let one = W::LOW & !(W::ONES << 8);
    one << ((x % W::BYTES) * 8 + (x / W::BYTES) % 8) as u32
}

/// The packed word of `PX` pixels: [`bit`]`(x)` set where `|f[x] − b[x]| > τ` (`k` is
/// [`swar_bias`]`(τ)`; 0 unless `f` and `b` hold `PX` pixels).
#[inline(always)]
pub(super) fn pack_swar<W: Word>(f: &[u8], b: &[u8], k: W) -> W {
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
pub(super) fn pack_word<W: Word>(f: &[u8], b: &[u8], tau: u8, k: W) -> W {
    if BYTE_SIMD {
        W::pack_simd(f, b, tau)
    } else {
        pack_swar(f, b, k)
    }
}

/// The packed word of a row's last, partial word, pixel by pixel (at most `PX`).
pub(super) fn pack_tail<W: Word>(f: &[u8], b: &[u8], tau: u8) -> W {
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
pub(super) fn horizontal<W: Word, const ERODE: bool>(prev: W, cur: W, next: W) -> W {
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
pub(super) struct Geometry<W> {
    pub(super) w: usize,
    pub(super) h: usize,
    /// Words per packed row.
    pub(super) words: usize,
    /// Bytes per packed row.
    pub(super) row_bytes: usize,
    /// Bytes of a packed plane.
    pub(super) packed: usize,
    /// The bits of each row's last word that hold pixels.
    pub(super) last_valid: W,
}

impl<W: Word> Geometry<W> {
    pub(super) fn new(w: usize, h: usize) -> Self {
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
pub(super) fn packed_mask<W: Word, B: AsRef<[u8]>>(
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
            // The row's whole words, their frame and background pixels as slices of one length
            // in words (the loop's count known before it starts), then the partial word.
            let frow = frame.row(y);
            let whole = g.w / W::PX;
            let (px, bytes) = (whole * W::PX, whole * W::BYTES);
            let (Some((fw, ft)), Some((bw, bt)), Some((pw, pt))) = (
                frow.split_at_checked(px),
                brow.split_at_checked(px),
                prow.split_at_mut_checked(bytes),
            ) else {
                continue;
            };
            let pixels = fw.chunks_exact(W::PX).zip(bw.chunks_exact(W::PX));
            for ((f, b), word) in pixels.zip(pw.chunks_exact_mut(W::BYTES)) {
                pack_word(f, b, tau, k).store(word);
            }
            if let Some(word) = pt.get_mut(..W::BYTES) {
                pack_tail::<W>(ft, bt, tau).store(word);
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
pub(super) fn vertical<W: Word, const ERODE: bool>(src: &[u8], dst: &mut [u8], g: &Geometry<W>) {
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
pub(super) fn horizontal_form<W: Word, const ERODE: bool, const SIMD: bool>(
    src: &[u8],
    dst: &mut [u8],
    g: &Geometry<W>,
) {
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
        // The row's whole words and their pixels as slices of one length in words (the loop's
        // count known before it starts), then the partial word.
        let whole = w / W::PX;
        let (out, rest) = out.split_at_mut((whole * W::PX).min(out.len()));
        let (src, partial) = src.split_at((whole * W::BYTES).min(src.len()));
        let (mut first, mut last) = ((usize::MAX, W::ZERO), (0, W::ZERO));
        for (k, (o, word)) in out.chunks_exact_mut(W::PX).zip(src.chunks_exact(W::BYTES)).enumerate() {
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
        if let Some(word) = partial.get(..W::BYTES) {
            let bits = W::load(word) & g.last_valid;
            foreground += bits.ones();
            expand_tail(rest, bits);
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
pub(super) fn expand_word<W: Word>(out: &mut [u8], bits: W) -> usize {
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
pub(super) fn expand32_u64(out: &mut [u8], bits: u32) {
    let r = u64::from(bits) | (u64::from(bits >> 1) << 32);
    if let Some(out) = out.first_chunk_mut::<32>() {
        for (pair, q) in out.chunks_exact_mut(8).zip((0..8).step_by(2)) {
            ((r >> q) & u64::LOW).store(pair);
        }
    }
}

/// Writes the 32 pixels of a packed 32-bit word as bytes (0 or 1) into `out` (32 bytes).
#[inline(always)]
pub(super) fn expand32(out: &mut [u8], mut bits: u32) {
    // Quad q (pixels 4q..4q + 4) is bit q of each byte.
    if let Some(out) = out.first_chunk_mut::<32>() {
        for quad in out.chunks_exact_mut(4) {
            (bits & u32::LOW).store(quad);
            bits >>= 1;
        }
    }
}

/// Writes the first `out.len()` (< `PX`) pixels of a packed word as bytes into `out`.
pub(super) fn expand_tail<W: Word>(out: &mut [u8], bits: W) {
    for (x, p) in out.iter_mut().enumerate().take(W::PX) {
        *p = u8::from(bits & bit::<W>(x) != W::ZERO);
    }
}
