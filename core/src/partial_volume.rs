//! Partial-volume centroid: the part's area centroid with its edge pixels counted by coverage.
//!
//! [`partial_volume_centroid`]: pixels well inside count 1, pixels in a 2-px band around the
//! mask's edge count `D / C` clipped to `[0, 1]`, where `D = I' − B` is the difference image and
//! `C` the local contrast: the mean difference of the ring pixels 3–4 px inside the edge within
//! 4 px of the band pixel (so shading across the part does not tilt the weights), or the ring's
//! median where none is near. With blur symmetric about the edge, that is the centroid of the
//! true silhouette to a few hundredths of a pixel. A part with no interior ring has no contrast
//! to scale by and gives `None` (the caller keeps the polygon centroid).
//!
//! The regions come from the seed's 8-connected component `P` in the box (the border's bounding
//! box plus 6 px; outside the box counts as background): "inside" is `P` eroded twice by 3×3,
//! the band is `P` dilated twice minus "inside", the ring is `P` eroded three times minus `P`
//! eroded five times. Iterated 3×3 erosion (dilation) `k` times is one erosion by the
//! `(2k+1)`-square, and a square is separable, so each region row is a few word operations on
//! bit rows (32 px a word): the AND (OR) of the component's rows within `k` of the row, then of
//! that row shifted by `−k..=k`.
//!
//! Method: mark `P` in the mask plane (bit 7) with a scanline fill that scans 8 pixels a step,
//! noting the rows it covers; then two passes over those rows:
//! 1. the ring, from the component's rows `y − 5 ..= y + 5` as bit rows; it is marked in the
//!    plane (bit 6) and its `D` goes into a histogram, whose median is the part's contrast
//!    (where `D` is not read from the image's rows, `α < 1`, the first 256 values are also kept
//!    for pass 2);
//! 2. the weights, in raster order, 4 rows behind the rows read from the plane (and cleared to
//!    the mask bit): inside and band from the component's rows `y − 2 ..= y + 2`; the ring's `D`
//!    is kept summed per column over rows `y − 4 ..= y + 4` (a row added when it enters,
//!    subtracted when it leaves), so a band pixel's local mean is 9 column sums, kept as a sum
//!    that slides along the row. `D` of a word's inside and band pixels is read in one loop
//!    over the frame's and background's rows ([`Difference::rows`], `α = 1`: from its first
//!    such pixel to its last, which the compiler vectorises), and the hole test of its inside
//!    pixels is one reduction (their least `D`, in the contrast's sense) unless one fails. The
//!    inside pixels of weight 1 between two
//!    pixels weighed alone (band, holes) are added as one run: one addition per sum when that
//!    is sure not to round (every partial sum exact), else one by one, so the sums are the same
//!    bits as pixel by pixel in raster order.
//!
//! The result is the per-pixel definition's (3×3 passes over flag bits, a 9×9 window per band
//! pixel), which the tests keep as the reference: the same bits where `D` is an integer
//! (`α = 1`), and within 1e-4 px otherwise (the local sums are added in another order).
//!
//! Time: a few word operations per 32 px of a row and pass, one `D` per weighted (inside or
//! band) pixel, three per ring pixel (histogram, entering and leaving the sums); for `α = 1`
//! `D` comes from the image's rows, a few instructions a pixel (x86 vectorises the weighted
//! pixels' loop); through [`Difference::at`] it was about 50. On the bench set (parts of
//! 100–170 px, 640×480; `vorl detect`, callgrind) a part takes 0.73 M x86 instructions (1.12 M
//! with `D` through `at`, kept ring values and a hole test per pixel; 1.31 M before the runs of
//! weight 1). Of it, the weights of the band pixels (`RowWeights::add`, an order-bound chain of
//! f32 sums) are 0.19 M, the fill 0.08 M. On the Cortex-M4 (QEMU, the firmware's QVGA frames
//! of 4 parts) the rows save 80–100 K instructions per part. Before all this, the fixture
//! set's parts (boxes of about 66×66 px) took 0.38 M x86 instructions each, 0.43 M on the
//! Cortex-M4, where the per-pixel definition took 4.0 M and 4.6 M. Memory: on the Cortex-M4, 2.2 KB of stack for the
//! fill, then at most 3.6 KB (the 256 ring values; then 264 column sums and counts and about 20
//! bit rows of 256 px); bits 6 and 7 of the plane inside the box as scratch. Boxes wider than 256 px
//! take the per-pixel path (bits 2–7 of the plane as scratch), same result, about 10× slower.

use crate::refine::Difference;
use core::ops::Range;

/// Below this fraction of the part's contrast an interior pixel is taken for platform (a filled
/// hole).
const HOLE_RATIO: f32 = 0.2;

/// Bit of the mask plane marking the seed's component while one part is measured (bit 0 is the
/// mask).
const COMPONENT: u8 = 1 << 7;

/// Bit of the mask plane marking the component's ring between the two passes.
const RING: u8 = 1 << 6;

/// The margin added around the border's bounding box, px.
const MARGIN: usize = 6;

/// Words of one bit row.
const WORDS: usize = 8;

/// The widest box (px) measured with bit rows.
const MAX_WIDTH: usize = 32 * WORDS;

/// One row of the box as bits: bit `j` of word `i` is the box's column `32·i + j`.
type Bits = [u32; WORDS];

/// An empty bit row.
const EMPTY: Bits = [0; WORDS];

/// A rectangle of pixels `[x0, x1) × [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rect {
    /// Left.
    pub x0: usize,
    /// Top.
    pub y0: usize,
    /// Right (exclusive).
    pub x1: usize,
    /// Bottom (exclusive).
    pub y1: usize,
}

/// The partial-volume area centroid of the part whose border passes through `seed` (a foreground
/// pixel), within `bbox` (the border's bounding box; a 6 px margin is added, clipped to the
/// image). `mask` is the 0/1 plane: bits 1–7 inside the box are scratch (they must be 0 on entry,
/// and are 0 again on return). `None` when the part has no weight, or when `seed` is outside the
/// image, the box or the mask, or `mask` is shorter than the image (then `mask` is not touched).
pub fn partial_volume_centroid<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    mask: &mut [u8],
    seed: (usize, usize),
    bbox: Rect,
) -> Option<[f32; 2]> {
    let (w, h) = (diff.width(), diff.height());
    if mask.len() < w * h || seed.0 >= w || seed.1 >= h {
        return None;
    }
    let r = Rect {
        x0: bbox.x0.saturating_sub(MARGIN),
        y0: bbox.y0.saturating_sub(MARGIN),
        x1: bbox.x1.saturating_add(MARGIN).min(w),
        y1: bbox.y1.saturating_add(MARGIN).min(h),
    };
    if !(r.x0..r.x1).contains(&seed.0) || !(r.y0..r.y1).contains(&seed.1) {
        return None;
    }
    if mask.get(seed.1 * w + seed.0).is_none_or(|v| v & 1 == 0) {
        return None;
    }
    let rows = mark_component(mask, w, r, seed);
    if r.x1 - r.x0 <= MAX_WIDTH {
        bit_row_centroid(diff, mask, w, r, rows)
    } else {
        per_pixel::centroid(diff, mask, w, r)
    }
}

/// The box's geometry as the bit-row passes see it.
#[derive(Clone, Copy)]
struct Shape {
    /// Words per bit row that hold columns of the box.
    words: usize,
    /// The valid bits of the last of them.
    last: u32,
}

impl Shape {
    fn new(width: usize) -> Self {
        let words = width.div_ceil(32).min(WORDS);
        let last = match width % 32 {
            0 => u32::MAX,
            bits => (1u32 << bits) - 1,
        };
        Shape { words, last }
    }
}

/// [`partial_volume_centroid`] after the component is marked in the box's rows `rows`, for a box
/// at most [`MAX_WIDTH`] wide; leaves only the mask bit in the box.
fn bit_row_centroid<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    mask: &mut [u8],
    w: usize,
    r: Rect,
    rows: Range<usize>,
) -> Option<[f32; 2]> {
    // Where every image row's D comes from the frame's and background's rows (α = 1 and a full
    // background plane: then also the rows above the last), a ring pixel's D is read anew as
    // cheaply as it would be kept.
    let keep = diff.height().checked_sub(1).and_then(|last| diff.rows(last)).is_none();
    let mut values = RingValues::new(keep);
    let contrast = mark_ring(diff, mask, w, r, rows.clone(), &mut values);
    if contrast.abs() < 1.0 {
        for q in rows {
            if let Some(row) = box_row_mut(mask, w, r, q) {
                keep_mask_bit(row);
            }
        }
        return None;
    }
    weigh(diff, mask, w, r, rows, contrast, &mut values)
}

/// First pass: marks the ring (component eroded three times minus eroded five times) with
/// [`RING`] in the plane and returns the median `D` over it (from a signed histogram; 0 without
/// ring pixels). Not inlined: its histogram and [`weigh`]'s column sums need not share a stack
/// frame.
#[inline(never)]
fn mark_ring<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    mask: &mut [u8],
    w: usize,
    r: Rect,
    comp_rows: Range<usize>,
    values: &mut RingValues,
) -> f32 {
    let n = Shape::new(r.x1 - r.x0).words;
    let mut hist = [0u16; 511];
    let mut ring_count = 0usize;
    // The component's row q as bits (empty outside `comp_rows`).
    let comp = |mask: &[u8], q: usize| match box_row(mask, w, r, q) {
        Some(row) if comp_rows.contains(&q) => gather(row, 7),
        _ => EMPTY,
    };
    // Ring rows have the component 3 rows above and below.
    let ring_rows = comp_rows.start + 3..comp_rows.end.saturating_sub(3);
    // The component's rows j − 5 ..= j + 5 around row j: row q in slot (q + 5) mod 11 (the slots of
    // rows above the box stay empty).
    let mut rows = [EMPTY; 11];
    for q in ring_rows.start.saturating_sub(5)..ring_rows.start + 5 {
        if let Some(slot) = rows.get_mut((q + 5) % 11) {
            *slot = comp(mask, q);
        }
    }
    for j in ring_rows {
        if let Some(slot) = rows.get_mut((j + 10) % 11) {
            *slot = comp(mask, j + 5);
        }
        let row = |t: usize| rows.get((j + t) % 11).unwrap_or(&EMPTY);
        // Erosion by the (2k+1)-square: AND of the rows within k, then of the columns within k.
        let mut v3 = *row(5);
        for t in [2, 3, 4, 6, 7, 8] {
            and_into(&mut v3, row(t));
        }
        if v3 == EMPTY {
            continue;
        }
        let mut v5 = v3;
        for t in [0, 1, 9, 10] {
            and_into(&mut v5, row(t));
        }
        let (e3, e5) = (erode::<3>(&v3, n), erode::<5>(&v5, n));
        let mut ring = EMPTY;
        for ((o, a), b) in ring.iter_mut().zip(e3).zip(e5).take(n) {
            *o = a & !b;
        }
        if ring == EMPTY {
            continue;
        }
        if let Some(plane) = box_row_mut(mask, w, r, j) {
            scatter(plane, &ring, RING);
        }
        let y = r.y0 + j;
        let rows = diff.rows(y);
        for_each_bit(&ring, n, |col| {
            let x = r.x0 + col;
            let (d, bin) = match rows.and_then(|(f, b)| Some((*f.get(x)?, *b.get(x)?))) {
                // An integer in −255..=255: its bin without the conversion back from `f32`.
                Some((f, b)) => {
                    let i = i32::from(f) - i32::from(b);
                    (i as f32, (i + 255) as usize)
                }
                None => {
                    let d = diff.at(x as isize, y as isize);
                    (d, (d as i32 + 255).clamp(0, 510) as usize)
                }
            };
            values.store(d);
            if let Some(hb) = hist.get_mut(bin) {
                *hb = hb.saturating_add(1);
            }
            ring_count += 1;
        });
    }
    if ring_count == 0 {
        return 0.0;
    }
    let mut acc = 0usize;
    for (bin, &c) in hist.iter().enumerate() {
        acc += c as usize;
        if 2 * acc >= ring_count {
            return bin as f32 - 255.0;
        }
    }
    0.0
}

/// Second pass: the weighted centroid, in raster order. Row `p` of the plane is read (and left
/// with only its mask bit) 4 rows ahead of the weights, so the ring's column sums cover rows
/// `y − 4 ..= y + 4` when row `y` is weighed. Not inlined (see [`mark_ring`]).
#[inline(never)]
fn weigh<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    mask: &mut [u8],
    w: usize,
    r: Rect,
    comp_rows: Range<usize>,
    contrast: f32,
    values: &mut RingValues,
) -> Option<[f32; 2]> {
    let shape = Shape::new(r.x1 - r.x0);
    let n = shape.words;
    let height = r.y1 - r.y0;
    // f32 sums of coordinates relative to the box's corner (small numbers, so single precision
    // keeps the centroid to about 1e-4 px; the MCU has no double-precision FPU).
    let mut sums = [0.0f32; 3];
    // D of the pixels of one word of a row, by bit.
    let mut d_at = [0.0f32; 32];
    // The component's rows p − 7 ..= p (row q in slot q mod 8) and the ring's rows p − 9 ..= p
    // (slot q mod 10); the slots of rows above the component stay empty.
    let mut comp = [EMPTY; 8];
    let mut rings = [EMPTY; 10];
    let mut columns = Columns::new();
    // Rows with inside or band pixels: the component's, and 2 more above and below.
    for p in comp_rows.start..(comp_rows.end + 2).min(height) + 4 {
        let (c, ring) = match box_row_mut(mask, w, r, p) {
            Some(plane) if comp_rows.contains(&p) => gather_and_clear(plane),
            _ => (EMPTY, EMPTY),
        };
        if let Some(slot) = comp.get_mut(p % 8) {
            *slot = c;
        }
        // The column sums move on to rows p − 8 ..= p.
        if let Some(q) = p.checked_sub(9) {
            columns.remove_row(diff, values, rings.get(q % 10).unwrap_or(&EMPTY), r, q, n);
        }
        columns.add_row(diff, values, &ring, r, p, n);
        if let Some(slot) = rings.get_mut(p % 10) {
            *slot = ring;
        }
        let Some(y) = p.checked_sub(4) else {
            continue;
        };
        // Inside = eroded twice, band = dilated twice minus inside: rows y − 2 ..= y + 2.
        let mut v2 = *comp.get((y + 6) % 8).unwrap_or(&EMPTY);
        let mut grown = v2;
        for k in 7..11 {
            let row = comp.get((y + k) % 8).unwrap_or(&EMPTY);
            for ((a, o), b) in v2.iter_mut().zip(grown.iter_mut()).zip(row).take(n) {
                *a &= b;
                *o |= b;
            }
        }
        if grown == EMPTY {
            continue;
        }
        let inside = erode::<2>(&v2, n);
        let mut band = dilate2(&grown, shape);
        for (b, s) in band.iter_mut().zip(inside).take(n) {
            *b &= !s;
        }
        let yy = r.y0 + y;
        let image_rows = diff.rows(yy);
        let mut slide = Slide::default();
        for (i, (&si, &bi)) in inside.iter().zip(&band).enumerate().take(n) {
            let word = si | bi;
            if word == 0 {
                continue;
            }
            // D of the word's pixels first (of all between its first and last: one loop), then
            // the weights (no call between the sums).
            let (lo, hi) = (word.trailing_zeros() as usize, 32 - word.leading_zeros() as usize);
            if let Some(span) = d_at.get_mut(lo..hi) {
                d_span(diff, image_rows, r.x0 + 32 * i + lo, yy, span);
            }
            let ones = at_least_hole_ratio(&d_at, si, contrast);
            let row = RowWeights {
                contrast,
                y: y as f32,
                first: 32 * i,
            };
            sums = row.add(sums, &d_at, [si, bi, ones], &mut slide, &columns);
        }
    }
    let [sw, sx, sy] = sums;
    (sw > 0.0).then(|| [r.x0 as f32 + sx / sw, r.y0 as f32 + sy / sw])
}

/// The bits of `inside` (a word's inside pixels) whose `d_at[bit] / contrast ≥ HOLE_RATIO`: the
/// inside pixels that weigh 1. Division by `contrast` is monotonic, so when the pixel of the
/// least `D · sign(contrast)` from the first inside pixel to the last passes, all pass (one
/// reduction, no branch a pixel); else pixel by pixel.
#[inline]
fn at_least_hole_ratio(d_at: &[f32; 32], inside: u32, contrast: f32) -> u32 {
    let (lo, hi) = (inside.trailing_zeros() as usize, 32 - inside.leading_zeros() as usize);
    let sign = contrast.signum();
    // `sign` is ±1: the products are exact.
    // (A select rather than `f32::min`: D is never NaN, and the compiler makes it one vector
    // instruction.)
    let least = d_at
        .get(lo..hi)
        .unwrap_or(&[])
        .iter()
        .fold(f32::INFINITY, |m, &d| if d * sign < m { d * sign } else { m });
    if (least * sign) / contrast >= HOLE_RATIO {
        return inside;
    }
    let mut ones = 0u32;
    let mut bits = inside;
    while bits != 0 {
        let bit = bits.trailing_zeros();
        bits &= bits - 1;
        let d = d_at.get(bit as usize).copied().unwrap_or(0.0);
        ones |= u32::from(d / contrast >= HOLE_RATIO) << bit;
    }
    ones
}

/// What the weights of one row's pixels depend on, besides `D`.
struct RowWeights {
    contrast: f32,
    /// The row in the box.
    y: f32,
    /// The column of bit 0 of the word.
    first: usize,
}

impl RowWeights {
    /// `sums` (Σw, Σw·x, Σw·y) plus weight 1 for each pixel of `run` (bits of the word), the
    /// same bits as adding them one by one in increasing column: at once when the sums are
    /// sure to stay exact, else one by one.
    #[inline]
    fn add_ones(&self, sums: [f32; 3], run: u32) -> [f32; 3] {
        self.add_ones_at_once(sums, run).unwrap_or_else(|| {
            let [mut sw, mut sx, mut sy] = sums;
            let mut bits = run;
            while bits != 0 {
                let col = self.first + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                sw += 1.0;
                sx += col as u32 as f32;
                sy += self.y;
            }
            [sw, sx, sy]
        })
    }

    /// [`Self::add_ones`] with one addition per sum, `None` when that might round differently.
    #[inline]
    fn add_ones_at_once(&self, sums: [f32; 3], run: u32) -> Option<[f32; 3]> {
        // The number of pixels and the sum of their bits' indices.
        let low = run.trailing_zeros();
        let span = run.checked_shr(low).unwrap_or(0);
        let (count, bit_sum) = if span & span.wrapping_add(1) == 0 {
            // Columns low .. low + count.
            let count = span.count_ones();
            (count, count * low + count * count.saturating_sub(1) / 2)
        } else {
            let bit_sum = (run & 0xAAAA_AAAA).count_ones()
                + 2 * (run & 0xCCCC_CCCC).count_ones()
                + 4 * (run & 0xF0F0_F0F0).count_ones()
                + 8 * (run & 0xFF00_FF00).count_ones()
                + 16 * (run & 0xFFFF_0000).count_ones();
            (run.count_ones(), bit_sum)
        };
        let cols = u32::try_from(self.first)
            .ok()?
            .checked_mul(count)?
            .checked_add(bit_sum)?;
        let [sw, sx, sy] = sums;
        Some([
            exact_sum(sw, count as f32)?,
            exact_sum(sx, exact_integer(cols)?)?,
            // y is an integer and count ≤ 32: the product is exact when it is below 2^24.
            exact_sum(sy, exact_integer_f32(self.y * count as f32)?)?,
        ])
    }

    /// `sums` (Σw, Σw·x, Σw·y) plus the weights of the word's inside and band pixels, in
    /// increasing column; `d_at[bit]` is `D` of the pixel of `bit`, `ones` the inside pixels of
    /// weight 1 (their runs between the other pixels are added at once). Not inlined, so the
    /// sums stay in registers.
    #[inline(never)]
    fn add(
        &self,
        sums: [f32; 3],
        d_at: &[f32; 32],
        [inside, band, ones]: [u32; 3],
        slide: &mut Slide,
        columns: &Columns,
    ) -> [f32; 3] {
        let [mut sw, mut sx, mut sy] = sums;
        let contrast = self.contrast;
        let sign = contrast.signum();
        let mut bits = inside | band;
        // The pixels weighed one by one.
        let single = bits & !ones;
        while bits != 0 {
            let next = bits & single;
            let lowest = next & next.wrapping_neg();
            // The pixels of weight 1 before the next one weighed alone (all when there is none).
            let run = bits & lowest.wrapping_sub(1);
            if run != 0 {
                [sw, sx, sy] = self.add_ones([sw, sx, sy], run);
                bits &= !run;
            }
            if lowest == 0 {
                break;
            }
            bits &= !lowest;
            let bit = lowest.trailing_zeros();
            let col = self.first + bit as usize;
            let d = d_at.get(bit as usize).copied().unwrap_or(0.0);
            let weight = if inside & lowest != 0 {
                // Inside counts 1, unless the pixel looks like the platform: a small hole or a
                // narrow gap that the mask's closing filled. Printed labels keep at least a third
                // of the part's contrast, holes keep none. (Here the ratio is below
                // HOLE_RATIO: the others are in `ones`.)
                (d / contrast).clamp(0.0, 1.0)
            } else if d * sign > 0.0 {
                // The local contrast: mean D of the ring pixels within 4 px (shading across the
                // part changes it from one side to the other), else the part's median. (It has
                // the contrast's sign, so a D of the other sign weighs 0.)
                let (sum, count) = slide.around(col, columns);
                let mut local = contrast;
                if count > 0 {
                    // At least 1 in size, of the contrast's sign (`sign` is ±1: exact).
                    let mean = sum / count as f32;
                    if mean * sign >= 1.0 {
                        local = mean;
                    }
                }
                (d / local).clamp(0.0, 1.0)
            } else {
                0.0
            };
            if weight > 0.0 {
                sw += weight;
                sx += weight * col as u32 as f32;
                sy += weight * self.y;
            }
        }
        [sw, sx, sy]
    }
}

/// Below this, every integer is an `f32`.
const EXACT: f32 = 16_777_216.0;

/// `v` as an `f32` when that is exact.
#[inline]
fn exact_integer(v: u32) -> Option<f32> {
    (v <= 1 << 24).then_some(v as f32)
}

/// `v` (an integer-valued product) when it is below 2^24, so that it was computed exactly.
#[inline]
fn exact_integer_f32(v: f32) -> Option<f32> {
    (v < EXACT).then_some(v)
}

/// `s + t` for `s ≥ 0` and an integer `t ≥ 0` that stands for several integer terms added to `s`
/// one by one in f32, when none of those additions rounds (so that their result is `s + t`):
/// either `s` is an integer and the sum stays below 2^24 (every partial sum is an integer an
/// `f32` holds), or `s` and the sum share their exponent below 2^24 (every partial sum lies in
/// that binade, on its grid of at most 1). `None` otherwise.
#[inline]
fn exact_sum(s: f32, t: f32) -> Option<f32> {
    let total = s + t;
    // Rounding is monotonic: a computed sum below 2^24 means a true one below it.
    if !(s >= 0.0 && total < EXACT) {
        return None;
    }
    let same_binade = s.to_bits() >> 23 == total.to_bits() >> 23;
    // `s as u32` truncates (s < 2^24): s is an integer iff that converts back to s.
    (same_binade || s as u32 as f32 == s).then_some(total)
}

/// The frame's and the background's image row (see [`Difference::rows`]), when `D` is their
/// difference.
type ImageRows<'a> = Option<(&'a [u8], &'a [u8])>;

/// `D` at column `x` of image row `y` whose [`Difference::rows`] are `rows`: the value of
/// [`Difference::at`], from the rows when there are.
#[inline]
fn d_pixel<B: AsRef<[u8]>>(diff: &Difference<'_, B>, rows: ImageRows<'_>, x: usize, y: usize) -> f32 {
    match rows.and_then(|(f, b)| Some((f.get(x)?, b.get(x)?))) {
        // Both exact integers, so the difference is exact: the same `f32` as `at`'s.
        Some((&f, &b)) => (i32::from(f) - i32::from(b)) as f32,
        None => diff.at(x as isize, y as isize),
    }
}

/// `D` of columns `x .. x + out.len()` of image row `y` into `out`, the values of
/// [`Difference::at`]: one loop over `rows` (which the compiler vectorises) when they hold the
/// columns, else pixel by pixel.
#[inline]
fn d_span<B: AsRef<[u8]>>(diff: &Difference<'_, B>, rows: ImageRows<'_>, x: usize, y: usize, out: &mut [f32]) {
    let end = x + out.len();
    if let Some((f, b)) = rows.and_then(|(f, b)| Some((f.get(x..end)?, b.get(x..end)?))) {
        for ((o, &f), &b) in out.iter_mut().zip(f).zip(b) {
            *o = (i32::from(f) - i32::from(b)) as f32;
        }
    } else {
        for (o, col) in out.iter_mut().zip(x..) {
            *o = diff.at(col as isize, y as isize);
        }
    }
}

/// Row `q` of the box in the plane.
fn box_row(mask: &[u8], w: usize, r: Rect, q: usize) -> Option<&[u8]> {
    let start = (r.y0 + q) * w + r.x0;
    mask.get(start..start + (r.x1 - r.x0))
}

/// Row `q` of the box in the plane, mutable.
fn box_row_mut(mask: &mut [u8], w: usize, r: Rect, q: usize) -> Option<&mut [u8]> {
    let start = (r.y0 + q) * w + r.x0;
    mask.get_mut(start..start + (r.x1 - r.x0))
}

#[inline]
fn and_into(acc: &mut Bits, row: &Bits) {
    for (a, b) in acc.iter_mut().zip(row) {
        *a &= b;
    }
}

/// Horizontal erosion by the `(2K+1)`-segment (columns outside the row count as 0); `K < 32`.
fn erode<const K: u32>(src: &Bits, n: usize) -> Bits {
    let mut out = EMPTY;
    let mut prev = 0u32;
    for (i, o) in out.iter_mut().enumerate().take(n) {
        let cur = src.get(i).copied().unwrap_or(0);
        let next = src.get(i + 1).copied().unwrap_or(0);
        let mut acc = cur;
        for s in 1..=K {
            acc &= ((cur << s) | (prev >> (32 - s))) & ((cur >> s) | (next << (32 - s)));
        }
        *o = acc;
        prev = cur;
    }
    out
}

/// Horizontal dilation by the 5-segment, clipped to the box.
#[inline]
fn dilate2(src: &Bits, shape: Shape) -> Bits {
    let n = shape.words;
    let mut out = EMPTY;
    let mut prev = 0u32;
    for (i, o) in out.iter_mut().enumerate().take(n) {
        let cur = src.get(i).copied().unwrap_or(0);
        let next = if i + 1 < n {
            src.get(i + 1).copied().unwrap_or(0)
        } else {
            0
        };
        let left = (cur << 1) | (prev >> 31) | (cur << 2) | (prev >> 30);
        let right = (cur >> 1) | (next << 31) | (cur >> 2) | (next << 30);
        *o = cur | left | right;
        if i + 1 == n {
            *o &= shape.last;
        }
        prev = cur;
    }
    out
}

/// Calls `f` with the column of every set bit of the first `n` words of `bits`, in increasing
/// order.
#[inline]
fn for_each_bit(bits: &[u32], n: usize, mut f: impl FnMut(usize)) {
    for (i, &word) in bits.iter().enumerate().take(n) {
        let mut word = word;
        while word != 0 {
            let col = 32 * i + word.trailing_zeros() as usize;
            word &= word - 1;
            f(col);
        }
    }
}

/// The low bit of each of 8 bytes.
const LOW: u64 = 0x0101_0101_0101_0101;

/// Bit `i` of the result is the low bit of byte `i` of `v` (the other bits of `v` 0).
#[inline]
fn pack(v: u64) -> u32 {
    (v.wrapping_mul(0x0102_0408_1020_4080) >> 56) as u32
}

/// The bytes of `chunk` (at most 8) as a little-endian word, zeros past its end.
fn load8(chunk: &[u8]) -> u64 {
    let mut bytes = [0u8; 8];
    for (b, v) in bytes.iter_mut().zip(chunk) {
        *b = *v;
    }
    u64::from_le_bytes(bytes)
}

/// Bit `x` of the result is bit `bit` of `row[x]`, `x` < [`MAX_WIDTH`]. (Chunks of 8 bytes without
/// the bit, as most of a box's are, cost a test.)
fn gather(row: &[u8], bit: u32) -> Bits {
    let mut out = EMPTY;
    let mut chunks = row.chunks_exact(8);
    let mut k = 0usize;
    for chunk in &mut chunks {
        if let Ok(bytes) = <[u8; 8]>::try_from(chunk) {
            let v = (u64::from_le_bytes(bytes) >> bit) & LOW;
            if v != 0 {
                if let Some(word) = out.get_mut(k / 4) {
                    *word |= pack(v) << (8 * (k % 4));
                }
            }
        }
        k += 1;
    }
    if let Some(word) = out.get_mut(k / 4) {
        *word |= pack((load8(chunks.remainder()) >> bit) & LOW) << (8 * (k % 4));
    }
    out
}

/// [`COMPONENT`] and [`RING`] of `row` as bit rows (see [`gather`]); the row's bytes keep only
/// the mask bit. (Chunks of 8 bytes with only mask bits cost a test.)
fn gather_and_clear(row: &mut [u8]) -> (Bits, Bits) {
    let (mut comp, mut ring) = (EMPTY, EMPTY);
    let mut put = |k: usize, v: u64| {
        if let (Some(c), Some(g)) = (comp.get_mut(k / 4), ring.get_mut(k / 4)) {
            *c |= pack((v >> 7) & LOW) << (8 * (k % 4));
            *g |= pack((v >> 6) & LOW) << (8 * (k % 4));
        }
    };
    let mut chunks = row.chunks_exact_mut(8);
    let mut k = 0usize;
    for chunk in &mut chunks {
        if let Ok(bytes) = <&mut [u8; 8]>::try_from(chunk) {
            let v = u64::from_le_bytes(*bytes);
            if v & !LOW != 0 {
                put(k, v);
                *bytes = (v & LOW).to_le_bytes();
            }
        }
        k += 1;
    }
    let rest = chunks.into_remainder();
    put(k, load8(rest));
    for b in rest {
        *b &= 1;
    }
    (comp, ring)
}

/// Sets `flag` in the bytes of `row` whose bit in `bits` is set (8 bytes a step, only where
/// `bits` has any: ring rows are sparse).
fn scatter(row: &mut [u8], bits: &Bits, flag: u8) {
    for (i, &word) in bits.iter().enumerate() {
        let mut rest = word;
        while rest != 0 {
            // The byte of the bit row with the lowest set bit: bytes 8k .. 8k + 8 of `row`.
            let b = rest.trailing_zeros() / 8;
            let byte = (rest >> (8 * b)) & 0xFF;
            rest &= !(0xFF << (8 * b));
            // Byte j of `set` is `flag` when bit j of `byte` is set.
            let high = (((byte as u64 * LOW) & 0x8040_2010_0804_0201) + 0x7F7F_7F7F_7F7F_7F7F) & 0x8080_8080_8080_8080;
            let set = (high >> 7) * flag as u64;
            let start = 8 * (4 * i + b as usize);
            match row.get_mut(start..start + 8).map(<&mut [u8; 8]>::try_from) {
                Some(Ok(bytes)) => *bytes = (u64::from_le_bytes(*bytes) | set).to_le_bytes(),
                // The row's last bytes.
                _ => {
                    for (v, m) in row
                        .get_mut(start..)
                        .unwrap_or(&mut [])
                        .iter_mut()
                        .zip(set.to_le_bytes())
                    {
                        *v |= m;
                    }
                }
            }
        }
    }
}

/// Clears bits 1–7 of every byte of `row`.
fn keep_mask_bit(row: &mut [u8]) {
    let mut chunks = row.chunks_exact_mut(8);
    for chunk in &mut chunks {
        if let Ok(bytes) = <&mut [u8; 8]>::try_from(chunk) {
            *bytes = (u64::from_le_bytes(*bytes) & LOW).to_le_bytes();
        }
    }
    for v in chunks.into_remainder() {
        *v &= 1;
    }
}

/// Capacity of [`RingValues`].
const RING_VALUES: usize = 256;

/// `D` of consecutive ring pixels (numbered in raster order), so that each is read from the
/// difference image once: the first pass stores the first [`RING_VALUES`]; the second reads each
/// pixel's value twice, when its row enters the column sums and when it leaves them, and stores
/// the values it has to read anew while there is room. Not kept at all (each read when asked
/// for) when `D` comes from the image's rows, as cheap as a kept value.
struct RingValues {
    /// Whether values are kept at all (else each is read when asked for).
    keep: bool,
    values: [f32; RING_VALUES],
    /// The pixels stored, `[from, to)` (pixel `k` in slot `k mod RING_VALUES`).
    from: usize,
    to: usize,
    /// The next pixel to enter the sums, and to leave them.
    entering: usize,
    leaving: usize,
}

impl RingValues {
    fn new(keep: bool) -> Self {
        RingValues {
            keep,
            values: [0.0; RING_VALUES],
            from: 0,
            to: 0,
            entering: 0,
            leaving: 0,
        }
    }

    /// First pass: the next ring pixel's `D`.
    fn store(&mut self, d: f32) {
        if !self.keep {
            return;
        }
        if let Some(slot) = self.values.get_mut(self.to) {
            *slot = d;
            self.to += 1;
        }
    }

    /// `D` of the next pixel to enter the sums (`read` when it is not stored).
    #[inline]
    fn enter(&mut self, read: impl FnOnce() -> f32) -> f32 {
        if !self.keep {
            return read();
        }
        let k = self.entering;
        self.entering += 1;
        // Pixels leave in the order they enter, so `from <= k` here.
        if k < self.to {
            return self.values.get(k % RING_VALUES).copied().unwrap_or(0.0);
        }
        let d = read();
        // Stored while the stored pixels stay consecutive and fit, or afresh once none is.
        if self.from == self.to {
            (self.from, self.to) = (k, k);
        }
        if k == self.to && k - self.from < RING_VALUES {
            if let Some(slot) = self.values.get_mut(k % RING_VALUES) {
                *slot = d;
                self.to = k + 1;
            }
        }
        d
    }

    /// `D` of ring pixel `k` when it is stored: a pixel between entering and leaving the sums
    /// is, unless it was read when there was no room. (For the tests.)
    #[cfg(test)]
    fn peek(&self, k: usize) -> Option<f32> {
        if (self.from..self.to).contains(&k) {
            self.values.get(k % RING_VALUES).copied()
        } else {
            None
        }
    }

    /// `D` of the next pixel to leave the sums (`read` when it is not stored).
    #[inline]
    fn leave(&mut self, read: impl FnOnce() -> f32) -> f32 {
        if !self.keep {
            return read();
        }
        let k = self.leaving;
        self.leaving += 1;
        // While any pixel is stored, `k <= from`.
        if k == self.from && k < self.to {
            self.from += 1;
            return self.values.get(k % RING_VALUES).copied().unwrap_or(0.0);
        }
        read()
    }
}

/// The ring's `D` summed per column over 9 consecutive rows, and the number of ring pixels in each
/// sum; column `c` of the box at index `c + 4` (4 empty columns each side).
struct Columns {
    sum: [f32; MAX_WIDTH + 8],
    count: [u8; MAX_WIDTH + 8],
}

impl Columns {
    fn new() -> Self {
        Columns {
            sum: [0.0; MAX_WIDTH + 8],
            count: [0; MAX_WIDTH + 8],
        }
    }

    /// Adds the ring pixels `ring` of box row `q`.
    fn add_row<B: AsRef<[u8]>>(
        &mut self,
        diff: &Difference<'_, B>,
        values: &mut RingValues,
        ring: &Bits,
        r: Rect,
        q: usize,
        n: usize,
    ) {
        let y = r.y0 + q;
        let rows = diff.rows(y);
        for_each_bit(ring, n, |col| {
            let d = values.enter(|| d_pixel(diff, rows, r.x0 + col, y));
            if let (Some(s), Some(c)) = (self.sum.get_mut(col + 4), self.count.get_mut(col + 4)) {
                *s += d;
                // At most 9 (one a row).
                *c = c.saturating_add(1);
            }
        });
    }

    /// Removes the ring pixels `ring` of box row `q` (the oldest row in the sums).
    fn remove_row<B: AsRef<[u8]>>(
        &mut self,
        diff: &Difference<'_, B>,
        values: &mut RingValues,
        ring: &Bits,
        r: Rect,
        q: usize,
        n: usize,
    ) {
        let y = r.y0 + q;
        let rows = diff.rows(y);
        for_each_bit(ring, n, |col| {
            let d = values.leave(|| d_pixel(diff, rows, r.x0 + col, y));
            if let (Some(s), Some(c)) = (self.sum.get_mut(col + 4), self.count.get_mut(col + 4)) {
                *c = c.saturating_sub(1);
                // An empty column restarts from an exact 0.
                *s = if *c == 0 { 0.0 } else { *s - d };
            }
        });
    }
}

/// The sum of the 9 column sums around a column, sliding right along a row.
#[derive(Default)]
struct Slide {
    /// The column of the last call plus 1 (0: none yet).
    next: usize,
    sum: f32,
    count: u32,
}

impl Slide {
    /// The ring's `D` summed over columns `col − 4 ..= col + 4` (clipped to the box), and the
    /// number of ring pixels in the sum; `col` above the previous call's.
    #[inline]
    fn around(&mut self, col: usize, columns: &Columns) -> (f32, u32) {
        // Padded, the window is [col, col + 9).
        if self.next != 0 && col == self.next {
            // One column enters, one leaves.
            let enter = (columns.sum.get(col + 8), columns.count.get(col + 8));
            let leave = (
                columns.sum.get(col.wrapping_sub(1)),
                columns.count.get(col.wrapping_sub(1)),
            );
            if let ((Some(s_in), Some(&c_in)), (Some(s_out), Some(&c_out))) = (enter, leave) {
                self.sum = self.sum + s_in - s_out;
                self.count = (self.count + c_in as u32).saturating_sub(c_out as u32);
            }
        } else {
            let window = col..col + 9;
            self.sum = columns
                .sum
                .get(window.clone())
                .unwrap_or(&[])
                .iter()
                .fold(0.0, |a, s| a + s);
            self.count = columns.count.get(window).unwrap_or(&[]).iter().map(|&c| c as u32).sum();
        }
        if self.count == 0 {
            self.sum = 0.0;
        }
        self.next = col + 1;
        (self.sum, self.count)
    }
}

/// Marks the 8-connected foreground component of `seed` (inside `r`) with [`COMPONENT`]: a
/// scanline fill with a fixed stack; when the stack overflows, repeated raster passes finish the
/// job (bounded by the box's size). Returns the box's rows that hold the component (all of them
/// after an overflow).
fn mark_component(mask: &mut [u8], w: usize, r: Rect, seed: (usize, usize)) -> Range<usize> {
    mark_component_with::<256>(mask, w, r, seed)
}

/// [`mark_component`] with a stack of `STACK` spans. Not inlined: its stack need not stay
/// allocated while the centroid is measured.
#[inline(never)]
fn mark_component_with<const STACK: usize>(mask: &mut [u8], w: usize, r: Rect, seed: (usize, usize)) -> Range<usize> {
    let width = r.x1 - r.x0;
    // (column, row) in the box.
    let mut stack = [(0u32, 0u32); STACK];
    let mut top = 0usize;
    let mut overflow = false;
    // The rows marked (the seed's row at least).
    let (mut top_row, mut bottom_row) = (seed.1, seed.1);
    match (
        stack.get_mut(0),
        u32::try_from(seed.0 - r.x0),
        u32::try_from(seed.1 - r.y0),
    ) {
        (Some(slot), Ok(x), Ok(y)) => {
            *slot = (x, y);
            top = 1;
        }
        _ => overflow = true,
    }
    while top > 0 {
        top -= 1;
        let Some(&(x, y)) = stack.get(top) else { break };
        let (x, y) = (x as usize, r.y0 + y as usize);
        let Some(row) = mask.get_mut(y * w + r.x0..y * w + r.x1) else {
            continue;
        };
        if !row.get(x).is_some_and(|&v| is_free(v)) {
            continue;
        }
        let xl = x - row.get(..x).map_or(0, free_suffix);
        let xr = x + row.get(x + 1..).map_or(0, free_prefix);
        set_flag(row.get_mut(xl..=xr).unwrap_or(&mut []), COMPONENT);
        (top_row, bottom_row) = (top_row.min(y), bottom_row.max(y));
        for ny in [y.wrapping_sub(1), y + 1] {
            if ny < r.y0 || ny >= r.y1 {
                continue;
            }
            let lo = xl.saturating_sub(1);
            let hi = (xr + 1).min(width - 1);
            let Some(next) = mask.get(ny * w + r.x0 + lo..=ny * w + r.x0 + hi) else {
                continue;
            };
            let by = (ny - r.y0) as u32;
            for_each_run_start(next, |k| match stack.get_mut(top) {
                // The box's width fits a u32 here: the seed's column did.
                Some(slot) => {
                    *slot = ((lo + k) as u32, by);
                    top += 1;
                }
                None => overflow = true,
            });
        }
    }
    if !overflow {
        return top_row - r.y0..bottom_row + 1 - r.y0;
    }
    let free_at = |mask: &[u8], x: usize, y: usize| mask.get(y * w + x).is_some_and(|&v| is_free(v));
    let mut changed = true;
    let mut passes = 0usize;
    while changed && passes < (r.x1 - r.x0) + (r.y1 - r.y0) + 2 {
        changed = false;
        for forward in [true, false] {
            for yi in 0..(r.y1 - r.y0) {
                let y = if forward { r.y0 + yi } else { r.y1 - 1 - yi };
                for xi in 0..(r.x1 - r.x0) {
                    let x = if forward { r.x0 + xi } else { r.x1 - 1 - xi };
                    if free_at(mask, x, y) && any_neighbour(mask, w, r, x, y, COMPONENT) {
                        if let Some(p) = mask.get_mut(y * w + x) {
                            *p |= COMPONENT;
                        }
                        changed = true;
                    }
                }
            }
        }
        passes += 1;
    }
    0..r.y1 - r.y0
}

/// Sets `flag` in every byte of `span`, 8 a step.
fn set_flag(span: &mut [u8], flag: u8) {
    let mut chunks = span.chunks_exact_mut(8);
    for chunk in &mut chunks {
        if let Ok(bytes) = <&mut [u8; 8]>::try_from(chunk) {
            *bytes = (u64::from_le_bytes(*bytes) | (LOW * flag as u64)).to_le_bytes();
        }
    }
    for v in chunks.into_remainder() {
        *v |= flag;
    }
}

/// A pixel of the mask not yet marked as the component's.
#[inline]
fn is_free(v: u8) -> bool {
    v & 1 != 0 && v & COMPONENT == 0
}

/// Byte `i` is 1 when pixel `i` of the 8 is free.
#[inline]
fn free_bytes(chunk: &[u8]) -> u64 {
    let v = u64::from_le_bytes(<[u8; 8]>::try_from(chunk).unwrap_or([0; 8]));
    v & !(v >> 7) & LOW
}

/// The number of free pixels at the start of `row`.
fn free_prefix(row: &[u8]) -> usize {
    let mut n = 0;
    let mut chunks = row.chunks_exact(8);
    for chunk in &mut chunks {
        let free = free_bytes(chunk);
        if free != LOW {
            return n + ((!free & LOW).trailing_zeros() / 8) as usize;
        }
        n += 8;
    }
    n + chunks.remainder().iter().take_while(|&&v| is_free(v)).count()
}

/// The number of free pixels at the end of `row`.
fn free_suffix(row: &[u8]) -> usize {
    let mut n = 0;
    let mut chunks = row.rchunks_exact(8);
    for chunk in &mut chunks {
        let free = free_bytes(chunk);
        if free != LOW {
            return n + ((!free & LOW).leading_zeros() / 8) as usize;
        }
        n += 8;
    }
    n + chunks.remainder().iter().rev().take_while(|&&v| is_free(v)).count()
}

/// Calls `f` with the index of the first pixel of every run of free pixels (mask bit set,
/// [`COMPONENT`] clear) in `row`, in increasing order; 8 pixels a step.
fn for_each_run_start(row: &[u8], mut f: impl FnMut(usize)) {
    // 1 when the pixel before the current one is free.
    let mut prev = 0u32;
    let mut chunks = row.chunks_exact(8);
    let mut k = 0usize;
    for chunk in &mut chunks {
        let free = free_bytes(chunk);
        if free == 0 {
            prev = 0;
        } else if free != LOW || prev == 0 {
            // Byte i's flag to bit i.
            let bits = (free.wrapping_mul(0x0102_0408_1020_4080) >> 56) as u32;
            let mut starts = bits & !((bits << 1) | prev);
            while starts != 0 {
                f(k + starts.trailing_zeros() as usize);
                starts &= starts - 1;
            }
            prev = bits >> 7;
        }
        k += 8;
    }
    for &v in chunks.remainder() {
        let free = is_free(v) as u32;
        if free > prev {
            f(k);
        }
        prev = free;
        k += 1;
    }
}

fn any_neighbour(mask: &[u8], w: usize, r: Rect, x: usize, y: usize, bit: u8) -> bool {
    for dy in -1isize..=1 {
        for dx in -1isize..=1 {
            let (nx, ny) = (x as isize + dx, y as isize + dy);
            if nx < r.x0 as isize || ny < r.y0 as isize || nx >= r.x1 as isize || ny >= r.y1 as isize {
                continue;
            }
            if mask.get(ny as usize * w + nx as usize).is_some_and(|v| v & bit != 0) {
                return true;
            }
        }
    }
    false
}

/// The per-pixel path for boxes wider than [`MAX_WIDTH`]: 3×3 passes over flag bits of the plane
/// and a 9×9 window per band pixel.
mod per_pixel {
    use super::{Rect, COMPONENT, HOLE_RATIO};
    use crate::refine::Difference;

    const GROWN: u8 = 1 << 2;
    const SHRUNK: u8 = 1 << 3;
    const SCRATCH: u8 = 1 << 4;
    const RING: u8 = 1 << 5;
    /// Horizontal scratch bit of the separable 3×3 passes.
    const HORIZONTAL: u8 = 1 << 6;

    /// [`super::partial_volume_centroid`] after the component is marked; clears bits 1–7 in the
    /// box.
    pub(super) fn centroid<B: AsRef<[u8]>>(
        diff: &Difference<'_, B>,
        mask: &mut [u8],
        w: usize,
        r: Rect,
    ) -> Option<[f32; 2]> {
        // Band = grown by 2 minus shrunk by 2; ring = shrunk by 3 minus shrunk by 5.
        morph_bits(mask, w, r, COMPONENT, GROWN, false);
        morph_bits(mask, w, r, GROWN, SCRATCH, false);
        move_bit(mask, w, r, SCRATCH, GROWN);
        morph_bits(mask, w, r, COMPONENT, SHRUNK, true);
        morph_bits(mask, w, r, SHRUNK, SCRATCH, true);
        move_bit(mask, w, r, SCRATCH, SHRUNK);
        morph_bits(mask, w, r, SHRUNK, RING, true);
        morph_bits(mask, w, r, RING, SCRATCH, true);
        morph_bits(mask, w, r, SCRATCH, RING, true);
        // RING now = shrunk by 5; ring = shrunk by 3 (SCRATCH after one more) minus shrunk by 5.
        morph_bits(mask, w, r, SHRUNK, SCRATCH, true);
        // Contrast: median of D over the ring (signed, from a histogram).
        let mut hist = [0u16; 511];
        let mut ring_count = 0usize;
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let v = mask.get(y * w + x).copied().unwrap_or(0);
                if v & SCRATCH != 0 && v & RING == 0 {
                    let d = diff.at(x as isize, y as isize);
                    let bin = (d as i32 + 255).clamp(0, 510) as usize;
                    if let Some(hb) = hist.get_mut(bin) {
                        *hb = hb.saturating_add(1);
                    }
                    ring_count += 1;
                }
            }
        }
        let contrast = if ring_count > 0 {
            let mut acc = 0usize;
            let mut med = 0.0f32;
            for (bin, &c) in hist.iter().enumerate() {
                acc += c as usize;
                if 2 * acc >= ring_count {
                    med = bin as f32 - 255.0;
                    break;
                }
            }
            med
        } else {
            0.0
        };
        let (mut sw, mut sx, mut sy) = (0.0f32, 0.0f32, 0.0f32);
        if contrast.abs() >= 1.0 {
            for y in r.y0..r.y1 {
                for x in r.x0..r.x1 {
                    let v = mask.get(y * w + x).copied().unwrap_or(0);
                    let weight = if v & SHRUNK != 0 {
                        let ratio = diff.at(x as isize, y as isize) / contrast;
                        if ratio >= HOLE_RATIO {
                            1.0
                        } else {
                            ratio.clamp(0.0, 1.0)
                        }
                    } else if v & GROWN != 0 {
                        let local = local_ring_mean(diff, mask, w, r, x, y)
                            .filter(|c| c.abs() >= 1.0 && c.signum() == contrast.signum());
                        (diff.at(x as isize, y as isize) / local.unwrap_or(contrast)).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    if weight > 0.0 {
                        sw += weight;
                        sx += weight * (x - r.x0) as f32;
                        sy += weight * (y - r.y0) as f32;
                    }
                }
            }
        }
        for y in r.y0..r.y1 {
            if let Some(row) = mask.get_mut(y * w + r.x0..y * w + r.x1) {
                super::keep_mask_bit(row);
            }
        }
        (sw > 0.0).then(|| [r.x0 as f32 + sx / sw, r.y0 as f32 + sy / sw])
    }

    /// Mean `D` of the ring pixels (bit `SCRATCH` set, `RING` clear) within 4 px of `(x, y)`.
    fn local_ring_mean<B: AsRef<[u8]>>(
        diff: &Difference<'_, B>,
        mask: &[u8],
        w: usize,
        r: Rect,
        x: usize,
        y: usize,
    ) -> Option<f32> {
        const RADIUS: usize = 4;
        let (mut sum, mut count) = (0.0f32, 0usize);
        for yy in y.saturating_sub(RADIUS).max(r.y0)..(y + RADIUS + 1).min(r.y1) {
            for xx in x.saturating_sub(RADIUS).max(r.x0)..(x + RADIUS + 1).min(r.x1) {
                let v = mask.get(yy * w + xx).copied().unwrap_or(0);
                if v & SCRATCH != 0 && v & RING == 0 {
                    sum += diff.at(xx as isize, yy as isize);
                    count += 1;
                }
            }
        }
        (count > 0).then(|| sum / count as f32)
    }

    /// `dst` bit = 3×3 erosion (or dilation) of the `src` bit inside `r` (outside `r` counts as
    /// 0), as a horizontal then a vertical 3-tap pass.
    fn morph_bits(mask: &mut [u8], w: usize, r: Rect, src: u8, dst: u8, erode: bool) {
        let width = r.x1.saturating_sub(r.x0);
        if width == 0 {
            return;
        }
        for y in r.y0..r.y1 {
            let Some(row) = mask.get_mut(y * w + r.x0..y * w + r.x1) else {
                continue;
            };
            let mut prev = false; // outside r
            for x in 0..width {
                let cur = row.get(x).is_some_and(|v| v & src != 0);
                let next = x + 1 < width && row.get(x + 1).is_some_and(|v| v & src != 0);
                let on = if erode {
                    prev && cur && next
                } else {
                    prev || cur || next
                };
                if let Some(v) = row.get_mut(x) {
                    *v = if on { *v | HORIZONTAL } else { *v & !HORIZONTAL };
                }
                prev = cur;
            }
        }
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let at = |yy: usize| mask.get(yy * w + x).is_some_and(|v| v & HORIZONTAL != 0);
                let up = y > r.y0 && at(y - 1);
                let cur = at(y);
                let down = y + 1 < r.y1 && at(y + 1);
                let on = if erode { up && cur && down } else { up || cur || down };
                if let Some(v) = mask.get_mut(y * w + x) {
                    *v = if on { *v | dst } else { *v & !dst };
                }
            }
        }
        // HORIZONTAL is left set on some pixels; the caller clears bits 1.. at the end.
    }

    fn move_bit(mask: &mut [u8], w: usize, r: Rect, from: u8, to: u8) {
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                if let Some(v) = mask.get_mut(y * w + x) {
                    *v = if *v & from != 0 {
                        (*v | to) & !from
                    } else {
                        *v & !(to | from)
                    };
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::enhance::Alpha;
    use crate::frame::Frame;
    use std::boxed::Box;
    use std::vec;
    use std::vec::Vec;

    use crate::test_rng::XorShift as Rng;

    /// Signed distance to a shape (negative inside), px.
    type Shape = Box<dyn Fn(f32, f32) -> f32>;

    fn disc(cx: f32, cy: f32, radius: f32) -> Shape {
        Box::new(move |x, y| ((x - cx).powi(2) + (y - cy).powi(2)).sqrt() - radius)
    }

    /// A random shape: discs, turned rectangles, discs with holes, 1-px rings, tiny specks,
    /// anywhere including across the image's border.
    fn random_shape(rng: &mut Rng, w: usize, h: usize) -> Shape {
        let (wf, hf) = (w as f32, h as f32);
        let cx = rng.range(-0.15 * wf, 1.15 * wf);
        let cy = rng.range(-0.15 * hf, 1.15 * hf);
        let size = wf.min(hf);
        match rng.below(7) {
            0 => disc(cx, cy, rng.range(0.3, 0.5 * size)),
            1 | 2 => {
                let (hw, hh) = (rng.range(0.5, 0.45 * wf), rng.range(0.5, 0.45 * hf));
                let a = if rng.chance(0.5) { 0.0 } else { rng.range(0.0, 3.2) };
                let (s, c) = a.sin_cos();
                Box::new(move |x, y| {
                    let (px, py) = (x - cx, y - cy);
                    let (qx, qy) = ((c * px + s * py).abs() - hw, (c * py - s * px).abs() - hh);
                    let outside = (qx.max(0.0).powi(2) + qy.max(0.0).powi(2)).sqrt();
                    outside + qx.max(qy).min(0.0)
                })
            }
            3 => {
                // A disc with a hole (off-centre), possibly touching its rim.
                let radius = rng.range(3.0, 0.5 * size + 3.0);
                let hole = rng.range(0.5, 0.6 * radius);
                let (hx, hy) = (cx + rng.range(-0.5, 0.5) * radius, cy + rng.range(-0.5, 0.5) * radius);
                Box::new(move |x, y| {
                    let outer = ((x - cx).powi(2) + (y - cy).powi(2)).sqrt() - radius;
                    let inner = hole - ((x - hx).powi(2) + (y - hy).powi(2)).sqrt();
                    outer.max(inner)
                })
            }
            4 => {
                // A ring about 1 px wide.
                let radius = rng.range(1.0, 0.5 * size + 1.0);
                let half = rng.range(0.3, 0.8);
                Box::new(move |x, y| (((x - cx).powi(2) + (y - cy).powi(2)).sqrt() - radius).abs() - half)
            }
            5 => {
                // A speck.
                let (x0, y0) = (rng.below(w) as f32, rng.below(h) as f32);
                let (hw, hh) = (rng.range(0.2, 1.5), rng.range(0.2, 1.5));
                Box::new(move |x, y| ((x - x0).abs() - hw).max((y - y0).abs() - hh))
            }
            _ => {
                // Two discs a few px apart (either may fall in the other's box).
                let r1 = rng.range(1.0, 0.3 * size + 1.0);
                let r2 = rng.range(1.0, 0.3 * size + 1.0);
                let gap = rng.range(0.5, 4.0);
                let a = rng.range(0.0, 6.3);
                let (dx, dy) = ((r1 + r2 + gap) * a.cos(), (r1 + r2 + gap) * a.sin());
                let (d1, d2) = (disc(cx, cy, r1), disc(cx + dx, cy + dy, r2));
                Box::new(move |x, y| d1(x, y).min(d2(x, y)))
            }
        }
    }

    /// A frame, its background and the 0/1 mask `|D| > τ`.
    struct Scene {
        w: usize,
        h: usize,
        frame: Vec<u8>,
        background: Vec<u8>,
        mask: Vec<u8>,
    }

    fn scene(rng: &mut Rng, w: usize, h: usize, alpha: Alpha) -> Scene {
        let base = 20.0 + rng.range(0.0, 80.0);
        let tilt = rng.range(-0.3, 0.3);
        let background: Vec<u8> = (0..w * h)
            .map(|i| (base + tilt * (i % w) as f32 + rng.below(4) as f32).clamp(0.0, 255.0) as u8)
            .collect();
        let sign = if rng.chance(0.7) { 1.0 } else { -1.0 };
        let amplitude = rng.range(25.0, 150.0);
        let shading = rng.range(-0.4, 0.4);
        let mut cover = vec![0.0f32; w * h];
        for _ in 0..1 + rng.below(6) {
            let shape = random_shape(rng, w, h);
            let blur = rng.range(0.3, 3.0);
            // Part of some parts is a printed label of lower contrast.
            let label = rng
                .chance(0.3)
                .then(|| (rng.below(w), rng.below(h), 1 + rng.below(8), rng.range(0.3, 0.7)));
            for y in 0..h {
                for x in 0..w {
                    let mut c = (0.5 - shape(x as f32, y as f32) / blur).clamp(0.0, 1.0);
                    if let Some((lx, ly, ls, lf)) = label {
                        if x.abs_diff(lx) < ls && y.abs_diff(ly) < ls {
                            c *= lf;
                        }
                    }
                    let slot = &mut cover[y * w + x];
                    *slot = slot.max(c);
                }
            }
        }
        let frame: Vec<u8> = (0..w * h)
            .map(|i| {
                let gain = 1.0 + shading * ((i % w) as f32 / w as f32 - 0.5);
                let noise = rng.below(5) as f32 - 2.0;
                (background[i] as f32 + sign * amplitude * gain * cover[i] + noise).clamp(0.0, 255.0) as u8
            })
            .collect();
        let mut mask = vec![0u8; w * h];
        {
            let f = Frame::new_checked(&frame[..], w, h).unwrap();
            let diff = Difference::new(&f, &background, alpha);
            let tau = amplitude * rng.range(0.25, 0.6);
            for y in 0..h {
                for x in 0..w {
                    mask[y * w + x] = (diff.at(x as isize, y as isize).abs() > tau) as u8;
                }
            }
        }
        if rng.chance(0.3) {
            // Specks and pinholes.
            for _ in 0..rng.below(w * h / 20 + 1) {
                let i = rng.below(w * h);
                mask[i] ^= 1;
            }
        }
        if rng.chance(0.05) {
            // Dense noise: one big ragged component.
            let density = rng.range(0.45, 0.75);
            for m in mask.iter_mut() {
                *m = rng.chance(density) as u8;
            }
        }
        Scene {
            w,
            h,
            frame,
            background,
            mask,
        }
    }

    /// The 8-connected components of a 0/1 plane: their pixels, first the top-left one.
    fn components(mask: &[u8], w: usize, h: usize) -> Vec<Vec<(usize, usize)>> {
        let mut seen = vec![false; w * h];
        let mut out = Vec::new();
        for y in 0..h {
            for x in 0..w {
                if mask[y * w + x] == 0 || seen[y * w + x] {
                    continue;
                }
                let mut pixels = vec![(x, y)];
                seen[y * w + x] = true;
                let mut k = 0;
                while k < pixels.len() {
                    let (px, py) = pixels[k];
                    k += 1;
                    for ny in py.saturating_sub(1)..(py + 2).min(h) {
                        for nx in px.saturating_sub(1)..(px + 2).min(w) {
                            if mask[ny * w + nx] != 0 && !seen[ny * w + nx] {
                                seen[ny * w + nx] = true;
                                pixels.push((nx, ny));
                            }
                        }
                    }
                }
                out.push(pixels);
            }
        }
        out
    }

    fn bounding_box(pixels: &[(usize, usize)]) -> Rect {
        let mut r = Rect {
            x0: usize::MAX,
            y0: usize::MAX,
            x1: 0,
            y1: 0,
        };
        for &(x, y) in pixels {
            r.x0 = r.x0.min(x);
            r.y0 = r.y0.min(y);
            r.x1 = r.x1.max(x + 1);
            r.y1 = r.y1.max(y + 1);
        }
        r
    }

    #[derive(Default, Debug)]
    struct Tally {
        calls: usize,
        some: usize,
        bit_identical: usize,
        worst: f32,
    }

    /// Old and new on copies of the plane: same `Option`, centroids within `tolerance` (0: the
    /// same bits), the same plane afterwards.
    fn compare(scene: &Scene, alpha: Alpha, seed: (usize, usize), bbox: Rect, tolerance: f32, tally: &mut Tally) {
        let (w, h) = (scene.w, scene.h);
        let frame = Frame::new_checked(&scene.frame[..], w, h).unwrap();
        let diff = Difference::new(&frame, &scene.background, alpha);
        let mut old_plane = scene.mask.clone();
        let mut new_plane = scene.mask.clone();
        let new = partial_volume_centroid(&diff, &mut new_plane, seed, bbox);
        let inside = seed.0 + MARGIN >= bbox.x0
            && seed.0 < bbox.x1.saturating_add(MARGIN)
            && seed.1 + MARGIN >= bbox.y0
            && seed.1 < bbox.y1.saturating_add(MARGIN);
        if !inside {
            assert_eq!(new, None, "seed {seed:?} outside the box {bbox:?}");
            assert!(new_plane == scene.mask, "plane touched, seed outside the box");
            return;
        }
        let old = reference::reference_partial_volume_centroid(&diff, &mut old_plane, seed, bbox);
        tally.calls += 1;
        let context = || std::format!("{w}x{h} seed {seed:?} box {bbox:?}: old {old:?} new {new:?}");
        assert!(new_plane == old_plane, "planes differ afterwards, {}", context());
        assert!(new_plane.iter().all(|&v| v <= 1), "plane not 0/1, {}", context());
        match (old, new) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                tally.some += 1;
                if a.map(f32::to_bits) == b.map(f32::to_bits) {
                    tally.bit_identical += 1;
                }
                let err = (a[0] - b[0]).abs().max((a[1] - b[1]).abs());
                tally.worst = tally.worst.max(err);
                assert!(err <= tolerance, "centroids differ by {err}, {}", context());
            }
            _ => panic!("Option-ness differs, {}", context()),
        }
    }

    /// Random scenes; every component's top-left pixel (what the recognizer passes) and a few
    /// random pixels as seeds, with the component's box or a perturbed one.
    fn random_scenes(seed: u64, scenes: usize, alpha: f32, tolerance: f32) -> Tally {
        let alpha = Alpha::new(alpha).unwrap();
        let mut rng = Rng(seed);
        let mut tally = Tally::default();
        for _ in 0..scenes {
            let (w, h) = if rng.chance(0.04) {
                (230 + rng.below(60), 6 + rng.below(30))
            } else {
                (1 + rng.below(72), 1 + rng.below(72))
            };
            let scene = scene(&mut rng, w, h, alpha);
            for pixels in components(&scene.mask, w, h).iter().take(12) {
                let exact = bounding_box(pixels);
                let mut seeds = vec![pixels[0]];
                for _ in 0..2 {
                    seeds.push(pixels[rng.below(pixels.len())]);
                }
                for seed in seeds {
                    let bbox = if rng.chance(0.25) {
                        let mut jitter = |v: usize| (v as isize + rng.below(17) as isize - 8).max(0) as usize;
                        let (x0, y0, x1, y1) = (jitter(exact.x0), jitter(exact.y0), jitter(exact.x1), jitter(exact.y1));
                        Rect {
                            x0,
                            y0,
                            x1: x1.max(x0),
                            y1: y1.max(y0),
                        }
                    } else {
                        exact
                    };
                    compare(&scene, alpha, seed, bbox, tolerance, &mut tally);
                }
            }
        }
        tally
    }

    fn cases(default: usize) -> usize {
        std::env::var("VORL_PV_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(default)
    }

    #[test]
    fn matches_the_reference_on_random_scenes() {
        // α = 1: D is an integer, so every sum is exact and the result has the same bits.
        let tally = random_scenes(0x9E37_79B9_7F4A_7C15, cases(400), 1.0, 0.0);
        std::println!("{tally:?}");
        assert!(tally.calls > 2000 && tally.some > 400, "{tally:?}");
        assert_eq!(tally.bit_identical, tally.some);
    }

    #[test]
    fn matches_the_reference_with_alpha_one_half() {
        // α < 1: D is fractional and the local sums are added in another order.
        let tally = random_scenes(0x2545_F491_4F6C_DD1D, cases(400), 0.5, 1e-4);
        std::println!("{tally:?}");
        assert!(tally.calls > 2000 && tally.some > 300, "{tally:?}");
    }

    #[test]
    fn box_width_at_the_bit_row_limit() {
        // Bar parts whose box (bbox + 2·6) is 250..=262 px wide: both paths and the switch.
        let (w, h) = (280, 24);
        let alpha = Alpha::ONE;
        let mut tally = Tally::default();
        for (k, bar) in (238..=250).enumerate() {
            let mut rng = Rng(77 + k as u64);
            let x0 = 8.0 + rng.below(10) as f32 + rng.unit();
            let shape = move |x: f32, y: f32| {
                ((x - x0 - bar as f32 / 2.0).abs() - bar as f32 / 2.0).max((y - 11.3).abs() - 5.0)
            };
            let background = vec![40u8; w * h];
            let frame: Vec<u8> = (0..w * h)
                .map(|i| {
                    let c = (0.5f32 - shape((i % w) as f32, (i / w) as f32) / 1.5).clamp(0.0, 1.0);
                    (40.0 + 120.0 * c) as u8 + rng.below(3) as u8
                })
                .collect();
            let mask: Vec<u8> = frame.iter().map(|&v| (v > 100) as u8).collect();
            let scene = Scene {
                w,
                h,
                frame,
                background,
                mask,
            };
            for pixels in components(&scene.mask, w, h) {
                compare(&scene, alpha, pixels[0], bounding_box(&pixels), 0.0, &mut tally);
            }
        }
        assert!(tally.some >= 13, "{tally:?}");
        assert_eq!(tally.bit_identical, tally.some);
    }

    #[test]
    fn bad_input_gives_none_without_panic() {
        let (w, h) = (30, 20);
        let frame_px = vec![90u8; w * h];
        let background = vec![10u8; w * h];
        let frame = Frame::new_checked(&frame_px[..], w, h).unwrap();
        let diff = Difference::new(&frame, &background, Alpha::ONE);
        let mut mask = vec![0u8; w * h];
        for y in 3..17 {
            for x in 4..24 {
                mask[y * w + x] = 1;
            }
        }
        let bbox = Rect {
            x0: 4,
            y0: 3,
            x1: 24,
            y1: 17,
        };
        let original = mask.clone();
        // A plane shorter than the image.
        let mut short = mask[..w * h - 1].to_vec();
        assert_eq!(partial_volume_centroid(&diff, &mut short, (5, 5), bbox), None);
        assert_eq!(partial_volume_centroid(&diff, &mut [], (5, 5), bbox), None);
        // Seeds outside the image or on the background; a seed outside its box.
        for seed in [(w, 5), (5, h), (usize::MAX, usize::MAX), (0, 0), (29, 19)] {
            assert_eq!(partial_volume_centroid(&diff, &mut mask, seed, bbox), None, "{seed:?}");
            assert_eq!(mask, original);
        }
        let boxes = [
            Rect {
                x0: 12,
                y0: 0,
                x1: 15,
                y1: 9,
            },
            Rect {
                x0: usize::MAX,
                y0: usize::MAX,
                x1: usize::MAX,
                y1: usize::MAX,
            },
            Rect {
                x0: 30,
                y0: 0,
                x1: 2,
                y1: 1,
            },
        ];
        for b in boxes {
            assert_eq!(partial_volume_centroid(&diff, &mut mask, (5, 5), b), None, "{b:?}");
            assert_eq!(mask, original);
        }
        // D is 80 everywhere: the part and its 2-px band count 1. A huge box is clipped.
        for b in [
            bbox,
            Rect {
                x0: 0,
                y0: 0,
                x1: usize::MAX,
                y1: usize::MAX,
            },
        ] {
            let c = partial_volume_centroid(&diff, &mut mask, (5, 5), b).unwrap();
            assert!((c[0] - 13.5).abs() < 1e-4 && (c[1] - 9.5).abs() < 1e-4, "{c:?}");
            assert_eq!(mask, original);
        }
    }

    #[test]
    fn component_fill_finishes_after_its_stack_overflows() {
        // A 2-span stack on ragged random masks: the raster passes must still find the whole
        // 8-connected component, inside the box only.
        let mut rng = Rng(12345);
        for _ in 0..40 {
            let (w, h) = (5 + rng.below(60), 5 + rng.below(60));
            let density = rng.range(0.4, 0.8);
            let mask: Vec<u8> = (0..w * h).map(|_| rng.chance(density) as u8).collect();
            let r = Rect {
                x0: rng.below(w / 3),
                y0: rng.below(h / 3),
                x1: w - rng.below(w / 3),
                y1: h - rng.below(h / 3),
            };
            let seed = (r.x0 + rng.below(r.x1 - r.x0), r.y0 + rng.below(r.y1 - r.y0));
            if mask[seed.1 * w + seed.0] == 0 {
                continue;
            }
            // The component within the box.
            let (bw, bh) = (r.x1 - r.x0, r.y1 - r.y0);
            let boxed: Vec<u8> = (0..bw * bh)
                .map(|i| mask[(r.y0 + i / bw) * w + r.x0 + i % bw])
                .collect();
            let comps = components(&boxed, bw, bh);
            let want = comps
                .iter()
                .find(|c| c.contains(&(seed.0 - r.x0, seed.1 - r.y0)))
                .unwrap();
            let top = want.iter().map(|p| p.1).min().unwrap();
            let bottom = want.iter().map(|p| p.1).max().unwrap() + 1;
            for small in [false, true] {
                let mut plane = mask.clone();
                let rows = if small {
                    mark_component_with::<2>(&mut plane, w, r, seed)
                } else {
                    mark_component(&mut plane, w, r, seed)
                };
                // The rows it reports hold the whole component.
                assert!(rows.start <= top && bottom <= rows.end && rows.end <= bh, "{rows:?}");
                if !small {
                    assert_eq!(rows, top..bottom);
                }
                let marked = plane.iter().filter(|&&v| v & COMPONENT != 0).count();
                assert_eq!(marked, want.len());
                for &(x, y) in want {
                    assert!(plane[(r.y0 + y) * w + r.x0 + x] & COMPONENT != 0);
                }
            }
        }
    }

    /// The weights of a word's pixels added one by one in increasing column, as `RowWeights::add`
    /// did before it added runs of weight 1 at once (and as the per-pixel path does).
    fn one_by_one(
        row: &RowWeights,
        sums: [f32; 3],
        d_at: &[f32; 32],
        inside: u32,
        band: u32,
        slide: &mut Slide,
        columns: &Columns,
    ) -> [f32; 3] {
        let [mut sw, mut sx, mut sy] = sums;
        let sign = row.contrast.signum();
        for (bit, &d) in d_at.iter().enumerate() {
            let col = row.first + bit;
            let weight = if inside >> bit & 1 != 0 {
                let ratio = d / row.contrast;
                if ratio >= HOLE_RATIO {
                    1.0
                } else {
                    ratio.clamp(0.0, 1.0)
                }
            } else if band >> bit & 1 != 0 && d * sign > 0.0 {
                let (sum, count) = slide.around(col, columns);
                let mut local = row.contrast;
                if count > 0 && (sum / count as f32) * sign >= 1.0 {
                    local = sum / count as f32;
                }
                (d / local).clamp(0.0, 1.0)
            } else {
                0.0
            };
            if weight > 0.0 {
                sw += weight;
                sx += weight * col as u32 as f32;
                sy += weight * row.y;
            }
        }
        [sw, sx, sy]
    }

    /// Sums as they come up while a part is weighed: integers, fractions, values just below a
    /// power of two and up to 2^24 and beyond.
    fn random_sum(rng: &mut Rng) -> f32 {
        match rng.below(5) {
            0 => rng.below(5000) as f32,
            1 => rng.range(0.0, 5000.0),
            2 => {
                let p = (1u32 << (3 + rng.below(21))) as f32;
                p - rng.range(0.0, 40.0)
            }
            3 => 16_777_216.0 - rng.range(0.0, 20_000.0),
            _ => rng.range(0.0, 1.0e6) * (1.0 + rng.below(40) as f32),
        }
    }

    #[test]
    fn runs_of_weight_one_add_up_like_one_pixel_at_a_time() {
        // `add` (runs of weight 1 at once when exact) against `one_by_one`: the same bits for
        // random words, D (integer as with α = 1, or fractional), ring sums and running sums.
        let mut rng = Rng(0x5EED_0001);
        let (mut at_once, mut words) = (0usize, 0usize);
        for case in 0..40_000 {
            let contrast = if rng.chance(0.5) { 1.0 } else { -1.0 } * (1 + rng.below(200)) as f32;
            let row = RowWeights {
                contrast,
                y: rng.below(if case % 8 == 0 { 70_000 } else { 400 }) as f32,
                first: 32 * rng.below(WORDS),
            };
            let integer = rng.chance(0.5);
            let mut d_at = [0.0f32; 32];
            for d in &mut d_at {
                // Mostly the part's contrast, some holes and other-signed values.
                let v = match rng.below(6) {
                    0 => rng.range(-255.0, 255.0),
                    1 => contrast * rng.range(0.0, 0.3),
                    _ => contrast * rng.range(0.5, 1.5),
                };
                *d = if integer { v.round() } else { v };
            }
            let mut columns = Columns::new();
            for (s, c) in columns.sum.iter_mut().zip(columns.count.iter_mut()) {
                *c = rng.below(4) as u8;
                *s = if *c == 0 { 0.0 } else { contrast * rng.range(0.0, 3.0) };
            }
            // Inside in the middle, band at the ends, as at a part's edge; or random bits.
            let (inside, band) = if rng.chance(0.5) {
                let (a, b) = (rng.below(33) as u32, rng.below(33) as u32);
                let (lo, hi) = (a.min(b), a.max(b));
                let span = |from: u32, to: u32| {
                    if to <= from {
                        0
                    } else {
                        (u32::MAX >> (32 - (to - from))) << from
                    }
                };
                let inside = span(lo, hi);
                (
                    inside,
                    span(lo.saturating_sub(2), hi.saturating_add(2).min(32)) & !inside,
                )
            } else {
                let inside = rng.next() as u32 & rng.next() as u32 | rng.next() as u32;
                (inside, rng.next() as u32 & !inside)
            };
            let ones = (0..32).fold(0u32, |m, b| m | (((d_at[b] / contrast >= HOLE_RATIO) as u32) << b)) & inside;
            let sums = [random_sum(&mut rng), random_sum(&mut rng), random_sum(&mut rng)];
            let got = row.add(sums, &d_at, [inside, band, ones], &mut Slide::default(), &columns);
            let want = one_by_one(&row, sums, &d_at, inside, band, &mut Slide::default(), &columns);
            assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "case {case}");
            // The runs alone, and how often they go at once.
            if ones != 0 {
                words += 1;
                let by_pixel = one_by_one(&row, sums, &[contrast; 32], ones, 0, &mut Slide::default(), &columns);
                let run = row.add_ones(sums, ones);
                assert_eq!(run.map(f32::to_bits), by_pixel.map(f32::to_bits), "case {case}");
                if let Some(sum) = row.add_ones_at_once(sums, ones) {
                    assert_eq!(sum.map(f32::to_bits), by_pixel.map(f32::to_bits), "case {case}");
                    at_once += 1;
                }
            }
        }
        // Runs are added at once often (here a third: the random sums are small and cross
        // binades more often than a part's); not near 2^24 nor across a binade.
        assert!(at_once > words / 5 && at_once < words, "{at_once} of {words}");
    }

    #[test]
    fn image_rows_give_the_values_of_at() {
        // D from the frame's and background's rows (α = 1), pixel by pixel and a span at a
        // time, against `Difference::at`; with α < 1 and short background planes the rows are
        // missing and the same functions fall back to `at`.
        let mut rng = Rng(4242);
        for case in 0..300 {
            let (w, h) = (1 + rng.below(40), 1 + rng.below(12));
            let pixels: Vec<u8> = (0..w * h).map(|_| rng.below(256) as u8).collect();
            let full = rng.chance(0.6);
            let bg_len = if full { w * h } else { rng.below(w * h + 1) };
            let background: Vec<u8> = (0..bg_len).map(|_| rng.below(256) as u8).collect();
            let frame = Frame::new_checked(&pixels[..], w, h).unwrap();
            for alpha in [1.0, 0.5] {
                let diff = Difference::new(&frame, &background, Alpha::new(alpha).unwrap());
                for y in 0..h {
                    let rows = diff.rows(y);
                    assert_eq!(
                        rows.is_some(),
                        alpha >= 1.0 && (y + 1) * w <= bg_len,
                        "case {case} row {y}"
                    );
                    if let Some((f, b)) = rows {
                        assert_eq!((f.len(), b.len()), (w, w));
                    }
                    for x in 0..w {
                        let (got, want) = (d_pixel(&diff, rows, x, y), diff.at(x as isize, y as isize));
                        assert_eq!(got.to_bits(), want.to_bits(), "case {case} α {alpha} ({x}, {y})");
                    }
                    // Spans, some past the row's end (those read through `at`, clamped).
                    let x = rng.below(w);
                    let mut span = vec![f32::NAN; rng.below(w + 4 - x)];
                    d_span(&diff, rows, x, y, &mut span);
                    for (k, got) in span.iter().enumerate() {
                        let want = diff.at((x + k) as isize, y as isize);
                        assert_eq!(
                            got.to_bits(),
                            want.to_bits(),
                            "case {case} α {alpha} span ({x}+{k}, {y})"
                        );
                    }
                }
            }
        }
        let frame = Frame::new_checked(&[0u8; 6][..], 3, 2).unwrap();
        let diff = Difference::new(&frame, &[0u8; 6], Alpha::new(1.0).unwrap());
        assert!(diff.rows(2).is_none());
    }

    #[test]
    fn hole_test_by_reduction_is_the_per_pixel_test() {
        // Words where every inside pixel passes (the reduction's shortcut), where some fail, and
        // values at the threshold, both signs of contrast.
        let mut rng = Rng(777);
        let mut shortcut = 0;
        for case in 0..40_000 {
            let contrast = rng.range(1.0, 200.0) * if rng.chance(0.5) { 1.0 } else { -1.0 };
            let at_threshold = contrast * HOLE_RATIO;
            let mode = rng.below(3);
            let d_at: [f32; 32] = core::array::from_fn(|_| match mode {
                0 => contrast * rng.range(0.2, 1.5),
                1 => at_threshold + [-1.0, 0.0, 1.0][rng.below(3)] * at_threshold.abs() * f32::EPSILON,
                _ => rng.below(511) as f32 - 255.0,
            });
            let inside = match rng.below(3) {
                0 => u32::MAX,
                1 => (rng.next() as u32) & (rng.next() as u32),
                _ => (u32::MAX >> rng.below(32)) << rng.below(32),
            };
            let mut want = 0u32;
            for (bit, &d) in d_at.iter().enumerate() {
                if inside >> bit & 1 == 1 && d / contrast >= HOLE_RATIO {
                    want |= 1 << bit;
                }
            }
            assert_eq!(at_least_hole_ratio(&d_at, inside, contrast), want, "case {case}");
            shortcut += usize::from(want == inside && inside != 0);
        }
        assert!(shortcut > 10_000, "{shortcut}");
    }

    #[test]
    fn exact_sums_are_exact() {
        // Sums of integers that `exact_sum` accepts, against adding 1 at a time in f64.
        let mut rng = Rng(31337);
        for _ in 0..20_000 {
            let s = random_sum(&mut rng);
            let t = rng.below(3000) as f32;
            if let Some(total) = exact_sum(s, t) {
                assert_eq!(total as f64, s as f64 + t as f64, "{s} + {t}");
                // Every partial sum holds too (the sum one by one is the same).
                let mut one_by_one = s;
                for _ in 0..t as u32 {
                    one_by_one += 1.0;
                }
                assert_eq!(one_by_one.to_bits(), total.to_bits(), "{s} + {t}");
            }
        }
        assert_eq!(exact_sum(4.5, 3.0), Some(7.5));
        assert_eq!(exact_sum(3.5, 4.0), None);
        // Crossing 4 from a fraction, reaching 2^24, negative or NaN sums: refused.
        assert_eq!(exact_sum(3.5, 1.0), None);
        assert_eq!(exact_sum(16_777_215.0, 1.0), None);
        assert_eq!(exact_sum(-1.0, 1.0), None);
        assert_eq!(exact_sum(f32::NAN, 1.0), None);
        assert_eq!(exact_sum(0.0, 16_777_215.0), Some(16_777_215.0));
    }

    #[test]
    fn ring_values_give_each_pixel_its_own_value() {
        // Rows of ring pixels enter the column sums and leave them 9 rows later, as in `weigh`;
        // whatever is stored or not, each pixel must come back with its own D.
        let mut rng = Rng(4242);
        for case in 0..200 {
            let rows: Vec<usize> = (0..1 + rng.below(60))
                .map(|_| match case % 4 {
                    0 => rng.below(8),
                    1 => rng.below(40),
                    2 => rng.below(3) * 150,
                    _ => rng.below(400),
                })
                .collect();
            let total: usize = rows.iter().sum();
            let value = |k: usize| k as f32 * 0.75 - 100.0;
            let mut values = RingValues::new(true);
            for k in 0..total {
                values.store(value(k));
            }
            let (mut entered, mut left, mut reads) = (0usize, 0usize, 0usize);
            for p in 0..rows.len() + 9 {
                if let Some(q) = p.checked_sub(9) {
                    for _ in 0..rows[q] {
                        let d = values.leave(|| {
                            reads += 1;
                            value(left)
                        });
                        assert_eq!(d, value(left), "case {case} leaving {left}");
                        left += 1;
                    }
                }
                for _ in 0..rows.get(p).copied().unwrap_or(0) {
                    let d = values.enter(|| {
                        reads += 1;
                        value(entered)
                    });
                    assert_eq!(d, value(entered), "case {case} entering {entered}");
                    entered += 1;
                }
                // What is kept is the pixel's own value (`weigh` reads the pixels 4 rows after
                // they entered), and nothing that left; all is kept when it fits.
                for k in left.saturating_sub(3)..total.min(entered + 600) {
                    match values.peek(k) {
                        Some(d) => {
                            // (Or stored by the first pass and yet to enter.)
                            assert!(k >= left, "case {case} peek {k}");
                            assert_eq!(d, value(k), "case {case} peek {k}");
                        }
                        None => assert!(!(left..entered).contains(&k) || total > RING_VALUES),
                    }
                }
            }
            assert_eq!((entered, left), (total, total));
            // Small parts need no second read at all.
            if total <= RING_VALUES {
                assert_eq!(reads, 0, "case {case}");
            }
        }
    }

    #[test]
    fn bit_rows_gather_scatter_and_clear() {
        let mut rng = Rng(99);
        for len in [0, 1, 3, 7, 8, 9, 31, 32, 33, 100, 255, 256] {
            let mut row: Vec<u8> = (0..len).map(|_| rng.next() as u8).collect();
            let before = row.clone();
            let comp = gather(&row, 7);
            assert_eq!(gather(&row, 6), gather(&before, 6));
            let (c, g) = gather_and_clear(&mut row);
            assert_eq!(comp, c);
            for (x, &v) in before.iter().enumerate() {
                assert_eq!(c[x / 32] >> (x % 32) & 1 != 0, v & COMPONENT != 0);
                assert_eq!(g[x / 32] >> (x % 32) & 1 != 0, v & RING != 0);
                assert_eq!(row[x], v & 1);
            }
            for x in len..MAX_WIDTH {
                assert_eq!(c[x / 32] >> (x % 32) & 1, 0);
                assert_eq!(g[x / 32] >> (x % 32) & 1, 0);
            }
            let mut again = before.clone();
            keep_mask_bit(&mut again);
            assert_eq!(again, row);
            // Scatter sets exactly the flagged bytes' bit.
            let mut bits = EMPTY;
            for x in 0..len {
                if rng.chance(0.3) {
                    bits[x / 32] |= 1 << (x % 32);
                }
            }
            let mut plane = row.clone();
            scatter(&mut plane, &bits, RING);
            for x in 0..len {
                let on = bits[x / 32] >> (x % 32) & 1 != 0;
                assert_eq!(plane[x], row[x] | if on { RING } else { 0 });
            }
            assert_eq!(gather(&plane, 6), bits);
        }
    }

    mod reference {
        use super::super::{any_neighbour, per_pixel, Rect, COMPONENT};
        use crate::refine::Difference;

        /// The implementation before the bit-row rewrite as the oracle: the partial-volume area
        /// centroid of the part whose border passes through `seed` (a foreground pixel), within
        /// `bbox` plus a 6 px margin. Its component fill is kept here verbatim (but for the flag
        /// bit); its morphology and weights live on unchanged as `per_pixel::centroid`, the path
        /// of boxes wider than the bit rows.
        pub fn reference_partial_volume_centroid<B: AsRef<[u8]>>(
            diff: &Difference<'_, B>,
            mask: &mut [u8],
            seed: (usize, usize),
            bbox: Rect,
        ) -> Option<[f32; 2]> {
            let (w, h) = (diff.width(), diff.height());
            if mask.len() < w * h || seed.0 >= w || seed.1 >= h {
                return None;
            }
            let r = Rect {
                x0: bbox.x0.saturating_sub(6),
                y0: bbox.y0.saturating_sub(6),
                x1: (bbox.x1 + 6).min(w),
                y1: (bbox.y1 + 6).min(h),
            };
            // The 8-connected component of the seed.
            if mask.get(seed.1 * w + seed.0).is_none_or(|v| v & 1 == 0) {
                return None;
            }
            mark_component(mask, w, r, seed);
            per_pixel::centroid(diff, mask, w, r)
        }

        /// Marks the 8-connected foreground component of `seed` (inside `r`) with [`COMPONENT`]: a
        /// scanline fill with a fixed stack; when the stack overflows, repeated raster passes finish the
        /// job (bounded by the box's size).
        fn mark_component(mask: &mut [u8], w: usize, r: Rect, seed: (usize, usize)) {
            const STACK: usize = 256;
            let free =
                |mask: &[u8], x: usize, y: usize| mask.get(y * w + x).is_some_and(|v| v & 1 != 0 && v & COMPONENT == 0);
            let mut stack = [(0usize, 0usize); STACK];
            let mut top = 0usize;
            let mut overflow = false;
            if let Some(slot) = stack.get_mut(0) {
                *slot = seed;
                top = 1;
            }
            while top > 0 {
                top -= 1;
                let Some(&(x, y)) = stack.get(top) else { break };
                if !free(mask, x, y) {
                    continue;
                }
                let (mut xl, mut xr) = (x, x);
                while xl > r.x0 && free(mask, xl - 1, y) {
                    xl -= 1;
                }
                while xr + 1 < r.x1 && free(mask, xr + 1, y) {
                    xr += 1;
                }
                for xx in xl..=xr {
                    if let Some(v) = mask.get_mut(y * w + xx) {
                        *v |= COMPONENT;
                    }
                }
                for ny in [y.wrapping_sub(1), y + 1] {
                    if ny < r.y0 || ny >= r.y1 {
                        continue;
                    }
                    let mut xx = xl.saturating_sub(1).max(r.x0);
                    let last = (xr + 1).min(r.x1 - 1);
                    while xx <= last {
                        if free(mask, xx, ny) {
                            match stack.get_mut(top) {
                                Some(slot) => {
                                    *slot = (xx, ny);
                                    top += 1;
                                }
                                None => overflow = true,
                            }
                            while xx <= last && free(mask, xx, ny) {
                                xx += 1;
                            }
                        } else {
                            xx += 1;
                        }
                    }
                }
            }
            if !overflow {
                return;
            }
            let mut changed = true;
            let mut passes = 0usize;
            while changed && passes < (r.x1 - r.x0) + (r.y1 - r.y0) + 2 {
                changed = false;
                for forward in [true, false] {
                    for yi in 0..(r.y1 - r.y0) {
                        let y = if forward { r.y0 + yi } else { r.y1 - 1 - yi };
                        for xi in 0..(r.x1 - r.x0) {
                            let x = if forward { r.x0 + xi } else { r.x1 - 1 - xi };
                            if free(mask, x, y) && any_neighbour(mask, w, r, x, y, COMPONENT) {
                                if let Some(p) = mask.get_mut(y * w + x) {
                                    *p |= COMPONENT;
                                }
                                changed = true;
                            }
                        }
                    }
                }
                passes += 1;
            }
        }
    }
}
