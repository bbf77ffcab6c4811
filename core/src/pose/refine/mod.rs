//! Refine and verify: the template's outline aligned on the frame to sub-pixel accuracy, and
//! how far the part's edge lies from it. The paper's pose (eqs. 6.1–6.4 on `n` resampled
//! points) is coarse, and its descriptor alone confuses near-similar parts; this stage works on
//! the frame itself (DESIGN.md, "Beyond the paper"). This file is the definition; the fast
//! reading of the profiles (`profile.rs`, [`EdgeFinder`]) is tested equal to it bit for bit,
//! and the part → template distances have their own file (`outline.rs`, [`Outline`]).
//!
//! - **Alignment** ([`align`]): the template's sub-pixel edge points, mapped into the frame by a
//!   pose `p = c + s·R(θ)·(t − a)` (`a` the template's area centroid, `R` counter-clockwise on
//!   screen), each look for the part's edge along their normal: the difference image
//!   `D = I' − B` is sampled (bilinear) from `−search` to `+search` px, and the crossing of the
//!   half-contrast level `(D_in + D_out)/2` nearest the point is the edge — the local contrast
//!   comes from the ends of the same profile, so printed labels and shading inside the part do
//!   not move it. A Gauss–Newton step on the signed normal distances (point-to-line) updates
//!   translation, rotation and scale (lightly damped — each direction by 10⁻³ of how far it
//!   moves the points — so the free rotation of a round part is left alone while the others
//!   take full steps). Coarse to fine: steps on every 4th point, with profiles sampled at twice
//!   the step, until an update moves the points along their normals by less than 0.05 px (root
//!   mean square) or they lie within 0.25 px of the edge, then steps on every point at the full
//!   sampling until an update moves them by less than 0.01 px (the right template settles in
//!   2–3 coarse and 2 fine steps from the DP's seed; a wrong one reaches the step limit without
//!   settling and is not refined further). The distances of a converged last step stand for
//!   those at the final pose (its update moved the points by less than 0.01 px); otherwise they
//!   are measured once more. 0.01 px instead of the first 0.001 saves a fine step of every
//!   point (angles on the generated sets within 1 % of the 0.001 px figures).
//! - **Profiles** ([`Difference::edge_offset`]): the samples lie at fixed-point positions
//!   ([`ProfileRay`]: a pixel by a shift, a fraction by a mask), each the bilinear interpolation
//!   of four clamped pixels of `D` ([`sample_by_pixels`]); every crossing of the level between
//!   two samples is placed by linear interpolation, and the nearest wins. That is the
//!   definition. The reading that runs (`profile.rs`) scans from the point outwards and stops
//!   at the nearest crossing (a pose near the edge reads about 8 of a profile's 25 samples),
//!   reads each pixel cell once, and reads a profile that lies inside the image on the
//!   [`EdgeFinder`]'s direct path, its cells straight from the frame and background buffers.
//! - **Giving up** ([`RefineParams::give_up`]): from the 4th step on, a step whose points lie
//!   farther than `give_up` from the edge on average (capped, profiles without an edge counting
//!   the cap) ends the alignment there, with that step's distances; so does, at any step, one
//!   whose profiles find too few edges to take it (those points then lie beyond 1.6 px on
//!   average), instead of a final measurement of every point. The recognizer sets twice
//!   its verification threshold (1.2 px), so half the distance alone puts the score over the
//!   threshold, and leaves it off for parts that touch the frame's edge (a cut part's right
//!   template can spend ten steps above 1.6 px before it finds the part) and for
//!   `refine = pose`. The rule trusts the DP's seed: on the five generated sets a right
//!   template's points never lie farther than 0.97 px from the edge on average from the 4th
//!   step on (one noisy part; 0.25–0.68 px on the other four sets), while 83–92 % of the wrong
//!   ones on parts inside the frame give up there; a square seeded 45° off gives up too,
//!   though it would converge.
//! - **Cost**: a profile reads a few cells along the normal, nearest crossing first (what an
//!   alignment costs on the bench set: `docs/performance.md`). Time `O(m·search/step)` per
//!   step, at most [`RefineParams::iterations`] steps (and up to 4 fine ones after a coarse
//!   stage that used them up). Memory: no buffers, a few numbers per step (the normal
//!   equations, at most 6×6); the caller's `distances`, when it wants them.
//! - **Verification** (the recognizer's): the capped distances of the template's edge points
//!   at the aligned pose to the part's edge ([`edge_distances`]; profiles that find no edge
//!   count the cap), and of the part's own edge to the aligned template outline ([`Outline`])
//!   — both ways, so a template that covers only part of the outline cannot look good — each
//!   averaged over its nearest [`VERIFY_KEPT`]; a scale outside the template's range is never
//!   verified. The part → template distances search the outline by runs of 8 segments with a
//!   bounding circle each (a run whose circle lies farther than the best so far is skipped
//!   whole).
//!
//! The part's position is measured separately, by [`crate::pose::partial_volume`].
//!
//! Guards: a profile with less contrast than `min_contrast` between its ends has no edge, and
//! so has one of more than [`MAX_PROFILE_STEPS`] samples a side, reaching beyond
//! [`MAX_PROFILE_REACH`], or with a point or normal that is not finite; a pose update that is
//! not finite, or a scale outside `[0.5, 2]`, stops the alignment at the last good pose.

use crate::math;
use crate::pixels::enhance::Alpha;
use crate::pixels::frame::Frame;
use crate::pose::refine::profile::Cell;

mod outline;
mod profile;

pub use outline::{Outline, OUTLINE_CHUNKS};
pub use profile::{EdgeFinder, DIRECT_MAX_SIDE};
/// A similarity pose: template point `t` (relative to the template's area centroid) lands at
/// `centre + scale·R(angle)·t` in the frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Where the template's area centroid lands, x (px).
    pub x: f32,
    /// Where the template's area centroid lands, y (px).
    pub y: f32,
    /// Rotation, radians, counter-clockwise on screen.
    pub angle: f32,
    /// Scale, frame px per template px.
    pub scale: f32,
}

impl Pose {
    /// Maps a template offset (from its area centroid) into the frame.
    #[inline]
    pub fn apply(&self, t: [f32; 2]) -> [f32; 2] {
        self.apply_sc(math::sin_cos(self.angle), t)
    }

    /// Rotates a direction without translating or scaling it.
    #[inline]
    pub fn rotate(&self, v: [f32; 2]) -> [f32; 2] {
        rotate_sc(math::sin_cos(self.angle), v)
    }

    /// [`Self::apply`] with `(sin, cos)` of the angle computed once by the caller.
    #[inline]
    fn apply_sc(&self, (s, c): (f32, f32), t: [f32; 2]) -> [f32; 2] {
        [
            self.x + self.scale * (t[0] * c + t[1] * s),
            self.y + self.scale * (-t[0] * s + t[1] * c),
        ]
    }

    /// The template offset that [`Self::apply`] maps to `p` (`None` for a zero scale).
    #[inline]
    pub fn invert(&self, p: [f32; 2]) -> Option<[f32; 2]> {
        self.invert_sc(math::sin_cos(self.angle), p)
    }

    /// [`Self::invert`] with `(sin, cos)` of the angle computed once by the caller.
    #[inline]
    pub fn invert_sc(&self, (s, c): (f32, f32), p: [f32; 2]) -> Option<[f32; 2]> {
        if !(self.scale != 0.0) {
            return None;
        }
        let (dx, dy) = ((p[0] - self.x) / self.scale, (p[1] - self.y) / self.scale);
        Some([dx * c - dy * s, dx * s + dy * c])
    }
}

/// [`Pose::rotate`] with `(sin, cos)` given.
#[inline]
fn rotate_sc((s, c): (f32, f32), v: [f32; 2]) -> [f32; 2] {
    [v[0] * c + v[1] * s, -v[0] * s + v[1] * c]
}

/// The unit outward normal at point `k` of a closed outline (from its two neighbours), or
/// `None` where they coincide. `counter_clockwise` is the outline's direction as seen on screen
/// (a negative shoelace sum in image coordinates), which decides which side is out.
pub fn outward_normal(points: &[[f32; 2]], k: usize, counter_clockwise: bool) -> Option<[f32; 2]> {
    let (n, k) = (points.len().max(1), k % points.len().max(1)); // k + n − 1 without overflow
    let (prev, next) = (points.get((k + n - 1) % n)?, points.get((k + 1) % n)?);
    let (tx, ty) = (next[0] - prev[0], next[1] - prev[1]);
    let len = math::hypot(tx, ty);
    if !(len > 0.0) {
        return None;
    }
    Some(if counter_clockwise {
        [-ty / len, tx / len]
    } else {
        [ty / len, -tx / len]
    })
}

/// Tuning of the alignment and verification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineParams {
    /// Most Gauss–Newton steps (coarse and fine stages together; when the coarse stage settles
    /// on its last step, the fine stage still gets up to 4).
    pub iterations: usize,
    /// Half-length of each normal profile, px.
    pub search: f32,
    /// Sampling step along a profile, px.
    pub step: f32,
    /// Least difference between a profile's ends for it to hold an edge (grey levels).
    pub min_contrast: f32,
    /// Distances are capped here when averaged for the verification score, px. A cap that
    /// is not a number or negative caps nothing (a profile without an edge then counts
    /// infinite: never verified).
    pub cap: f32,
    /// The alignment gives up once a step, from the [`GIVE_UP_AFTER`]-th on, finds its
    /// profiles farther than this from the edge on average (capped at [`Self::cap`], profiles
    /// without an edge counting the cap), px, or a step that finds too few edges to be taken
    /// does; `f32::INFINITY` never gives up. The recognizer sets twice its verification
    /// threshold, which half of the distance alone then exceeds.
    pub give_up: f32,
    /// Largest uniform offset of the outline along its normals that the alignment may fit,
    /// px (a fifth parameter beside translation, rotation and scale): the walls of a thick part
    /// under a close lens, or an edge that blur and exposure move, make the whole outline
    /// lie farther out or in than the template's, which a scale cannot take up without
    /// stretching the part's length. 0 (the default) fits no offset.
    pub offset_max: f32,
    /// Largest wall the alignment may fit, px (a sixth parameter, with the offset): a thick
    /// part under a close, non-telecentric lens shows its walls on the side that faces the
    /// principal point, so the outline lies farther out there by `wall · max(0, n·u)` (`n` the
    /// outward normal, `u` = [`Self::wall_toward`]): the top face swept towards the bottom
    /// one. The pose is then the top face's. 0 (the default) fits no wall.
    pub wall_max: f32,
    /// The unit vector from the part towards the principal point (where the camera looks
    /// straight down), in frame coordinates; the direction the walls show in.
    pub wall_toward: [f32; 2],
}

impl RefineParams {
    /// The defaults.
    pub const DEFAULT: RefineParams = RefineParams {
        iterations: 12,
        search: 3.0,
        step: 0.25,
        min_contrast: 8.0,
        cap: 2.0,
        give_up: f32::INFINITY,
        offset_max: 0.0,
        wall_max: 0.0,
        wall_toward: [0.0, 0.0],
    };
}

/// The signed difference image `D = I' − B` over a frame and a background plane.
#[derive(Debug, Clone, Copy)]
pub struct Difference<'a, B> {
    frame: &'a Frame<B>,
    background: &'a [u8],
    alpha: Alpha,
}

impl<'a, B: AsRef<[u8]>> Difference<'a, B> {
    /// `D` of `frame` against a background plane of the frame's size (row-packed). A short plane
    /// reads as 0 where it ends.
    pub fn new(frame: &'a Frame<B>, background: &'a [u8], alpha: Alpha) -> Self {
        Difference {
            frame,
            background,
            alpha,
        }
    }

    /// Width of the image.
    pub fn width(&self) -> usize {
        self.frame.width()
    }

    /// Height of the image.
    pub fn height(&self) -> usize {
        self.frame.height()
    }

    /// `D` at a pixel, coordinates clamped into the image.
    #[inline]
    pub fn at(&self, x: isize, y: isize) -> f32 {
        let (xc, yc) = self.clamped(x, y);
        let b = self.level(xc, yc) as f32;
        if self.alpha.get() >= 1.0 {
            // The default α = 1: a subtraction, small enough to inline into the callers' loops.
            return self.frame.get_clamped(xc, yc) as f32 - b;
        }
        self.enhanced(xc, yc) - b
    }

    /// The background plane's level at a pixel, coordinates clamped into the image (0 where a
    /// short plane ends), as [`Self::at`] subtracts it.
    #[inline]
    pub fn background_at(&self, x: isize, y: isize) -> u8 {
        let (xc, yc) = self.clamped(x, y);
        self.level(xc, yc)
    }

    /// Coordinates clamped into the image (`max` then `min`, not `clamp`: that panics for an
    /// empty image, where `w − 1 < 0`).
    #[inline(always)]
    fn clamped(&self, x: isize, y: isize) -> (isize, isize) {
        let (w, h) = (self.frame.width() as isize, self.frame.height() as isize);
        (x.max(0).min(w - 1), y.max(0).min(h - 1))
    }

    /// The background plane at clamped coordinates (0 where a short plane ends).
    #[inline(always)]
    fn level(&self, xc: isize, yc: isize) -> u8 {
        let w = self.frame.width() as isize;
        self.background.get((yc * w + xc) as usize).copied().unwrap_or(0)
    }

    /// Row `y` of the frame and of the background plane when `D` is their difference (`α = 1`):
    /// `D` at column `x` of the row is `frame[x] as f32 − background[x] as f32`, the same value
    /// as [`Self::at`]. Both slices are `width` long. `None` for `α < 1`, a row outside the
    /// image, or a background plane that ends within the row.
    #[inline]
    pub fn rows(&self, y: usize) -> Option<(&'a [u8], &'a [u8])> {
        if !(self.alpha.get() >= 1.0) {
            return None;
        }
        let w = self.frame.width();
        let frame = self.frame.row(y);
        let start = y.checked_mul(w)?;
        let background = self.background.get(start..start.checked_add(w)?)?;
        (frame.len() == w).then_some((frame, background))
    }

    /// [`Self::rows`] from row `y` on, without a call per row: the frame's bytes from row `y`
    /// (row `y + k` at `k · stride`), the stride, and the background plane's from row `y` (row
    /// `y + k` at `k · width`). `None` for `α < 1` or a row outside the image.
    #[inline]
    pub(crate) fn rows_from(&self, y: usize) -> Option<(&'a [u8], usize, &'a [u8])> {
        if !(self.alpha.get() >= 1.0) || y >= self.frame.height() {
            return None;
        }
        let start = y.checked_mul(self.frame.width())?;
        Some((
            self.frame.bytes_from(y),
            self.frame.stride(),
            self.background.get(start..)?,
        ))
    }

    /// `I' = α·I + (1 − α)·|∇I|` at an in-image pixel (α < 1), kept out of line so that
    /// [`Self::at`] stays small.
    #[inline(never)]
    fn enhanced(&self, xc: isize, yc: isize) -> f32 {
        let a = self.alpha.get();
        let i = self.frame.get_clamped(xc, yc) as f32;
        let p = |dx: isize, dy: isize| self.frame.get_clamped(xc + dx, yc + dy) as f32;
        let gx = (p(1, -1) + 2.0 * p(1, 0) + p(1, 1)) - (p(-1, -1) + 2.0 * p(-1, 0) + p(-1, 1));
        let gy = (p(-1, 1) + 2.0 * p(0, 1) + p(1, 1)) - (p(-1, -1) + 2.0 * p(0, -1) + p(1, -1));
        let g = math::sqrt(gx * gx + gy * gy) * 0.176_776_69;
        (a * i + (1.0 - a) * g).clamp(0.0, 255.0)
    }

    /// `D` at a sub-pixel position, bilinear.
    #[inline]
    pub fn bilinear(&self, x: f32, y: f32) -> f32 {
        let mut cell = Cell::EMPTY;
        self.bilinear_cached(x, y, &mut cell)
    }

    /// [`Self::bilinear`] from four [`Self::at`] values: any α, any position.
    fn bilinear_by_pixels(&self, x: f32, y: f32) -> f32 {
        // Beyond a pixel outside the image every neighbour clamps to the border anyway; the
        // clamp keeps the integer coordinates from overflowing.
        let (x, y) = (
            math::clamp(x, -2.0, self.width() as f32 + 1.0),
            math::clamp(y, -2.0, self.height() as f32 + 1.0),
        );
        let (fx, fy) = (math::floor(x), math::floor(y));
        let (tx, ty) = (x - fx, y - fy);
        let (ix, iy) = (fx as isize, fy as isize);
        let top = self.at(ix, iy) * (1.0 - tx) + self.at(ix + 1, iy) * tx;
        let bottom = self.at(ix, iy + 1) * (1.0 - tx) + self.at(ix + 1, iy + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// The signed offset along `normal` (unit, pointing out of the part) from `p` to the
    /// half-contrast crossing nearest `p`, or `None` when the profile holds no edge.
    ///
    /// The profile is `2·search/step + 1` samples `D(p + k·step·normal)`, bilinear
    /// ([`sample_by_pixels`] at the fixed-point positions of a [`ProfileRay`]); the level is
    /// the mean of the two ends (two samples each), and an edge is a fall from the inner side's
    /// level to the outer's between two samples, placed by linear interpolation. Intervals are
    /// visited from `p` outwards and the scan stops once no farther interval can hold a nearer
    /// crossing, so a pose already near the edge reads about 8 samples instead of 25. Of two
    /// crossings at the same distance the inner one wins. A profile with more than
    /// [`MAX_PROFILE_STEPS`] samples a side, reaching farther than [`MAX_PROFILE_REACH`] px
    /// along an axis, or with a non-finite point or normal, holds no edge.
    ///
    /// Where every sample's cell lies inside the image and `α = 1` (nearly every profile), the
    /// cells are read straight from the frame and background buffers at offsets from the
    /// profile's base pixel; elsewhere from four clamped pixels. Consecutive samples in the same
    /// cell reuse its four differences. Either way the values of [`sample_by_pixels`].
    pub fn edge_offset(&self, p: [f32; 2], normal: [f32; 2], params: &RefineParams) -> Option<f32> {
        self.edge_finder(params).offset(p, normal)
    }

    /// `D` at the four pixels of the cell with top-left `(ix, iy)` (top-left, top-right,
    /// bottom-left, bottom-right), each coordinate clamped into the image: [`Self::at`] four
    /// times.
    fn cell_clamped(&self, ix: isize, iy: isize) -> [f32; 4] {
        [
            self.at(ix, iy),
            self.at(ix + 1, iy),
            self.at(ix, iy + 1),
            self.at(ix + 1, iy + 1),
        ]
    }
}

/// Most samples on each side of a profile ([`Difference::edge_offset`] finds no edge beyond).
pub const MAX_PROFILE_STEPS: i32 = 1024;

/// Fraction bits of the fixed-point sample positions of a profile ([`ProfileRay`]).
const RAY_FRACTION_BITS: u32 = 16;

/// Most a profile may reach from its point along either axis, px (`search·|normal|`); beyond,
/// [`Difference::edge_offset`] finds no edge (the fixed-point positions would overflow).
pub const MAX_PROFILE_REACH: f32 = 16384.0;

/// The sample positions `p + k·step·normal` of one profile, in fixed point.
///
/// Per axis, position `k` is the pixel `base` (`p` truncated towards zero) plus
/// `(start + k·delta) / 2¹⁶` px, where `start` is the rest of `p` (truncated to 1/65536 px) and
/// `delta` is `step·normal` (rounded to 1/65536 px): within `(|k| + 2)·2⁻¹⁶` px of
/// `p + k·step·normal`. An arithmetic shift gives each sample's pixel and a mask its fraction,
/// the same on either side of the image's origin, and the profile's ends bound all its pixels
/// (the positions are linear in `k`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfileRay {
    base: [isize; 2],
    start: [i32; 2],
    delta: [i32; 2],
}

impl ProfileRay {
    /// The ray of `steps` samples a side from `p` along `normal`, `step` px apart; `None` for a
    /// non-finite input or a reach (`steps·step·|normal|` on an axis) beyond
    /// [`MAX_PROFILE_REACH`]. Coordinates of `p` beyond ±2³⁰ are clamped there (a sample that
    /// far off reads the image's border either way).
    #[inline]
    pub fn new(p: [f32; 2], normal: [f32; 2], step: f32, steps: i32) -> Option<Self> {
        const ONE: f32 = (1u32 << RAY_FRACTION_BITS) as f32;
        const FAR: f32 = (1u32 << 30) as f32;
        let axis = |p: f32, n: f32| -> Option<(isize, i32, i32)> {
            let reach = steps as f32 * step * n * ONE;
            if !(p.is_finite() && reach.abs() <= MAX_PROFILE_REACH * ONE) {
                return None;
            }
            let p = p.clamp(-FAR, FAR);
            // Within ±2³⁰ the truncation is exact and so is `p − base` (below 2²⁴ both keep
            // every bit; above, `p` is a whole number): the rest lies in (−1, 1).
            let base = p as i32;
            let start = ((p - base as f32) * ONE) as i32;
            Some((base as isize, start, fixed_delta(step, n)))
        };
        let (bx, sx, dx) = axis(p[0], normal[0])?;
        let (by, sy, dy) = axis(p[1], normal[1])?;
        Some(ProfileRay {
            base: [bx, by],
            start: [sx, sy],
            delta: [dx, dy],
        })
    }

    /// Sample `k`'s pixel offset from the base pixel and its fraction in `[0, 1)`, per axis.
    /// `|k|` must not exceed the `steps` the ray was made for (the positions then stay within
    /// `MAX_PROFILE_REACH + 1` px of the base, far from overflowing).
    #[inline(always)]
    fn offset(&self, k: i32) -> ([i32; 2], [f32; 2]) {
        const MASK: i32 = (1 << RAY_FRACTION_BITS) - 1;
        const INV: f32 = 1.0 / (1u32 << RAY_FRACTION_BITS) as f32;
        let x = self.start[0].wrapping_add(k.wrapping_mul(self.delta[0]));
        let y = self.start[1].wrapping_add(k.wrapping_mul(self.delta[1]));
        (
            [x >> RAY_FRACTION_BITS, y >> RAY_FRACTION_BITS],
            [(x & MASK) as f32 * INV, (y & MASK) as f32 * INV],
        )
    }

    /// Sample `k`'s pixel (the floor of its position) and fraction in `[0, 1)`, per axis.
    #[inline(always)]
    pub fn at(&self, k: i32) -> ([isize; 2], [f32; 2]) {
        let ([ox, oy], t) = self.offset(k);
        (
            [
                self.base[0].wrapping_add(ox as isize),
                self.base[1].wrapping_add(oy as isize),
            ],
            t,
        )
    }
}

/// `step·n` in 1/65536 px, rounded to the nearest (a tie to even below 2²², away from zero
/// above).
///
/// Below 2²² in magnitude (steps under 64 px along a unit normal) by adding 1.5·2²³, which
/// leaves the rounded value in the low bits of the sum; beyond, by a conversion.
#[inline(always)]
fn fixed_delta(step: f32, n: f32) -> i32 {
    const ONE: f32 = (1u32 << RAY_FRACTION_BITS) as f32;
    const MAGIC: f32 = 12_582_912.0;
    let delta = step * n * ONE;
    if delta.abs() < 4_194_304.0 {
        ((delta + MAGIC).to_bits() as i32).wrapping_sub(MAGIC.to_bits() as i32)
    } else {
        math::round(delta) as i32
    }
}

/// The bilinear coefficients `[a, b, c, e]` of a cell `[top-left, top-right, bottom-left,
/// bottom-right]`: its value at the fraction `(tx, ty)` is `a + tx·b + ty·(c + tx·e)`
/// ([`evaluate`]). The cells hold integer differences, so the coefficients are exact.
#[inline(always)]
fn coefficients([d00, d01, d10, d11]: [f32; 4]) -> [f32; 4] {
    [d00, d01 - d00, d10 - d00, (d11 - d10) - (d01 - d00)]
}

/// The bilinear interpolation of a cell's [`coefficients`] at the fraction `(tx, ty)`.
#[inline(always)]
fn evaluate([a, b, c, e]: [f32; 4], [tx, ty]: [f32; 2]) -> f32 {
    a + tx * b + ty * (c + tx * e)
}

/// `D` at sample `k` of `ray`, bilinear from four clamped pixels ([`Difference::at`]): the
/// definition the profiles of [`Difference::edge_offset`] reproduce, however they read it.
pub fn sample_by_pixels<B: AsRef<[u8]>>(diff: &Difference<'_, B>, ray: &ProfileRay, k: i32) -> f32 {
    let ([ix, iy], t) = ray.at(k);
    evaluate(coefficients(diff.cell_clamped(ix, iy)), t)
}

/// [`Difference::edge_offset`] by its definition, as first written: every sample of the
/// profile ([`sample_by_pixels`]), every crossing of the half-contrast level, the nearest kept
/// (of two at the same distance the inner, which comes first). The reading that runs
/// (`profile.rs`) is tested equal to it; this one is kept for the tests.
#[cfg(test)]
fn edge_offset_by_definition<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    p: [f32; 2],
    normal: [f32; 2],
    params: &RefineParams,
) -> Option<f32> {
    let steps = (params.search / params.step) as i32;
    if steps < 2 {
        return None;
    }
    let ray = ProfileRay::new(p, normal, params.step, steps)?;
    let sample = |k: i32| sample_by_pixels(diff, &ray, k);
    let d_in = 0.5 * (sample(-steps) + sample(-steps + 1));
    let d_out = 0.5 * (sample(steps) + sample(steps - 1));
    if !((d_in - d_out).abs() >= params.min_contrast) {
        return None;
    }
    let level = 0.5 * (d_in + d_out);
    let sign = if d_in > d_out { 1.0 } else { -1.0 };
    let mut best: Option<f32> = None;
    let mut prev = sign * (sample(-steps) - level);
    for k in (-steps + 1)..=steps {
        let cur = sign * (sample(k) - level);
        if prev > 0.0 && cur <= 0.0 {
            let t = prev / (prev - cur);
            let u = ((k - 1) as f32 + t) * params.step;
            if best.is_none_or(|b| u.abs() < b.abs()) {
                best = Some(u);
            }
        }
        prev = cur;
    }
    best
}

/// The result of [`align`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alignment {
    /// The refined pose.
    pub pose: Pose,
    /// Mean capped distance from the template's edge points to the part's edge, px (profiles
    /// without an edge count the cap).
    pub distance: f32,
    /// Fraction of profiles that found an edge.
    pub coverage: f32,
    /// Whether the pose settled (the coarse stage's updates fell below 0.05 px or its points
    /// came within 0.25 px of the edge); an unsettled pose is not refined by the fine stage.
    pub settled: bool,
    /// Whether the alignment gave up ([`RefineParams::give_up`]): then `pose` is where its last
    /// step measured, and `distance` and `coverage` are that step's (on its points only).
    pub gave_up: bool,
    /// The uniform outline offset fitted, px along the outward normals (0 unless
    /// [`RefineParams::offset_max`] allows one).
    pub offset: f32,
    /// The wall fitted, px ([`RefineParams::wall_max`]; 0 unless it allows one).
    pub wall: f32,
}

/// Aligns the template's edge points (offsets from its area centroid, with unit outward
/// normals) onto the part's edge in `diff`, starting from `seed`.
pub fn align<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    edge: &[[f32; 2]],
    normals: &[[f32; 2]],
    seed: Pose,
    params: &RefineParams,
) -> Alignment {
    align_recording(diff, edge, normals, seed, params, &mut [])
}

/// [`align`], which also writes the capped distance of every edge point to the part's edge
/// into `distances` (as [`edge_distances`] at the final pose; those of the last step when it
/// converged, whose update moved the points by less than 0.01 px): what a robust verification
/// score sorts, without measuring the profiles again. `distances` beyond the edge points is
/// left alone; a shorter one takes the first points. When the alignment gave up
/// ([`Alignment::gave_up`]), `distances` holds no valid values: measure them with
/// [`edge_distances`] if needed.
///
/// ```
/// use vorl_core::pixels::enhance::Alpha;
/// use vorl_core::pose::refine::{align_recording, Alignment, Difference, Pose, RefineParams};
/// use vorl_core::Frame;
/// // A bright 20×20 square on a dark 48×48 frame.
/// let (w, h) = (48usize, 48usize);
/// let mut pixels = [0u8; 48 * 48];
/// for y in 14..34 {
///     for x in 14..34 {
///         pixels[y * w + x] = 200;
///     }
/// }
/// let frame = Frame::new_checked(&pixels[..], w, h).unwrap();
/// let background = [0u8; 48 * 48];
/// let diff = Difference::new(&frame, &background, Alpha::ONE);
/// // The square's outline, 8 points a side, and its outward normals.
/// let mut edge = [[0.0f32; 2]; 32];
/// let mut normals = [[0.0f32; 2]; 32];
/// for (i, (e, n)) in edge.iter_mut().zip(normals.iter_mut()).enumerate() {
///     let t = -10.0 + 2.5 * (i % 8) as f32;
///     (*e, *n) = match i / 8 {
///         0 => ([t, -10.0], [0.0, -1.0]),
///         1 => ([10.0, t], [1.0, 0.0]),
///         2 => ([-t, 10.0], [0.0, 1.0]),
///         _ => ([-10.0, -t], [-1.0, 0.0]),
///     };
/// }
/// let seed = Pose { x: 24.5, y: 23.6, angle: 0.03, scale: 1.0 };
/// let mut distances = [0.0f32; 32];
/// let a: Alignment =
///     align_recording(&diff, &edge, &normals, seed, &RefineParams::DEFAULT, &mut distances);
/// assert!(!a.gave_up);
/// let mean = distances.iter().sum::<f32>() / 32.0;
/// assert!((mean - a.distance).abs() < 1e-4);
/// assert!(distances.iter().all(|d| *d < 0.5), "{distances:?}");
/// ```
pub fn align_recording<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    edge: &[[f32; 2]],
    normals: &[[f32; 2]],
    seed: Pose,
    params: &RefineParams,
    distances: &mut [f32],
) -> Alignment {
    let sane = RefineParams {
        cap: sane_cap(params.cap),
        ..*params
    };
    let params = &sane;
    let coarse_stride = if edge.len() >= 4 * COARSE_POINTS { 4 } else { 1 };
    let points = edge.len().min(normals.len());
    let mut pose = seed;
    let mut offset = 0.0f32;
    let mut wall = 0.0f32;
    let mut left = params.iterations;
    // Coarse: every 4th point, profiles sampled half as densely, until the pose settles; fine:
    // every point until it converges. A pose that has not settled when the steps run out is not
    // refined further (a wrong template does not converge; its distances below say so).
    let coarse = RefineParams {
        step: params.step * 2.0,
        ..*params
    };
    let mut settled_once = false;
    let stages = [
        (true, coarse_stride, COARSE_SETTLED, &coarse),
        (false, 1, CONVERGED, params),
    ];
    // The capped distances of the last fine step, when it converged: its update moved the
    // points by less than `CONVERGED`, so they stand for the distances at the final pose.
    let mut converged_distances: Option<(f32, usize)> = None;
    let mut taken = 0usize;
    'stages: for (coarse_stage, stride, settled, prm) in stages {
        let mut calm = false;
        while left > 0 {
            left -= 1;
            let profiles = points.div_ceil(stride.max(1)).max(1) as f32;
            // The fine stage's steps record their distances (the last one's stand for the
            // final pose when it converged).
            let record: &mut [f32] = if coarse_stage { &mut [] } else { &mut *distances };
            let step = match gauss_newton_step(
                diff,
                edge,
                normals,
                pose,
                Shift::new(offset, wall, prm),
                stride,
                prm,
                record,
            ) {
                Ok(step) => step,
                // Too few edges for a step: the alignment ends here, and when those profiles
                // already lie beyond `give_up` they stand for the final distances.
                Err(Some((capped_sum, found))) if capped_sum > params.give_up * profiles => {
                    return Alignment {
                        pose,
                        distance: capped_sum / profiles,
                        coverage: found as f32 / profiles,
                        settled: settled_once,
                        gave_up: true,
                        offset,
                        wall,
                    };
                }
                Err(_) => break 'stages,
            };
            taken += 1;
            // Giving up: the points at `pose` lie too far from the edge to end up verified.
            if taken >= GIVE_UP_AFTER && step.capped_sum > params.give_up * profiles {
                return Alignment {
                    pose,
                    distance: step.capped_sum / profiles,
                    coverage: step.found as f32 / profiles,
                    settled: settled_once,
                    gave_up: true,
                    offset,
                    wall,
                };
            }
            pose = step.next;
            offset = step.offset;
            wall = step.wall;
            // Settled: the update is small, or (coarse stage) the points already sit on the edge
            // and only a direction the edge cannot fix moves (a round part's rotation).
            if step.moved < settled || (coarse_stage && step.fit < FIT_SETTLED) {
                if !coarse_stage {
                    converged_distances = Some((step.capped_sum, step.found));
                }
                calm = true;
                break;
            }
        }
        if !calm {
            break;
        }
        settled_once = true;
        left = left.max(FINE_ITERATIONS.min(params.iterations));
    }
    // Final distances at the converged pose (those of the last step when it converged).
    let (sum, found) = converged_distances
        .unwrap_or_else(|| edge_distances_walled(diff, edge, normals, pose, offset, wall, params, distances));
    let count = points.max(1) as f32;
    Alignment {
        pose,
        distance: sum / count,
        coverage: found as f32 / count,
        settled: settled_once,
        gave_up: false,
        offset,
        wall,
    }
}

/// The capped distance of every edge point at `pose` (and the outline `offset`) to the
/// part's edge, into `out` (profiles without an edge count the cap; `out` beyond the edge
/// points is left alone, a shorter one takes the first points): what a robust verification
/// score sorts. Returns the sum of the distances over every edge point and how many profiles
/// found an edge.
pub fn edge_distances<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    edge: &[[f32; 2]],
    normals: &[[f32; 2]],
    pose: Pose,
    offset: f32,
    params: &RefineParams,
    out: &mut [f32],
) -> (f32, usize) {
    edge_distances_walled(diff, edge, normals, pose, offset, 0.0, params, out)
}

/// [`edge_distances`] with a `wall` as well ([`RefineParams::wall_max`], its direction
/// [`RefineParams::wall_toward`]), as an [`Alignment`] that fitted one measures.
#[allow(clippy::too_many_arguments)]
pub fn edge_distances_walled<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    edge: &[[f32; 2]],
    normals: &[[f32; 2]],
    pose: Pose,
    offset: f32,
    wall: f32,
    params: &RefineParams,
    out: &mut [f32],
) -> (f32, usize) {
    let shift = Shift::new(offset, wall, params);
    let (mut sum, mut found) = (0.0f32, 0usize);
    let sc = math::sin_cos(pose.angle);
    let finder = diff.edge_finder(params);
    let params = &RefineParams {
        cap: sane_cap(params.cap),
        ..*params
    };
    for (i, (t, n)) in edge.iter().zip(normals).enumerate() {
        let nf = rotate_sc(sc, *n);
        let p = offset_point(pose.apply_sc(sc, *t), nf, shift.along(nf));
        let d = match finder.offset(p, nf) {
            Some(r) => {
                found += 1;
                r.abs().min(params.cap)
            }
            None => params.cap,
        };
        sum += d;
        if let Some(slot) = out.get_mut(i) {
            *slot = d;
        }
    }
    (sum, found)
}

/// The fraction of each side's points that the verification score averages (the nearest):
/// the recognizer's verification and a template's own spread ([`crate::Template`]) both use it.
pub const VERIFY_KEPT: f32 = 0.8;

/// [`RefineParams::cap`] as used: a cap that is not a number or negative caps nothing.
fn sane_cap(cap: f32) -> f32 {
    if cap >= 0.0 {
        cap
    } else {
        f32::INFINITY
    }
}

/// What one [`gauss_newton_step`] measured and where it goes.
#[derive(Debug, Clone, Copy)]
struct Step {
    /// The updated pose.
    next: Pose,
    /// The updated outline offset, px.
    offset: f32,
    /// The updated wall, px.
    wall: f32,
    /// How far the update moves the points along their normals (root mean square, px).
    moved: f32,
    /// How far the points were from the edge before the update (root mean square, px).
    fit: f32,
    /// The points' distances to the edge before the update, capped at `params.cap`; a profile
    /// without an edge counts the cap (as in [`edge_distances`]).
    capped_sum: f32,
    /// How many profiles found an edge.
    found: usize,
}

/// The alignment stops once an update moves the edge points along their normals by less than
/// this (root mean square), px. The update is still applied; the distances measured before it
/// stand for those after it.
const CONVERGED: f32 = 0.01;

/// [`RefineParams::give_up`] is first tested on this step (counting from 1, both stages): the
/// DP's seed can lie a pixel off, and the first steps of a right template can still find its
/// points far from the edge.
pub const GIVE_UP_AFTER: usize = 4;

/// Levenberg–Marquardt damping of the Gauss–Newton steps, relative to how far each direction
/// moves the edge points ([`gauss_newton_step`]).
const DAMPING: f32 = 1e-3;

/// The coarse stage (every 4th edge point) hands over to the fine one once an update moves the
/// points along their normals by less than this (root mean square), px.
const COARSE_SETTLED: f32 = 0.05;

/// The coarse stage also hands over once its points lie this close to the edge (root mean
/// square of the normal distances, px), however the pose still moves: a round part's rotation
/// is free and never settles.
const FIT_SETTLED: f32 = 0.25;

/// The coarse stage needs at least this many points (else every point is used throughout).
const COARSE_POINTS: usize = 16;

/// Steps the fine stage may always take, even when the coarse one used up the iterations.
const FINE_ITERATIONS: usize = 4;

/// One Gauss–Newton step on every `stride`-th edge point: the next pose, how far it moves the
/// points along their normals and how far they were from the edge before it (both root mean
/// square, px). An error when too few profiles find an edge (with the capped sum and the count
/// of those that did, as [`Step`] holds them), or without them when the system is singular or
/// the next pose is not finite or its scale leaves `[0.5, 2]`.
#[allow(clippy::too_many_arguments)]
fn gauss_newton_step<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    edge: &[[f32; 2]],
    normals: &[[f32; 2]],
    pose: Pose,
    shift: Shift,
    stride: usize,
    params: &RefineParams,
    record: &mut [f32],
) -> Result<Step, Option<(f32, usize)>> {
    if shift.can_wall() {
        gauss_newton_step_n::<B, 6>(diff, edge, normals, pose, shift, stride, params, record)
    } else if params.offset_max > 0.0 {
        gauss_newton_step_n::<B, 5>(diff, edge, normals, pose, shift, stride, params, record)
    } else {
        gauss_newton_step_n::<B, 4>(diff, edge, normals, pose, Shift::NONE, stride, params, record)
    }
}

/// How far a wall towards `toward` ([`RefineParams::wall_toward`]) moves an outline point of
/// (frame) outward normal `nf`, per px of wall: `max(0, n·u)`.
#[inline(always)]
pub fn wall_facing(nf: [f32; 2], toward: [f32; 2]) -> f32 {
    (nf[0] * toward[0] + nf[1] * toward[1]).max(0.0)
}

/// Where the outline lies off the template's along its outward normals: a uniform `offset`
/// and a `wall` on the side facing `toward` ([`RefineParams::wall_max`]).
#[derive(Debug, Clone, Copy)]
struct Shift {
    offset: f32,
    wall: f32,
    toward: [f32; 2],
    wall_max: f32,
}

impl Shift {
    const NONE: Shift = Shift {
        offset: 0.0,
        wall: 0.0,
        toward: [0.0, 0.0],
        wall_max: 0.0,
    };

    fn new(offset: f32, wall: f32, params: &RefineParams) -> Self {
        Shift {
            offset,
            wall,
            toward: params.wall_toward,
            wall_max: params.wall_max,
        }
    }

    /// Whether a wall may be fitted (a limit and a direction).
    fn can_wall(&self) -> bool {
        self.wall_max > 0.0 && (self.toward[0] != 0.0 || self.toward[1] != 0.0)
    }

    /// How far the wall moves a point of (frame) normal `nf` per px of wall.
    #[inline(always)]
    fn facing(&self, nf: [f32; 2]) -> f32 {
        wall_facing(nf, self.toward)
    }

    /// The shift of a point of (frame) normal `nf`, px along it.
    #[inline(always)]
    fn along(&self, nf: [f32; 2]) -> f32 {
        if self.wall == 0.0 {
            self.offset
        } else {
            self.offset + self.wall * self.facing(nf)
        }
    }
}

/// A template point `p` moved by the outline offset along its (frame) normal `nf`; the point
/// itself without an offset.
#[inline(always)]
fn offset_point(p: [f32; 2], nf: [f32; 2], offset: f32) -> [f32; 2] {
    if offset == 0.0 {
        p
    } else {
        [p[0] + offset * nf[0], p[1] + offset * nf[1]]
    }
}

/// [`gauss_newton_step`] with `N` parameters: translation, rotation and scale (`N = 4`), and
/// the outline offset (`N = 5`).
#[allow(clippy::too_many_arguments)]
fn gauss_newton_step_n<B: AsRef<[u8]>, const N: usize>(
    diff: &Difference<'_, B>,
    edge: &[[f32; 2]],
    normals: &[[f32; 2]],
    pose: Pose,
    shift: Shift,
    stride: usize,
    params: &RefineParams,
    record: &mut [f32],
) -> Result<Step, Option<(f32, usize)>> {
    // Normal equations for δ = (δx, δy, δθ, δs[, δo[, δw]]) of Σ (n·δp + δo + f·δw − r)², `f`
    // how far the wall moves the point (`max(0, n·u)`).
    let mut ata = [[0.0f32; N]; N];
    let mut atb = [0.0f32; N];
    let mut used = 0usize;
    let mut residual2 = 0.0f32;
    let mut lever2 = 0.0f32;
    let mut capped_sum = 0.0f32;
    let sc = math::sin_cos(pose.angle);
    let (s, c) = sc;
    let finder = diff.edge_finder(params);
    let (offset, wall) = (shift.offset, shift.wall);
    for (i, (t, n)) in edge.iter().zip(normals).enumerate().step_by(stride.max(1)) {
        let nf = rotate_sc(sc, *n);
        // (The wall's terms only in the six-parameter step: the others are as without one.)
        let facing = if N > 5 { shift.facing(nf) } else { 0.0 };
        let amount = if N > 5 { offset + wall * facing } else { offset };
        let p = offset_point(pose.apply_sc(sc, *t), nf, amount);
        let Some(r) = finder.offset_inline(p, nf) else {
            capped_sum += params.cap;
            if let Some(slot) = record.get_mut(i) {
                *slot = params.cap;
            }
            continue;
        };
        let d = r.abs().min(params.cap);
        capped_sum += d;
        if let Some(slot) = record.get_mut(i) {
            *slot = d;
        }
        // ∂p/∂θ = s·R'(θ)·t with R'(θ)t = (−t_x sinθ + t_y cosθ, −t_x cosθ − t_y sinθ).
        let dth = [pose.scale * (-t[0] * s + t[1] * c), pose.scale * (-t[0] * c - t[1] * s)];
        // ∂p/∂s = R(θ)·t.
        let ds = [t[0] * c + t[1] * s, -t[0] * s + t[1] * c];
        // ∂p/∂o = n (a unit normal: 1 along itself); ∂p/∂w = max(0, n·u)·n.
        let mut j = [1.0f32; N];
        for (slot, v) in j.iter_mut().zip([
            nf[0],
            nf[1],
            nf[0] * dth[0] + nf[1] * dth[1],
            nf[0] * ds[0] + nf[1] * ds[1],
            1.0,
            facing,
        ]) {
            *slot = v;
        }
        for a in 0..N {
            for b in a..N {
                ata[a][b] += j[a] * j[b];
            }
            atb[a] += j[a] * r;
        }
        residual2 += r * r;
        lever2 += t[0] * t[0] + t[1] * t[1];
        used += 1;
    }
    if used < N {
        return Err(Some((capped_sum, used)));
    }
    // The lower triangle mirrors the upper one.
    for a in 1..N {
        for b in 0..a {
            if let Some(v) = ata.get(b).and_then(|row| row.get(a)).copied() {
                if let Some(cell) = ata.get_mut(a).and_then(|row| row.get_mut(b)) {
                    *cell = v;
                }
            }
        }
    }
    // A touch of damping keeps a direction the edge cannot fix (the rotation of a round part)
    // from making the system singular; it then gets no update instead of noise. Each direction
    // is damped in proportion to how far it moves the points at all, Σ |∂p/∂δ|² (half of it:
    // what Σ (n·∂p/∂δ)² comes to for normals of every direction) — translation `m`, rotation
    // `s²·Σ|t|²`, scale `Σ|t|²`, offset `m` (twice: it moves every point by all of itself) — so
    // the damping is equally light in every direction that the edge does fix (one common
    // value, set by the large rotation and scale terms, held translation back to about half a
    // step per iteration).
    let undamped = ata;
    let half = 0.5 * used as f32;
    let lever = 0.5 * lever2;
    let damping = [half, half, lever * pose.scale * pose.scale, lever, 2.0 * half, half];
    for ((d, row), amount) in ata.iter_mut().enumerate().zip(damping) {
        if let Some(v) = row.get_mut(d) {
            *v += DAMPING * amount + 1e-12;
        }
    }
    let delta = solve_n(ata, atb).ok_or(None)?;
    let next = Pose {
        x: pose.x + delta[0],
        y: pose.y + delta[1],
        angle: pose.angle + delta[2],
        scale: pose.scale + delta[3],
    };
    // Within the limits (`max`/`min`, not `clamp`: a limit that is NaN or negative is none).
    let next_offset = match delta.get(4) {
        Some(d) => {
            let limit = params.offset_max.max(0.0);
            (shift.offset + d).max(-limit).min(limit)
        }
        None => shift.offset,
    };
    let next_wall = match delta.get(5) {
        Some(d) => (shift.wall + d).min(params.wall_max).max(0.0),
        None => shift.wall,
    };
    if !(next.x.is_finite()
        && next.y.is_finite()
        && next.angle.is_finite()
        && next_offset.is_finite()
        && next_wall.is_finite()
        && (0.5..=2.0).contains(&next.scale))
    {
        return Err(None);
    }
    // How far the update moves the edge points along their normals (root mean square, from the
    // normal equations: Σ (J·δ)² = δᵀ·JᵀJ·δ); motion along the edge does not count.
    let mut quad = 0.0f32;
    for (row, &da) in undamped.iter().zip(&delta) {
        for (&v, &db) in row.iter().zip(&delta) {
            quad += da * v * db;
        }
    }
    let moved = math::sqrt(quad.max(0.0) / used as f32);
    Ok(Step {
        next,
        offset: next_offset,
        wall: next_wall,
        moved,
        fit: math::sqrt(residual2 / used as f32),
        capped_sum,
        found: used,
    })
}

/// Solves a symmetric positive-definite `N`×`N` system by Gaussian elimination with partial
/// pivoting; `None` when singular.
fn solve_n<const N: usize>(mut a: [[f32; N]; N], mut b: [f32; N]) -> Option<[f32; N]> {
    for col in 0..N {
        let mut piv = col;
        for r in col + 1..N {
            if a[r][col].abs() > a[piv][col].abs() {
                piv = r;
            }
        }
        if !(a[piv][col].abs() > 1e-9) {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        let pivot_row = a[col];
        for r in col + 1..N {
            let f = a[r][col] / pivot_row[col];
            for (x, p) in a[r].iter_mut().zip(pivot_row.iter()).skip(col) {
                *x -= f * p;
            }
            b[r] -= f * b[col];
        }
    }
    let mut x = [0.0f32; N];
    for r in (0..N).rev() {
        let mut v = b[r];
        for k in r + 1..N {
            v -= a[r][k] * x[k];
        }
        x[r] = v / a[r][r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_rng::XorShift as Rng;

    #[test]
    fn profile_ray_positions_lie_on_the_normal() {
        let mut rng = Rng(0x5eed_0f7a_7500_1234);
        let mut checked = 0;
        for _ in 0..5000 {
            let scale = [1.0f32, 40.0, 700.0, 20_000.0][(rng.next() % 4) as usize];
            let p = [(rng.unit() - 0.5) * 2.0 * scale, (rng.unit() - 0.5) * 2.0 * scale];
            // Whole and half pixels too, where a floor is easy to get wrong.
            let p = match rng.next() % 5 {
                0 => [p[0].round(), p[1].round()],
                1 => [p[0].round() + 0.5, p[1].round() - 0.5],
                _ => p,
            };
            let a = rng.unit() * core::f32::consts::TAU;
            let normal = [a.cos(), a.sin()];
            let step = [0.25f32, 0.5, 0.3, 1.7][(rng.next() % 4) as usize];
            let steps = 2 + (rng.next() % 20) as i32;
            let ray = ProfileRay::new(p, normal, step, steps).unwrap();
            for k in -steps..=steps {
                let ([ix, iy], [tx, ty]) = ray.at(k);
                assert!(
                    (0.0..1.0).contains(&tx) && (0.0..1.0).contains(&ty),
                    "{p:?} k {k}: {tx} {ty}"
                );
                // In f64: the ray's position against p + k·step·normal.
                for (pix, t, want) in [
                    (ix, tx, p[0] as f64 + k as f64 * step as f64 * normal[0] as f64),
                    (iy, ty, p[1] as f64 + k as f64 * step as f64 * normal[1] as f64),
                ] {
                    let got = pix as f64 + t as f64;
                    let tolerance = (k.abs() + 2) as f64 / 65536.0 + 1e-7 * want.abs();
                    assert!(
                        (got - want).abs() <= tolerance,
                        "{p:?} {normal:?} k {k}: {got} vs {want}"
                    );
                }
                checked += 1;
            }
        }
        assert!(checked > 50_000);
        // Non-finite inputs and reaches beyond the limit make no ray.
        for (p, n, step, steps) in [
            ([f32::NAN, 1.0], [1.0, 0.0], 0.25, 12),
            ([1.0, f32::INFINITY], [1.0, 0.0], 0.25, 12),
            ([1.0, 1.0], [f32::NAN, 0.0], 0.25, 12),
            ([1.0, 1.0], [0.0, 1.0], 20.0, 1000),
        ] {
            assert_eq!(ProfileRay::new(p, n, step, steps), None, "{p:?} {n:?} {step} {steps}");
        }
        // Far points are clamped, not wrapped: the profile still reads the image's border.
        let far = ProfileRay::new([3e9, -3e9], [1.0, 0.0], 0.25, 12).unwrap();
        assert_eq!(far.at(0).0, [1 << 30, -(1 << 30)]);
    }

    /// A square's 72 edge points (offsets from its centre, 18 evenly spaced a side) and outward
    /// normals, half side `half`.
    fn square_edge(half: f32) -> ([[f32; 2]; 72], [[f32; 2]; 72]) {
        let (mut edge, mut normals) = ([[0.0f32; 2]; 72], [[0.0f32; 2]; 72]);
        for k in 0..72 {
            let t = -half + 2.0 * half * ((k % 18) as f32 + 0.5) / 18.0;
            (edge[k], normals[k]) = match k / 18 {
                0 => ([t, -half], [0.0, -1.0]),
                1 => ([half, t], [1.0, 0.0]),
                2 => ([-t, half], [0.0, 1.0]),
                _ => ([-half, -t], [-1.0, 0.0]),
            };
        }
        (edge, normals)
    }

    /// Aligns a square's edge points (offsets from its centre, outward normals) from a seed at
    /// (24, 24), angle 0, onto a bright square drawn (8×8 supersampled, unblurred) with centre
    /// `(cx, cy)`, half-side `half`, turned by `turn` (radians, counter-clockwise on screen).
    fn square_alignment(cx: f32, cy: f32, half: f32, turn: f32) -> Alignment {
        let (w, h) = (48usize, 48usize);
        let mut frame_px = [0u8; 48 * 48];
        let bg = [50u8; 48 * 48];
        for y in 0..h {
            for x in 0..w {
                // Supersampled coverage of the turned square.
                let mut cover = 0.0;
                for sy in 0..8 {
                    for sx in 0..8 {
                        let (px, py) = (
                            x as f32 + (sx as f32 + 0.5) / 8.0 - 0.5 - cx,
                            y as f32 + (sy as f32 + 0.5) / 8.0 - 0.5 - cy,
                        );
                        let (u, v) = (px * turn.cos() - py * turn.sin(), px * turn.sin() + py * turn.cos());
                        if u.abs() <= half && v.abs() <= half {
                            cover += 1.0 / 64.0;
                        }
                    }
                }
                frame_px[y * w + x] = (50.0 + 150.0 * cover + 0.5) as u8;
            }
        }
        let frame = Frame::new_checked(&frame_px[..], w, h).unwrap();
        let diff = Difference::new(&frame, &bg[..], Alpha::ONE);
        let (edge, normals) = square_edge(half);
        let seed = Pose {
            x: 24.0,
            y: 24.0,
            angle: 0.0,
            scale: 1.0,
        };
        let params = RefineParams::DEFAULT;
        let a = align(&diff, &edge, &normals, seed, &params);
        // The distances come from the last step's profiles when it converged; they must stand
        // for those at the final pose.
        let (sum, found) = edge_distances(&diff, &edge, &normals, a.pose, a.offset, &params, &mut []);
        assert!((a.distance - sum / 72.0).abs() < 2e-3, "{a:?}: {}", sum / 72.0);
        assert_eq!(a.coverage, found as f32 / 72.0, "{a:?}");
        a
    }

    #[test]
    fn alignment_converges_from_a_seed_off_by_ten_degrees() {
        // Seeds are 0.4–1.2 px and up to 10° off. An unblurred edge leaves the bilinear crossing
        // a few hundredths of a pixel off; the generated sets (`scripts/accuracy.sh`) measure the
        // accuracy on blurred parts, this test the convergence.
        for (cx, cy, deg) in [(24.4f32, 23.7f32, 10.0f32), (23.2, 24.9, -10.0), (24.0, 24.3, 3.0)] {
            let a = square_alignment(cx, cy, 9.0, deg.to_radians());
            assert!(
                (a.pose.x - cx).abs() < 0.1 && (a.pose.y - cy).abs() < 0.1,
                "{deg}°: {:?}",
                a.pose
            );
            assert!((a.pose.angle.to_degrees() - deg).abs() < 0.3, "{deg}°: {:?}", a.pose);
            assert!(a.settled, "{deg}°: {a:?}");
            assert!(
                (a.pose.scale - 1.0).abs() < 0.01 && a.distance < 0.2 && a.coverage > 0.9,
                "{a:?}"
            );
        }
    }

    /// Side of the frames of [`blurred_square`].
    const SQUARE_W: usize = 64;

    /// A 64×64 frame: an axis-aligned square of half side `half` centred at (`cx`, `cy`), 200
    /// on a background of 50, its edge blurred over about 1.5 px.
    fn blurred_square(cx: f32, cy: f32, half: f32) -> [u8; SQUARE_W * SQUARE_W] {
        let mut frame_px = [0u8; SQUARE_W * SQUARE_W];
        for (i, px) in frame_px.iter_mut().enumerate() {
            let (x, y) = ((i % SQUARE_W) as f32 - cx, (i / SQUARE_W) as f32 - cy);
            let d = x.abs().max(y.abs()) - half;
            *px = (50.0 + 150.0 * (0.5 - d / 1.5).clamp(0.0, 1.0) + 0.5) as u8;
        }
        frame_px
    }

    #[test]
    fn one_step_recovers_a_translation_on_a_large_part() {
        // A 48 px square, edge blurred over about 1.5 px, 0.5 px off the seed. The rotation and
        // scale terms of the normal equations are hundreds of times the translation terms here;
        // damping must not hold the translation back (a common damping of 1e-3 of the mean
        // diagonal recovered only about 70 % of it per step).
        let (cx, cy, half) = (32.3f32, 31.6f32, 24.0f32);
        let frame_px = blurred_square(cx, cy, half);
        let bg = [50u8; SQUARE_W * SQUARE_W];
        let frame = Frame::new_checked(&frame_px[..], SQUARE_W, SQUARE_W).unwrap();
        let diff = Difference::new(&frame, &bg[..], Alpha::ONE);
        let (edge, normals) = square_edge(half);
        for (ox, oy) in [(0.5f32, 0.0f32), (0.0, -0.5), (-0.35, 0.35)] {
            let seed = Pose {
                x: cx + ox,
                y: cy + oy,
                angle: 0.0,
                scale: 1.0,
            };
            let step = gauss_newton_step(
                &diff,
                &edge,
                &normals,
                seed,
                Shift::NONE,
                1,
                &RefineParams::DEFAULT,
                &mut [],
            )
            .unwrap();
            let (ex, ey) = (step.next.x - cx, step.next.y - cy);
            assert!(
                math::hypot(ex, ey) < 0.1 * math::hypot(ox, oy),
                "offset ({ox}, {oy}) left ({ex}, {ey}) after one step: {:?}",
                step.next
            );
            // Every offset here moves the points by 0.5/√2 px along their normals (RMS).
            assert!((step.moved - 0.3536).abs() < 0.02 && step.found == 72, "{step:?}");
        }
    }

    /// A thick part seen by a close lens: the top face (a 32 px square) swept 4 px towards the
    /// principal point (+x), blurred like [`blurred_square`]. With the wall free the alignment
    /// finds the top face (its centre within 0.1 px, the wall within 0.3 px of 4); with the
    /// offset alone the pose moves half the wall towards it.
    #[test]
    fn a_wall_towards_the_principal_point_leaves_the_top_face() {
        let (cx, cy, half, wall) = (28.3f32, 31.6f32, 16.0f32, 4.0f32);
        let mut frame_px = [0u8; SQUARE_W * SQUARE_W];
        for (i, px) in frame_px.iter_mut().enumerate() {
            let (x, y) = ((i % SQUARE_W) as f32, (i / SQUARE_W) as f32);
            let dx = (x - (cx + half + wall)).max((cx - half) - x);
            let d = dx.max((y - cy).abs() - half);
            *px = (50.0 + 150.0 * (0.5 - d / 1.5).clamp(0.0, 1.0) + 0.5) as u8;
        }
        let bg = [50u8; SQUARE_W * SQUARE_W];
        let frame = Frame::new_checked(&frame_px[..], SQUARE_W, SQUARE_W).unwrap();
        let diff = Difference::new(&frame, &bg[..], Alpha::ONE);
        let (edge, normals) = square_edge(half);
        let seed = Pose {
            x: cx + 1.0,
            y: cy - 0.5,
            angle: 0.0,
            scale: 1.0,
        };
        let walled = RefineParams {
            offset_max: 1.0,
            wall_max: 8.0,
            wall_toward: [1.0, 0.0],
            ..RefineParams::DEFAULT
        };
        let mut distances = [0.0f32; 72];
        let a = align_recording(&diff, &edge, &normals, seed, &walled, &mut distances);
        assert!(!a.gave_up, "{a:?}");
        assert!((a.pose.x - cx).abs() < 0.1 && (a.pose.y - cy).abs() < 0.1, "{a:?}");
        assert!(
            (a.pose.scale - 1.0).abs() < 0.01 && (a.wall - wall).abs() < 0.3,
            "{a:?}"
        );
        // Its distances are those of the walled outline: every point on the edge.
        assert!(
            a.distance < 0.1 && distances.iter().all(|d| *d < 0.3),
            "{a:?} {distances:?}"
        );
        let (sum, _) = edge_distances_walled(&diff, &edge, &normals, a.pose, a.offset, a.wall, &walled, &mut []);
        assert!((sum / 72.0 - a.distance).abs() < 2e-3, "{a:?}");
        // Without the wall the pose takes up the sweep: half of it off the top face.
        let flat = RefineParams {
            offset_max: 1.0,
            ..RefineParams::DEFAULT
        };
        let b = align(&diff, &edge, &normals, seed, &flat);
        assert!(b.wall == 0.0 && b.pose.x - cx > 1.0, "{b:?}");
    }

    /// 72 edge points (offsets from the centre, evenly spaced along each side) and outward
    /// normals of a closed counter-clockwise-on-screen polygon given by its `corners`
    /// (`72 / corners.len()` points a side).
    fn polygon_edge(corners: &[[f32; 2]]) -> ([[f32; 2]; 72], [[f32; 2]; 72]) {
        let (mut edge, mut normals) = ([[0.0f32; 2]; 72], [[0.0f32; 2]; 72]);
        let per_side = 72 / corners.len();
        for k in 0..72 {
            let side = (k / per_side).min(corners.len() - 1);
            let (a, b) = (corners[side], corners[(side + 1) % corners.len()]);
            let f = ((k - side * per_side) as f32 + 0.5) / per_side as f32;
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len = (dx * dx + dy * dy).sqrt();
            edge[k] = [a[0] + f * dx, a[1] + f * dy];
            // Counter-clockwise on screen (y down): the outside lies to the right of the way.
            normals[k] = [-dy / len, dx / len];
        }
        (edge, normals)
    }

    #[test]
    fn a_wrong_template_gives_up_and_the_right_one_does_not() {
        // A 24 px square, edge blurred over about 1.5 px, seen from seeds up to 1 px and 4° off;
        // the right template never gives up (and ends where it would without the rule), a
        // triangle of about the same area gives up with its points far off the edge.
        let (cx, cy, half) = (32.3f32, 31.6f32, 12.0f32);
        let frame_px = blurred_square(cx, cy, half);
        let bg = [50u8; SQUARE_W * SQUARE_W];
        let frame = Frame::new_checked(&frame_px[..], SQUARE_W, SQUARE_W).unwrap();
        let diff = Difference::new(&frame, &bg[..], Alpha::ONE);
        let strict = RefineParams {
            give_up: 1.2,
            ..RefineParams::DEFAULT
        };
        let h = half + 0.5;
        let (square, square_normals) = polygon_edge(&[[h, h], [h, -h], [-h, -h], [-h, h]]);
        let (triangle, triangle_normals) = polygon_edge(&[[18.25, 10.5], [0.0, -21.0], [-18.25, 10.5]]);
        let (bar, bar_normals) = polygon_edge(&[[20.0, 4.0], [20.0, -4.0], [-20.0, -4.0], [-20.0, 4.0]]);
        for (ox, oy, deg) in [(0.6f32, -0.4f32, 4.0f32), (-1.0, 0.0, -3.0), (0.0, 0.7, 0.0)] {
            let seed = Pose {
                x: cx + ox,
                y: cy + oy,
                angle: deg.to_radians(),
                scale: 1.0,
            };
            let free = align(&diff, &square, &square_normals, seed, &RefineParams::DEFAULT);
            let right = align(&diff, &square, &square_normals, seed, &strict);
            assert_eq!(right, free, "seed {seed:?}");
            assert!(!right.gave_up && right.settled && right.distance < 0.2, "{right:?}");
            let wrong = align(&diff, &triangle, &triangle_normals, seed, &strict);
            assert!(wrong.gave_up && !wrong.settled && wrong.distance > 1.2, "{wrong:?}");
            // Without the rule the triangle still ends far from the edge: the verification
            // would not have taken it either.
            let wrong_free = align(&diff, &triangle, &triangle_normals, seed, &RefineParams::DEFAULT);
            assert!(!wrong_free.gave_up && wrong_free.distance > 0.6, "{wrong_free:?}");
            // A bar whose profiles nearly all miss the square cannot take a step: it gives up
            // at the seed on those profiles' distances, where it would be measured once more.
            let missed = align(&diff, &bar, &bar_normals, seed, &strict);
            let measured = align(&diff, &bar, &bar_normals, seed, &RefineParams::DEFAULT);
            assert!(
                missed.gave_up && missed.pose == seed && missed.distance > 1.2,
                "{missed:?}"
            );
            assert!(
                !measured.gave_up && measured.pose == seed && measured.distance > 1.2,
                "{measured:?}"
            );
        }
    }

    #[test]
    fn pose_invert_undoes_apply() {
        let pose = Pose {
            x: 12.5,
            y: -3.0,
            angle: 2.3,
            scale: 1.7,
        };
        for t in [[0.0, 0.0], [3.0, -4.0], [-10.0, 0.5]] {
            let back = pose.invert(pose.apply(t)).unwrap();
            assert!(
                (back[0] - t[0]).abs() < 1e-4 && (back[1] - t[1]).abs() < 1e-4,
                "{t:?} → {back:?}"
            );
        }
        assert!(Pose { scale: 0.0, ..pose }.invert([1.0, 1.0]).is_none());
    }
}
