//! The fast path of the profiles: [`Difference::edge_offset`] and [`Difference::bilinear`] as
//! they run, each tested equal, bit for bit, to its definition in the module's first file
//! (every sample by [`sample_by_pixels`], four clamped pixels of [`Difference::at`]; every
//! crossing, the nearest kept). The alignment reads one profile per edge point and step, most
//! of its work (`docs/performance.md`), so the reading is cut down without changing a value:
//!
//! - **Outwards** ([`nearest_crossing`]): round `r` visits the two intervals between `r` and
//!   `r + 1` steps from the point, and the scan stops once no farther interval can hold a
//!   nearer crossing (of two at the same distance the inner wins, as in the definition).
//! - **One cell a side**: consecutive samples in the same pixel cell reuse its bilinear
//!   coefficients (exact: the cells hold integer differences), one cache for each side.
//! - **Three readers** ([`Cells`]): the [`EdgeFinder`]'s direct path for a profile whose every
//!   sample lies at least 1/64 px inside the image (`α = 1`, up to [`DIRECT_MAX_SIDE`] px a
//!   side: its positions counted from the image's origin, its cells straight from the frame and
//!   background buffers); a [`Window`] for a ray whose cells lie inside (indices from its base
//!   pixel's); [`Clamped`] pixels elsewhere, which is the definition itself.
//!
//! Cost: at most `2·steps + 1` samples a profile, about a third of them for a pose near the
//! edge, each at most one cell read. Memory: a few numbers a profile (the two cached cells).
//! Guards: the look-ups are checked slices (a background plane shorter than the frame falls
//! back to the clamped pixels, which read 0 where it ends); a profile on the direct path has
//! its ends, which bound every sample, inside the image.

use crate::pixels::frame::Frame;
#[cfg(doc)]
use crate::pose::refine::sample_by_pixels;
use crate::pose::refine::{
    coefficients, evaluate, fixed_delta, Difference, ProfileRay, RefineParams, MAX_PROFILE_STEPS, RAY_FRACTION_BITS,
};

impl<'a, B: AsRef<[u8]>> Difference<'a, B> {
    /// [`Self::bilinear`] through a one-cell cache: where `α = 1` and the 2×2 neighbourhood lies
    /// inside the image, its four differences are read once into `cell` and reused while the
    /// position stays in that cell (consecutive samples of a profile mostly do); elsewhere
    /// [`Self::bilinear_by_pixels`]. Either way the same arithmetic, so the same value.
    #[inline(always)]
    pub(super) fn bilinear_cached(&self, x: f32, y: f32, cell: &mut Cell) -> f32 {
        if !(self.alpha.get() >= 1.0 && x >= 0.0 && y >= 0.0) {
            return self.bilinear_by_pixels(x, y);
        }
        // Truncation is the floor for non-negative values; through `i32`, a cheap conversion on
        // the host and the M4 (a value beyond its range saturates and fails the look-ups).
        let (ix, iy) = (x as i32, y as i32);
        let (tx, ty) = (x - ix as f32, y - iy as f32);
        let (ix, iy) = (ix as usize, iy as usize);
        if cell.at != (ix, iy) {
            match self.cell(ix, iy) {
                Some(d) => *cell = Cell { at: (ix, iy), d },
                None => return self.bilinear_by_pixels(x, y),
            }
        }
        let [d00, d01, d10, d11] = cell.d;
        let top = d00 * (1.0 - tx) + d01 * tx;
        let bottom = d10 * (1.0 - tx) + d11 * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// `D` at `(ix, iy)`, `(ix + 1, iy)`, `(ix, iy + 1)` and `(ix + 1, iy + 1)` for `α = 1`, or
    /// `None` unless all four lie inside the image (and the background plane). The look-ups are
    /// the bounds checks: row `iy + 1` exists and holds columns `ix..ix + 2` exactly when the
    /// cell lies inside.
    #[inline(always)]
    fn cell(&self, ix: usize, iy: usize) -> Option<[f32; 4]> {
        let &[f00, f01] = self.frame.row(iy).get(ix..ix.checked_add(2)?)? else {
            return None;
        };
        let &[f10, f11] = self.frame.row(iy.checked_add(1)?).get(ix..ix + 2)? else {
            return None;
        };
        // Inside the image, so `iy·w + ix + w + 2` cannot overflow.
        let w = self.frame.width();
        let b = iy * w + ix;
        let &[b00, b01] = self.background.get(b..b + 2)? else {
            return None;
        };
        let &[b10, b11] = self.background.get(b + w..b + w + 2)? else {
            return None;
        };
        // The integer difference is exact, so it converts to the same `f32` as `f − g` would.
        let d = |f: u8, g: u8| (i32::from(f) - i32::from(g)) as f32;
        Some([d(f00, b00), d(f01, b01), d(f10, b10), d(f11, b11)])
    }

    /// What [`Self::edge_offset`] needs that does not change from profile to profile, worked
    /// out once for many profiles with the same `params`.
    pub fn edge_finder<'d>(&'d self, params: &RefineParams) -> EdgeFinder<'d, 'a, B> {
        let steps = (params.search / params.step) as i32;
        // A profile of more than MAX_PROFILE_STEPS samples a side (a step of 0 or NaN included)
        // is a misconfiguration, not a profile.
        let steps = if (2..=MAX_PROFILE_STEPS).contains(&steps) && params.step > 0.0 {
            steps
        } else {
            0
        };
        let (w, h) = (self.width(), self.height());
        let direct = (self.alpha.get() >= 1.0 && w.max(h) <= DIRECT_MAX_SIDE).then(|| Direct {
            frame: self.frame.pixels(),
            background: self.background,
            stride: self.frame.stride(),
            width: w,
            reach: steps as f32 * params.step,
            x_max: (w - 1) as f32 - DIRECT_MARGIN,
            y_max: (h - 1) as f32 - DIRECT_MARGIN,
        });
        EdgeFinder {
            diff: self,
            steps,
            step: params.step,
            min_contrast: params.min_contrast,
            direct,
        }
    }
}

/// [`Difference::edge_offset`] for many profiles with the same [`RefineParams`]
/// ([`Difference::edge_finder`]): the same results, with the profile length, the image's
/// buffers and bounds read once.
///
/// A profile whose every sample lies at least 1/64 px inside `[0, w − 1) × [0, h − 1)` (for
/// `α = 1` and images of up to [`DIRECT_MAX_SIDE`] px a side, nearly every profile) is read
/// on the direct path: its fixed-point positions counted from the image's origin (`p·2¹⁶`
/// truncated, which for `p ≥ 0` is the [`ProfileRay`]'s base pixel and start exactly), each
/// sample's cell straight from the buffers. Any other goes through a [`ProfileRay`].
#[derive(Debug, Clone, Copy)]
pub struct EdgeFinder<'d, 'a, B> {
    diff: &'d Difference<'a, B>,
    /// Samples a side; 0 for parameters that make no profile.
    steps: i32,
    step: f32,
    min_contrast: f32,
    direct: Option<Direct<'a>>,
}

/// Most pixels a side of an image whose profiles [`EdgeFinder`] reads on its direct path
/// (their positions times 2¹⁶ then fit an `i32` with room).
pub const DIRECT_MAX_SIDE: usize = 16384;

/// How far inside `[0, w − 1) × [0, h − 1)` the ends of a profile on the direct path must lie,
/// px: far more than its fixed-point positions can differ from `p + k·step·normal`.
const DIRECT_MARGIN: f32 = 1.0 / 64.0;

/// The direct path's view of the image: buffers, row lengths, and the bounds a profile's ends
/// must keep to.
#[derive(Debug, Clone, Copy)]
struct Direct<'a> {
    frame: &'a [u8],
    background: &'a [u8],
    stride: usize,
    width: usize,
    /// `steps·step`, px.
    reach: f32,
    x_max: f32,
    y_max: f32,
}

impl<'a, B: AsRef<[u8]>> EdgeFinder<'_, 'a, B> {
    /// [`Difference::edge_offset`]`(p, normal, params)` for this finder's `params`.
    pub fn offset(&self, p: [f32; 2], normal: [f32; 2]) -> Option<f32> {
        self.offset_inline(p, normal)
    }

    /// [`Self::offset`], inlined into the alignment's step.
    #[inline(always)]
    pub(super) fn offset_inline(&self, p: [f32; 2], normal: [f32; 2]) -> Option<f32> {
        let steps = self.steps;
        if steps == 0 {
            return None;
        }
        if let Some(direct) = &self.direct {
            // The ends bound every sample; NaN fails every comparison.
            let (ex, ey) = (direct.reach * normal[0], direct.reach * normal[1]);
            let (x0, x1, y0, y1) = (p[0] - ex, p[0] + ex, p[1] - ey, p[1] + ey);
            if x0.min(x1) >= DIRECT_MARGIN
                && y0.min(y1) >= DIRECT_MARGIN
                && x0.max(x1) <= direct.x_max
                && y0.max(y1) <= direct.y_max
            {
                const ONE: f32 = (1u32 << RAY_FRACTION_BITS) as f32;
                let cells = DirectCells {
                    diff: self.diff,
                    direct,
                    start: [(p[0] * ONE) as i32, (p[1] * ONE) as i32],
                    delta: [fixed_delta(self.step, normal[0]), fixed_delta(self.step, normal[1])],
                };
                return nearest_crossing(&cells, steps, self.step, self.min_contrast);
            }
        }
        let ray = ProfileRay::new(p, normal, self.step, steps)?;
        match Window::new(self.diff, &ray, steps) {
            Some(window) => nearest_crossing(&window, steps, self.step, self.min_contrast),
            None => nearest_crossing(&Clamped(self.diff, ray), steps, self.step, self.min_contrast),
        }
    }

    /// Whether [`Self::offset`] reads the profile on the direct path.
    #[cfg(test)]
    fn is_direct(&self, p: [f32; 2], normal: [f32; 2]) -> bool {
        self.direct.is_some_and(|d| {
            let (ex, ey) = (d.reach * normal[0], d.reach * normal[1]);
            let (x0, x1, y0, y1) = (p[0] - ex, p[0] + ex, p[1] - ey, p[1] + ey);
            x0.min(x1) >= DIRECT_MARGIN && y0.min(y1) >= DIRECT_MARGIN && x0.max(x1) <= d.x_max && y0.max(y1) <= d.y_max
        }) && self.steps > 0
    }
}

/// A profile on the direct path: fixed-point positions `start + k·delta` from the image's
/// origin, every cell inside the image.
struct DirectCells<'d, 'e, 'a, B> {
    diff: &'d Difference<'a, B>,
    direct: &'e Direct<'a>,
    start: [i32; 2],
    delta: [i32; 2],
}

impl<B: AsRef<[u8]>> Cells for DirectCells<'_, '_, '_, B> {
    type Cell = WindowCell;
    const EMPTY: WindowCell = WindowCell::EMPTY;

    #[inline(always)]
    fn sample(&self, k: i32, cell: &mut WindowCell) -> f32 {
        const MASK: i32 = (1 << RAY_FRACTION_BITS) - 1;
        const INV: f32 = 1.0 / (1u32 << RAY_FRACTION_BITS) as f32;
        let x = self.start[0].wrapping_add(k.wrapping_mul(self.delta[0]));
        let y = self.start[1].wrapping_add(k.wrapping_mul(self.delta[1]));
        // Non-negative: the profile's ends lie inside the image.
        let (ix, iy) = ((x >> RAY_FRACTION_BITS) as usize, (y >> RAY_FRACTION_BITS) as usize);
        let d = self.direct;
        let f = iy.wrapping_mul(d.stride).wrapping_add(ix);
        if cell.at != f {
            let b = iy.wrapping_mul(d.width).wrapping_add(ix);
            let frame = d.frame.get(f..f.wrapping_add(d.stride).wrapping_add(2));
            let background = d.background.get(b..b.wrapping_add(d.width).wrapping_add(2));
            let cells = match (frame, background) {
                (Some(&[f00, f01, .., f10, f11]), Some(&[b00, b01, .., b10, b11])) => {
                    let d = |f: u8, g: u8| (i32::from(f) - i32::from(g)) as f32;
                    [d(f00, b00), d(f01, b01), d(f10, b10), d(f11, b11)]
                }
                // A short background plane (it reads 0 where it ends, as the clamped path).
                _ => clamped_cell(
                    self.diff,
                    (x >> RAY_FRACTION_BITS) as isize,
                    (y >> RAY_FRACTION_BITS) as isize,
                ),
            };
            *cell = WindowCell {
                at: f,
                c: coefficients(cells),
            };
        }
        evaluate(cell.c, [(x & MASK) as f32 * INV, (y & MASK) as f32 * INV])
    }
}

/// [`Difference::cell_clamped`], out of line (the rare path).
#[cold]
#[inline(never)]
fn clamped_cell<B: AsRef<[u8]>>(diff: &Difference<'_, B>, ix: isize, iy: isize) -> [f32; 4] {
    diff.cell_clamped(ix, iy)
}

/// How [`Difference::edge_offset`] reads a profile's samples: through a one-cell cache.
trait Cells {
    /// The cache: the cell read last.
    type Cell: Copy;
    /// No cell yet.
    const EMPTY: Self::Cell;
    /// `D` at sample `k` of the profile ([`sample_by_pixels`]), through `cell`.
    fn sample(&self, k: i32, cell: &mut Self::Cell) -> f32;
}

/// The scan of [`Difference::edge_offset`] over samples `k` in `-steps..=steps` of a profile,
/// two caches (one a side of the profile).
#[inline(always)]
fn nearest_crossing<S: Cells>(cells: &S, steps: i32, step: f32, min_contrast: f32) -> Option<f32> {
    let sample = |k: i32, cell: &mut S::Cell| cells.sample(k, cell);
    // One cell cache for each side of the profile: the ends first, then the scan outwards.
    let (mut inner, mut outer) = (S::EMPTY, S::EMPTY);
    let outer_end = sample(-steps, &mut inner);
    let d_in = 0.5 * (outer_end + sample(-steps + 1, &mut inner));
    let d_out = 0.5 * (sample(steps, &mut outer) + sample(steps - 1, &mut outer));
    if !((d_in - d_out).abs() >= min_contrast) {
        return None;
    }
    let level = 0.5 * (d_in + d_out);
    let sign = if d_in > d_out { 1.0 } else { -1.0 };
    let centre = sign * (sample(0, &mut outer) - level);
    inner = outer;
    // Round r visits the intervals [r, r+1] and [−r−1, −r] (in steps), whose crossings lie
    // between r·step and (r+1)·step from p.
    // `neg` and `pos` hold the signed samples at −r and +r.
    let (mut neg, mut pos) = (centre, centre);
    let mut best: Option<f32> = None;
    for r in 0..steps {
        let before = sign
            * (if r + 1 == steps {
                outer_end
            } else {
                sample(-r - 1, &mut inner)
            } - level);
        let after = sign * (sample(r + 1, &mut outer) - level);
        for (k, prev, cur) in [(-r, before, neg), (r + 1, pos, after)] {
            if prev > 0.0 && cur <= 0.0 {
                let t = prev / (prev - cur);
                let u = ((k - 1) as f32 + t) * step;
                if best.is_none_or(|b| u.abs() < b.abs() || (u.abs() == b.abs() && u < b)) {
                    best = Some(u);
                }
            }
        }
        (neg, pos) = (before, after);
        if best.is_some_and(|b| b.abs() < (r + 1) as f32 * step) {
            break;
        }
    }
    best
}

/// A profile whose every cell lies inside the image, with `α = 1`: its cells are read from the
/// frame and background buffers at offsets from the indices of the ray's base pixel.
struct Window<'d, 'a, B> {
    diff: &'d Difference<'a, B>,
    ray: ProfileRay,
    frame: &'a [u8],
    background: &'a [u8],
    stride: usize,
    width: usize,
    /// Indices of the base pixel in the frame buffer and the background plane.
    frame_base: usize,
    background_base: usize,
}

impl<'d, 'a, B: AsRef<[u8]>> Window<'d, 'a, B> {
    /// The window of `ray` over `-steps..=steps`, or `None` unless `α = 1` and the cells of
    /// all its samples lie inside the image (the samples' pixels lie between those of the
    /// ends, and a cell reaches one pixel on).
    #[inline(always)]
    fn new(diff: &'d Difference<'a, B>, ray: &ProfileRay, steps: i32) -> Option<Self> {
        if !(diff.alpha.get() >= 1.0) {
            return None;
        }
        let ([x0, y0], _) = ray.at(-steps);
        let ([x1, y1], _) = ray.at(steps);
        let (w, h) = (diff.width() as isize, diff.height() as isize);
        if !(x0.min(x1) >= 0 && y0.min(y1) >= 0 && x0.max(x1) < w - 1 && y0.max(y1) < h - 1) {
            return None;
        }
        let (bx, by) = (ray.base[0] as usize, ray.base[1] as usize);
        let frame: &'a Frame<B> = diff.frame;
        let stride = frame.stride();
        let width = frame.width();
        // The base pixel lies within the image's extent (between the ends' pixels, or one
        // pixel beyond with a fraction): the indices are small.
        Some(Window {
            diff,
            ray: *ray,
            frame: frame.pixels(),
            background: diff.background,
            stride,
            width,
            frame_base: by.wrapping_mul(stride).wrapping_add(bx),
            background_base: by.wrapping_mul(width).wrapping_add(bx),
        })
    }
}

impl<B: AsRef<[u8]>> Cells for Window<'_, '_, B> {
    type Cell = WindowCell;
    const EMPTY: WindowCell = WindowCell::EMPTY;

    #[inline(always)]
    fn sample(&self, k: i32, cell: &mut WindowCell) -> f32 {
        let ([ox, oy], t) = self.ray.offset(k);
        let (ox, oy) = (ox as isize, oy as isize);
        let f = self
            .frame_base
            .wrapping_add_signed(oy.wrapping_mul(self.stride as isize).wrapping_add(ox));
        if cell.at != f {
            let b = self
                .background_base
                .wrapping_add_signed(oy.wrapping_mul(self.width as isize).wrapping_add(ox));
            // A cell's two rows as one run of `stride + 2` (or `width + 2`) bytes: its first two
            // and last two are the cell's pixels (the window's width is at least 2).
            let (s, w) = (self.stride, self.width);
            let frame = self.frame.get(f..f.wrapping_add(s).wrapping_add(2));
            let background = self.background.get(b..b.wrapping_add(w).wrapping_add(2));
            let d = match (frame, background) {
                // The integer difference is exact, so it converts to the same `f32` as the
                // clamped path's `f − g`.
                (Some(&[f00, f01, .., f10, f11]), Some(&[b00, b01, .., b10, b11])) => {
                    let d = |f: u8, g: u8| (i32::from(f) - i32::from(g)) as f32;
                    [d(f00, b00), d(f01, b01), d(f10, b10), d(f11, b11)]
                }
                // Not for a cell inside the image (a short background plane reads 0 there,
                // as the clamped path does).
                _ => cell_by_pixels(self.diff, &self.ray, k),
            };
            *cell = WindowCell {
                at: f,
                c: coefficients(d),
            };
        }
        evaluate(cell.c, t)
    }
}

/// The cell of sample `k` of `ray` from four clamped pixels, out of line (the rare path).
#[cold]
#[inline(never)]
fn cell_by_pixels<B: AsRef<[u8]>>(diff: &Difference<'_, B>, ray: &ProfileRay, k: i32) -> [f32; 4] {
    let ([ix, iy], _) = ray.at(k);
    clamped_cell(diff, ix, iy)
}

/// Profiles that reach beyond the image, or `α < 1`: cells from four clamped pixels.
struct Clamped<'d, 'a, B>(&'d Difference<'a, B>, ProfileRay);

impl<B: AsRef<[u8]>> Cells for Clamped<'_, '_, B> {
    type Cell = ClampedCell;
    const EMPTY: ClampedCell = ClampedCell::EMPTY;

    #[inline(always)]
    fn sample(&self, k: i32, cell: &mut ClampedCell) -> f32 {
        let (at, t) = self.1.at(k);
        if cell.at != at {
            *cell = ClampedCell {
                at,
                c: coefficients(self.0.cell_clamped(at[0], at[1])),
            };
        }
        evaluate(cell.c, t)
    }
}

/// The cell a [`Window`] read last: its top-left pixel's index in the frame buffer and its
/// [`coefficients`].
#[derive(Debug, Clone, Copy)]
struct WindowCell {
    at: usize,
    c: [f32; 4],
}

impl WindowCell {
    /// No cell yet (no slice holds an index of `usize::MAX` and the byte after it).
    const EMPTY: WindowCell = WindowCell {
        at: usize::MAX,
        c: [0.0; 4],
    };
}

/// The cell the clamped path of [`Difference::edge_offset`] read last: its top-left pixel and
/// its [`coefficients`].
#[derive(Debug, Clone, Copy)]
struct ClampedCell {
    at: [isize; 2],
    c: [f32; 4],
}

impl ClampedCell {
    /// No cell yet (no sample's pixel lies at `isize::MIN`: positions are clamped to ±2³⁰).
    const EMPTY: ClampedCell = ClampedCell {
        at: [isize::MIN; 2],
        c: [0.0; 4],
    };
}

/// A 2×2 cell of `D` read by [`Difference::bilinear_cached`]: its top-left pixel and the four
/// differences (top-left, top-right, bottom-left, bottom-right).
#[derive(Debug, Clone, Copy)]
pub(super) struct Cell {
    at: (usize, usize),
    d: [f32; 4],
}

impl Cell {
    /// No cell yet (no pixel of an image lies at `usize::MAX`).
    pub(super) const EMPTY: Cell = Cell {
        at: (usize::MAX, usize::MAX),
        d: [0.0; 4],
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::pixels::enhance::Alpha;
    use crate::pose::refine::{edge_offset_by_definition, sample_by_pixels};
    use crate::test_rng::XorShift as Rng;

    /// A `w`×`h` frame with a bright disc of blurred edge at `(cx, cy)` plus noise, and a flat
    /// background.
    fn scene(rng: &mut Rng, w: usize, h: usize, cx: f32, cy: f32, radius: f32) -> ([u8; 1024], [u8; 1024]) {
        let (mut frame, mut bg) = ([0u8; 1024], [0u8; 1024]);
        for y in 0..h {
            for x in 0..w {
                let d = ((x as f32 - cx).powi(2) + (y as f32 - cy).powi(2)).sqrt() - radius;
                let cover = (0.5 - d / 2.0).clamp(0.0, 1.0);
                let noise = (rng.next() % 9) as f32 - 4.0;
                frame[y * w + x] = (60.0 + 120.0 * cover + noise).clamp(0.0, 255.0) as u8;
                bg[y * w + x] = 60;
            }
        }
        (frame, bg)
    }

    #[test]
    fn bilinear_fast_path_equals_pixel_interpolation() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for alpha in [1.0, 0.5] {
            for _ in 0..20 {
                let (w, h) = (1 + (rng.next() % 31) as usize, 1 + (rng.next() % 31) as usize);
                let (frame_px, bg) = scene(&mut rng, w, h, w as f32 / 2.0, h as f32 / 2.0, 6.0);
                let frame = Frame::new_checked(&frame_px[..], w, h).unwrap();
                let diff = Difference::new(&frame, &bg[..w * h], Alpha::new(alpha).unwrap());
                for _ in 0..200 {
                    let x = rng.unit() * (w as f32 + 4.0) - 2.0;
                    let y = rng.unit() * (h as f32 + 4.0) - 2.0;
                    assert_eq!(
                        diff.bilinear(x, y),
                        diff.bilinear_by_pixels(x, y),
                        "{w}×{h} at ({x}, {y})"
                    );
                }
                for (x, y) in [
                    (f32::NAN, 1.0),
                    (1.0, f32::INFINITY),
                    (-1e30, 1e30),
                    (w as f32 - 1.0, 0.0),
                ] {
                    let (a, b) = (diff.bilinear(x, y), diff.bilinear_by_pixels(x, y));
                    assert!(a == b || (a.is_nan() && b.is_nan()), "({x}, {y}): {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn cached_cells_give_the_same_values_as_pixel_interpolation() {
        // Walks of small steps (the cache is reused) with jumps, off-image stretches and
        // non-finite positions (it must be refreshed or bypassed), one cache throughout.
        let mut rng = Rng(0x0bad_5eed_1234_5678);
        let mut reused = 0;
        for alpha in [1.0, 0.5] {
            for _ in 0..20 {
                let (w, h) = (1 + (rng.next() % 31) as usize, 1 + (rng.next() % 31) as usize);
                let (frame_px, bg) = scene(&mut rng, w, h, w as f32 / 2.0, h as f32 / 2.0, 6.0);
                let frame = Frame::new_checked(&frame_px[..], w, h).unwrap();
                // Sometimes a background plane shorter than the frame (it reads 0 where it ends).
                let short = if rng.next() % 4 == 0 { w * h / 2 } else { w * h };
                let diff = Difference::new(&frame, &bg[..short], Alpha::new(alpha).unwrap());
                let mut cell = Cell::EMPTY;
                let (mut x, mut y) = (rng.unit() * w as f32, rng.unit() * h as f32);
                for _ in 0..400 {
                    match rng.next() % 40 {
                        0 => (x, y) = (rng.unit() * (w as f32 + 6.0) - 3.0, rng.unit() * (h as f32 + 6.0) - 3.0),
                        1 => (x, y) = (f32::NAN, y),
                        2 => (x, y) = (x, f32::INFINITY),
                        3 => (x, y) = (1e30, -1e30),
                        _ => {
                            if !(x.is_finite() && y.is_finite() && x.abs() < 1e3 && y.abs() < 1e3) {
                                (x, y) = (rng.unit() * w as f32, rng.unit() * h as f32);
                            }
                            x += (rng.unit() - 0.5) * 0.6;
                            y += (rng.unit() - 0.5) * 0.6;
                        }
                    }
                    let before = cell.at;
                    let (a, b) = (diff.bilinear_cached(x, y, &mut cell), diff.bilinear_by_pixels(x, y));
                    assert!(
                        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                        "{w}×{h} α {alpha} at ({x}, {y}): {a} vs {b}"
                    );
                    reused += (before == cell.at && before != Cell::EMPTY.at) as usize;
                }
            }
        }
        // The test must exercise the reuse, not only fresh cells.
        assert!(reused > 2000, "only {reused} samples reused a cell");
    }

    #[test]
    fn outward_scan_finds_the_same_crossing_as_the_full_profile() {
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let params = [
            RefineParams::DEFAULT,
            RefineParams {
                step: 0.5,
                search: 2.0,
                ..RefineParams::DEFAULT
            },
            RefineParams {
                step: 0.3,
                search: 4.0,
                ..RefineParams::DEFAULT
            },
        ];
        let mut found = 0;
        for _ in 0..40 {
            let (w, h) = (32, 32);
            let (cx, cy, radius) = (
                10.0 + rng.unit() * 12.0,
                10.0 + rng.unit() * 12.0,
                3.0 + rng.unit() * 6.0,
            );
            let (frame_px, bg) = scene(&mut rng, w, h, cx, cy, radius);
            let frame = Frame::new_checked(&frame_px[..], w, h).unwrap();
            let diff = Difference::new(&frame, &bg[..w * h], Alpha::ONE);
            for _ in 0..100 {
                // Points near the rim (and some far off), normals roughly outward or random.
                let a = rng.unit() * core::f32::consts::TAU;
                let r = radius + (rng.unit() - 0.5) * 8.0;
                let p = [cx + r * a.cos(), cy + r * a.sin()];
                let b = if rng.next() % 4 == 0 {
                    rng.unit() * core::f32::consts::TAU
                } else {
                    a
                };
                let normal = [b.cos(), b.sin()];
                for prm in &params {
                    let (fast, full) = (
                        diff.edge_offset(p, normal, prm),
                        edge_offset_by_definition(&diff, p, normal, prm),
                    );
                    assert_eq!(fast, full, "p {p:?} normal {normal:?} params {prm:?}");
                    found += fast.is_some() as usize;
                }
            }
        }
        // Degenerate sampling finds nothing instead of looping for ever.
        let p0 = [16.0, 16.0];
        for step in [0.0, -0.25, f32::NAN, 1e-9] {
            let prm = RefineParams {
                step,
                ..RefineParams::DEFAULT
            };
            let frame = Frame::new_checked(&[0u8; 1024][..], 32, 32).unwrap();
            let diff = Difference::new(&frame, &[0u8; 1024][..], Alpha::ONE);
            assert_eq!(diff.edge_offset(p0, [1.0, 0.0], &prm), None, "step {step}");
        }
        // The test must exercise real crossings, not only profiles without an edge.
        assert!(found > 4000, "only {found} profiles held an edge");
    }

    #[test]
    fn window_cells_equal_clamped_pixels() {
        // The fast path (cells straight from the buffers) against the definition, sample by
        // sample, on rays inside, across and outside the image, one cache per ray.
        let mut rng = Rng(0x771d_0eca_fef0_0d11);
        let (mut inside, mut outside) = (0usize, 0usize);
        for _ in 0..60 {
            let (w, h) = (2 + (rng.next() % 30) as usize, 2 + (rng.next() % 30) as usize);
            let (frame_px, bg) = scene(&mut rng, w, h, w as f32 / 2.0, h as f32 / 2.0, 5.0);
            // Sometimes rows wider than the image (a stride), sometimes a short background.
            let stride = w + (rng.next() % 3) as usize;
            let mut strided = [0u8; 1200];
            for y in 0..h {
                for x in 0..w {
                    strided[y * stride + x] = frame_px[y * w + x];
                }
                for x in w..stride {
                    strided[y * stride + x] = 255;
                }
            }
            let frame = Frame::with_stride(&strided[..], w, h, stride).unwrap();
            let short = if rng.next() % 5 == 0 {
                w * h - 1 - (rng.next() as usize % (w * h / 2))
            } else {
                w * h
            };
            for alpha in [Alpha::ONE, Alpha::new(0.5).unwrap()] {
                let diff = Difference::new(&frame, &bg[..short], alpha);
                for _ in 0..100 {
                    let p = [rng.unit() * (w as f32 + 8.0) - 4.0, rng.unit() * (h as f32 + 8.0) - 4.0];
                    let a = rng.unit() * core::f32::consts::TAU;
                    let steps = 2 + (rng.next() % 8) as i32;
                    let step = 0.1 + rng.unit() * 0.6;
                    let ray = ProfileRay::new(p, [a.cos(), a.sin()], step, steps).unwrap();
                    let window = Window::new(&diff, &ray, steps);
                    let mut cell = WindowCell::EMPTY;
                    let mut clamped = ClampedCell::EMPTY;
                    // Visit the samples in a shuffled order, with repeats.
                    for _ in 0..3 * steps {
                        let k = (rng.next() % (2 * steps as u64 + 1)) as i32 - steps;
                        let want = sample_by_pixels(&diff, &ray, k);
                        let got = match &window {
                            Some(window) => {
                                inside += 1;
                                window.sample(k, &mut cell)
                            }
                            None => {
                                outside += 1;
                                Clamped(&diff, ray).sample(k, &mut clamped)
                            }
                        };
                        assert_eq!(got.to_bits(), want.to_bits(), "{w}×{h} stride {stride} p {p:?} k {k}");
                    }
                }
            }
        }
        assert!(inside > 5000 && outside > 5000, "inside {inside}, outside {outside}");
    }

    #[test]
    fn direct_path_finds_the_crossing_of_the_ray() {
        // Profiles read on the direct path (inside the image) and through a ray (across its
        // edge, α < 1) against the full scan of the ray's samples, bit for bit, with strides,
        // short background planes and normals that are not unit.
        let mut rng = Rng(0xd1ec_7a11_0ff5_e7ed);
        let (mut direct, mut generic) = (0usize, 0usize);
        for round in 0..120 {
            let (w, h) = (4 + (rng.next() % 27) as usize, 4 + (rng.next() % 27) as usize);
            let (cx, cy, radius) = (w as f32 * rng.unit(), h as f32 * rng.unit(), 2.0 + rng.unit() * 8.0);
            let (frame_px, bg) = scene(&mut rng, w, h, cx, cy, radius);
            let stride = w + (rng.next() % 3) as usize;
            let mut strided = [0u8; 1200];
            for y in 0..h {
                strided[y * stride..y * stride + w].copy_from_slice(&frame_px[y * w..y * w + w]);
            }
            let frame = Frame::with_stride(&strided[..], w, h, stride).unwrap();
            let short = if round % 7 == 0 {
                w * h - 1 - (rng.next() as usize % w)
            } else {
                w * h
            };
            let alpha = if round % 5 == 0 {
                Alpha::new(0.7).unwrap()
            } else {
                Alpha::ONE
            };
            let diff = Difference::new(&frame, &bg[..short], alpha);
            let params = [
                RefineParams::DEFAULT,
                RefineParams {
                    step: 0.5,
                    ..RefineParams::DEFAULT
                },
                RefineParams {
                    step: 0.3,
                    search: 1.0,
                    ..RefineParams::DEFAULT
                },
            ][round % 3];
            let finder = diff.edge_finder(&params);
            for _ in 0..150 {
                let p = [rng.unit() * (w as f32 + 4.0) - 2.0, rng.unit() * (h as f32 + 4.0) - 2.0];
                let a = rng.unit() * core::f32::consts::TAU;
                let len = if rng.next() % 4 == 0 {
                    0.5 + rng.unit() * 1.5
                } else {
                    1.0
                };
                let normal = [len * a.cos(), len * a.sin()];
                let want = edge_offset_by_definition(&diff, p, normal, &params);
                assert_eq!(
                    finder.offset(p, normal),
                    want,
                    "{w}×{h} p {p:?} n {normal:?} {params:?}"
                );
                if finder.is_direct(p, normal) {
                    direct += 1;
                } else {
                    generic += 1;
                }
            }
        }
        assert!(direct > 3000 && generic > 3000, "direct {direct}, generic {generic}");
        // Parameters that make no profile find nothing on either path.
        let frame = Frame::new_checked(&[0u8; 1024][..], 32, 32).unwrap();
        let diff = Difference::new(&frame, &[0u8; 1024][..], Alpha::ONE);
        let bad = RefineParams {
            step: 0.0,
            ..RefineParams::DEFAULT
        };
        assert_eq!(diff.edge_finder(&bad).offset([16.0, 16.0], [1.0, 0.0]), None);
    }
}
