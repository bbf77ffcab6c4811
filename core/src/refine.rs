//! Refine and verify: sub-pixel pose by point-to-line alignment, and the partial-volume centroid.
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
//!   translation, rotation and scale; a dozen steps converge from the DP's seed. Time
//!   `O(m·search/step)` per step, no memory beyond a few numbers.
//! - **Verification**: the mean of the capped normal distances (profiles that find no edge count
//!   the cap), plus how far the part's own border lies from the aligned template outline, plus a
//!   penalty for a scale far from 1 — both ways, so a template that covers only part of the
//!   outline cannot look good. The lowest score among the DP's best candidates wins; above a
//!   threshold the part is unknown.
//! - **Partial-volume centroid** ([`partial_volume_centroid`]): the part's area centroid with its
//!   edge pixels counted by coverage: pixels well inside count 1, pixels in a 2-px band around
//!   the mask's edge count `D / C` clipped to `[0, 1]`, where `C` is the local contrast: the mean
//!   difference of the ring pixels 3–4 px inside the edge within 4 px of the band pixel (so
//!   shading across the part does not tilt the weights), or the ring's median where none is near. With blur symmetric about the edge,
//!   that is the centroid of the true silhouette to a few hundredths of a pixel.
//!
//! Guards: a profile with less contrast than `min_contrast` between its ends has no edge; a pose
//! update that is not finite, or a scale outside `[0.5, 2]`, stops the alignment at the last good
//! pose; a part with no interior ring falls back to the mean of the band's extremes.

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
        let (s, c) = math::sin_cos(self.angle);
        [
            self.x + self.scale * (t[0] * c + t[1] * s),
            self.y + self.scale * (-t[0] * s + t[1] * c),
        ]
    }

    /// Rotates (and scales) a direction without translating it.
    #[inline]
    pub fn rotate(&self, v: [f32; 2]) -> [f32; 2] {
        let (s, c) = math::sin_cos(self.angle);
        [v[0] * c + v[1] * s, -v[0] * s + v[1] * c]
    }
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
    /// Gauss–Newton steps.
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
        let a = self.alpha.get();
        let i = self.frame.get_clamped(xc, yc) as f32;
        if a >= 1.0 {
            return i - b;
        }
        let p = |dx: isize, dy: isize| self.frame.get_clamped(xc + dx, yc + dy) as f32;
        let gx = (p(1, -1) + 2.0 * p(1, 0) + p(1, 1)) - (p(-1, -1) + 2.0 * p(-1, 0) + p(-1, 1));
        let gy = (p(-1, 1) + 2.0 * p(0, 1) + p(1, 1)) - (p(-1, -1) + 2.0 * p(0, -1) + p(1, -1));
        let g = math::sqrt(gx * gx + gy * gy) * 0.176_776_69;
        (a * i + (1.0 - a) * g).clamp(0.0, 255.0) - b
    }

    /// `D` at a sub-pixel position, bilinear.
    #[inline]
    pub fn bilinear(&self, x: f32, y: f32) -> f32 {
        let (fx, fy) = (math::floor(x), math::floor(y));
        let (tx, ty) = (x - fx, y - fy);
        let (ix, iy) = (fx as isize, fy as isize);
        let top = self.at(ix, iy) * (1.0 - tx) + self.at(ix + 1, iy) * tx;
        let bottom = self.at(ix, iy + 1) * (1.0 - tx) + self.at(ix + 1, iy + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// The signed offset along `normal` (unit, pointing out of the part) from `p` to the
    /// half-contrast crossing nearest `p`, or `None` when the profile holds no edge.
    pub fn edge_offset(&self, p: [f32; 2], normal: [f32; 2], params: &RefineParams) -> Option<f32> {
        let steps = (params.search / params.step) as i32;
        if steps < 2 {
            return None;
        }
        let sample = |k: i32| {
            let u = k as f32 * params.step;
            self.bilinear(p[0] + u * normal[0], p[1] + u * normal[1])
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
    let mut pose = seed;
    for _ in 0..params.iterations {
        // Normal equations for δ = (δx, δy, δθ, δs) of Σ (n·δp − r)².
        let mut ata = [[0.0f32; 4]; 4];
        let mut atb = [0.0f32; 4];
        let mut used = 0usize;
        let (s, c) = math::sin_cos(pose.angle);
        for (t, n) in edge.iter().zip(normals) {
            let p = pose.apply(*t);
            let nf = pose.rotate(*n);
            let Some(r) = diff.edge_offset(p, nf, params) else {
                continue;
            };
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
                for b in 0..4 {
                    ata[a][b] += j[a] * j[b];
                }
                atb[a] += j[a] * r;
            }
            used += 1;
        }
        if used < 4 {
            break;
        }
        let Some(delta) = solve4(ata, atb) else { break };
        let next = Pose {
            x: pose.x + delta[0],
            y: pose.y + delta[1],
            angle: pose.angle + delta[2],
            scale: pose.scale + delta[3],
        };
        if !(next.x.is_finite() && next.y.is_finite() && next.angle.is_finite() && (0.5..=2.0).contains(&next.scale)) {
            break;
        }
        pose = next;
        if delta[0].abs() + delta[1].abs() < 1e-4 && delta[2].abs() < 1e-6 {
            break;
        }
    }
    // Final distances at the converged pose.
    let (mut sum, mut found) = (0.0f32, 0usize);
    for (t, n) in edge.iter().zip(normals) {
        let p = pose.apply(*t);
        let nf = pose.rotate(*n);
        match diff.edge_offset(p, nf, params) {
            Some(r) => {
                sum += r.abs().min(params.cap);
                found += 1;
            }
            None => sum += params.cap,
        }
    }
    let count = edge.len().min(normals.len()).max(1) as f32;
    Alignment {
        pose,
        distance: sum / count,
        coverage: found as f32 / count,
    }
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

/// Mean distance from `points` to the closed polyline `outline`, each capped at `cap` (px).
/// `O(points·outline)`.
pub fn mean_distance_to_outline(points: &[[f32; 2]], outline: impl Fn(usize) -> [f32; 2], len: usize, cap: f32) -> f32 {
    if points.is_empty() || len < 2 {
        return cap;
    }
    let mut sum = 0.0f32;
    for p in points {
        let mut best = cap * cap;
        let mut prev = outline(len - 1);
        for i in 0..len {
            let cur = outline(i);
            let q = crate::pose::closest_on_segment(*p, prev, cur);
            let d = (q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]);
            if d < best {
                best = d;
            }
            prev = cur;
        }
        sum += math::sqrt(best);
    }
    sum / points.len() as f32
}

/// Below this fraction of the part's contrast an interior pixel is taken for platform (a filled
/// hole).
const HOLE_RATIO: f32 = 0.2;

/// Bits of the label plane used while measuring one part (bit 0 is the mask).
const COMPONENT: u8 = 1 << 1;
const GROWN: u8 = 1 << 2;
const SHRUNK: u8 = 1 << 3;
const SCRATCH: u8 = 1 << 4;
const RING: u8 = 1 << 5;

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
/// image). `mask` is the 0/1 plane (only bit 0 is read; bits 1–5 are used as scratch inside the
/// box and cleared again). `None` when the part has no weight.
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
    morph_bits(mask, w, r, SHRUNK, SCRATCH, true); // shrunk by 3
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
    // f32 sums of coordinates relative to the box's corner (small numbers, so single precision
    // keeps the centroid to about 1e-4 px; the MCU has no double-precision FPU).
    let (mut sw, mut sx, mut sy) = (0.0f32, 0.0f32, 0.0f32);
    if contrast.abs() >= 1.0 {
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let v = mask.get(y * w + x).copied().unwrap_or(0);
                let weight = if v & SHRUNK != 0 {
                    // Inside counts 1, unless the pixel looks like the platform: a small hole or a
                    // narrow gap that the mask's closing filled. Printed labels keep at least a
                    // third of the part's contrast, holes keep none.
                    let ratio = diff.at(x as isize, y as isize) / contrast;
                    if ratio >= HOLE_RATIO {
                        1.0
                    } else {
                        ratio.clamp(0.0, 1.0)
                    }
                } else if v & GROWN != 0 {
                    // The local contrast: mean D of the ring pixels within 4 px (shading across the
                    // part changes it from one side to the other), else the part's median.
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
    // Clear the scratch bits (1–6).
    for y in r.y0..r.y1 {
        for x in r.x0..r.x1 {
            if let Some(v) = mask.get_mut(y * w + x) {
                *v &= 1;
            }
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

/// Horizontal scratch bit of the separable 3×3 passes.
const HORIZONTAL: u8 = 1 << 6;

/// `dst` bit = 3×3 erosion (or dilation) of the `src` bit inside `r` (outside `r` counts as 0),
/// as a horizontal then a vertical 3-tap pass.
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

/// Marks the 8-connected foreground component of `seed` (inside `r`) with [`COMPONENT`]: a
/// scanline fill with a fixed stack; when the stack overflows, repeated raster passes finish the
/// job (bounded by the box's size).
fn mark_component(mask: &mut [u8], w: usize, r: Rect, seed: (usize, usize)) {
    const STACK: usize = 256;
    let free = |mask: &[u8], x: usize, y: usize| mask.get(y * w + x).is_some_and(|v| v & 1 != 0 && v & COMPONENT == 0);
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
