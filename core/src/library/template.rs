//! Templates: the taught silhouettes, resampled to `m` points and described.
//!
//! A template is made from the outer border of a part at its reference pose (angle 0): the
//! border is resampled to `m` points (eq. 4.5) and described with the neighbourhood
//! `round(k·m/n)` (DESIGN.md: the same fraction of the outline as a part's `k` of `n`).
//! [`Template::from_silhouette`] takes the largest outer border of a silhouette image (part 255,
//! rest 0; `docs/pipeline-spec.md` §9).
//!
//! Memory: `32·M + 156` bytes per template of capacity `M` on a 32-bit camera, its holes and
//! tolerance included
//! (see `vorl budget`).

use crate::borders::contour::{trace_borders, BorderFilter, ContourStore, Point};
use crate::borders::resample::resample;
use crate::error::{Error, Result};
use crate::math;
use crate::params::Params;
use crate::pixels::frame::Frame;
use crate::pose::area_centroid;
use crate::pose::holes::{Holes, MIN_HOLE_FRACTION};
use crate::shape::descriptor::describe;

/// [`Template::mirror_gap`] from which a template is chiral (its mirror image fits no turn of
/// it): 2 % of its size. Resampling and the pixel grid leave up to about 1 % of an exact
/// mirror axis (a 12-tooth gear of sharp corners 0.010, a small arrow 0.016, a real gear 0.009);
/// the catalogue's chiral parts are at 0.029–0.31, a scalene triangle two sides of which differ
/// by 3 % at 0.024. A template photographed from a real mirror-symmetric part may land above
/// it (a real rod: 0.037): it is then matched upside down too, and the evidence rule of the
/// recognizer keeps such parts the right way up ([`crate::recognizer::FLIP_EVIDENCE`]).
pub const CHIRAL_GAP: f32 = 0.02;

/// How far a mirrored hole may lie from the hole it matches before [`Template::mirror_gap`]
/// counts the distance, px: two pixel-grid centres half a pixel off a mirror axis each.
const HOLE_GRID_SLACK: f32 = 1.0;

/// Turns of the coarse grid of [`Template::mirror_gap`] (4° apart).
const MIRROR_GRID: usize = 90;
/// Lowest local minima of the coarse grid that [`Template::mirror_gap`] refines.
const MIRROR_MINIMA: usize = 3;
/// Golden-section steps refining a coarse minimum of [`Template::mirror_gap`] or
/// [`Template::near_turn`] (±4° to 0.004°).
const MIRROR_REFINE_STEPS: usize = 16;
/// Turns of the coarse grid of [`Template::near_turn`] over half a turn (4° apart, as
/// [`MIRROR_GRID`]'s).
const TURN_GRID: usize = MIRROR_GRID / 2;

/// The lowest value of `f` over `[a, b]` and where it is, by [`MIRROR_REFINE_STEPS`] steps of
/// golden-section search (`f` taken to have one minimum there).
fn golden_minimum(f: impl Fn(f32) -> f32, a: f32, b: f32) -> (f32, f32) {
    const INV_PHI: f32 = 0.618_034;
    let (mut a, mut b) = (a, b);
    let (mut x1, mut x2) = (b - INV_PHI * (b - a), a + INV_PHI * (b - a));
    let (mut g1, mut g2) = (f(x1), f(x2));
    for _ in 0..MIRROR_REFINE_STEPS {
        if g1 <= g2 {
            (b, x2, g2) = (x2, x1, g1);
            x1 = b - INV_PHI * (b - a);
            g1 = f(x1);
        } else {
            (a, x1, g1) = (x1, x2, g2);
            x2 = a + INV_PHI * (b - a);
            g2 = f(x2);
        }
    }
    if g1 <= g2 {
        (g1, x1)
    } else {
        (g2, x2)
    }
}

/// One taught part: `m` resampled border points, their descriptor and centroids, and the
/// sub-pixel edge the refine stage aligns.
#[derive(Debug, Clone, PartialEq)]
pub struct Template<const M: usize> {
    m: usize,
    points: [[f32; 2]; M],
    descriptor: [f32; M],
    /// The descriptor values in ascending order (for [`crate::shape::matching::sorted_lower_bound`]).
    sorted: [f32; M],
    centroid: [f32; 2],
    area_centroid: [f32; 2],
    area: f32,
    /// Sub-pixel edge points, offsets from `area_centroid`.
    edge: [[f32; 2]; M],
    /// Unit outward normals at the edge points.
    normals: [[f32; 2]; M],
    /// The silhouette's own centroid (mean of its pixels) as an offset from `area_centroid`:
    /// where the part's position is, in template coordinates.
    position: [f32; 2],
    /// Mean distance of the edge turned by 180° about the area centroid to the edge itself,
    /// over [`Self::size`] (0 for a 2-fold symmetric part).
    half_turn: f32,
    /// Where the outline turned nearly repeats other than none and half a turn: see
    /// [`Self::near_turn`].
    near_turn: NearTurn,
    /// Mean distance of the edge mirrored left-right and turned to where it fits best to the
    /// edge itself, over [`Self::size`] (0 for a part with a mirror axis): see
    /// [`Self::mirror_gap`].
    mirror_gap: f32,
    /// The same over the nearest [`crate::pose::refine::VERIFY_KEPT`] of the points: see
    /// [`Self::mirror_score`].
    mirror_score: f32,
    /// The silhouette's holes, centres as offsets from `area_centroid`.
    holes: Holes,
    /// What a class taught from several examples needs beyond the parameters' limits.
    tolerance: Tolerance,
}

/// What a class taught from several examples shows of its own spread, against the
/// parameters' verification limit and scale range: measured when it is taught (each example
/// aligned on each other one). A single-example template has [`Tolerance::NONE`]. The scale
/// range is never narrower than `[scale_min, scale_max]` (a camera moved between shifts scales
/// every part alike). The limit follows the examples both ways: wider where they lie further
/// apart than `Params::verify_limit` allows, narrower where they agree more closely, down to
/// [`Tolerance::MIN_VERIFY`] of it (a part that merely resembles the class, 10–15 % shorter,
/// then fails; the partial search keeps the parameters' limit as its floor).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Factor on the verification limit (at least [`Tolerance::MIN_VERIFY`]).
    pub verify: f32,
    /// Part size over template size that the examples need: `[low, high]`.
    pub scale: [f32; 2],
}

impl Tolerance {
    /// Nothing beyond the parameters.
    pub const NONE: Tolerance = Tolerance {
        verify: 1.0,
        scale: [1.0, 1.0],
    };

    /// The least factor on the verification limit a class may carry, however closely its
    /// examples agree: a right part of the generated sets scores 0.1–0.4 of the parameters'
    /// limit ([`crate::recognizer::CONFIDENT`]), and the examples are silhouettes, which never
    /// show what the frame adds to a part's edge (blur, noise, a wall, a shadow's rim).
    pub const MIN_VERIFY: f32 = 0.5;

    /// The factor the alignment (its give-up and distance cap) and the partial search use:
    /// the class's, but never under the parameters' own limit. A narrowed class is narrowed
    /// in its decision only: the alignment must first reach the part's best fit, and a partial
    /// fit's score holds the junction with another part, which no example shows.
    pub fn search_verify(&self) -> f32 {
        self.verify.max(1.0)
    }

    /// Whether every value is finite, the factor at least [`Self::MIN_VERIFY`] and the range
    /// ordered around 1.
    pub fn is_valid(&self) -> bool {
        self.verify.is_finite()
            && self.verify >= Self::MIN_VERIFY
            && self.scale[0].is_finite()
            && self.scale[1].is_finite()
            && self.scale[0] > 0.0
            && self.scale[0] <= 1.0
            && self.scale[1] >= 1.0
    }

    /// `[lo, hi]` widened to take this tolerance's scale range in.
    pub fn scale_range(&self, lo: f32, hi: f32) -> (f32, f32) {
        (lo.min(self.scale[0]), hi.max(self.scale[1]))
    }
}

/// Where a template's outline nearly repeats turned, other than none and half a turn
/// ([`Template::near_turn`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NearTurn {
    /// The turn, degrees in (0, 180) (the outline repeats about as closely the other way).
    pub turn_deg: f32,
    /// The mean distance of the edge turned by it to the edge itself, over
    /// [`Template::size`] (infinite for [`NearTurn::NONE`]).
    pub gap: f32,
    /// The same over the nearest [`crate::pose::refine::VERIFY_KEPT`] of the points, as the
    /// verification scores an alignment: about the score (over [`Template::size`]) a part
    /// aligned that turn off would get. A part that fits much closer than this is not turned.
    pub score: f32,
    /// Whether every hole turned by it lands on a hole of like area (within a pixel).
    pub holes_repeat: bool,
}

impl NearTurn {
    /// No near turn.
    pub const NONE: NearTurn = NearTurn {
        turn_deg: 0.0,
        gap: f32::INFINITY,
        score: f32::INFINITY,
        holes_repeat: false,
    };
}

impl<const M: usize> Template<M> {
    /// An empty template (`const`, for `static` storage).
    pub const fn empty() -> Self {
        Template {
            m: 0,
            points: [[0.0; 2]; M],
            descriptor: [0.0; M],
            sorted: [0.0; M],
            centroid: [0.0; 2],
            area_centroid: [0.0; 2],
            area: 0.0,
            edge: [[0.0; 2]; M],
            normals: [[0.0; 2]; M],
            position: [0.0; 2],
            half_turn: f32::INFINITY,
            near_turn: NearTurn::NONE,
            mirror_gap: 0.0,
            mirror_score: 0.0,
            holes: Holes::new(),
            tolerance: Tolerance::NONE,
        }
    }

    /// A template from an outer border and its hole borders (for the area centroid and the
    /// template's [`Self::holes`]).
    ///
    /// # Errors
    /// [`Error::PointCounts`] when `params.m > M`, [`Error::DegenerateContour`] for a border
    /// that cannot be resampled or described.
    pub fn from_border<'a>(
        border: &[Point],
        holes: impl Iterator<Item = &'a [Point]> + Clone,
        params: &Params,
    ) -> Result<Self> {
        let m = params.m;
        if m > M || m == 0 {
            return Err(Error::PointCounts { n: params.n, m });
        }
        let mut t = Self::empty();
        t.m = m;
        resample(border, &mut t.points[..m])?;
        t.centroid = describe(&t.points[..m], params.descriptor(m), &mut t.descriptor[..m])?;
        t.sort_descriptor();
        let ac = area_centroid(border, holes.clone()).ok_or(Error::DegenerateContour { points: border.len() })?;
        t.area_centroid = ac;
        let mut a2 = 0i64;
        for (i, p) in border.iter().enumerate() {
            let q = border.get((i + 1) % border.len()).copied().unwrap_or(*p);
            a2 += p.x as i64 * q.y as i64 - q.x as i64 * p.y as i64;
        }
        t.area = a2.unsigned_abs() as f32 * 0.5;
        t.holes = Holes::from_borders(holes, MIN_HOLE_FRACTION * t.area).relative_to(ac);
        t.derive_edge(a2 < 0, |_, _| None);
        Ok(t)
    }

    /// Computes the outward normals of the resampled outline and the sub-pixel edge points:
    /// where `crossing(point, normal)` finds the edge (an offset along the normal), there;
    /// otherwise half a pixel out from the pixel-centre outline, where a binary silhouette's edge
    /// lies on average.
    fn derive_edge(&mut self, counter_clockwise_on_screen: bool, crossing: impl Fn([f32; 2], [f32; 2]) -> Option<f32>) {
        let m = self.m;
        let ac = self.area_centroid;
        for k in 0..m {
            let points = self.points.get(..m).unwrap_or(&[]);
            let Some(p) = points.get(k).copied() else { continue };
            let n = crate::pose::refine::outward_normal(points, k, counter_clockwise_on_screen).unwrap_or([0.0, 0.0]);
            let u = crossing(p, n).unwrap_or(0.5);
            if let (Some(e), Some(nn)) = (self.edge.get_mut(k), self.normals.get_mut(k)) {
                *e = [p[0] + u * n[0] - ac[0], p[1] + u * n[1] - ac[1]];
                *nn = n;
            }
        }
        self.measure_half_turn();
    }

    /// [`Self::half_turn`] and [`Self::mirror_gap`] from the edge.
    fn measure_half_turn(&mut self) {
        self.measure_mirror_gap();
        let edge = self.edge.get(..self.m).unwrap_or(&[]);
        let size = self.size();
        if edge.is_empty() || !(size > 0.0) {
            self.half_turn = f32::INFINITY;
            return;
        }
        let outline = crate::pose::refine::Outline::new(edge);
        self.half_turn = self.mean_self_distance(&outline, |e| [-e[0], -e[1]]) / size;
        self.near_turn = self.measure_near_turn(&outline);
    }

    /// [`Self::near_turn`] from the edge and the holes: the lowest local minimum of the turned
    /// edge's mean distance to itself strictly between none and half a turn, away from either
    /// by two steps of the grid (a k-fold outline, k ≥ 3, has one at 360°/k; a 2-fold one only
    /// at half a turn, which [`Self::half_turn`] covers).
    // (Out of line: its buffers then share the stack with the mirror gap's, not add to them.)
    #[inline(never)]
    fn measure_near_turn(&self, outline: &crate::pose::refine::Outline) -> NearTurn {
        let size = self.size();
        let turned = |theta: f32| {
            let (s, c) = math::sin_cos(theta);
            move |e: [f32; 2]| [e[0] * c - e[1] * s, e[0] * s + e[1] * c]
        };
        let gap = |theta: f32| self.mean_self_distance(outline, turned(theta));
        let step = core::f32::consts::PI / TURN_GRID as f32;
        let mut coarse = [0.0f32; TURN_GRID + 1];
        for (k, g) in coarse.iter_mut().enumerate().skip(1) {
            *g = gap(k as f32 * step);
        }
        let mut lowest = (f32::INFINITY, 0usize);
        for (k, w) in coarse.windows(3).enumerate().skip(1).take(TURN_GRID.saturating_sub(3)) {
            if let [before, v, after] = *w {
                if v <= before && v <= after && v < lowest.0 {
                    lowest = (v, k + 1);
                }
            }
        }
        if !lowest.0.is_finite() {
            return NearTurn::NONE;
        }
        let k = lowest.1 as f32;
        let (g, theta) = golden_minimum(gap, (k - 1.0) * step, (k + 1.0) * step);
        let map = turned(theta);
        let (gap, score) = (g / size, self.trimmed_self_distance(outline, map));
        if !(gap.is_finite() && score.is_finite()) {
            return NearTurn::NONE;
        }
        NearTurn {
            turn_deg: math::degrees(theta),
            gap,
            score,
            holes_repeat: self.holes_gap(map) == 0.0,
        }
    }

    /// The farthest a hole mapped by `map` (a turn, or a mirror image and a turn, about the
    /// area centroid) lies from a hole of like area, less a pixel ([`HOLE_GRID_SLACK`]), px,
    /// at most [`Self::size`]: 0 where the holes repeat under `map`.
    fn holes_gap(&self, map: impl Fn([f32; 2]) -> [f32; 2]) -> f32 {
        let holes = self.holes.as_slice();
        let size = self.size();
        let mut gap = 0.0f32;
        for h in holes {
            let p = map(h.centre);
            let nearest = holes
                .iter()
                .filter(|q| q.area <= 1.5 * h.area && h.area <= 1.5 * q.area)
                .map(|q| math::hypot(q.centre[0] - p[0], q.centre[1] - p[1]))
                .fold(f32::INFINITY, f32::min);
            // (A hole's centre on the pixel grid may sit half a pixel off the axis, and its
            // image half a pixel off the other way.)
            gap = gap.max(math::clamp(nearest - HOLE_GRID_SLACK, 0.0, size));
        }
        gap
    }

    /// The mean distance of the edge mapped by `map` to `outline` (the edge's own), each capped
    /// at [`Self::size`], px.
    fn mean_self_distance(&self, outline: &crate::pose::refine::Outline, map: impl Fn([f32; 2]) -> [f32; 2]) -> f32 {
        let edge = self.edge.get(..self.m).unwrap_or(&[]);
        let size = self.size();
        let sum: f32 = edge.iter().map(|e| outline.capped_distance(map(*e), size)).sum();
        sum / edge.len().max(1) as f32
    }

    /// The mean distance of the edge mapped by `map` to `outline` (the edge's own), over its
    /// nearest [`crate::pose::refine::VERIFY_KEPT`] points, as the verification scores an
    /// alignment, over [`Self::size`] (0 where that is not a number).
    fn trimmed_self_distance(&self, outline: &crate::pose::refine::Outline, map: impl Fn([f32; 2]) -> [f32; 2]) -> f32 {
        let edge = self.edge.get(..self.m).unwrap_or(&[]);
        let size = self.size();
        let mut distances = [0.0f32; M];
        let count = edge.len().min(M);
        for (d, e) in distances.iter_mut().zip(edge) {
            *d = outline.capped_distance(map(*e), size);
        }
        let kept = distances.get_mut(..count).unwrap_or(&mut []);
        crate::shape::matching::sort_total(kept);
        let keep = ((count as f32 * crate::pose::refine::VERIFY_KEPT) as usize).clamp(1, count.max(1));
        let score = kept.iter().take(keep).sum::<f32>() / keep as f32 / size;
        if score.is_finite() {
            score
        } else {
            0.0
        }
    }

    /// [`Self::mirror_gap`] from the edge and the holes.
    fn measure_mirror_gap(&mut self) {
        let edge = self.edge.get(..self.m).unwrap_or(&[]);
        let size = self.size();
        if edge.len() < 3 || !(size > 0.0) {
            self.mirror_gap = 0.0;
            self.mirror_score = 0.0;
            return;
        }
        let outline = crate::pose::refine::Outline::new(edge);
        // The edge mirrored left-right and turned by `theta`, and its mean capped distance.
        let mirrored = |theta: f32| {
            let (s, c) = math::sin_cos(theta);
            move |e: [f32; 2]| [-e[0] * c + e[1] * s, e[0] * s + e[1] * c]
        };
        let gap = |theta: f32| self.mean_self_distance(&outline, mirrored(theta));
        // A coarse turn grid, then its lowest local minima refined by golden-section search.
        // Every point counts on the grid too: a subsample of a gear's outline sees the same
        // place on every tooth and finds minima that are not there.
        let step = core::f32::consts::TAU / MIRROR_GRID as f32;
        let mut coarse = [0.0f32; MIRROR_GRID];
        for (k, g) in coarse.iter_mut().enumerate() {
            *g = gap(k as f32 * step);
        }
        let at = |k: usize| coarse.get(k % MIRROR_GRID).copied().unwrap_or(f32::INFINITY);
        let mut lowest = [(f32::INFINITY, 0usize); MIRROR_MINIMA];
        for k in 0..MIRROR_GRID {
            let v = at(k);
            if v <= at(k + MIRROR_GRID - 1) && v <= at(k + 1) {
                // Insert in ascending order, the highest falling off the end.
                let mut item = (v, k);
                for slot in lowest.iter_mut() {
                    if item.0 < slot.0 {
                        core::mem::swap(slot, &mut item);
                    }
                }
            }
        }
        let mut best = (f32::INFINITY, 0.0f32);
        for (v, k) in lowest {
            if !v.is_finite() {
                continue;
            }
            let (g, theta) = golden_minimum(gap, (k as f32 - 1.0) * step, (k as f32 + 1.0) * step);
            if g < best.0 {
                best = (g, theta);
            }
        }
        // The holes at that turn: each mirrored hole needs a hole of like area near it.
        let map = mirrored(best.1);
        let g = best.0.max(self.holes_gap(map)) / size;
        self.mirror_gap = if g.is_finite() { g } else { 0.0 };
        // The trimmed mean at that turn, as the verification takes it.
        let score = self.trimmed_self_distance(&outline, map);
        self.mirror_score = if score.is_finite() { score } else { 0.0 };
    }

    /// [`Self::mirror_gap`] of the outline alone over its nearest
    /// [`crate::pose::refine::VERIFY_KEPT`] points, as the verification scores an alignment: about
    /// the score (over [`Self::size`]) a part lying upside down would get against this
    /// template. A part that fits the template much closer than this is not upside down.
    pub fn mirror_score(&self) -> f32 {
        self.mirror_score
    }

    /// How far the template is from having a mirror axis: the mean distance of its edge,
    /// mirrored left-right and turned to where it fits best, to the edge itself — or the
    /// farthest a mirrored hole then lies from a hole of like area (less a pixel), when that
    /// is more — over
    /// [`Self::size`]. Near 0 for a part with a mirror axis (a gear, a washer, a T, a U):
    /// upside down it looks the same. From [`CHIRAL_GAP`] on the template is chiral
    /// ([`Self::is_chiral`]).
    ///
    /// ```
    /// use vorl_core::{borders::contour::ContourStore, Frame, Params, Template};
    /// let (w, h) = (64, 64);
    /// // `inside(x, y)` drawn as a silhouette and taught.
    /// let teach = |inside: &dyn Fn(usize, usize) -> bool| {
    ///     let px: Vec<u8> = (0..w * h).map(|i| if inside(i % w, i / w) { 255 } else { 0 }).collect();
    ///     let mut labels = vec![0u8; w * h];
    ///     let mut store = ContourStore::<4096, 8>::new();
    ///     Template::<96>::from_silhouette(&Frame::new_checked(&px[..], w, h).unwrap(), &Params::DEFAULT, &mut labels, &mut store).unwrap()
    /// };
    /// // An L of unequal arms: upside down it is another part.
    /// let l = teach(&|x, y| (10..50).contains(&x) && (10..20).contains(&y) || (10..20).contains(&x) && (10..40).contains(&y));
    /// assert!(l.is_chiral(), "{}", l.mirror_gap());
    /// // A T: its mirror image is itself.
    /// let t = teach(&|x, y| (10..54).contains(&x) && (10..20).contains(&y) || (27..37).contains(&x) && (10..50).contains(&y));
    /// assert!(!t.is_chiral(), "{}", t.mirror_gap());
    /// ```
    pub fn mirror_gap(&self) -> f32 {
        self.mirror_gap
    }

    /// Whether the template is chiral: its mirror image matches no turn of it
    /// ([`Self::mirror_gap`] at least [`CHIRAL_GAP`]). A part lying upside down is then the
    /// [`Self::mirrored`] template, and the recognizer matches that too
    /// ([`crate::Params::flipped_parts`]).
    pub fn is_chiral(&self) -> bool {
        self.mirror_gap >= CHIRAL_GAP
    }

    /// The template mirrored left-right about its area centroid (`x → −x` in the template
    /// image): what the part looks like lying upside down. Its points run the other way round
    /// the mirrored outline, so that they keep the border's orientation, and its descriptor is
    /// the original's in that order (the descriptor is the same for a mirror image).
    pub fn mirrored(&self) -> Self {
        let mut out = Self::empty();
        out.mirror_from(self);
        out
    }

    /// Makes `self` [`Self::mirrored`] of `src`, in place (no template-sized temporary: on a
    /// camera it fills a scratch template).
    pub fn mirror_from(&mut self, src: &Self) {
        let m = src.m.min(M);
        let ac = src.area_centroid;
        let flip = |p: [f32; 2]| [2.0 * ac[0] - p[0], p[1]];
        let flip0 = |p: [f32; 2]| [-p[0], p[1]];
        for i in 0..m {
            let j = (m - i) % m;
            let get = |a: &[[f32; 2]; M]| a.get(j).copied().unwrap_or([0.0; 2]);
            if let Some(p) = self.points.get_mut(i) {
                *p = flip(get(&src.points));
            }
            if let Some(e) = self.edge.get_mut(i) {
                *e = flip0(get(&src.edge));
            }
            if let Some(nrm) = self.normals.get_mut(i) {
                *nrm = flip0(get(&src.normals));
            }
            if let (Some(d), Some(s)) = (self.descriptor.get_mut(i), src.descriptor.get(j)) {
                *d = *s;
            }
        }
        self.m = m;
        self.sorted = src.sorted;
        self.centroid = flip(src.centroid);
        self.area_centroid = ac;
        self.area = src.area;
        self.position = flip0(src.position);
        self.half_turn = src.half_turn;
        self.near_turn = src.near_turn;
        self.mirror_gap = src.mirror_gap;
        self.mirror_score = src.mirror_score;
        self.holes = src.holes.mirrored_x();
        self.tolerance = src.tolerance;
    }

    /// Whether the template's holes are the same half a turn on: each hole turned by 180° about
    /// the area centroid lies on a hole of like area (true without holes). Where they are not
    /// (a plate with a large and a small hole on its axis), they tell a part from its half turn
    /// even where the outline does not ([`Self::half_turn`]).
    pub fn holes_repeat_half_turn(&self) -> bool {
        self.holes_gap(|c| [-c[0], -c[1]]) == 0.0
    }

    /// How far the outline is from 2-fold symmetric: the mean distance of its edge turned by
    /// 180° to the edge itself, over [`Self::size`]. Near 0 (elongated parts such as rods,
    /// 2-fold parts) the DP's correspondence may be half a turn off, and the recognizer aligns
    /// both ways.
    pub fn half_turn(&self) -> f32 {
        self.half_turn
    }

    /// Where the outline comes nearest to itself turned, other than none and half a turn
    /// ([`NearTurn`]; [`NearTurn::NONE`] where the turned edge's distance has no minimum
    /// strictly between: a 2-fold outline). A nearly 3-fold outline (a rounded triangle) gives
    /// about 120° and a small gap: the DP's correspondence may then be that turn off either
    /// way, and the recognizer aligns those poses too.
    pub fn near_turn(&self) -> NearTurn {
        self.near_turn
    }

    /// The template's holes (the largest, each at least [`MIN_HOLE_FRACTION`] of its area),
    /// centres as offsets from [`Self::area_centroid`] ([`crate::pose::holes`]).
    pub fn holes(&self) -> &Holes {
        &self.holes
    }

    /// Replaces the template's holes (centres as offsets from the area centroid), as stored by
    /// a template library.
    pub fn set_holes(&mut self, holes: Holes) {
        self.holes = holes;
        self.measure_mirror_gap();
    }

    /// What the template's class needs beyond the parameters ([`Tolerance::NONE`] unless set).
    pub fn tolerance(&self) -> Tolerance {
        self.tolerance
    }

    /// Sets the class's tolerance (as measured when a class is taught from several examples,
    /// or stored by a template library).
    ///
    /// # Errors
    /// [`Error::Corrupt`] for a tolerance that is not [`Tolerance::is_valid`].
    pub fn set_tolerance(&mut self, tolerance: Tolerance) -> Result<()> {
        if !tolerance.is_valid() {
            return Err(Error::Corrupt {
                what: "template tolerance out of range (factor ≥ 0.5, scale low ≤ 1 ≤ high, finite)",
            });
        }
        self.tolerance = tolerance;
        Ok(())
    }

    /// The template's size, px: the radius of the disc of its area, `√(area/π)`. Tolerances
    /// relative to a part's size ([`crate::Params::verify_relative`]) are fractions of it.
    pub fn size(&self) -> f32 {
        crate::math::sqrt(self.area.max(0.0) / core::f32::consts::PI)
    }

    /// The template's mean thickness, px: `2·area / perimeter` of its outline (the resampled
    /// points' polygon), the width of a strip of that area and outline. A disc of radius `r`
    /// has `r`, a long bar its width. 0 for an empty or degenerate template.
    ///
    /// ```
    /// use vorl_core::{borders::contour::ContourStore, Frame, Params, Template};
    /// // A 40×10 bar: 2·400 / 100 = 8 px (a little more: the polygon cuts its corners).
    /// let (w, h) = (60, 30);
    /// let mut px = vec![0u8; w * h];
    /// for y in 10..20 { for x in 10..50 { px[y * w + x] = 255; } }
    /// let mut labels = vec![0u8; w * h];
    /// let mut store = ContourStore::<1024, 8>::new();
    /// let t = Template::<96>::from_silhouette(&Frame::new_checked(&px[..], w, h).unwrap(), &Params::DEFAULT, &mut labels, &mut store).unwrap();
    /// assert!((t.thickness() - 8.0).abs() < 1.0, "{}", t.thickness());
    /// ```
    pub fn thickness(&self) -> f32 {
        let perimeter = crate::math::perimeter(self.points().iter().copied());
        if perimeter > 0.0 && self.area.is_finite() {
            2.0 * self.area.max(0.0) / perimeter
        } else {
            0.0
        }
    }

    /// A template from a silhouette image (part > 127): its largest outer border.
    /// `labels` (`width·height` bytes) and `store` are scratch.
    ///
    /// ```
    /// use vorl_core::{borders::contour::ContourStore, Frame, Params, Template};
    /// let (w, h) = (40, 40);
    /// let mut px = vec![0u8; w * h];
    /// for y in 10..30 { for x in 8..32 { px[y * w + x] = 255; } }
    /// let mut labels = vec![0u8; w * h];
    /// let mut store = ContourStore::<1024, 8>::new();
    /// let t = Template::<96>::from_silhouette(&Frame::new_checked(&px[..], w, h).unwrap(), &Params::DEFAULT, &mut labels, &mut store).unwrap();
    /// assert_eq!(t.points().len(), 96);
    /// assert!((t.area_centroid()[0] - 19.5).abs() < 1e-4);
    /// ```
    ///
    /// # Errors
    /// [`Error::NoPart`] when the image has no border, plus those of [`Self::from_border`] and
    /// [`trace_borders`].
    pub fn from_silhouette<B: AsRef<[u8]>, const P: usize, const C: usize>(
        silhouette: &Frame<B>,
        params: &Params,
        labels: &mut [u8],
        store: &mut ContourStore<P, C>,
    ) -> Result<Self> {
        let (w, h) = (silhouette.width(), silhouette.height());
        let n = w * h;
        if labels.len() < n {
            return Err(Error::BufferTooSmall {
                needed: n,
                got: labels.len(),
            });
        }
        for (y, row) in labels.chunks_exact_mut(w.max(1)).take(h).enumerate() {
            for (l, &p) in row.iter_mut().zip(silhouette.row(y)) {
                *l = (p > 127) as u8;
            }
        }
        let filter = BorderFilter {
            min_points: 1,
            min_area: 0.0,
        };
        trace_borders(labels, w, h, filter, store)?;
        let best = store.largest_outer().ok_or(Error::NoPart)?;
        let holes = store.holes_of(best).map(|i| store.points(i));
        let mut t = Self::from_border(store.points(best), holes, params)?;
        // The silhouette's edge: where the bilinear image crosses half level along each normal.
        let ccw = store.contours().get(best).is_some_and(|c| c.area2 < 0);
        t.derive_edge(ccw, |p, n| silhouette_crossing(silhouette, p, n));
        // The silhouette's pixel centroid, relative to the area centroid.
        let (mut sx, mut sy, mut count) = (0.0f32, 0.0f32, 0usize);
        for y in 0..h {
            for (x, &v) in silhouette.row(y).iter().enumerate() {
                if v > 127 {
                    sx += x as f32;
                    sy += y as f32;
                    count += 1;
                }
            }
        }
        if count > 0 {
            t.position = [
                sx / count as f32 - t.area_centroid[0],
                sy / count as f32 - t.area_centroid[1],
            ];
        }
        Ok(t)
    }

    /// Sub-pixel edge points (offsets from [`Self::area_centroid`]), one per resampled point.
    pub fn edge(&self) -> &[[f32; 2]] {
        self.edge.get(..self.m).unwrap_or(&[])
    }

    /// Unit outward normals at [`Self::edge`].
    pub fn normals(&self) -> &[[f32; 2]] {
        self.normals.get(..self.m).unwrap_or(&[])
    }

    /// The part's position (the silhouette's pixel centroid) as an offset from
    /// [`Self::area_centroid`].
    pub fn position_offset(&self) -> [f32; 2] {
        self.position
    }

    /// A template from its stored parts (as [`crate::library`] reads them): the `m` resampled
    /// points, their `m` descriptor values, the points' mean `C'`, the area centroid and the area.
    ///
    /// ```
    /// use vorl_core::Template;
    /// let pts = [[0.0f32, 0.0], [4.0, 0.0], [4.0, 2.0], [0.0, 2.0]];
    /// let t = Template::<8>::from_parts(pts, [1.0; 4], [2.0, 1.0], [2.0, 1.0], 8.0).unwrap();
    /// assert_eq!((t.len(), t.centroid()), (4, [2.0, 1.0]));
    /// assert!(Template::<3>::from_parts(pts, [1.0; 4], [2.0, 1.0], [2.0, 1.0], 8.0).is_err());
    /// ```
    ///
    /// # Errors
    /// [`Error::Capacity`] for more than `M` points or descriptor values,
    /// [`Error::DegenerateContour`] for fewer than 3 points, and [`Error::Corrupt`] when the
    /// counts differ or a value is not finite.
    pub fn from_parts(
        points: impl IntoIterator<Item = [f32; 2]>,
        descriptor: impl IntoIterator<Item = f32>,
        centroid: [f32; 2],
        area_centroid: [f32; 2],
        area: f32,
    ) -> Result<Self> {
        let mut t = Self::empty();
        let full = |requested| Error::Capacity {
            what: "template points M",
            capacity: M,
            requested,
        };
        let mut m = 0;
        for p in points {
            *t.points.get_mut(m).ok_or(full(m + 1))? = p;
            m += 1;
        }
        let mut count = 0;
        for c in descriptor {
            *t.descriptor.get_mut(count).ok_or(full(count + 1))? = c;
            count += 1;
        }
        if m < 3 {
            return Err(Error::DegenerateContour { points: m });
        }
        if count != m {
            return Err(Error::Corrupt {
                what: "template points and descriptor differ in length",
            });
        }
        let scalars = centroid.into_iter().chain(area_centroid).chain([area]);
        let mut values = t.points.iter().flatten().chain(&t.descriptor).copied().chain(scalars);
        if !values.all(f32::is_finite) {
            return Err(Error::Corrupt {
                what: "template value is not finite",
            });
        }
        t.m = m;
        t.sort_descriptor();
        t.centroid = centroid;
        t.area_centroid = area_centroid;
        t.area = area;
        // The edge: half a pixel out from the stored outline (no silhouette to look at here).
        let mut a2 = 0.0f32;
        for k in 0..m {
            if let (Some(a), Some(b)) = (t.points.get(k), t.points.get((k + 1) % m)) {
                a2 += a[0] * b[1] - b[0] * a[1];
            }
        }
        t.derive_edge(a2 < 0.0, |_, _| None);
        t.position = [0.0; 2];
        Ok(t)
    }

    /// Replaces the sub-pixel edge (offsets from the area centroid), its normals and the
    /// position offset, as stored by a template library.
    ///
    /// # Errors
    /// [`Error::Corrupt`] when the lengths differ from `m` or a value is not finite.
    pub fn set_edge(&mut self, edge: &[[f32; 2]], normals: &[[f32; 2]], position: [f32; 2]) -> Result<()> {
        if edge.len() != self.m || normals.len() != self.m {
            return Err(Error::Corrupt {
                what: "template edge length differs from m",
            });
        }
        if !edge
            .iter()
            .chain(normals)
            .flatten()
            .chain(&position)
            .all(|v| v.is_finite())
        {
            return Err(Error::Corrupt {
                what: "template edge value is not finite",
            });
        }
        for (d, s) in self.edge.iter_mut().zip(edge) {
            *d = *s;
        }
        for (d, s) in self.normals.iter_mut().zip(normals) {
            *d = *s;
        }
        self.position = position;
        self.measure_half_turn();
        Ok(())
    }

    /// Number of resampled points `m`.
    pub fn len(&self) -> usize {
        self.m
    }

    /// Whether the template is empty (never for one made by a constructor).
    pub fn is_empty(&self) -> bool {
        self.m == 0
    }

    /// The `m` resampled border points.
    pub fn points(&self) -> &[[f32; 2]] {
        self.points.get(..self.m).unwrap_or(&[])
    }

    /// The `m` descriptor values `c'_j`.
    pub fn descriptor(&self) -> &[f32] {
        self.descriptor.get(..self.m).unwrap_or(&[])
    }

    /// The `m` descriptor values in ascending order.
    pub fn sorted_descriptor(&self) -> &[f32] {
        self.sorted.get(..self.m).unwrap_or(&[])
    }

    /// Fills `sorted` from the first `m` descriptor values.
    fn sort_descriptor(&mut self) {
        let m = self.m.min(M);
        if let (Some(dst), Some(src)) = (self.sorted.get_mut(..m), self.descriptor.get(..m)) {
            dst.copy_from_slice(src);
            crate::shape::matching::sort_total(dst);
        }
    }

    /// Mean of the resampled points (the `C'` of eqs. 4.1–4.2 and 6.3).
    pub fn centroid(&self) -> [f32; 2] {
        self.centroid
    }

    /// Area centroid of the silhouette (the reference position).
    pub fn area_centroid(&self) -> [f32; 2] {
        self.area_centroid
    }

    /// Polygon area of the border, px².
    pub fn area(&self) -> f32 {
        self.area
    }
}

/// Offset along `n` from `p` where the silhouette's bilinear interpolation crosses 127.5,
/// searched within ±1.5 px (the nearest crossing), or `None`.
fn silhouette_crossing<B: AsRef<[u8]>>(img: &Frame<B>, p: [f32; 2], n: [f32; 2]) -> Option<f32> {
    let sample = |u: f32| {
        let (x, y) = (p[0] + u * n[0], p[1] + u * n[1]);
        let (fx, fy) = (crate::math::floor(x), crate::math::floor(y));
        let (tx, ty) = (x - fx, y - fy);
        let at = |dx: isize, dy: isize| img.get_clamped(fx as isize + dx, fy as isize + dy) as f32;
        (at(0, 0) * (1.0 - tx) + at(1, 0) * tx) * (1.0 - ty) + (at(0, 1) * (1.0 - tx) + at(1, 1) * tx) * ty
    };
    let mut best: Option<f32> = None;
    let steps = 12;
    let step = 1.5 / steps as f32;
    let mut prev = sample(-1.5) - 127.5;
    for k in (-steps + 1)..=steps {
        let u = k as f32 * step;
        let cur = sample(u) - 127.5;
        if prev > 0.0 && cur <= 0.0 {
            let t = prev / (prev - cur);
            let c = u - step + t * step;
            if best.is_none_or(|b| c.abs() < b.abs()) {
                best = Some(c);
            }
        }
        prev = cur;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;

    /// A template from an `inside` test on an 80 × 80 silhouette.
    fn taught(inside: impl Fn(usize, usize) -> bool) -> Template<96> {
        let (w, h) = (80usize, 80usize);
        let px: std::vec::Vec<u8> = (0..w * h).map(|i| if inside(i % w, i / w) { 255 } else { 0 }).collect();
        let mut labels = std::vec![0u8; w * h];
        let mut store = std::boxed::Box::new(ContourStore::<4096, 16>::new());
        Template::from_silhouette(
            &Frame::new_checked(&px[..], w, h).unwrap(),
            &Params::DEFAULT,
            &mut labels,
            &mut store,
        )
        .unwrap()
    }

    /// The mirror image keeps the outline's orientation and the descriptor (read backwards),
    /// mirrors every offset, and mirrored again is the template.
    #[test]
    fn the_mirror_image_is_the_template_mirrored_and_twice_is_itself() {
        // An L with a hole off its axis.
        let t = taught(|x, y| {
            let l = (10..60).contains(&x) && (10..22).contains(&y) || (10..22).contains(&x) && (22..50).contains(&y);
            l && !((40..48).contains(&x) && (13..19).contains(&y))
        });
        assert!(t.is_chiral());
        let f = t.mirrored();
        let m = t.len();
        assert_eq!(f.len(), m);
        let ac = t.area_centroid();
        for i in 0..m {
            let j = (m - i) % m;
            let (p, q) = (f.points()[i], t.points()[j]);
            assert!((p[0] - (2.0 * ac[0] - q[0])).abs() < 1e-4 && p[1] == q[1]);
            assert_eq!(f.descriptor()[i], t.descriptor()[j]);
            assert_eq!(f.edge()[i], [-t.edge()[j][0], t.edge()[j][1]]);
            assert_eq!(f.normals()[i], [-t.normals()[j][0], t.normals()[j][1]]);
        }
        assert_eq!(
            f.holes().as_slice()[0].centre,
            [-t.holes().as_slice()[0].centre[0], t.holes().as_slice()[0].centre[1]]
        );
        assert_eq!(f.position_offset()[0], -t.position_offset()[0]);
        // The outline keeps its orientation: the shoelace sums agree in sign.
        let area2 = |p: &[[f32; 2]]| {
            (0..p.len())
                .map(|k| {
                    let (a, b) = (p[k], p[(k + 1) % p.len()]);
                    a[0] * b[1] - b[0] * a[1]
                })
                .sum::<f32>()
        };
        assert_eq!(area2(f.points()) > 0.0, area2(t.points()) > 0.0);
        let back = f.mirrored();
        for (a, b) in back.points().iter().zip(t.points()) {
            assert!((a[0] - b[0]).abs() < 1e-4 && a[1] == b[1]);
        }
        assert_eq!(back.descriptor(), t.descriptor());
        assert_eq!((back.mirror_gap(), back.area()), (t.mirror_gap(), t.area()));
    }

    /// Shapes with a mirror axis in any direction are not chiral; shapes without one are, and
    /// so is one whose outline has a mirror axis but whose hole sits off it.
    #[test]
    fn chirality_needs_a_mirror_axis_of_outline_and_holes() {
        let disc = |x: usize, y: usize, cx: f32, cy: f32, r: f32| {
            let (dx, dy) = (x as f32 - cx, y as f32 - cy);
            dx * dx + dy * dy < r * r
        };
        // A rectangle, a diagonal kite, a plate with a central hole: mirror axes.
        let rect = taught(|x, y| (15..65).contains(&x) && (25..50).contains(&y));
        let kite = taught(|x, y| {
            let (u, v) = (x as f32 - 40.0, y as f32 - 40.0);
            // Symmetric about the diagonal u = v.
            (u + v).abs() < 40.0 && (u - v).abs() < 16.0 + 0.3 * (u + v)
        });
        let plate = taught(|x, y| (15..65).contains(&x) && (25..55).contains(&y) && !disc(x, y, 40.0, 40.0, 6.0));
        for t in [&rect, &kite, &plate] {
            assert!(!t.is_chiral(), "{}", t.mirror_gap());
        }
        // The plate with its hole off the axes; a blob without an axis.
        let off = taught(|x, y| (15..65).contains(&x) && (25..55).contains(&y) && !disc(x, y, 28.0, 33.0, 5.0));
        let blob = taught(|x, y| {
            (15..65).contains(&x) && (25..40).contains(&y)
                || (15..30).contains(&x) && (40..60).contains(&y)
                || (50..65).contains(&x) && (40..47).contains(&y)
        });
        for t in [&off, &blob] {
            assert!(t.is_chiral(), "{}", t.mirror_gap());
        }
    }

    /// A rounded triangle nearly repeats at a third of a turn (the DP may take it that far
    /// off); a bar only at half a turn (no near turn); a square plate with a hole in each
    /// corner repeats at a quarter turn, holes and all; the same plate with one corner's hole
    /// missing repeats in its outline only.
    #[test]
    fn the_near_turn_is_where_the_outline_nearly_repeats() {
        let disc = |x: usize, y: usize, cx: f32, cy: f32, r: f32| {
            let (dx, dy) = (x as f32 - cx, y as f32 - cy);
            dx * dx + dy * dy < r * r
        };
        // Three discs' hull, one a little larger: nearly 3-fold.
        let corners = [(40.0f32, 16.0f32, 11.0f32), (17.5, 53.0, 8.0), (62.5, 53.0, 8.0)];
        let triangle = taught(|x, y| {
            let (px, py) = (x as f32, y as f32);
            // Inside when on the inner side of each edge of the corners' outer tangents (near
            // enough: the triangle of the centres grown by the radius), or in a corner's disc.
            let inside_edges = corners.iter().enumerate().all(|(k, a)| {
                let b = corners[(k + 1) % 3];
                let (ex, ey) = (b.0 - a.0, b.1 - a.1);
                let len = libm::hypotf(ex, ey);
                // The edge's outward normal (the corners run counter-clockwise on screen).
                let (nx, ny) = (-ey / len, ex / len);
                (px - a.0) * nx + (py - a.1) * ny <= 8.0
            });
            inside_edges || corners.iter().any(|c| disc(x, y, c.0, c.1, c.2))
        });
        let near = triangle.near_turn();
        assert!((near.turn_deg - 120.0).abs() < 6.0, "{near:?}");
        assert!(near.gap < 0.2 && near.gap > 0.02, "{near:?}");
        assert!(triangle.half_turn() > near.gap, "{} {near:?}", triangle.half_turn());
        let bar = taught(|x, y| (10..70).contains(&x) && (32..48).contains(&y));
        assert!(bar.half_turn() < 0.02, "{}", bar.half_turn());
        let bar_near = bar.near_turn();
        assert!(bar_near.gap > 0.2, "{bar_near:?}");
        // (About the plate's centre, 39.5: pixel centres.)
        let holes = [(24.5f32, 24.5f32), (54.5, 24.5), (24.5, 54.5), (54.5, 54.5)];
        let plate = |missing: usize| {
            taught(move |x, y| {
                (15..65).contains(&x)
                    && (15..65).contains(&y)
                    && !holes.iter().take(4 - missing).any(|h| disc(x, y, h.0, h.1, 4.0))
            })
        };
        let (all, three) = (plate(0), plate(1));
        let (a, b) = (all.near_turn(), three.near_turn());
        assert!(
            (a.turn_deg - 90.0).abs() < 2.0 && a.gap < 0.01 && a.holes_repeat,
            "{a:?}"
        );
        // (Its area centroid, about which it turns, lies 0.6 px off the square's centre.)
        assert!(
            (b.turn_deg - 90.0).abs() < 2.0 && b.gap < 0.05 && !b.holes_repeat,
            "{b:?}"
        );
    }
}
