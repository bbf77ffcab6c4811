//! The partial-volume centroid with rows of bits (boxes 4 to 256 px wide): the definition's
//! result (`definition.rs`), the same bits where `D` is an integer (`α = 1`) and within 1e-4 px
//! otherwise, in `O(box area / word)` word operations and a few dozen instructions per band and
//! ring pixel. Bit rows are machine words (64 columns a word on 64-bit targets, 32 on the
//! Cortex-M4), the code made for the box's number of words. They live in the mask plane itself
//! ([`Plane`]): a box row in use holds, from its first byte, four fields of one bit row each (the
//! mask's row, the component's and later its inside, the ring's, the band's; a word each for
//! every 32 or 64 columns, or `⌈width/8⌉` bytes in a narrow box), and its mask bits go back into
//! those bytes when it is done. Three passes over the rows:
//! 1. the fill ([`mark`]): one sweep down from the seed's row, gathering each row's mask bits from
//!    its bytes (8 with a multiplication) and taking the runs of them that touch the row above,
//!    dilated by one (all of them when every run does; else from each run's seed up by an
//!    addition with carry, down by a bit scan); where a row's runs also touch a free pixel of the
//!    row above, sweeps up and down over the rows concerned follow until one adds nothing
//!    ([`settle`]);
//! 2. the shape pass ([`shape_pass`]): from a window of the 11 component rows around a row, its
//!    inside, band and ring into its fields, and each ring pixel's `D` into a signed histogram,
//!    whose median is the part's contrast (and its background level into a sum, whose mean is
//!    the ring's level);
//! 3. the weights, in raster order ([`weigh`], [`Source::weigh`]): the ring's values summed per
//!    column over rows `y − 4 ..= y + 4` (where `D` is an integer, as `128·D·sign + 1`: the count
//!    rides in the low bits), sliding along each run of band pixels; with `α = 1` integer tests
//!    decide where a weight clips to 0 or 1 and only the others are divided, as the definition
//!    does. A run of inside pixels passes the hole test when its least `D·sign` does (the least
//!    saturating difference of the rows' bytes, which the compiler vectorises) and is added at
//!    once: one addition per sum where no partial sum rounds, the terms that round on their own,
//!    so that the sums are the same bits as pixel by pixel in raster order.
//!
//! `D` comes from the frame's and background's rows where `α = 1` (integers, so every sum of them
//! is exact); else through [`Difference::at`], with the same passes and the definition's pixel
//! loops (the ring's values kept from entering the column sums to leaving them, as far as 128 of
//! them at a time).
//!
//! Memory: on the Cortex-M4 about 3.3 KB of stack for the firmware's parts (boxes of at most
//! 96 px), at most 4.4 KB for boxes of more than 128 px: the weights' column sums and row caches
//! (up to 2.4 KB) stay allocated while the shape pass's histogram and window (up to 2 KB) are;
//! the fill needs a few hundred bytes (with `α < 1`, 4.3 KB). The box's rows in the plane are
//! scratch.

mod bits;
mod sources;

use super::definition::Weights;
use super::{Moments, Rect, HOLE_RATIO};
use crate::pose::refine::Difference;
use bits::*;
use core::ops::Range;
use sources::*;

/// The fields of a box row on the bit-row path (see [`Plane`]): the mask's row,
const MASK_FIELD: usize = 0;
/// the component's row (after the shape pass: its inside, the component eroded twice),
const COMP_FIELD: usize = 1;
/// the ring's row (the component eroded three times minus eroded five times),
const RING_FIELD: usize = 2;
/// and the band's row (the component dilated twice minus its inside).
const BAND_FIELD: usize = 3;
/// The number of fields.
const FIELDS: usize = 4;

/// The narrowest box measured with bit rows: the fields need `FIELDS · ⌈width/8⌉` bytes of a row.
const MIN_WIDTH: usize = FIELDS;

/// Column sums of ring values: box column `c` at `c + 4`, and room for a run's window to slide
/// one column past the box.
const COLUMNS: usize = MAX_WIDTH + 9;

/// Whether a box `width` px wide is measured with bit rows.
pub(super) fn measures(width: usize) -> bool {
    (MIN_WIDTH..=MAX_WIDTH).contains(&width)
}

/// The bit-row path for box `r` of the mask plane (`w` wide), from the seed (box column, box
/// row): the same result as [`super::definition::moments`].
pub(super) fn moments<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    mask: &mut [u8],
    w: usize,
    r: Rect,
    seed: (usize, usize),
) -> Option<Moments> {
    let width = r.x1 - r.x0;
    // Every row of the box has its D from the frame's and background's rows when the last has
    // (α = 1, and the background plane reaches that far).
    let Some(src) = Exact::new(diff, r) else {
        return bit_rows::<_, WORDS>(&Approx { diff, x0: r.x0 }, Plane::new(mask, w, r), seed);
    };
    let plane = Plane::new(mask, w, r);
    // Rows of exactly the box's words (beyond 4, the widest).
    match width.div_ceil(BITS) {
        1 => bit_rows::<_, 1>(&src, plane, seed),
        2 => bit_rows::<_, 2>(&src, plane, seed),
        3 => bit_rows::<_, 3>(&src, plane, seed),
        4 => bit_rows::<_, 4>(&src, plane, seed),
        _ => bit_rows::<_, WORDS>(&src, plane, seed),
    }
}

/// The bit-row path with rows of `N` words: the component from the seed (box column, box row),
/// its inside, band and ring and the ring's median `D`, then the weights; the plane holds its
/// mask again afterwards.
fn bit_rows<S: Source, const N: usize>(src: &S, mut plane: Plane<'_>, (x, q): (usize, usize)) -> Option<Moments> {
    let comp = mark::<N>(&mut plane, x, q);
    // Rows with inside or band pixels: the component's, and 2 more above and below.
    let rows = comp.start.saturating_sub(2)..(comp.end + 2).min(plane.height);
    let (contrast, level) = shape_pass::<S, N>(src, &mut plane, comp, rows.clone());
    let sums = if contrast.abs() >= 1.0 {
        src.weigh::<N>(&mut plane, rows, Weights::new(contrast, level))
    } else {
        [0.0; 3]
    };
    plane.restore::<N>();
    Moments::of(plane.r, sums, contrast)
}

/// The box in the mask plane while bit rows are measured. A box row whose fields are set up
/// ([`Plane::init`]) holds [`FIELDS`] bit rows from its first byte, `stride` bytes each (its
/// words little-endian): the mask bits of those bytes are then in the first field only, and
/// [`Plane::restore`] puts them back.
struct Plane<'m> {
    mask: &'m mut [u8],
    /// The image's width.
    w: usize,
    r: Rect,
    width: usize,
    height: usize,
    /// Words of a row.
    words: usize,
    /// The valid bits of the last of them.
    last: Word,
    /// Bytes of a field: whole words where they fit, else `⌈width/8⌉`.
    stride: usize,
    /// The box rows whose fields are set up: `lo..hi`; of them, `restored` hold the mask again.
    lo: usize,
    hi: usize,
    restored: Range<usize>,
}

impl<'m> Plane<'m> {
    fn new(mask: &'m mut [u8], w: usize, r: Rect) -> Self {
        let width = r.x1 - r.x0;
        let words = width.div_ceil(BITS).min(WORDS);
        Plane {
            mask,
            w,
            r,
            width,
            height: r.y1 - r.y0,
            words,
            last: match width % BITS {
                0 => Word::MAX,
                bits => (1 << bits) - 1,
            },
            // (Whole words from two on: `FIELDS · 2 · WORD_BYTES` bytes fit a row of more than
            // one word.)
            stride: if FIELDS * words * WORD_BYTES <= width {
                words * WORD_BYTES
            } else {
                width.div_ceil(8)
            },
            lo: 0,
            hi: 0,
            restored: 0..0,
        }
    }

    /// The plane's index of box row `q`'s first byte (wrapping: only a row of the box's is read
    /// there).
    #[inline(always)]
    fn at(&self, q: usize) -> usize {
        self.r.y0.wrapping_add(q).wrapping_mul(self.w).wrapping_add(self.r.x0)
    }

    /// The fields' bytes of box row `q` (`None` where they are not set up).
    #[inline(always)]
    fn fields(&self, q: usize) -> Option<&[u8]> {
        let s = self.at(q);
        if q >= self.lo && q < self.hi {
            self.mask.get(s..s + FIELDS * self.stride)
        } else {
            None
        }
    }

    /// [`Self::fields`], mutable.
    #[inline(always)]
    fn fields_mut(&mut self, q: usize) -> Option<&mut [u8]> {
        let s = self.at(q);
        if q >= self.lo && q < self.hi {
            self.mask.get_mut(s..s + FIELDS * self.stride)
        } else {
            None
        }
    }

    /// Field `field` of box row `q` (empty where the row's fields are not set up).
    #[inline(always)]
    fn load<const N: usize>(&self, q: usize, field: usize) -> Bits<N> {
        self.fields(q).map_or([0; N], |f| get(f, self.stride, field))
    }

    /// Sets field `field` of box row `q` (a row whose fields are set up).
    #[inline(always)]
    fn store<const N: usize>(&mut self, q: usize, field: usize, bits: &Bits<N>) {
        let stride = self.stride;
        if let Some(f) = self.fields_mut(q) {
            put(f, stride, field, bits);
        }
    }

    /// Sets up the fields of box row `q` when it is next to the rows set up (or the first): the
    /// mask's bits from the row's bytes, the component empty (the ring and the band are set by
    /// the shape pass); returns the mask's bits (empty when `q` is not set up).
    #[inline(always)]
    fn init<const N: usize>(&mut self, q: usize) -> Bits<N> {
        let first = self.lo == self.hi;
        if q >= self.height || !(first || q + 1 == self.lo || q == self.hi) {
            return self.load(q, MASK_FIELD);
        }
        let (s, stride) = (self.at(q), self.stride);
        let Some(row) = self.mask.get_mut(s..s + self.width) else {
            return [0; N];
        };
        let m = gather::<N>(row);
        put(row, stride, MASK_FIELD, &m);
        put(row, stride, COMP_FIELD, &[0; N]);
        (self.lo, self.hi) = match (first, q + 1 == self.lo) {
            (true, _) => (q, q + 1),
            (false, true) => (q, self.hi),
            (false, false) => (self.lo, q + 1),
        };
        m
    }

    /// Puts the mask's bits back into the bytes of the fields (of the rows not `restored`); no
    /// row is set up afterwards.
    fn restore<const N: usize>(&mut self) {
        let stride = self.stride;
        for q in self.lo..self.hi {
            if self.restored.contains(&q) {
                continue;
            }
            let s = self.at(q);
            if let Some(row) = self.mask.get_mut(s..s + FIELDS * stride) {
                restore_row::<N>(row, stride);
            }
        }
        (self.lo, self.hi, self.restored) = (0, 0, 0..0);
    }
}

/// Puts the mask's bits back into a row's field bytes (`FIELDS · stride` of them): byte i from
/// bit i of the mask's field (the fields take at most half of the row's bytes, so the first half
/// of its words).
#[inline(always)]
fn restore_row<const N: usize>(row: &mut [u8], stride: usize) {
    let m: Bits<N> = get(row, stride, MASK_FIELD);
    if whole_words::<N>(stride) {
        // A whole number of 8-byte chunks: unrolled.
        for (i, c) in row.chunks_exact_mut(8).enumerate().take(FIELDS * N * WORD_BYTES / 8) {
            let byte = m
                .get(i / WORD_BYTES)
                .map_or(0, |&w| (w >> (8 * (i % WORD_BYTES))) as u8);
            c.copy_from_slice(&SPREAD.get(usize::from(byte)).copied().unwrap_or(0).to_le_bytes());
        }
    } else {
        for (i, c) in row.chunks_mut(8).enumerate() {
            let byte = m
                .get(i / WORD_BYTES)
                .map_or(0, |&w| (w >> (8 * (i % WORD_BYTES))) as u8);
            for (b, v) in c.iter_mut().zip(spread(byte).to_le_bytes()) {
                *b = v;
            }
        }
    }
}

/// Whether fields of `stride` bytes are `N` whole words: known for rows of 2 to `WORDS − 1`
/// words, which are always that wide (see [`Plane::new`]); the widest rows are also those of
/// [`Approx`]'s, which may be narrower.
#[inline(always)]
fn whole_words<const N: usize>(stride: usize) -> bool {
    (N > 1 && N < WORDS) || stride == N * WORD_BYTES
}

/// Field `field` of a row's bytes (its words little-endian from byte `stride · field`).
#[inline(always)]
fn get<const N: usize>(row: &[u8], stride: usize, field: usize) -> Bits<N> {
    let mut out = [0; N];
    if whole_words::<N>(stride) {
        let s = N * WORD_BYTES * field;
        if let Some(bytes) = row.get(s..s + N * WORD_BYTES) {
            for (o, c) in out.iter_mut().zip(bytes.chunks_exact(WORD_BYTES)) {
                *o = Word::from_le_bytes(c.try_into().unwrap_or_default());
            }
        }
    } else if let Some(bytes) = row.get(stride * field..stride * (field + 1)) {
        for (o, c) in out.iter_mut().zip(bytes.chunks(WORD_BYTES)) {
            let mut word = [0u8; WORD_BYTES];
            for (b, v) in word.iter_mut().zip(c) {
                *b = *v;
            }
            *o = Word::from_le_bytes(word);
        }
    }
    out
}

/// Sets field `field` of a row's bytes (see [`get`]).
#[inline(always)]
fn put<const N: usize>(row: &mut [u8], stride: usize, field: usize, bits: &Bits<N>) {
    if whole_words::<N>(stride) {
        let s = N * WORD_BYTES * field;
        if let Some(bytes) = row.get_mut(s..s + N * WORD_BYTES) {
            for (c, v) in bytes.chunks_exact_mut(WORD_BYTES).zip(bits) {
                c.copy_from_slice(&v.to_le_bytes());
            }
        }
    } else if let Some(bytes) = row.get_mut(stride * field..stride * (field + 1)) {
        for (c, v) in bytes.chunks_mut(WORD_BYTES).zip(bits) {
            for (b, v) in c.iter_mut().zip(v.to_le_bytes()) {
                *b = v;
            }
        }
    }
}

/// Marks the 8-connected component of the mask's pixel at box column `x` of box row `q` in the
/// component field, setting up the rows it reaches and one more above and below; returns the box
/// rows that hold it. One sweep down from the seed's row adds to each row the runs next to the
/// row above; where a row's runs touch a free pixel of the row above (the component turns
/// upward), [`settle`] sweeps back and forth over the rows concerned.
#[inline(never)]
fn mark<const N: usize>(plane: &mut Plane<'_>, x: usize, q: usize) -> Range<usize> {
    let m = plane.init::<N>(q);
    if !bit(&m, x) {
        return q..q;
    }
    let (a, b) = run_around(&m, x);
    let mut c = [0; N];
    set_range(&mut c, a, b);
    plane.store(q, COMP_FIELD, &c);
    let mut grown = dilate::<1, N>(&c);
    // The rows whose runs touch a free pixel of the row above.
    let mut touched: Option<(usize, usize)> = None;
    let mut touch = |k: usize| {
        touched = Some(touched.map_or((k, k), |(lo, hi)| (lo.min(k), hi.max(k))));
    };
    if q > 0 && !none(&and(&plane.init::<N>(q - 1), &grown)) {
        touch(q);
    }
    let mut above_free = and_not(&m, &c);
    // Rows q..end hold the component; each next row is set up here, from the row's bytes (rows
    // q − 1 ..= q are).
    let (stride, width, height, w) = (plane.stride, plane.width, plane.height, plane.w);
    let mut end = q + 1;
    if plane.hi == end {
        let mut next = end;
        let mut s = plane.at(next);
        let mask = &mut *plane.mask;
        while next < height {
            let Some(row) = mask.get_mut(s..s + width) else {
                break;
            };
            let m = gather::<N>(row);
            put(row, stride, MASK_FIELD, &m);
            next += 1;
            let seeds = and(&m, &grown);
            if none(&seeds) {
                put(row, stride, COMP_FIELD, &[0; N]);
                break;
            }
            let c = runs_of(&m, &seeds);
            put(row, stride, COMP_FIELD, &c);
            end = next;
            grown = dilate::<1, N>(&c);
            if !none(&and(&above_free, &grown)) {
                touch(end - 1);
            }
            above_free = and_not(&m, &c);
            s += w;
        }
        plane.hi = next;
    }
    match touched {
        None => q..end,
        Some(rows) => settle::<N>(plane, rows),
    }
}

/// Completes the component after [`mark`]'s sweep down, whose runs in the rows `touched` (first
/// and last) touch free pixels of the row above: sweeps up from the row above the last, through
/// the rows above those touched and on while rows grow, then down over the rows below those whose
/// new runs touch free pixels below, and so on until a sweep's new runs touch nothing behind it.
/// Every row is then settled: no free pixel of it is next to the component in the rows above and
/// below. Returns the rows that hold the component.
fn settle<const N: usize>(plane: &mut Plane<'_>, touched: (usize, usize)) -> Range<usize> {
    // Rows to grow: `pending` (first and last), the row behind each row touched.
    let mut pending = (touched.0.saturating_sub(1), touched.1.saturating_sub(1));
    let mut up = true;
    loop {
        let mut next: Option<(usize, usize)> = None;
        let mut k = if up { pending.1 } else { pending.0 };
        let mut grew = false;
        loop {
            let must = (pending.0..=pending.1).contains(&k) || grew;
            if !must || !(plane.lo..plane.hi).contains(&k) {
                break;
            }
            let (g, touch) = grow_row::<N>(plane, k, up);
            grew = g;
            if touch {
                next = Some(next.map_or((k, k), |(lo, hi)| (lo.min(k), hi.max(k))));
            }
            if up {
                let Some(above) = k.checked_sub(1) else { break };
                k = above;
            } else {
                k += 1;
            }
        }
        let Some((lo, hi)) = next else { break };
        // The rows behind those touched: below them after a sweep up, above after a sweep down.
        pending = if up {
            (lo + 1, hi + 1)
        } else {
            (lo.saturating_sub(1), hi.saturating_sub(1))
        };
        up = !up;
    }
    let mut rows = 0..0;
    for r in plane.lo..plane.hi {
        if !none(&plane.load::<N>(r, COMP_FIELD)) {
            rows = if rows.start == rows.end {
                r..r + 1
            } else {
                rows.start..r + 1
            };
        }
    }
    rows
}

/// Adds to row `k` its free runs next to the component in rows `k − 1` and `k + 1`, setting up
/// the rows next to it; returns whether it added any, and whether those touch a free pixel of the
/// row behind (below for a sweep `up`, above for a sweep down).
fn grow_row<const N: usize>(plane: &mut Plane<'_>, k: usize, up: bool) -> (bool, bool) {
    let (m, c) = (plane.load::<N>(k, MASK_FIELD), plane.load::<N>(k, COMP_FIELD));
    let (above, below) = (
        plane.load::<N>(k.wrapping_sub(1), COMP_FIELD),
        plane.load::<N>(k + 1, COMP_FIELD),
    );
    let free = and_not(&m, &c);
    let seeds = and(&free, &dilate::<1, N>(&or(&above, &below)));
    if none(&seeds) {
        return (false, false);
    }
    let new = runs_of(&free, &seeds);
    plane.store(k, COMP_FIELD, &or(&c, &new));
    if k + 1 == plane.hi {
        plane.init::<N>(k + 1);
    }
    if k == plane.lo && k > 0 {
        plane.init::<N>(k - 1);
    }
    let behind = if up { k + 1 } else { k.wrapping_sub(1) };
    let behind_free = and_not(
        &plane.load::<N>(behind, MASK_FIELD),
        &plane.load::<N>(behind, COMP_FIELD),
    );
    (true, !none(&and(&behind_free, &dilate::<1, N>(&new))))
}

/// Slot of row `q` in a window of 16 rows.
#[inline(always)]
fn slot(q: usize) -> usize {
    q % 16
}

/// First pass: each row of `rows` gets its inside (component eroded twice), band (dilated twice
/// minus inside) and ring (eroded three times minus eroded five times) in its fields, the
/// component's rows being `comp`; returns the median `D` over the ring (from a signed histogram;
/// 0 without ring pixels) and the ring's mean background level. Not inlined: its histogram and
/// [`weigh`]'s column sums need not share a stack frame.
#[inline(never)]
fn shape_pass<S: Source, const N: usize>(
    src: &S,
    plane: &mut Plane<'_>,
    comp: Range<usize>,
    rows: Range<usize>,
) -> (f32, f32) {
    // Fields for every row weighed.
    while plane.lo > rows.start {
        let lo = plane.lo;
        plane.init::<N>(lo - 1);
        if plane.lo == lo {
            break;
        }
    }
    while plane.hi < rows.end {
        let hi = plane.hi;
        plane.init::<N>(hi);
        if plane.hi == hi {
            break;
        }
    }
    let mut hist = [0u16; 511];
    let mut ring_count = 0usize;
    let mut level_sum = 0u64;
    // No bin of a box of fewer than 2^16 pixels gets to u16::MAX.
    let small = plane.width * plane.height < 1 << 16;
    let load = |plane: &Plane<'_>, q: usize| {
        if comp.contains(&q) {
            plane.load::<N>(q, COMP_FIELD)
        } else {
            [0; N]
        }
    };
    // The component's rows j − 5 ..= j + 5 around row j (empty outside `comp`).
    let mut window = [[0; N]; 16];
    for q in rows.start.saturating_sub(5)..rows.start + 5 {
        if let Some(w) = window.get_mut(slot(q)) {
            *w = load(plane, q);
        }
    }
    let valid: Bits<N> = core::array::from_fn(|k| match (k + 1).cmp(&plane.words) {
        core::cmp::Ordering::Less => Word::MAX,
        core::cmp::Ordering::Equal => plane.last,
        core::cmp::Ordering::Greater => 0,
    });
    for j in rows {
        if let Some(w) = window.get_mut(slot(j + 5)) {
            *w = load(plane, j + 5);
        }
        // Row j + t − 6 for t = 1..=11.
        let row = |t: usize| window.get(slot(j + t + 10)).copied().unwrap_or([0; N]);
        // Erosion by the (2k+1)-square: AND of the rows within k, then of the columns within k;
        // dilation likewise with OR.
        let (a, b, c, d, e) = (row(4), row(5), row(6), row(7), row(8));
        let grown = or(&or(&or(&a, &b), &or(&c, &d)), &e);
        let (mut inside, mut band, mut ring) = ([0; N], [0; N], [0; N]);
        if !none(&grown) {
            let v2 = and(&and(&and(&a, &b), &and(&c, &d)), &e);
            inside = erode::<2, N>(&v2);
            band = and_not(&and(&dilate::<2, N>(&grown), &valid), &inside);
            let v3 = and(&and(&v2, &row(3)), &row(9));
            if !none(&v3) {
                let v5 = and(&and(&and(&v3, &row(1)), &and(&row(2), &row(10))), &row(11));
                ring = and_not(&erode::<3, N>(&v3), &erode::<5, N>(&v5));
            }
        }
        let stride = plane.stride;
        if let Some(fields) = plane.fields_mut(j) {
            put(fields, stride, COMP_FIELD, &inside);
            put(fields, stride, BAND_FIELD, &band);
            put(fields, stride, RING_FIELD, &ring);
        }
        if !none(&ring) {
            let image_row = src.row(plane.r.y0 + j);
            if small {
                src.histogram::<true, N>(image_row, &ring, &mut hist, &mut level_sum);
            } else {
                src.histogram::<false, N>(image_row, &ring, &mut hist, &mut level_sum);
            }
            ring_count += ring.iter().map(|w| w.count_ones() as usize).sum::<usize>();
        }
    }
    if ring_count == 0 {
        return (0.0, 0.0);
    }
    let level = level_sum as f32 / ring_count as f32;
    let mut acc = 0usize;
    for (bin, &c) in hist.iter().enumerate() {
        acc += c as usize;
        if 2 * acc >= ring_count {
            return (bin as f32 - 255.0, level);
        }
    }
    (0.0, level)
}

/// Second pass: the sums (Σw, Σw·x, Σw·y, box coordinates) of the weights of the rows `rows`, in
/// raster order, from the fields the shape pass left. The ring's values are summed per column
/// over rows `y − 4 ..= y + 4` while row `y` is weighed. Not inlined (see [`shape_pass`]).
#[inline(never)]
fn weigh<S: Source, const N: usize>(src: &S, plane: &Plane<'_>, rows: Range<usize>, weights: Weights) -> [f32; 3] {
    let mut sums = [0.0f32; 3];
    let mut columns = [S::Col::default(); COLUMNS];
    // The image rows and ring rows of rows y − 4 ..= y + 4 (row q in slot q mod 16), each read
    // once: when it enters the column sums; the ring values too, as many as the FIFO holds.
    let mut images = [S::Row::default(); 16];
    let mut rings = [[0; N]; 16];
    let mut fifo = RingFifo::new(S::Col::default());
    let enter = |columns: &mut [S::Col; COLUMNS],
                 images: &mut [S::Row; 16],
                 rings: &mut [Bits<N>; 16],
                 fifo: &mut RingFifo<S::Col>,
                 q: usize| {
        let image_row = src.row(plane.r.y0 + q);
        let bits = if rows.contains(&q) {
            plane.load::<N>(q, RING_FIELD)
        } else {
            [0; N]
        };
        for_each_bit(&bits, |c| {
            if let Some(s) = columns.get_mut(c + 4) {
                let v = src.col(image_row, c, &weights);
                *s = *s + v;
                fifo.enter(v);
            }
        });
        if let (Some(i), Some(r)) = (images.get_mut(q % 16), rings.get_mut(q % 16)) {
            (*i, *r) = (image_row, bits);
        }
    };
    for q in rows.start.saturating_sub(4)..rows.start + 4 {
        enter(&mut columns, &mut images, &mut rings, &mut fifo, q);
    }
    for y in rows.clone() {
        enter(&mut columns, &mut images, &mut rings, &mut fifo, y + 4);
        if let Some(fields) = plane.fields(y) {
            let band: Bits<N> = get(fields, plane.stride, BAND_FIELD);
            if !none(&band) {
                let inside: Bits<N> = get(fields, plane.stride, COMP_FIELD);
                let image_row = images.get(y % 16).copied().unwrap_or_default();
                sums = src.weigh_row(image_row, y, &inside, &band, &columns, &weights, sums);
            }
        }
        if let Some(q) = y.checked_sub(4) {
            if let (Some(&image_row), Some(bits)) = (images.get(q % 16), rings.get(q % 16)) {
                for_each_bit(bits, |c| {
                    if let Some(s) = columns.get_mut(c + 4) {
                        *s = *s - fifo.leave(|| src.col(image_row, c, &weights));
                    }
                });
            }
        }
    }
    sums
}

/// Capacity of [`RingFifo`].
const RING_FIFO: usize = 128;

/// The ring values between entering the column sums and leaving them, in the order they enter
/// (which is the order they leave), so that each is computed once ([`Approx`]'s are dear): the
/// values numbered `kept` (at most [`RING_FIFO`] of them); the others are computed again.
struct RingFifo<C> {
    values: [C; RING_FIFO],
    kept: Range<usize>,
    /// The number of values entered, and left.
    entered: usize,
    left: usize,
}

impl<C: Copy> RingFifo<C> {
    fn new(zero: C) -> Self {
        RingFifo {
            values: [zero; RING_FIFO],
            kept: 0..0,
            entered: 0,
            left: 0,
        }
    }

    /// The next value entered: kept while the kept values stay consecutive and fit, or afresh
    /// once none is.
    #[inline(always)]
    fn enter(&mut self, v: C) {
        let k = self.entered;
        self.entered += 1;
        if self.kept.start == self.kept.end {
            self.kept = k..k;
        }
        if k == self.kept.end && k - self.kept.start < RING_FIFO {
            if let Some(slot) = self.values.get_mut(k % RING_FIFO) {
                *slot = v;
                self.kept.end = k + 1;
            }
        }
    }

    /// The next value to leave (`read` when it is not kept).
    #[inline(always)]
    fn leave(&mut self, read: impl FnOnce() -> C) -> C {
        let k = self.left;
        self.left += 1;
        // Values leave in the order they enter: a kept one is the first kept.
        if k == self.kept.start && k < self.kept.end {
            self.kept.start += 1;
            if let Some(&v) = self.values.get(k % RING_FIFO) {
                return v;
            }
        }
        read()
    }
}

/// `sums` plus `weights`' share of the inside pixels `cols` of box row `y`: 1, unless the pixel
/// looks like the platform (a small hole or a narrow gap that the mask's closing filled;
/// printed labels keep at least a third of the part's contrast, holes keep none).
#[inline(always)]
fn inside_run<S: Source>(
    weights: &Weights,
    src: &S,
    image_row: S::Row,
    cols: Range<usize>,
    y: usize,
    sums: [f32; 3],
) -> [f32; 3] {
    let (contrast, sign) = (weights.contrast, weights.sign);
    // Division by the contrast is monotonic: when the least `D · sign` passes, all do.
    let least = src.least(image_row, cols.clone(), sign);
    if (least * sign) / contrast >= HOLE_RATIO {
        return add_ones(sums, cols, y);
    }
    inside_by_pixel(weights, src, image_row, cols, y, sums)
}

/// [`inside_run`] pixel by pixel (runs of weight 1 between the others at once).
#[inline(never)]
fn inside_by_pixel<S: Source>(
    weights: &Weights,
    src: &S,
    image_row: S::Row,
    cols: Range<usize>,
    y: usize,
    sums: [f32; 3],
) -> [f32; 3] {
    let contrast = weights.contrast;
    let mut sums = sums;
    let mut ones = cols.start;
    for c in cols.clone() {
        let ratio = src.d(image_row, c) / contrast;
        if ratio >= HOLE_RATIO {
            continue;
        }
        sums = add_ones(sums, ones..c, y);
        ones = c + 1;
        let weight = ratio.clamp(0.0, 1.0);
        if weight > 0.0 {
            let [sw, sx, sy] = sums;
            sums = [sw + weight, sx + weight * c as u32 as f32, sy + weight * y as f32];
        }
    }
    add_ones(sums, ones..cols.end, y)
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::pose::partial_volume::tests::components;
    use crate::pose::partial_volume::LOW;
    use bits::tests::random_bits;
    use std::vec::Vec;

    use crate::test_rng::XorShift as Rng;

    #[test]
    fn ring_fifo_gives_each_value_back() {
        // Rows of ring values enter the column sums and leave them 9 rows later, as in `weigh`;
        // kept or computed again, each value must come back as it entered, and a window that
        // fits the FIFO computes none again.
        let mut rng = Rng(4242);
        for case in 0..300 {
            let rows: Vec<usize> = (0..1 + rng.below(60))
                .map(|_| match case % 4 {
                    0 => rng.below(8),
                    1 => rng.below(40),
                    2 => rng.below(3) * 60,
                    _ => rng.below(200),
                })
                .collect();
            let value = |k: usize| k as f32 * 0.75 - 100.0;
            let mut fifo = RingFifo::new(0.0f32);
            let (mut entered, mut left, mut reads, mut most) = (0usize, 0usize, 0usize, 0usize);
            for p in 0..rows.len() + 9 {
                for _ in 0..rows.get(p).copied().unwrap_or(0) {
                    fifo.enter(value(entered));
                    entered += 1;
                }
                most = most.max(entered - left);
                if let Some(q) = p.checked_sub(8) {
                    for _ in 0..rows.get(q).copied().unwrap_or(0) {
                        let v = fifo.leave(|| {
                            reads += 1;
                            value(left)
                        });
                        assert_eq!(v, value(left), "case {case} value {left}");
                        left += 1;
                    }
                }
            }
            assert_eq!(entered, left);
            if most <= RING_FIFO {
                assert_eq!(reads, 0, "case {case}");
            }
        }
    }

    /// A random box (at least [`MIN_WIDTH`] wide, at most [`MAX_WIDTH`]; narrow ones often) in a
    /// random 0/1 plane.
    fn random_box(rng: &mut Rng, density: f32) -> (usize, usize, Vec<u8>, Rect) {
        let (w, h) = (MIN_WIDTH + rng.below(300), 1 + rng.below(60));
        let mask: Vec<u8> = (0..w * h).map(|_| rng.chance(density) as u8).collect();
        let x0 = rng.below(w - MIN_WIDTH + 1);
        let most = if rng.chance(0.3) { 40 } else { MAX_WIDTH };
        let x1 = (x0 + MIN_WIDTH + rng.below(most - MIN_WIDTH + 1)).min(w);
        let y0 = rng.below(h);
        let r = Rect {
            x0,
            y0,
            x1,
            y1: y0 + 1 + rng.below(h - y0),
        };
        (w, h, mask, r)
    }

    /// Calls `f::<N>` with the box's words.
    macro_rules! with_words {
        ($width:expr, $f:ident ( $($arg:expr),* )) => {
            match ($width).div_ceil(BITS) {
                1 => $f::<1>($($arg),*),
                2 => $f::<2>($($arg),*),
                3 => $f::<3>($($arg),*),
                4 => $f::<4>($($arg),*),
                _ => $f::<WORDS>($($arg),*),
            }
        };
    }

    fn plane_case<const N: usize>(rng: &mut Rng, case: usize, w: usize, mask: &[u8], r: Rect) -> bool {
        let mut plane_bytes = mask.to_vec();
        let mut plane = Plane::new(&mut plane_bytes, w, r);
        assert!(FIELDS * plane.stride <= plane.width);
        let packed = plane.stride < N * WORD_BYTES;
        let first = rng.below(plane.height);
        plane.init::<N>(first);
        // Not next to the rows set up: refused.
        plane.init::<N>(first + 2);
        assert_eq!((plane.lo, plane.hi), (first, first + 1));
        for q in (0..first).rev().chain(first + 1..plane.height) {
            plane.init::<N>(q);
        }
        assert_eq!((plane.lo, plane.hi), (0, plane.height));
        let width = r.x1 - r.x0;
        let narrow = |bits: Bits<WORDS>| -> Bits<N> { core::array::from_fn(|k| bits[k]) };
        let mut rows = Vec::new();
        for q in 0..plane.height {
            let m = plane.load::<N>(q, MASK_FIELD);
            for c in 0..BITS * N {
                let want = c < width && mask[(r.y0 + q) * w + r.x0 + c] == 1;
                assert_eq!(bit(&m, c), want, "case {case} row {q} column {c}");
            }
            assert_eq!(plane.load::<N>(q, COMP_FIELD), [0; N]);
            let (c, g, b) = (
                narrow(random_bits(rng, width)),
                narrow(random_bits(rng, width)),
                narrow(random_bits(rng, width)),
            );
            plane.store(q, COMP_FIELD, &c);
            plane.store(q, RING_FIELD, &g);
            plane.store(q, BAND_FIELD, &b);
            rows.push((m, c, g, b));
        }
        for (q, &(m, c, g, b)) in rows.iter().enumerate() {
            assert_eq!(plane.load::<N>(q, MASK_FIELD), m, "case {case}");
            assert_eq!(plane.load::<N>(q, COMP_FIELD), c, "case {case}");
            assert_eq!(plane.load::<N>(q, RING_FIELD), g, "case {case}");
            assert_eq!(plane.load::<N>(q, BAND_FIELD), b, "case {case}");
        }
        assert_eq!(plane.load::<N>(plane.height, MASK_FIELD), [0; N]);
        plane.restore::<N>();
        assert_eq!(plane.load::<N>(0, MASK_FIELD), [0; N]);
        assert!(plane_bytes == mask, "case {case}: plane not restored");
        packed
    }

    #[test]
    fn plane_fields_hold_bit_rows_and_give_the_mask_back() {
        // Rows set up from the mask's bytes, next to each other only; their fields loaded and
        // stored (whole words and packed); the plane as it was after `restore`.
        let mut rng = Rng(99);
        let mut packed = 0;
        for case in 0..400 {
            let (w, _, mask, r) = random_box(&mut rng, 0.5);
            packed += usize::from(with_words!(r.x1 - r.x0, plane_case(&mut rng, case, w, &mask, r)));
        }
        assert!(packed > 50, "{packed}");
        for byte in 0..=255u8 {
            let v = spread(byte);
            assert_eq!(v & !LOW, 0);
            assert_eq!(pack(v), byte as Word);
        }
    }

    fn fill_case<const N: usize>(
        w: usize,
        mask: &[u8],
        r: Rect,
        seed: (usize, usize),
        want: &[(usize, usize)],
        case: usize,
    ) {
        let (bw, bh) = (r.x1 - r.x0, r.y1 - r.y0);
        let top = want.iter().map(|p| p.1).min().unwrap();
        let bottom = want.iter().map(|p| p.1).max().unwrap() + 1;
        let mut bytes = mask.to_vec();
        let mut plane = Plane::new(&mut bytes, w, r);
        let rows = mark::<N>(&mut plane, seed.0 - r.x0, seed.1 - r.y0);
        assert_eq!(rows, top..bottom, "case {case}");
        assert!(
            plane.lo <= top.saturating_sub(1) && (bottom + 1).min(bh) <= plane.hi,
            "case {case}"
        );
        let mut marked = 0;
        for q in 0..bh {
            let c = plane.load::<N>(q, COMP_FIELD);
            marked += c.iter().map(|v| v.count_ones() as usize).sum::<usize>();
            for x in 0..bw {
                assert_eq!(bit(&c, x), want.contains(&(x, q)), "case {case} ({x}, {q})");
            }
        }
        assert_eq!(marked, want.len(), "case {case}");
        plane.restore::<N>();
        assert!(bytes == mask, "case {case}: plane not restored");
    }

    #[test]
    fn bit_row_fill_finds_the_component() {
        // The fill over bit rows (one sweep down, and sweeps back and forth where the component
        // turns upward): exactly the 8-connected component within the box, the rows that hold it
        // with one more set up above and below, the mask back after `restore`. Ragged random
        // masks, and spirals and combs that turn many times.
        let mut rng = Rng(12345);
        let mut upward = 0usize;
        for case in 0..600 {
            let density = rng.range(0.3, 0.8);
            let (w, h, mut mask, r) = random_box(&mut rng, density);
            if case % 3 == 0 {
                // Vertical and horizontal bars joined alternately at the top and the bottom, or
                // a square spiral.
                let spiral = rng.chance(0.5);
                for y in 0..h {
                    for x in 0..w {
                        let (bx, by) = (x / 2, y / 2);
                        mask[y * w + x] = if spiral {
                            let ring = bx
                                .min(by)
                                .min((w / 2).saturating_sub(bx + 1))
                                .min((h / 2).saturating_sub(by + 1));
                            u8::from(
                                ring % 2 == 0 && !(bx == ring + 1 && by == ring)
                                    || (ring % 2 == 1 && bx == ring && by == ring - 1),
                            )
                        } else {
                            let joint = if (bx / 2) % 2 == 0 { y + 2 >= h } else { y < 2 };
                            u8::from(bx % 2 == 0 || joint)
                        };
                    }
                }
            }
            let seed = (r.x0 + rng.below(r.x1 - r.x0), r.y0 + rng.below(r.y1 - r.y0));
            if mask[seed.1 * w + seed.0] == 0 {
                continue;
            }
            let (bw, bh) = (r.x1 - r.x0, r.y1 - r.y0);
            let boxed: Vec<u8> = (0..bw * bh)
                .map(|i| mask[(r.y0 + i / bw) * w + r.x0 + i % bw])
                .collect();
            let comps = components(&boxed, bw, bh);
            let want = comps
                .iter()
                .find(|c| c.contains(&(seed.0 - r.x0, seed.1 - r.y0)))
                .unwrap();
            upward += usize::from(want.iter().any(|p| p.1 < seed.1 - r.y0));
            with_words!(bw, fill_case(w, &mask, r, seed, want, case));
        }
        assert!(upward > 100, "{upward}");
    }
}
