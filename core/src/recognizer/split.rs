//! Several parts in one blob, and parts cut by the frame's edge: the partial search.
//!
//! With [`crate::Params::touching_parts`] on (the default), a blob goes to the partial search
//! when its whole-border result does not settle it: no part was verified, or it touches the
//! frame's edge (its whole-border match took the edge's straight cut for outline, and its
//! centroid is the visible piece's), or the verified template covers less of the blob than the
//! blob's area less half the smallest template and less the band the verification lets the
//! outline lie off the template all round (the border's length times its limit: a thick part's
//! walls are not another part). Such a blob may hold parts that touch or lie partly over one
//! another, or a part the frame's edge cuts.
//!
//! **Blobs of one part.** Most blobs the whole-border match leaves unnamed are one part no
//! template explains (an unknown part, a part too far off its template); the search would find
//! nothing on them, at several times the cost of their whole-border match. Two rules spare
//! them, both from what the frame shows:
//!
//! - *No junction, one part.* Where a blob holds several parts, its border passes from one
//!   part's outline to another's at a junction, and turns concave there by the angle at which
//!   the outlines cross: about a half turn where parts merely touch, less the more one lies
//!   over the other. A blob inside the frame whose border turns concave nowhere by
//!   [`JUNCTION_TURN`] or more (over chords of [`JUNCTION_CHAIN_CHORD`] points of its pixel
//!   chain, [`turns_concave_by`]) is one part: its whole-border result stands, unsearched. The turn
//!   is `π·(2v − 1)` for the least visible share `v` the search takes inside the frame
//!   ([`MIN_VISIBLE_PINNED`]): where two equal discs cross when the lower one still shows `v` of
//!   its outline. It is a model, not a bound: parts of about one size lying mostly over one
//!   another, or along a shared straight side, can meet at a shallower turn, and their blob is
//!   then taken for one part. [`Recognizer::set_junction_gate`] turns the rule off (to hold it
//!   against the search: every blob of the accuracy sets keeps its result, `docs/performance.md`).
//! - *Holes.* A part of a blob inside the frame lies wholly inside it, holes and all, and its
//!   fit needs every hole of its template shown: found, each in a hole of the blob of its own,
//!   where the tracing keeps a hole that size ([`crate::pose::holes::traceable`]), and as a dip
//!   of `|D|` as wide as the hole where it does not (a pin's end-hole under `min_area`:
//!   [`crate::pose::holes::untraced_shown`]). A template with more holes the tracing keeps at
//!   its least scale than the blob has is not searched (exact: such a fit is never kept). An
//!   unknown part without holes is searched only for the templates without such holes.
//!
//! And the open DP of a template ([`crate::shape::arcs::best_arcs`]) first bounds, at a fraction
//! of its cost, whether any run could cover the third of the template a hypothesis needs; where
//! none could, it keeps none without the DP.
//!
//! **Hypotheses.** Each template that fits in the blob (its area at the least scale, plus half
//! the smallest template's inside the frame), and the mirror image of each chiral one (a part
//! lying upside down, with [`crate::Params::flipped_parts`], as the whole part's scan has it;
//! its fits are reported `flipped`), is matched against arcs of the blob's border
//! ([`crate::shape::arcs`]: the paper's order-preserving DP, open instead of cyclic, on turning
//! angles, at every [`STRIDE`]-th template point and the border at that step, the border
//! resampled at the template's step at the middle of its scale range, and where that leaves
//! the blob unexplained at the other of the [`SCALE_STEPS`] scale points its runs point to).
//! Each of the best runs ([`RUNS_PER_TEMPLATE`] of a template at a scale, [`MAX_HYPOTHESES`]
//! over all, their scores per length of border at the range's middle) seeds a pose: the
//! similarity that maps the run's template points onto its border points (least squares).
//!
//! **Fits.** The template is aligned on the frame from there as a whole part is
//! ([`crate::pose::refine`], up to [`PARTIAL_ITERATIONS`] steps), and verified on the **visible edge
//! only**: the share of its edge points whose profile finds the part's edge within
//! [`CONFIRM_PX`] (scaled as the verification's limit) is its `visible_fraction`, and the mean
//! distance over those is its score; only the edge points that the pose puts inside the frame,
//! farther from its edge than a profile reaches, are aligned and can be confirmed (a profile
//! beyond the frame reads the frame's edge pixels, clamped, and would find the silhouette's
//! cut there). A fit is kept when it shows at least [`MIN_VISIBLE_INSIDE`] of its border
//! inside the frame ([`MIN_VISIBLE`], the documented half, for a part the edge cuts: one with
//! edge points outside the frame or within a profile's reach of its edge at the aligned pose;
//! another part of the same blob that lies wholly inside is held to the share inside, and is
//! not reported cut), scores within [`PARTIAL_LIMIT`] of its limit, lies in its scale range and
//! shows every hole it has that the pose puts inside the frame (as above: in the mask, or as a
//! dip for a hole too small for the tracing). A fit whose holes pin its pose
//! (every hole of its template found, one off its centre, and no other hole of the blob inside
//! its outline) may depart from its template's outline as a real part of its type does, as a
//! whole part may ([`crate::recognizer::NEAR_MISS`]): [`NEAR_MISS`] times [`PARTIAL_LIMIT`],
//! and [`MIN_VISIBLE_PINNED`] of its border (two real rods lying against each other, each a few
//! per cent off its template's outline). An alignment gives up early where its mean distance
//! says less of the border could be confirmed than the fit would need. Kept fits are taken
//! best first (the more of its template's holes found, as a whole part's fits are ranked: a
//! rod with two eyes is the two-eyed template's even where the one-eyed template's outline
//! fits as much of it; then the larger share of its edge points inside the frame confirmed —
//! its visible share for a part inside the frame, while a cut part is not held to the points
//! the frame hides, so a smaller template fitting the visible piece of a larger part does not
//! win by the larger share of its own outline; then the lower score) unless their
//! centre falls within half a size of one taken already (the same part matched twice, from
//! both sides of the blob or by two templates, or by a template and its mirror image, which
//! are ranked as any two templates are); a pose whose seed
//! falls on a part taken in the first round is not aligned in the second. (The whole part's
//! rule for the upside-down reading, the mirror image closer by
//! [`crate::recognizer::FLIP_EVIDENCE`] over every point, was tried here over the points inside
//! the frame: the points another part hides count alike for both sides and dilute the ratio,
//! and it lost right flips on the `touching` sets while changing nothing else,
//! `docs/accuracy.md`.)
//!
//! **Two rounds.** When the parts taken leave [`REST_SHARE`] of the border unexplained (farther
//! than [`EXPLAINED_PX`] from every taken part's outline), the hypotheses are made once more with
//! the explained border points given a turning no template has ([`EXPLAINED_TURN`]), so the
//! runs all lie on the rest. What is still unexplained then is reported as one more, unknown
//! part, so nothing is silently lost: at the area centroid of the longest unexplained run
//! closed across its ends (the outline of the part no template explains, cut where it meets
//! the parts found). That run is a part of its own when it is [`REST_SHARE`] of the border
//! itself (not scattered stretches where fits fall a little short of a part's outline), its
//! centroid lies outside every part found (not the end of a part longer than its template),
//! and the area it closes exceeds the band the verification lets an outline lie off its
//! template along it (its length times the parts' largest limit) by [`crate::Params::min_area`],
//! the least a blob is a part at: an untaught part smaller than every template is reported
//! too.
//!
//! Positions of parts found this way are their aligned template's (the pose applied to the
//! template's position offset, [`crate::Detection::position_from_pose`]): the partial-volume
//! centroid needs the whole silhouette.
//!
//! **Bounds.** A blob longer than [`BLOB_POINTS`] points at a template's step is not searched
//! for it (when no template could be, the whole-border result stands and
//! [`crate::recognizer::Report::unsplit`] counts the blob); each template's DP visits
//! `(n + m′ − 1)·m′` cells at each scale it is searched at (the middle, and at most the other
//! `SCALE_STEPS − 1` of [`SCALE_STEPS`]; `m′ = m / STRIDE`, `n` the border's points at that
//! step), at most [`MAX_HYPOTHESES`] alignments run a pass (the middle's, then the other
//! scales'), two passes a round, two rounds a blob, and at most
//! [`MAX_BLOB_PARTS`] parts come out of one. Memory: the recognizer's `arc_points` and
//! `arc_turning` ([`BLOB_POINTS`] each), `arc_template` (`M`) and `arc_rows`
//! (`(`[`crate::shape::arcs::ARC_ROWS`]` + 1)·M`), counted by `vorl budget`; the search runs out of
//! line, so its locals take stack only while it runs.

use crate::borders::resample::resample;
use crate::library::template::Template;
use crate::math;
use crate::pixels::frame::Frame;
use crate::pose::holes::{agreement, traceable, untraced_shown, Hole, HoleAgreement, Holes};
use crate::pose::refine::{align_recording, edge_distances, Difference, Outline, Pose, RefineParams};
use crate::recognizer::verdict::in_frame;
use crate::recognizer::{Detection, Recognizer, Report, SkipReason, NEAR_MISS};
use crate::shape::arcs::{best_arcs, turning, ArcMatch, ArcParams};

/// Most points of a blob's border at a template's step: a longer blob is not searched.
pub const BLOB_POINTS: usize = 512;
/// Most parts (with the unexplained rest) reported from one blob.
pub const MAX_BLOB_PARTS: usize = 8;
/// Most poses aligned for one blob.
pub const MAX_HYPOTHESES: usize = 24;
/// Runs kept per template ([`best_arcs`]).
pub const RUNS_PER_TEMPLATE: usize = 3;
/// The partial DP takes every `STRIDE`-th template point, and the border at that step.
pub const STRIDE: usize = 2;
/// Scales a blob's border may be resampled at for each template: the points that divide the
/// template's scale range into `SCALE_STEPS + 1` equal (geometric) parts, its middle among
/// them (0.845, 1 and 1.183 for the default 1/1.4–1.4; 0.917, 1.058 and 1.217 for 0.8–1.4).
/// Every scale from the first to the last lies within `(hi/lo)^(1/8)` of one of them (±9 %
/// for the default range), which the DP's stretch steps follow; a part's size is not known
/// before its fit, and parts of one type lie all over a range (rods at 0.9–1.3× their
/// template in 0.8–1.4), farther from its middle alone than the stretch steps follow.
///
/// The middle ([`MIDDLE_STEP`]) is searched for every template; another point only in a round
/// whose middle search leaves the blob unexplained ([`REST_SHARE`] of its border, or no part
/// taken), and only for a template one of whose runs at the middle fits a pose
/// (`pose_from_run`) whose scale lies nearer that point than the middle: the run found the
/// outline there, drawn at another size than the step it was resampled at. The search at every
/// point for every template named as many touching rods but cost the DP three times over in
/// every searched blob, most of which (an unknown part, parts the middle explains) gain
/// nothing from it.
pub const SCALE_STEPS: usize = 3;
/// The scale point at the range's middle, searched first ([`SCALE_STEPS`]).
pub const MIDDLE_STEP: usize = SCALE_STEPS / 2;
// An odd count keeps the middle among the points; a template's points are bits of a `u8`.
const _: () = assert!(SCALE_STEPS % 2 == 1 && SCALE_STEPS <= 8);
/// Neighbourhood of the turning angle, points each way (at the DP's step).
pub const TURN_K: usize = 3;
/// An edge point is confirmed when its profile finds the edge this close (px, times the
/// verification limit over its threshold).
pub const CONFIRM_PX: f32 = 1.0;
/// Least share of a template's edge points the image must confirm for a part the frame's
/// edge cuts (the documented half).
pub const MIN_VISIBLE: f32 = 0.5;
/// Least share for a part in a blob inside the frame: a part that touches or lies under
/// another shows most of its border (a bar-like part fits an arm of a bracket over less).
pub const MIN_VISIBLE_INSIDE: f32 = 0.75;
/// Least share for a part in a blob inside the frame whose holes pin its pose (every hole of
/// its template found, one off its centre, no other hole of the blob inside its outline).
pub const MIN_VISIBLE_PINNED: f32 = 0.65;
/// The mean distance over the confirmed points must stay below this share of the limit.
pub const PARTIAL_LIMIT: f32 = 0.5;
/// A border point this far (px) from every part found is not explained.
pub const EXPLAINED_PX: f32 = 2.5;
/// Gauss–Newton steps of a partial fit's alignment (a whole part's: 12).
pub const PARTIAL_ITERATIONS: usize = 30;
/// The turning angle given to border points a part found explains: no template point has it,
/// so no run of the second round passes them.
pub const EXPLAINED_TURN: f32 = 1.0e3;
/// The unexplained share of the border from which a second round searches the rest, and the
/// share the rest's longest run must be to be reported as a part.
pub const REST_SHARE: f32 = 0.15;
/// The least concave turn (radians) taken for a junction of a blob's border, where it passes
/// from one part's outline to another's ("Blobs of one part" in the module doc):
/// `π·(2·v − 1)` for the least visible share `v` the search takes inside the frame
/// ([`MIN_VISIBLE_PINNED`]), 0.3 π = 54°. Two equal discs meet at this turn when the lower one
/// shows `v` of its outline (it shows `1 − a/π` of it where the outlines cross at `±a` about its
/// centre, and the border turns by `π − 2a` there), and at a deeper one the less they overlap,
/// up to a half turn for discs that merely touch.
pub const JUNCTION_TURN: f32 = core::f32::consts::PI * (2.0 * MIN_VISIBLE_PINNED - 1.0);
/// The junction test turns at every `JUNCTION_CHAIN_STEP`-th point of a blob's pixel chain
/// (1 to 1.4 px apart): every 2 to 3 px.
pub const JUNCTION_CHAIN_STEP: usize = 2;
/// Points of the pixel chain each way of the chords the junction test turns between
/// ([`turns_concave_by`]): chords of 5 to 7 px, longer than the mask rounds a corner and than
/// the stairs of a digital straight edge, shorter than the parts' sides.
pub const JUNCTION_CHAIN_CHORD: usize = 5;

/// One pose to align: a template and where a run of its outline puts it.
#[derive(Debug, Clone, Copy)]
struct Hypothesis {
    /// Template `slot / 2`, or its mirror image for an odd slot (as the candidate scan's).
    slot: usize,
    seed: Pose,
    score: f32,
}

/// A verified partial fit.
#[derive(Debug, Clone, Copy)]
struct PartFit {
    /// Template `slot / 2`, or its mirror image for an odd slot: the part lies upside down.
    slot: usize,
    pose: Pose,
    visible: f32,
    distance: f32,
    limit: f32,
    holes: HoleAgreement,
    /// Its holes pin it ([`pinned`], no [`foreign_hole`] in its outline).
    pinned: bool,
    /// The frame's edge cuts it: some of its edge points lie outside the frame or within a
    /// profile's reach of its edge at the aligned pose (they could not be confirmed).
    cut: bool,
    /// The share of its edge points inside the frame that are confirmed.
    confirmed: f32,
    /// The part's position (its template's pixel centroid at the pose), on the frame.
    position: [f32; 2],
}

/// A template offset `u` as slot `slot`'s template has it: mirrored left-right (`x → −x`)
/// for the mirror image's (odd) slot ([`Template::mirror_from`]).
fn slot_offset(slot: usize, u: [f32; 2]) -> [f32; 2] {
    if slot % 2 == 1 {
        [-u[0], u[1]]
    } else {
        u
    }
}

/// Whether a fit's holes pin its pose: every hole of its template found where the pose puts
/// it, one at least off the template's centre. Such a fit may depart from its template's
/// outline as a real part of its type does (the whole part's rule,
/// [`crate::recognizer::NEAR_MISS`]): its mean distance may reach [`NEAR_MISS`] times
/// [`PARTIAL_LIMIT`] of the limit, and [`MIN_VISIBLE_PINNED`] of its border suffices inside the
/// frame (with [`foreign_hole`]).
fn pinned(holes: &HoleAgreement) -> bool {
    holes.off_centre > 0 && holes.all_found()
}

/// Whether hole `j` of the blob's [`Holes`] is one that the fit's template explains
/// (`matched`, as [`HoleAgreement::matched`]).
fn explained(matched: u8, j: usize) -> bool {
    u8::try_from(j)
        .ok()
        .and_then(|j| 1u8.checked_shl(u32::from(j)))
        .is_some_and(|bit| matched & bit != 0)
}

/// Whether a hole of the blob that the fit's template does not explain (`matched`, as
/// [`HoleAgreement::matched`]) has its centre inside the template's outline at `pose`: the
/// part there is not this template (another one's holes fall in it).
fn foreign_hole<const M: usize>(t: &Template<M>, pose: &Pose, part_holes: &Holes, matched: u8) -> bool {
    part_holes
        .as_slice()
        .iter()
        .enumerate()
        .any(|(j, hole)| !explained(matched, j) && inside_outline(t, 0, pose, hole.centre))
}

/// Whether `point` lies inside slot `slot`'s outline of template `t` ([`slot_offset`]) at
/// `pose` (even–odd crossings of a ray from it along +x).
fn inside_outline<const M: usize>(t: &Template<M>, slot: usize, pose: &Pose, point: [f32; 2]) -> bool {
    math::polygon_holds(t.edge().iter().map(|a| pose.apply(slot_offset(slot, *a))), point)
}

/// The rest of a blob: the longest run of unexplained border points (`marks` 0) closed by the
/// chord across its ends — the outline of the part that no template explains, cut where it
/// meets the parts found.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Rest {
    /// The border points no part explains, over the whole border.
    unexplained: usize,
    /// Points in the longest run of them.
    run: usize,
    /// The area centroid of the run closed by its chord (the run's mean where that polygon has
    /// no area).
    at: [f32; 2],
    /// The area of that polygon, px².
    area: f32,
}

/// The longest run of unexplained border points (`marks` 0) as a [`Rest`] (its `unexplained`
/// left 0).
fn rest_centroid(points: &[[f32; 2]], marks: &[f32]) -> Rest {
    let n = points.len().min(marks.len());
    let unexplained = |i: usize| marks.get(i % n.max(1)).is_some_and(|m| *m == 0.0);
    // The longest cyclic run: start after an explained point (anywhere when none is).
    let first = (0..n).find(|&i| !unexplained(i)).map_or(0, |i| i + 1);
    let (mut best, mut run) = ((0usize, 0usize), (first, 0usize));
    for k in 0..n {
        let i = first + k;
        if unexplained(i) {
            run.1 += 1;
            if run.1 > best.1 {
                best = run;
            }
        } else {
            run = (i + 1, 0);
        }
    }
    let at = |k: usize| points.get((best.0 + k) % n.max(1)).copied().unwrap_or_default();
    let (mut a2, mut cx, mut cy, mut mx, mut my) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for k in 0..best.1 {
        let (p, q) = (at(k), at((k + 1) % best.1.max(1)));
        let cross = p[0] * q[1] - q[0] * p[1];
        a2 += cross;
        cx += (p[0] + q[0]) * cross;
        cy += (p[1] + q[1]) * cross;
        mx += p[0];
        my += p[1];
    }
    let at = if a2.abs() > 1.0 {
        [cx / (3.0 * a2), cy / (3.0 * a2)]
    } else if best.1 > 0 {
        [mx / best.1 as f32, my / best.1 as f32]
    } else {
        [0.0, 0.0]
    };
    Rest {
        unexplained: 0,
        run: best.1,
        at,
        area: 0.5 * a2.abs(),
    }
}

/// Sets `out[i]` to `value` for every border point `pts[i]` that a part in `taken` explains:
/// within [`EXPLAINED_PX`] of its template's outline (mirrored for a part upside down) at its
/// pose.
fn mark_explained<const M: usize>(
    templates: &[Template<M>],
    taken: &[PartFit],
    pts: &[[f32; 2]],
    out: &mut [f32],
    value: f32,
) {
    for f in taken {
        let Some(t) = templates.get(f.slot / 2) else {
            continue;
        };
        let outline = Outline::new(t.edge());
        let cap = EXPLAINED_PX / f.pose.scale;
        for (q, o) in pts.iter().zip(out.iter_mut()) {
            let near = |u: [f32; 2]| outline.capped_distance(slot_offset(f.slot, u), cap) < cap;
            if *o != value && f.pose.invert(*q).is_some_and(near) {
                *o = value;
            }
        }
    }
}

/// The deepest concave turn of the closed polyline `points`: the largest angle (radians) by
/// which it turns against its own direction of travel (concave, for an outer border) between
/// the chord from `k` points before a point to it and the chord from it to `k` points after.
/// Over chords a few pixels long a corner shows its whole turn, also where the mask rounded
/// it, and a smooth concave stretch of radius `R` about `2·chord / R`. 0 for a convex polyline.
pub fn deepest_concavity(points: &[[f32; 2]], k: usize) -> f32 {
    let n = points.len();
    if n < 3 {
        return 0.0;
    }
    let k = k.clamp(1, (n - 1) / 2);
    let at = |i: usize| points.get(i % n).copied().unwrap_or_default();
    // The polygon's orientation: a concave turn has the other sign.
    let mut area2 = 0.0f32;
    for i in 0..n {
        let (p, q) = (at(i), at(i + 1));
        area2 += p[0] * q[1] - q[0] * p[1];
    }
    let against = if area2 < 0.0 { 1.0 } else { -1.0 };
    let mut deepest = 0.0f32;
    for i in 0..n {
        let (a, b, c) = (at(i + n - k), at(i), at(i + k));
        let (u, v) = ([b[0] - a[0], b[1] - a[1]], [c[0] - b[0], c[1] - b[1]]);
        let cross = (u[0] * v[1] - u[1] * v[0]) * against;
        if cross > 0.0 {
            deepest = deepest.max(math::atan2(cross, u[0] * v[0] + u[1] * v[1]));
        }
    }
    deepest
}

/// Whether the closed polyline `points` turns concave somewhere by `turn` (radians, in
/// `(0, π)`) or more, over the chords of [`deepest_concavity`]: `deepest_concavity(points, k) >=
/// turn` without an arc tangent per point, and done at the first such turn (the camera's cost of
/// the junction test).
pub fn turns_concave_by(points: &[[f32; 2]], k: usize, turn: f32) -> bool {
    let n = points.len();
    let at = |i: usize| points.get(i).copied().unwrap_or_default();
    let mut area2 = 0.0f32;
    for i in 0..n {
        let (p, q) = (at(i), at(if i + 1 == n { 0 } else { i + 1 }));
        area2 += p[0] * q[1] - q[0] * p[1];
    }
    turns_concave_at(n, k, 1, area2 > 0.0, turn, at)
}

/// [`turns_concave_by`] over the `n` points `at(0..n)` of a closed polyline that runs
/// counter-clockwise (in image coordinates) or not, turning at every `every`-th point.
fn turns_concave_at(n: usize, k: usize, every: usize, ccw: bool, turn: f32, at: impl Fn(usize) -> [f32; 2]) -> bool {
    if n < 3 {
        return false;
    }
    let k = k.clamp(1, (n - 1) / 2);
    // A concave turn has the sign opposite to the polygon's orientation.
    let against = if ccw { -1.0 } else { 1.0 };
    // atan2(cross, dot) ≥ turn for cross > 0 is sin(angle − turn) ≥ 0.
    let (sin_t, cos_t) = math::sin_cos(turn);
    (0..n).step_by(every.max(1)).any(|i| {
        let before = if i >= k { i - k } else { i + n - k };
        let after = if i + k < n { i + k } else { i + k - n };
        let (a, b, c) = (at(before), at(i), at(after));
        let (u, v) = ([b[0] - a[0], b[1] - a[1]], [c[0] - b[0], c[1] - b[1]]);
        let cross = (u[0] * v[1] - u[1] * v[0]) * against;
        let dot = u[0] * v[0] + u[1] * v[1];
        cross > 0.0 && cross * cos_t - dot * sin_t >= 0.0
    })
}

/// The similarity mapping template offsets `t(j)` onto border points `q(i)` for the run, in
/// least squares (template index advancing linearly along the border's run).
fn pose_from_run<const M: usize>(run: &ArcMatch, border: &[[f32; 2]], t: &Template<M>) -> Option<Pose> {
    let (n, edge) = (border.len(), t.edge());
    let m = edge.len();
    if n == 0 || m == 0 || run.part_len < 2 {
        return None;
    }
    let along = (run.template_len.saturating_sub(1)) as f32 / (run.part_len - 1) as f32;
    let pair = |k: usize| {
        let q = border.get((run.part_start + k) % n).copied()?;
        let j = run.template_start as f32 + k as f32 * along;
        let j0 = math::floor(j);
        let f = j - j0;
        let a = edge.get(j0 as usize % m).copied()?;
        let b = edge.get((j0 as usize + 1) % m).copied()?;
        Some(([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])], q))
    };
    let count = run.part_len as f32;
    let (mut mt, mut mq) = ([0.0f32; 2], [0.0f32; 2]);
    for k in 0..run.part_len {
        let (u, q) = pair(k)?;
        mt = [mt[0] + u[0] / count, mt[1] + u[1] / count];
        mq = [mq[0] + q[0] / count, mq[1] + q[1] / count];
    }
    // R(θ)·u = [u0 c + u1 s, −u0 s + u1 c] (counter-clockwise on screen).
    let (mut dot, mut cross, mut norm) = (0.0f32, 0.0f32, 0.0f32);
    for k in 0..run.part_len {
        let (u, q) = pair(k)?;
        let (u, v) = ([u[0] - mt[0], u[1] - mt[1]], [q[0] - mq[0], q[1] - mq[1]]);
        dot += u[0] * v[0] + u[1] * v[1];
        cross += u[1] * v[0] - u[0] * v[1];
        norm += u[0] * u[0] + u[1] * u[1];
    }
    if !(norm > 0.0) {
        return None;
    }
    let angle = math::atan2(cross, dot);
    let scale = math::hypot(dot, cross) / norm;
    let probe = Pose {
        x: 0.0,
        y: 0.0,
        angle,
        scale,
    };
    let r = probe.apply(mt);
    Some(Pose {
        x: mq[0] - r[0],
        y: mq[1] - r[1],
        angle,
        scale,
    })
}

impl<const T: usize, const M: usize, const P: usize, const C: usize, const D: usize> Recognizer<T, M, P, C, D> {
    /// Whether a blob inside the frame whose border has no junction ([`JUNCTION_TURN`]) is left
    /// whole, unsearched (on, as [`Self::new`] makes it). Off, every blob the whole-border
    /// result does not settle is searched: to measure the gate against the search.
    pub fn set_junction_gate(&mut self, on: bool) {
        self.junction_gate = on;
    }

    /// Whether blob `index`'s border turns concave by [`JUNCTION_TURN`] or more
    /// ([`turns_concave_by`] on its pixel chain, at every [`JUNCTION_CHAIN_STEP`]-th point over
    /// chords of [`JUNCTION_CHAIN_CHORD`] points): where two parts' outlines could meet.
    fn has_junction(&self, index: usize) -> bool {
        let border = self.store.points(index);
        let Some(contour) = self.store.contours().get(index) else {
            return true;
        };
        // Points of a border too long for the store lie `stride` pixels of the chain apart.
        let stride = (contour.stride as usize).max(1);
        let chord = (JUNCTION_CHAIN_CHORD / stride).max(1);
        let every = (JUNCTION_CHAIN_STEP / stride).max(1);
        let at = |i: usize| border.get(i).map_or([0.0; 2], |p| [f32::from(p.x), f32::from(p.y)]);
        turns_concave_at(border.len(), chord, every, contour.area2 > 0, JUNCTION_TURN, at)
    }

    /// The partial search on blob `index` (whole-border result `whole`), its parts pushed to
    /// `report` (skips when it is full); false when it found none (then `whole` stands) or the
    /// blob is too long to search ([`Report::unsplit`]). Kept out of line, so its buffers take
    /// stack only while it runs.
    #[inline(never)]
    pub(crate) fn split_into<B: AsRef<[u8]>>(
        &mut self,
        index: usize,
        frame: &Frame<B>,
        background: &[u8],
        whole: &Detection,
        report: &mut Report,
    ) -> bool {
        // A blob inside the frame without a junction is one part: its whole-border result
        // stands (tested before anything else is set up: most blobs end here).
        if self.junction_gate && !whole.touches_edge && !self.has_junction(index) {
            return false;
        }
        let border = self.store.points(index);
        let chain = math::perimeter(border.iter().map(|p| [p.x as f32, p.y as f32]));
        let diff = Difference::new(frame, background, self.params.alpha());
        let holes = Holes::from_borders(self.store.holes_of(index).map(|i| self.store.points(i)), 0.0);
        match self.split_blob(index, chain, &diff, &holes, whole) {
            Ok(parts) if !parts.is_empty() => {
                // By reference: a by-value iterator left at `break` drops its rest through a
                // slice index the firmware would link as a panic path.
                for d in &parts {
                    if report.detections.push(*d).is_err() {
                        report.skip(index, SkipReason::TooManyParts);
                        break;
                    }
                }
                true
            }
            Ok(_) => false,
            Err(()) => {
                report.unsplit += 1;
                false
            }
        }
    }

    /// The parts along blob `index`'s border whose whole-border result `whole` was not
    /// verified (see the module doc); empty when none is found (then `whole` stands) or the
    /// blob is too long to search (`Err(())`).
    fn split_blob<B: AsRef<[u8]>>(
        &mut self,
        index: usize,
        chain: f32,
        diff: &Difference<'_, B>,
        part_holes: &Holes,
        whole: &Detection,
    ) -> Result<heapless::Vec<Detection, MAX_BLOB_PARTS>, ()> {
        let mut found = heapless::Vec::new();
        let mut searched = 0usize;
        let least = self.least_part_area();
        let mut taken: heapless::Vec<PartFit, MAX_BLOB_PARTS> = heapless::Vec::new();
        // Round 1 over the whole border; round 2, when the first left a rest, over the border
        // that no part found explains (the first round's runs all on the parts it found).
        // The rest of the border that no part found explains, over `count` points: measured
        // whenever a round takes a part.
        let count = BLOB_POINTS.min(math::round(chain / 2.0).max(8.0) as usize);
        let mut rest = Rest::default();
        // Each round first at the middle of each template's scale range; where that leaves the
        // blob unexplained, at the other scales its runs' own poses point to (the scale points
        // nearest their fitted scales, [`Self::hypotheses`]), for those templates only.
        let mut explained = false;
        for round in 0..2 {
            let before = taken.len();
            let mut steps = [[1u8 << MIDDLE_STEP; 2]; T];
            for pass in 0..2 {
                let mut pointed = [[0u8; 2]; T];
                let (hyps, s, too_long) =
                    self.hypotheses(index, whole, least, chain, part_holes, &taken, &steps, &mut pointed);
                searched += s;
                if round == 0 && pass == 0 && too_long && hyps.is_empty() {
                    return Err(());
                }
                let after = taken.len();
                self.take_fits(&hyps, diff, part_holes, !whole.touches_edge, &mut taken);
                if taken.len() > after {
                    rest = self.unexplained(index, count, &taken);
                    explained = (rest.unexplained as f32) < REST_SHARE * count as f32;
                }
                for p in pointed.as_flattened_mut() {
                    *p &= !(1 << MIDDLE_STEP);
                }
                if explained || pass > 0 || pointed.as_flattened().iter().all(|p| *p == 0) {
                    break;
                }
                steps = pointed;
            }
            if taken.len() == before || explained {
                break;
            }
        }
        if taken.is_empty() {
            return Ok(found);
        }
        // A rest: one run of unexplained border long enough, outside every part found (a part
        // of its own, not the end of a found part longer than its template), and enclosing
        // more than the band the verification lets an outline lie off its template along the
        // run (the run's length times the largest limit of the parts found), by the least
        // area a part is reported at.
        let limit = taken.iter().map(|f| f.limit).fold(0.0f32, f32::max);
        let run_len = rest.run as f32 * chain / count.max(1) as f32;
        let outside = !taken.iter().any(|f| {
            self.templates
                .get(f.slot / 2)
                .is_some_and(|t| inside_outline(t, f.slot, &f.pose, rest.at))
        });
        let rest_part = rest.run as f32 >= REST_SHARE * count as f32
            && outside
            && rest.area - run_len * limit >= self.params.min_area;
        let several = taken.len() > 1 || rest_part;
        for f in &taken {
            let [x, y] = f.position;
            let ti = u16::try_from(f.slot / 2).ok();
            let d = Detection {
                template: ti,
                best_template: ti,
                score: f32::INFINITY,
                x,
                y,
                angle_deg: math::wrap_degrees(math::degrees(f.pose.angle)),
                verify: f.distance,
                verify_limit: f.limit,
                scale: f.pose.scale,
                pose: Some(f.pose),
                holes: f.holes,
                flipped: f.slot % 2 == 1,
                searches: u8::try_from(searched).unwrap_or(u8::MAX),
                touching: several,
                visible_fraction: f.visible,
                position_from_pose: true,
                touches_edge: f.cut,
                ..*whole
            };
            let _ = found.push(d);
        }
        if rest_part && rest.run > 0 {
            let [x, y] = rest.at;
            // Unknown: no template's pose or verification (the whole blob's were not the
            // rest's); the blob's DP diagnostics stay.
            let d = Detection {
                template: None,
                x,
                y,
                verify: f32::INFINITY,
                scale: 1.0,
                pose: None,
                holes: HoleAgreement::default(),
                flipped: false,
                touching: true,
                visible_fraction: 0.0,
                position_from_pose: false,
                ..*whole
            };
            let _ = found.push(d);
        }
        Ok(found)
    }

    /// The poses to align for blob `index`: the best runs of each template along its border
    /// ([`best_arcs`]), and of the mirror image of each chiral one (a part upside down, with
    /// [`crate::Params::flipped_parts`]), at most [`MAX_HYPOTHESES`]; border points the parts
    /// in `taken` explain take part in no run. Template `ti` is searched at the scale points
    /// (of [`SCALE_STEPS`]) set in `steps[ti][0]` (bit `s` for point `s`), its mirror image at
    /// those in `steps[ti][1]`; `pointed` gets the bit of the scale point nearest
    /// (geometrically) each of their runs' fitted scales. Also the templates searched, and
    /// whether the blob was too long for one of them.
    #[allow(clippy::too_many_arguments)]
    fn hypotheses(
        &mut self,
        index: usize,
        whole: &Detection,
        least: f32,
        chain: f32,
        part_holes: &Holes,
        taken: &[PartFit],
        steps: &[[u8; 2]; T],
        pointed: &mut [[u8; 2]; T],
    ) -> (heapless::Vec<Hypothesis, MAX_HYPOTHESES>, usize, bool) {
        let params = self.params;
        let mut hyps: heapless::Vec<Hypothesis, MAX_HYPOTHESES> = heapless::Vec::new();
        let mut searched = 0usize;
        let mut too_long = false;
        for slot in 0..2 * self.templates.len() {
            let (ti, side) = (slot / 2, slot % 2);
            let want = steps.get(ti).and_then(|s| s.get(side)).copied().unwrap_or(0);
            if want == 0 {
                continue;
            }
            // The mirror image of a chiral template: a part lying upside down (as a whole
            // part's scan has it). A template with a mirror axis is its own mirror image.
            if side == 1 {
                if !(params.flipped_parts && self.templates.get(ti).is_some_and(|t| t.is_chiral())) {
                    continue;
                }
                self.prepare_mirror(ti);
            }
            let t = if side == 1 {
                &self.mirror
            } else {
                let Some(t) = self.templates.get(ti) else {
                    continue;
                };
                t
            };
            let border = self.store.points(index);
            let (lo, _) = t.tolerance().scale_range(params.scale_min, params.scale_max);
            // A blob inside the frame holds the template and another part (or a rest) that
            // shows at least `least`; one the frame's edge cuts, half of the template.
            let needed = if whole.touches_edge {
                MIN_VISIBLE * lo * lo * t.area()
            } else {
                lo * lo * t.area() + least
            };
            if needed > whole.area {
                continue;
            }
            // A part of a blob inside the frame lies wholly inside it, holes and all: its fit
            // needs every hole of its template that the tracing keeps found
            // ([`Self::partial_fit`]), each in a hole of the blob of its own ([`agreement`]). A
            // blob with fewer holes than those kept at the least scale cannot hold it.
            let filter = params.filter();
            let kept = t
                .holes()
                .as_slice()
                .iter()
                .filter(|h| traceable(h, lo, &filter))
                .count();
            if !whole.touches_edge && kept > part_holes.len() {
                continue;
            }
            // Every STRIDE-th template point, the border at the same step.
            let m = t.len();
            let coarse = m / STRIDE;
            if coarse < 8 {
                continue;
            }
            let tp = self.points.get_mut(..coarse).unwrap_or(&mut []);
            for (slot, p) in tp.iter_mut().zip(t.points().iter().step_by(STRIDE)) {
                *slot = *p;
            }
            let tk = self.arc_template.get_mut(..coarse).unwrap_or(&mut []);
            if turning(tp, TURN_K, tk).is_err() {
                continue;
            }
            let arc_params = ArcParams {
                min_template: coarse / 3,
                ..ArcParams::DEFAULT
            };
            // The border at each of SCALE_STEPS scales over the range (scale is a factor: the
            // points dividing it into equal geometric parts), as the template's step there.
            let (lo_s, hi_s) = t.tolerance().scale_range(params.scale_min, params.scale_max);
            let (middle, span) = (math::sqrt(lo_s * hi_s), hi_s / lo_s);
            let template_step = STRIDE as f32 * math::perimeter(t.points().iter().copied()) / m.max(1) as f32;
            // Neighbouring scale points lie `spacing` apart (a factor), and a fitted scale is
            // nearest the point `s` within `spacing^±½` of it.
            let spacing = math::powf(span, 1.0 / (SCALE_STEPS + 1) as f32);
            let half = math::sqrt(spacing);
            let mut dp_ran = false;
            let mut last_count = 0usize;
            for s in 0..SCALE_STEPS {
                if want & (1 << s) == 0 {
                    continue;
                }
                let scale = if s == MIDDLE_STEP {
                    middle
                } else {
                    middle * math::powf(span, (s + 1) as f32 / (SCALE_STEPS + 1) as f32 - 0.5)
                };
                let step = scale * template_step;
                let count = if step > 0.0 { math::round(chain / step) } else { 0.0 };
                if !(count >= 8.0) {
                    continue;
                }
                if count > BLOB_POINTS as f32 {
                    too_long = true;
                    continue;
                }
                let count = count as usize;
                // (A narrow range gives the same points twice: searched once.)
                if count == last_count {
                    continue;
                }
                last_count = count;
                let pts = self.arc_points.get_mut(..count).unwrap_or(&mut []);
                if resample(border, pts).is_err() {
                    continue;
                }
                let kappa = self.arc_turning.get_mut(..count).unwrap_or(&mut []);
                if turning(pts, TURN_K, kappa).is_err() {
                    continue;
                }
                // Explained points: a turning no template point has, so no run passes them.
                mark_explained(&self.templates, taken, pts, kappa, EXPLAINED_TURN);
                let mut runs: heapless::Vec<ArcMatch, RUNS_PER_TEMPLATE> = heapless::Vec::new();
                let rows = self.arc_rows.as_flattened_mut();
                let tk = self.arc_template.get(..coarse).unwrap_or(&[]);
                if best_arcs(kappa, tk, &arc_params, rows, &mut runs).is_err() {
                    continue;
                }
                dp_ran = true;
                let pts = self.arc_points.get(..count).unwrap_or(&[]);
                for run in &runs {
                    // Back to the template's own points.
                    let run = ArcMatch {
                        template_start: run.template_start * STRIDE,
                        template_len: (run.template_len - 1) * STRIDE + 1,
                        ..*run
                    };
                    let Some(seed) = pose_from_run(&run, pts, t) else {
                        continue;
                    };
                    // The scale point nearest the run's fitted scale.
                    if let Some(p) = pointed.get_mut(ti).and_then(|p| p.get_mut(side)) {
                        let (mut nearest, mut at) = (s, scale);
                        while nearest > 0 && seed.scale < at / half {
                            nearest -= 1;
                            at /= spacing;
                        }
                        while nearest + 1 < SCALE_STEPS && seed.scale > at * half {
                            nearest += 1;
                            at *= spacing;
                        }
                        *p |= 1u8.checked_shl(nearest as u32).unwrap_or(0);
                    }
                    // A run's score sums over its border points, more of them the smaller the
                    // step: per length of border at the middle scale, to compare the steps'.
                    let h = Hypothesis {
                        slot,
                        seed,
                        score: run.score * scale / middle,
                    };
                    if hyps.push(h).is_err() {
                        let low = hyps
                            .iter_mut()
                            .min_by(|a, b| a.score.total_cmp(&b.score))
                            .filter(|l| l.score < h.score);
                        if let Some(l) = low {
                            *l = h;
                        }
                    }
                }
            }
            searched += usize::from(dp_ran);
        }
        (hyps, searched, too_long)
    }

    /// Each pose aligned and verified on the visible edge ([`Self::partial_fit`]); the fits
    /// taken into `taken` best first (the more holes found, then the larger share of the edge
    /// points inside the frame confirmed, then the lower score), unless their centre falls
    /// within half a size of one taken already. A hypothesis of a mirror image has it made in
    /// the recognizer's scratch template first.
    fn take_fits<B: AsRef<[u8]>>(
        &mut self,
        hyps: &[Hypothesis],
        diff: &Difference<'_, B>,
        part_holes: &Holes,
        blob_inside: bool,
        taken: &mut heapless::Vec<PartFit, MAX_BLOB_PARTS>,
    ) {
        // Align and verify each pose on the visible edge, but for a pose whose centre falls on
        // a part taken already (in the first round): its fit would be that part's again, and
        // not be taken.
        let mut fits: heapless::Vec<PartFit, MAX_HYPOTHESES> = heapless::Vec::new();
        for h in hyps {
            if taken
                .iter()
                .any(|f| self.same_place(f, h.slot / 2, h.seed.x, h.seed.y, h.seed.scale))
            {
                continue;
            }
            if h.slot % 2 == 1 {
                self.prepare_mirror(h.slot / 2);
            }
            let Some(t) = self.slot_template(h.slot) else {
                continue;
            };
            // Half the border for a part the frame's edge cuts (not for another part of its
            // blob that lies wholly inside), 65 % for one its holes pin.
            let least_visible = |f: &PartFit| {
                if f.cut {
                    MIN_VISIBLE
                } else if f.pinned {
                    MIN_VISIBLE_PINNED
                } else {
                    MIN_VISIBLE_INSIDE
                }
            };
            if let Some(fit) = self
                .partial_fit(t, h, diff, part_holes, blob_inside)
                .filter(|f| f.visible >= least_visible(f))
            {
                let _ = fits.push(PartFit { slot: h.slot, ..fit });
            }
        }
        // Best first: the more of its template's holes found (as a whole part's fits are
        // ranked: a rod with two eyes is the two-eyed template's, even where the one-eyed
        // template's outline fits as much of it), then the larger share of the edge points
        // inside the frame confirmed (the visible share, for a part inside it), then the lower
        // score.
        let before = |a: &PartFit, b: &PartFit| {
            if a.holes.found != b.holes.found {
                return a.holes.found > b.holes.found;
            }
            a.confirmed > b.confirmed || (a.confirmed == b.confirmed && a.distance / a.limit < b.distance / b.limit)
        };
        for i in 1..fits.len() {
            let mut j = i;
            while j > 0 && fits.get(j).zip(fits.get(j - 1)).is_some_and(|(a, b)| before(a, b)) {
                fits.swap(j, j - 1);
                j -= 1;
            }
        }
        for f in &fits {
            let clash = taken
                .iter()
                .any(|g| self.same_place(g, f.slot / 2, f.pose.x, f.pose.y, f.pose.scale));
            if !clash && taken.push(*f).is_err() {
                break;
            }
        }
    }

    /// Whether template `template` placed at `(x, y)` with `scale` is the part `fit` again:
    /// their centres lie within half the smaller one's size.
    fn same_place(&self, fit: &PartFit, template: usize, x: f32, y: f32, scale: f32) -> bool {
        let size = self.templates.get(template).map_or(0.0, |t| t.size() * scale);
        let other = self
            .templates
            .get(fit.slot / 2)
            .map_or(0.0, |t| t.size() * fit.pose.scale);
        math::hypot(x - fit.pose.x, y - fit.pose.y) < 0.5 * size.min(other)
    }

    /// How many of `count` points along blob `index`'s border no part in `taken` explains
    /// (farther than [`EXPLAINED_PX`] from each one's aligned outline), and their longest run
    /// ([`rest_centroid`]).
    fn unexplained(&mut self, index: usize, count: usize, taken: &[PartFit]) -> Rest {
        let border = self.store.points(index);
        let pts = self.arc_points.get_mut(..count).unwrap_or(&mut []);
        if resample(border, pts).is_err() {
            return Rest::default();
        }
        // 1 marks a point some part explains.
        let marks = self.arc_turning.get_mut(..count).unwrap_or(&mut []);
        marks.fill(0.0);
        mark_explained(&self.templates, taken, pts, marks, 1.0);
        Rest {
            unexplained: marks.iter().filter(|m| **m == 0.0).count(),
            ..rest_centroid(pts, marks)
        }
    }

    /// The least area a part may show: half of the smallest template at its least scale.
    fn least_part_area(&self) -> f32 {
        let params = &self.params;
        self.templates
            .iter()
            .map(|t| {
                let (lo, _) = t.tolerance().scale_range(params.scale_min, params.scale_max);
                MIN_VISIBLE * lo * lo * t.area()
            })
            .fold(f32::INFINITY, f32::min)
    }

    /// Whether a blob's whole-border result leaves it to the partial search: no part was
    /// verified, the blob touches the frame's edge, or the verified template covers less of
    /// the blob than its area less half the smallest template's (the least a second part
    /// shows) and less the band the verification lets the outline lie off the template all
    /// round (the border's length times the verification's limit: a thick part's walls, the
    /// mask's edge a pixel out).
    pub(crate) fn blob_not_explained(&self, whole: &Detection) -> bool {
        let Some(ti) = whole.template else {
            return true;
        };
        // A part the frame's edge cuts: its whole-border match saw the edge's straight cut as
        // outline, and its centroid is the visible piece's. The partial search places the
        // whole template.
        if whole.touches_edge {
            return true;
        }
        let least = self.least_part_area();
        let covered = self
            .templates
            .get(usize::from(ti))
            .map_or(f32::INFINITY, |t| t.area() * whole.scale * whole.scale);
        let excess = whole.area - covered;
        // (The border's length only where the area alone would leave the blob to the search.)
        excess > least && {
            let border = self.store.points(usize::from(whole.contour));
            let chain = math::perimeter(border.iter().map(|p| [p.x as f32, p.y as f32]));
            excess > least + chain * whole.verify_limit
        }
    }

    /// Template `t` aligned from the hypothesis' seed and verified on its visible edge; `None`
    /// when it does not hold (see the module doc). `blob_inside`: the blob does not touch the
    /// frame's edge (so neither does any part of it, nor any of its holes).
    fn partial_fit<B: AsRef<[u8]>>(
        &self,
        t: &Template<M>,
        h: &Hypothesis,
        diff: &Difference<'_, B>,
        part_holes: &Holes,
        blob_inside: bool,
    ) -> Option<PartFit> {
        let params = &self.params;
        let (lo, hi) = t.tolerance().scale_range(params.scale_min, params.scale_max);
        let seed = Pose {
            scale: math::clamp(h.seed.scale, lo, hi),
            ..h.seed
        };
        // A class whose examples agree closely narrows its whole parts' limit, not this one.
        let limit_at = |scale: f32| params.verify_limit(t.size() * scale) * t.tolerance().search_verify();
        let reach = limit_at(seed.scale) / params.verify_threshold.max(f32::MIN_POSITIVE);
        let reach = if reach.is_finite() { reach.max(1.0) } else { 1.0 };
        // More steps than a whole part's: the seed of a run can lie a few degrees off, and a
        // part with a hidden stretch converges slowly.
        let cap = RefineParams::DEFAULT.cap * reach;
        let confirm = CONFIRM_PX * reach;
        let rp = RefineParams {
            cap,
            iterations: PARTIAL_ITERATIONS,
            ..RefineParams::DEFAULT
        };
        // Only the edge points the pose puts inside the frame, away from its edge by more than
        // a profile's reach: a profile beyond the frame reads its edge pixels (clamped) and
        // finds the silhouette's cut there, which would pull the fit and confirm a hidden edge.
        let (w, h) = (diff.width() as f32, diff.height() as f32);
        let margin = rp.search;
        let inside =
            |p: [f32; 2]| p[0] >= margin && p[1] >= margin && p[0] <= w - 1.0 - margin && p[1] <= h - 1.0 - margin;
        let (mut edge, mut normals) = ([[0.0f32; 2]; M], [[0.0f32; 2]; M]);
        let keep = |pose: &Pose, edge: &mut [[f32; 2]; M], normals: &mut [[f32; 2]; M]| {
            let mut k = 0usize;
            for (e, n) in t.edge().iter().zip(t.normals()) {
                if inside(pose.apply(*e)) {
                    if let (Some(se), Some(sn)) = (edge.get_mut(k), normals.get_mut(k)) {
                        (*se, *sn) = (*e, *n);
                        k += 1;
                    }
                }
            }
            k
        };
        let k = keep(&seed, &mut edge, &mut normals);
        let mut distances = [0.0f32; M];
        let (e, n) = (edge.get(..k).unwrap_or(&[]), normals.get(..k).unwrap_or(&[]));
        // The alignment gives up (from its fourth step) where its mean capped distance says
        // that less could be confirmed than the fit would need: a fit with a share `v`
        // confirmed has its mean below v · confirm + (1 − v) · cap, and a part whole inside the
        // frame at its seed needs MIN_VISIBLE_PINNED at the least (a cut one the documented
        // half).
        let least = if k >= t.edge().len() {
            MIN_VISIBLE_PINNED
        } else {
            MIN_VISIBLE
        };
        let rp_seed = RefineParams {
            give_up: least * confirm + (1.0 - least) * cap,
            ..rp
        };
        let a = align_recording(diff, e, n, seed, &rp_seed, &mut distances);
        let pose = a.pose;
        if a.gave_up || !(pose.scale >= lo && pose.scale <= hi) {
            return None;
        }
        // Confirmed at the final pose, over the points inside the frame there.
        let k = keep(&pose, &mut edge, &mut normals);
        let (e, n) = (edge.get(..k).unwrap_or(&[]), normals.get(..k).unwrap_or(&[]));
        edge_distances(diff, e, n, pose, 0.0, &rp, &mut distances);
        let m = t.edge().len();
        let (mut seen, mut sum) = (0usize, 0.0f32);
        for d in distances.iter().take(k) {
            if *d <= confirm {
                seen += 1;
                sum += *d;
            }
        }
        let visible = seen as f32 / m.max(1) as f32;
        let confirmed = seen as f32 / k.max(1) as f32;
        let limit = limit_at(pose.scale);
        let distance = if seen > 0 { sum / seen as f32 } else { f32::INFINITY };
        let holes = agreement(t.holes(), &pose, part_holes);
        // Every hole the pose puts wholly inside the frame must be there (every hole of a part
        // of a blob inside the frame): in a hole of the blob, or, for a hole too small for the
        // tracing to keep, as a dip of |D| ([`untraced_shown`]; a pin's end-hole, which also
        // tells its ends apart).
        let counts = |hole: &Hole| {
            if blob_inside {
                return true;
            }
            let [x, y] = pose.apply(hole.centre);
            let r = math::sqrt(hole.area / core::f32::consts::PI) * pose.scale + 1.0;
            x >= r && y >= r && x <= w - 1.0 - r && y <= h - 1.0 - r
        };
        let wanted = t.holes().as_slice().iter().filter(|hole| counts(hole)).count();
        let shown = if usize::from(holes.found) >= wanted {
            0
        } else {
            untraced_shown(
                t.holes(),
                &pose,
                part_holes,
                &params.filter(),
                |x, y| diff.bilinear(x, y),
                |x, y| in_frame(diff, x, y),
                counts,
            )
        };
        let holes_there = usize::from(holes.found) + shown >= wanted;
        let pinned = pinned(&holes) && !foreign_hole(t, &pose, part_holes, holes.matched);
        let within = if pinned {
            PARTIAL_LIMIT * NEAR_MISS
        } else {
            PARTIAL_LIMIT
        };
        // A part's position (the aligned template's) on the frame: a fit of a cut part whose
        // centre the pose puts beyond the frame's edge is not taken (the whole-border result
        // stands for its blob; every position reported lies on the frame).
        let position = pose.apply(t.position_offset());
        let placed = in_frame(diff, position[0], position[1]);
        (visible >= MIN_VISIBLE && distance < within * limit && holes_there && placed).then_some(PartFit {
            slot: 0,
            pose,
            visible,
            distance,
            limit,
            holes,
            pinned,
            cut: k < m,
            confirmed,
            position,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::borders::contour::BorderKind;
    use crate::pixels::background::Background;
    use crate::Params;
    extern crate std;
    use std::vec::Vec;

    /// A shape: whether an offset from its origin is inside it.
    type Inside = fn([f32; 2]) -> bool;

    /// Shapes at `(x, y)` turned by an angle (°), as [`draw`] takes them.
    type Scene<'a> = &'a [(Inside, f32, f32, f32)];

    // The recognizer's own test shapes: an L (a bar 44 × 10, a foot 10 × 16 below its left
    // end) and a T (a bar 44 × 10 over a stem 10 × 30), offsets from their area centroids.
    use crate::recognizer::tests::{l_inside as ell, t_inside as tee, taught};

    /// A ring (outer radius 20, hole 10): a template with a hole the tracing keeps at every
    /// scale of the default range (radius 7.1 at its least).
    fn ring(t: [f32; 2]) -> bool {
        let r2 = t[0] * t[0] + t[1] * t[1];
        r2 < 400.0 && r2 > 100.0
    }

    /// An ellipse 32 × 20 (no template): a convex unknown part.
    fn ellipse(t: [f32; 2]) -> bool {
        (t[0] / 16.0).powi(2) + (t[1] / 10.0).powi(2) < 1.0
    }

    /// A bean (no template): a disc of radius 15 with a shallow bite of radius 30 out of one
    /// side, a smooth concave stretch and no corner.
    fn bean(t: [f32; 2]) -> bool {
        t[0] * t[0] + t[1] * t[1] < 225.0 && t[0] * t[0] + (t[1] - 40.0).powi(2) > 900.0
    }

    /// Dark parts (20) on a platform of 200: each shape turned by its angle (°) about its origin
    /// at `(x, y)`, 4 × 4 samples a pixel.
    fn draw(w: usize, h: usize, parts: &[(Inside, f32, f32, f32)]) -> Vec<u8> {
        let mut px = std::vec![200u8; w * h];
        for (y, row) in px.chunks_exact_mut(w).enumerate() {
            for (x, p) in row.iter_mut().enumerate() {
                let mut cover = 0.0f32;
                for &(inside, cx, cy, deg) in parts {
                    let (s, c) = libm::sincosf(deg.to_radians());
                    for k in 0..16 {
                        let dx = x as f32 - 0.375 + 0.25 * (k % 4) as f32 - cx;
                        let dy = y as f32 - 0.375 + 0.25 * (k / 4) as f32 - cy;
                        cover += u8::from(inside([c * dx - s * dy, s * dx + c * dy])) as f32 / 16.0;
                    }
                }
                *p = (200.0 - 180.0 * cover.min(1.0)).round() as u8;
            }
        }
        px
    }

    type Rec = Recognizer<4, 96, 8192, 64, 2112>;

    /// A recognizer with the defaults and the partial search on, the junction gate as given, and
    /// the L, the T and the ring taught.
    fn recognizer(gate: bool) -> std::boxed::Box<Rec> {
        let mut rec: std::boxed::Box<Rec> = std::boxed::Box::default();
        rec.set_params(Params {
            touching_parts: true,
            ..Params::DEFAULT
        })
        .unwrap();
        rec.set_junction_gate(gate);
        for inside in [ell as Inside, tee, ring] {
            rec.add_template(taught(inside)).unwrap();
        }
        rec
    }

    /// One frame through `rec` on the empty platform.
    fn run(rec: &mut Rec, px: &[u8], w: usize, h: usize) -> crate::recognizer::Report {
        let bg_px = std::vec![200u8; w * h];
        let mut bg = Background::new(std::vec![0u8; w * h], w, h).unwrap();
        bg.set_from_frame(&Frame::new_checked(&bg_px[..], w, h).unwrap(), Params::DEFAULT.alpha())
            .unwrap();
        let mut labels = std::vec![0u8; w * h];
        rec.process(&Frame::new_checked(px, w, h).unwrap(), &bg, &mut labels)
            .unwrap()
    }

    /// The deepest concave turn: none on a convex outline (a square, a circle), a corner's
    /// whole turn (the L's inner corner, a right angle, whichever way round the outline runs),
    /// and little on a smooth concave stretch (a bite of radius 30 taken at chords of 6 px).
    #[test]
    fn the_deepest_concavity_is_a_corner_s_turn() {
        let square: Vec<[f32; 2]> = (0..40)
            .map(|i| {
                let t = (i % 10) as f32 * 2.0;
                match i / 10 {
                    0 => [t, 0.0],
                    1 => [20.0, t],
                    2 => [20.0 - t, 20.0],
                    _ => [0.0, 20.0 - t],
                }
            })
            .collect();
        assert_eq!(deepest_concavity(&square, 3), 0.0);
        let circle: Vec<[f32; 2]> = (0..60)
            .map(|i| {
                let (s, c) = libm::sincosf(i as f32 * core::f32::consts::TAU / 60.0);
                [20.0 * c, 20.0 * s]
            })
            .collect();
        assert_eq!(deepest_concavity(&circle, 3), 0.0);
        // An L traced at 2 px: (0,0) → (40,0) → (40,10) → (10,10) → (10,30) → (0,30) → back.
        let corners = [
            [0.0f32, 0.0],
            [40.0, 0.0],
            [40.0, 10.0],
            [10.0, 10.0],
            [10.0, 30.0],
            [0.0, 30.0],
        ];
        let mut ell_pts = Vec::new();
        for (a, b) in corners.iter().zip(corners.iter().cycle().skip(1)) {
            let steps = ((b[0] - a[0]).abs() + (b[1] - a[1]).abs()) as usize / 2;
            for s in 0..steps {
                let f = s as f32 / steps as f32;
                ell_pts.push([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]);
            }
        }
        let turn = deepest_concavity(&ell_pts, 3);
        assert!((turn - core::f32::consts::FRAC_PI_2).abs() < 1e-4, "{turn}");
        let reversed: Vec<[f32; 2]> = ell_pts.iter().rev().copied().collect();
        assert!((deepest_concavity(&reversed, 3) - turn).abs() < 1e-4);
        // A disc of radius 40 with a bite of radius 30 (2 px apart): the bite turns about
        // 2 · 6 / 30 = 0.4 rad over the chords.
        let mut bite = Vec::new();
        for i in 0..200 {
            let (s, c) = libm::sincosf(i as f32 * core::f32::consts::TAU / 200.0);
            let p = [40.0 * c, 40.0 * s];
            let d = libm::hypotf(p[0], p[1] - 60.0);
            bite.push(if d < 30.0 {
                [p[0] * 1.0, 60.0 - (60.0 - p[1]) * 30.0 / d]
            } else {
                p
            });
        }
        let shallow = deepest_concavity(&bite, 3);
        assert!(shallow > 0.0 && shallow < 0.6 && shallow < JUNCTION_TURN, "{shallow}");
    }

    /// The camera's junction test says what the deepest concave turn says, on random
    /// star-like polygons (radii 10–30 at random steps, either way round) for turns from 0.1
    /// to 3 radians, away from the boundary by float noise.
    #[test]
    fn turns_concave_by_is_the_deepest_turn_reached() {
        let mut rng = crate::test_rng::XorShiftStar(0x7e57);
        let (mut yes, mut no) = (0usize, 0usize);
        for case in 0..200 {
            let n = 12 + rng.below(60) as usize;
            let mut pts: Vec<[f32; 2]> = (0..n)
                .map(|i| {
                    let r = 10.0 + rng.below(2000) as f32 / 100.0;
                    let (s, c) = libm::sincosf(i as f32 * core::f32::consts::TAU / n as f32);
                    [r * c, r * s]
                })
                .collect();
            if case % 2 == 1 {
                pts.reverse();
            }
            let deepest = deepest_concavity(&pts, 3);
            for t in 1..30 {
                let turn = t as f32 / 10.0;
                if (deepest - turn).abs() < 1e-4 {
                    continue;
                }
                let reached = turns_concave_by(&pts, 3, turn);
                assert_eq!(reached, deepest >= turn, "case {case}, turn {turn}, deepest {deepest}");
                if reached {
                    yes += 1;
                } else {
                    no += 1;
                }
            }
        }
        assert!(yes > 500 && no > 500, "{yes} reached, {no} not");
        assert!(!turns_concave_by(&[[0.0, 0.0], [1.0, 0.0]], 3, 0.5));
    }

    /// Blobs of one part the whole-border match leaves unnamed (an ellipse, a bean: no
    /// template) have no junction; an L and a T that touch or lie over one another do, and so
    /// does an L alone (its own inner corner: the rule leaves parts of concave outline to the
    /// search).
    #[test]
    fn junctions_are_where_outlines_meet() {
        let (w, h) = (260usize, 120usize);
        let cases: [(Scene, bool); 5] = [
            (&[(ellipse, 60.0, 60.0, 30.0)], false),
            (&[(bean, 60.0, 60.0, 100.0)], false),
            (&[(ell, 60.0, 60.0, 15.0), (tee, 95.0, 60.0, 0.0)], true),
            (&[(ell, 60.0, 60.0, 0.0), (tee, 88.0, 66.0, 200.0)], true),
            (&[(ell, 60.0, 60.0, 15.0)], true),
        ];
        for (parts, junction) in cases {
            let px = draw(w, h, parts);
            let mut rec = recognizer(true);
            run(&mut rec, &px, w, h);
            let outer: Vec<usize> = (0..rec.store.contours().len())
                .filter(|&i| rec.store.contours().get(i).is_some_and(|c| c.kind == BorderKind::Outer))
                .collect();
            assert_eq!(outer.len(), 1, "{parts:?}");
            assert_eq!(rec.has_junction(outer[0]), junction, "{parts:?}");
        }
    }

    /// The gate never changes what the search finds: scenes of Ls and Ts against and over one
    /// another at random angles, with unknown ellipses and beans beside them or against them,
    /// give the same detections with the gate on and off (every field but the searches), and
    /// the gate leaves the lone unknown parts whole.
    #[test]
    fn the_junction_gate_keeps_every_part_the_search_finds() {
        let mut rng = crate::test_rng::XorShiftStar(0x6a7e);
        let (w, h) = (300usize, 160usize);
        let (mut named, mut touching) = (0usize, 0usize);
        for case in 0..24 {
            let angle = |rng: &mut crate::test_rng::XorShiftStar| rng.below(360) as f32;
            let a: Inside = if rng.below(2) == 0 { ell } else { tee };
            let b: Inside = match rng.below(3) {
                0 => ell,
                1 => tee,
                _ => ellipse,
            };
            // B against A: 26–38 px apart (they touch or overlap), in a random direction.
            let (s, c) = libm::sincosf(angle(&mut rng).to_radians());
            let d = 26.0 + rng.below(13) as f32;
            let lone: Inside = if case % 2 == 0 { ellipse } else { bean };
            let parts = [
                (a, 80.0, 80.0, angle(&mut rng)),
                (b, 80.0 + d * c, 80.0 + d * s, angle(&mut rng)),
                (lone, 230.0, 80.0, angle(&mut rng)),
            ];
            let px = draw(w, h, &parts);
            let on = run(&mut recognizer(true), &px, w, h);
            let off = run(&mut recognizer(false), &px, w, h);
            let key = |r: &crate::recognizer::Report| -> Vec<_> {
                r.detections
                    .iter()
                    .map(|d| {
                        (
                            d.template,
                            d.x.to_bits(),
                            d.y.to_bits(),
                            d.angle_deg.to_bits(),
                            d.touching,
                            d.visible_fraction.to_bits(),
                            d.touches_edge,
                            d.position_from_pose,
                        )
                    })
                    .collect()
            };
            assert_eq!(
                key(&on),
                key(&off),
                "case {case}: {parts:?}\n{:?}\n{:?}",
                on.detections,
                off.detections
            );
            named += on.detections.iter().filter(|d| d.template.is_some()).count();
            touching += on.detections.iter().filter(|d| d.touching).count();
            // The lone unknown part: whole, unknown, not touching.
            assert!(
                on.detections
                    .iter()
                    .any(|d| d.template.is_none() && !d.touching && (d.x - 230.0).abs() < 3.0),
                "case {case}: {:?}",
                on.detections
            );
        }
        // The scenes exercise the search: most parts against another are found.
        assert!(named >= 30 && touching >= 30, "{named} named, {touching} touching");
    }

    /// A template with more holes than the blob is not searched (its fit would need them all);
    /// the templates without holes are.
    #[test]
    fn a_blob_without_holes_is_not_searched_for_a_template_with_one() {
        let (w, h) = (200usize, 120usize);
        let px = draw(w, h, &[(ell, 60.0, 60.0, 15.0), (tee, 95.0, 60.0, 0.0)]);
        let mut rec = recognizer(true);
        let report = run(&mut rec, &px, w, h);
        assert!(
            report.detections.iter().filter(|d| d.template.is_some()).count() >= 2,
            "{:?}",
            report.detections
        );
        let index = (0..rec.store.contours().len())
            .find(|&i| rec.store.contours().get(i).is_some_and(|c| c.kind == BorderKind::Outer))
            .unwrap();
        let border = rec.store.points(index);
        let chain = math::perimeter(border.iter().map(|p| [p.x as f32, p.y as f32]));
        let whole = Detection {
            touches_edge: false,
            area: rec.store.contours()[index].area(),
            ..report.detections[0]
        };
        let least = rec.least_part_area();
        // At the middle of each template's range (and of the mirror image's).
        let middle = [[1u8 << MIDDLE_STEP; 2]; 4];
        let (_, searched, _) = rec.hypotheses(
            index,
            &whole,
            least,
            chain,
            &Holes::new(),
            &[],
            &middle,
            &mut [[0; 2]; 4],
        );
        // The L, its mirror image (it is chiral) and the T; not the ring.
        assert_eq!(searched, 3);
        let mut one = Holes::new();
        one.insert(crate::pose::holes::Hole {
            centre: [60.0, 60.0],
            area: 110.0,
        });
        let (_, searched, _) = rec.hypotheses(index, &whole, least, chain, &one, &[], &middle, &mut [[0; 2]; 4]);
        assert_eq!(searched, 4);
    }

    /// A pin 64 × 16 with an end-hole of radius 4 (50 px², under the tracing's 64): a hole
    /// the mask never keeps.
    fn pin(t: [f32; 2]) -> bool {
        t[0].abs() < 32.0 && t[1].abs() < 8.0 && (t[0] - 24.0).powi(2) + t[1] * t[1] >= 16.0
    }

    /// A pin against an unknown part: its end-hole leaves no hole in the blob, yet the partial
    /// search names it, the right way round (the hole's dip is at the end the pose puts it), and
    /// the pin template is searched at all for a blob without holes.
    #[test]
    fn a_touching_part_is_named_by_a_hole_too_small_for_the_tracing() {
        let (w, h) = (160usize, 120usize);
        let mut rec: std::boxed::Box<Rec> = std::boxed::Box::default();
        rec.set_params(Params {
            touching_parts: true,
            ..Params::DEFAULT
        })
        .unwrap();
        let t = taught(pin);
        assert_eq!(t.holes().len(), 1, "the template keeps its hole");
        rec.add_template(t).unwrap();
        // Both ways round, the ellipse against the pin's long side.
        for deg in [20.0f32, 200.0] {
            let px = draw(w, h, &[(pin, 70.0, 60.0, deg), (ellipse, 70.0, 77.0, 0.0)]);
            let report = run(&mut rec, &px, w, h);
            let named: Vec<_> = report.detections.iter().filter(|d| d.template == Some(0)).collect();
            assert_eq!(named.len(), 1, "{deg}°: {:?}", report.detections);
            let d = named[0];
            assert!(d.touching, "{deg}°: {d:?}");
            let off = (d.angle_deg - deg).rem_euclid(360.0);
            assert!(off.min(360.0 - off) < 3.0, "{deg}°: {d:?}");
            assert!((d.x - 70.0).abs() < 1.5 && (d.y - 60.0).abs() < 1.5, "{deg}°: {d:?}");
        }
    }

    /// The L upside down: the template mirrored left-right, as the contract draws it.
    fn ell_flipped(t: [f32; 2]) -> bool {
        ell([-t[0], t[1]])
    }

    /// An L lying upside down against an unknown part, in one blob: the partial search matches
    /// the mirror image of a chiral template too, and names the L `flipped` at the contract's
    /// angle (the template mirrored, then turned); the same scene with the L the right way up
    /// is not flipped.
    #[test]
    fn a_touching_part_upside_down_is_named_by_the_mirror_image() {
        let (w, h) = (160usize, 120usize);
        let mut rec = recognizer(true);
        for (shape, flipped) in [(ell_flipped as Inside, true), (ell, false)] {
            // The ellipse along the top of the L's bar (the same edge either way up), half a
            // pixel over it.
            let (deg, at) = (25.0f32, [62.0f32, 60.0]);
            let px = draw(
                w,
                h,
                &[(shape, at[0], at[1], deg), (ellipse, at[0] - 7.6, at[1] - 16.3, deg)],
            );
            let report = run(&mut rec, &px, w, h);
            let l = report
                .detections
                .iter()
                .find(|d| d.template == Some(0))
                .unwrap_or_else(|| panic!("flipped {flipped}: no L in {:?}", report.detections));
            assert!(l.touching, "{l:?}");
            assert_eq!(l.flipped, flipped, "{l:?}");
            let off = (l.angle_deg - deg).rem_euclid(360.0);
            assert!(off.min(360.0 - off) < 2.0, "flipped {flipped}: {l:?}");
            assert!(
                (l.x - at[0]).abs() < 1.0 && (l.y - at[1]).abs() < 1.0,
                "flipped {flipped}: {l:?}"
            );
        }
    }
}
