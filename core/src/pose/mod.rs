//! Pose from the matched points: rotation (paper eqs. 6.1–6.4) and position.
//!
//! Both estimators use the DP correspondence `i → j(i)` and the offsets of the matched points
//! from their contours' centroids, `v_i = q_i − C` (part) and `v'_i = t_{j(i)} − C'` (template):
//!
//! - [`angle_paper`]: the paper's estimator, the mean of the unsigned angles
//!   `arccos(v·v' / |v||v'|)` (eqs. 6.1–6.4). It cannot tell θ from 360° − θ and is biased near
//!   0° and 180°; it is kept under its own name for comparison.
//! - [`angle_signed`] (the default): the least-squares rotation of the `v'` onto the `v`,
//!   `atan2(Σ v×v', Σ v·v')`, over the full circle, counter-clockwise as seen on screen.
//!
//! Position ([`area_centroid`]): the area centroid of the outer border polygon with its holes
//! subtracted (`docs/pipeline-spec.md` §8).
//!
//! Guards: `arccos` gets its argument clamped to `[−1, 1]` (a normalised dot product can exceed 1
//! by rounding); pairs at a centroid (`|v||v'| < 1e-12`) are left out; a zero-area outline has no
//! centroid (`None`).

use crate::borders::contour::Point;
use crate::math;

pub mod holes;
pub mod partial_volume;
pub mod refine;

/// The matched pairs as offsets from their centroids: `(v_i, v'_i)` for every part point whose
/// template index is in range.
fn pair_offsets<'a>(
    part: &'a [[f32; 2]],
    part_centroid: [f32; 2],
    template: &'a [[f32; 2]],
    template_centroid: [f32; 2],
    assignment: &'a [u16],
) -> impl Iterator<Item = ([f32; 2], [f32; 2])> + 'a {
    part.iter().zip(assignment).filter_map(move |(p, &j)| {
        let t = template.get(j as usize)?;
        Some((
            [p[0] - part_centroid[0], p[1] - part_centroid[1]],
            [t[0] - template_centroid[0], t[1] - template_centroid[1]],
        ))
    })
}

/// The paper's unsigned rotation estimate in degrees, `[0, 180]` (eq. 6.4); `None` when no pair
/// is usable (a pair whose offsets are not finite, or whose cosine is not, is not).
pub fn angle_paper(
    part: &[[f32; 2]],
    part_centroid: [f32; 2],
    template: &[[f32; 2]],
    template_centroid: [f32; 2],
    assignment: &[u16],
) -> Option<f32> {
    let mut sum = 0.0f32;
    let mut count = 0usize;
    for ([vx, vy], [wx, wy]) in pair_offsets(part, part_centroid, template, template_centroid, assignment) {
        let den = math::hypot(vx, vy) * math::hypot(wx, wy);
        if den < 1e-12 {
            continue;
        }
        let cos = (vx * wx + vy * wy) / den;
        if !cos.is_finite() {
            continue;
        }
        sum += math::acos_clamped(cos);
        count += 1;
    }
    (count > 0).then(|| math::degrees(sum / count as f32))
}

/// The signed least-squares rotation in degrees, `[0, 360)`, counter-clockwise on screen;
/// `None` when no pair is usable.
///
/// ```
/// use vorl_core::pose::angle_signed;
/// // Template points right, down, left, up of the centroid (image coordinates, y down) …
/// let t = [[1.0f32, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
/// // … turned 90° counter-clockwise on screen: right goes up.
/// let p = [[0.0f32, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]];
/// let a = angle_signed(&p, [0.0, 0.0], &t, [0.0, 0.0], &[0, 1, 2, 3]).unwrap();
/// assert!((a - 90.0).abs() < 1e-3);
/// ```
pub fn angle_signed(
    part: &[[f32; 2]],
    part_centroid: [f32; 2],
    template: &[[f32; 2]],
    template_centroid: [f32; 2],
    assignment: &[u16],
) -> Option<f32> {
    let (mut cross, mut dot) = (0.0f32, 0.0f32);
    let mut count = 0usize;
    for ([vx, vy], [wx, wy]) in pair_offsets(part, part_centroid, template, template_centroid, assignment) {
        cross += vx * wy - vy * wx;
        dot += vx * wx + vy * wy;
        count += 1;
    }
    if count == 0 || (cross == 0.0 && dot == 0.0) {
        return None;
    }
    Some(math::wrap_degrees(math::degrees(math::atan2(cross, dot))))
}

/// Sub-sample refinement passes of [`angle_signed_refined`].
pub const REFINE_PASSES: usize = 4;

/// The signed estimator with the correspondences refined below the template's sampling step.
///
/// The DP pairs part point `i` with a template *sample* `j(i)`; the samples are `P/m` apart
/// along the outline, so a part whose first point falls between two template samples gets every
/// pair shifted the same way along the outline, a rotation bias of up to half a step over the
/// radius (a few degrees for a 100 px part at `m = 96`). Each pass maps the part's offsets into the
/// template frame with the current angle and the mean-radius scale, moves each pair's template
/// end to the nearest point on the two template edges beside `j(i)`, and solves the
/// least-squares rotation (and scale) again. Same correspondences, no search: `O(n)` per pass.
/// Point-to-point steps converge slowly where points can slide along straight edges, so this
/// removes most, not all, of the sampling bias (the example: 3.1° → 0.6°).
///
/// ```
/// use vorl_core::pose::{angle_signed, angle_signed_refined};
/// // Points every `step` along the outline of an L, starting `offset` along it.
/// fn l_outline(step: f32, offset: f32, count: usize) -> Vec<[f32; 2]> {
///     let v = [[0.0f32, 0.0], [0.0, 60.0], [40.0, 60.0], [40.0, 45.0], [15.0, 45.0], [15.0, 0.0]];
///     (0..count).map(|k| {
///         let mut s = offset + k as f32 * step;
///         let mut i = 0;
///         loop {
///             let (a, b) = (v[i % 6], v[(i + 1) % 6]);
///             let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
///             if s <= len { let t = s / len; return [a[0] + t * (b[0] - a[0]) - 15.0, a[1] + t * (b[1] - a[1]) - 30.0]; }
///             s -= len;
///             i += 1;
///         }
///     }).collect()
/// }
/// // Perimeter 250: the template has 50 samples (step 5), the part the same outline
/// // sampled half a step later and turned by 10° counter-clockwise on screen.
/// let t = l_outline(5.0, 0.0, 50);
/// let (s, c) = 10f32.to_radians().sin_cos();
/// let p: Vec<[f32; 2]> = l_outline(5.0, 2.5, 50).iter().map(|v| [v[0] * c + v[1] * s, -v[0] * s + v[1] * c]).collect();
/// let pairs: Vec<u16> = (0..50).collect();
/// let ct = vorl_core::shape::descriptor::centroid(&t);
/// let cp = vorl_core::shape::descriptor::centroid(&p);
/// let coarse = angle_signed(&p, cp, &t, ct, &pairs).unwrap();
/// let fine = angle_signed_refined(&p, cp, &t, ct, &pairs).unwrap();
/// assert!((coarse - 10.0).abs() > 2.0, "{coarse}"); // 13.1° here
/// assert!((fine - 10.0).abs() < 1.0, "{fine}"); // 10.6° here
/// assert!((fine - 10.0).abs() < (coarse - 10.0).abs() / 4.0);
/// ```
pub fn angle_signed_refined(
    part: &[[f32; 2]],
    part_centroid: [f32; 2],
    template: &[[f32; 2]],
    template_centroid: [f32; 2],
    assignment: &[u16],
) -> Option<f32> {
    let seed = angle_signed(part, part_centroid, template, template_centroid, assignment)?;
    let m = template.len();
    // Scale part → template, first from the mean radii of all points (both sample their outline
    // uniformly by arc length), then by least squares with each pass.
    let mean_radius = |pts: &[[f32; 2]], c: [f32; 2]| {
        pts.iter().map(|p| math::hypot(p[0] - c[0], p[1] - c[1])).sum::<f32>() / pts.len().max(1) as f32
    };
    let (rp, rt) = (
        mean_radius(part, part_centroid),
        mean_radius(template, template_centroid),
    );
    if !(rp > 0.0) || !(rt > 0.0) || m < 2 {
        return Some(seed);
    }
    let mut inv_scale = rt / rp;
    let mut theta = math::radians(seed);
    for _ in 0..REFINE_PASSES {
        let (s, c) = math::sin_cos(theta);
        let (mut cross, mut dot, mut ww) = (0.0f32, 0.0f32, 0.0f32);
        for (p, &j) in part.iter().zip(assignment) {
            let j = j as usize;
            let (Some(a), Some(b), Some(d)) = (
                template.get((j + m - 1) % m),
                template.get(j),
                template.get((j + 1) % m),
            ) else {
                continue;
            };
            let (vx, vy) = (p[0] - part_centroid[0], p[1] - part_centroid[1]);
            // The part offset in the template frame: R(−θ)·v / scale.
            let q = [
                template_centroid[0] + inv_scale * (vx * c - vy * s),
                template_centroid[1] + inv_scale * (vx * s + vy * c),
            ];
            let e1 = closest_on_segment(q, *a, *b);
            let e2 = closest_on_segment(q, *b, *d);
            let t = if dist2(q, e1) <= dist2(q, e2) { e1 } else { e2 };
            let (wx, wy) = (t[0] - template_centroid[0], t[1] - template_centroid[1]);
            cross += vx * wy - vy * wx;
            dot += vx * wx + vy * wy;
            ww += wx * wx + wy * wy;
        }
        if (cross == 0.0 && dot == 0.0) || !(ww > 0.0) {
            break;
        }
        theta = math::atan2(cross, dot);
        // Least-squares scale at this angle: σ = Σ v·R(θ)w / Σ|w|².
        let sigma = math::hypot(cross, dot) / ww;
        if sigma > 0.0 {
            inv_scale = 1.0 / sigma;
        }
    }
    Some(math::wrap_degrees(math::degrees(theta)))
}

#[inline]
fn dist2(a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1])
}

/// The point of segment `a`–`b` nearest to `q`.
#[inline]
pub(crate) fn closest_on_segment(q: [f32; 2], a: [f32; 2], b: [f32; 2]) -> [f32; 2] {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    if !(len2 > 0.0) {
        return a;
    }
    let t = (((q[0] - a[0]) * dx + (q[1] - a[1]) * dy) / len2).clamp(0.0, 1.0);
    [a[0] + t * dx, a[1] + t * dy]
}

/// Twice the signed area and the first moments of a closed polygon (shoelace), exact in
/// integers: `(2A, Σ(x_i+x_{i+1})·cross_i, Σ(y_i+y_{i+1})·cross_i)`.
pub(crate) fn polygon_moments(points: &[Point]) -> (i64, i64, i64) {
    let n = points.len();
    let (mut a2, mut mx, mut my) = (0i64, 0i64, 0i64);
    for (i, p) in points.iter().enumerate() {
        let q = points.get((i + 1) % n).copied().unwrap_or(*p);
        let (x0, y0, x1, y1) = (p.x as i64, p.y as i64, q.x as i64, q.y as i64);
        let cross = x0 * y1 - x1 * y0;
        a2 += cross;
        mx += (x0 + x1) * cross;
        my += (y0 + y1) * cross;
    }
    (a2, mx, my)
}

/// Area centroid of the outer polygon minus its hole polygons; `None` for zero net area.
///
/// ```
/// use vorl_core::{borders::contour::Point, pose::area_centroid};
/// let p = |x, y| Point { x, y };
/// let square = [p(0, 0), p(0, 4), p(4, 4), p(4, 0)];
/// let c = area_centroid(&square, core::iter::empty::<&[Point]>()).unwrap();
/// assert_eq!(c, [2.0, 2.0]);
/// ```
pub fn area_centroid<'a>(outer: &[Point], holes: impl Iterator<Item = &'a [Point]>) -> Option<[f32; 2]> {
    let (a2, mx, my) = polygon_moments(outer);
    // Orient every polygon positively so holes subtract whatever their traced direction.
    let sign = |a: i64| if a < 0 { -1i64 } else { 1 };
    let s = sign(a2);
    let (mut a2t, mut mxt, mut myt) = (a2 * s, mx * s, my * s);
    for h in holes {
        let (ha, hx, hy) = polygon_moments(h);
        let hs = sign(ha);
        a2t -= ha * hs;
        mxt -= hx * hs;
        myt -= hy * hs;
    }
    if a2t <= 0 {
        return None;
    }
    // Centroid = Σ(x_i+x_{i+1})·cross / (6A) = mx / (3·2A).
    let den = 3.0 * a2t as f32;
    Some([mxt as f32 / den, myt as f32 / den])
}
