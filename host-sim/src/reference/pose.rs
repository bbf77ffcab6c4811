//! §8: the rotation angle from the DP correspondence (eqs. 6.1–6.4).

use super::descriptor::centroid;

/// The matched centred pairs `(v_i, v'_i)`: `v_i = q_i − C` (part points and their mean),
/// `v'_i = t_{j(i)} − C'` (template points and their mean, eqs. 6.2, 6.3). Part points beyond
/// the assignment's length and template indices out of range are left out.
fn matched_pairs(part: &[(f64, f64)], template: &[(f64, f64)], assignment: &[usize]) -> Vec<((f64, f64), (f64, f64))> {
    if part.is_empty() || template.is_empty() {
        return Vec::new();
    }
    let (cx, cy) = centroid(part);
    let (tx, ty) = centroid(template);
    part.iter()
        .zip(assignment)
        .filter_map(|(&(px, py), &j)| {
            let &(qx, qy) = template.get(j)?;
            Some(((px - cx, py - cy), (qx - tx, qy - ty)))
        })
        .collect()
}

/// The paper's rotation estimate (eq. 6.4), in degrees: the mean over `i` of
/// `β_i = arccos(clamp(v·v' / (|v|·|v'|), −1, 1))` (eq. 6.1), pairs with `|v|·|v'| < 1e-12`
/// left out.
///
/// Unsigned: a rotation by θ and by `360° − θ` give the same value, in `[0, 180]`. Returns 0
/// when no pair is usable.
pub fn angle_paper(part: &[(f64, f64)], template: &[(f64, f64)], assignment: &[usize]) -> f64 {
    let mut sum = 0.0;
    let mut count = 0usize;
    for ((vx, vy), (wx, wy)) in matched_pairs(part, template, assignment) {
        let norms = vx.hypot(vy) * wx.hypot(wy);
        if norms < 1e-12 || !norms.is_finite() {
            continue;
        }
        let cos = ((vx * wx + vy * wy) / norms).clamp(-1.0, 1.0);
        sum += cos.acos().to_degrees(); // eq. 6.1
        count += 1;
    }
    if count == 0 {
        0.0
    } else {
        sum / count as f64 // eq. 6.4
    }
}

/// The signed rotation estimate of §8, in degrees in `[0, 360)`, counter-clockwise on screen:
/// the least-squares rotation of the `v'` onto the `v`,
/// `θ = atan2(Σ (v_x·v'_y − v_y·v'_x), Σ (v_x·v'_x + v_y·v'_y))`.
///
/// With the spec's convention (rotating `(dx, dy)` by θ counter-clockwise on screen gives
/// `(dx·cosθ + dy·sinθ, −dx·sinθ + dy·cosθ)`), a part that is the template rotated by θ gives
/// back θ. Returns 0 when there are no pairs.
pub fn angle_signed(part: &[(f64, f64)], template: &[(f64, f64)], assignment: &[usize]) -> f64 {
    let mut sin_sum = 0.0;
    let mut cos_sum = 0.0;
    for ((vx, vy), (wx, wy)) in matched_pairs(part, template, assignment) {
        sin_sum += vx * wy - vy * wx;
        cos_sum += vx * wx + vy * wy;
    }
    let theta = sin_sum.atan2(cos_sum).to_degrees();
    if theta.is_nan() {
        return 0.0;
    }
    let wrapped = if theta < 0.0 { theta + 360.0 } else { theta };
    if wrapped >= 360.0 {
        0.0
    } else {
        wrapped
    }
}
