//! Border following: Suzuki & Abe (1985), 8-connectivity (paper section 3.3).
//!
//! Input: the label plane written by [`crate::pixels::mask::foreground_mask`] (0 background, 1
//! foreground), labelled in place as the algorithm goes: a traced border's pixels get its number
//! `NBD`, or `−NBD` where the pixel's right neighbour is background that the trace examined.
//! The plane is `u8`, so a label is `NBD` (2..=127) or `0x80 | NBD`; after 126 borders in one
//! frame the labels saturate: tracing goes on (nothing is dropped), [`TraceStats::labels_saturated`]
//! is set, and a later border whose parent the labels no longer tell gets it by containment
//! instead: the smallest border of the other kind kept before it that holds the point beside its
//! start (print or texture on the platform easily makes hundreds of borders, and a part's holes
//! must still be its own).
//!
//! Output: ordered border points in a [`ContourStore`] of fixed capacity, each border with its
//! type (outer or hole) and parent. Borders with fewer than `min_points` points or a polygon area
//! under `min_area` are dropped (and counted). A border longer than the free point storage is
//! traced again keeping every `stride`-th point, so it still describes the whole outline
//! ([`Contour::stride`] > 1), never a cut-off piece; only when the storage is nearly full is a
//! border skipped, and that is counted in [`TraceStats::skipped_capacity`].
//!
//! Pixels outside the image count as background, which is what `imageproc`'s `find_contours`
//! gives on the mask padded with a one-pixel zero frame (`docs/pipeline-spec.md` §4).
//!
//! [`trace_borders_in`] takes the mask's [`RowSpans`]
//! ([`crate::pixels::mask::foreground_mask_spans`]): rows without foreground are not read at all, the
//! others only inside their span. Labels are written only on foreground pixels, so the spans
//! also bound them: [`clear_labels`] turns the labelled plane back into the 0/1 mask inside
//! them only.
//!
//! Time: one raster scan (inside the spans) plus `O(border length)` per border (twice for a
//! subsampled one). The scan skips runs of background and of unlabelled interior pixels 16
//! bytes at a time; where it stops after a run of background it knows the left neighbour is
//! background. A trace step reads neighbours at fixed offsets in the plane away from the
//! image's edge, and starts its search past the neighbours the step before found background
//! (after a step along a row or column the first two, after a diagonal one the first, when the
//! search before passed them). Measured
//! figures: `docs/performance.md`.
//! Memory: `4·P` bytes of points and a small record per border in the store; 128 border records
//! on the stack while tracing.

use crate::error::{Error, Result};
use crate::pixels::mask::RowSpans;

/// A border pixel (pixel-centre coordinates).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Point {
    /// Column.
    pub x: u16,
    /// Row.
    pub y: u16,
}

/// Whether a border encloses a region (outer) or lies around a hole in one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BorderKind {
    /// Border between a region and the background around it.
    Outer,
    /// Border between a region and a hole inside it.
    Hole,
}

/// One kept border in a [`ContourStore`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contour {
    /// Outer border or hole border.
    pub kind: BorderKind,
    /// Index of the enclosing kept border in the store (a hole's parent is the outer border of
    /// its region), `None` at the top level or when unknown.
    pub parent: Option<u16>,
    /// First point in the store's point array.
    pub start: u32,
    /// Points stored.
    pub len: u32,
    /// Points of the full trace (equal to `len` unless subsampled).
    pub traced_len: u32,
    /// 1, or the subsampling step when the border did not fit.
    pub stride: u32,
    /// Twice the signed polygon area over the full trace (shoelace, exact in integers); positive
    /// when the points run counter-clockwise in image coordinates.
    pub area2: i64,
    /// Whether the border touches the image's edge.
    pub touches_edge: bool,
}

impl Contour {
    /// Polygon area of the full trace, px².
    pub fn area(&self) -> f32 {
        (self.area2.unsigned_abs() as f32) * 0.5
    }
}

/// What [`trace_borders`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TraceStats {
    /// Borders found (kept or not).
    pub found: usize,
    /// Borders kept in the store.
    pub kept: usize,
    /// Borders dropped as too small (`min_points`, `min_area`).
    pub dropped_small: usize,
    /// Borders kept subsampled because they did not fit.
    pub subsampled: usize,
    /// Borders skipped because the store was full.
    pub skipped_capacity: usize,
    /// Borders whose trace was abandoned by the iteration guard (never on a valid plane).
    pub aborted: usize,
    /// More than 126 borders: parents of later ones were found by containment.
    pub labels_saturated: bool,
}

/// Fixed-capacity storage for borders: `P` points and `C` border records.
///
/// `4·P + C·size_of::<Contour>()` bytes; see `vorl budget`.
#[derive(Debug, Clone)]
pub struct ContourStore<const P: usize, const C: usize> {
    points: [Point; P],
    contours: heapless::Vec<Contour, C>,
    used: usize,
}

impl<const P: usize, const C: usize> Default for ContourStore<P, C> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const P: usize, const C: usize> ContourStore<P, C> {
    /// An empty store (`const`, for `static` use).
    pub const fn new() -> Self {
        ContourStore {
            points: [Point { x: 0, y: 0 }; P],
            contours: heapless::Vec::new(),
            used: 0,
        }
    }

    /// Removes every border.
    pub fn clear(&mut self) {
        self.contours.clear();
        self.used = 0;
    }

    /// The kept borders, in the order they were found.
    pub fn contours(&self) -> &[Contour] {
        &self.contours
    }

    /// The points of border `index` (empty for an unknown index).
    pub fn points(&self, index: usize) -> &[Point] {
        match self.contours.get(index) {
            Some(c) => {
                let s = c.start as usize;
                self.points.get(s..s + c.len as usize).unwrap_or(&[])
            }
            None => &[],
        }
    }

    /// Sets the parent of border `index`, traced from pixel `(x, y)`, where the labels ran out
    /// ([`TraceStats::labels_saturated`]): the smallest kept border of the other kind, found
    /// before it, whose polygon holds the point half a pixel beside the start towards the
    /// background the trace began at (left of an outer border's start pixel, right of a hole's).
    /// That point lies inside the parent's region and off every border's polygon; a hole's
    /// parent always encloses it, so its parent is found whenever it was kept. An outer border
    /// that no hole holds stays at the top level.
    fn parent_by_containment(&mut self, index: usize, x: usize, y: usize) {
        let Some(&child) = self.contours.get(index) else {
            return;
        };
        let hole = child.kind == BorderKind::Hole;
        let q = [x as f32 + if hole { 0.5 } else { -0.5 }, y as f32];
        let want = if hole { BorderKind::Outer } else { BorderKind::Hole };
        let mut best: Option<(u64, u16)> = None;
        for (i, c) in self.contours.iter().enumerate().take(index) {
            let size = c.area2.unsigned_abs();
            if c.kind != want || size <= child.area2.unsigned_abs() || best.is_some_and(|(b, _)| size >= b) {
                continue;
            }
            let polygon = self.points(i).iter().map(|p| [f32::from(p.x), f32::from(p.y)]);
            if crate::math::polygon_holds(polygon, q) {
                best = Some((size, i as u16));
            }
        }
        if let Some(slot) = self.contours.get_mut(index) {
            slot.parent = best.map(|(_, i)| i);
        }
    }

    /// Index of the outer border of largest area, if any.
    pub fn largest_outer(&self) -> Option<usize> {
        self.contours
            .iter()
            .enumerate()
            .filter(|(_, c)| c.kind == BorderKind::Outer)
            .max_by_key(|(_, c)| c.area2.unsigned_abs())
            .map(|(i, _)| i)
    }

    /// Kept hole borders whose parent is border `index`.
    pub fn holes_of(&self, index: usize) -> impl Iterator<Item = usize> + Clone + '_ {
        self.contours
            .iter()
            .enumerate()
            .filter(move |(_, c)| c.kind == BorderKind::Hole && c.parent == Some(index as u16))
            .map(|(i, _)| i)
    }
}

/// Size filters for [`trace_borders`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BorderFilter {
    /// Fewest points of a kept border.
    pub min_points: usize,
    /// Smallest polygon area of a kept border, px².
    pub min_area: f32,
}

/// Directions clockwise on screen from west: W, NW, N, NE, E, SE, S, SW.
const DIRS: [(i32, i32); 8] = [(-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0), (1, 1), (0, 1), (-1, 1)];
const EAST: usize = 4;
const MAX_NBD: u8 = 127;
const NEG: u8 = 0x80;

/// Per-NBD record while tracing: kind, parent NBD, index in the store.
#[derive(Clone, Copy)]
struct Nbd {
    hole: bool,
    parent: u8,
    stored: Option<u16>,
}

struct Plane<'a> {
    px: &'a mut [u8],
    w: usize,
    h: usize,
}

impl Plane<'_> {
    #[inline]
    fn at(&self, x: i32, y: i32) -> u8 {
        if x < 0 || y < 0 || x as usize >= self.w || y as usize >= self.h {
            return 0;
        }
        self.px.get(y as usize * self.w + x as usize).copied().unwrap_or(0)
    }

    #[cfg(test)]
    #[inline]
    fn set(&mut self, x: i32, y: i32, v: u8) {
        if x >= 0 && y >= 0 && (x as usize) < self.w && (y as usize) < self.h {
            if let Some(p) = self.px.get_mut(y as usize * self.w + x as usize) {
                *p = v;
            }
        }
    }
}

/// Signed label value: positive NBD, negative NBD, or the plain 0/1.
#[inline]
fn label_abs(v: u8) -> u8 {
    v & !NEG
}

/// Follows every border of the 0/1 plane `labels` (`width·height`, row-major), keeping those
/// that pass `filter` in `store` (which is cleared first).
///
/// ```
/// use vorl_core::borders::contour::{trace_borders, BorderFilter, BorderKind, ContourStore, Point};
/// // A 2×2 square in a 4×4 image.
/// let mut plane = [0u8; 16];
/// for (x, y) in [(1, 1), (2, 1), (1, 2), (2, 2)] { plane[y * 4 + x] = 1; }
/// let mut store = ContourStore::<64, 4>::new();
/// let f = BorderFilter { min_points: 1, min_area: 0.0 };
/// let stats = trace_borders(&mut plane, 4, 4, f, &mut store).unwrap();
/// assert_eq!(stats.kept, 1);
/// assert_eq!(store.contours()[0].kind, BorderKind::Outer);
/// let pts: Vec<(u16, u16)> = store.points(0).iter().map(|p| (p.x, p.y)).collect();
/// assert_eq!(pts, [(1, 1), (1, 2), (2, 2), (2, 1)]);
/// ```
///
/// # Errors
/// [`Error::EmptyFrame`], [`Error::BufferTooSmall`] when `labels` is short, and
/// [`Error::Capacity`] when the image is too large for `u16` coordinates.
pub fn trace_borders<const P: usize, const C: usize>(
    labels: &mut [u8],
    width: usize,
    height: usize,
    filter: BorderFilter,
    store: &mut ContourStore<P, C>,
) -> Result<TraceStats> {
    trace_borders_in(labels, width, height, &RowSpans::full(width, height), filter, store)
}

/// [`trace_borders`] scanning each row only inside its span of `spans`
/// ([`crate::pixels::mask::foreground_mask_spans`] writes them with the mask): the plane must be 0
/// outside them. The result is [`trace_borders`]'s; only rows and columns that hold nothing
/// are not read. Spans of another plane size count as unknown (every row scanned whole).
///
/// ```
/// use vorl_core::borders::contour::{trace_borders, trace_borders_in, BorderFilter, ContourStore};
/// use vorl_core::pixels::mask::RowSpans;
/// let mut plane = [0u8; 16];
/// for (x, y) in [(1, 1), (2, 1), (1, 2), (2, 2)] { plane[y * 4 + x] = 1; }
/// let mut again = plane;
/// let (mut a, mut b) = (ContourStore::<64, 4>::new(), ContourStore::<64, 4>::new());
/// let f = BorderFilter { min_points: 1, min_area: 0.0 };
/// let spans = RowSpans::full(4, 4);
/// assert_eq!(trace_borders_in(&mut plane, 4, 4, &spans, f, &mut a), trace_borders(&mut again, 4, 4, f, &mut b));
/// assert_eq!(plane, again);
/// ```
///
/// # Errors
/// As [`trace_borders`].
pub fn trace_borders_in<const P: usize, const C: usize>(
    labels: &mut [u8],
    width: usize,
    height: usize,
    spans: &RowSpans,
    filter: BorderFilter,
    store: &mut ContourStore<P, C>,
) -> Result<TraceStats> {
    if width == 0 || height == 0 {
        return Err(Error::EmptyFrame { width, height });
    }
    if width > u16::MAX as usize || height > u16::MAX as usize {
        return Err(Error::Capacity {
            what: "image side for u16 border coordinates",
            capacity: u16::MAX as usize,
            requested: width.max(height),
        });
    }
    let n = width * height;
    if labels.len() < n {
        return Err(Error::BufferTooSmall {
            needed: n,
            got: labels.len(),
        });
    }
    let known = spans.width() == width && spans.height() == height;
    store.clear();
    let mut plane = Plane {
        px: &mut labels[..n],
        w: width,
        h: height,
    };
    let mut stats = TraceStats::default();
    // Index 1 is the frame (the background around everything).
    let mut nbds = [Nbd {
        hole: true,
        parent: 0,
        stored: None,
    }; MAX_NBD as usize + 1];
    let mut nbd: u8 = 1;
    for y in 0..height {
        // Background pixels start nothing and change nothing, and outside its span a row holds
        // only background.
        let span = if known { spans.row(y) } else { 0..width };
        if span.is_empty() {
            continue;
        }
        let mut lnbd: u8 = 1;
        let row = y * width;
        let end = row + span.end;
        let mut i = row + span.start;
        loop {
            // Skip the run of background (a plain search the compiler vectorises). The row is
            // read afresh, as tracing writes labels into it (never into background).
            let rest = plane.px.get(i..end).unwrap_or_default();
            let skip = run_of(rest, 0);
            if skip >= rest.len() {
                break;
            }
            // The left neighbour is background when a run of it was skipped, and at the span's
            // first column (outside the span, or outside the image); otherwise it is the pixel
            // visited last or an interior pixel.
            let left_zero = skip > 0 || i == row + span.start;
            i += skip;
            let x = i - row;
            let v = plane.px.get(i).copied().unwrap_or(0);
            let start = if v == 1 && left_zero {
                Some((false, 0usize))
            } else if v & NEG == 0 && (x + 1 == width || plane.px.get(i + 1).is_some_and(|&r| r == 0)) {
                if v > 1 {
                    lnbd = v;
                }
                Some((true, EAST))
            } else {
                None
            };
            if let Some((hole, from)) = start {
                let saturated = nbd >= MAX_NBD;
                if saturated {
                    stats.labels_saturated = true;
                } else {
                    nbd += 1;
                }
                // Parent by Suzuki–Abe's table: same kind as LNBD's border → LNBD's parent.
                let lb = nbds.get(lnbd as usize).copied().unwrap_or(nbds[1]);
                let parent_nbd = if lnbd == 1 {
                    1
                } else if lb.hole != hole {
                    lnbd
                } else {
                    lb.parent
                };
                let parent_known = !(stats.labels_saturated && (saturated || lnbd == MAX_NBD));
                let parent = if parent_known {
                    nbds.get(parent_nbd as usize).and_then(|p| p.stored)
                } else {
                    None
                };
                stats.found += 1;
                let stored = follow(&mut plane, x, y, from, nbd, hole, parent, filter, store, &mut stats);
                if !parent_known {
                    if let Some(index) = stored {
                        store.parent_by_containment(index as usize, x, y);
                    }
                }
                if !saturated {
                    if let Some(slot) = nbds.get_mut(nbd as usize) {
                        *slot = Nbd {
                            hole,
                            parent: parent_nbd,
                            stored,
                        };
                    }
                }
                let v = plane.px.get(i).copied().unwrap_or(0);
                if v != 1 {
                    lnbd = label_abs(v);
                }
            } else if v != 1 {
                lnbd = label_abs(v);
            }
            // So do unlabelled interior pixels (1) between two foreground neighbours: no border
            // starts there and LNBD stays. Skip their run too.
            i += 1 + plane.px.get(i + 1..end).map_or(0, interior_run);
        }
    }
    Ok(stats)
}

/// Turns the plane labelled by [`trace_borders_in`] back into the 0/1 mask: every byte that is
/// not 0 becomes 1. Only the columns inside `spans` are read, where the plane must hold all its
/// non-zero bytes (spans of another plane size count as unknown: whole rows). A plane that
/// `labels` does not fully hold is cleared as far as it goes.
///
/// ```
/// use vorl_core::borders::contour::{clear_labels, trace_borders_in, BorderFilter, ContourStore};
/// use vorl_core::pixels::mask::RowSpans;
/// let mut plane = [0u8; 16];
/// for (x, y) in [(1, 1), (2, 1), (1, 2), (2, 2)] { plane[y * 4 + x] = 1; }
/// let mask = plane;
/// let spans = RowSpans::full(4, 4);
/// let f = BorderFilter { min_points: 1, min_area: 0.0 };
/// trace_borders_in(&mut plane, 4, 4, &spans, f, &mut ContourStore::<64, 4>::new()).unwrap();
/// assert_ne!(plane, mask);
/// clear_labels(&mut plane, 4, 4, &spans);
/// assert_eq!(plane, mask);
/// ```
pub fn clear_labels(labels: &mut [u8], width: usize, height: usize, spans: &RowSpans) {
    let known = spans.width() == width && spans.height() == height;
    for (y, row) in labels.chunks_mut(width.max(1)).take(height).enumerate() {
        let span = if known { spans.row(y) } else { 0..width };
        if let Some(r) = row.get_mut(span.start..span.end.min(row.len())) {
            binarize(r);
        }
    }
}

/// Every byte of `r` that is not 0 becomes 1: a byte loop where it vectorises, four bytes at a
/// time in a `u32` elsewhere (`(x & 0x7F) + 0x7F | x` reaches bit 7 exactly when `x ≠ 0`).
#[inline]
fn binarize(r: &mut [u8]) {
    binarize_form::<{ crate::pixels::mask::BYTE_SIMD }>(r);
}

/// [`binarize`] as a byte loop (`SIMD`) or four bytes at a time (the Cortex-M4's form).
#[inline(always)]
fn binarize_form<const SIMD: bool>(r: &mut [u8]) {
    if SIMD {
        for v in r.iter_mut() {
            *v = u8::from(*v != 0);
        }
        return;
    }
    let mut quads = r.chunks_exact_mut(4);
    for q in quads.by_ref() {
        if let Some(q) = q.first_chunk_mut::<4>() {
            let x = u32::from_le_bytes(*q);
            *q = ((((x & 0x7F7F_7F7F) + 0x7F7F_7F7F) | x) >> 7 & 0x0101_0101).to_le_bytes();
        }
    }
    for v in quads.into_remainder() {
        *v = u8::from(*v != 0);
    }
}

/// Length of the run of bytes equal to `v` at the start of `r` (`r.len()` when all are): 16
/// bytes to a comparison of little-endian `u128` words (a few instructions per 16 pixels on
/// x86_64 and on the Cortex-M4 alike), then the first differing byte from the lowest set bit.
/// The bytes after the last whole word are compared as the slice's last 16 (or 8) bytes, the
/// ones already compared included (they are `v`).
#[inline]
fn run_of(r: &[u8], v: u8) -> usize {
    const LANE: usize = 16;
    let pattern = u128::from_le_bytes([v; LANE]);
    let mut chunks = r.chunks_exact(LANE);
    let mut run = 0;
    for c in chunks.by_ref() {
        let diff = c.first_chunk::<LANE>().map_or(pattern, |c| u128::from_le_bytes(*c)) ^ pattern;
        if diff != 0 {
            return run + (diff.trailing_zeros() / 8) as usize;
        }
        run += LANE;
    }
    let len = r.len();
    if run == len {
        return len;
    }
    if let Some(last) = r.last_chunk::<LANE>() {
        let diff = u128::from_le_bytes(*last) ^ pattern;
        return if diff == 0 {
            len
        } else {
            len - LANE + (diff.trailing_zeros() / 8) as usize
        };
    }
    // Fewer than 16 bytes.
    let pattern = u64::from_le_bytes([v; 8]);
    if let (Some(head), Some(tail)) = (r.first_chunk::<8>(), r.last_chunk::<8>()) {
        let (h, t) = (u64::from_le_bytes(*head) ^ pattern, u64::from_le_bytes(*tail) ^ pattern);
        return if h != 0 {
            (h.trailing_zeros() / 8) as usize
        } else if t != 0 {
            len - 8 + (t.trailing_zeros() / 8) as usize
        } else {
            len
        };
    }
    r.iter().position(|&b| b != v).unwrap_or(len)
}

/// How many unlabelled interior pixels start `r` (the rest of a row after a pixel): pixels of
/// value 1 whose right neighbour is foreground, i.e. the leading run of 1s, less its last pixel
/// unless a labelled pixel (not 0, not 1) follows it. Neither starts a border nor changes LNBD.
#[inline]
fn interior_run(r: &[u8]) -> usize {
    let ones = run_of(r, 1);
    if r.get(ones).is_some_and(|&v| v != 0) {
        ones
    } else {
        ones.saturating_sub(1)
    }
}

/// One border trace from `(x0, y0)`; `from` is the direction of the background neighbour that
/// started it. Stores the border when it passes the filter; returns its store index.
#[allow(clippy::too_many_arguments)]
fn follow<const P: usize, const C: usize>(
    plane: &mut Plane<'_>,
    x0: usize,
    y0: usize,
    from: usize,
    nbd: u8,
    hole: bool,
    parent: Option<u16>,
    filter: BorderFilter,
    store: &mut ContourStore<P, C>,
    stats: &mut TraceStats,
) -> Option<u16> {
    let free = P.saturating_sub(store.used);
    let first = trace::<false>(plane, x0, y0, from, nbd, 1, &mut store.points, store.used, free);
    let Some(first) = first else {
        stats.aborted += 1;
        return None;
    };
    if first.len < filter.min_points || (first.area2.unsigned_abs() as f32) * 0.5 < filter.min_area {
        stats.dropped_small += 1;
        return None;
    }
    let mut result = first;
    let mut stride = 1;
    if first.len > free {
        // Keep every stride-th point; at least 8 must remain to describe an outline.
        if free < 8 {
            stats.skipped_capacity += 1;
            return None;
        }
        stride = first.len.div_ceil(free);
        match trace::<true>(plane, x0, y0, from, nbd, stride, &mut store.points, store.used, free) {
            Some(r) => result = r,
            None => {
                stats.aborted += 1;
                return None;
            }
        }
        stats.subsampled += 1;
    }
    let stored_len = result.len.div_ceil(stride.max(1)).min(free);
    let contour = Contour {
        kind: if hole { BorderKind::Hole } else { BorderKind::Outer },
        parent,
        start: store.used as u32,
        len: stored_len as u32,
        traced_len: result.len as u32,
        stride: stride as u32,
        area2: result.area2,
        touches_edge: result.touches_edge,
    };
    let index = store.contours.len();
    if store.contours.push(contour).is_err() {
        stats.skipped_capacity += 1;
        return None;
    }
    store.used += stored_len;
    stats.kept += 1;
    Some(index as u16)
}

#[derive(Clone, Copy)]
struct TraceResult {
    len: usize,
    area2: i64,
    touches_edge: bool,
}

/// Traces one border, labelling pixels, storing every `stride`-th point into
/// `points[offset .. offset + free]` while there is room. `None` when the iteration guard trips.
/// `STRIDED` unset: `stride` is 1 (every point, the first trace of each border).
///
/// Each step searches counter-clockwise from the direction back to the previous pixel, which is
/// the opposite of the step that reached the current one. Away from the image's edge the
/// neighbours are read at fixed offsets in the plane; on the edge (which is what
/// [`Contour::touches_edge`] means) through the bounds checks of [`Plane::at`] (outside counts
/// as background). Whether the search examined the east neighbour follows from where it stopped.
#[allow(clippy::too_many_arguments)]
fn trace<const STRIDED: bool>(
    plane: &mut Plane<'_>,
    x0: usize,
    y0: usize,
    from: usize,
    nbd: u8,
    stride: usize,
    points: &mut [Point],
    offset: usize,
    free: usize,
) -> Option<TraceResult> {
    let (w, h) = (plane.w, plane.h);
    // The points' room.
    let points = points
        .get_mut(offset..offset.saturating_add(free).min(points.len()))
        .unwrap_or_default();
    let (x0i, y0i) = (x0 as i32, y0 as i32);
    // Step 3.1: clockwise from `from` for the first foreground neighbour.
    let mut first = None;
    for k in 0..8 {
        let d = (from + k) % 8;
        let (dx, dy) = DIRS[d];
        if plane.at(x0i + dx, y0i + dy) != 0 {
            first = Some(d);
            break;
        }
    }
    let i0 = y0 * w + x0;
    let Some(d1) = first else {
        // Isolated pixel.
        if let Some(p) = plane.px.get_mut(i0) {
            *p = NEG | nbd;
        }
        if let Some(p) = points.first_mut() {
            *p = Point {
                x: x0 as u16,
                y: y0 as u16,
            };
        }
        return Some(TraceResult {
            len: 1,
            area2: 0,
            touches_edge: x0 == 0 || y0 == 0 || x0 + 1 == w || y0 + 1 == h,
        });
    };
    // Offsets in the plane of the neighbours in the order of [`DIRS`], twice over: the search
    // from `back` reads entries `back + 7` down to `back`.
    let row = w as isize;
    let once: [isize; 8] = [-1, -row - 1, -row, 1 - row, 1, row + 1, row, row - 1];
    let offsets: [isize; 16] = core::array::from_fn(|j| once[j & 7]);
    // The first pixel after the start, (x1, y1).
    let i1 = i0.wrapping_add_signed(offsets[d1]);
    // The current pixel (x3, y3) at index i3, and the direction back to the previous one
    // (x2, y2), which starts as (x1, y1).
    let (mut x3, mut y3) = (x0, y0);
    let mut i3 = i0;
    let mut back = d1;
    // Columns and rows of pixels away from the edge: 1 ..= w − 2 (none when w < 3).
    let (inner_w, inner_h) = (w.saturating_sub(2), h.saturating_sub(2));
    // Each pixel is entered at most 4 times on one border; the guard only protects against a
    // plane changed under our feet.
    let guard = 4 * (w * h) + 16;
    let mut len = 0usize;
    let mut stored = 0usize;
    // `len % stride`, counted instead of divided.
    let mut phase = 0usize;
    let mut area2: i64 = 0;
    let mut touches_edge = false;
    // Search steps known to find background (none before the first step).
    let mut known = 0;
    loop {
        if !STRIDED || phase == 0 {
            if let Some(p) = points.get_mut(stored) {
                *p = Point {
                    x: x3 as u16,
                    y: y3 as u16,
                };
                stored += 1;
            }
        }
        if STRIDED {
            phase += 1;
            if phase >= stride {
                phase = 0;
            }
        }
        len += 1;
        if len > guard {
            return None;
        }
        // Step 3.3: counter-clockwise from the direction after (x2, y2); (x2, y2) itself when
        // nothing else is foreground. `found` is the step of the search that stopped it (9: none).
        let inner = x3.wrapping_sub(1) < inner_w && y3.wrapping_sub(1) < inner_h;
        touches_edge |= !inner;
        // The first `known` steps read neighbours the previous step's search found background.
        let found = if inner {
            let ahead = offsets.get(back..back + 8).unwrap_or_default();
            match known {
                0 => search_inner::<1>(plane.px, i3, ahead),
                1 => search_inner::<2>(plane.px, i3, ahead),
                _ => search_inner::<3>(plane.px, i3, ahead),
            }
        } else {
            let mut found = 9;
            for k in known + 1..=8 {
                let (dx, dy) = DIRS[(back + 8 - k) & 7];
                if plane.at(x3 as i32 + dx, y3 as i32 + dy) != 0 {
                    found = k;
                    break;
                }
            }
            found
        };
        let next = if found <= 8 { (back + 8 - found) & 7 } else { back };
        // Step 3.4: label. The search reaches east at step (back − 4) mod 8 (8 for 0); it was
        // examined (and background) when that comes before the step that stopped it.
        let east = match (back + 4) & 7 {
            0 => 8,
            k => k,
        };
        if let Some(p) = plane.px.get_mut(i3) {
            if east < found {
                *p = NEG | nbd;
            } else if *p == 1 {
                *p = nbd;
            }
        }
        let (dx, dy) = DIRS[next];
        // x3·y4 − x4·y3 with (x4, y4) = (x3 + dx, y3 + dy).
        area2 += x3 as i64 * dy as i64 - y3 as i64 * dx as i64;
        let i4 = i3.wrapping_add_signed(offsets[next]);
        // Step 3.5: back at the start heading for the first point → done.
        if i4 == i0 && i3 == i1 {
            break;
        }
        // This search found directions next + 1 ..= next + found − 1 background. From the next
        // pixel, the search's first step reads this pixel's neighbour next + 2 (a step along a
        // row or column) or next + 1 (a diagonal one), and after a straight step its second
        // reads next + 1: those are known when this search passed them.
        known = match (next & 1, found) {
            (_, 9..) => 0,
            (0, 3..) => 2,
            (1, 2..) => 1,
            _ => 0,
        };
        back = (next + 4) & 7;
        x3 = x3.wrapping_add_signed(dx as isize);
        y3 = y3.wrapping_add_signed(dy as isize);
        i3 = i4;
    }
    Some(TraceResult {
        len,
        area2,
        touches_edge,
    })
}

/// The step of the search around pixel `i` (away from the image's edge) that first finds
/// foreground, from step `FROM` on (9: none): step `k` reads the neighbour at offset
/// `ahead[8 − k]`.
#[inline(always)]
fn search_inner<const FROM: usize>(px: &[u8], i: usize, ahead: &[isize]) -> usize {
    for k in FROM..=8 {
        let o = ahead.get(8 - k).copied().unwrap_or(0);
        if px.get(i.wrapping_add_signed(o)).is_some_and(|&v| v != 0) {
            return k;
        }
    }
    9
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The border following before the word-wise run skipping and the leaner trace step (commit
    /// 59f53be) as the oracle: the runs of background and of interior pixels found byte by byte,
    /// every neighbour read through the bounds-checked `Plane::at`.
    fn reference_trace_borders<const P: usize, const C: usize>(
        labels: &mut [u8],
        width: usize,
        height: usize,
        filter: BorderFilter,
        store: &mut ContourStore<P, C>,
    ) -> TraceStats {
        store.clear();
        let mut plane = Plane {
            px: &mut labels[..width * height],
            w: width,
            h: height,
        };
        let mut stats = TraceStats::default();
        let mut nbds = [Nbd {
            hole: true,
            parent: 0,
            stored: None,
        }; MAX_NBD as usize + 1];
        let mut nbd: u8 = 1;
        for y in 0..height as i32 {
            let mut lnbd: u8 = 1;
            let row = y as usize * width;
            let mut x = -1i32;
            loop {
                x += 1;
                let Some(skip) = plane
                    .px
                    .get(row + x as usize..row + width)
                    .and_then(|r| r.iter().position(|&b| b != 0))
                else {
                    break;
                };
                x += skip as i32;
                let v = plane.at(x, y);
                if v == 0 {
                    continue;
                }
                let start = if v == 1 && plane.at(x - 1, y) == 0 {
                    Some((false, 0usize))
                } else if v & NEG == 0 && plane.at(x + 1, y) == 0 {
                    if v > 1 {
                        lnbd = v;
                    }
                    Some((true, EAST))
                } else {
                    None
                };
                if let Some((hole, from)) = start {
                    let saturated = nbd >= MAX_NBD;
                    if saturated {
                        stats.labels_saturated = true;
                    } else {
                        nbd += 1;
                    }
                    let lb = nbds.get(lnbd as usize).copied().unwrap_or(nbds[1]);
                    let parent_nbd = if lnbd == 1 {
                        1
                    } else if lb.hole != hole {
                        lnbd
                    } else {
                        lb.parent
                    };
                    let parent_known = !(stats.labels_saturated && (saturated || lnbd == MAX_NBD));
                    let parent = if parent_known {
                        nbds.get(parent_nbd as usize).and_then(|p| p.stored)
                    } else {
                        None
                    };
                    stats.found += 1;
                    let stored = reference_follow(&mut plane, x, y, from, nbd, hole, parent, filter, store, &mut stats);
                    // (The parents the labels no longer tell: the same containment rule; the
                    // host's `borders_parents` test holds it against imageproc's tracing.)
                    if !parent_known {
                        if let Some(index) = stored {
                            store.parent_by_containment(index as usize, x as usize, y as usize);
                        }
                    }
                    if !saturated {
                        if let Some(slot) = nbds.get_mut(nbd as usize) {
                            *slot = Nbd {
                                hole,
                                parent: parent_nbd,
                                stored,
                            };
                        }
                    }
                }
                let v = plane.at(x, y);
                if v != 1 {
                    lnbd = label_abs(v);
                }
                let interior = plane.px.get(row + x as usize + 1..row + width).map_or(0, |r| {
                    r.windows(2)
                        .take_while(|w| w.first() == Some(&1) && w.get(1) != Some(&0))
                        .count()
                });
                x += interior as i32;
            }
        }
        stats
    }

    /// `follow` before the leaner trace (commit 59f53be), calling [`reference_trace`]: one border trace from `(x0, y0)`; `from` is the direction of the background neighbour that
    /// started it. Stores the border when it passes the filter; returns its store index.
    #[allow(clippy::too_many_arguments)]
    fn reference_follow<const P: usize, const C: usize>(
        plane: &mut Plane<'_>,
        x0: i32,
        y0: i32,
        from: usize,
        nbd: u8,
        hole: bool,
        parent: Option<u16>,
        filter: BorderFilter,
        store: &mut ContourStore<P, C>,
        stats: &mut TraceStats,
    ) -> Option<u16> {
        let free = P.saturating_sub(store.used);
        let first = reference_trace(plane, x0, y0, from, nbd, 1, &mut store.points, store.used, free);
        let Some(first) = first else {
            stats.aborted += 1;
            return None;
        };
        if first.len < filter.min_points || (first.area2.unsigned_abs() as f32) * 0.5 < filter.min_area {
            stats.dropped_small += 1;
            return None;
        }
        let mut result = first;
        let mut stride = 1;
        if first.len > free {
            // Keep every stride-th point; at least 8 must remain to describe an outline.
            if free < 8 {
                stats.skipped_capacity += 1;
                return None;
            }
            stride = first.len.div_ceil(free);
            match reference_trace(plane, x0, y0, from, nbd, stride, &mut store.points, store.used, free) {
                Some(r) => result = r,
                None => {
                    stats.aborted += 1;
                    return None;
                }
            }
            stats.subsampled += 1;
        }
        let stored_len = result.len.div_ceil(stride).min(free);
        let contour = Contour {
            kind: if hole { BorderKind::Hole } else { BorderKind::Outer },
            parent,
            start: store.used as u32,
            len: stored_len as u32,
            traced_len: result.len as u32,
            stride: stride as u32,
            area2: result.area2,
            touches_edge: result.touches_edge,
        };
        let index = store.contours.len();
        if store.contours.push(contour).is_err() {
            stats.skipped_capacity += 1;
            return None;
        }
        store.used += stored_len;
        stats.kept += 1;
        Some(index as u16)
    }

    /// The trace before the leaner step (commit 59f53be): traces one border, labelling pixels, storing every `stride`-th point into
    /// `points[offset .. offset + free]` while there is room. `None` when the iteration guard trips.
    #[allow(clippy::too_many_arguments)]
    fn reference_trace(
        plane: &mut Plane<'_>,
        x0: i32,
        y0: i32,
        from: usize,
        nbd: u8,
        stride: usize,
        points: &mut [Point],
        offset: usize,
        free: usize,
    ) -> Option<TraceResult> {
        let (w, h) = (plane.w as i32, plane.h as i32);
        let mut len = 0usize;
        let mut stored = 0usize;
        let mut area2: i64 = 0;
        let mut touches_edge = false;
        let mut push = |x: i32, y: i32, len: &mut usize| {
            if *len % stride == 0 && stored < free {
                if let Some(p) = points.get_mut(offset + stored) {
                    *p = Point {
                        x: x as u16,
                        y: y as u16,
                    };
                }
                stored += 1;
            }
            *len += 1;
            if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
                touches_edge = true;
            }
        };
        // Step 3.1: clockwise from `from` for the first foreground neighbour.
        let mut first = None;
        for k in 0..8 {
            let d = (from + k) % 8;
            let (dx, dy) = DIRS[d];
            if plane.at(x0 + dx, y0 + dy) != 0 {
                first = Some((x0 + dx, y0 + dy));
                break;
            }
        }
        let Some((x1, y1)) = first else {
            // Isolated pixel.
            plane.set(x0, y0, NEG | nbd);
            push(x0, y0, &mut len);
            return Some(TraceResult {
                len,
                area2: 0,
                touches_edge,
            });
        };
        let (mut x2, mut y2) = (x1, y1);
        let (mut x3, mut y3) = (x0, y0);
        // Each pixel is entered at most 4 times on one border; the guard only protects against a
        // plane changed under our feet.
        let guard = 4 * (plane.w * plane.h) + 16;
        loop {
            push(x3, y3, &mut len);
            if len > guard {
                return None;
            }
            // Step 3.3: counter-clockwise from the direction after (x2, y2).
            let back = dir_index(x2 - x3, y2 - y3);
            let mut east_examined = false;
            let mut next = (x2, y2);
            for k in 1..=8 {
                let d = (back + 8 - k) % 8;
                let (dx, dy) = DIRS[d];
                if plane.at(x3 + dx, y3 + dy) != 0 {
                    next = (x3 + dx, y3 + dy);
                    break;
                }
                if d == EAST {
                    east_examined = true;
                }
            }
            // Step 3.4: label.
            if east_examined {
                plane.set(x3, y3, NEG | nbd);
            } else if plane.at(x3, y3) == 1 {
                plane.set(x3, y3, nbd);
            }
            let (x4, y4) = next;
            area2 += x3 as i64 * y4 as i64 - x4 as i64 * y3 as i64;
            // Step 3.5: back at the start heading for the first point → done.
            if x4 == x0 && y4 == y0 && x3 == x1 && y3 == y1 {
                break;
            }
            (x2, y2) = (x3, y3);
            (x3, y3) = (x4, y4);
        }
        Some(TraceResult {
            len,
            area2,
            touches_edge,
        })
    }

    /// Index in [`DIRS`] of a unit step (W for anything unexpected).
    #[inline]
    fn dir_index(dx: i32, dy: i32) -> usize {
        match (dx, dy) {
            (-1, 0) => 0,
            (-1, -1) => 1,
            (0, -1) => 2,
            (1, -1) => 3,
            (1, 0) => 4,
            (1, 1) => 5,
            (0, 1) => 6,
            _ => 7,
        }
    }

    use crate::test_rng::XorShiftStar as Rng;

    #[test]
    fn run_of_and_interior_run_match_their_definitions() {
        let mut rng = Rng(3);
        let mut r = [0u8; 100];
        for _ in 0..20_000 {
            let len = rng.below(101) as usize;
            let fill = rng.below(3) as u8;
            let stop = rng.below(len as u64 + 1) as usize;
            for (i, p) in r[..len].iter_mut().enumerate() {
                *p = if i < stop {
                    fill
                } else {
                    [0, 1, 2, 0x82][rng.below(4) as usize]
                };
            }
            let r = &r[..len];
            for v in 0..3 {
                assert_eq!(run_of(r, v), r.iter().take_while(|&&b| b == v).count(), "{r:?} {v}");
            }
            let want = r
                .windows(2)
                .take_while(|w| w.first() == Some(&1) && w.get(1) != Some(&0))
                .count();
            assert_eq!(interior_run(r), want, "{r:?}");
        }
    }

    /// Spans of `plane`: each row's foreground hull, widened by `widen()` columns each way
    /// (a true superset of its foreground, as [`trace_borders_in`] needs).
    fn spans_of(plane: &[u8], w: usize, h: usize, mut widen: impl FnMut() -> (usize, usize)) -> RowSpans {
        let mut spans = RowSpans::new();
        spans.clear(w, h);
        for (y, row) in plane.chunks_exact(w).take(h).enumerate() {
            if let (Some(x0), Some(x1)) = (row.iter().position(|&v| v != 0), row.iter().rposition(|&v| v != 0)) {
                let (a, b) = widen();
                spans.include(y, x0.saturating_sub(a), (x1 + 1 + b).min(w));
            }
        }
        spans
    }

    /// Every mask of a 4×4, 5×3 and 3×5 window, in a frame of background and at the image's
    /// corner, against the reference: every local shape the search meets (spurs, one-pixel
    /// lines, diagonal steps, pixels met twice) in every position.
    #[test]
    fn borders_equal_reference_on_every_small_mask() {
        let filter = BorderFilter {
            min_points: 0,
            min_area: 0.0,
        };
        for (bw, bh) in [(4usize, 4usize), (5, 3), (3, 5)] {
            for (ox, oy, w, h) in [(1usize, 1usize, bw + 2, bh + 2), (0, 0, bw + 1, bh)] {
                for bits in 0u32..1 << (bw * bh) {
                    let mut plane = [0u8; 64];
                    for i in 0..bw * bh {
                        if bits >> i & 1 == 1 {
                            plane[(oy + i / bw) * w + ox + i % bw] = 1;
                        }
                    }
                    let spans = spans_of(&plane[..w * h], w, h, || (0, 0));
                    assert_same::<64, 16>(&plane[..w * h], w, h, filter, &spans, bits as usize);
                }
            }
        }
    }

    /// Both forms of the label clearing (the byte loop runs on the host, the four-byte one on
    /// the Cortex-M4) against the definition, on every byte value in every position and on
    /// random lengths.
    #[test]
    fn binarize_forms_match_definition() {
        let mut rng = Rng(9);
        for case in 0..20_000 {
            let len = rng.below(40) as usize;
            let mut r = [0u8; 40];
            for (i, v) in r[..len].iter_mut().enumerate() {
                *v = if case < 256 {
                    (case as u8).wrapping_add(i as u8)
                } else {
                    [0, 1, 2, 0x80, 0x81, 0xFF][rng.below(6) as usize]
                };
            }
            let want = r.map(|v| u8::from(v != 0));
            let (mut a, mut b) = (r, r);
            binarize_form::<true>(&mut a[..len]);
            binarize_form::<false>(&mut b[..len]);
            assert_eq!(a[..len], want[..len], "{:?}", &r[..len]);
            assert_eq!(b[..len], want[..len], "{:?}", &r[..len]);
            assert_eq!((&a[len..], &b[len..]), (&r[len..], &r[len..]));
        }
    }

    /// Traces `plane` with both implementations into stores of `P` points and `C` borders and
    /// asserts the same labels, borders (points, order, kinds, parents) and stats; returns them.
    /// The scan within `spans` (which must cover the plane's foreground) gives the same, and
    /// [`clear_labels`] within them leaves the plane itself again.
    fn assert_same<const P: usize, const C: usize>(
        plane: &[u8],
        w: usize,
        h: usize,
        filter: BorderFilter,
        spans: &RowSpans,
        case: usize,
    ) -> TraceStats {
        let (mut got, mut want) = (plane.to_vec(), plane.to_vec());
        let (mut store_got, mut store_want) = (ContourStore::<P, C>::new(), ContourStore::<P, C>::new());
        let g = trace_borders(&mut got, w, h, filter, &mut store_got).unwrap();
        let r = reference_trace_borders(&mut want, w, h, filter, &mut store_want);
        assert_eq!(g, r, "case {case}: {w}×{h} P={P}");
        assert_eq!(got, want, "case {case}: {w}×{h} P={P}");
        assert_eq!(store_got.contours(), store_want.contours(), "case {case} P={P}");
        for i in 0..store_got.contours().len() {
            assert_eq!(
                store_got.points(i),
                store_want.points(i),
                "case {case} P={P} border {i}"
            );
        }
        let mut within = plane.to_vec();
        let mut store_within = ContourStore::<P, C>::new();
        let s = trace_borders_in(&mut within, w, h, spans, filter, &mut store_within).unwrap();
        assert_eq!(s, r, "case {case}: {w}×{h} P={P} within spans");
        assert_eq!(within, want, "case {case}: {w}×{h} P={P} within spans");
        assert_eq!(
            store_within.contours(),
            store_want.contours(),
            "case {case} P={P} within spans"
        );
        for i in 0..store_within.contours().len() {
            assert_eq!(
                store_within.points(i),
                store_want.points(i),
                "case {case} P={P} border {i}"
            );
        }
        clear_labels(&mut within, w, h, spans);
        assert_eq!(within, plane, "case {case}: {w}×{h} cleared within spans");
        g
    }

    /// The scan and trace give the same result as the byte-wise, bounds-checked ones on random
    /// masks: specks, rectangles (long runs of background and of interior, rings with holes,
    /// parts on the image's edge), every width around the 16-byte words, over 126 borders, and
    /// a store large enough for everything or small enough to subsample and skip.
    #[test]
    fn borders_equal_reference_on_random_masks() {
        const MAX: usize = 200 * 40;
        let mut rng = Rng(0x51ed_2701);
        let mut plane = [0u8; MAX];
        let (mut saturated, mut skipped, mut subsampled, mut borders) = (0, 0, 0, 0);
        for case in 0..2500 {
            let w = if case % 3 == 0 {
                [1usize, 2, 15, 16, 17, 31, 32, 33, 47, 48, 49, 200][rng.below(12) as usize]
            } else {
                1 + rng.below(200) as usize
            };
            // Every fifth plane as tall as fits: over 256 rows the spans are per group of rows.
            let tall = if case % 5 == 4 { MAX / w } else { (MAX / w).min(40) };
            let h = 1 + rng.below(tall as u64) as usize;
            let n = w * h;
            let density = rng.below(101);
            for p in plane[..n].iter_mut() {
                *p = u8::from(rng.below(1000) < density);
            }
            for _ in 0..rng.below(8) {
                let (x0, y0) = (rng.below(w as u64) as usize, rng.below(h as u64) as usize);
                let (rw, rh) = (1 + rng.below(60) as usize, 1 + rng.below(20) as usize);
                let v = u8::from(rng.below(3) != 0);
                for y in y0..(y0 + rh).min(h) {
                    for x in x0..(x0 + rw).min(w) {
                        plane[y * w + x] = v;
                    }
                }
            }
            let filter = BorderFilter {
                min_points: rng.below(4) as usize,
                min_area: rng.below(3) as f32,
            };
            // Spans: the foreground's hull per row (widened to 32 px), or widened further at
            // random, or of another plane (unknown: whole rows).
            let spans = match case % 3 {
                0 => spans_of(&plane[..n], w, h, || (0, 0)),
                1 => spans_of(&plane[..n], w, h, || (rng.below(40) as usize, rng.below(40) as usize)),
                _ if case % 2 == 0 => RowSpans::full(w + 1, h),
                _ => spans_of(&plane[..n], w, h, || (rng.below(3) as usize, 0)),
            };
            for g in [
                assert_same::<8192, 256>(&plane[..n], w, h, filter, &spans, case),
                assert_same::<64, 256>(&plane[..n], w, h, filter, &spans, case),
            ] {
                saturated += usize::from(g.labels_saturated);
                skipped += g.skipped_capacity;
                subsampled += g.subsampled;
                borders += g.found;
            }
        }
        // The cases reach saturated labels, subsampled borders and a full store, not only small
        // masks.
        assert!(
            saturated > 50 && skipped > 50 && subsampled > 100 && borders > 100_000,
            "{saturated} {skipped} {subsampled} {borders}"
        );
    }
}
