//! The `touching` variant: parts moved against, and partly over, one another.
//!
//! After the usual placement (parts apart), each part after the first is, with chance
//! [`TOUCHING_SHARE`], moved against an earlier part that touches nothing yet: along a random
//! direction from that part's centroid, to the distance where the two silhouettes share the
//! drawn overlap share of the smaller one's area — [`JUST_TOUCHING`] for a third of the pairs
//! (they merely touch), otherwise up to [`OVERLAP_MAX`] (the issue's "by at most 12 % of the
//! smaller"). The moved part is drawn later, on top; it keeps `INSIDE_MARGIN_PX` from
//! the frame's edge and `GAP_PX` from every other part's bounding circle, or it stays
//! where it was. Truth marks both parts `"touching": true`, and the lower one's
//! `visible_fraction` is the share of its area the upper one leaves visible.

use super::raster::{bounds, Pose};
use super::render::silhouette;
use super::rng::Rng;
use super::scene::{self, Placed};
use super::shapes::{norm, sub, PartSpec};

/// Share of the parts (after the first of a frame) moved against another.
pub const TOUCHING_SHARE: f64 = 0.6;
/// Overlap (share of the smaller part's area) of a pair that merely touches.
pub const JUST_TOUCHING: f64 = 0.003;
/// Largest overlap drawn, share of the smaller part's area.
pub const OVERLAP_MAX: f64 = 0.12;

/// Shared area of two placed parts, px² (coverage of the pixels both cover, the smaller of the
/// two coverages each), and the area of each.
fn overlap(cat: &[PartSpec], a: &Placed, b: &Placed, w: usize, h: usize) -> (f64, f64, f64) {
    let ca = silhouette(a.drawn(cat), &a.pose, w, h);
    let cb = silhouette(b.drawn(cat), &b.pose, w, h);
    let (mut shared, mut area_a, mut area_b) = (0.0, 0.0, 0.0);
    ca.for_each(|x, y, c| {
        area_a += c;
        shared += c.min(cb.at(x, y));
    });
    cb.for_each(|_, _, c| area_b += c);
    (shared, area_a, area_b)
}

/// Moves parts of `parts` against earlier ones (see the module doc); marks the pairs.
pub(crate) fn bring_together(rng: &mut Rng, cat: &[PartSpec], parts: &mut [Placed], w: usize, h: usize) {
    for i in 1..parts.len() {
        if !rng.chance(TOUCHING_SHARE) {
            continue;
        }
        let free: Vec<usize> = (0..i).filter(|&j| !parts[j].touching).collect();
        if free.is_empty() {
            continue;
        }
        let j = free[rng.below(free.len())];
        let target = if rng.chance(1.0 / 3.0) {
            JUST_TOUCHING
        } else {
            rng.range(0.02, OVERLAP_MAX)
        };
        for _attempt in 0..12 {
            let dir = rng.range(0.0, std::f64::consts::TAU);
            if let Some((pose, shared)) = against(cat, parts, i, j, dir, target, w, h) {
                let area_j = parts[j].drawn(cat).area_mm2() * parts[j].pose.k * parts[j].pose.k;
                parts[i].pose = pose;
                parts[i].touching = true;
                parts[j].touching = true;
                // The lower part loses what the upper one covers.
                parts[j].visible = (1.0 - shared / area_j).clamp(0.0, 1.0);
                break;
            }
        }
    }
}

/// Where part `i` lies against part `j` along direction `dir` from `j`'s centroid with the
/// overlap share `target` (of the smaller area), if it stays inside the frame and clear of the
/// others; its pose and the shared area.
#[allow(clippy::too_many_arguments)]
fn against(
    cat: &[PartSpec],
    parts: &[Placed],
    i: usize,
    j: usize,
    dir: f64,
    target: f64,
    w: usize,
    h: usize,
) -> Option<(Pose, f64)> {
    let (pi, pj) = (&parts[i], &parts[j]);
    let (ri, rj) = (
        pi.drawn(cat).radius_mm() * pi.pose.k,
        pj.drawn(cat).radius_mm() * pj.pose.k,
    );
    let (dx, dy) = (dir.cos(), dir.sin());
    let at = |d: f64| {
        let mut p = pi.clone();
        p.pose = Pose::new(pj.pose.cx + d * dx, pj.pose.cy + d * dy, pi.angle_deg, pi.pose.k);
        p
    };
    let share = |p: &Placed| {
        let (shared, a, b) = overlap(cat, p, pj, w, h);
        (shared / a.min(b).max(1e-9), shared)
    };
    // Bisection on the distance: apart at ri + rj, the overlap grows as they close in.
    let (mut lo, mut hi) = (0.0, ri + rj);
    if share(&at(lo)).0 < target {
        return None;
    }
    for _ in 0..22 {
        let mid = 0.5 * (lo + hi);
        if share(&at(mid)).0 >= target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let placed = at(lo);
    let (got, shared) = share(&placed);
    if got <= 0.0 {
        return None;
    }
    let b = bounds(&placed.pose.rings(placed.drawn(cat).rings()));
    let m = scene::INSIDE_MARGIN_PX;
    if b[0] < m || b[1] < m || b[2] > w as f64 - 1.0 - m || b[3] > h as f64 - 1.0 - m {
        return None;
    }
    let c = [placed.pose.cx, placed.pose.cy];
    for (k, q) in parts.iter().enumerate() {
        if k == i || k == j {
            continue;
        }
        let rq = q.drawn(cat).radius_mm() * q.pose.k;
        if norm(sub(c, [q.pose.cx, q.pose.cy])) < ri + rq + scene::GAP_PX {
            return None;
        }
    }
    Some((placed.pose, shared))
}
