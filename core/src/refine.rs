//! Refine and verify: sub-pixel pose by point-to-line alignment, and the verification score.
//!
//! The paper's pose (eqs. 6.1–6.4 on `n` resampled points) is coarse, and its descriptor alone
//! confuses near-similar parts. This stage works on the frame itself (DESIGN.md, "Beyond the
//! paper"):
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
//!   sampling until they move by less than 0.001 px (the right template settles in 2–3 coarse
//!   and 2–3 fine steps from the DP's seed; a wrong one reaches the step limit without settling
//!   and is not refined further). The distances of a converged last step stand for those at the
//!   final pose (it moved the points by less than 0.001 px); otherwise they are measured once
//!   more. The profiles are scanned from the point outwards and stop at the nearest crossing,
//!   so a pose near the edge reads about 8 of a profile's 25 samples, and consecutive samples
//!   in the same pixel cell reuse its four differences. On the bench set (142 alignments over
//!   30 frames) an alignment costs about 0.47 M x86 instructions (1.05 M before the per-direction
//!   damping, the reused distances and the cell cache). Time `O(m·search/step)` per step, no
//!   memory beyond a few numbers.
//! - **Verification**: the mean of the capped normal distances (profiles that find no edge count
//!   the cap), plus how far the part's own border lies from the aligned template outline, plus a
//!   penalty for a scale far from 1 — both ways, so a template that covers only part of the
//!   outline cannot look good. The lowest score among the DP's best candidates wins; above a
//!   threshold the part is unknown.
//!
//! The part's position is measured separately, by [`crate::partial_volume`].
//!
//! Guards: a profile with less contrast than `min_contrast` between its ends has no edge; a pose
//! update that is not finite, or a scale outside `[0.5, 2]`, stops the alignment at the last good
//! pose.

use crate::enhance::Alpha;
use crate::frame::Frame;
use crate::math;

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
    let n = points.len();
    let (prev, next) = (points.get((k + n - 1) % n.max(1))?, points.get((k + 1) % n.max(1))?);
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
    /// Distances are capped here when averaged for the verification score, px.
    pub cap: f32,
    /// Weight of `|ln scale|` in the verification score (px per unit of log-scale).
    pub scale_penalty: f32,
}

impl RefineParams {
    /// The defaults.
    pub const DEFAULT: RefineParams = RefineParams {
        iterations: 12,
        search: 3.0,
        step: 0.25,
        min_contrast: 8.0,
        cap: 2.0,
        scale_penalty: 4.0,
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
        let (w, h) = (self.frame.width() as isize, self.frame.height() as isize);
        let xc = x.clamp(0, w - 1);
        let yc = y.clamp(0, h - 1);
        let b = self.background.get((yc * w + xc) as usize).copied().unwrap_or(0) as f32;
        if self.alpha.get() >= 1.0 {
            // The default α = 1: a subtraction, small enough to inline into the callers' loops.
            return self.frame.get_clamped(xc, yc) as f32 - b;
        }
        self.enhanced(xc, yc) - b
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
            x.clamp(-2.0, self.width() as f32 + 1.0),
            y.clamp(-2.0, self.height() as f32 + 1.0),
        );
        let (fx, fy) = (math::floor(x), math::floor(y));
        let (tx, ty) = (x - fx, y - fy);
        let (ix, iy) = (fx as isize, fy as isize);
        let top = self.at(ix, iy) * (1.0 - tx) + self.at(ix + 1, iy) * tx;
        let bottom = self.at(ix, iy + 1) * (1.0 - tx) + self.at(ix + 1, iy + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// [`Self::bilinear`] through a one-cell cache: where `α = 1` and the 2×2 neighbourhood lies
    /// inside the image, its four differences are read once into `cell` and reused while the
    /// position stays in that cell (consecutive samples of a profile mostly do); elsewhere
    /// [`Self::bilinear_by_pixels`]. Either way the same arithmetic, so the same value.
    #[inline(always)]
    fn bilinear_cached(&self, x: f32, y: f32, cell: &mut Cell) -> f32 {
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

    /// The signed offset along `normal` (unit, pointing out of the part) from `p` to the
    /// half-contrast crossing nearest `p`, or `None` when the profile holds no edge.
    ///
    /// The profile is `2·search/step + 1` samples `D(p + k·step·normal)`; the level is the mean
    /// of the two ends (two samples each), and an edge is a fall from the inner side's level to
    /// the outer's between two samples, placed by linear interpolation. Intervals are visited
    /// from `p` outwards and the scan stops once no farther interval can hold a nearer crossing,
    /// so a pose already near the edge reads about 9 samples instead of 25. Of two crossings at
    /// the same distance the inner one wins.
    pub fn edge_offset(&self, p: [f32; 2], normal: [f32; 2], params: &RefineParams) -> Option<f32> {
        let steps = (params.search / params.step) as i32;
        // A profile of more than MAX_PROFILE_STEPS samples a side (a step of 0 or NaN included)
        // is a misconfiguration, not a profile.
        if !(2..=MAX_PROFILE_STEPS).contains(&steps) || !(params.step > 0.0) {
            return None;
        }
        let sample = |k: i32, cell: &mut Cell| {
            let u = k as f32 * params.step;
            self.bilinear_cached(p[0] + u * normal[0], p[1] + u * normal[1], cell)
        };
        // One cell cache for each side of the profile: the ends first, then the scan outwards.
        let (mut inner, mut outer) = (Cell::EMPTY, Cell::EMPTY);
        let outer_end = sample(-steps, &mut inner);
        let d_in = 0.5 * (outer_end + sample(-steps + 1, &mut inner));
        let d_out = 0.5 * (sample(steps, &mut outer) + sample(steps - 1, &mut outer));
        if !((d_in - d_out).abs() >= params.min_contrast) {
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
                    let u = ((k - 1) as f32 + t) * params.step;
                    if best.is_none_or(|b| u.abs() < b.abs() || (u.abs() == b.abs() && u < b)) {
                        best = Some(u);
                    }
                }
            }
            (neg, pos) = (before, after);
            if best.is_some_and(|b| b.abs() < (r + 1) as f32 * params.step) {
                break;
            }
        }
        best
    }
}

/// A 2×2 cell of `D` read by [`Difference::bilinear_cached`]: its top-left pixel and the four
/// differences (top-left, top-right, bottom-left, bottom-right).
#[derive(Debug, Clone, Copy)]
struct Cell {
    at: (usize, usize),
    d: [f32; 4],
}

impl Cell {
    /// No cell yet (no pixel of an image lies at `usize::MAX`).
    const EMPTY: Cell = Cell {
        at: (usize::MAX, usize::MAX),
        d: [0.0; 4],
    };
}

/// Most samples on each side of a profile ([`Difference::edge_offset`] finds no edge beyond).
pub const MAX_PROFILE_STEPS: i32 = 1024;

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
    let coarse_stride = if edge.len() >= 4 * COARSE_POINTS { 4 } else { 1 };
    let mut pose = seed;
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
    'stages: for (coarse_stage, stride, settled, prm) in stages {
        let mut calm = false;
        while left > 0 {
            left -= 1;
            let Some(step) = gauss_newton_step(diff, edge, normals, pose, stride, prm) else {
                break 'stages;
            };
            pose = step.next;
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
    let (sum, found) = converged_distances.unwrap_or_else(|| capped_distances(diff, edge, normals, pose, params));
    let count = edge.len().min(normals.len()).max(1) as f32;
    Alignment {
        pose,
        distance: sum / count,
        coverage: found as f32 / count,
        settled: settled_once,
    }
}

/// The sum of the capped distances from the edge points at `pose` to the part's edge (profiles
/// without an edge count the cap), and how many profiles found an edge.
fn capped_distances<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    edge: &[[f32; 2]],
    normals: &[[f32; 2]],
    pose: Pose,
    params: &RefineParams,
) -> (f32, usize) {
    let (mut sum, mut found) = (0.0f32, 0usize);
    let sc = math::sin_cos(pose.angle);
    for (t, n) in edge.iter().zip(normals) {
        let p = pose.apply_sc(sc, *t);
        let nf = rotate_sc(sc, *n);
        match diff.edge_offset(p, nf, params) {
            Some(r) => {
                sum += r.abs().min(params.cap);
                found += 1;
            }
            None => sum += params.cap,
        }
    }
    (sum, found)
}

/// What one [`gauss_newton_step`] measured and where it goes.
#[derive(Debug, Clone, Copy)]
struct Step {
    /// The updated pose.
    next: Pose,
    /// How far the update moves the points along their normals (root mean square, px).
    moved: f32,
    /// How far the points were from the edge before the update (root mean square, px).
    fit: f32,
    /// The points' distances to the edge before the update, capped at `params.cap`; a profile
    /// without an edge counts the cap (as [`capped_distances`]).
    capped_sum: f32,
    /// How many profiles found an edge.
    found: usize,
}

/// The alignment stops once an update moves the edge points along their normals by less than
/// this (root mean square), px.
const CONVERGED: f32 = 1e-3;

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
/// square, px); `None` when too few profiles find an edge, the system is singular, or the next
/// pose is not finite or its scale leaves `[0.5, 2]`.
fn gauss_newton_step<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    edge: &[[f32; 2]],
    normals: &[[f32; 2]],
    pose: Pose,
    stride: usize,
    params: &RefineParams,
) -> Option<Step> {
    // Normal equations for δ = (δx, δy, δθ, δs) of Σ (n·δp − r)².
    let mut ata = [[0.0f32; 4]; 4];
    let mut atb = [0.0f32; 4];
    let mut used = 0usize;
    let mut residual2 = 0.0f32;
    let mut lever2 = 0.0f32;
    let mut capped_sum = 0.0f32;
    let sc = math::sin_cos(pose.angle);
    let (s, c) = sc;
    for (t, n) in edge.iter().zip(normals).step_by(stride.max(1)) {
        let p = pose.apply_sc(sc, *t);
        let nf = rotate_sc(sc, *n);
        let Some(r) = diff.edge_offset(p, nf, params) else {
            capped_sum += params.cap;
            continue;
        };
        capped_sum += r.abs().min(params.cap);
        // ∂p/∂θ = s·R'(θ)·t with R'(θ)t = (−t_x sinθ + t_y cosθ, −t_x cosθ − t_y sinθ).
        let dth = [pose.scale * (-t[0] * s + t[1] * c), pose.scale * (-t[0] * c - t[1] * s)];
        // ∂p/∂s = R(θ)·t.
        let ds = [t[0] * c + t[1] * s, -t[0] * s + t[1] * c];
        let j = [
            nf[0],
            nf[1],
            nf[0] * dth[0] + nf[1] * dth[1],
            nf[0] * ds[0] + nf[1] * ds[1],
        ];
        for a in 0..4 {
            for b in a..4 {
                ata[a][b] += j[a] * j[b];
            }
            atb[a] += j[a] * r;
        }
        residual2 += r * r;
        lever2 += t[0] * t[0] + t[1] * t[1];
        used += 1;
    }
    if used < 4 {
        return None;
    }
    // The lower triangle mirrors the upper one.
    for (a, b) in [(1, 0), (2, 0), (2, 1), (3, 0), (3, 1), (3, 2)] {
        if let Some(v) = ata.get(b).and_then(|row| row.get(a)).copied() {
            if let Some(cell) = ata.get_mut(a).and_then(|row| row.get_mut(b)) {
                *cell = v;
            }
        }
    }
    // A touch of damping keeps a direction the edge cannot fix (the rotation of a round part)
    // from making the system singular; it then gets no update instead of noise. Each direction
    // is damped in proportion to how far it moves the points at all, Σ |∂p/∂δ|² (half of it:
    // what Σ (n·∂p/∂δ)² comes to for normals of every direction) — translation `m`, rotation
    // `s²·Σ|t|²`, scale `Σ|t|²` — so the damping is equally light in every direction that the
    // edge does fix (one common value, set by the large rotation and scale terms, held
    // translation back to about half a step per iteration).
    let undamped = ata;
    let half = 0.5 * used as f32;
    let lever = 0.5 * lever2;
    let damping = [half, half, lever * pose.scale * pose.scale, lever];
    for ((d, row), amount) in ata.iter_mut().enumerate().zip(damping) {
        if let Some(v) = row.get_mut(d) {
            *v += DAMPING * amount + 1e-12;
        }
    }
    let delta = solve4(ata, atb)?;
    let next = Pose {
        x: pose.x + delta[0],
        y: pose.y + delta[1],
        angle: pose.angle + delta[2],
        scale: pose.scale + delta[3],
    };
    if !(next.x.is_finite() && next.y.is_finite() && next.angle.is_finite() && (0.5..=2.0).contains(&next.scale)) {
        return None;
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
    Some(Step {
        next,
        moved,
        fit: math::sqrt(residual2 / used as f32),
        capped_sum,
        found: used,
    })
}

/// Solves a symmetric positive-definite 4×4 system by Gaussian elimination with partial pivoting;
/// `None` when singular.
fn solve4(mut a: [[f32; 4]; 4], mut b: [f32; 4]) -> Option<[f32; 4]> {
    for col in 0..4 {
        let mut piv = col;
        for r in col + 1..4 {
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
        for r in col + 1..4 {
            let f = a[r][col] / pivot_row[col];
            for (x, p) in a[r].iter_mut().zip(pivot_row.iter()).skip(col) {
                *x -= f * p;
            }
            b[r] -= f * b[col];
        }
    }
    let mut x = [0.0f32; 4];
    for r in (0..4).rev() {
        let mut v = b[r];
        for k in r + 1..4 {
            v -= a[r][k] * x[k];
        }
        x[r] = v / a[r][r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Distances from points to a closed polyline (the template outline in verification).
///
/// ```
/// use vorl_core::refine::Outline;
/// let square = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
/// let outline = Outline::new(&square);
/// assert!((outline.capped_distance([5.0, 1.0], 5.0) - 1.0).abs() < 1e-6);
/// assert_eq!(outline.capped_distance([5.0, 5.0], 2.0), 2.0); // capped
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Outline<'a> {
    points: &'a [[f32; 2]],
    /// The longest segment, px.
    longest: f32,
}

impl<'a> Outline<'a> {
    /// The closed polyline through `points` (the last joins the first).
    pub fn new(points: &'a [[f32; 2]]) -> Self {
        let mut longest2 = 0.0f32;
        let mut prev = points.last().copied().unwrap_or([0.0; 2]);
        for &p in points {
            longest2 = longest2.max((p[0] - prev[0]) * (p[0] - prev[0]) + (p[1] - prev[1]) * (p[1] - prev[1]));
            prev = p;
        }
        Outline {
            points,
            longest: math::sqrt(longest2),
        }
    }

    /// The distance from `q` to the polyline, or `cap` when that is less (also for a polyline
    /// of fewer than 2 points). `O(points)`, but a segment whose start lies farther than
    /// `best + longest` from `q` (it cannot come nearer than `best`) costs a single comparison.
    pub fn capped_distance(&self, q: [f32; 2], cap: f32) -> f32 {
        let len = self.points.len();
        if len < 2 {
            return cap;
        }
        let mut best = cap * cap;
        let mut reject = (cap + self.longest) * (cap + self.longest);
        let mut prev = self.points.last().copied().unwrap_or([0.0; 2]);
        for &cur in self.points {
            let (dx, dy) = (prev[0] - q[0], prev[1] - q[1]);
            if dx * dx + dy * dy < reject {
                let c = crate::pose::closest_on_segment(q, prev, cur);
                let d = (c[0] - q[0]) * (c[0] - q[0]) + (c[1] - q[1]) * (c[1] - q[1]);
                if d < best {
                    best = d;
                    let r = math::sqrt(d) + self.longest;
                    reject = r * r;
                }
            }
            prev = cur;
        }
        math::sqrt(best)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    /// The profile scan as first written: every sample, every crossing, the nearest kept.
    fn edge_offset_full<B: AsRef<[u8]>>(
        diff: &Difference<'_, B>,
        p: [f32; 2],
        normal: [f32; 2],
        params: &RefineParams,
    ) -> Option<f32> {
        let steps = (params.search / params.step) as i32;
        if steps < 2 {
            return None;
        }
        let sample = |k: i32| {
            let u = k as f32 * params.step;
            diff.bilinear_by_pixels(p[0] + u * normal[0], p[1] + u * normal[1])
        };
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
                        edge_offset_full(&diff, p, normal, prm),
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
        let (mut edge, mut normals) = ([[0.0f32; 2]; 72], [[0.0f32; 2]; 72]);
        for k in 0..72 {
            let side = k / 18;
            let t = -half + 2.0 * half * ((k % 18) as f32 + 0.5) / 18.0;
            (edge[k], normals[k]) = match side {
                0 => ([t, -half], [0.0, -1.0]),
                1 => ([half, t], [1.0, 0.0]),
                2 => ([-t, half], [0.0, 1.0]),
                _ => ([-half, -t], [-1.0, 0.0]),
            };
        }
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
        let (sum, found) = capped_distances(&diff, &edge, &normals, a.pose, &params);
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

    #[test]
    fn one_step_recovers_a_translation_on_a_large_part() {
        // A 48 px square, edge blurred over about 1.5 px, 0.5 px off the seed. The rotation and
        // scale terms of the normal equations are hundreds of times the translation terms here;
        // damping must not hold the translation back (a common damping of 1e-3 of the mean
        // diagonal recovered only about 70 % of it per step).
        const W: usize = 64;
        let (cx, cy, half) = (32.3f32, 31.6f32, 24.0f32);
        let mut frame_px = [0u8; W * W];
        for (i, px) in frame_px.iter_mut().enumerate() {
            let (x, y) = ((i % W) as f32 - cx, (i / W) as f32 - cy);
            let d = x.abs().max(y.abs()) - half;
            *px = (50.0 + 150.0 * (0.5 - d / 1.5).clamp(0.0, 1.0) + 0.5) as u8;
        }
        let bg = [50u8; W * W];
        let frame = Frame::new_checked(&frame_px[..], W, W).unwrap();
        let diff = Difference::new(&frame, &bg[..], Alpha::ONE);
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
        for (ox, oy) in [(0.5f32, 0.0f32), (0.0, -0.5), (-0.35, 0.35)] {
            let seed = Pose {
                x: cx + ox,
                y: cy + oy,
                angle: 0.0,
                scale: 1.0,
            };
            let step = gauss_newton_step(&diff, &edge, &normals, seed, 1, &RefineParams::DEFAULT).unwrap();
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

    #[test]
    fn outline_distance_matches_every_segment() {
        let mut rng = Rng(0x1234_5678_9abc_def1);
        for _ in 0..200 {
            let len = 2 + (rng.next() % 40) as usize;
            let mut pts = [[0.0f32; 2]; 41];
            for p in pts.iter_mut().take(len) {
                *p = [rng.unit() * 20.0, rng.unit() * 20.0];
            }
            let outline = Outline::new(&pts[..len]);
            for _ in 0..20 {
                let q = [rng.unit() * 30.0 - 5.0, rng.unit() * 30.0 - 5.0];
                let cap = rng.unit() * 6.0;
                let mut best = cap;
                for i in 0..len {
                    let (a, b) = (pts[(i + len - 1) % len], pts[i]);
                    let c = crate::pose::closest_on_segment(q, a, b);
                    best = best.min(math::hypot(c[0] - q[0], c[1] - q[1]));
                }
                let got = outline.capped_distance(q, cap);
                assert!((got - best).abs() <= 1e-5 * (1.0 + best), "{got} vs {best}");
            }
        }
        assert_eq!(Outline::new(&[[1.0, 1.0]]).capped_distance([0.0, 0.0], 3.0), 3.0);
        assert_eq!(Outline::new(&[]).capped_distance([0.0, 0.0], 3.0), 3.0);
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
