//! The candidate scan of `refine = Verify`: which templates a part is aligned and verified
//! against, in which order, and when the scan ends. The templates are taken in ascending order
//! of their sorted-value bound ([`sorted_lower_bound`], computed only for the templates that
//! could come next, behind the cheaper [`sorted_window_bound`]); each is searched by the cyclic
//! DP ([`best_match`]) bounded by `candidate_ratio` times the lowest cost found before it, and
//! one that comes in is a candidate (at most `candidates`, ≤ [`MAX_CANDIDATES`]), aligned on
//! the frame and verified (`verdict.rs`). The bound order puts the right template first for
//! nearly every part, so a known part usually costs one search and one alignment; a template
//! whose bound rules it out costs no search at all.
//!
//! - **Wider passes.** When no candidate verified well (the descriptor may rank a near-alike
//!   template first), the scan starts again without the candidates tried, within
//!   [`NEAR_TIE_RATIO`] of the lowest cost, then [`FALLBACK_RATIO`]; a confident first
//!   candidate ends it.
//! - **The part's family** ([`UNVERIFIED_FAMILY`]). A whole part is no template's at
//!   `f′ ≥ 2ε`: a first candidate that far off ends the scan unaligned (the part unknown, its
//!   nearest template reported), and no later search of any pass goes beyond that cost. A part
//!   the frame's edge cuts, a class taught from several examples and `candidate_ratio = inf`
//!   are exempt.
//! - **Sizes.** A whole part is not searched against a template whose scale from the areas
//!   lies outside the template's range ([`SCALE_SLACK`]).
//! - **Mirror images.** Each chiral template has a second slot for its mirror image (a part
//!   upside down), with the same bounds, built on demand into the recognizer's one scratch
//!   template; it comes in only below [`MIRROR_GAIN`] of its template's cost, is held against
//!   its template, and an accepted fit that is doubtful ([`STRETCH_OFF`]) has its other side
//!   aligned too.
//! - **The paper's path** takes the same scan with ratio 1 and no limit: exactly the DP's best
//!   template, as searching every one.
//!
//! Cost: an `O(n)` window bound per template, an `O(n·(m − n + 1))` exact bound for the
//! templates that could come next, one DP search per template searched. Memory: the scan's
//! state on the stack (the part's sorted descriptor, `M` values, and seven values per template
//! and side: about `4·M + 28·T` bytes) and the fits tried (at most `2·`[`MAX_CANDIDATES`]); the
//! DP works in the recognizer's table (`D` cells). Guards: a template without a bound (lengths
//! that do not fit, NaN) is left out of the scan; the passes, the candidates and the searches
//! are bounded by the templates (`2·T` slots, each searched at most once a pass).

use crate::library::template::Tolerance;
use crate::params::MAX_CANDIDATES;
use crate::pose::holes::{Holes, MIN_HOLE_FRACTION};
use crate::pose::refine::{Difference, RefineParams};
use crate::recognizer::report::Detection;
use crate::recognizer::verdict::{accepted, Fit, CONFIDENT, NEAR_MISS};
use crate::recognizer::Recognizer;
use crate::shape::matching::{best_match, sorted_lower_bound, sorted_window_bound, Match};

impl<const T: usize, const M: usize, const P: usize, const C: usize, const D: usize> Recognizer<T, M, P, C, D> {
    /// `refine = Verify`: the candidates of [`Self::next_candidate`], each aligned on the
    /// frame from its DP pose and verified. Fills the detection's DP fields and `verify` from
    /// the best fit ([`Fit::better_than`]); returns its template index and fit (`None` without
    /// a candidate).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn verify_candidates<B: AsRef<[u8]>>(
        &mut self,
        n: usize,
        centroid: [f32; 2],
        position: [f32; 2],
        area: f32,
        counter_clockwise: bool,
        part_holes: &Holes,
        diff: &Difference<'_, B>,
        refine_params: &RefineParams,
        detection: &mut Detection,
    ) -> Option<(usize, Fit)> {
        let params = self.params;
        let k = params.candidates.clamp(1, MAX_CANDIDATES);
        let whole = !detection.touches_edge;
        // A part cut by the frame's edge shows too little to tell its sides apart.
        let mut scan = self.candidate_scan(n, whole);
        // A whole part is no template's at `f′ ≥ 2ε` (UNVERIFIED_FAMILY): no later search of
        // any pass goes beyond that cost, and a first candidate that far off ends the scan.
        if whole {
            scan.cap = UNVERIFIED_FAMILY * params.epsilon * n as f32;
            let tolerant = self.templates.iter().any(|t| t.tolerance() != Tolerance::NONE);
            scan.walk_cap = if tolerant { f32::INFINITY } else { scan.cap };
            self.leave_out_by_size(&mut scan, area);
        }
        let significant_holes = part_holes
            .as_slice()
            .iter()
            .filter(|h| h.area >= MIN_HOLE_FRACTION * area)
            .count();
        // Confident: well within the limit, every template hole found, and no hole of the
        // part's size left that another template might have.
        let confident = |d: &Detection| {
            d.verify < CONFIDENT * d.verify_limit
                && d.holes.all_found()
                && usize::from(d.holes.found) >= significant_holes
        };
        let mut best = Tried::default();
        let mut edges = false;
        // The cost records of the bound order first (a first one that is confident ends the
        // scan); unless one of them verified with a score below CONFIDENT times its limit, one
        // more candidate (a real part's descriptor may rank its template behind a near-alike
        // one, which then verifies, but less well) — when the best so far is a NEAR_MISS, or
        // could not be verified at all (no candidate, or a scale out of range): the next
        // template of the bound order within NEAR_TIE_RATIO of the lowest cost, or without
        // one, within FALLBACK_RATIO.
        let mut ratio = params.candidate_ratio;
        let mut limit = k;
        loop {
            let Some((mut slot, mut m)) = self.next_candidate(&mut scan, n, limit, ratio) else {
                let near_miss = detection.verify < NEAR_MISS * detection.verify_limit;
                let confident = confident(detection);
                // The near ties' pass first; the wider one when that found none (it stopped
                // below its limit).
                let wider = if ratio < NEAR_TIE_RATIO {
                    Some(NEAR_TIE_RATIO)
                } else if ratio < FALLBACK_RATIO && (ratio != NEAR_TIE_RATIO || scan.found < limit) {
                    Some(FALLBACK_RATIO)
                } else {
                    None
                };
                if let Some(wider) =
                    wider.filter(|_| scan.found < k && !confident && (near_miss || !detection.verify.is_finite()))
                {
                    // Again from the start of the bound order, without the candidates tried.
                    ratio = wider;
                    // One more candidate, the next of the bound order within the ratio.
                    limit = scan.found + 1;
                    scan.reopen();
                    if whole {
                        self.leave_out_by_size(&mut scan, area);
                    }
                    continue;
                }
                break;
            };
            // A first candidate at `f′ ≥ 2ε` (UNVERIFIED_FAMILY) that is a chiral template: its
            // mirror image shares its bounds and comes after it, so a part upside down whose
            // template's turns all lie that far (a hook) would end the scan before the mirror
            // image was searched. It is searched now, within the family's cap, and a match takes
            // the template's place.
            let twin = slot ^ 1;
            // The template's own angles, taken before the mirror's search overwrites the
            // correspondence.
            let mut noted = None;
            if self.far_first(&scan, slot, m, ratio)
                && slot % 2 == 0
                && scan.listing(twin) != Listing::Out
                && !scan.tried.as_flattened().get(twin).copied().unwrap_or(true)
            {
                noted = self.angles(n, centroid, slot);
                scan.set(twin, Listing::Out);
                let cap = self.family_cap(&scan, twin);
                if let Some(mm) = self.search_slot(&mut scan, n, twin, cap) {
                    if let Some(c) = scan.cost.as_flattened_mut().get_mut(twin) {
                        *c = mm.cost;
                    }
                    scan.lowest = scan.lowest.min(mm.cost);
                    (slot, m) = (twin, mm);
                    noted = None;
                }
            }
            // A first candidate at `f′ ≥ 2ε` (UNVERIFIED_FAMILY): the part is of no template's
            // family and unknown; the DP's nearest template is reported, not aligned.
            if self.far_first(&scan, slot, m, ratio) {
                if let Some(angles) = noted.or_else(|| self.angles(n, centroid, slot)) {
                    note_dp(detection, slot, m, angles);
                }
                break;
            }
            if let Some(t) = scan.tried.as_flattened_mut().get_mut(slot) {
                *t = true;
            }
            if !edges {
                self.part_edge(n, counter_clockwise, diff);
                edges = true;
            }
            self.try_candidate(
                n,
                centroid,
                position,
                area,
                slot,
                m,
                part_holes,
                diff,
                refine_params,
                detection,
                &mut best,
            );
            // A mirror image is held against its template (the upside-down reading needs clear
            // evidence, Fit::beats): the template is tried too, whatever its DP cost.
            let twin = slot ^ 1;
            let twin_tried = scan.tried.as_flattened().get(twin).copied().unwrap_or(true);
            // (Only a mirror image that may be the part: the others are not reported.)
            let may_be = best
                .fits
                .last()
                .is_some_and(|(s, f)| *s == slot && f.verify < NEAR_MISS * f.limit);
            if slot % 2 == 1 && !twin_tried && may_be {
                scan.set(twin, Listing::Out);
                if let Some(t) = scan.tried.as_flattened_mut().get_mut(twin) {
                    *t = true;
                }
                if let Some(m) = self.search_slot(&mut scan, n, twin, f32::INFINITY) {
                    self.try_candidate(
                        n,
                        centroid,
                        position,
                        area,
                        twin,
                        m,
                        part_holes,
                        diff,
                        refine_params,
                        detection,
                        &mut best,
                    );
                }
            }
            // A first candidate that is confident ends the scan: a later cost record would have
            // to beat a fit within half its limit with all its holes, and the part's. So does
            // one far off the part in size and shape (UNVERIFIED_FAMILY) that the family rule
            // left to its alignment: a part the frame's edge cuts, a class taught from several
            // examples, `candidate_ratio = inf`.
            if scan.found == 1
                && (confident(detection)
                    || (!detection.verify.is_finite() && m.normalized >= UNVERIFIED_FAMILY * params.epsilon))
            {
                break;
            }
        }
        // The best fit's other side, when it was not tried and the fit is accepted but not
        // confident, or a stretch of its outline does not fit (the mean over every point is
        // STRETCH_OFF times the trimmed score or more): a part upside down may fit a nearly
        // mirror-symmetric template well, the verification leaving out the stretch where they
        // differ, or a chiral one loosely, and its mirror image better (their DP costs can be
        // too close to tell).
        let doubtful = |f: &Fit| f.full >= STRETCH_OFF * f.verify || f.verify >= CONFIDENT * f.limit;
        if let Some((slot, _)) = best.best.filter(|(_, f)| accepted(*f) && doubtful(f)) {
            let twin = slot ^ 1;
            let open =
                scan.listing(twin) != Listing::Out || scan.window.as_flattened().get(twin).is_some_and(|w| !w.is_nan());
            let tried = scan.tried.as_flattened().get(twin).copied().unwrap_or(true);
            if open && !tried {
                scan.set(twin, Listing::Out);
                if let Some(t) = scan.tried.as_flattened_mut().get_mut(twin) {
                    *t = true;
                }
                if let Some(m) = self.search_slot(&mut scan, n, twin, f32::INFINITY) {
                    self.try_candidate(
                        n,
                        centroid,
                        position,
                        area,
                        twin,
                        m,
                        part_holes,
                        diff,
                        refine_params,
                        detection,
                        &mut best,
                    );
                }
            }
        }
        detection.searches = u8::try_from(scan.searches).unwrap_or(u8::MAX);
        best.best
    }

    /// Aligns and verifies one candidate (slot and DP match, its correspondence in
    /// `self.assignment`); when its fit beats the best so far and the fit of its own mirror
    /// image or template, where tried ([`Fit::beats`]), it becomes the best and fills the
    /// detection's DP fields, `verify`, `holes` and `flipped`.
    #[allow(clippy::too_many_arguments)]
    fn try_candidate<B: AsRef<[u8]>>(
        &mut self,
        n: usize,
        centroid: [f32; 2],
        position: [f32; 2],
        area: f32,
        slot: usize,
        m: Match,
        part_holes: &Holes,
        diff: &Difference<'_, B>,
        refine_params: &RefineParams,
        detection: &mut Detection,
        best: &mut Tried,
    ) {
        let Some((signed, paper)) = self.angles(n, centroid, slot) else {
            return;
        };
        let family = m.normalized < self.params.epsilon;
        // A part the frame's edge cuts shows too little for its DP match to rule a side out.
        let dp = (!detection.touches_edge).then_some(m);
        let Some(fit) = self.align_and_verify(
            n,
            position,
            signed,
            area,
            slot,
            family,
            dp,
            part_holes,
            diff,
            refine_params,
        ) else {
            return;
        };
        // A template and its mirror image are held against each other even when neither is
        // the best so far.
        let twin = best.fits.iter().find(|(s, _)| *s == slot ^ 1).map(|(_, f)| *f);
        // (Room for every candidate and its twin; a full list would only forget.)
        let _ = best.fits.push((slot, fit));
        let beats_twin = twin.is_none_or(|t| fit.beats(slot, &t, slot ^ 1));
        if beats_twin && best.best.as_ref().is_none_or(|(b_slot, b)| fit.beats(slot, b, *b_slot)) {
            best.best = Some((slot, fit));
            detection.verify = fit.verify;
            detection.verify_limit = fit.limit;
            detection.holes = fit.holes;
            note_dp(detection, slot, m, (signed, paper));
        }
    }

    /// Leaves out of `scan` every template that a whole part of this `area` could not verify
    /// against: its scale from the areas, `√(area / template area)`, lies outside
    /// `[scale_min, scale_max]` widened by [`SCALE_SLACK`] (the aligned scale follows the
    /// outline, which blur, walls and holes move a little from the areas' ratio), and above by
    /// as much as the wall model takes up ([`Self::grown_max`]: a thick part under a close lens
    /// shows its walls, which add to its area more than to its outline's scale). No DP is run
    /// for them: an integrator's catalogue holds parts of many sizes, and a distractor far
    /// from every size costs no search at all (it stays unknown, without a nearest template).
    fn leave_out_by_size(&self, scan: &mut CandidateScan<T, M>, area: f32) {
        let above = SCALE_SLACK.max(self.grown_max());
        for (t, state) in self.templates.iter().zip(scan.state.iter_mut()) {
            let (lo, hi) = t.tolerance().scale_range(self.params.scale_min, self.params.scale_max);
            let (lo, hi) = (lo / SCALE_SLACK, hi * above);
            let ratio = if t.area() > 0.0 { area / t.area() } else { f32::NAN };
            // Compared squared (no square root): NaN is left out too.
            if !(ratio >= lo * lo && ratio <= hi * hi) {
                *state = [Listing::Out; 2];
            }
        }
    }

    /// The scan of [`Self::next_candidate`] over this part's templates: the part's sorted
    /// descriptor and every template's [`sorted_window_bound`] (the exact sorted-value bounds
    /// are computed as the scan needs them).
    fn candidate_scan(&mut self, n: usize, mirrors: bool) -> CandidateScan<T, M> {
        let mut scan = CandidateScan {
            sorted: [0.0; M],
            window: [[f32::NAN; 2]; T],
            exact: [[f32::NAN; 2]; T],
            state: [[Listing::Out; 2]; T],
            lowest: f32::INFINITY,
            found: 0,
            tried: [[false; 2]; T],
            cost: [[f32::NAN; 2]; T],
            searches: 0,
            cap: f32::INFINITY,
            walk_cap: f32::INFINITY,
        };
        let flips = self.params.flipped_parts && mirrors;
        let (Some(part), Some(sorted)) = (self.descriptor.get(..n), scan.sorted.get_mut(..n)) else {
            return scan;
        };
        sorted.copy_from_slice(part);
        crate::shape::matching::sort_total(sorted);
        for ((t, w), state) in self
            .templates
            .iter()
            .zip(scan.window.iter_mut())
            .zip(scan.state.iter_mut())
        {
            if let Some(v) = sorted_window_bound(sorted, t.sorted_descriptor()).filter(|v| !v.is_nan()) {
                // The mirror image has the same descriptor values, so the same bounds.
                let mirror = flips && t.is_chiral();
                *w = [v, if mirror { v } else { f32::NAN }];
                *state = [Listing::Window, if mirror { Listing::Window } else { Listing::Out }];
            }
        }
        scan
    }

    /// Whether `m`, the match of slot `slot` and the scan's first candidate, lies at `f′ ≥ 2ε`
    /// from the part ([`UNVERIFIED_FAMILY`], [`Self::family_cap`]; never with an infinite
    /// `ratio`).
    fn far_first(&self, scan: &CandidateScan<T, M>, slot: usize, m: Match, ratio: f32) -> bool {
        scan.found == 1 && ratio != f32::INFINITY && m.cost >= self.family_cap(scan, slot)
    }

    /// The DP cost that slot `slot` must stay below to be a candidate once a first search has
    /// run ([`UNVERIFIED_FAMILY`]): the scan's cap for a template taught from one example,
    /// none (`+∞`) for a class taught from several, whose examples may lie further apart in
    /// the descriptor than `2ε` and still verify within the class's tolerance.
    fn family_cap(&self, scan: &CandidateScan<T, M>, slot: usize) -> f32 {
        match self.templates.get(slot / 2) {
            Some(t) if t.tolerance() == Tolerance::NONE => scan.cap,
            _ => f32::INFINITY,
        }
    }

    /// The next candidate of `refine = Verify`, its correspondence in `self.assignment`: the
    /// templates are taken in ascending order of their sorted-value bound
    /// ([`Self::next_template`]), each searched by the DP bounded by `ratio` times the lowest
    /// cost found before it, and the first that comes in is the candidate (with `ratio = 1`,
    /// it beats every earlier one's cost). `None` once `k` were found (at least one is always
    /// sought) or no later template can come in.
    fn next_candidate(
        &mut self,
        scan: &mut CandidateScan<T, M>,
        n: usize,
        k: usize,
        ratio: f32,
    ) -> Option<(usize, Match)> {
        while scan.found < k.max(1) {
            // (An infinite ratio takes every template in turn, even after a cost of 0, whatever
            // its cost: no cap.)
            let uncapped = if ratio == f32::INFINITY {
                f32::INFINITY
            } else {
                scan.lowest * ratio
            };
            // The family's cap (UNVERIFIED_FAMILY) bounds every search after the first (a bound
            // on the first would cost it a relaxed pass over every start). The bound order is
            // walked to the widest cap of the library (a class taught from several examples has
            // none); each template is searched within its own.
            let searched = scan.lowest.is_finite() && ratio != f32::INFINITY;
            let capped = |cap: f32| if searched { uncapped.min(cap) } else { uncapped };
            let slot = self.next_template(scan, n, capped(scan.walk_cap))?;
            let bound = capped(self.family_cap(scan, slot));
            // A mirror image whose template was searched comes in only well below its cost: a
            // part that is neither fits both about alike.
            let twin_cost = scan.cost.as_flattened().get(slot ^ 1).copied().unwrap_or(f32::NAN);
            let bound = if slot % 2 == 1 && twin_cost.is_finite() {
                bound.min(MIRROR_GAIN * twin_cost)
            } else {
                bound
            };
            // (Its sorted-value bound may already rule that out: no search.)
            let lower = scan.exact.as_flattened().get(slot).copied().unwrap_or(0.0);
            if lower * (1.0 - LOWER_BOUND_MARGIN) >= bound {
                continue;
            }
            let found = self.search_slot(scan, n, slot, bound);
            if let (Some(m), Some(c)) = (found, scan.cost.as_flattened_mut().get_mut(slot)) {
                *c = m.cost;
            }
            let Some(m) = found else {
                continue;
            };
            scan.lowest = scan.lowest.min(m.cost);
            // A template and its mirror image count as one candidate.
            if !scan.tried.as_flattened().get(slot ^ 1).copied().unwrap_or(false) {
                scan.found += 1;
            }
            return Some((slot, m));
        }
        None
    }

    /// The DP search of the part against slot `slot` (template `slot / 2`, its mirror image
    /// for an odd slot), bounded by `bound`; counted in `scan.searches`. `None` when it does
    /// not come in (or the slot holds no template).
    fn search_slot(&mut self, scan: &mut CandidateScan<T, M>, n: usize, slot: usize, bound: f32) -> Option<Match> {
        if slot % 2 == 1 {
            self.prepare_mirror(slot / 2);
        }
        let t = if slot % 2 == 1 {
            (self.mirror_of == Some((slot / 2) as u16)).then_some(&self.mirror)
        } else {
            self.templates.get(slot / 2)
        };
        let (Some(t), Some(part), Some(assignment)) = (t, self.descriptor.get(..n), self.assignment.get_mut(..n))
        else {
            return None;
        };
        scan.searches = scan.searches.saturating_add(1);
        best_match(part, t.descriptor(), bound, &mut self.table, assignment)
            .ok()
            .flatten()
    }

    /// Makes `self.mirror` the mirror image of template `ti` (unless it is already).
    pub(super) fn prepare_mirror(&mut self, ti: usize) {
        let Ok(index) = u16::try_from(ti) else {
            return;
        };
        if self.mirror_of == Some(index) {
            return;
        }
        if let Some(t) = self.templates.get(ti) {
            self.mirror.mirror_from(t);
            self.mirror_of = Some(index);
        }
    }

    /// The next template of the scan in ascending order of its [`sorted_lower_bound`] (ties:
    /// library order), taken out of the scan; `None` when its bound reaches `bound` (then no
    /// later one can come in either, as long as the caller's `bound` never rises).
    ///
    /// The exact bounds are computed lazily: a template's [`sorted_window_bound`] is at most its
    /// sorted bound, so one whose window bound exceeds the least exact bound computed so far
    /// cannot come next, and one whose window bound reaches `bound` never comes in; the order
    /// is the same as computing every bound first (how many need it on the bench set:
    /// `docs/performance.md`).
    fn next_template(&mut self, scan: &mut CandidateScan<T, M>, n: usize, bound: f32) -> Option<usize> {
        // The bound and the search round differently; a margin keeps near ties searched.
        let may_come_in = |lb: f32| lb * (1.0 - LOWER_BOUND_MARGIN) < bound;
        // Exact bounds for every template that could come before the least one known.
        let best = loop {
            let best = scan.least(Listing::Exact, &scan.exact);
            let Some(u) = scan.least(Listing::Window, &scan.window) else {
                break best;
            };
            let wu = scan.window.as_flattened().get(u).copied().unwrap_or(f32::INFINITY);
            let before_best =
                best.is_none_or(|b| wu <= scan.exact.as_flattened().get(b).copied().unwrap_or(f32::INFINITY));
            if !(before_best && may_come_in(wu)) {
                break best;
            }
            let (Some(t), Some(sorted)) = (self.templates.get(u / 2), scan.sorted.get(..n)) else {
                scan.set(u, Listing::Out);
                continue;
            };
            // A template and its mirror image share their sorted values: one bound for both.
            let twin = u ^ 1;
            match sorted_lower_bound(sorted, t.sorted_descriptor(), f32::INFINITY, &mut self.table) {
                Ok(Some(lb)) => {
                    for slot in [u, twin] {
                        if slot == u || scan.listing(slot) == Listing::Window {
                            if let Some(e) = scan.exact.as_flattened_mut().get_mut(slot) {
                                *e = lb;
                            }
                            scan.set(slot, Listing::Exact);
                        }
                    }
                }
                _ => {
                    scan.set(u, Listing::Out);
                    scan.set(twin, Listing::Out);
                }
            }
        };
        let slot = best?;
        if !may_come_in(scan.exact.as_flattened().get(slot).copied().unwrap_or(f32::INFINITY)) {
            return None;
        }
        scan.set(slot, Listing::Out);
        Some(slot)
    }

    /// The paper's path: the template of lowest DP cost and its match, its correspondence in
    /// `self.assignment` (`None` without a template that can be matched). The scan of
    /// [`Self::next_candidate`] with ratio 1 and no limit: each template in ascending order of
    /// its sorted-value bound is searched bounded by the lowest cost so far, until the bound
    /// rules the rest out; the last that came in is the same template as searching all of them
    /// (the first in the bound order among equal costs). Also returns the DP searches run.
    pub(super) fn dp_best_match(&mut self, n: usize, mirrors: bool) -> (Option<(usize, Match)>, usize) {
        let mut scan = self.candidate_scan(n, mirrors);
        let mut best = None;
        while let Some(found) = self.next_candidate(&mut scan, n, usize::MAX, 1.0) {
            best = Some(found);
        }
        (best, scan.searches)
    }
}

/// The candidates one part was aligned and verified against: the best fit so far (by
/// [`Fit::beats`]) and every fit, so that a mirror image is held against its template. At most
/// [`MAX_CANDIDATES`] templates are candidates, each perhaps with its mirror image.
#[derive(Default)]
struct Tried {
    best: Option<(usize, Fit)>,
    fits: heapless::Vec<(usize, Fit), { 2 * MAX_CANDIDATES }>,
}

/// Notes the DP's side of candidate slot `slot` in `detection`: its template, side, cost
/// (`score`) and the angles of its correspondence (`signed`, `paper`).
pub(super) fn note_dp(detection: &mut Detection, slot: usize, m: Match, (signed, paper): (f32, f32)) {
    detection.best_template = Some((slot / 2) as u16);
    detection.flipped = slot % 2 == 1;
    detection.score = m.normalized;
    detection.angle_paper_deg = paper;
    detection.angle_dp_deg = signed;
}

/// Where a template is in a [`CandidateScan`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Listing {
    /// Searched, or without a bound (no template, lengths that do not fit): not in the scan.
    Out,
    /// Only its window bound is known.
    Window,
    /// Its exact sorted-value bound is known.
    Exact,
}

/// Where [`Recognizer::next_candidate`] is in a part's templates. Each template has two
/// slots, `2·ti` for itself and `2·ti + 1` for its mirror image (a part lying upside down;
/// [`Listing::Out`] unless the template is chiral and [`crate::Params::flipped_parts`] is on): the
/// arrays below hold them in pairs, and read flattened they are indexed by slot.
struct CandidateScan<const T: usize, const M: usize> {
    /// The part's descriptor, sorted (its first `n` values).
    sorted: [f32; M],
    /// Each slot's [`sorted_window_bound`].
    window: [[f32; 2]; T],
    /// Each slot's [`sorted_lower_bound`], where computed.
    exact: [[f32; 2]; T],
    /// Where each slot is.
    state: [[Listing; 2]; T],
    /// The lowest DP cost found so far.
    lowest: f32,
    /// Candidates found so far.
    found: usize,
    /// Slots that were candidates.
    tried: [[bool; 2]; T],
    /// Each slot's DP cost where its search came in (NaN elsewhere).
    cost: [[f32; 2]; T],
    /// DP searches run so far.
    searches: usize,
    /// The DP cost no later candidate reaches once one was found ([`UNVERIFIED_FAMILY`] times
    /// `ε·n` for a whole part; `+∞` on the paper's path and for a part the frame's edge cuts),
    /// for a template taught from one example ([`Recognizer::family_cap`]).
    cap: f32,
    /// The largest of the templates' caps: `cap`, or `+∞` when a class of the library was
    /// taught from several examples.
    walk_cap: f32,
}

impl<const T: usize, const M: usize> CandidateScan<T, M> {
    /// The slot in `listing` of least value (ties: the lower slot).
    fn least(&self, listing: Listing, values: &[[f32; 2]; T]) -> Option<usize> {
        let mut best: Option<(f32, usize)> = None;
        for (slot, (&state, &v)) in self.state.as_flattened().iter().zip(values.as_flattened()).enumerate() {
            if state == listing && best.is_none_or(|(b, _)| v < b) {
                best = Some((v, slot));
            }
        }
        best.map(|(_, slot)| slot)
    }

    /// Where slot `slot` is.
    fn listing(&self, slot: usize) -> Listing {
        self.state.as_flattened().get(slot).copied().unwrap_or(Listing::Out)
    }

    /// Moves slot `slot` to `listing`.
    fn set(&mut self, slot: usize, listing: Listing) {
        if let Some(s) = self.state.as_flattened_mut().get_mut(slot) {
            *s = listing;
        }
    }

    /// Back to the start of the bound order, without the templates that were candidates: the
    /// others are in the scan again, with the exact bounds already computed (the order is the
    /// same as a new scan's, which would compute them again). Mirror images are not: a part
    /// upside down fits its template's mirror image better than any other template, so the
    /// first pass finds it; the wider passes are for near misses of the right way up.
    fn reopen(&mut self) {
        for (slot, ((state, &tried), (&exact, &window))) in self
            .state
            .as_flattened_mut()
            .iter_mut()
            .zip(self.tried.as_flattened())
            .zip(self.exact.as_flattened().iter().zip(self.window.as_flattened()))
            .enumerate()
        {
            *state = if tried || slot % 2 == 1 {
                Listing::Out
            } else if !exact.is_nan() {
                Listing::Exact
            } else if !window.is_nan() {
                Listing::Window
            } else {
                Listing::Out
            };
        }
    }
}

/// A mirror image whose template was searched for this part is a candidate only when its DP
/// cost is below this share of the template's: a part upside down fits the mirror image
/// clearly better, one that is neither (an unknown part) about alike. A nearly
/// mirror-symmetric part upside down, whose two costs are too close to tell, is caught by its
/// fit instead ([`STRETCH_OFF`]).
pub const MIRROR_GAIN: f32 = 0.8;

/// How far the scale from the areas may lie outside `[scale_min, scale_max]` (as a factor)
/// before a template is not searched for a whole part ([`Recognizer`]'s candidate scan).
pub const SCALE_SLACK: f32 = 1.15;

/// The bound ratio of the candidate scan once no candidate so far has verified well, first:
/// a template whose DP cost is this close to the lowest is a near tie, which the descriptor
/// cannot rank (blur, walls and part-to-part variation move a cost by more), so it is tried
/// before a template ranked earlier by the bound order but costing more (a thick washer's walls
/// put the hex nut's cost 4 % below the washer's, and two gears' 40–75 % above it).
pub const NEAR_TIE_RATIO: f32 = 1.25;

/// The bound ratio of the candidate scan once no candidate so far has verified well and no
/// near tie ([`NEAR_TIE_RATIO`]) was left.
pub const FALLBACK_RATIO: f32 = 3.0;

/// The family of a part, in multiples of `ε`: a whole part (not cut by the frame's edge) is no
/// template's whose DP cost is `f′ ≥ UNVERIFIED_FAMILY·ε` (the paper's decision would call it
/// unknown twice over). A first candidate that far off ends the candidate scan before any
/// alignment, the part unknown (its DP's nearest template reported as `best_template` with its
/// `score`); every later search of the scan, in every pass, is bounded by that cost, so the
/// wider passes (up to [`FALLBACK_RATIO`] times a distractor's lowest cost) search only the
/// part's family. A part the frame's edge cuts (its outline holds the straight cut, `f′` up to
/// 0.16 on the border set) has no cap; its first candidate that far off ends the scan only
/// when it could not be verified. Neither has a template of a class taught from several
/// examples (its examples may lie further apart than `2ε` and the class's tolerance still
/// take them in), nor a scan with `candidate_ratio = inf`, which asks for templates whatever
/// their costs (how the host measures one example against another).
///
/// The right templates of known parts lie at `f′` 0.025–0.09 on every set measured (ε = 0.08;
/// `docs/accuracy.md`): over every generated set, the 3× camera set and the real photos the
/// rule changes no known part's class, angle or position, and spares the searches and
/// alignments of distractors (`docs/performance.md`).
pub const UNVERIFIED_FAMILY: f32 = 2.0;

/// An accepted fit of a chiral template (or its mirror image) whose mean distance over every
/// point is this multiple of its trimmed verification score or more has a stretch of outline
/// that does not fit: the other side is aligned too. A part the right way up gives 1.3–2.
pub const STRETCH_OFF: f32 = 3.0;

/// Relative margin by which a template's sorted lower bound must exceed the `k`-th best DP cost
/// before the template is skipped (the two are rounded differently in `f32`).
const LOWER_BOUND_MARGIN: f32 = 1e-5;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::library::template::Template;
    use crate::params::Params;
    use crate::shape::matching::{best_cost, match_at_start};
    extern crate std;

    /// Smooth descriptor-like values with a little noise, from a seed.
    fn values(seed: u64, len: usize, out: &mut [f32]) {
        let mut x = seed | 1;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x % 10_000) as f32 / 10_000.0
        };
        let (phase, freq, amp) = (next() * 6.0, 0.1 + next() * 0.3, 0.1 + next() * 0.4);
        for (i, v) in out.iter_mut().take(len).enumerate() {
            *v = 1.0 + amp * libm::sinf(phase + i as f32 * freq) + 0.05 * next();
        }
    }

    #[test]
    fn skipping_by_sorted_bound_keeps_the_dp_best() {
        const N: usize = 24;
        const MM: usize = 36;
        let params = Params {
            n: N,
            m: MM,
            k: 2,
            ..Params::DEFAULT
        };
        let mut skippable = 0;
        for seed in 1..40u64 {
            let mut r: Recognizer<12, MM, 64, 4, { N * (MM - N + 1) }> = Recognizer::new();
            r.set_params(params).unwrap();
            for t in 0..12u64 {
                let mut desc = [0.0f32; MM];
                values(seed * 100 + t, MM, &mut desc);
                let pts = (0..MM).map(|j| {
                    let a = j as f32 * core::f32::consts::TAU / MM as f32;
                    [libm::cosf(a) * 10.0, libm::sinf(a) * 10.0]
                });
                let tpl = Template::from_parts(pts, desc, [0.0; 2], [0.0; 2], 314.0).unwrap();
                r.add_template(tpl).unwrap();
            }
            values(seed * 7 + 3, N, &mut r.descriptor);
            // Every template searched without a bound, sorted by cost (ties: library order).
            let mut all = [(0usize, f32::INFINITY); 12];
            for (ti, t) in r.templates.iter().enumerate() {
                let mut table = [0.0f32; N * (MM - N + 1)];
                let m = best_cost(&r.descriptor[..N], t.descriptor(), f32::INFINITY, &mut table)
                    .unwrap()
                    .unwrap();
                all[ti] = (ti, m.cost);
            }
            all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            // Templates whose sorted bound already rules them out of the best 3 (the old test of
            // the three best: the same random libraries).
            let mut sorted = r.descriptor;
            sorted[..N].sort_by(f32::total_cmp);
            for t in r.templates.iter() {
                let mut row = [0.0f32; MM];
                let lb = sorted_lower_bound(&sorted[..N], t.sorted_descriptor(), f32::INFINITY, &mut row);
                skippable += lb.unwrap().is_some_and(|lb| lb > all[2].1) as usize;
            }
            let (slot, m) = r.dp_best_match(N, true).0.unwrap();
            // A circle's outline is not chiral: no mirror image is searched.
            assert_eq!(slot % 2, 0);
            let ti = slot / 2;
            assert_eq!(ti, all[0].0, "seed {seed}");
            assert!((m.cost - all[0].1).abs() <= 1e-5 * m.cost.max(1.0));
            // The start is the one whose correspondence costs that much, and the
            // correspondence left in `assignment` is that start's and costs as much.
            let mut table = [0.0f32; N * (MM - N + 1)];
            let mut asg = [0u16; N];
            let t = r.templates[ti].descriptor();
            let at = match_at_start(&r.descriptor[..N], t, m.start, &mut table, &mut asg).unwrap();
            assert!((at.cost - m.cost).abs() <= 1e-5 * m.cost.max(1.0));
            let total = r.descriptor[..N]
                .iter()
                .zip(&r.assignment[..N])
                .fold(0.0f32, |acc, (p, &j)| acc + (p - t[j as usize]).abs());
            assert!((total - m.cost).abs() <= 1e-5 * m.cost.max(1.0));
            assert_eq!(r.assignment[0] as usize, m.start);
        }
        // The bound must have had something to skip for the test to mean anything.
        assert!(skippable > 40, "only {skippable} of 468 templates were skippable");
    }

    #[test]
    fn candidates_are_the_cost_records_of_the_bound_order() {
        const N: usize = 24;
        const MM: usize = 36;
        let params = Params {
            n: N,
            m: MM,
            k: 2,
            ..Params::DEFAULT
        };
        let (mut more_than_one, mut cut_short, mut never_bounded, mut capped_off) = (0, 0, 0, 0);
        for seed in 1..60u64 {
            let mut r: Recognizer<12, MM, 64, 4, { N * (MM - N + 1) }> = Recognizer::new();
            r.set_params(params).unwrap();
            for t in 0..12u64 {
                let mut desc = [0.0f32; MM];
                values(seed * 100 + t, MM, &mut desc);
                let pts = (0..MM).map(|j| {
                    let a = j as f32 * core::f32::consts::TAU / MM as f32;
                    [libm::cosf(a) * 10.0, libm::sinf(a) * 10.0]
                });
                r.add_template(Template::from_parts(pts, desc, [0.0; 2], [0.0; 2], 314.0).unwrap())
                    .unwrap();
            }
            values(seed * 7 + 3, N, &mut r.descriptor);
            // Every template's bound and unbounded DP cost, in the bound order (ties: library
            // order, as the insertion keeps it).
            let mut sorted = r.descriptor;
            sorted[..N].sort_by(f32::total_cmp);
            let mut all: std::vec::Vec<(f32, usize, f32)> = r
                .templates
                .iter()
                .enumerate()
                .map(|(ti, t)| {
                    let mut table = [0.0f32; N * (MM - N + 1)];
                    let lb = sorted_lower_bound(&sorted[..N], t.sorted_descriptor(), f32::INFINITY, &mut table)
                        .unwrap()
                        .unwrap();
                    let c = best_cost(&r.descriptor[..N], t.descriptor(), f32::INFINITY, &mut table)
                        .unwrap()
                        .unwrap();
                    (lb, ti, c.cost)
                })
                .collect();
            all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            // A cap that some templates' costs reach: the median cost.
            let mut costs: std::vec::Vec<f32> = all.iter().map(|a| a.2).collect();
            costs.sort_by(f32::total_cmp);
            let median = costs[costs.len() / 2];
            let runs = [
                (3usize, 1.0f32, f32::INFINITY),
                (8, 1.0, f32::INFINITY),
                (3, 1.5, f32::INFINITY),
                (2, f32::INFINITY, f32::INFINITY),
                (3, 1.0, median),
                (8, 3.0, median),
                (2, f32::INFINITY, median),
            ];
            for (k, ratio, cap) in runs {
                // By definition: along the bound order, a template whose cost is below `ratio`
                // times the lowest cost before it, until `k` are found; once a cost is known,
                // also below `cap` (unless the ratio is infinite).
                let mut want = std::vec::Vec::new();
                let mut lowest = f32::INFINITY;
                for &(_, ti, c) in &all {
                    if want.len() == k {
                        break;
                    }
                    let bound = if ratio == f32::INFINITY {
                        f32::INFINITY
                    } else if lowest.is_finite() {
                        (lowest * ratio).min(cap)
                    } else {
                        lowest * ratio
                    };
                    if c < bound {
                        want.push(ti);
                    } else if c < lowest * ratio {
                        capped_off += 1;
                    }
                    lowest = lowest.min(c);
                }
                let mut scan = r.candidate_scan(N, true);
                (scan.cap, scan.walk_cap) = (cap, cap);
                let mut got = std::vec::Vec::new();
                while let Some((slot, m)) = r.next_candidate(&mut scan, N, k, ratio) {
                    // A circle's outline is not chiral: no mirror image is searched.
                    assert_eq!(slot % 2, 0);
                    let ti = slot / 2;
                    got.push(ti);
                    let want_cost = all.iter().find(|a| a.1 == ti).unwrap().2;
                    assert!((m.cost - want_cost).abs() <= 1e-5 * want_cost.max(1.0));
                    // The correspondence left in `assignment` is the start's and costs as much.
                    let mut table = [0.0f32; N * (MM - N + 1)];
                    let mut asg = [0u16; N];
                    let t = r.templates[ti].descriptor();
                    let at = match_at_start(&r.descriptor[..N], t, m.start, &mut table, &mut asg).unwrap();
                    assert!((at.cost - m.cost).abs() <= 1e-5 * m.cost.max(1.0));
                    let total = r.descriptor[..N]
                        .iter()
                        .zip(&r.assignment[..N])
                        .fold(0.0f32, |acc, (p, &j)| acc + (p - t[j as usize]).abs());
                    assert!((total - m.cost).abs() <= 1e-5 * m.cost.max(1.0));
                    assert_eq!(r.assignment[0] as usize, m.start);
                }
                let count = got.len();
                assert_eq!(got, want, "seed {seed} k {k} ratio {ratio}");
                never_bounded += scan
                    .state
                    .as_flattened()
                    .iter()
                    .filter(|&&s| s == Listing::Window)
                    .count();
                if k == 3 && ratio == 1.0 {
                    more_than_one += (count > 1) as usize;
                    cut_short += (count < 3) as usize;
                }
            }
        }
        // Both ways of ending must occur for the test to mean anything, the cap must have
        // kept some templates out, and the window bounds must have spared some exact bounds.
        assert!(more_than_one > 5 && cut_short > 5, "{more_than_one} {cut_short}");
        assert!(capped_off > 5, "{capped_off}");
        assert!(never_bounded > 100, "{never_bounded}");
    }
}
