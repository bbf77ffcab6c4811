//! One candidate aligned, verified and judged. The descriptor alone confuses near-similar
//! parts, so each candidate template is aligned on the frame itself from the DP's pose (the
//! part's centroid, the signed angle of the correspondence, the scale of the areas;
//! [`crate::pose::refine`]) and scored: the verification score is the mean of the template →
//! part and part → template distances, each capped and averaged over the nearest
//! [`VERIFY_KEPT`] of its points (a part of one type may differ from its template over a
//! stretch: a head, a burr, the walls a close lens sees), held to a limit that grows with the
//! part's size ([`Params::verify_limit`]).
//!
//! - **Retries.** A near miss ([`NEAR_MISS`]) that is not [`CONFIDENT`] is aligned again with
//!   the outline offset free, and an outline grown beyond the scale range with a wall too
//!   ([`WALL_FACTOR`]); a nearly 2-fold outline is aligned half a turn on too
//!   ([`HALF_TURN_AMBIGUOUS`]), and an outline that nearly repeats at another turn (a rounded
//!   triangle's third) that turn on either way, for a near miss of the DP's family, unless the
//!   fit is far closer than a part that turn off could come ([`NEAR_TURN_EVIDENCE`]); a
//!   template with holes whose holes are not found is aligned once more from the pose its
//!   holes give.
//! - **The decision.** A fit is the part when its score is below its limit — or, for a
//!   template with holes, all found and one off its centre, and the DP's `f' < ε`, below
//!   [`NEAR_MISS`] times it. Fits are ranked by their holes, then their score over its limit;
//!   between a template and its own mirror image the upside-down reading needs clear evidence
//!   ([`FLIP_EVIDENCE`]); between a fit and its half turn whose holes the mask cannot tell
//!   apart (too small to trace: a pin's end-hole), the one whose holes lie on the deeper dips
//!   of `|D|` (`half_turn_by_dips`).
//!
//! Cost: up to five starts a candidate, each aligned once or twice (an alignment is
//! `O(iterations · m · search/step)`), and the part → template distances, `n` queries of an
//! [`Outline`]. Memory: on the stack, `M` distances and the template outline moved by the
//! fitted offset (`12·M` bytes). Guards: a scale outside the template's range scores
//! infinite; a score over a limit that is not a number counts as infinite; a side without
//! distances scores the cap.

use crate::library::template::Template;
use crate::math;
use crate::params::Params;
use crate::pose::holes::{
    agreement, edge_blur, hole_dip, pose_from_holes, shade, size_misfit, solid_where_a_hole_is, HoleAgreement, Holes,
    Sight, HOLE_AREA_RATIO, SHADE_START, SOLID_KEEPS,
};
use crate::pose::refine::{
    align_recording, edge_distances_walled, outward_normal, wall_facing, Alignment, Difference, Outline, Pose,
    RefineParams, VERIFY_KEPT,
};
use crate::recognizer::Recognizer;
use crate::shape::matching::{starts_reach, Match};
// What the doc links name.
#[cfg(doc)]
use crate::recognizer::{FALLBACK_RATIO, NEAR_TIE_RATIO};

impl<const T: usize, const M: usize, const P: usize, const C: usize, const D: usize> Recognizer<T, M, P, C, D> {
    /// Slot `slot`'s template ([`Self::slot_template`]) aligned on the frame from the DP's pose (the part's `position`, the
    /// `signed` angle in degrees, the scale of the areas), and its verification score against
    /// the part's edge (`self.part_edges`) with the score's limit for the aligned part's size,
    /// and which of its holes `part_holes` shows there.
    /// A template whose outline is nearly but not exactly 2-fold ([`Template::half_turn`]
    /// between [`HALF_TURN_SYMMETRIC`] and [`HALF_TURN_AMBIGUOUS`]: a connecting rod) is
    /// aligned half a turn on too, and the better of the two kept ([`Fit::better_than`]: the
    /// holes decide where they can, a rod's two eyes of different size) — unless the first fit
    /// is confident with its holes all found and the DP's match `dp` (its start and cost; `None`
    /// where the DP is no evidence, a part the frame's edge cuts) rules the other way round out
    /// ([`HALF_TURN_DP_RATIO`]). A template whose outline nearly repeats at another turn
    /// ([`Template::near_turn`]: a rounded triangle at about 120°, gap below
    /// [`HALF_TURN_AMBIGUOUS`], and not the same pose there, holes and all) is aligned that turn
    /// on either way too, where the fit so far is of the DP's `family` and a near miss
    /// ([`NEAR_MISS`]), unless it scores below [`NEAR_TURN_EVIDENCE`] of the template's own
    /// score at that turn.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn align_and_verify<B: AsRef<[u8]>>(
        &self,
        n: usize,
        position: [f32; 2],
        signed: f32,
        area: f32,
        slot: usize,
        family: bool,
        dp: Option<Match>,
        part_holes: &Holes,
        diff: &Difference<'_, B>,
        refine_params: &RefineParams,
    ) -> Option<Fit> {
        let t = self.slot_template(slot)?;
        let params = &self.params;
        let part_edges = self.part_edges.get(..n).unwrap_or(&[]);
        let seed = seed_pose(position, signed, area, t);
        let limit_at = |scale: f32| params.verify_limit(t.size() * scale) * t.tolerance().verify;
        // The alignment gives up at the limit for the seed's size, at least the caller's
        // (unless the caller never gives up).
        // The distance cap grows with the limit (a large part's edge may lie farther from its
        // template's than a small one's and still be the same part); the profiles keep their
        // length, which thin rings and slots need. Both take a narrowed class's limit at the
        // parameters' own (`Tolerance::search_verify`).
        let limit = params.verify_limit(t.size() * seed.scale) * t.tolerance().search_verify();
        let reach = limit / params.verify_threshold.max(f32::MIN_POSITIVE);
        let reach = if reach.is_finite() { reach.max(1.0) } else { 1.0 };
        let rp = RefineParams {
            give_up: if refine_params.give_up.is_finite() {
                refine_params.give_up.max(limit)
            } else {
                f32::INFINITY
            },
            cap: refine_params.cap * reach,
            ..*refine_params
        };
        // Without an outline offset first; a near miss that is not CONFIDENT is aligned again
        // from where it ended with the offset free (walls, blur), and the better kept.
        // The walls of a thick part under a close lens show on its side towards the principal
        // point (taken at the frame's centre), up to WALL_FACTOR times the offset's limit.
        let offset_max = params.offset_relative * t.size() * seed.scale;
        let principal = [(diff.width() as f32 - 1.0) * 0.5, (diff.height() as f32 - 1.0) * 0.5];
        let (ux, uy) = (principal[0] - position[0], principal[1] - position[1]);
        let far = math::hypot(ux, uy);
        let wall_toward = if far >= 1.0 { [ux / far, uy / far] } else { [0.0, 0.0] };
        let with_offset = RefineParams {
            offset_max,
            wall_max: WALL_FACTOR * offset_max,
            wall_toward,
            ..rp
        };
        let once = |s: Pose, retry_allowed: bool| {
            let mut distances = [0.0f32; M];
            #[cfg(test)]
            ALIGNMENTS.with(|a| a.set(a.get() + 1));
            let aligned = align_recording(diff, t.edge(), t.normals(), s, &rp, &mut distances);
            let (verify, full) = verify_score(&aligned, &mut distances, t, part_edges, diff, &rp, params);
            let fit = |pose: Pose, (verify, full): (f32, f32), wall: f32| Fit {
                pose,
                verify,
                full,
                limit: limit_at(pose.scale),
                holes: agreement(t.holes(), &pose, part_holes),
                family,
                wall,
                // (A fit with a wall: the walls may hide a hole; its veto is left out. A fit
                // NEAR_MISS times its limit or more is not accepted anyway.)
                solid_hole: wall == 0.0
                    && verify < NEAR_MISS * limit_at(pose.scale)
                    && solid_where_a_hole_is(
                        t.holes(),
                        &pose,
                        part_holes,
                        // The widest wall the alignment admits (WALL_FACTOR times the offset's
                        // limit) may close a hole of half that radius, and narrow one of up to
                        // it; the part's own shadow, read to twice the hole's radius beside it,
                        // may fill one.
                        &Sight {
                            hidden: WALL_FACTOR * params.offset_relative * t.size() * pose.scale,
                            filter: params.filter(),
                        },
                        || self.part_blur(part_edges, diff),
                        |x, y| diff.bilinear(x, y),
                        |x, y| in_frame(diff, x, y),
                        |sign, r| {
                            shade(
                                t.edge()
                                    .iter()
                                    .zip(t.normals())
                                    .map(|(p, n)| (pose.apply(*p), pose.rotate(*n))),
                                t.edge().len(),
                                SHADE_START + 2.0 * r,
                                |x, y| sign * diff.bilinear(x, y),
                            )
                        },
                    ),
            };
            let first = fit(aligned.pose, (verify, full), 0.0);
            let near_miss = verify < NEAR_MISS * first.limit;
            // A scale just beyond the range may be the outline grown by walls or blur, which
            // the offset and the wall explain instead — for a template of the DP's family
            // (`f' < ε`) and a part whose area did grow beyond the range, even where the first
            // alignment gave up on it.
            let (_, hi) = t.tolerance().scale_range(params.scale_min, params.scale_max);
            let grown = family
                && verify.is_infinite()
                && area > hi * hi * t.area()
                && aligned.pose.scale > hi
                && aligned.pose.scale <= hi * self.grown_max();
            if !retry_allowed
                || verify < CONFIDENT * first.limit
                || !(near_miss || grown)
                || !(with_offset.offset_max > 0.0)
                || (aligned.gave_up && !grown)
            {
                return first;
            }
            // Grown: from the range's end, so the wall and the offset take up the growth rather
            // than the scale that did.
            let start = if grown {
                Pose {
                    scale: hi,
                    ..aligned.pose
                }
            } else {
                aligned.pose
            };
            // The wall only where the outline grew beyond the range: a near miss within it is
            // a part's own variation, which the offset alone takes up.
            let retry = if grown {
                with_offset
            } else {
                RefineParams {
                    wall_max: 0.0,
                    ..with_offset
                }
            };
            let again = align_recording(diff, t.edge(), t.normals(), start, &retry, &mut distances);
            let scores = verify_score(&again, &mut distances, t, part_edges, diff, &retry, params);
            let second = fit(again.pose, scores, again.wall);
            if second.ratio() < first.ratio() {
                second
            } else {
                first
            }
        };
        let mut best = once(seed_pose(position, signed, area, t), true);
        // Once a fit is CONFIDENT with its holes all found, an alternative pose is aligned once,
        // without the retry that rescues near misses: a near miss could beat it only by a
        // score below the confident one's, which the retry's freedom does not bring.
        let settled = |f: &Fit| f.verify < CONFIDENT * f.limit && f.holes.all_found();
        // A 2-fold symmetric outline (a gear of even teeth, a washer) is the same half a turn on,
        // unless its holes say otherwise (a bar with one eye at one end).
        let symmetric = t.half_turn() < HALF_TURN_SYMMETRIC;
        // Holes that differ half a turn on (a large and a small hole on the axis) tell the ends
        // of a symmetric outline apart, also where both ways find them all (a hole may be
        // [`crate::pose::holes::HOLE_AREA_RATIO`] off in area): the half turn is tried, and
        // the hole sizes decide where they differ by more than a hole may be off
        // ([`size_misfit`], scale-free: a real rod's walls and the blur grow its eyes alike).
        let holes_tell = !t.holes_repeat_half_turn();
        // (Not when the fit leaves no doubt and the DP ruled the other way round out; the DP
        // cannot rule out the half turn of a symmetric outline whose holes tell it.)
        let ruled_out = |best: &Fit| {
            !(symmetric && holes_tell) && settled(best) && dp.is_some_and(|m| self.half_turn_ruled_out(n, t, m))
        };
        if t.half_turn() < HALF_TURN_AMBIGUOUS
            && (!symmetric || !best.holes.all_found() || holes_tell)
            && !ruled_out(&best)
        {
            let second = once(seed_pose(position, signed + 180.0, area, t), !settled(&best));
            // (Sizes within the area ratio a hole may be off by are no evidence.)
            let by_sizes = (holes_tell
                && accepted(best)
                && accepted(second)
                && best.holes.all_found()
                && second.holes.all_found())
            .then(|| size_misfit(t.holes(), &second.pose, part_holes) - size_misfit(t.holes(), &best.pose, part_holes))
            .filter(|gap| gap.abs() > math::ln(HOLE_AREA_RATIO))
            .map(|gap| gap < 0.0);
            let by_dips = || half_turn_by_dips(t, &best, &second, diff);
            if by_sizes
                .or_else(by_dips)
                .unwrap_or_else(|| second.beats_half_turn(&best, t.holes().is_empty()))
            {
                best = second;
            }
        }
        // An outline that nearly repeats at a turn other than half a turn (a rounded triangle at
        // 120°) is aligned that turn on either way too — unless it repeats there with its holes
        // (the same pose), the fit is far closer than the template turned by it comes to
        // itself ([`NEAR_TURN_EVIDENCE`]: a part that turn off could not fit so well), or the
        // fit is no near miss ([`NEAR_MISS`]). Only in the DP's family (`f' < ε`): outside it
        // the DP's correspondence is no evidence of a turn.
        let near = t.near_turn();
        let repeats = near.gap < HALF_TURN_SYMMETRIC && near.holes_repeat;
        if family && near.gap < HALF_TURN_AMBIGUOUS && !repeats {
            for turn in [near.turn_deg, -near.turn_deg] {
                // (A fit that is no near miss is of another part, or of several touching: the
                // DP's correspondence is no evidence of a turn there.)
                let turned_score = near.score * t.size() * best.pose.scale;
                if best.verify < NEAR_TURN_EVIDENCE * turned_score || !(best.verify < NEAR_MISS * best.limit) {
                    break;
                }
                let second = once(seed_pose(position, signed + turn, area, t), !settled(&best));
                if second.beats_half_turn(&best, t.holes().is_empty()) {
                    best = second;
                }
            }
        }
        // Holes that are not where the outline's pose puts them, or a pose that does not
        // verify: the outline may have pulled the pose off (a part whose outline departs from
        // its template's); a template with two or more holes is aligned once more from the
        // pose its two largest holes give.
        if !best.holes.all_found() || !accepted(best) {
            if let Some(seed) = pose_from_holes(t.holes(), part_holes) {
                let third = once(seed, !settled(&best));
                if third.better_than(&best) {
                    best = third;
                }
            }
        }
        Some(best)
    }

    /// Whether the DP's match `m` of template `t` rules out the correspondence half a turn on:
    /// every start within `m_t/24` (at least 2) of half the template's `m_t` points on from
    /// `m`'s costs [`HALF_TURN_DP_RATIO`] times `m`'s cost or more ([`starts_reach`], each
    /// start's DP abandoned at that cost; a match of cost 0 rules nothing out).
    fn half_turn_ruled_out(&self, n: usize, t: &Template<M>, m: Match) -> bool {
        let (Some(part), td) = (self.descriptor.get(..n), t.descriptor()) else {
            return false;
        };
        if !(m.cost > 0.0) {
            return false;
        }
        let mt = td.len();
        let mut row = [0.0f32; M];
        starts_reach(
            part,
            td,
            m.start + mt / 2,
            (mt / 24).max(2),
            HALF_TURN_DP_RATIO * m.cost,
            &mut row,
        )
        .unwrap_or(false)
    }

    /// The blur of the part's edge, σ px ([`edge_blur`] across `part_edges`, the part's sub-pixel
    /// edge points), measured the first time a verification of this part asks for it.
    fn part_blur<B: AsRef<[u8]>>(&self, part_edges: &[[f32; 2]], diff: &Difference<'_, B>) -> Option<f32> {
        if let Some(known) = self.part_blur.get() {
            return known;
        }
        let blur = edge_blur(across(part_edges), part_edges.len(), |x, y| diff.bilinear(x, y).abs());
        self.part_blur.set(Some(blur));
        blur
    }

    /// How far beyond the scale range's end an outline grown by walls may be and still be
    /// aligned with the wall model: `1 + 2 · offset_relative · (1 + WALL_FACTOR)` (the offset
    /// and the wall, each on both sides).
    pub(super) fn grown_max(&self) -> f32 {
        1.0 + 2.0 * self.params.offset_relative * (1.0 + WALL_FACTOR)
    }
}

/// One candidate's alignment: the aligned pose, its verification score and the score's limit
/// (px), which of the template's holes the part shows there, and whether the DP puts the part
/// in the template's family (the paper's decision, `f' < ε`, eq. 5.2).
#[derive(Debug, Clone, Copy)]
pub(super) struct Fit {
    pub(super) pose: Pose,
    pub(super) verify: f32,
    /// The verification's distances over every point, none left out, px.
    pub(super) full: f32,
    pub(super) limit: f32,
    pub(super) holes: HoleAgreement,
    pub(super) family: bool,
    /// The wall the alignment fitted, px (0 without one).
    pub(super) wall: f32,
    /// A template hole the part shows no trace of ([`solid_where_a_hole_is`]): a veto.
    pub(super) solid_hole: bool,
}

impl Fit {
    /// The score over its limit (the same meaning for every size; NaN counts as infinite).
    fn ratio(&self) -> f32 {
        let r = self.verify / self.limit;
        if r.is_nan() {
            f32::INFINITY
        } else {
            r
        }
    }

    /// Whether this fit beats `other` for the same part: one that is [`accepted`] beats one
    /// that is not; of two accepted, the one with fewer of its template's holes missing, then
    /// the one whose template's holes explain more of the part's (a rod with two eyes is the
    /// two-eyed template's, even when the one-eyed template's outline fits it as well), then
    /// the lower [`Self::ratio`]; of two that are not, one with a finite score, then one
    /// whose template's holes are all found, then the lower ratio.
    fn better_than(&self, other: &Fit) -> bool {
        let (a, b) = (accepted(*self), accepted(*other));
        if a != b {
            return a;
        }
        let (h, g) = (self.holes, other.holes);
        if a && h.missing() != g.missing() {
            return h.missing() < g.missing();
        }
        if a && h.found != g.found {
            return h.found > g.found;
        }
        // Of two accepted, one without a wall (the simpler model).
        if a && (self.wall > 0.0) != (other.wall > 0.0) {
            return self.wall == 0.0;
        }
        // Of two not accepted: one that could be verified at all, then one whose holes are
        // all found (an alignment that ran off the part finds holes by chance).
        let (fa, fb) = (self.ratio().is_finite(), other.ratio().is_finite());
        if !a && fa != fb {
            return fa;
        }
        if !a && h.all_found() != g.all_found() {
            return h.all_found();
        }
        self.ratio() < other.ratio()
    }
}

impl Fit {
    /// Whether this fit beats `other`, the same template's fit half a turn away:
    /// [`Self::better_than`] — except, for a template without holes (`holeless`), that of two
    /// accepted fits the lower mean distance over every point ([`Fit::full`]) wins. A nearly
    /// 2-fold outline (a bolt, a screw) differs from its half turn only over a stretch (the
    /// head), which the verification's trimmed score leaves out, as between a template and its
    /// mirror image ([`Self::beats`]). Where the template has holes (a connecting rod's eyes)
    /// they tell the ends apart, and the trimmed score keeps a part of one type that departs
    /// from its template over a head from losing to its own half turn.
    fn beats_half_turn(&self, other: &Fit, holeless: bool) -> bool {
        if holeless && accepted(*self) && accepted(*other) {
            // (NaN never wins.)
            return self.full < other.full;
        }
        self.better_than(other)
    }

    /// Whether this fit, of candidate slot `slot`, beats `other`, of slot `other_slot`
    /// (the candidate scan's slots): [`Self::better_than`] — except between a template and its
    /// own mirror image: then the upside-down reading needs clear evidence, a mean distance
    /// over every point ([`Fit::full`]: a nearly mirror-symmetric part differs from its mirror
    /// image only over a stretch, which the verification's trimmed score leaves out) below
    /// [`FLIP_EVIDENCE`] times the other's, whatever the holes and the DP's family say (they
    /// follow the same outline). A part whose mirror axis the template nearly has (a real
    /// part photographed for its template, with its walls and variation) fits both alike, and
    /// is not flipped.
    pub(super) fn beats(&self, slot: usize, other: &Fit, other_slot: usize) -> bool {
        if slot ^ 1 == other_slot {
            let (flipped, plain) = if slot % 2 == 1 { (self, other) } else { (other, self) };
            // (An infinite plain mean loses to any finite one; NaN never wins.)
            let flip_wins = flipped.full.is_finite() && flipped.full < FLIP_EVIDENCE * plain.full;
            return flip_wins == (slot % 2 == 1);
        }
        self.better_than(other)
    }
}

/// Whether `(x, y)` lies on the frame's pixels, where `diff` samples the frame itself rather
/// than its clamped edge (what the hole tests may read).
pub(super) fn in_frame<B: AsRef<[u8]>>(diff: &Difference<'_, B>, x: f32, y: f32) -> bool {
    let (w, h) = (diff.width() as f32, diff.height() as f32);
    x >= 0.0 && y >= 0.0 && x <= w - 1.0 && y <= h - 1.0
}

/// Between a fit and its half turn whose holes the mask does not tell apart (both accepted,
/// as many of the template's holes found, not all): `Some(true)` when the half turn's holes
/// lie on dips of `|D|` deeper by more than a quarter of the part's face than the fit's
/// ([`hole_dip`]; a quarter gone is the least dip that a hole the blur nearly closes still
/// shows, [`SOLID_KEEPS`]), `Some(false)` the other way round, `None` (the outline decides)
/// otherwise. A pin's end-hole too small for the tracing still shows as a dip, at its end only.
fn half_turn_by_dips<const M: usize, B: AsRef<[u8]>>(
    t: &Template<M>,
    first: &Fit,
    second: &Fit,
    diff: &Difference<'_, B>,
) -> Option<bool> {
    let (a, b) = (first.holes, second.holes);
    if t.holes().is_empty() || !accepted(*first) || !accepted(*second) || a.found != b.found || a.all_found() {
        return None;
    }
    let dip = |f: &Fit| {
        hole_dip(
            t.holes(),
            &f.pose,
            |x, y| diff.bilinear(x, y),
            |x, y| in_frame(diff, x, y),
        )
    };
    let (d1, d2) = (dip(first)?, dip(second)?);
    let evidence = 1.0 - SOLID_KEEPS;
    if d2 < d1 - evidence {
        Some(true)
    } else if d1 < d2 - evidence {
        Some(false)
    } else {
        None
    }
}

/// Whether an aligned candidate is the part: its verification score is below its limit — or,
/// for a template with holes, all of them found where the pose puts them, at least one of them
/// off its centre ([`HoleAgreement::off_centre`]: a central hole fits a washer, a bore, a
/// triangle with a hole, and says nothing of the part's ends), and the DP's `f' < ε`, below
/// [`NEAR_MISS`] times its limit (not for a fit with a wall, [`WALL_FACTOR`]). The holes and the
/// DP's family are two cues the rigid
/// outline fit lacks: a part of one type may depart from its template's outline over a shaft
/// or a head (real rods), and a distractor that fits the outline that loosely does not also
/// have the template's descriptor profile and its holes in place.
///
/// A template hole that the part shows no trace of ([`Fit::solid_hole`]: resolvable at the
/// part's scale, wider than the widest wall the alignment admits, no part hole near where it
/// should be, and either the difference there as high as on the face around it, or the hole
/// so wide against the blur of the part's edge that the mask would show it) vetoes the fit,
/// however well the outline verifies: a smooth blob is not a cam without its bore, nor a solid
/// nut with a label where the bore should be. A hole that is merely not found (it closed in
/// the mask under blur, or a close lens's walls shrink and move it) still leaves a dip in the
/// difference and does not veto; it ranks the candidates ([`Fit::better_than`]).
pub(super) fn accepted(fit: Fit) -> bool {
    if fit.solid_hole {
        return false;
    }
    let r = fit.ratio();
    // A fit that took a wall to get there has used its freedom: the outline alone decides.
    r < 1.0 || (fit.wall == 0.0 && fit.family && fit.holes.off_centre > 0 && fit.holes.all_found() && r < NEAR_MISS)
}

/// Each point of a closed outline (NaN where it has none: left out) with the unit normal of the
/// chord between its neighbours ([`outward_normal`]; which side is out does not matter here).
fn across(outline: &[[f32; 2]]) -> impl Iterator<Item = ([f32; 2], [f32; 2])> + '_ {
    outline.iter().enumerate().filter_map(|(k, &p)| {
        let n = outward_normal(outline, k, false).filter(|_| p[0].is_finite())?;
        Some((p, n))
    })
}

/// The alignment's start: the part's centroid, the DP's signed angle (degrees), the scale of the
/// areas.
fn seed_pose<const M: usize>(position: [f32; 2], angle_deg: f32, area: f32, t: &Template<M>) -> Pose {
    Pose {
        x: position[0],
        y: position[1],
        angle: math::radians(angle_deg),
        scale: if t.area() > 0.0 {
            math::sqrt(area / t.area())
        } else {
            1.0
        },
    }
}

/// Verification score of an alignment, px: the mean of the template → part and part → template
/// distances (capped), each over the nearest [`VERIFY_KEPT`] of its points (a part of one type
/// may differ from its template over a stretch of its outline: a head, a burr, the walls a
/// close lens sees); infinite for a scale outside `[scale_min, scale_max]`.
/// `distances` holds the template → part distances that the alignment recorded
/// ([`align_recording`]; measured again here when it gave up) and is scratch afterwards.
/// Also returns the same mean over every point, none left out (what tells a part upside down
/// from one the right way up, where they differ only over a stretch: [`Fit::beats`]).
#[allow(clippy::too_many_arguments)]
fn verify_score<const M: usize, B: AsRef<[u8]>>(
    a: &Alignment,
    distances: &mut [f32; M],
    t: &Template<M>,
    part_edges: &[[f32; 2]],
    diff: &Difference<'_, B>,
    params: &RefineParams,
    limits: &Params,
) -> (f32, f32) {
    let edge = t.edge();
    let pose = a.pose;
    let (lo, hi) = t.tolerance().scale_range(limits.scale_min, limits.scale_max);
    if !(pose.scale >= lo && pose.scale <= hi) {
        return (f32::INFINITY, f32::INFINITY);
    }
    let dist = distances;
    let mean = |d: &[f32]| {
        if d.is_empty() {
            params.cap
        } else {
            d.iter().sum::<f32>() / d.len() as f32
        }
    };
    let (there, there_all) = {
        let d = dist.get_mut(..edge.len()).unwrap_or(&mut []);
        if a.gave_up {
            edge_distances_walled(diff, edge, t.normals(), pose, a.offset, a.wall, params, d);
        }
        let all = mean(d);
        (trimmed_mean(d, VERIFY_KEPT, params.cap), all)
    };
    let valid = part_edges.iter().filter(|e| e[0].is_finite()).count();
    let (back, back_all) = if valid == 0 {
        (params.cap, params.cap)
    } else {
        // Distances are measured in the template's frame (the part's edge mapped back by the
        // pose) and scaled back, so the template outline needs no mapping.
        let scale = pose.scale;
        let cap = params.cap / scale;
        // The template's outline moved by the fitted offset (in its own frame: over the scale;
        // the buffer set only where it is used).
        let mut moved: [[f32; 2]; M];
        let sc = math::sin_cos(pose.angle);
        let edge = if a.offset == 0.0 && a.wall == 0.0 {
            edge
        } else {
            moved = [[0.0f32; 2]; M];
            let toward = params.wall_toward;
            let (s, c) = sc;
            for ((slot, e), nrm) in moved.iter_mut().zip(edge).zip(t.normals()) {
                // The wall on the side whose (frame) normal faces the principal point.
                let facing = if a.wall == 0.0 {
                    0.0
                } else {
                    wall_facing([nrm[0] * c + nrm[1] * s, -nrm[0] * s + nrm[1] * c], toward)
                };
                let o = (a.offset + a.wall * facing) / scale;
                *slot = [e[0] + o * nrm[0], e[1] + o * nrm[1]];
            }
            moved.get(..edge.len()).unwrap_or(edge)
        };
        let outline = Outline::new(edge);
        for (e, d) in part_edges.iter().zip(dist.iter_mut()) {
            *d = match pose.invert_sc(sc, *e).filter(|_| e[0].is_finite() && cap.is_finite()) {
                Some(q) => scale * outline.capped_distance(q, cap),
                None => params.cap,
            };
        }
        let d = dist.get_mut(..part_edges.len()).unwrap_or(&mut []);
        let all = mean(d);
        (trimmed_mean(d, VERIFY_KEPT, params.cap), all)
    };
    (0.5 * (there + back), 0.5 * (there_all + back_all))
}

/// The mean of the smallest `kept` fraction of `values` (at least one; `empty` for none): the
/// values below the `keep`-th smallest, and that one for the rest ([`math::select_nth`], which
/// reorders `values`).
fn trimmed_mean(values: &mut [f32], kept: f32, empty: f32) -> f32 {
    let len = values.len();
    if len == 0 {
        return empty;
    }
    let keep = ((len as f32 * kept) as usize).clamp(1, len);
    let Some(t) = math::select_nth(values, keep - 1) else {
        return empty;
    };
    let (mut sum, mut below) = (0.0f32, 0usize);
    for &v in values.iter() {
        if v < t {
            sum += v;
            below += 1;
        }
    }
    (sum + (keep.saturating_sub(below)) as f32 * t) / keep as f32
}

/// A candidate whose score is below this fraction of its limit (with its holes found, and no
/// hole of the part's left unexplained) ends the candidate scan: the first candidate at once,
/// a later one at the cost records (the right template of a generated set's part scores 0.1–0.4
/// of it); above, the scan goes on within [`NEAR_TIE_RATIO`], then [`FALLBACK_RATIO`].
pub const CONFIDENT: f32 = 0.5;

/// A candidate whose score is below this multiple of its limit is a near miss: only then does
/// the alignment try the outline offset, and the candidate scan go on (a part far from every
/// template so far, such as a distractor, is not searched further; on the generated sets their
/// scores are 2.6× their limit and more, the real rods' right templates 0.5–2.2×).
pub const NEAR_MISS: f32 = 2.5;

/// How much closer than the template itself its mirror image must fit a part for the part to
/// be reported upside down: the ratio of their mean distances over every point. A part that
/// lies upside down fits the mirror image at the noise's level and the template by the
/// stretch where the two differ; a mirror-symmetric part whose template is not quite (a real
/// rod) fits both alike.
pub const FLIP_EVIDENCE: f32 = 0.5;

/// Largest wall the second alignment may fit, as a multiple of its offset's limit
/// ([`Params::offset_relative`]): a close lens over a thick part shows its walls up to about a
/// fifth of the part's size on the side towards the principal point.
pub const WALL_FACTOR: f32 = 4.0;

/// A fitted wall above this (px) makes the part's position its pose's (its top face's).
pub const WALL_SIGNIFICANT: f32 = 0.5;

/// [`Template::half_turn`] below which the outline counts as nearly 2-fold: the DP's
/// correspondence may then be half a turn off, and both are aligned.
pub const HALF_TURN_AMBIGUOUS: f32 = 0.2;

/// The fraction of the score a part aligned a near turn off would get (the template's
/// [`crate::library::template::NearTurn::score`] at the fit's size) below which a fit rules
/// that turn out without aligning it: half, where the alignment's freedom of position and scale
/// may bring a turned part's score under the template's own at a fixed centre.
pub const NEAR_TURN_EVIDENCE: f32 = 0.5;

/// [`Template::half_turn`] below which the outline is 2-fold symmetric: half a turn on is the
/// same pose, and it is not aligned twice.
pub const HALF_TURN_SYMMETRIC: f32 = 0.01;

/// The factor over the DP cost of its match that every correspondence half a turn on (every
/// start within `m/24`, at least 2, of half the template's `m` points on from the match's) must
/// cost at least for a confident fit, its holes all found, to keep its side without an
/// alignment the other way round. Over the 28 sets of `docs/accuracy.md` (1 979 half-turn
/// alignments, 244 of them better than the first) the half-turned fit never won where those
/// starts cost more than 1.8 times the DP's when the first fit was confident, nor more than 3.5
/// times otherwise.
pub const HALF_TURN_DP_RATIO: f32 = 4.0;

#[cfg(test)]
extern crate std;

#[cfg(test)]
std::thread_local! {
    /// Alignments run on this thread (for the tests' work counts).
    pub(crate) static ALIGNMENTS: core::cell::Cell<usize> = const { core::cell::Cell::new(0) };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recognizer::tests::{pin_inside, scene_of, taught};
    use crate::Frame;

    /// A pin's end-hole, too small for the tracing (38 px² under `min_area`), tells its ends
    /// apart by the dip of `|D|` where the template's hole lies; where the two turns' holes are
    /// told apart by the mask, or neither fit is accepted, the dips do not decide.
    #[test]
    fn the_turn_whose_hole_lies_on_the_dip_is_the_pins() {
        let (w, h) = (120usize, 60usize);
        let t = taught(pin_inside);
        assert_eq!(t.holes().as_slice().len(), 1);
        let px = scene_of(w, h, &[(pin_inside, 60.0, 30.0, 0.0, false)]);
        let bg = std::vec![200u8; w * h];
        let frame = Frame::new_checked(&px[..], w, h).unwrap();
        let diff = Difference::new(&frame, &bg, crate::pixels::enhance::Alpha::ONE);
        let fit = |angle: f32| Fit {
            pose: Pose {
                x: 60.0,
                y: 30.0,
                angle,
                scale: 1.0,
            },
            verify: 0.3,
            full: 0.3,
            limit: 1.0,
            holes: HoleAgreement {
                expected: 1,
                found: 0,
                matched: 0,
                off_centre: 0,
            },
            family: true,
            wall: 0.0,
            solid_hole: false,
        };
        // At angle 0 the template's hole lies on the drawn one; half a turn on, on the bar.
        let (right, turned) = (fit(0.0), fit(core::f32::consts::PI));
        assert_eq!(half_turn_by_dips(&t, &turned, &right, &diff), Some(true));
        assert_eq!(half_turn_by_dips(&t, &right, &turned, &diff), Some(false));
        let found = HoleAgreement {
            found: 1,
            matched: 1,
            ..right.holes
        };
        assert_eq!(
            half_turn_by_dips(
                &t,
                &Fit { holes: found, ..turned },
                &Fit { holes: found, ..right },
                &diff
            ),
            None
        );
        let off = Fit { verify: 3.0, ..right };
        assert_eq!(half_turn_by_dips(&t, &turned, &off, &diff), None);
    }
}
