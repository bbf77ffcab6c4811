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

use crate::contour::Point;
use crate::math;

/// The paper's unsigned rotation estimate in degrees, `[0, 180]` (eq. 6.4); `None` when no pair
/// is usable.
pub fn angle_paper(
    part: &[[f32; 2]],
    part_centroid: [f32; 2],
    template: &[[f32; 2]],
    template_centroid: [f32; 2],
    assignment: &[u16],
) -> Option<f32> {
    let mut sum = 0.0f32;
    let mut count = 0usize;
    for (p, &j) in part.iter().zip(assignment) {
        let Some(t) = template.get(j as usize) else { continue };
        let (vx, vy) = (p[0] - part_centroid[0], p[1] - part_centroid[1]);
        let (wx, wy) = (t[0] - template_centroid[0], t[1] - template_centroid[1]);
        let den = math::hypot(vx, vy) * math::hypot(wx, wy);
        if den < 1e-12 {
            continue;
        }
        sum += math::acos_clamped((vx * wx + vy * wy) / den);
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
    for (p, &j) in part.iter().zip(assignment) {
        let Some(t) = template.get(j as usize) else { continue };
        let (vx, vy) = (p[0] - part_centroid[0], p[1] - part_centroid[1]);
        let (wx, wy) = (t[0] - template_centroid[0], t[1] - template_centroid[1]);
        cross += vx * wy - vy * wx;
        dot += vx * wx + vy * wy;
        count += 1;
    }
    if count == 0 || (cross == 0.0 && dot == 0.0) {
        return None;
    }
    Some(math::wrap_degrees(math::degrees(math::atan2(cross, dot))))
}

/// Twice the signed area and the first moments of a closed polygon (shoelace), exact in
/// integers: `(2A, Σ(x_i+x_{i+1})·cross_i, Σ(y_i+y_{i+1})·cross_i)`.
fn polygon_moments(points: &[Point]) -> (i64, i64, i64) {
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
/// use vorl_core::{contour::Point, pose::area_centroid};
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
