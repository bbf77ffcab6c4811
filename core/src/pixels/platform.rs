//! The platform estimated from the frame itself, for installations without an empty shot.
//!
//! Real integrators often have no picture of the empty platform: parts keep arriving, or the
//! backlight and the exposure change between shots. This stage makes the background model
//! (paper section 3.2) out of the frame it is used on, so any brighter or dimmer exposure, any
//! vignetting and any slow fall-off of a backlight are the frame's own:
//!
//! 1. **Cells.** The frame is cut into square cells of `s ≥` [`MIN_CELL`] px, about
//!    [`CELLS_ALONG`] along its longer side (more when the grid's capacity `G` is smaller).
//!    Each cell's level is read from at most 8 × 8 of its pixels ([`SAMPLES_ALONG`]), and is
//!    the *mode-trimmed mean* of their `I'`
//!    values: the peak of its histogram (smoothed over 5 grey levels), then the mean of the
//!    values within ±[`TRIM`] levels of it, re-centred once. A cell that is more than half
//!    platform gets the platform's level whatever lies in the rest (a part's edge, a speck),
//!    because the values of the minority lie more than `TRIM` away or are too few to move the
//!    peak. A cell whose peak holds less than a quarter of its pixels has no level.
//! 2. **A smooth surface through the platform's cells.** Parts cover cells too, and their levels
//!    lie far from the platform's (a part of either polarity: dark on a backlight, bright or
//!    dark on a belt). A low-order 2-D polynomial (products of Chebyshev polynomials `T_i(u)·T_j(v)`,
//!    `i + j ≤ 4`, over the frame scaled to `[−1, 1]²`; degree 2 first) is fitted to the
//!    cells' levels by least squares. The first fit is to the cells reached from the frame's
//!    edge: the edge cells within `max(`[`MIN_OUTLIER`]`, 4 × 1.4826 × MAD)` of the edge's
//!    median level, then every cell within that of a reached neighbour's level. The platform
//!    surrounds the parts and meets the frame's edge nearly all the way round, and changes
//!    smoothly from cell to cell, while a part's edge is a step of its contrast; so a part over
//!    half of the frame (more than half of the cells: the median of all cells is then the
//!    part's level, or falls between the two and every cell is kept) is not taken for the
//!    platform. Each later fit keeps the cells within `max(`[`MIN_OUTLIER`]`, 4 × 1.4826 × MAD)`
//!    of the last one, the MAD of all cells' residuals while the last round kept most cells
//!    (the median is then a platform cell's), of the kept cells' otherwise. Vignetting and
//!    fall-off are smooth, so they are in the surface; the parts are not. (Without a level on
//!    the frame's edge, the first cut is the median level's, within `4 ×` [`MIN_OUTLIER`] or
//!    the MAD's threshold.)
//! 3. **Fill and spread.** The kept cells keep their own level (so the platform may deviate from
//!    the polynomial where it really does); the others take the surface plus their kept
//!    neighbours' mean residual, spread cell by cell from the kept ones.
//! 4. **Plane.** Each pixel of the model is the bilinear interpolation of the cell levels at
//!    the cell centres, rounded to `u8` (clamped at the frame's edge).
//!
//! The estimate holds while the platform shows in more than half of the cells along the frame's
//! edge and around a covered area; a part larger than the frame, or a frame that is all part, is
//! taken as the platform
//! (no part is found, and [`PlatformStats::kept`] says how many cells looked alike). A uniform
//! frame gives a flat plane.
//!
//! Time: the cell levels read at most 64 pixels a cell; the fit is per cell (the normal
//! equations summed a grid row at a time, 30 products a cell, up to [`FIT_ROUNDS`] rounds with a
//! 15×15 solve each; the surface evaluated from each row's coefficients, 5 products a cell;
//! the growth from the edge a few sweeps over the cells, 8 neighbours a cell);
//! the plane is written once, a multiply-add and a shift a pixel. Memory: the caller's
//! [`PlatformGrid`] (`9·G` bytes), a 512-byte histogram and a table of the plane's segments on
//! the stack.

use crate::error::{Error, Result};
use crate::pixels::enhance::{enhance_span, Alpha};
use crate::pixels::frame::Frame;

/// Smallest cell side, px.
pub const MIN_CELL: usize = 16;
/// Smallest step between the pixels a cell level is read from, along a row and down a column.
pub const SAMPLE: usize = 2;
/// A cell level is read from at most `SAMPLES_ALONG`² pixels: every `t`-th pixel of every
/// `t`-th row, `t = max(`[`SAMPLE`]`, ⌈s / SAMPLES_ALONG⌉)` (a cell of the smallest size, 16 px,
/// has 64 samples; a larger cell no more). The platform is smooth over a cell, and 64 values
/// find its level within a fraction of a grey level; more only cost time.
pub const SAMPLES_ALONG: usize = 8;
/// Cells along the frame's longer side (at least [`MIN_CELL`] px each): the grid has the same
/// shape for a camera of any resolution.
pub const CELLS_ALONG: usize = 20;
/// Half-width of the window around a cell's histogram peak that its level is the mean of,
/// grey levels.
pub const TRIM: i32 = 8;
/// Least residual (grey levels) that excludes a cell from the surface fit.
pub const MIN_OUTLIER: f32 = 10.0;
/// Rounds of the surface fit (degree 0, 2, then 4 for the rest).
pub const FIT_ROUNDS: usize = 4;
/// Terms of the degree-4 surface.
const TERMS: usize = 15;

/// Cell of a [`PlatformGrid`]: what it holds.
const NO_LEVEL: u8 = 0;
const LEVEL: u8 = 1;
const KEPT: u8 = 2;
const FILLED: u8 = 3;

/// Storage of the platform estimate: up to `G` cells.
///
/// ```
/// use vorl_core::pixels::platform::PlatformGrid;
/// let grid = PlatformGrid::<512>::new();
/// assert_eq!(PlatformGrid::<512>::BYTES, 9 * 512);
/// # let _ = grid;
/// ```
#[derive(Debug, Clone)]
pub struct PlatformGrid<const G: usize> {
    level: [f32; G],
    value: [f32; G],
    state: [u8; G],
}

impl<const G: usize> Default for PlatformGrid<G> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const G: usize> PlatformGrid<G> {
    /// Bytes of the grid's buffers.
    pub const BYTES: usize = 9 * G;

    /// An empty grid (`const`, for `static` use).
    pub const fn new() -> Self {
        PlatformGrid {
            level: [0.0; G],
            value: [0.0; G],
            state: [NO_LEVEL; G],
        }
    }
}

/// What the estimate found.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlatformStats {
    /// Cell side, px.
    pub cell: usize,
    /// Cells across.
    pub cells_x: usize,
    /// Cells down.
    pub cells_y: usize,
    /// Cells with a level.
    pub with_level: usize,
    /// Cells taken as platform (the surface's support).
    pub kept: usize,
    /// Degree of the last surface fitted.
    pub degree: usize,
    /// Threshold of the last round, grey levels.
    pub outlier: f32,
    /// Lowest and highest level of the plane's cells.
    pub range: [f32; 2],
}

/// The cell side for a `width`×`height` frame and `cells` cells of capacity: the smallest side
/// `≥ MIN_CELL` whose grid fits.
///
/// # Errors
/// [`Error::Capacity`] when `cells` is 0 and [`Error::EmptyFrame`] for an empty frame.
pub fn cell_size(width: usize, height: usize, cells: usize) -> Result<usize> {
    if width == 0 || height == 0 {
        return Err(Error::EmptyFrame { width, height });
    }
    if cells == 0 {
        return Err(Error::Capacity {
            what: "platform grid cells G",
            capacity: 0,
            requested: 1,
        });
    }
    let mut s = MIN_CELL.max(width.max(height).div_ceil(CELLS_ALONG));
    // Grows by at least one a round and ends at the frame's larger side (one cell).
    loop {
        let n = width.div_ceil(s).saturating_mul(height.div_ceil(s));
        if n <= cells || s >= width.max(height) {
            return Ok(s);
        }
        let scale = math_sqrt_ratio(n, cells);
        s = (s + 1).max((s as f32 * scale) as usize).min(width.max(height));
    }
}

/// `sqrt(n / cells)` rounded up a little, ≥ 1.
fn math_sqrt_ratio(n: usize, cells: usize) -> f32 {
    let r = crate::math::sqrt(n as f32 / cells.max(1) as f32);
    if r.is_finite() && r > 1.0 {
        r * 1.01
    } else {
        1.0
    }
}

/// Estimates the platform under `frame` (its `I'` for this `alpha`) into `plane`
/// (`width·height` bytes, row-major), using `grid` as storage. See the module doc.
///
/// ```
/// use vorl_core::{pixels::enhance::Alpha, pixels::platform::{estimate_platform, PlatformGrid}, Frame};
/// // A 64×48 backlight falling off from 240 (left) to 200 (right), with a dark 20×12 bar.
/// let (w, h) = (64, 48);
/// let mut px = vec![0u8; w * h];
/// for y in 0..h { for x in 0..w { px[y * w + x] = (240.0 - 40.0 * x as f32 / 63.0) as u8; } }
/// for y in 18..30 { for x in 22..42 { px[y * w + x] = 30; } }
/// let mut plane = vec![0u8; w * h];
/// let mut grid = PlatformGrid::<64>::new();
/// let frame = Frame::new_checked(&px[..], w, h).unwrap();
/// estimate_platform(&frame, Alpha::ONE, &mut plane, &mut grid).unwrap();
/// // Under the bar the platform is the light's, not the bar's.
/// let under = plane[24 * w + 32] as i32;
/// assert!((under - 220).abs() <= 3, "{under}");
/// ```
///
/// # Errors
/// [`Error::BufferTooSmall`] for `plane`; [`cell_size`]'s errors.
pub fn estimate_platform<B: AsRef<[u8]>, const G: usize>(
    frame: &Frame<B>,
    alpha: Alpha,
    plane: &mut [u8],
    grid: &mut PlatformGrid<G>,
) -> Result<PlatformStats> {
    let (w, h) = (frame.width(), frame.height());
    let needed = w.saturating_mul(h);
    if plane.len() < needed {
        return Err(Error::BufferTooSmall {
            needed,
            got: plane.len(),
        });
    }
    let s = cell_size(w, h, G)?;
    let (cx, cy) = (w.div_ceil(s), h.div_ceil(s));
    let cells = (cx * cy).min(G);
    let mut stats = PlatformStats {
        cell: s,
        cells_x: cx,
        cells_y: cy,
        ..PlatformStats::default()
    };
    // 1. Cell levels.
    for c in 0..cells {
        let (gx, gy) = (cell_x(c, cx), cell_y(c, cx));
        let level = cell_level(frame, alpha, gx * s, gy * s, s);
        if let (Some(l), Some(st)) = (grid.level.get_mut(c), grid.state.get_mut(c)) {
            match level {
                Some(v) => {
                    *l = v;
                    *st = LEVEL;
                    stats.with_level += 1;
                }
                None => {
                    *l = 0.0;
                    *st = NO_LEVEL;
                }
            }
        }
    }
    // 2. The surface through the platform's cells.
    let surface = fit_surface(grid, cx, cy, cells, &mut stats);
    // 3. Fill: kept cells keep their level; the others take the surface plus the residuals
    //    spread from their kept neighbours.
    let mut eval = Eval::new(&surface, cx, cy);
    for c in 0..cells {
        let fit = eval.at(c);
        if let (Some(&st), Some(&l), Some(v)) = (grid.state.get(c), grid.level.get(c), grid.value.get_mut(c)) {
            *v = if st == KEPT { l - fit } else { f32::NAN };
        }
    }
    spread_residuals(grid, cx, cy, cells);
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    let mut eval = Eval::new(&surface, cx, cy);
    for c in 0..cells {
        let fit = eval.at(c);
        if let Some(v) = grid.value.get_mut(c) {
            let r = if v.is_finite() { *v } else { 0.0 };
            *v = (fit + r).clamp(0.0, 255.0);
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
    }
    stats.range = [lo, hi];
    // 4. The plane (`level` is free now: one row's values at the cell centres).
    write_plane(&grid.value, &mut grid.level, cx, cy, s, w, h, plane);
    Ok(stats)
}

/// Column of cell `c` in a grid `cx` cells across (0 for an empty grid).
fn cell_x(c: usize, cx: usize) -> usize {
    c.checked_rem(cx).unwrap_or(0)
}

/// Row of cell `c` in a grid `cx` cells across (0 for an empty grid).
fn cell_y(c: usize, cx: usize) -> usize {
    c.checked_div(cx).unwrap_or(0)
}

/// The mode-trimmed mean of the cell at `(x0, y0)`, side `s` (cut by the frame's edge), or
/// `None` when its peak holds less than a quarter of its pixels.
fn cell_level<B: AsRef<[u8]>>(frame: &Frame<B>, alpha: Alpha, x0: usize, y0: usize, s: usize) -> Option<f32> {
    let (w, h) = (frame.width(), frame.height());
    let x1 = x0.saturating_add(s).min(w);
    let y1 = y0.saturating_add(s).min(h);
    let t = sample_step(s);
    let mut hist = [0u16; 256];
    let mut count = 0u32;
    let (mut lo_v, mut hi_v) = (255u8, 0u8);
    let mut add = |v: u8| {
        if let Some(b) = hist.get_mut(v as usize) {
            *b = b.saturating_add(1);
        }
        lo_v = lo_v.min(v);
        hi_v = hi_v.max(v);
        count += 1;
    };
    for y in (y0..y1).step_by(t) {
        if alpha.get() >= 1.0 {
            // `I' = I`: the row's own bytes.
            for &v in frame.row(y).get(x0..x1).unwrap_or(&[]).iter().step_by(t) {
                add(v);
            }
        } else {
            for x in (x0..x1).step_by(t) {
                let mut v = [0u8; 1];
                enhance_span(frame, y, x, alpha, &mut v);
                add(v[0]);
            }
        }
    }
    if count == 0 {
        return None;
    }
    // Peak of the histogram smoothed over 5 levels (only where the cell has values).
    let (first, last) = (lo_v as usize, hi_v as usize);
    let at = |v: usize| hist.get(v).copied().unwrap_or(0) as u32;
    let mut window: u32 = at(first)
        + at(first + 1)
        + at(first + 2)
        + first.checked_sub(1).map_or(0, at)
        + first.checked_sub(2).map_or(0, at);
    let (mut peak, mut peak_sum) = (first, window);
    for v in first + 1..=last {
        if v >= 3 {
            window -= hist.get(v - 3).copied().unwrap_or(0) as u32;
        }
        window += hist.get(v + 2).copied().unwrap_or(0) as u32;
        if window > peak_sum {
            (peak, peak_sum) = (v, window);
        }
    }
    let mut centre = peak as f32;
    let mut inside = 0u32;
    for _ in 0..2 {
        let c = crate::math::round(centre) as i32;
        let (lo, hi) = ((c - TRIM).max(0) as usize, (c + TRIM).min(255) as usize);
        let (mut sum, mut n) = (0u32, 0u32);
        for v in lo..=hi {
            let k = hist.get(v).copied().unwrap_or(0) as u32;
            sum += k * v as u32;
            n += k;
        }
        if n == 0 {
            return None;
        }
        centre = sum as f32 / n as f32;
        inside = n;
    }
    (4 * inside >= count).then_some(centre)
}

/// The step between the pixels a cell of side `s` is read from ([`SAMPLES_ALONG`]).
pub fn sample_step(s: usize) -> usize {
    SAMPLE.max(s.div_ceil(SAMPLES_ALONG))
}

/// A fitted surface: coefficients of `T_i(u)·T_j(v)`, `i + j ≤ degree`.
#[derive(Debug, Clone, Copy)]
struct Surface {
    coef: [f32; TERMS],
    degree: usize,
}

impl Surface {
    /// The surface along grid row `gy` of `cy`: the coefficients of `T_i(u)`, `i = 0..=4`.
    /// (The coefficients beyond the surface's degree are 0: `solve` leaves them so.)
    fn row(&self, gy: usize, cy: usize) -> [f32; 5] {
        let tv = cheb(cell_u(gy, cy));
        let mut a = [0.0f32; 5];
        for (&(i, j), &c) in TERM_UV.iter().zip(&self.coef) {
            if let (Some(ai), Some(&t)) = (a.get_mut(i), tv.get(j)) {
                *ai += c * t;
            }
        }
        a
    }
}

/// A [`Surface`] evaluated at the cell centres in the grid's order, one row's coefficients at a
/// time (five products a cell).
struct Eval<'s> {
    surface: &'s Surface,
    cx: usize,
    cy: usize,
    gy: usize,
    row: [f32; 5],
}

impl<'s> Eval<'s> {
    fn new(surface: &'s Surface, cx: usize, cy: usize) -> Self {
        Eval {
            surface,
            cx,
            cy,
            gy: usize::MAX,
            row: [0.0; 5],
        }
    }

    /// The surface at the centre of cell `c`.
    fn at(&mut self, c: usize) -> f32 {
        let (gx, gy) = (cell_x(c, self.cx), cell_y(c, self.cx));
        if gy != self.gy {
            self.gy = gy;
            self.row = self.surface.row(gy, self.cy);
        }
        let tu = cheb(cell_u(gx, self.cx));
        tu.iter().zip(&self.row).fold(0.0, |acc, (t, a)| acc + t * a)
    }
}

/// `T_0(x) … T_4(x)`, the Chebyshev polynomials.
fn cheb(x: f32) -> [f32; 5] {
    let t2 = 2.0 * x * x - 1.0;
    let t3 = 2.0 * x * t2 - x;
    let t4 = 2.0 * x * t3 - t2;
    [1.0, x, t2, t3, t4]
}

/// The surface's terms `T_i(u)·T_j(v)` as `(i, j)`, in order of `i + j`, then of `i`: the first `(d + 1)(d + 2)/2` are those of degree `≤ d`.
const TERM_UV: [(usize, usize); TERMS] = [
    (0, 0),
    (0, 1),
    (1, 0),
    (0, 2),
    (1, 1),
    (2, 0),
    (0, 3),
    (1, 2),
    (2, 1),
    (3, 0),
    (0, 4),
    (1, 3),
    (2, 2),
    (3, 1),
    (4, 0),
];

/// Cell index `g` of `n` scaled into `[−1, 1]` (its centre).
fn cell_u(g: usize, n: usize) -> f32 {
    if n <= 1 {
        0.0
    } else {
        2.0 * g as f32 / (n - 1) as f32 - 1.0
    }
}

/// Rounds of least squares on the cells with a level: the first on the cells reached from the
/// frame's edge ([`grow_from_edge`]), each later one on the cells within the threshold of the
/// previous fit. Marks the kept cells.
fn fit_surface<const G: usize>(
    grid: &mut PlatformGrid<G>,
    cx: usize,
    cy: usize,
    cells: usize,
    stats: &mut PlatformStats,
) -> Surface {
    // Round 0: the platform's cells connected to the frame's edge, or (a frame whose edge has
    // no level) a constant at the median level with a generous cut.
    let seeded = grow_from_edge(grid, cx, cy, cells);
    let median = median_of(grid, cells, |_, l, _| Some(l)).unwrap_or(0.0);
    let mut surface = Surface {
        coef: [0.0; TERMS],
        degree: 0,
    };
    if let Some(c) = surface.coef.get_mut(0) {
        *c = median;
    }
    for round in 0..FIT_ROUNDS {
        let (kept, outlier) = match seeded {
            Some(seed) if round == 0 => seed,
            _ => {
                // The threshold from the median residual of all cells while the last round kept
                // most of them (the median is then a platform cell's), else from the kept cells'
                // own: a part that covers half the frame, far from the platform, must not widen
                // it (the median of all would be a part cell's residual, and every cell kept).
                let first = seeded.is_none() && round == 0;
                let all = first || 2 * stats.kept > stats.with_level;
                let mut eval = Eval::new(&surface, cx, cy);
                let mad =
                    median_of(grid, cells, |c, l, kept| (all || kept).then(|| (l - eval.at(c)).abs())).unwrap_or(0.0);
                let outlier = (4.0 * 1.4826 * mad).max(MIN_OUTLIER);
                // A generous first cut: the median alone does not follow vignetting.
                let outlier = if first { outlier.max(4.0 * MIN_OUTLIER) } else { outlier };
                (mark_kept(grid, &surface, outlier, cx, cy, cells), outlier)
            }
        };
        stats.kept = kept;
        stats.outlier = outlier;
        let degree = match round {
            0 => 2,
            _ => 4,
        };
        // Enough support for the terms, or a lower degree.
        let degree = if kept >= 4 * TERMS {
            degree
        } else if kept >= 4 * 6 {
            degree.min(2)
        } else {
            0
        };
        match least_squares(grid, cx, cy, cells, degree) {
            Some(s) => surface = s,
            None => break,
        }
        stats.degree = surface.degree;
    }
    // Final membership against the last surface.
    stats.kept = mark_kept(grid, &surface, stats.outlier, cx, cy, cells);
    surface
}

/// Whether cell `(gx, gy)` lies on the edge of a `cx`×`cy` grid.
fn on_edge(gx: usize, gy: usize, cx: usize, cy: usize) -> bool {
    gx == 0 || gy == 0 || gx + 1 >= cx || gy + 1 >= cy
}

/// The first round's platform: the cells reached from the frame's edge. The platform surrounds
/// the parts: a part lies inside the frame or is cut by its edge over a short stretch, so the
/// cells along the edge are mostly platform even where a part covers half of the frame, or
/// more than half of its cells (the median of all cells is then the part's, or falls between
/// the two). The edge cells within `cut = max(`[`MIN_OUTLIER`]`, 4 × 1.4826 × MAD)` of their
/// median level are kept, then every cell whose level lies within `cut` of a kept
/// neighbour's (8-connected): the platform changes smoothly from cell to cell (vignetting,
/// fall-off; the edge's own spread sets `cut`, so a steep backlight widens it), a part's edge
/// is a step of its contrast. Marks the kept cells; `(kept, cut)`, or `None` (nothing marked)
/// when no edge cell has a level.
fn grow_from_edge<const G: usize>(
    grid: &mut PlatformGrid<G>,
    cx: usize,
    cy: usize,
    cells: usize,
) -> Option<(usize, f32)> {
    let edge = |c: usize| on_edge(cell_x(c, cx), cell_y(c, cx), cx, cy);
    let seed = median_of(grid, cells, |c, l, _| edge(c).then_some(l))?;
    let mad = median_of(grid, cells, |c, l, _| edge(c).then(|| (l - seed).abs())).unwrap_or(0.0);
    let cut = (4.0 * 1.4826 * mad).max(MIN_OUTLIER);
    let mut kept = 0;
    for c in 0..cells {
        if let (Some(st), Some(&l)) = (grid.state.get_mut(c), grid.level.get(c)) {
            if *st == LEVEL || *st == KEPT {
                *st = if edge(c) && (l - seed).abs() <= cut {
                    KEPT
                } else {
                    LEVEL
                };
                kept += (*st == KEPT) as usize;
            }
        }
    }
    // Sweeps down and up the grid until one adds nothing (a sweep carries the platform along
    // its direction at once; a few suffice but for winding gaps between parts).
    for pass in 0..cells {
        let mut added = 0;
        for i in 0..cells {
            let c = if pass % 2 == 0 { i } else { cells - 1 - i };
            if grid.state.get(c) != Some(&LEVEL) {
                continue;
            }
            let l = grid.level.get(c).copied().unwrap_or(0.0);
            let (gx, gy) = (cell_x(c, cx), cell_y(c, cx));
            let mut reached = false;
            for ny in gy.saturating_sub(1)..=(gy + 1).min(cy.saturating_sub(1)) {
                for nx in gx.saturating_sub(1)..=(gx + 1).min(cx.saturating_sub(1)) {
                    let k = ny * cx + nx;
                    if k < cells
                        && grid.state.get(k) == Some(&KEPT)
                        && grid.level.get(k).is_some_and(|&m| (m - l).abs() <= cut)
                    {
                        reached = true;
                    }
                }
            }
            if reached {
                if let Some(st) = grid.state.get_mut(c) {
                    *st = KEPT;
                    added += 1;
                }
            }
        }
        kept += added;
        if added == 0 {
            break;
        }
    }
    Some((kept, cut))
}

/// Marks every cell with a level as kept when it lies within `outlier` of `surface` (else as
/// a plain level); returns how many are kept.
fn mark_kept<const G: usize>(
    grid: &mut PlatformGrid<G>,
    surface: &Surface,
    outlier: f32,
    cx: usize,
    cy: usize,
    cells: usize,
) -> usize {
    let mut kept = 0;
    let mut eval = Eval::new(surface, cx, cy);
    for c in 0..cells {
        let fit = eval.at(c);
        if let (Some(st), Some(&l)) = (grid.state.get_mut(c), grid.level.get(c)) {
            if *st == LEVEL || *st == KEPT {
                *st = if (l - fit).abs() <= outlier { KEPT } else { LEVEL };
                kept += (*st == KEPT) as usize;
            }
        }
    }
    kept
}

/// The median of `f(cell, level, kept)` over the cells with a level (`value` is scratch).
fn median_of<const G: usize>(
    grid: &mut PlatformGrid<G>,
    cells: usize,
    mut f: impl FnMut(usize, f32, bool) -> Option<f32>,
) -> Option<f32> {
    let mut n = 0;
    for c in 0..cells {
        let (Some(&st), Some(&l)) = (grid.state.get(c), grid.level.get(c)) else {
            continue;
        };
        if st == NO_LEVEL {
            continue;
        }
        if let Some(v) = f(c, l, st == KEPT).filter(|v| v.is_finite()) {
            if let Some(slot) = grid.value.get_mut(n) {
                *slot = v;
                n += 1;
            }
        }
    }
    let values = grid.value.get_mut(..n)?;
    crate::math::select_nth(values, n / 2)
}

/// Least squares of the kept cells' levels on the degree-`degree` basis (`None` when singular
/// or no cell is kept). The normal equations are summed a grid row at a time: the basis is a
/// product `T_i(u)·T_j(v)` and `v` is the row's, so the row's kept cells give the sums of
/// `T_i(u)·T_k(u)` and `T_i(u)·level` (30 products a cell), and the row adds those times
/// `T_j(v)·T_l(v)` to every entry (instead of 225 products a cell).
fn least_squares<const G: usize>(
    grid: &PlatformGrid<G>,
    cx: usize,
    cy: usize,
    cells: usize,
    degree: usize,
) -> Option<Surface> {
    let d = degree.min(4);
    let terms = (d + 1) * (d + 2) / 2;
    let mut a = [[0.0f32; TERMS]; TERMS];
    let mut b = [0.0f32; TERMS];
    let mut any = false;
    for gy in 0..cy {
        let mut m = [[0.0f32; 5]; 5];
        let mut r = [0.0f32; 5];
        let mut in_row = false;
        for gx in 0..cx {
            let c = gy * cx + gx;
            if c >= cells {
                break;
            }
            if grid.state.get(c) != Some(&KEPT) {
                continue;
            }
            let l = grid.level.get(c).copied().unwrap_or(0.0);
            let tu = cheb(cell_u(gx, cx));
            for ((mi, ri), &ti) in m.iter_mut().zip(r.iter_mut()).zip(&tu) {
                *ri += ti * l;
                for (mik, &tk) in mi.iter_mut().zip(&tu) {
                    *mik += ti * tk;
                }
            }
            in_row = true;
        }
        if !in_row {
            continue;
        }
        any = true;
        let tv = cheb(cell_u(gy, cy));
        let at = |m: &[[f32; 5]; 5], i: usize, k: usize| m.get(i).and_then(|row| row.get(k)).copied().unwrap_or(0.0);
        let tv_at = |j: usize| tv.get(j).copied().unwrap_or(0.0);
        for ((row, bt), &(i, j)) in a.iter_mut().zip(b.iter_mut()).zip(&TERM_UV).take(terms) {
            let vj = tv_at(j);
            *bt += vj * r.get(i).copied().unwrap_or(0.0);
            for (e, &(k, l)) in row.iter_mut().zip(&TERM_UV).take(terms) {
                *e += at(&m, i, k) * vj * tv_at(l);
            }
        }
    }
    if !any {
        return None;
    }
    let coef = solve(&mut a, &mut b, terms)?;
    Some(Surface { coef, degree: d })
}

/// Gaussian elimination with partial pivoting on the first `n` rows and columns.
fn solve(a: &mut [[f32; TERMS]; TERMS], b: &mut [f32; TERMS], n: usize) -> Option<[f32; TERMS]> {
    let n = n.min(TERMS);
    let at =
        |a: &[[f32; TERMS]; TERMS], r: usize, c: usize| a.get(r).and_then(|row| row.get(c)).copied().unwrap_or(0.0);
    // A light ridge keeps a grid with few kept cells solvable.
    let scale = (0..n).map(|i| at(a, i, i)).fold(0.0f32, f32::max);
    if !(scale > 0.0) {
        return None;
    }
    for (i, row) in a.iter_mut().enumerate().take(n) {
        if let Some(v) = row.get_mut(i) {
            *v += 1e-6 * scale;
        }
    }
    for col in 0..n {
        let mut pivot = col;
        for r in col + 1..n {
            if at(a, r, col).abs() > at(a, pivot, col).abs() {
                pivot = r;
            }
        }
        if !(at(a, pivot, col).abs() > 1e-12 * scale) {
            return None;
        }
        a.swap(col, pivot.min(TERMS - 1));
        b.swap(col, pivot.min(TERMS - 1));
        let p = at(a, col, col);
        let pivot_row = a.get(col).copied().unwrap_or([0.0; TERMS]);
        let pivot_b = b.get(col).copied().unwrap_or(0.0);
        for (row, rb) in a.iter_mut().zip(b.iter_mut()).take(n).skip(col + 1) {
            let f = row.get(col).copied().unwrap_or(0.0) / p;
            if f == 0.0 {
                continue;
            }
            for (x, y) in row.iter_mut().zip(pivot_row.iter()).skip(col).take(n - col) {
                *x -= f * y;
            }
            *rb -= f * pivot_b;
        }
    }
    let mut x = [0.0f32; TERMS];
    for i in (0..n).rev() {
        let mut s = b.get(i).copied().unwrap_or(0.0);
        for (j, xj) in x.iter().enumerate().take(n).skip(i + 1) {
            s -= at(a, i, j) * xj;
        }
        if let Some(xi) = x.get_mut(i) {
            *xi = s / at(a, i, i);
        }
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Gives every cell without a residual (NaN in `value`) the mean of its 8 neighbours' that
/// have one, a ring at a time from the kept cells; cells no kept cell reaches keep NaN.
fn spread_residuals<const G: usize>(grid: &mut PlatformGrid<G>, cx: usize, cy: usize, cells: usize) {
    // Each pass reaches one ring further; `level` holds the pass's new values.
    for _ in 0..cx.max(cy) {
        let mut changed = false;
        for c in 0..cells {
            if grid.value.get(c).is_none_or(|v| v.is_finite()) {
                continue;
            }
            let (gx, gy) = (cell_x(c, cx) as isize, cell_y(c, cx) as isize);
            let (mut sum, mut n) = (0.0f32, 0u32);
            for dy in -1..=1isize {
                for dx in -1..=1isize {
                    let (x, y) = (gx + dx, gy + dy);
                    if (dx, dy) == (0, 0) || x < 0 || y < 0 || x >= cx as isize || y >= cy as isize {
                        continue;
                    }
                    let k = y as usize * cx + x as usize;
                    // Only cells filled before this pass (not FILLED in it).
                    if grid.state.get(k) == Some(&FILLED) {
                        continue;
                    }
                    if let Some(v) = grid.value.get(k).filter(|v| v.is_finite()) {
                        sum += v;
                        n += 1;
                    }
                }
            }
            if n > 0 {
                if let (Some(l), Some(st)) = (grid.level.get_mut(c), grid.state.get_mut(c)) {
                    *l = sum / n as f32;
                    *st = FILLED;
                    changed = true;
                }
            }
        }
        // Commit the pass.
        for c in 0..cells {
            if grid.state.get(c) == Some(&FILLED) {
                let l = grid.level.get(c).copied().unwrap_or(0.0);
                if let (Some(v), Some(st)) = (grid.value.get_mut(c), grid.state.get_mut(c)) {
                    *v = l;
                    *st = NO_LEVEL;
                }
            }
        }
        if !changed {
            break;
        }
    }
}

/// The centre of cell `g` of side `s` along an axis of `len` px (the last cell may be cut).
fn cell_centre(g: usize, s: usize, len: usize) -> f32 {
    twice_centre(g, s, len) as f32 * 0.5
}

/// The two cells whose centres bracket row `x` along an axis of `n` cells (the outer pair
/// beyond the outermost centres, so the plane extrapolates there) and the weight of the second.
fn bracket(x: usize, s: usize, len: usize, n: usize) -> (usize, usize, f32) {
    if n <= 1 {
        return (0, 0, 0.0);
    }
    let mut g = (x / s.max(1)).min(n - 1);
    if g > 0 && (x as f32) < cell_centre(g, s, len) {
        g -= 1;
    }
    let g = g.min(n - 2);
    let (c0, c1) = (cell_centre(g, s, len), cell_centre(g + 1, s, len));
    let t = if c1 > c0 { (x as f32 - c0) / (c1 - c0) } else { 0.0 };
    (g, g + 1, t)
}

/// The plane: the cell values (at the cell centres) bilinearly interpolated, extrapolated
/// linearly beyond the outermost centres, rounded. `row` (at least `cx` values) is scratch for
/// one row's values at the cell centres; along the row the value then grows by a constant step
/// between two centres, so a pixel costs an addition.
#[allow(clippy::too_many_arguments)]
fn write_plane(values: &[f32], row: &mut [f32], cx: usize, cy: usize, s: usize, w: usize, h: usize, plane: &mut [u8]) {
    let cell = |gx: usize, gy: usize| values.get(gy * cx + gx).copied().unwrap_or(0.0);
    // The segments, once for all rows.
    let mut segments = [Segment::default(); MAX_ALONG];
    let mut from = 0;
    for (g, seg) in segments.iter_mut().enumerate().take(cx.saturating_sub(1)) {
        *seg = Segment::new(g, cx, s, w, from);
        from = seg.end;
    }
    for (y, out) in plane.chunks_exact_mut(w.max(1)).take(h).enumerate() {
        let (gy0, gy1, ty) = bracket(y, s, h, cy);
        for (gx, r) in row.iter_mut().enumerate().take(cx) {
            *r = cell(gx, gy0) * (1.0 - ty) + cell(gx, gy1) * ty;
        }
        if cx <= 1 {
            let v = row.first().copied().unwrap_or(0.0);
            out.iter_mut().for_each(|p| *p = (v + 0.5).clamp(0.0, 255.0) as u8);
            continue;
        }
        // Segment g runs from the centre of cell g to that of g + 1 (the first from x = 0, the
        // last to the row's end). In 1/65536 of a level, rounded at the end; the centres are
        // kept doubled (`first + last` of the cell's pixels), so the geometry is integer.
        let fixed = |f: f32| (f * 65536.0) as i32;
        let mut r1 = row.first().copied().unwrap_or(0.0);
        let mut prev_end = 0;
        for g in 0..cx - 1 {
            let seg = segments
                .get(g)
                .copied()
                .unwrap_or_else(|| Segment::new(g, cx, s, w, prev_end));
            prev_end = seg.end;
            let r0 = r1;
            r1 = row.get(g + 1).copied().unwrap_or(0.0);
            // The step per pixel: (r1 − r0) over (a1 − a0)/2 pixels (one float division; a
            // 64-bit one is a library call on the camera).
            let dv = if seg.twice_len > 0 {
                fixed((r1 - r0) * 2.0 / seg.twice_len as f32)
            } else {
                0
            };
            // The value at x: r0 + ½ + (x − a0/2)·dv (the product in 64 bits, halved by a shift).
            let v = (fixed(r0 + 0.5) as i64 + (((2 * seg.from as i64 - seg.a0 as i64) * dv as i64) >> 1)) as i32;
            let span = out.get_mut(seg.from..seg.end).unwrap_or(&mut []);
            // The values run linearly from the first pixel's to the last's: when both lie in
            // 0..=255 every one does, and none needs clamping (between two centres, always:
            // the cell values are clamped; beyond the outermost ones, mostly).
            let last = v.wrapping_add((span.len().saturating_sub(1) as i32).wrapping_mul(dv));
            let in_range = |a: i32| (0..256 << 16).contains(&a);
            if in_range(v) && in_range(last) {
                // Each pixel `v + k·dv`, an induction the loop vectorises.
                let mut at = v;
                for p in span.iter_mut() {
                    *p = (at >> 16) as u8;
                    at = at.wrapping_add(dv);
                }
            } else {
                for (k, p) in span.iter_mut().enumerate() {
                    let at = v.wrapping_add((k as i32).wrapping_mul(dv));
                    *p = (at >> 16).clamp(0, 255) as u8;
                }
            }
        }
    }
}

/// Most cells along a side of the grid: [`cell_size`] keeps the longer side at
/// [`CELLS_ALONG`] (the plane's segments are kept in a table of this size; a grid with more
/// would take them as it goes).
const MAX_ALONG: usize = CELLS_ALONG + 1;

/// One segment of a plane row, the same in every row: from the centre of cell `g` to that of
/// `g + 1` (the first from x = 0, the last to the row's end).
#[derive(Debug, Clone, Copy, Default)]
struct Segment {
    /// Twice the centre of cell `g`.
    a0: usize,
    /// Twice the distance between the two centres.
    twice_len: usize,
    /// Pixels `from..end`.
    from: usize,
    end: usize,
}

impl Segment {
    /// Segment `g` of a row of `cx` cells of side `s`, `w` px long, starting at `from` (the
    /// previous segment's end).
    fn new(g: usize, cx: usize, s: usize, w: usize, from: usize) -> Self {
        let (a0, a1) = (twice_centre(g, s, w), twice_centre(g + 1, s, w));
        let end = if g + 2 == cx { w } else { (a1 / 2 + 1).min(w) };
        let from = if g == 0 { 0 } else { from.min(w) };
        Segment {
            a0,
            twice_len: a1.saturating_sub(a0),
            from,
            end: end.max(from),
        }
    }
}

/// Twice the centre of cell `g` of side `s` along an axis of `len` px ([`cell_centre`]), an
/// integer (saturating).
fn twice_centre(g: usize, s: usize, len: usize) -> usize {
    let first = g.saturating_mul(s);
    let last = first.saturating_add(s).min(len).saturating_sub(1).max(first);
    first.saturating_add(last)
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::vec;

    fn run(px: &[u8], w: usize, h: usize) -> (std::vec::Vec<u8>, PlatformStats) {
        let mut plane = vec![0u8; w * h];
        let mut grid: std::boxed::Box<PlatformGrid<4096>> = std::boxed::Box::default();
        let frame = Frame::new_checked(px, w, h).unwrap();
        let st = estimate_platform(&frame, Alpha::ONE, &mut plane, &mut grid).unwrap();
        (plane, st)
    }

    /// A vignetted backlight (centre 250, corners about 150) with dark parts and a hole: the
    /// estimate follows the light under the parts within 4 levels (the frame's noise is ±2,
    /// and the corners are extrapolated).
    #[test]
    fn follows_vignetting_under_dark_parts() {
        let (w, h) = (256usize, 240usize);
        let light = |x: usize, y: usize| {
            let (u, v) = ((x as f32 - 128.0) / 128.0, (y as f32 - 120.0) / 120.0);
            250.0 - 50.0 * (u * u + v * v)
        };
        let mut px = vec![0u8; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut v = light(x, y);
                let in_bar = (40..200).contains(&x) && (100..130).contains(&y);
                let in_ring = ((x as f32 - 60.0).powi(2) + (y as f32 - 50.0).powi(2)).sqrt();
                if in_bar || (12.0..26.0).contains(&in_ring) {
                    v = 25.0;
                }
                // A little deterministic noise.
                v += ((x * 7 + y * 13) % 5) as f32 - 2.0;
                px[y * w + x] = v.clamp(0.0, 255.0) as u8;
            }
        }
        let (plane, st) = run(&px, w, h);
        assert!(st.kept > st.cells_x * st.cells_y / 2, "{st:?}");
        let mut worst = 0.0f32;
        for y in 0..h {
            for x in 0..w {
                worst = worst.max((plane[y * w + x] as f32 - light(x, y)).abs());
            }
        }
        assert!(worst <= 4.0, "worst {worst} {st:?}");
    }

    /// Printed paper (about 205, a gentle slope, rows of dark glyph strokes 120 levels below it
    /// and a ruled line under each row) under one uniform part over 40 % of the frame, dark or
    /// bright, and the paper itself: the plane stays within a few levels of the paper everywhere
    /// (under the part too). The median of the cells was the part's, or fell between the part and
    /// the paper and every cell was kept.
    #[test]
    fn a_part_over_much_of_printed_paper_is_not_platform() {
        let (w, h) = (320usize, 240usize);
        let paper = |x: usize, y: usize| 203.0 + 8.0 * x as f32 / w as f32 - 5.0 * y as f32 / h as f32;
        for (level, a, b) in [(60.0f32, 128.0f32, 92.0f32), (245.0, 128.0, 92.0), (60.0, 112.0, 80.0)] {
            let mut px = vec![0u8; w * h];
            let mut part = 0usize;
            for y in 0..h {
                for x in 0..w {
                    let mut v = paper(x, y);
                    let (row, col) = (y % 12, x % 6);
                    let written = (y / 12) % 5 != 4 && (x / 6 + 3 * (y / 12)) % 7 != 0;
                    if written && (2..9).contains(&row) && col < 2 {
                        v -= 120.0;
                    }
                    if row == 10 {
                        v -= 50.0;
                    }
                    let (u, t) = ((x as f32 - 170.0) / a, (y as f32 - 118.0) / b);
                    if u * u + t * t <= 1.0 {
                        v = level;
                        part += 1;
                    }
                    v += ((x * 7 + y * 13) % 5) as f32 - 2.0;
                    px[y * w + x] = v.clamp(0.0, 255.0) as u8;
                }
            }
            let share = part as f32 / (w * h) as f32;
            assert!((0.33..0.5).contains(&share), "{share}");
            let (plane, st) = run(&px, w, h);
            let mut worst = 0.0f32;
            for y in 0..h {
                for x in 0..w {
                    worst = worst.max((plane[y * w + x] as f32 - paper(x, y)).abs());
                }
            }
            assert!(worst <= 4.0, "part {level}, {share}: worst {worst} {st:?}");
        }
    }

    /// Parts of both polarities on a flat belt: both are found as not platform.
    #[test]
    fn both_polarities_are_parts() {
        let (w, h) = (160usize, 120usize);
        let mut px = vec![120u8; w * h];
        for y in 20..60 {
            for x in 20..70 {
                px[y * w + x] = 60;
            }
        }
        for y in 60..110 {
            for x in 90..150 {
                px[y * w + x] = 200;
            }
        }
        let (plane, _) = run(&px, w, h);
        assert!(plane.iter().all(|&p| (p as i32 - 120).abs() <= 1));
    }

    /// A uniform frame gives a flat plane; a one-pixel frame and a frame of one cell work.
    #[test]
    fn uniform_and_tiny_frames() {
        let (plane, st) = run(&[77u8; 50 * 30], 50, 30);
        assert!(plane.iter().all(|&p| p == 77), "{st:?}");
        let (plane, _) = run(&[9u8], 1, 1);
        assert_eq!(plane, [9]);
    }

    /// Errors: a short plane, an empty grid.
    #[test]
    fn errors() {
        let px = [1u8; 20];
        let frame = Frame::new_checked(&px[..], 5, 4).unwrap();
        let mut grid = PlatformGrid::<4>::new();
        let mut plane = [0u8; 19];
        assert!(matches!(
            estimate_platform(&frame, Alpha::ONE, &mut plane, &mut grid),
            Err(Error::BufferTooSmall { needed: 20, got: 19 })
        ));
        let mut grid = PlatformGrid::<0>::new();
        let mut plane = [0u8; 20];
        assert!(matches!(
            estimate_platform(&frame, Alpha::ONE, &mut plane, &mut grid),
            Err(Error::Capacity { .. })
        ));
    }

    /// The cell side grows until the grid fits.
    #[test]
    fn cell_sizes() {
        assert_eq!(cell_size(320, 240, 512).unwrap(), 16);
        let s = cell_size(640, 480, 512).unwrap();
        assert!(640usize.div_ceil(s) * 480usize.div_ceil(s) <= 512 && s > 16);
        assert_eq!(cell_size(10_000, 3, 1).unwrap(), 10_000);
    }
}
