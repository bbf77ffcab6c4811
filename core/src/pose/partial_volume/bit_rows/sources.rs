//! Where `D` comes from and the weights' pixel loops: [`Source`] with the definition's loops
//! pixel by pixel, [`Exact`] (`α = 1`: `D` from the frame's and background's bytes, integer
//! column sums and integer tests where a weight clips, [`ExactPart`]) and [`Approx`] (`D` through
//! [`Difference::at`]); and [`add_ones`], which adds a run of weight 1 at once with the same bits
//! as one pixel at a time.

use super::bits::*;
use super::*;
use crate::pose::refine::Difference;
use core::ops::{Add, Range, Sub};

/// `sums` (Σw, Σw·x, Σw·y) plus weight 1 for each pixel of columns `cols` of box row `y`: the
/// same bits as adding them one by one in increasing column.
#[inline(always)]
pub(super) fn add_ones(sums: [f32; 3], cols: Range<usize>, y: usize) -> [f32; 3] {
    let (Ok(count), Ok(first), Ok(y)) = (u32::try_from(cols.len()), u32::try_from(cols.start), u32::try_from(y)) else {
        return sums;
    };
    if count == 0 {
        return sums;
    }
    let [sw, sx, sy] = sums;
    // Σ columns (below 2^17 for a box row).
    let columns = u64::from(first) * u64::from(count) + u64::from(count) * u64::from(count - 1) / 2;
    let at_once = |s: f32, t: u64| exact_integer(t).and_then(|t| exact_sum(s, t));
    [
        at_once(sw, u64::from(count)).unwrap_or_else(|| add_sequence(sw, 1, 0, count)),
        at_once(sx, columns).unwrap_or_else(|| add_sequence(sx, first, 1, count)),
        at_once(sy, u64::from(y) * u64::from(count)).unwrap_or_else(|| add_sequence(sy, y, 0, count)),
    ]
}

/// `s` plus the `count` integers `first + step·k` (`k = 0, 1, …`) one by one in `f32`: at once as
/// far as none of the additions rounds ([`exact_sum`]), the one that does on its own.
#[inline(never)]
pub(super) fn add_sequence(s: f32, first: u32, step: u32, count: u32) -> f32 {
    // The sum of the first `k` terms (exact: below 2^64).
    let terms = |first: u32, k: u32| {
        let (first, k, step) = (u64::from(first), u64::from(k), u64::from(step));
        first * k + step * (k * k.saturating_sub(1) / 2)
    };
    let at_once = |s: f32, t: u64| exact_integer(t).and_then(|t| exact_sum(s, t));
    let (mut s, mut first, mut count) = (s, first, count);
    while count > 0 {
        if let Some(total) = at_once(s, terms(first, count)) {
            return total;
        }
        // The most terms that go at once (none at least, when `s` is a sum that rounds on its
        // own): a bisection, the test is monotonic in the number of terms; first around where
        // the terms reach the next binade of `s` (or 2^24 from an integer `s`).
        let (mut lo, mut hi) = (0u32, count);
        if at_once(s, 0).is_none() {
            hi = 1;
        } else if s > 0.0 {
            let top = if s as u32 as f32 == s {
                EXACT
            } else {
                f32::from_bits(((s.to_bits() >> 23) + 1) << 23)
            };
            // (A guess in f32: the bisection settles it.)
            let room = top - s;
            let (a, b) = (first as f32, step as f32);
            // b·k²/2 + (a − b/2)·k = room.
            let k = if b > 0.0 {
                let c = a - b / 2.0;
                (crate::math::sqrt(c * c + 2.0 * b * room) - c) / b
            } else if a > 0.0 {
                room / a
            } else {
                count as f32
            };
            let k = (k.max(0.0) as u32).min(count - 1);
            if at_once(s, terms(first, k)).is_some() {
                lo = k;
                if at_once(s, terms(first, k + 1)).is_none() {
                    hi = k + 1;
                }
            } else {
                hi = k;
            }
        }
        while hi - lo > 1 {
            let mid = lo + (hi - lo) / 2;
            if at_once(s, terms(first, mid)).is_some() {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        if let Some(part) = at_once(s, terms(first, lo)) {
            s = part;
        }
        // The next term alone (it rounds, or is the first of a new binade).
        let next = first.saturating_add(step.saturating_mul(lo));
        s += next as f32;
        first = next.saturating_add(step);
        count -= lo + 1;
    }
    s
}

/// Below this, every integer is an `f32`.
pub(super) const EXACT: f32 = 16_777_216.0;

/// `v` as an `f32` when that is exact (at most 2^24).
#[inline(always)]
pub(super) fn exact_integer(v: u64) -> Option<f32> {
    (v <= 1 << 24).then_some(v as f32)
}

/// `s + t` for `s ≥ 0` and an integer `t ≥ 0` that stands for several integer terms added to `s`
/// one by one in f32, when none of those additions rounds (so that their result is `s + t`):
/// either `s` is an integer and the sum stays below 2^24 (every partial sum is an integer an
/// `f32` holds), or `s` and the sum share their exponent below 2^24 (every partial sum lies in
/// that binade, on its grid of at most 1). `None` otherwise.
#[inline(always)]
pub(super) fn exact_sum(s: f32, t: f32) -> Option<f32> {
    let total = s + t;
    // Rounding is monotonic: a computed sum below 2^24 means a true one below it.
    if !(s >= 0.0 && total < EXACT) {
        return None;
    }
    let same_binade = s.to_bits() >> 23 == total.to_bits() >> 23;
    // `s as u32` truncates (s < 2^24): s is an integer iff that converts back to s.
    (same_binade || s as u32 as f32 == s).then_some(total)
}

/// Where `D` comes from: the frame's and background's image rows ([`Exact`], `α = 1`: integers)
/// or [`Difference::at`] ([`Approx`]). Columns are the box's. The pixel loops have a definition
/// here, pixel by pixel through [`Source::d`]; [`Exact`] has faster ones with the same results.
pub(super) trait Source: Sized {
    /// What a row's values are read from.
    type Row: Copy + Default;
    /// A sum of ring values: their `D` and how many.
    type Col: Copy + Default + Add<Output = Self::Col> + Sub<Output = Self::Col>;
    /// Image row `y`.
    fn row(&self, y: usize) -> Self::Row;
    /// `D` at column `c`: the value of [`Difference::at`].
    fn d(&self, row: Self::Row, c: usize) -> f32;
    /// The background plane's level at column `c` ([`Difference::background_at`]).
    fn b(&self, row: Self::Row, c: usize) -> u8;
    /// The ring value at column `c`.
    fn col(&self, row: Self::Row, c: usize, weights: &Weights) -> Self::Col;
    /// The sum of `D` and the count of a sum of ring values.
    fn split(col: Self::Col, weights: &Weights) -> (f32, u32);

    /// Adds the ring pixels `ring` to the signed histogram of `D` (bin `D + 255`, clamped to
    /// 0..=510), counts saturating at `u16::MAX` (`WRAP`: adding 1 plainly, for a box of fewer
    /// pixels, where they cannot get there), and their background levels to `level`.
    #[inline(always)]
    fn histogram<const WRAP: bool, const N: usize>(
        &self,
        row: Self::Row,
        ring: &Bits<N>,
        hist: &mut [u16; 511],
        level: &mut u64,
    ) {
        for_each_bit(ring, |c| {
            let bin = (self.d(row, c) as i32 + 255).clamp(0, 510) as usize;
            if let Some(h) = hist.get_mut(bin) {
                *h = if WRAP { h.wrapping_add(1) } else { h.saturating_add(1) };
            }
            *level += u64::from(self.b(row, c));
        });
    }

    /// The least `D · sign` over the columns `cols` (not empty), or a value that is not above 0
    /// when that is not above 0.
    #[inline(always)]
    fn least(&self, row: Self::Row, cols: Range<usize>, sign: f32) -> f32 {
        // `sign` is ±1: the products are exact. (A select rather than `f32::min`: D is never
        // NaN.)
        cols.map(|c| self.d(row, c) * sign)
            .fold(f32::INFINITY, |m, v| if v < m { v } else { m })
    }

    /// `sums` plus the weights of the band pixels `cols` of the row at `yf` (box coordinates):
    /// `D` over the local contrast, the mean `D` of the ring pixels within 4 px (shading across
    /// the part changes it from one side to the other), else the part's median scaled by the
    /// background's level ([`Weights::fallback`]), clipped to `[0, 1]`; `columns` holds the
    /// ring's values summed over the rows within 4.
    #[inline(always)]
    fn band_run(
        &self,
        row: Self::Row,
        cols: Range<usize>,
        yf: f32,
        columns: &[Self::Col; COLUMNS],
        weights: &Weights,
        sums: [f32; 3],
    ) -> [f32; 3] {
        let sign = weights.sign;
        let [mut sw, mut sx, mut sy] = sums;
        let window = |c: usize| {
            columns
                .get(c..c + 9)
                .unwrap_or(&[])
                .iter()
                .fold(Self::Col::default(), |s, &v| s + v)
        };
        for c in cols {
            let d = self.d(row, c);
            let (sum, count) = Self::split(window(c), weights);
            let mut local = weights.fallback(f32::from(self.b(row, c)));
            if count > 0 {
                // At least 1 in size, of the contrast's sign (`sign` is ±1: exact).
                let mean = sum / count as f32;
                if mean * sign >= 1.0 {
                    local = mean;
                }
            }
            // (A D of the other sign than the contrast weighs 0.)
            let weight = (d / local).clamp(0.0, 1.0);
            if weight > 0.0 {
                sw += weight;
                sx += weight * c as u32 as f32;
                sy += weight * yf;
            }
        }
        [sw, sx, sy]
    }

    /// The second pass ([`weigh`]).
    #[inline(always)]
    fn weigh<const N: usize>(&self, plane: &mut Plane<'_>, rows: Range<usize>, weights: Weights) -> [f32; 3] {
        weigh::<Self, N>(self, plane, rows, weights)
    }

    /// `sums` plus the weights of box row `y`'s inside and band pixels, in increasing column.
    /// Inside pixels come in runs between band pixels (next to an inside pixel is an inside or a
    /// band pixel); a run whose pixels all pass the hole test is added at once.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn weigh_row<const N: usize>(
        &self,
        row: Self::Row,
        y: usize,
        inside: &Bits<N>,
        band: &Bits<N>,
        columns: &[Self::Col; COLUMNS],
        weights: &Weights,
        sums: [f32; 3],
    ) -> [f32; 3] {
        let mut sums = sums;
        let yf = y as f32;
        // The column after the last band pixel.
        let mut after = 0usize;
        for_each_run(band, |a, e| {
            if a > after && bit(inside, after) {
                sums = inside_run(weights, self, row, after..a, y, sums);
            }
            after = e;
            sums = self.band_run(row, a..e, yf, columns, weights, sums);
        });
        sums
    }
}

/// `D` from the frame's and background's rows ([`Difference::rows`]): integers in −255..=255,
/// so that every sum of them is exact and the weights' tests can be integer ones. The rows of the
/// box come from the bytes of both from its first row on (no call a row).
pub(super) struct Exact<'a> {
    /// The frame's bytes from the box's first row, and the step from a row to the next.
    frame: &'a [u8],
    stride: usize,
    /// The background plane's bytes from the box's first row (a row is `w` bytes).
    background: &'a [u8],
    w: usize,
    /// The box's first image row and column, its width and its image rows.
    y0: usize,
    x0: usize,
    width: usize,
    rows: usize,
}

impl<'a> Exact<'a> {
    /// The rows of box `r` when every row has its `D` from the frame's and background's rows:
    /// when the last has ([`Difference::rows`]: `α = 1`, and the background plane reaches that
    /// far).
    pub(super) fn new<B: AsRef<[u8]>>(diff: &Difference<'a, B>, r: Rect) -> Option<Self> {
        diff.rows(r.y1.checked_sub(1)?)?;
        let (frame, stride, background) = diff.rows_from(r.y0)?;
        Some(Exact {
            frame,
            stride,
            background,
            w: diff.width(),
            y0: r.y0,
            x0: r.x0,
            width: r.x1 - r.x0,
            rows: r.y1 - r.y0,
        })
    }

    /// The row's bytes whose difference is `D · sign`: the frame's first for a positive contrast.
    #[inline(always)]
    fn signed((f, b): (&'a [u8], &'a [u8]), weights: &Weights) -> (&'a [u8], &'a [u8]) {
        if weights.sign > 0.0 {
            (f, b)
        } else {
            (b, f)
        }
    }
}

impl<'a> Source for Exact<'a> {
    /// The box's columns of the frame's and the background's row.
    type Row = (&'a [u8], &'a [u8]);
    /// `128·Σ(D·sign) + count` (counts are at most 81, |ΣD| at most 81·255).
    type Col = i32;

    #[inline(always)]
    fn row(&self, y: usize) -> Self::Row {
        match y.checked_sub(self.y0) {
            Some(k) if k < self.rows => {
                let (f, b) = (k * self.stride + self.x0, k * self.w + self.x0);
                match (
                    self.frame.get(f..f + self.width),
                    self.background.get(b..b + self.width),
                ) {
                    (Some(f), Some(b)) => (f, b),
                    _ => (&[], &[]),
                }
            }
            _ => (&[], &[]),
        }
    }

    #[inline(always)]
    fn d(&self, (f, b): Self::Row, c: usize) -> f32 {
        match (f.get(c), b.get(c)) {
            // Both exact integers, so the difference is exact: the same `f32` as `at`'s.
            (Some(&f), Some(&b)) => (i32::from(f) - i32::from(b)) as f32,
            _ => 0.0,
        }
    }

    #[inline(always)]
    fn b(&self, (_, b): Self::Row, c: usize) -> u8 {
        b.get(c).copied().unwrap_or(0)
    }

    #[inline(always)]
    fn col(&self, row: Self::Row, c: usize, weights: &Weights) -> i32 {
        let (hi, lo) = Self::signed(row, weights);
        match (hi.get(c), lo.get(c)) {
            (Some(&h), Some(&l)) => 128 * (i32::from(h) - i32::from(l)) + 1,
            _ => 0,
        }
    }

    #[inline(always)]
    fn split(col: i32, weights: &Weights) -> (f32, u32) {
        let sign = if weights.sign > 0.0 { 1 } else { -1 };
        (((col >> 7) * sign) as f32, (col & 127) as u32)
    }

    #[inline(always)]
    fn histogram<const WRAP: bool, const N: usize>(
        &self,
        (f, b): Self::Row,
        ring: &Bits<N>,
        hist: &mut [u16; 511],
        level: &mut u64,
    ) {
        for_each_bit_with(ring, f, b, |_, f, b| {
            // An integer in −255..=255: its bin without a conversion.
            if let Some(h) = hist.get_mut((i32::from(f) - i32::from(b) + 255) as usize) {
                *h = if WRAP { h.wrapping_add(1) } else { h.saturating_add(1) };
            }
            *level += u64::from(b);
        });
    }

    /// The least of `D · sign` where it is positive, else 0: the minimum of the bytes' saturating
    /// difference (which the compiler vectorises).
    #[inline(always)]
    fn least(&self, (f, b): Self::Row, cols: Range<usize>, sign: f32) -> f32 {
        let (Some(f), Some(b)) = (f.get(cols.clone()), b.get(cols)) else {
            return 0.0;
        };
        let (hi, lo) = if sign > 0.0 { (f, b) } else { (b, f) };
        hi.iter()
            .zip(lo)
            .fold(u8::MAX, |m, (&h, &l)| m.min(h.saturating_sub(l))) as f32
    }

    /// [`weigh`] with the constants of the part out of the loop, each image row read once, and
    /// each row's mask put back once it is weighed ([`Plane::restore`] does the others).
    #[inline(always)]
    fn weigh<const N: usize>(&self, plane: &mut Plane<'_>, rows: Range<usize>, weights: Weights) -> [f32; 3] {
        let part = ExactPart::new(weights);
        let (stride, w, y0) = (plane.stride, plane.w, plane.r.y0);
        let fields_len = FIELDS * stride;
        let mut columns = [0i32; COLUMNS];
        // The image rows (signed: `hi − lo = D·sign`) and ring rows of rows y − 4 ..= y + 4 (row q
        // in slot q mod 16); rows outside `rows` hold no ring.
        let mut images: [Self::Row; 16] = [(&[], &[]); 16];
        let mut rings = [[0; N]; 16];
        let mut sums = [0.0f32; 3];
        // The plane's index of row q's first byte, and of row q − 4's.
        let (mut s, mut s_weighed) = (plane.at(rows.start), plane.at(rows.start));
        let mask = &mut *plane.mask;
        for q in rows.start..rows.end + 4 {
            if q < rows.end {
                // Row q enters the column sums.
                let (f, b) = self.row(y0 + q);
                let (hi, lo) = if part.positive { (f, b) } else { (b, f) };
                let ring: Bits<N> = mask
                    .get(s..s + fields_len)
                    .map_or([0; N], |f| get(f, stride, RING_FIELD));
                move_ring::<true, N>(hi, lo, &ring, &mut columns);
                if let (Some(i), Some(r)) = (images.get_mut(q % 16), rings.get_mut(q % 16)) {
                    (*i, *r) = ((hi, lo), ring);
                }
                s += w;
            }
            // Row q − 4 is weighed, and its mask put back.
            if let Some(y) = q.checked_sub(4).filter(|&y| y >= rows.start) {
                if let (Some(fields), Some(&(hi, lo))) =
                    (mask.get_mut(s_weighed..s_weighed + fields_len), images.get(y % 16))
                {
                    let band: Bits<N> = get(fields, stride, BAND_FIELD);
                    if !none(&band) {
                        let inside: Bits<N> = get(fields, stride, COMP_FIELD);
                        sums = part.row(self, hi, lo, y, &inside, &band, &columns, sums);
                    }
                    restore_row::<N>(fields, stride);
                }
                s_weighed += w;
                // Row q − 8 leaves.
                if let Some(r) = q.checked_sub(8).filter(|&r| r >= rows.start) {
                    if let (Some(&(hi, lo)), Some(bits)) = (images.get(r % 16), rings.get(r % 16)) {
                        move_ring::<false, N>(hi, lo, bits, &mut columns);
                    }
                }
            }
        }
        plane.restored = rows;
        sums
    }
}

/// Adds (`ENTER`) the ring values `128·(hi − lo) + 1` of the pixels `ring` to their columns'
/// sums, or takes them away ([`Exact`]'s column sums).
#[inline(always)]
pub(super) fn move_ring<const ENTER: bool, const N: usize>(
    hi: &[u8],
    lo: &[u8],
    ring: &Bits<N>,
    columns: &mut [i32; COLUMNS],
) {
    for_each_bit_with(ring, hi, lo, |c, h, l| {
        if let Some(s) = columns.get_mut(c + 4) {
            let v = 128 * (i32::from(h) - i32::from(l)) + 1;
            *s = if ENTER { *s + v } else { *s - v };
        }
    });
}

/// Calls `f(c, a[c], b[c])` for the column `c` of every set bit of `bits` within the slices, in
/// increasing order: with a whole word's bytes of both at once where they hold them (a bit's
/// index into them needs no test then).
#[inline(always)]
pub(super) fn for_each_bit_with<const N: usize>(bits: &Bits<N>, a: &[u8], b: &[u8], mut f: impl FnMut(usize, u8, u8)) {
    for (k, &word) in bits.iter().enumerate() {
        let mut word = word;
        if word == 0 {
            continue;
        }
        let base = BITS * k;
        let whole = (
            a.get(base..base + BITS).and_then(|s| <&[u8; BITS]>::try_from(s).ok()),
            b.get(base..base + BITS).and_then(|s| <&[u8; BITS]>::try_from(s).ok()),
        );
        if let (Some(wa), Some(wb)) = whole {
            while word != 0 {
                let t = word.trailing_zeros() as usize % BITS;
                word &= word - 1;
                if let (Some(&x), Some(&y)) = (wa.get(t), wb.get(t)) {
                    f(base + t, x, y);
                }
            }
        } else {
            while word != 0 {
                let c = base + word.trailing_zeros() as usize;
                word &= word - 1;
                if let (Some(&x), Some(&y)) = (a.get(c), b.get(c)) {
                    f(c, x, y);
                }
            }
        }
    }
}

/// `v` (in 0..=255) as an `f32`, from a table (one load rather than a conversion).
#[inline(always)]
pub(super) fn to_f32(v: i32) -> f32 {
    SMALL_F32.get((v & 255) as usize).copied().unwrap_or(0.0)
}

/// The integers 0..=255 as `f32`.
pub(super) static SMALL_F32: [f32; 256] = {
    let mut table = [0.0; 256];
    let mut i = 0;
    while i < 256 {
        table[i] = i as f32;
        i += 1;
    }
    table
};

/// The constants of [`Exact`]'s second pass.
pub(super) struct ExactPart {
    weights: Weights,
    positive: bool,
    /// `|C|` (the median of integers is one), and as `f32`.
    median: i32,
    median_f: f32,
    /// The least `D·sign` of an inside pixel of weight 1: `u / |C| ≥ HOLE_RATIO` (monotonic
    /// in `u`) from here on.
    hole: u8,
}

impl ExactPart {
    fn new(weights: Weights) -> Self {
        let contrast = weights.contrast;
        let median = contrast.abs() as i32;
        let median_f = median as f32;
        // The division as the definition does it, integer by integer (at most 255 of them).
        let hole = (1..=255u8)
            .find(|&u| f32::from(u) / median_f >= HOLE_RATIO)
            .unwrap_or(u8::MAX);
        ExactPart {
            weights,
            positive: contrast > 0.0,
            median,
            median_f,
            hole,
        }
    }

    /// `sums` plus the weights of box row `y`'s inside and band pixels (`hi − lo = D·sign`), in
    /// increasing column: [`Source::weigh_row`] with integer tests where the weights clip. With
    /// `u = D·sign > 0`, `V = ΣD·sign` and `n` ring pixels in the window, the mean is the local
    /// contrast iff `V ≥ n` (a quotient `V/n < 1` is at most 80/81), and `u / (V/n)` is at least
    /// 1 iff `u·n ≥ V` (else `V/n − u ≥ 1/81`, far more than the roundings); against the median
    /// `C` (without a level to scale it by), iff `u ≥ |C|`. Only the weights between 0 and 1 are
    /// divided, as the definition does; against the scaled median, every one (`D / C` and
    /// `u / |C|` are the same quotient: operands of both signs negated).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn row<const N: usize>(
        &self,
        src: &Exact<'_>,
        hi: &[u8],
        lo: &[u8],
        y: usize,
        inside: &Bits<N>,
        band: &Bits<N>,
        columns: &[i32; COLUMNS],
        sums: [f32; 3],
    ) -> [f32; 3] {
        let (median, median_f) = (self.median, self.median_f);
        let per_level = self.weights.per_level;
        // The byte of the background: the row subtracted for a positive contrast.
        let positive = self.positive;
        let yf = y as f32;
        let [mut sw, mut sx, mut sy] = sums;
        // The column after the last band pixel.
        let mut after = 0usize;
        let mut a = next_bit::<true, N>(band, 0);
        while a < BITS * N {
            let e = next_bit::<false, N>(band, a);
            if a > after && bit(inside, after) {
                // An inside run: weight 1 unless a pixel fails the hole test.
                let least = match (hi.get(after..a), lo.get(after..a)) {
                    (Some(h), Some(l)) => h.iter().zip(l).fold(u8::MAX, |m, (&h, &l)| m.min(h.saturating_sub(l))),
                    _ => 0,
                };
                [sw, sx, sy] = if least >= self.hole {
                    add_ones([sw, sx, sy], after..a, y)
                } else {
                    let row = if self.positive { (hi, lo) } else { (lo, hi) };
                    inside_by_pixel(&self.weights, src, row, after..a, y, [sw, sx, sy])
                };
            }
            after = e;
            // The run's pixels, and the column sums of their windows: columns a − 4 ..= e + 3,
            // padded a .. e + 8, the first window the first 9, then one in and one out a pixel.
            if e <= hi.len() && e <= lo.len() && e + 9 <= columns.len() {
                let mut window: i32 = columns.get(a..a + 9).map_or(0, |w| w.iter().sum());
                let mut xf = a as u32 as f32;
                for c in a..e {
                    let (Some(&h), Some(&l), Some(&i), Some(&o)) =
                        (hi.get(c), lo.get(c), columns.get(c + 9), columns.get(c))
                    else {
                        break;
                    };
                    let u = i32::from(h) - i32::from(l);
                    if u > 0 {
                        let (v, n) = (window >> 7, window & 127);
                        let weight = if v >= n.max(1) {
                            if u * n >= v {
                                1.0
                            } else {
                                // The mean (`V/n`, exact operands) as the definition divides it.
                                to_f32(u) / (v as f32 / to_f32(n))
                            }
                        } else if per_level > 0.0 {
                            let b = if positive { l } else { h };
                            let k = (to_f32(i32::from(b)) * per_level).clamp(0.5, 2.0);
                            (to_f32(u) / (median_f * k)).min(1.0)
                        } else if u >= median {
                            1.0
                        } else {
                            to_f32(u) / median_f
                        };
                        sw += weight;
                        sx += weight * xf;
                        sy += weight * yf;
                    }
                    xf += 1.0;
                    window += i - o;
                }
            }
            a = next_bit::<true, N>(band, e);
        }
        [sw, sx, sy]
    }
}

/// `D` through [`Difference::at`] (`α < 1`, or a background plane that ends within the box).
pub(super) struct Approx<'d, 'a, B> {
    pub(super) diff: &'d Difference<'a, B>,
    pub(super) x0: usize,
}

/// A sum of `f32` ring values and their count.
#[derive(Clone, Copy, Default)]
pub(super) struct FloatSum {
    sum: f32,
    count: u32,
}

impl Add for FloatSum {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        FloatSum {
            sum: self.sum + o.sum,
            count: self.count + o.count,
        }
    }
}

impl Sub for FloatSum {
    type Output = Self;
    /// An empty sum restarts from an exact 0.
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        let count = self.count.saturating_sub(o.count);
        FloatSum {
            sum: if count == 0 { 0.0 } else { self.sum - o.sum },
            count,
        }
    }
}

impl<B: AsRef<[u8]>> Source for Approx<'_, '_, B> {
    /// The image row.
    type Row = usize;
    type Col = FloatSum;

    #[inline(always)]
    fn row(&self, y: usize) -> usize {
        y
    }

    #[inline(always)]
    fn d(&self, y: usize, c: usize) -> f32 {
        self.diff.at((self.x0 + c) as isize, y as isize)
    }

    #[inline(always)]
    fn b(&self, y: usize, c: usize) -> u8 {
        self.diff.background_at((self.x0 + c) as isize, y as isize)
    }

    #[inline(always)]
    fn col(&self, y: usize, c: usize, _: &Weights) -> FloatSum {
        FloatSum {
            sum: self.d(y, c),
            count: 1,
        }
    }

    #[inline(always)]
    fn split(col: FloatSum, _: &Weights) -> (f32, u32) {
        (col.sum, col.count)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::super::bits::tests::random_bits;
    use super::*;
    use crate::pixels::enhance::Alpha;
    use crate::pixels::frame::Frame;
    use std::vec::Vec;

    use crate::test_rng::XorShift as Rng;

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

    /// One row of inside and band pixels as a part's rows have them: runs of inside pixels with
    /// band pixels on both sides, band runs alone, outside pixels between.
    fn random_row_regions(rng: &mut Rng, width: usize) -> (Bits<WORDS>, Bits<WORDS>) {
        let (mut inside, mut band) = ([0; WORDS], [0; WORDS]);
        let mut x = rng.below(6);
        let set = |bits: &mut Bits<WORDS>, from: usize, len: usize| {
            for c in from..(from + len).min(width) {
                bits[c / BITS] |= 1 << (c % BITS);
            }
        };
        while x < width {
            let left = 1 + rng.below(6);
            set(&mut band, x, left);
            x += left;
            if rng.chance(0.7) {
                let longest = if rng.chance(0.3) { 250 } else { 40 };
                let run = 1 + rng.below(longest);
                if x + run < width {
                    set(&mut inside, x, run);
                    x += run;
                    let right = 1 + rng.below(6);
                    set(&mut band, x, right);
                    x += right;
                } else {
                    continue;
                }
            }
            let gap = if rng.chance(0.5) { 3 } else { 60 };
            x += rng.below(gap);
        }
        (inside, band)
    }

    #[test]
    fn row_weights_are_the_per_pixel_weights() {
        // `ExactPart::row` (runs of weight 1 at once, integer tests where the weights clip, the
        // window sliding along the band) against the per-pixel definition with the pixels added
        // one by one in increasing column, and against `Source`'s own loops: the same bits for
        // random rows, integer D (α = 1), column sums and running sums.
        let mut rng = Rng(0x5EED_0001);
        let (mut runs, mut pixels, mut clipped) = (0usize, 0usize, 0usize);
        for case in 0..6000 {
            let width = MIN_WIDTH + rng.below(MAX_WIDTH - MIN_WIDTH + 1);
            let contrast = if rng.chance(0.5) { 1.0 } else { -1.0 } * (1 + rng.below(200)) as f32;
            let sign = contrast.signum();
            let base = rng.below(256) as f32;
            // A platform level that varies along the row (vignetting, texture) half the time.
            let varies = rng.chance(0.5);
            let background: Vec<u8> = (0..width)
                .map(|_| {
                    let b = if varies { base + rng.range(-60.0, 60.0) } else { base };
                    b.round().clamp(0.0, 255.0) as u8
                })
                .collect();
            let frame_row: Vec<u8> = background
                .iter()
                .map(|&b| {
                    // Mostly the part's contrast, some holes and other-signed values.
                    let d = match rng.below(8) {
                        0 => rng.range(-255.0, 255.0),
                        1 => contrast * rng.range(0.0, 0.3),
                        _ => contrast * rng.range(0.5, 1.5),
                    };
                    (f32::from(b) + d).round().clamp(0.0, 255.0) as u8
                })
                .collect();
            let frame = Frame::new_checked(&frame_row[..], width, 1).unwrap();
            let diff = Difference::new(&frame, &background, Alpha::ONE);
            let src = Exact::new(
                &diff,
                Rect {
                    x0: 0,
                    y0: 0,
                    x1: width,
                    y1: 1,
                },
            )
            .unwrap();
            let image_row = src.row(0);
            // Column sums of D·sign: windows of means near integers, below 1, of the other sign.
            let mut columns = [0i32; COLUMNS];
            let typical = (contrast.abs() * rng.range(0.3, 1.5)).round();
            for c in columns.iter_mut().skip(4).take(width) {
                let count = rng.below(10) as i32;
                let sum: i32 = (0..count)
                    .map(|_| match rng.below(6) {
                        0 => rng.below(511) as i32 - 255,
                        1 => rng.below(3) as i32 - 1,
                        _ => (typical + rng.range(-2.0, 2.0)).round().clamp(-255.0, 255.0) as i32,
                    })
                    .sum();
                *c = 128 * sum + count;
            }
            let (inside, band) = random_row_regions(&mut rng, width);
            let y = rng.below(if case % 8 == 0 { 70_000 } else { 400 });
            let sums = if rng.chance(0.2) {
                [0.0; 3]
            } else {
                [random_sum(&mut rng), random_sum(&mut rng), random_sum(&mut rng)]
            };
            // The ring's level: none to scale by, the platform's, or one the guard refuses.
            let level = match rng.below(3) {
                0 => 0.0,
                1 => base.max(1.0) * rng.range(0.8, 1.25),
                _ => 0.4 * contrast.abs(),
            };
            let weights = Weights::new(contrast, level);
            let (f, b) = image_row;
            let (hi, lo) = if contrast > 0.0 { (f, b) } else { (b, f) };
            let got = ExactPart::new(weights).row::<WORDS>(&src, hi, lo, y, &inside, &band, &columns, sums);
            let plain = src.weigh_row::<WORDS>(image_row, y, &inside, &band, &columns, &weights, sums);
            let [mut sw, mut sx, mut sy] = sums;
            for c in 0..width {
                let d = diff.at(c as isize, 0);
                let weight = if bit(&inside, c) {
                    let ratio = d / contrast;
                    if ratio >= HOLE_RATIO {
                        1.0
                    } else {
                        ratio.clamp(0.0, 1.0)
                    }
                } else if bit(&band, c) {
                    let window: i32 = columns[c..c + 9].iter().sum();
                    let (sum, count) = ((window >> 7) as f32 * sign, window & 127);
                    let local = (count > 0)
                        .then(|| sum / count as f32)
                        .filter(|m| m.abs() >= 1.0 && m.signum() == contrast.signum());
                    // Without a ring nearby: the median, scaled by the platform's level here
                    // over the ring's where there is a level (the definition's words).
                    let fallback = if weights.per_level > 0.0 {
                        contrast * (f32::from(background[c]) * weights.per_level).clamp(0.5, 2.0)
                    } else {
                        contrast
                    };
                    let w = (d / local.unwrap_or(fallback)).clamp(0.0, 1.0);
                    clipped += usize::from(w == 1.0);
                    w
                } else {
                    0.0
                };
                if weight > 0.0 {
                    sw += weight;
                    sx += weight * c as f32;
                    sy += weight * y as f32;
                }
            }
            let want = [sw, sx, sy].map(f32::to_bits);
            assert_eq!(got.map(f32::to_bits), want, "case {case}");
            assert_eq!(plain.map(f32::to_bits), want, "case {case} (definition's loops)");
            runs += inside
                .iter()
                .map(|w| (w & !(w << 1)).count_ones() as usize)
                .sum::<usize>();
            pixels += band.iter().map(|w| w.count_ones() as usize).sum::<usize>();
        }
        assert!(
            runs > 5000 && pixels > 50_000 && clipped > 10_000,
            "{runs} {pixels} {clipped}"
        );
    }

    #[test]
    fn sequences_add_up_like_one_term_at_a_time() {
        // `add_sequence` (at once where nothing rounds, the rounding terms alone) against adding
        // the terms one by one, across binades, at 2^24 and beyond, from 0 and from fractions.
        let mut rng = Rng(0x5EED_0002);
        let mut split = 0usize;
        for case in 0..40_000 {
            let s = match rng.below(4) {
                0 => 0.0,
                1 => rng.below(300) as f32,
                _ => random_sum(&mut rng),
            };
            let step = rng.below(2) as u32;
            let first = match rng.below(3) {
                0 => rng.below(3) as u32,
                1 => rng.below(256) as u32,
                _ => rng.below(100_000) as u32,
            };
            let most = if rng.chance(0.2) { 2000 } else { 256 };
            let count = 1 + rng.below(most) as u32;
            let mut want = s;
            for k in 0..count {
                want += (first + step * k) as f32;
            }
            let got = add_sequence(s, first, step, count);
            assert_eq!(
                got.to_bits(),
                want.to_bits(),
                "case {case}: {s} + {first} + {step}·k, {count} terms"
            );
            let total = u64::from(first) * u64::from(count) + u64::from(step) * u64::from(count * (count - 1) / 2);
            split += usize::from(exact_integer(total).and_then(|t| exact_sum(s, t)).is_none());
        }
        // Many sums had to be split where a term rounds.
        assert!(split > 5000, "{split}");
    }

    #[test]
    fn sources_give_the_values_of_at() {
        // D from the frame's and background's rows (α = 1) and through `at` (α < 1, or a short
        // background plane): values, histogram bins, ring values into column sums and out again,
        // and the hole test's least value, against `Difference::at` and the pixel-by-pixel test.
        let mut rng = Rng(4242);
        let mut shortcut = 0usize;
        for case in 0..400 {
            let (w, h) = (1 + rng.below(40), 1 + rng.below(12));
            let pixels: Vec<u8> = (0..w * h).map(|_| rng.below(256) as u8).collect();
            let full = rng.chance(0.6);
            let bg_len = if full { w * h } else { rng.below(w * h + 1) };
            let background: Vec<u8> = (0..bg_len).map(|_| rng.below(256) as u8).collect();
            let frame = Frame::new_checked(&pixels[..], w, h).unwrap();
            for alpha in [1.0, 0.5] {
                let diff = Difference::new(&frame, &background, Alpha::new(alpha).unwrap());
                assert_eq!(
                    diff.rows(h - 1).is_some(),
                    alpha >= 1.0 && bg_len == w * h,
                    "case {case}"
                );
                let x0 = rng.below(w);
                let x1 = x0 + 1 + rng.below(w - x0);
                // (Exact reads the rows of a box whose rows all have them: those up to the first
                // without.)
                let avail = (0..h).take_while(|&y| diff.rows(y).is_some()).count();
                let full = Rect {
                    x0,
                    y0: 0,
                    x1,
                    y1: avail,
                };
                let exact = Exact::new(&diff, full).unwrap_or(Exact {
                    frame: &[],
                    stride: w,
                    background: &[],
                    w,
                    y0: 0,
                    x0,
                    width: x1 - x0,
                    rows: h,
                });
                let approx = Approx { diff: &diff, x0 };
                for y in 0..h {
                    let rows = diff.rows(y).is_some();
                    assert_eq!(rows, y < avail, "case {case}");
                    let (er, ar) = (exact.row(y), approx.row(y));
                    let ring = random_bits(&mut rng, x1 - x0);
                    let (mut want_hist, mut want_cols) = ([0u16; 511], Vec::new());
                    let contrast = if rng.chance(0.5) { 9.0 } else { -9.0 };
                    let weights = Weights::new(contrast, 0.0);
                    let mut want_level = 0u64;
                    for c in 0..x1 - x0 {
                        let want = diff.at((x0 + c) as isize, y as isize);
                        assert_eq!(approx.d(ar, c).to_bits(), want.to_bits());
                        let (s, n) = <Approx<'_, '_, &[u8]> as Source>::split(approx.col(ar, c, &weights), &weights);
                        assert_eq!((s.to_bits(), n), (want.to_bits(), 1));
                        if rows {
                            assert_eq!(exact.d(er, c).to_bits(), want.to_bits(), "case {case} ({c}, {y})");
                            let (s, n) = <Exact<'_> as Source>::split(exact.col(er, c, &weights), &weights);
                            assert_eq!((s.to_bits(), n), (want.to_bits(), 1));
                        }
                        if bit(&ring, c) {
                            want_hist[(want as i32 + 255).clamp(0, 510) as usize] += 1;
                            want_cols.push(c);
                            want_level += u64::from(diff.background_at((x0 + c) as isize, y as isize));
                        }
                    }
                    // The ring's histogram, and its values into the column sums and out again.
                    let (mut hist, mut level) = ([0u16; 511], 0u64);
                    approx.histogram::<false, WORDS>(ar, &ring, &mut hist, &mut level);
                    assert_eq!((hist, level), (want_hist, want_level));
                    if rows {
                        for wrap in [false, true] {
                            let (mut hist, mut level) = ([0u16; 511], 0u64);
                            if wrap {
                                exact.histogram::<true, WORDS>(er, &ring, &mut hist, &mut level);
                            } else {
                                exact.histogram::<false, WORDS>(er, &ring, &mut hist, &mut level);
                            }
                            assert_eq!((hist, level), (want_hist, want_level), "case {case}");
                        }
                        let mut columns = [0i32; COLUMNS];
                        let (hi, lo) = Exact::signed(er, &weights);
                        move_ring::<true, WORDS>(hi, lo, &ring, &mut columns);
                        for c in 0..x1 - x0 {
                            let want = if bit(&ring, c) { exact.col(er, c, &weights) } else { 0 };
                            assert_eq!(columns[c + 4], want);
                        }
                        move_ring::<false, WORDS>(hi, lo, &ring, &mut columns);
                        assert!(columns.iter().all(|&v| v == 0));
                    }
                    // The hole test of a run by its least value, both signs of contrast, at the
                    // threshold too.
                    for _ in 0..8 {
                        let a = rng.below(x1 - x0);
                        let e = a + 1 + rng.below(x1 - x0 - a);
                        let contrast = match rng.below(3) {
                            0 => (1 + rng.below(255)) as f32,
                            1 => -((1 + rng.below(255)) as f32),
                            _ => {
                                // A contrast that puts a pixel of the run at the threshold.
                                let d = diff.at((x0 + a) as isize, y as isize);
                                if d.abs() >= 1.0 {
                                    (d / HOLE_RATIO).round()
                                } else {
                                    7.0
                                }
                            }
                        };
                        let sign = contrast.signum();
                        let all = (a..e).all(|c| diff.at((x0 + c) as isize, y as isize) / contrast >= HOLE_RATIO);
                        let by_least = |least: f32| (least * sign) / contrast >= HOLE_RATIO;
                        assert_eq!(by_least(approx.least(ar, a..e, sign)), all, "case {case}");
                        if rows {
                            assert_eq!(by_least(exact.least(er, a..e, sign)), all, "case {case} {a}..{e}");
                        }
                        shortcut += usize::from(all);
                    }
                }
            }
        }
        assert!(shortcut > 1000, "{shortcut}");
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
}
