//! Partial-volume centroid: the part's area centroid with its edge pixels counted by coverage.
//!
//! DOCS-PLACEHOLDER

use crate::refine::Difference;
use core::ops::{Add, Range, Sub};

/// Below this fraction of the part's contrast an interior pixel is taken for platform (a filled
/// hole).
const HOLE_RATIO: f32 = 0.2;

/// Bit of the mask plane marking the seed's component on the per-pixel path (bit 0 is the mask).
const COMPONENT: u8 = 1 << 7;

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

/// The fields a box row holds on the bit-row path, `n` little-endian words each from byte
/// `4·n·field` of the row: the mask's row, the component's and the ring's.
const MASK_FIELD: usize = 0;
/// See [`MASK_FIELD`].
const COMP_FIELD: usize = 1;
/// See [`MASK_FIELD`].
const RING_FIELD: usize = 2;
/// The number of fields.
const FIELDS: usize = 3;

/// The narrowest box measured with bit rows: its rows hold the fields (`4·FIELDS·n` bytes for
/// `n = ⌈width/32⌉` words fit a row from 12 px on).
const MIN_WIDTH: usize = 4 * FIELDS;

/// Spans the component fill keeps at most (then raster scans restart it).
const FILL_STACK: usize = 512;

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
/// image). `mask` is the 0/1 plane: inside the box it is scratch while the call runs (bits 1–7
/// must be 0 on entry), and it holds its 0/1 values again on return. `None` when the part has no
/// weight, or when `seed` is outside the image, the box or the mask, or `mask` is shorter than the
/// image (then `mask` is not touched).
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
    let (width, height) = (r.x1 - r.x0, r.y1 - r.y0);
    if (MIN_WIDTH..=MAX_WIDTH).contains(&width) && height < 1 << 24 {
        let plane = Plane::new(mask, w, r);
        let (x, q) = (seed.0 - r.x0, seed.1 - r.y0);
        // Every row of the box has its D from the frame's and background's rows when the last
        // has (α = 1, and the background plane reaches that far).
        if diff.rows(r.y1 - 1).is_some() {
            bit_rows(&Exact { diff, x0: r.x0, x1: r.x1 }, plane, x, q)
        } else {
            bit_rows(&Approx { diff, x0: r.x0 }, plane, x, q)
        }
    } else {
        mark_component(mask, w, r, seed);
        per_pixel::centroid(diff, mask, w, r)
    }
}

/// The bit-row path: the component from the seed at box column `x` of box row `q`, the ring's
/// median `D`, the weights; the plane holds its mask again afterwards.
fn bit_rows<S: Source>(src: &S, mut plane: Plane<'_>, x: usize, q: usize) -> Option<[f32; 2]> {
    let comp = mark(&mut plane, x, q);
    let contrast = ring_pass(src, &mut plane, comp.clone());
    let sums = if contrast.abs() >= 1.0 {
        weigh(src, &plane, comp, contrast)
    } else {
        [0.0; 3]
    };
    plane.restore();
    let [sw, sx, sy] = sums;
    let r = plane.r;
    (sw > 0.0).then(|| [r.x0 as f32 + sx / sw, r.y0 as f32 + sy / sw])
}

/// The box in the mask plane while bit rows are measured. A box row whose fields are set up
/// ([`Plane::init`]) holds, from its first byte, the mask's row, the component's and the ring's as
/// [`Bits`] (`n` words each, little-endian): the mask bits of those bytes are then in the first
/// field only, and [`Plane::restore`] puts them back.
struct Plane<'m> {
    mask: &'m mut [u8],
    /// The image's width.
    w: usize,
    r: Rect,
    width: usize,
    height: usize,
    /// Words per bit row.
    n: usize,
    /// The valid bits of the last of them.
    last: u32,
    /// The box rows whose fields are set up: `lo..hi`.
    lo: usize,
    hi: usize,
}

impl<'m> Plane<'m> {
    fn new(mask: &'m mut [u8], w: usize, r: Rect) -> Self {
        let width = r.x1 - r.x0;
        Plane {
            mask,
            w,
            r,
            width,
            height: r.y1 - r.y0,
            n: width.div_ceil(32).min(WORDS),
            last: match width % 32 {
                0 => u32::MAX,
                bits => (1u32 << bits) - 1,
            },
            lo: 0,
            hi: 0,
        }
    }

    /// The plane's index of box row `q`'s first byte.
    fn start(&self, q: usize) -> usize {
        (self.r.y0 + q) * self.w + self.r.x0
    }

    /// Field `field` of box row `q` (`EMPTY` where the row's fields are not set up).
    #[inline]
    fn load(&self, q: usize, field: usize) -> Bits {
        let mut out = EMPTY;
        if (self.lo..self.hi).contains(&q) {
            let s = self.start(q) + 4 * self.n * field;
            if let Some(bytes) = self.mask.get(s..s + 4 * self.n) {
                for (o, b) in out.iter_mut().zip(bytes.chunks_exact(4)) {
                    *o = u32::from_le_bytes(b.try_into().unwrap_or_default());
                }
            }
        }
        out
    }

    /// Sets field `field` of box row `q` (a row whose fields are set up).
    #[inline]
    fn store(&mut self, q: usize, field: usize, bits: &Bits) {
        if (self.lo..self.hi).contains(&q) {
            let s = self.start(q) + 4 * self.n * field;
            if let Some(bytes) = self.mask.get_mut(s..s + 4 * self.n) {
                for (b, v) in bytes.chunks_exact_mut(4).zip(bits) {
                    b.copy_from_slice(&v.to_le_bytes());
                }
            }
        }
    }

    /// Sets up the fields of box row `q` when it is next to the rows set up (or the first): the
    /// mask's bits from the row's bytes, the others empty.
    fn init(&mut self, q: usize) {
        let first = self.lo == self.hi;
        if q >= self.height || !(first || q + 1 == self.lo || q == self.hi) {
            return;
        }
        let s = self.start(q);
        let bytes = 4 * self.n;
        let Some(row) = self.mask.get_mut(s..s + self.width) else {
            return;
        };
        let m = gather(row);
        let Some(fields) = row.get_mut(..FIELDS * bytes) else {
            return;
        };
        for (k, chunk) in fields.chunks_exact_mut(4).enumerate() {
            let v = if k < self.n { m.get(k).copied().unwrap_or(0) } else { 0 };
            chunk.copy_from_slice(&v.to_le_bytes());
        }
        if first {
            (self.lo, self.hi) = (q, q + 1);
        } else if q + 1 == self.lo {
            self.lo = q;
        } else {
            self.hi = q + 1;
        }
    }

    /// Puts the mask's bits back into the bytes of the fields; no row is set up afterwards.
    fn restore(&mut self) {
        let bytes = FIELDS * 4 * self.n;
        for q in self.lo..self.hi {
            let m = self.load(q, MASK_FIELD);
            let s = self.start(q);
            if let Some(row) = self.mask.get_mut(s..s + bytes) {
                for (k, chunk) in row.chunks_mut(8).enumerate() {
                    let byte = m.get(k / 4).map_or(0, |&v| (v >> (8 * (k % 4))) & 0xFF);
                    for (b, v) in chunk.iter_mut().zip(spread(byte).to_le_bytes()) {
                        *b = v;
                    }
                }
            }
        }
        (self.lo, self.hi) = (0, 0);
    }
}

/// The low bit of each of 8 bytes.
const LOW: u64 = 0x0101_0101_0101_0101;

/// Bit `i` of the result is the low bit of byte `i` of `v` (the other bits of `v` 0).
#[inline]
fn pack(v: u64) -> u32 {
    (v.wrapping_mul(0x0102_0408_1020_4080) >> 56) as u32
}

/// Byte `i` of the result is bit `i` of `byte` (< 256).
#[inline]
fn spread(byte: u32) -> u64 {
    let bits = (u64::from(byte) * LOW) & 0x8040_2010_0804_0201;
    ((bits + 0x7F7F_7F7F_7F7F_7F7F) >> 7) & LOW
}

/// The bytes of `chunk` (at most 8) as a little-endian word, zeros past its end.
fn load8(chunk: &[u8]) -> u64 {
    let mut bytes = [0u8; 8];
    for (b, v) in bytes.iter_mut().zip(chunk) {
        *b = *v;
    }
    u64::from_le_bytes(bytes)
}

/// Bit `x` of the result is bit 0 of `row[x]`, `x` < [`MAX_WIDTH`].
fn gather(row: &[u8]) -> Bits {
    let mut out = EMPTY;
    let mut chunks = row.chunks_exact(32);
    for (o, chunk) in out.iter_mut().zip(&mut chunks) {
        let mut word = 0;
        for (j, b) in chunk.chunks_exact(8).enumerate() {
            word |= pack(u64::from_le_bytes(b.try_into().unwrap_or_default()) & LOW) << (8 * j);
        }
        *o = word;
    }
    let rest = chunks.remainder();
    if let Some(o) = out.get_mut(row.len() / 32) {
        for (j, b) in rest.chunks(8).enumerate() {
            *o |= pack(load8(b) & LOW) << (8 * j);
        }
    }
    out
}

/// The bits of word `k` of a bit row within columns `lo..=hi`.
#[inline]
fn range_word(k: usize, lo: usize, hi: usize) -> u32 {
    let (a, b) = (32 * k, 32 * k + 31);
    if hi < a || lo > b {
        return 0;
    }
    let low = if lo > a { u32::MAX << (lo - a) } else { u32::MAX };
    let high = if hi < b { u32::MAX >> (b - hi) } else { u32::MAX };
    low & high
}

/// Whether column `x` of `bits` is set.
#[inline]
fn bit(bits: &Bits, x: usize) -> bool {
    bits.get(x / 32).is_some_and(|&v| v >> (x % 32) & 1 != 0)
}

/// The run of set bits of `free` around column `x` (which is set): its first and last column.
fn run_around(free: &Bits, x: usize) -> (usize, usize) {
    let (i, b) = (x / 32, x % 32);
    let word = |k: usize| free.get(k).copied().unwrap_or(0);
    let mut k = i;
    let mut z = !word(k) & (u32::MAX << b);
    let right = loop {
        if z != 0 {
            break (32 * k + z.trailing_zeros() as usize).saturating_sub(1);
        }
        k += 1;
        if k >= WORDS {
            break MAX_WIDTH - 1;
        }
        z = !word(k);
    };
    let mut k = i;
    let mut z = !word(k) & ((1u32 << b) - 1);
    let left = loop {
        if z != 0 {
            break 32 * k + 32 - z.leading_zeros() as usize;
        }
        if k == 0 {
            break 0;
        }
        k -= 1;
        z = !word(k);
    };
    (left, right)
}

/// Marks the 8-connected component of the mask's pixel at box column `x` of box row `q` in the
/// fields (a scanline fill over bit rows, setting up the rows it reaches); returns the box rows
/// that hold it.
fn mark(plane: &mut Plane<'_>, x: usize, q: usize) -> Range<usize> {
    mark_with::<FILL_STACK>(plane, x, q)
}

/// [`mark`] with a stack of `STACK` spans: when it overflows, raster scans push the free pixels
/// next to the component until there are none. Not inlined: its stack need not stay allocated
/// while the centroid is measured.
#[inline(never)]
fn mark_with<const STACK: usize>(plane: &mut Plane<'_>, x: usize, q: usize) -> Range<usize> {
    // (column, row) as `column | row << 8` (the box is at most 256 wide and 2^24 high).
    let mut stack = [0u32; STACK];
    let mut top = 0usize;
    let mut rows = q..q;
    plane.init(q);
    if let (Some(slot), Ok(x), Ok(q)) = (stack.get_mut(0), u32::try_from(x), u32::try_from(q)) {
        *slot = x | q << 8;
        top = 1;
    }
    let mut pending = spans(plane, &mut stack, &mut top, &mut rows);
    while pending {
        // Spans were dropped: push the free pixels next to the component (as many as fit).
        let mut dropped = false;
        for q in plane.lo..plane.hi {
            let (above, below) = (plane.load(q.wrapping_sub(1), COMP_FIELD), plane.load(q + 1, COMP_FIELD));
            let (m, c) = (plane.load(q, MASK_FIELD), plane.load(q, COMP_FIELD));
            let near = dilate::<1>(&or(&or(&above, &below), &c));
            for (k, ((&m, &c), &v)) in m.iter().zip(&c).zip(&near).enumerate() {
                let mut cand = m & !c & v;
                while cand != 0 {
                    let col = 32 * k as u32 + cand.trailing_zeros();
                    cand &= cand - 1;
                    match stack.get_mut(top) {
                        Some(slot) => {
                            *slot = col | (q as u32) << 8;
                            top += 1;
                        }
                        None => dropped = true,
                    }
                }
            }
        }
        if top == 0 {
            break;
        }
        pending = spans(plane, &mut stack, &mut top, &mut rows) || dropped;
    }
    rows
}

/// The scanline fill's loop: pops spans until the stack is empty; `rows` grows to the rows
/// marked. Returns whether a span was dropped because the stack was full.
fn spans(plane: &mut Plane<'_>, stack: &mut [u32], top: &mut usize, rows: &mut Range<usize>) -> bool {
    let mut overflow = false;
    let (width, height) = (plane.width, plane.height);
    while *top > 0 {
        *top -= 1;
        let Some(&entry) = stack.get(*top) else { break };
        let (x, q) = ((entry & 0xFF) as usize, (entry >> 8) as usize);
        let m = plane.load(q, MASK_FIELD);
        let mut c = plane.load(q, COMP_FIELD);
        let mut free = EMPTY;
        for ((f, &m), &c) in free.iter_mut().zip(&m).zip(&c) {
            *f = m & !c;
        }
        if !bit(&free, x) {
            continue;
        }
        let (xl, xr) = run_around(&free, x);
        for (k, c) in c.iter_mut().enumerate().take(xr / 32 + 1).skip(xl / 32) {
            *c |= range_word(k, xl, xr);
        }
        plane.store(q, COMP_FIELD, &c);
        *rows = if rows.start == rows.end {
            q..q + 1
        } else {
            rows.start.min(q)..rows.end.max(q + 1)
        };
        let (lo, hi) = (xl.saturating_sub(1), (xr + 1).min(width - 1));
        for nq in [q.wrapping_sub(1), q + 1] {
            if nq >= height {
                continue;
            }
            plane.init(nq);
            let (m, c) = (plane.load(nq, MASK_FIELD), plane.load(nq, COMP_FIELD));
            let mut carry = 0u32;
            for k in lo / 32..=hi / 32 {
                let f = m.get(k).copied().unwrap_or(0) & !c.get(k).copied().unwrap_or(0) & range_word(k, lo, hi);
                let mut starts = f & !((f << 1) | carry);
                carry = f >> 31;
                while starts != 0 {
                    let col = 32 * k as u32 + starts.trailing_zeros();
                    starts &= starts - 1;
                    match stack.get_mut(*top) {
                        Some(slot) => {
                            *slot = col | (nq as u32) << 8;
                            *top += 1;
                        }
                        None => overflow = true,
                    }
                }
            }
        }
    }
    overflow
}

/// Bit `c` of the result is bit `c + S` of `x` (0 past the row's end); `S < 32`.
#[inline]
fn shift_down<const S: u32>(x: &Bits) -> Bits {
    let mut out = EMPTY;
    for (i, o) in out.iter_mut().enumerate() {
        let cur = x.get(i).copied().unwrap_or(0);
        let next = x.get(i + 1).copied().unwrap_or(0);
        *o = (cur >> S) | next.checked_shl(32 - S).unwrap_or(0);
    }
    out
}

/// Bit `c` of the result is bit `c − S` of `x` (0 before the row's start); `S < 32`.
#[inline]
fn shift_up<const S: u32>(x: &Bits) -> Bits {
    let mut out = EMPTY;
    for (i, o) in out.iter_mut().enumerate() {
        let cur = x.get(i).copied().unwrap_or(0);
        let prev = i.checked_sub(1).and_then(|p| x.get(p)).copied().unwrap_or(0);
        *o = (cur << S) | prev.checked_shr(32 - S).unwrap_or(0);
    }
    out
}

#[inline]
fn and(a: &Bits, b: &Bits) -> Bits {
    let mut out = *a;
    for (o, &b) in out.iter_mut().zip(b) {
        *o &= b;
    }
    out
}

#[inline]
fn or(a: &Bits, b: &Bits) -> Bits {
    let mut out = *a;
    for (o, &b) in out.iter_mut().zip(b) {
        *o |= b;
    }
    out
}

/// Horizontal erosion by the `(2K+1)`-segment (columns outside the row count as 0), `K` 2, 3 or 5.
#[inline]
fn erode<const K: u32>(x: &Bits) -> Bits {
    // AND over windows from the column on: 2 columns, 4, then 5 (K = 2), 7 (K = 3) or 8 and 11
    // (K = 5); then centred.
    let a2 = and(x, &shift_down::<1>(x));
    let a4 = and(&a2, &shift_down::<2>(&a2));
    match K {
        2 => shift_up::<2>(&and(&a4, &shift_down::<4>(x))),
        3 => shift_up::<3>(&and(&a4, &shift_down::<3>(&a4))),
        _ => {
            let a8 = and(&a4, &shift_down::<4>(&a4));
            shift_up::<5>(&and(&a8, &shift_down::<7>(&a4)))
        }
    }
}

/// Horizontal dilation by the `(2K+1)`-segment, `K` 1 or 2 (not clipped to the box).
#[inline]
fn dilate<const K: u32>(x: &Bits) -> Bits {
    let one = or(&or(x, &shift_down::<1>(x)), &shift_up::<1>(x));
    if K == 1 {
        one
    } else {
        or(&or(&one, &shift_down::<2>(x)), &shift_up::<2>(x))
    }
}

/// Calls `f` with the column of every set bit of `bits`, in increasing order.
#[inline]
fn for_each_bit(bits: &Bits, mut f: impl FnMut(usize)) {
    for (i, &word) in bits.iter().enumerate() {
        let mut word = word;
        while word != 0 {
            let col = 32 * i + word.trailing_zeros() as usize;
            word &= word - 1;
            f(col);
        }
    }
}

/// First pass: the ring (component eroded three times minus eroded five times) into the ring
/// field of its rows, and the median `D` over it (from a signed histogram; 0 without ring
/// pixels). Not inlined: its histogram and [`weigh`]'s column sums need not share a stack frame.
#[inline(never)]
fn ring_pass<S: Source>(src: &S, plane: &mut Plane<'_>, comp: Range<usize>) -> f32 {
    let mut hist = [0u16; 511];
    let mut ring_count = 0usize;
    let load = |plane: &Plane<'_>, q: usize| {
        if comp.contains(&q) {
            plane.load(q, COMP_FIELD)
        } else {
            EMPTY
        }
    };
    // Ring rows have the component 3 rows above and below.
    let ring_rows = comp.start + 3..comp.end.saturating_sub(3);
    // The component's rows j − 5 ..= j + 5 around row j: row q in slot (q + 5) mod 11 (the slots
    // of rows above the box stay empty).
    let mut rows = [EMPTY; 11];
    for q in ring_rows.start.saturating_sub(5)..ring_rows.start + 5 {
        if let Some(slot) = rows.get_mut((q + 5) % 11) {
            *slot = load(plane, q);
        }
    }
    for j in ring_rows {
        if let Some(slot) = rows.get_mut((j + 10) % 11) {
            *slot = load(plane, j + 5);
        }
        let row = |t: usize| rows.get((j + t) % 11).unwrap_or(&EMPTY);
        // Erosion by the (2k+1)-square: AND of the rows within k, then of the columns within k.
        let mut v3 = *row(5);
        for t in [2, 3, 4, 6, 7, 8] {
            v3 = and(&v3, row(t));
        }
        if v3 == EMPTY {
            continue;
        }
        let mut v5 = v3;
        for t in [0, 1, 9, 10] {
            v5 = and(&v5, row(t));
        }
        let (e3, e5) = (erode::<3>(&v3), erode::<5>(&v5));
        let mut ring = EMPTY;
        for ((o, a), b) in ring.iter_mut().zip(e3).zip(e5) {
            *o = a & !b;
        }
        if ring == EMPTY {
            continue;
        }
        plane.store(j, RING_FIELD, &ring);
        let image_row = src.row(plane.r.y0 + j);
        for_each_bit(&ring, |c| {
            if let Some(hb) = hist.get_mut(src.bin(image_row, c)) {
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

/// Second pass: the sums (Σw, Σw·x, Σw·y, box coordinates) of the weights, in raster order. Row
/// `p` of the fields is read 4 rows ahead of the weights, so the ring's column sums cover rows
/// `y − 4 ..= y + 4` when row `y` is weighed. Not inlined (see [`ring_pass`]).
#[inline(never)]
fn weigh<S: Source>(src: &S, plane: &Plane<'_>, comp: Range<usize>, contrast: f32) -> [f32; 3] {
    let height = plane.height;
    let mut sums = [0.0f32; 3];
    // The component's rows p − 7 ..= p (row q in slot q mod 8) and the ring's rows p − 9 ..= p
    // (slot q mod 10); the slots of rows above the component stay empty.
    let mut comp_rows = [EMPTY; 8];
    let mut rings = [EMPTY; 10];
    // The ring's values summed per column over 9 rows: column c of the box at c + 4.
    let mut columns = [S::Col::default(); MAX_WIDTH + 8];
    let weights = Weights {
        contrast,
        sign: contrast.signum(),
    };
    // Rows with inside or band pixels: the component's, and 2 more above and below.
    for p in comp.start..(comp.end + 2).min(height) + 4 {
        let (c, ring) = if comp.contains(&p) {
            (plane.load(p, COMP_FIELD), plane.load(p, RING_FIELD))
        } else {
            (EMPTY, EMPTY)
        };
        if let Some(slot) = comp_rows.get_mut(p % 8) {
            *slot = c;
        }
        // The column sums move on to rows p − 8 ..= p.
        if let Some(q) = p.checked_sub(9) {
            let leaving = rings.get(q % 10).unwrap_or(&EMPTY);
            if *leaving != EMPTY {
                let image_row = src.row(plane.r.y0 + q);
                for_each_bit(leaving, |col| {
                    if let Some(s) = columns.get_mut(col + 4) {
                        *s = *s - src.col(image_row, col);
                    }
                });
            }
        }
        if ring != EMPTY {
            let image_row = src.row(plane.r.y0 + p);
            for_each_bit(&ring, |col| {
                if let Some(s) = columns.get_mut(col + 4) {
                    *s = *s + src.col(image_row, col);
                }
            });
        }
        if let Some(slot) = rings.get_mut(p % 10) {
            *slot = ring;
        }
        let Some(y) = p.checked_sub(4) else {
            continue;
        };
        // Inside = eroded twice, band = dilated twice minus inside: rows y − 2 ..= y + 2.
        let mut v2 = *comp_rows.get((y + 6) % 8).unwrap_or(&EMPTY);
        let mut grown = v2;
        for k in 7..11 {
            let row = comp_rows.get((y + k) % 8).unwrap_or(&EMPTY);
            v2 = and(&v2, row);
            grown = or(&grown, row);
        }
        if grown == EMPTY {
            continue;
        }
        let inside = erode::<2>(&v2);
        let mut band = dilate::<2>(&grown);
        for (i, (b, &s)) in band.iter_mut().zip(&inside).enumerate() {
            let valid = match i.cmp(&(plane.n - 1)) {
                core::cmp::Ordering::Less => u32::MAX,
                core::cmp::Ordering::Equal => plane.last,
                core::cmp::Ordering::Greater => 0,
            };
            *b &= !s & valid;
        }
        let image_row = src.row(plane.r.y0 + y);
        sums = weights.row(src, image_row, y, &inside, &band, &columns, sums);
    }
    sums
}

/// What the weights depend on besides `D` and the ring's column sums.
struct Weights {
    contrast: f32,
    /// The contrast's sign, ±1.
    sign: f32,
}

impl Weights {
    /// `sums` plus the weights of box row `y`'s inside and band pixels, in increasing column.
    /// Inside pixels come in runs between band pixels (next to an inside pixel is an inside or a
    /// band pixel); a run whose pixels all pass the hole test is added at once.
    #[inline(never)]
    fn row<S: Source>(
        &self,
        src: &S,
        image_row: S::Row,
        y: usize,
        inside: &Bits,
        band: &Bits,
        columns: &[S::Col; MAX_WIDTH + 8],
        sums: [f32; 3],
    ) -> [f32; 3] {
        let [mut sw, mut sx, mut sy] = sums;
        let yf = y as f32;
        let (contrast, sign) = (self.contrast, self.sign);
        // The window sum of the last band pixel's column, and that column plus 1 (0: none).
        let mut window = S::Col::default();
        let mut next = 0usize;
        // The column after the last band pixel.
        let mut after = 0usize;
        for (i, &word) in band.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                let c = 32 * i + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if c > after && bit(inside, after) {
                    [sw, sx, sy] = self.inside_run(src, image_row, after..c, y, [sw, sx, sy]);
                }
                after = c + 1;
                // The ring's values within 4 columns (padded: columns c .. c + 9).
                if next != 0 && c == next {
                    if let (Some(&enter), Some(&leave)) = (columns.get(c + 8), columns.get(c - 1)) {
                        window = window + enter - leave;
                    }
                } else {
                    window = columns
                        .get(c..c + 9)
                        .unwrap_or(&[])
                        .iter()
                        .fold(S::Col::default(), |a, &s| a + s);
                }
                next = c + 1;
                let d = src.d(image_row, c);
                // A D of the other sign than the contrast weighs 0.
                if !(d * sign > 0.0) {
                    continue;
                }
                // The local contrast: mean D of the ring pixels within 4 px (shading across the
                // part changes it from one side to the other), else the part's median.
                let (sum, count) = S::split(window);
                let mut local = contrast;
                if count > 0 {
                    // At least 1 in size, of the contrast's sign (`sign` is ±1: exact).
                    let mean = sum / count as f32;
                    if mean * sign >= 1.0 {
                        local = mean;
                    }
                }
                let weight = (d / local).clamp(0.0, 1.0);
                if weight > 0.0 {
                    sw += weight;
                    sx += weight * c as f32;
                    sy += weight * yf;
                }
            }
        }
        [sw, sx, sy]
    }

    /// `sums` plus the weights of the inside pixels `cols` of box row `y`: 1, unless the pixel
    /// looks like the platform (a small hole or a narrow gap that the mask's closing filled;
    /// printed labels keep at least a third of the part's contrast, holes keep none).
    #[inline]
    fn inside_run<S: Source>(
        &self,
        src: &S,
        image_row: S::Row,
        cols: Range<usize>,
        y: usize,
        sums: [f32; 3],
    ) -> [f32; 3] {
        let (contrast, sign) = (self.contrast, self.sign);
        // Division by the contrast is monotonic: when the least `D · sign` passes, all do.
        let least = src.least(image_row, cols.clone(), sign);
        if (least * sign) / contrast >= HOLE_RATIO {
            return add_ones(sums, cols, y);
        }
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
                sums = [sw + weight, sx + weight * c as f32, sy + weight * y as f32];
            }
        }
        add_ones(sums, ones..cols.end, y)
    }
}

/// `sums` (Σw, Σw·x, Σw·y) plus weight 1 for each pixel of columns `cols` of box row `y`: the
/// same bits as adding them one by one in increasing column.
#[inline]
fn add_ones(sums: [f32; 3], cols: Range<usize>, y: usize) -> [f32; 3] {
    let Ok(count) = u32::try_from(cols.len()) else {
        return sums;
    };
    if count == 0 {
        return sums;
    }
    let first = u32::try_from(cols.start).unwrap_or(u32::MAX);
    let y = u32::try_from(y).unwrap_or(u32::MAX);
    let [sw, sx, sy] = sums;
    [
        add_sequence(sw, 1, 0, count),
        add_sequence(sx, first, 1, count),
        add_sequence(sy, y, 0, count),
    ]
}

/// `s` plus the `count` integers `first + step·k` (`k = 0, 1, …`) one by one in `f32`: at once as
/// far as none of the additions rounds ([`exact_sum`]), the one that does on its own.
fn add_sequence(s: f32, first: u32, step: u32, count: u32) -> f32 {
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
        // own): a bisection, the test is monotonic in the number of terms.
        let (mut lo, mut hi) = (0u32, count);
        if at_once(s, 0).is_none() {
            hi = 1;
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
const EXACT: f32 = 16_777_216.0;

/// `v` as an `f32` when that is exact (at most 2^24).
#[inline]
fn exact_integer(v: u64) -> Option<f32> {
    (v <= 1 << 24).then_some(v as f32)
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

/// Where `D` comes from: the frame's and background's image rows ([`Exact`], `α = 1`: integers)
/// or [`Difference::at`] ([`Approx`]). Columns are the box's.
trait Source {
    /// What a row's values are read from.
    type Row: Copy;
    /// A sum of ring values: their `D` and how many.
    type Col: Copy + Default + Add<Output = Self::Col> + Sub<Output = Self::Col>;
    /// Image row `y`.
    fn row(&self, y: usize) -> Self::Row;
    /// `D` at column `c`: the value of [`Difference::at`].
    fn d(&self, row: Self::Row, c: usize) -> f32;
    /// The signed histogram's bin of `D` at column `c`, `D + 255` clamped to 0..=510.
    fn bin(&self, row: Self::Row, c: usize) -> usize;
    /// The ring value at column `c`.
    fn col(&self, row: Self::Row, c: usize) -> Self::Col;
    /// The sum of `D` and the count of a sum of ring values.
    fn split(col: Self::Col) -> (f32, u32);
    /// The least `D · sign` over the columns `cols` (not empty), or a value that is not above 0
    /// when it is not above 0.
    fn least(&self, row: Self::Row, cols: Range<usize>, sign: f32) -> f32;
}

/// `D` from the frame's and background's rows ([`Difference::rows`]): integers in −255..=255.
struct Exact<'d, 'a, B> {
    diff: &'d Difference<'a, B>,
    x0: usize,
    x1: usize,
}

impl<'a, B: AsRef<[u8]>> Source for Exact<'_, 'a, B> {
    /// The box's columns of the frame's and the background's row.
    type Row = (&'a [u8], &'a [u8]);
    /// `128·ΣD + count` (counts are at most 81, |ΣD| at most 81·255).
    type Col = i32;

    #[inline]
    fn row(&self, y: usize) -> Self::Row {
        self.diff
            .rows(y)
            .and_then(|(f, b)| Some((f.get(self.x0..self.x1)?, b.get(self.x0..self.x1)?)))
            .unwrap_or((&[], &[]))
    }

    #[inline]
    fn d(&self, (f, b): Self::Row, c: usize) -> f32 {
        match (f.get(c), b.get(c)) {
            // Both exact integers, so the difference is exact: the same `f32` as `at`'s.
            (Some(&f), Some(&b)) => (i32::from(f) - i32::from(b)) as f32,
            _ => 0.0,
        }
    }

    #[inline]
    fn bin(&self, (f, b): Self::Row, c: usize) -> usize {
        match (f.get(c), b.get(c)) {
            (Some(&f), Some(&b)) => (i32::from(f) - i32::from(b) + 255) as usize,
            _ => 255,
        }
    }

    #[inline]
    fn col(&self, (f, b): Self::Row, c: usize) -> i32 {
        match (f.get(c), b.get(c)) {
            (Some(&f), Some(&b)) => 128 * (i32::from(f) - i32::from(b)) + 1,
            _ => 0,
        }
    }

    #[inline]
    fn split(col: i32) -> (f32, u32) {
        ((col >> 7) as f32, (col & 127) as u32)
    }

    /// The least of `D · sign` where it is positive, else 0: the minimum of the bytes' saturating
    /// difference (which the compiler vectorises).
    #[inline]
    fn least(&self, (f, b): Self::Row, cols: Range<usize>, sign: f32) -> f32 {
        let (Some(f), Some(b)) = (f.get(cols.clone()), b.get(cols)) else {
            return 0.0;
        };
        let (hi, lo) = if sign > 0.0 { (f, b) } else { (b, f) };
        hi.iter()
            .zip(lo)
            .fold(u8::MAX, |m, (&h, &l)| m.min(h.saturating_sub(l))) as f32
    }
}

/// `D` through [`Difference::at`] (`α < 1`, or a background plane that ends within the box).
struct Approx<'d, 'a, B> {
    diff: &'d Difference<'a, B>,
    x0: usize,
}

/// A sum of `f32` ring values and their count.
#[derive(Clone, Copy, Default)]
struct FloatSum {
    sum: f32,
    count: u32,
}

impl Add for FloatSum {
    type Output = Self;
    #[inline]
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
    #[inline]
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

    #[inline]
    fn row(&self, y: usize) -> usize {
        y
    }

    #[inline]
    fn d(&self, y: usize, c: usize) -> f32 {
        self.diff.at((self.x0 + c) as isize, y as isize)
    }

    #[inline]
    fn bin(&self, y: usize, c: usize) -> usize {
        (self.d(y, c) as i32 + 255).clamp(0, 510) as usize
    }

    #[inline]
    fn col(&self, y: usize, c: usize) -> FloatSum {
        FloatSum {
            sum: self.d(y, c),
            count: 1,
        }
    }

    #[inline]
    fn split(col: FloatSum) -> (f32, u32) {
        (col.sum, col.count)
    }

    fn least(&self, y: usize, cols: Range<usize>, sign: f32) -> f32 {
        // `sign` is ±1: the products are exact. (A select rather than `f32::min`: D is never
        // NaN.)
        cols.map(|c| self.d(y, c) * sign)
            .fold(f32::INFINITY, |m, v| if v < m { v } else { m })
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

    /// A random bit row of `width` columns (the bits past it 0).
    fn random_bits(rng: &mut Rng, width: usize) -> Bits {
        let mut bits = EMPTY;
        let density = rng.unit();
        for x in 0..width {
            if rng.chance(density) {
                bits[x / 32] |= 1 << (x % 32);
            }
        }
        bits
    }

    /// One row of inside and band pixels as a part's rows have them: runs of inside pixels with
    /// band pixels on both sides, band runs alone, outside pixels between.
    fn random_row_regions(rng: &mut Rng, width: usize) -> (Bits, Bits) {
        let (mut inside, mut band) = (EMPTY, EMPTY);
        let mut x = rng.below(6);
        let set = |bits: &mut Bits, from: usize, len: usize| {
            for c in from..(from + len).min(width) {
                bits[c / 32] |= 1 << (c % 32);
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
        // `Weights::row` (runs of weight 1 at once, the window sum sliding along the band) against
        // the per-pixel definition with the pixels added one by one in increasing column: the
        // same bits for random rows, integer D (α = 1), column sums and running sums.
        let mut rng = Rng(0x5EED_0001);
        let (mut runs, mut pixels) = (0usize, 0usize);
        for case in 0..6000 {
            let width = MIN_WIDTH + rng.below(MAX_WIDTH - MIN_WIDTH + 1);
            let contrast = if rng.chance(0.5) { 1.0 } else { -1.0 } * (1 + rng.below(200)) as f32;
            let base = rng.below(256) as f32;
            let frame_row: Vec<u8> = (0..width)
                .map(|_| {
                    // Mostly the part's contrast, some holes and other-signed values.
                    let d = match rng.below(8) {
                        0 => rng.range(-255.0, 255.0),
                        1 => contrast * rng.range(0.0, 0.3),
                        _ => contrast * rng.range(0.5, 1.5),
                    };
                    (base + d).round().clamp(0.0, 255.0) as u8
                })
                .collect();
            let background = vec![base as u8; width];
            let frame = Frame::new_checked(&frame_row[..], width, 1).unwrap();
            let diff = Difference::new(&frame, &background, Alpha::ONE);
            let src = Exact {
                diff: &diff,
                x0: 0,
                x1: width,
            };
            let image_row = src.row(0);
            let mut columns = [0i32; MAX_WIDTH + 8];
            for c in columns.iter_mut().skip(4).take(width) {
                let count = rng.below(10) as i32;
                let sum: i32 = (0..count)
                    .map(|_| {
                        if rng.chance(0.8) {
                            (contrast * rng.range(0.5, 1.5)).round().clamp(-255.0, 255.0) as i32
                        } else {
                            rng.below(511) as i32 - 255
                        }
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
            let weights = Weights {
                contrast,
                sign: contrast.signum(),
            };
            let got = weights.row(&src, image_row, y, &inside, &band, &columns, sums);
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
                    let (sum, count) = ((window >> 7) as f32, window & 127);
                    let local = (count > 0)
                        .then(|| sum / count as f32)
                        .filter(|m| m.abs() >= 1.0 && m.signum() == contrast.signum());
                    (d / local.unwrap_or(contrast)).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                if weight > 0.0 {
                    sw += weight;
                    sx += weight * c as f32;
                    sy += weight * y as f32;
                }
            }
            assert_eq!(got.map(f32::to_bits), [sw, sx, sy].map(f32::to_bits), "case {case}");
            runs += inside.iter().map(|w| (w & !(w << 1)).count_ones() as usize).sum::<usize>();
            pixels += band.iter().map(|w| w.count_ones() as usize).sum::<usize>();
        }
        assert!(runs > 5000 && pixels > 50_000, "{runs} {pixels}");
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
            assert_eq!(got.to_bits(), want.to_bits(), "case {case}: {s} + {first} + {step}·k, {count} terms");
            let total = u64::from(first) * u64::from(count) + u64::from(step) * u64::from(count * (count - 1) / 2);
            split += usize::from(exact_integer(total).and_then(|t| exact_sum(s, t)).is_none());
        }
        // Many sums had to be split where a term rounds.
        assert!(split > 5000, "{split}");
    }

    #[test]
    fn sources_give_the_values_of_at() {
        // D from the frame's and background's rows (α = 1) and through `at` (α < 1, or a short
        // background plane): values, bins, ring values and the hole test's least value, against
        // `Difference::at` and the pixel-by-pixel test.
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
                assert_eq!(diff.rows(h - 1).is_some(), alpha >= 1.0 && bg_len == w * h, "case {case}");
                let x0 = rng.below(w);
                let x1 = x0 + 1 + rng.below(w - x0);
                let exact = Exact { diff: &diff, x0, x1 };
                let approx = Approx { diff: &diff, x0 };
                for y in 0..h {
                    let rows = diff.rows(y).is_some();
                    let (er, ar) = (exact.row(y), approx.row(y));
                    for c in 0..x1 - x0 {
                        let want = diff.at((x0 + c) as isize, y as isize);
                        let bin = (want as i32 + 255).clamp(0, 510) as usize;
                        assert_eq!(approx.d(ar, c).to_bits(), want.to_bits());
                        assert_eq!(approx.bin(ar, c), bin);
                        let (s, n) = <Approx<'_, '_, &[u8]> as Source>::split(approx.col(ar, c));
                        assert_eq!((s.to_bits(), n), (want.to_bits(), 1));
                        if rows {
                            assert_eq!(exact.d(er, c).to_bits(), want.to_bits(), "case {case} ({c}, {y})");
                            assert_eq!(exact.bin(er, c), bin);
                            let (s, n) = <Exact<'_, '_, &[u8]> as Source>::split(exact.col(er, c));
                            assert_eq!((s.to_bits(), n), (want.to_bits(), 1));
                        }
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

    #[test]
    fn bit_row_morphology_is_the_per_bit_definition() {
        // Erosion and dilation by segments, and the shifts they are made of, against the
        // definition column by column (outside the row is 0).
        let mut rng = Rng(2024);
        for case in 0..3000 {
            let width = 1 + rng.below(MAX_WIDTH);
            let x = random_bits(&mut rng, width);
            let at = |c: isize| c >= 0 && bit(&x, c as usize);
            for c in 0..MAX_WIDTH {
                let ci = c as isize;
                let window = |k: isize, all: bool| {
                    let mut v = (-k..=k).map(|d| at(ci + d));
                    if all {
                        v.all(|b| b)
                    } else {
                        v.any(|b| b)
                    }
                };
                assert_eq!(bit(&erode::<2>(&x), c), window(2, true), "case {case} erode 2 at {c}");
                assert_eq!(bit(&erode::<3>(&x), c), window(3, true), "case {case} erode 3 at {c}");
                assert_eq!(bit(&erode::<5>(&x), c), window(5, true), "case {case} erode 5 at {c}");
                assert_eq!(bit(&dilate::<1>(&x), c), window(1, false), "case {case} dilate 1 at {c}");
                assert_eq!(bit(&dilate::<2>(&x), c), window(2, false), "case {case} dilate 2 at {c}");
                assert_eq!(bit(&shift_down::<7>(&x), c), at(ci + 7));
                assert_eq!(bit(&shift_up::<5>(&x), c), at(ci - 5));
            }
            // Runs around a set bit, and the words of a column range.
            let set: Vec<usize> = (0..width).filter(|&c| bit(&x, c)).collect();
            if let Some(&c) = set.get(rng.below(set.len().max(1))) {
                let (l, r) = run_around(&x, c);
                assert!((l..=r).all(|k| bit(&x, k)), "case {case}");
                assert!(l == 0 || !bit(&x, l - 1));
                assert!(!bit(&x, r + 1));
            }
            let lo = rng.below(MAX_WIDTH);
            let hi = lo + rng.below(MAX_WIDTH - lo);
            for c in 0..MAX_WIDTH {
                assert_eq!(range_word(c / 32, lo, hi) >> (c % 32) & 1 != 0, (lo..=hi).contains(&c));
            }
        }
    }

    #[test]
    fn plane_fields_hold_bit_rows_and_give_the_mask_back() {
        // Rows set up from the mask's bytes, next to each other only; their fields loaded and
        // stored; the plane as it was after `restore`.
        let mut rng = Rng(99);
        for case in 0..300 {
            let (w, h) = (MIN_WIDTH + rng.below(300), 1 + rng.below(20));
            let mask: Vec<u8> = (0..w * h).map(|_| rng.chance(0.5) as u8).collect();
            let x0 = rng.below(w - MIN_WIDTH + 1);
            let x1 = (x0 + MIN_WIDTH + rng.below(MAX_WIDTH - MIN_WIDTH + 1)).min(w);
            let y0 = rng.below(h);
            let r = Rect {
                x0,
                y0,
                x1,
                y1: y0 + 1 + rng.below(h - y0),
            };
            let mut plane_bytes = mask.clone();
            let mut plane = Plane::new(&mut plane_bytes, w, r);
            let first = rng.below(plane.height);
            plane.init(first);
            // Not next to the rows set up: refused.
            plane.init(first + 2);
            assert_eq!((plane.lo, plane.hi), (first, first + 1));
            for q in (0..first).rev().chain(first + 1..plane.height) {
                plane.init(q);
            }
            assert_eq!((plane.lo, plane.hi), (0, plane.height));
            let mut rings = Vec::new();
            for q in 0..plane.height {
                let m = plane.load(q, MASK_FIELD);
                for c in 0..MAX_WIDTH {
                    let want = c < x1 - x0 && mask[(y0 + q) * w + x0 + c] == 1;
                    assert_eq!(bit(&m, c), want, "case {case} row {q} column {c}");
                }
                assert_eq!(plane.load(q, COMP_FIELD), EMPTY);
                assert_eq!(plane.load(q, RING_FIELD), EMPTY);
                let (c, g) = (random_bits(&mut rng, x1 - x0), random_bits(&mut rng, x1 - x0));
                plane.store(q, COMP_FIELD, &c);
                plane.store(q, RING_FIELD, &g);
                rings.push((c, g, m));
            }
            for (q, &(c, g, m)) in rings.iter().enumerate() {
                assert_eq!(plane.load(q, COMP_FIELD), c);
                assert_eq!(plane.load(q, RING_FIELD), g);
                assert_eq!(plane.load(q, MASK_FIELD), m);
            }
            assert_eq!(plane.load(plane.height, MASK_FIELD), EMPTY);
            plane.restore();
            assert_eq!(plane.load(0, MASK_FIELD), EMPTY);
            assert!(plane_bytes == mask, "case {case}: plane not restored");
        }
        for byte in 0..256u32 {
            let v = spread(byte);
            assert_eq!(v & !LOW, 0);
            assert_eq!(pack(v), byte);
        }
    }

    #[test]
    fn bit_row_fill_finds_the_component() {
        // The scanline fill over bit rows, with stacks that overflow and the default: exactly the
        // 8-connected component within the box, the rows that hold it, and the mask back after
        // `restore`.
        let mut rng = Rng(12345);
        let mut overflowed = 0usize;
        for case in 0..300 {
            let (w, h) = (MIN_WIDTH + rng.below(280), 1 + rng.below(60));
            let density = rng.range(0.3, 0.8);
            let mask: Vec<u8> = (0..w * h).map(|_| rng.chance(density) as u8).collect();
            let x0 = rng.below(w - MIN_WIDTH + 1);
            let x1 = (x0 + MIN_WIDTH + rng.below(MAX_WIDTH - MIN_WIDTH + 1)).min(w);
            let y0 = rng.below(h);
            let r = Rect {
                x0,
                y0,
                x1,
                y1: y0 + 1 + rng.below(h - y0),
            };
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
            let top = want.iter().map(|p| p.1).min().unwrap();
            let bottom = want.iter().map(|p| p.1).max().unwrap() + 1;
            for stack in [1, 2, 8, FILL_STACK] {
                let mut bytes = mask.clone();
                let mut plane = Plane::new(&mut bytes, w, r);
                let (x, q) = (seed.0 - r.x0, seed.1 - r.y0);
                let rows = match stack {
                    1 => mark_with::<1>(&mut plane, x, q),
                    2 => mark_with::<2>(&mut plane, x, q),
                    8 => mark_with::<8>(&mut plane, x, q),
                    _ => mark(&mut plane, x, q),
                };
                assert_eq!(rows, top..bottom, "case {case} stack {stack}");
                assert!(plane.lo <= top.saturating_sub(1) && (bottom + 1).min(bh) <= plane.hi);
                let mut marked = 0;
                for q in 0..bh {
                    let c = plane.load(q, COMP_FIELD);
                    marked += c.iter().map(|v| v.count_ones() as usize).sum::<usize>();
                    for x in 0..bw {
                        assert_eq!(bit(&c, x), want.contains(&(x, q)), "case {case} stack {stack} ({x}, {q})");
                    }
                }
                assert_eq!(marked, want.len());
                plane.restore();
                assert!(bytes == mask, "case {case}: plane not restored");
            }
            overflowed += usize::from(want.len() > 40);
        }
        assert!(overflowed > 30, "{overflowed}");
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
