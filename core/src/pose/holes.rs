//! Hole signatures: the holes of a silhouette, and whether a template's holes lie where its
//! aligned pose puts them in a part.
//!
//! The DP (eqs. 4.4–4.9) and the verification look at the outer border only, but two parts of
//! nearly one outline may differ in their holes alone: a connecting rod with one eye or with
//! two, a washer and a disc. The holes are a second cue, independent of the outline, and it
//! does not depend on how closely a part's outline follows its template: two rods of one type
//! differ along their shafts and heads (real rods: 0.6–0.85 IoU between two of one type), but
//! their eyes stay round and where they are. So the recognizer holds a part to its template's
//! holes ([`agreement`]): a candidate whose holes are not found is not that part, and one
//! whose holes are all found may be accepted with an outline a little further off
//! (`recognizer::NEAR_MISS`), for templates that have holes at all.
//!
//! - A hole is measured from its hole border (the part's pixels around it, as Suzuki–Abe
//!   traces them): by Pick's theorem the border's polygon, through the centres of those
//!   pixels, encloses `A − B/2 + 1` pixels that are not on it (`A` its area, `B` its points);
//!   for a hole border those are the hole's own pixels. The centre is the polygon's area
//!   centroid (the points' mean when the area is 0).
//! - [`Holes`] keeps the [`MAX_HOLES`] largest holes of at least [`MIN_HOLE_PIXELS`]; a
//!   template keeps only those of at least [`MIN_HOLE_FRACTION`] of its outer area, so a speck
//!   of dust in a teach shot does not become a hole the parts must have.
//! - A template hole is *found* when a part hole that no other template hole took lies within
//!   [`HOLE_REACH`] of its radius, plus [`HOLE_STRETCH`] of its distance from the centre, plus
//!   one pixel for blur, of where the pose puts it, with an
//!   area within a factor [`HOLE_AREA_RATIO`] of the template hole's, scaled by the pose (its
//!   radius within [`HOLE_EDGE`] px more: the mask's edge moves a small hole's radius as much as
//!   a large one's).
//!   Part holes that no template hole explains (print, texture, a light patch) are not
//!   evidence against the template; the recognizer counts them as the part for its position
//!   ([`crate::pose::partial_volume::print_deficit`]).
//! - A hole too small for the tracing (its border under the frame's `min_area`) still shows as
//!   a dip of `D` (read in the sense of the part's face, so a bright part's shadow in its
//!   bore is no face): [`solid_where_a_hole_is`] vetoes a template whose hole the part shows no
//!   trace of, [`hole_dip`] tells a fit from its half turn by where the dips lie (a pin's
//!   end-hole), and [`untraced_shown`] holds a part of a blob of several to such holes (the
//!   partial search, which asks every hole of a template to be shown).
//!
//! Time: O(B) per hole border; [`agreement`] and [`pose_from_holes`] are O(H²) for
//! `H ≤` [`MAX_HOLES`]. Memory: [`Holes`] is `12·MAX_HOLES + 4` = 100 bytes (in each template,
//! and once on the stack for the part being matched).
//!
//! ```
//! use vorl_core::borders::contour::Point;
//! use vorl_core::pose::holes::{agreement, Hole, Holes};
//! use vorl_core::pose::refine::Pose;
//! // The border of a 2×2 hole at columns 1–2, rows 1–2 of a 4×4 block (8-connected, as traced).
//! let p = |x, y| Point { x, y };
//! let border = [p(1, 0), p(0, 1), p(0, 2), p(1, 3), p(2, 3), p(3, 2), p(3, 1), p(2, 0)];
//! let hole = Hole::from_border(&border).unwrap();
//! assert_eq!(hole.area, 4.0);
//! assert_eq!(hole.centre, [1.5, 1.5]);
//! // A template with that hole 10 px right of its centroid, found in a part turned by 90°.
//! let mut template = Holes::new();
//! template.insert(Hole { centre: [10.0, 0.0], area: 40.0 });
//! let mut part = Holes::new();
//! part.insert(Hole { centre: [50.0, 40.0], area: 42.0 }); // x right, y down: 90° ccw is up
//! let pose = Pose { x: 50.0, y: 50.0, angle: core::f32::consts::FRAC_PI_2, scale: 1.0 };
//! let a = agreement(&template, &pose, &part);
//! assert_eq!((a.expected, a.found), (1, 1));
//! ```

use crate::borders::contour::{BorderFilter, Point};
use crate::pose::polygon_moments;
use crate::pose::refine::Pose;

/// Most holes a [`Holes`] keeps (the largest).
pub const MAX_HOLES: usize = 8;

/// How far from where the pose puts template hole `h` (at `scale`) a part hole may lie and be
/// it: [`HOLE_REACH`] of its radius, plus [`HOLE_STRETCH`] of its distance from the centre,
/// plus one pixel for blur.
fn reach(h: &Hole, scale: f32) -> f32 {
    let from_centre = crate::math::sqrt(h.centre[0] * h.centre[0] + h.centre[1] * h.centre[1]) * scale;
    HOLE_REACH * radius(h.area * scale * scale) + HOLE_STRETCH * from_centre + 1.0
}

/// Whether a hole of `area` px² (at the part's scale) can show in the mask: its edge there may
/// lie [`HOLE_EDGE`] px inside the true one (blur, the threshold), and what is left must still
/// be a hole of [`MIN_HOLE_PIXELS`], which border following traces.
///
/// ```
/// use vorl_core::pose::holes::resolvable;
/// assert!(resolvable(200.0)); // radius 8 px
/// assert!(!resolvable(12.0)); // radius 2 px: it may close
/// ```
pub fn resolvable(area: f32) -> bool {
    radius(area) - HOLE_EDGE >= radius(MIN_HOLE_PIXELS)
}

/// Fewest pixels of a hole that counts (smaller ones are noise of the mask).
pub const MIN_HOLE_PIXELS: f32 = 4.0;

/// Smallest hole a template keeps, as a fraction of its outer area (0.5 %: a 2 px speck in a
/// part of 800 px² is no hole; the smaller eye of a connecting rod is about 3 % of its area).
pub const MIN_HOLE_FRACTION: f32 = 0.005;

/// How far a part hole's centre may lie from where the pose puts the template hole's, in
/// radii of the template hole (scaled): within one radius the two overlap by most of their
/// area. Real rods of one type put their eyes within 0.1–0.6 radii of the template's after
/// the outline's alignment.
pub const HOLE_REACH: f32 = 1.0;

/// How much nearer to or farther from the part's centre than the pose puts it a part hole may
/// lie, as a fraction of that distance: parts of one type differ in length (real connecting
/// rods by up to 15 %), and the outline's aligned scale follows their outline, which a close
/// lens's view of the walls and blur make look larger than the holes' spacing says (real rods:
/// 1.19 against 0.96).
pub const HOLE_STRETCH: f32 = 0.3;

/// How much larger or smaller than the template hole (scaled by the pose) a part hole may be.
pub const HOLE_AREA_RATIO: f32 = 2.0;

/// How far (px) a part hole's radius may lie beyond the [`HOLE_AREA_RATIO`] band around the
/// expected radius: the mask's edge lies a pixel or so off the true edge (blur, the threshold),
/// which shrinks or grows a hole's radius by that much whatever its size, so a small hole's
/// area changes by a larger factor (a generated rod's 7 px eye measured 0.47 of its expected
/// area).
pub const HOLE_EDGE: f32 = 1.5;

/// Whether a hole of `area` px² is of the size expected (`expected` px²): its radius within
/// `[r/√HOLE_AREA_RATIO − HOLE_EDGE, r·√HOLE_AREA_RATIO + HOLE_EDGE]` of the expected radius `r`.
fn radius_fits(area: f32, expected: f32) -> bool {
    let (r, e) = (radius(area), radius(expected));
    let k = crate::math::sqrt(HOLE_AREA_RATIO);
    r >= e / k - HOLE_EDGE && r <= e * k + HOLE_EDGE
}

/// The radius of a disc of `area` px² (0 for a negative area).
fn radius(area: f32) -> f32 {
    crate::math::sqrt(area.max(0.0) / core::f32::consts::PI)
}

/// One hole: its centre and its area in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Hole {
    /// Centre, px (for a template: an offset from its area centroid).
    pub centre: [f32; 2],
    /// Pixels of the hole.
    pub area: f32,
}

impl Hole {
    /// The hole inside a hole border (see the module doc); `None` for an empty border or a
    /// hole of no pixel.
    pub fn from_border(points: &[Point]) -> Option<Hole> {
        if points.is_empty() {
            return None;
        }
        // (2A, Σ(x_i + x_{i+1})·cross_i, Σ(y_i + y_{i+1})·cross_i), signed by the orientation.
        let (a2, mx, my) = polygon_moments(points);
        // Pick's theorem: interior lattice points = A − B/2 + 1.
        let area = 0.5 * a2.unsigned_abs() as f32 - 0.5 * points.len() as f32 + 1.0;
        if !(area > 0.0) {
            return None;
        }
        let centre = if a2 != 0 {
            let den = 3.0 * a2 as f32;
            [mx as f32 / den, my as f32 / den]
        } else {
            let len = points.len() as f32;
            let (sx, sy) = points
                .iter()
                .fold((0.0f32, 0.0f32), |(sx, sy), p| (sx + p.x as f32, sy + p.y as f32));
            [sx / len, sy / len]
        };
        Some(Hole { centre, area })
    }
}

/// The largest holes of a silhouette (at most [`MAX_HOLES`], largest first).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Holes {
    /// The holes, largest first; the slots after `len` stay zero.
    holes: [Hole; MAX_HOLES],
    len: u32,
}

impl Default for Holes {
    fn default() -> Self {
        Self::new()
    }
}

impl Holes {
    /// No holes (`const`, for `static` storage).
    pub const fn new() -> Self {
        Holes {
            holes: [Hole {
                centre: [0.0; 2],
                area: 0.0,
            }; MAX_HOLES],
            len: 0,
        }
    }

    /// The holes inside `borders` (hole borders of one part) of at least `min_area` pixels
    /// (and [`MIN_HOLE_PIXELS`]), the largest [`MAX_HOLES`] of them.
    pub fn from_borders<'a>(borders: impl Iterator<Item = &'a [Point]>, min_area: f32) -> Holes {
        let mut holes = Holes::new();
        for h in borders.filter_map(Hole::from_border) {
            if h.area >= min_area && h.area >= MIN_HOLE_PIXELS {
                holes.insert(h);
            }
        }
        holes
    }

    /// Adds a hole, keeping the [`MAX_HOLES`] largest in descending order of area (a hole
    /// with an area that is not a number is not kept).
    pub fn insert(&mut self, hole: Hole) {
        if !hole.area.is_finite() || !hole.centre.iter().all(|v| v.is_finite()) {
            return;
        }
        let len = self.len().min(MAX_HOLES);
        let at = self
            .holes
            .get(..len)
            .unwrap_or(&[])
            .iter()
            .position(|h| hole.area > h.area)
            .unwrap_or(len);
        if at >= MAX_HOLES {
            return;
        }
        // Shift the smaller ones down by one (the last falls off when full).
        let mut carry = hole;
        for slot in self.holes.iter_mut().take(len + 1).skip(at) {
            core::mem::swap(slot, &mut carry);
        }
        self.len = (len + 1).min(MAX_HOLES) as u32;
    }

    /// The holes, largest first.
    pub fn as_slice(&self) -> &[Hole] {
        self.holes.get(..self.len()).unwrap_or(&[])
    }

    /// Number of holes.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// Whether there is no hole.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The same holes mirrored left-right (`x → −x`: centres taken as offsets from the mirror
    /// axis, as a template's are from its area centroid).
    pub fn mirrored_x(&self) -> Holes {
        let mut out = *self;
        for h in out.holes.iter_mut().take(self.len()) {
            h.centre[0] = -h.centre[0];
        }
        out
    }

    /// The same holes with `origin` subtracted from their centres.
    pub fn relative_to(&self, origin: [f32; 2]) -> Holes {
        let mut out = *self;
        for h in out.holes.iter_mut().take(self.len()) {
            h.centre = [h.centre[0] - origin[0], h.centre[1] - origin[1]];
        }
        out
    }
}

/// How many of a template's holes a part shows where the pose puts them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HoleAgreement {
    /// The template's holes.
    pub expected: u8,
    /// Those found in the part.
    pub found: u8,
    /// Which of the part's holes (bit `j`: the `j`-th of [`Holes::as_slice`]) the template's
    /// explain.
    pub matched: u8,
    /// Of the found holes, those that lie off the template's centre (farther from its area
    /// centroid than their radius): they fix where the part's ends are and which way it points,
    /// where a central hole (a washer's, a bore) fits many parts.
    pub off_centre: u8,
}

impl HoleAgreement {
    /// Every hole of the template was found (true for a template without holes).
    pub fn all_found(&self) -> bool {
        self.found >= self.expected
    }

    /// The template's holes that were not found.
    pub fn missing(&self) -> u8 {
        self.expected.saturating_sub(self.found)
    }
}

/// How far the sizes of `part`'s holes are from `template`'s where `pose` puts them, whatever
/// the scale: for each template hole `k`, `l_k = ln(a_k / a′_k)` with `a_k` the area of the part
/// hole nearest where the pose puts it and `a′_k` the template hole's; the sum of `|l_k − l̄|`
/// (0 with fewer than two holes; infinite when the part has none). A part's scale (its walls,
/// the blur) shifts every `l_k` alike; holes swapped shift them apart. [`agreement`] lets a hole
/// be up to [`HOLE_AREA_RATIO`] off in area, so a part whose outline is (nearly) the same half a
/// turn on (a plate with a large and a small hole on its axis) finds its holes both ways round;
/// their sizes still tell which way is right.
pub fn size_misfit(template: &Holes, pose: &Pose, part: &Holes) -> f32 {
    let holes = template.as_slice();
    let mut logs = [0.0f32; MAX_HOLES];
    for (l, h) in logs.iter_mut().zip(holes) {
        let at = pose.apply(h.centre);
        let d = |q: &Hole| {
            let (dx, dy) = (q.centre[0] - at[0], q.centre[1] - at[1]);
            dx * dx + dy * dy
        };
        let nearest = part.as_slice().iter().min_by(|a, b| d(a).total_cmp(&d(b)));
        let ratio = nearest.map_or(0.0, |q| q.area / h.area);
        *l = if ratio > 0.0 {
            crate::math::ln(ratio)
        } else {
            return f32::INFINITY;
        };
    }
    let logs = logs.get(..holes.len().min(MAX_HOLES)).unwrap_or(&[]);
    let mean = logs.iter().sum::<f32>() / logs.len().max(1) as f32;
    logs.iter().map(|l| (l - mean).abs()).sum()
}

/// Which of `template`'s holes (centres as offsets from its area centroid) `part`'s holes
/// (centres in the frame) show where `pose` puts them (see the module doc). Each part hole
/// serves at most one template hole; the template's holes are taken largest first, each the
/// nearest free part hole that fits.
pub fn agreement(template: &Holes, pose: &Pose, part: &Holes) -> HoleAgreement {
    let mut used = [false; MAX_HOLES];
    let mut found = 0u8;
    let mut off_centre = 0u8;
    let scale = pose.scale;
    let expected = template.as_slice();
    for h in expected {
        let at = pose.apply(h.centre);
        let area = h.area * scale * scale;
        let reach = reach(h, scale);
        let mut best: Option<(f32, usize)> = None;
        for (j, (q, u)) in part.as_slice().iter().zip(used.iter()).enumerate() {
            if *u {
                continue;
            }
            let (dx, dy) = (q.centre[0] - at[0], q.centre[1] - at[1]);
            let d2 = dx * dx + dy * dy;
            let fits = d2 <= reach * reach && radius_fits(q.area, area);
            if fits && best.is_none_or(|(b, _)| d2 < b) {
                best = Some((d2, j));
            }
        }
        if let Some((_, j)) = best {
            if let Some(u) = used.get_mut(j) {
                *u = true;
            }
            found = found.saturating_add(1);
            let r = radius(h.area);
            if h.centre[0] * h.centre[0] + h.centre[1] * h.centre[1] > r * r {
                off_centre = off_centre.saturating_add(1);
            }
        }
    }
    let matched = used
        .iter()
        .enumerate()
        .fold(0u8, |bits, (j, &u)| if u { bits | (1 << j) } else { bits });
    HoleAgreement {
        expected: expected.len().min(u8::MAX as usize) as u8,
        found,
        matched,
        off_centre,
    }
}

/// Fraction of the part's face contrast that the difference at a template hole's place must
/// keep for the place to count as solid ([`solid_where_a_hole_is`]): a quarter of the contrast
/// gone is the least dip a hole that the blur nearly closes still shows at its centre, for the
/// hole sizes [`resolvable`] admits (a radius of 2.6 px under a blur of 1 px σ keeps 0.5 of it).
pub const SOLID_KEEPS: f32 = 0.75;

/// Whether `template` has a hole that the part, at `pose`, shows no trace of: resolvable at
/// the pose's scale ([`resolvable`]) and of a radius above half [`Sight::hidden`] (a wall
/// closes a hole wholly only where it is twice the hole's radius wide), its disc and the ring
/// of face around it inside the frame (`inside`), no part hole within reach of where the pose
/// puts it (see the module doc) of a size it could be found at (a radius at least the lower
/// end of [`HOLE_AREA_RATIO`]'s band, less [`HOLE_EDGE`]), and either
///
/// - a smaller part hole there, the hole's radius above [`Sight::hidden`], and the difference
///   midway between that hole's radius and the template hole's still [`SOLID_KEEPS`] of the
///   face in all eight directions: the template's hole seen past a wall on one side, or partly
///   covered, would open its rim somewhere; a solid rim all round is another part's smaller
///   hole (a cam's bore where a hex nut's, twice as wide, should be); or
/// - the difference `d` (a sampler of `D` at a sub-pixel position, signed: a shadow darker
///   than the platform beside a brighter part is no face) at its centre (the mean of five
///   samples there) and at each of eight points halfway to its edge still [`SOLID_KEEPS`] of
///   the part's face around it (sampled on a ring at 1.6 radii, where that ring lies on the
///   part): a hole that blur nearly closed, or that a wall narrows to a lens, still leaves a
///   dip at one of them; or
/// - a dip, the hole's radius above [`Sight::hidden`] (a wall that wide may narrow it below
///   what the mask keeps), the dip deeper than the part's own shadow beside it
///   (`shadow(sign, r)`, asked for only here: [`shade`] of the part's outline in the face's sense `sign`, read to
///   `2r` beyond it; a hole in its own shadow, which the mask closes, dips no deeper), a
///   radius of [`OPEN_RADII`] times the blur of the part's edge or more (`blur`: σ px, asked
///   for at most once, only for such a hole; [`edge_blur`]), and wide enough that its border,
///   its edge [`HOLE_EDGE`] inside, passes the border filter of the frame's tracing
///   ([`Sight::filter`]): a blur that soft cannot close a hole that wide, so the mask would
///   show it and the tracing keep it (print over a bore keeps it solid however far its grey
///   lies from the face's).
///
/// A part without the template's bore is not the part with it, however well its outline fits
/// (a smooth blob fitted a cam or a hex nut).
///
/// ```
/// use vorl_core::borders::contour::BorderFilter;
/// use vorl_core::pose::holes::{solid_where_a_hole_is, Hole, Holes, Sight};
/// use vorl_core::pose::refine::Pose;
/// let mut template = Holes::new();
/// template.insert(Hole { centre: [0.0, 0.0], area: 300.0 }); // a bore, radius 9.8 px
/// let pose = Pose { x: 50.0, y: 50.0, angle: 0.0, scale: 1.0 };
/// let inside = |_x: f32, _y: f32| true;
/// let sharp = || Some(0.5); // the frame's edges: σ 0.5 px
/// let no_shadow = |_sign: f32, _r: f32| 0.0; // nothing of the part's sense beside it
/// let f = Sight { hidden: 0.0, filter: BorderFilter { min_points: 16, min_area: 64.0 } };
/// // A solid disc of contrast 80: no trace of the bore.
/// assert!(solid_where_a_hole_is(&template, &pose, &Holes::new(), &f, sharp, |_, _| 80.0, inside, no_shadow));
/// // The bore there (the platform shows: D = 0 within 9.8 px of the centre), but its mask
/// // hole not passed in: the dip says it is there.
/// let d = |x: f32, y: f32| if (x - 50.0).hypot(y - 50.0) < 9.8 { 0.0 } else { 80.0 };
/// assert!(!solid_where_a_hole_is(&template, &pose, &Holes::new(), &f, || Some(4.0), d, inside, no_shadow));
/// // A label of half the contrast over the bore's place: under sharp edges a bore that wide
/// // would show in the mask, and no part hole is near it.
/// let label = |x: f32, y: f32| if (x - 50.0).hypot(y - 50.0) < 12.0 { 40.0 } else { 80.0 };
/// assert!(solid_where_a_hole_is(&template, &pose, &Holes::new(), &f, sharp, label, inside, no_shadow));
/// // The same label under a tracing that drops borders under 400 px² (no hole of that size
/// // would reach the recognizer): only the dip counts, and the label's keeps half the face.
/// let coarse = Sight { hidden: 0.0, filter: BorderFilter { min_points: 16, min_area: 400.0 } };
/// assert!(!solid_where_a_hole_is(&template, &pose, &Holes::new(), &coarse, sharp, label, inside, no_shadow));
/// // The label's grey, but as the part's own shadow (as dark beside the part): a hole in it.
/// let shaded = |_sign: f32, _r: f32| 40.0;
/// assert!(!solid_where_a_hole_is(&template, &pose, &Holes::new(), &f, sharp, label, inside, shaded));
/// // A platform darker than the face's sense at the bore (a bright part's shadow in it): no face.
/// let bright_part = |x: f32, y: f32| if (x - 50.0).hypot(y - 50.0) < 9.8 { -30.0 } else { 80.0 };
/// assert!(!solid_where_a_hole_is(&template, &pose, &Holes::new(), &f, || Some(4.0), bright_part, inside, no_shadow));
/// ```
#[allow(clippy::too_many_arguments)]
pub fn solid_where_a_hole_is(
    template: &Holes,
    pose: &Pose,
    part: &Holes,
    sight: &Sight,
    blur: impl FnOnce() -> Option<f32>,
    d: impl Fn(f32, f32) -> f32,
    inside: impl Fn(f32, f32) -> bool,
    shadow: impl Fn(f32, f32) -> f32,
) -> bool {
    let scale = pose.scale;
    // The frame's edge blur, measured once, the first time a hole needs it.
    let mut blur = Some(blur);
    let mut sigma: Option<f32> = None;
    template.as_slice().iter().any(|h| {
        let area = h.area * scale * scale;
        // A wall `w` px wide moves the hole's far opening `w` px across its near one: only a
        // wall of twice the hole's radius closes it wholly; a narrower one leaves a lens open.
        if !resolvable(area) || radius(area) <= 0.5 * sight.hidden {
            return false;
        }
        let at = pose.apply(h.centre);
        let r = radius(area);
        let reach = reach(h, scale);
        // A part hole within reach is the hole's trace when it is of a size the hole could be
        // found at ([`radius_fits`]' lower end); a smaller one only when the hole's rim shows
        // an opening somewhere (below).
        let found_at = r / crate::math::sqrt(HOLE_AREA_RATIO) - HOLE_EDGE;
        let mut smaller: Option<f32> = None;
        for q in part.as_slice() {
            let (dx, dy) = (q.centre[0] - at[0], q.centre[1] - at[1]);
            if dx * dx + dy * dy <= reach * reach {
                let rq = radius(q.area);
                if !(rq < found_at) {
                    return false;
                }
                smaller = Some(smaller.map_or(rq, |s: f32| s.max(rq)));
            }
        }
        let Some(Dip { centre, face, sign }) = dip_and_face(at, r, &d, &inside) else {
            return false;
        };
        // A wall may have narrowed the hole to a lens the mask does not keep, or that shows
        // only as a smaller hole: only a face all over its place tells it is not there.
        let narrowed = r <= sight.hidden;
        // A smaller hole where the template's is: the template's hole seen through a wall on
        // one side, or partly covered, still opens its rim on the other side; one whose rim is
        // solid all round, midway between the two radii, is another part's hole (a cam's bore
        // where a hex nut's, twice as wide, should be).
        if let Some(rq) = smaller {
            let mid = 0.5 * (rq + r);
            return !narrowed
                && DIRS
                    .iter()
                    .all(|u| sign * d(at[0] + mid * u[0], at[1] + mid * u[1]) >= SOLID_KEEPS * face);
        }
        // Solid: the face at the centre and at eight points half the radius from it (a lens a
        // wall leaves open reaches one of them unless the wall all but closes the hole).
        let least = DIRS.iter().fold(centre, |m, u| {
            m.min(sign * d(at[0] + 0.5 * r * u[0], at[1] + 0.5 * r * u[1]))
        });
        if least >= SOLID_KEEPS * face {
            return true;
        }
        // A dip no deeper than the part's own shadow beside it may be the hole in that
        // shadow, which the mask then closes; a dip a wall may have narrowed, likewise.
        if narrowed || centre <= shadow(sign, r) {
            return false;
        }
        // A dip, but no hole in the mask: whether the blur could have closed one that wide.
        if !traced(r, &sight.filter) {
            return false;
        }
        if let Some(measure) = blur.take() {
            sigma = measure();
        }
        sigma.is_some_and(|s| r >= OPEN_RADII * s)
    })
}

/// Eight directions, 45° apart.
const DIRS: [[f32; 2]; 8] = {
    const D: f32 = core::f32::consts::FRAC_1_SQRT_2;
    [
        [1.0, 0.0],
        [D, D],
        [0.0, 1.0],
        [-D, D],
        [-1.0, 0.0],
        [-D, -D],
        [0.0, -1.0],
        [D, -D],
    ]
};

/// What the difference `D` shows where a hole would lie ([`dip_and_face`]), in the sense of the
/// part's face: `D` times [`Dip::sign`], so the face is positive and a shadow beside a
/// brighter part, darker than the platform, negative.
#[derive(Debug, Clone, Copy)]
struct Dip {
    /// The mean of five samples: the hole's centre and four points half its radius from it.
    centre: f32,
    /// The part's face around the hole.
    face: f32,
    /// The face's sign in `D`: +1 for a part brighter than the platform, −1 for a darker one.
    sign: f32,
}

/// What `D` (the sampler `d`, signed) shows where a hole of radius `r` px would lie at `at`
/// ([`Dip`]): the mean of five samples (the centre, and four points `r/2` from it) and the
/// part's face around it (the mean of the samples on a ring at 1.6 `r` that lie on the part:
/// at least half the largest `|D|`, so the platform beside a hole near the outline does not
/// count), both in the face's sense. `None` where that ring leaves the frame (`inside`) or
/// fewer than four of its eight samples lie on the part.
fn dip_and_face(at: [f32; 2], r: f32, d: &impl Fn(f32, f32) -> f32, inside: &impl Fn(f32, f32) -> bool) -> Option<Dip> {
    let ring = 1.6 * r;
    if !DIRS.iter().all(|u| inside(at[0] + ring * u[0], at[1] + ring * u[1])) {
        return None;
    }
    let centre = DIRS.iter().step_by(2).fold(d(at[0], at[1]), |acc, u| {
        acc + d(at[0] + 0.5 * r * u[0], at[1] + 0.5 * r * u[1])
    }) / 5.0;
    let samples = DIRS.map(|u| d(at[0] + ring * u[0], at[1] + ring * u[1]));
    let top = samples.iter().fold(0.0f32, |m, &v| m.max(v.abs()));
    let (sum, count) = samples
        .iter()
        .filter(|&&v| v.abs() >= 0.5 * top)
        .fold((0.0f32, 0u32), |(s, c), &v| (s + v, c + 1));
    if count < 4 || !(top > 0.0) {
        return None;
    }
    let face = sum / count as f32;
    let sign = if face < 0.0 { -1.0 } else { 1.0 };
    Some(Dip {
        centre: sign * centre,
        face: sign * face,
        sign,
    })
}

/// How deep the part dips where `template`'s holes lie at `pose`: the mean, over its holes that
/// are [`resolvable`] at the pose's scale and whose surroundings the frame shows (a ring at 1.6
/// radii inside it, at least half of it on the part), of the share of the face around a hole
/// that `D` (the sampler `d`, signed; read in the face's sense) keeps over it, five samples at its centre and halfway to its
/// edge (near 0 over a hole, near 1 over solid face). `None` without such a hole. It tells a
/// fit from its half turn where the template's holes are too small for the mask to trace (a
/// pin's end-hole): the turn whose holes lie on the part's dips is the part's.
///
/// ```
/// use vorl_core::pose::holes::{hole_dip, Hole, Holes};
/// use vorl_core::pose::refine::Pose;
/// let mut template = Holes::new();
/// template.insert(Hole { centre: [20.0, 0.0], area: 50.0 }); // an end-hole, radius 4 px
/// let pin = |x: f32, y: f32| if (x - 70.0).hypot(y - 50.0) < 4.0 { 0.0 } else { 60.0 };
/// let inside = |_x: f32, _y: f32| true;
/// let right = Pose { x: 50.0, y: 50.0, angle: 0.0, scale: 1.0 };
/// let turned = Pose { angle: core::f32::consts::PI, ..right };
/// assert!(hole_dip(&template, &right, pin, inside).unwrap() < 0.5);
/// assert!(hole_dip(&template, &turned, pin, inside).unwrap() > 0.9);
/// ```
pub fn hole_dip(
    template: &Holes,
    pose: &Pose,
    d: impl Fn(f32, f32) -> f32,
    inside: impl Fn(f32, f32) -> bool,
) -> Option<f32> {
    let scale = pose.scale;
    let (sum, count) = template
        .as_slice()
        .iter()
        .filter_map(|h| {
            let area = h.area * scale * scale;
            if !resolvable(area) {
                return None;
            }
            let dip = dip_and_face(pose.apply(h.centre), radius(area), &d, &inside)?;
            Some(dip.centre / dip.face)
        })
        .fold((0.0f32, 0u32), |(s, c), v| (s + v, c + 1));
    (count > 0).then(|| sum / count as f32)
}

/// Whether the frame's tracing keeps template hole `h` at `scale`: its border passes `filter`
/// with the edge [`HOLE_EDGE`] inside (a smaller hole leaves no hole in the mask's traced
/// borders, however clearly the frame shows it).
pub fn traceable(h: &Hole, scale: f32, filter: &BorderFilter) -> bool {
    traced(radius(h.area * scale * scale), filter)
}

/// How many of `template`'s holes at `pose` that `counts` asks about, that the tracing cannot
/// keep ([`traceable`]: not at the pose's scale) and that no part hole lies within reach of
/// (see the module doc), the part still shows: `D` (the sampler `d`, signed; read in the
/// face's sense) at the hole's centre
/// and halfway to its edge below [`SOLID_KEEPS`] of the face around it (a ring at 1.6 radii,
/// inside the frame by `inside`), as a hole the blur nearly closes leaves it, and its mean on
/// the circle of `1/√`[`HOLE_AREA_RATIO`] of the hole's radius below half the face: the dip is
/// as wide as a hole that would be found for this one (a smaller hole there, another part's,
/// is not it). A hole whose surroundings the frame does not show is not counted. The partial
/// search holds a part of a blob to its template's holes: a traced hole each for those the
/// tracing keeps, this dip for the others (a pin's end-hole, which also tells the pin's ends
/// apart).
///
/// ```
/// use vorl_core::borders::contour::BorderFilter;
/// use vorl_core::pose::holes::{untraced_shown, Hole, Holes};
/// use vorl_core::pose::refine::Pose;
/// let mut template = Holes::new();
/// template.insert(Hole { centre: [20.0, 0.0], area: 50.0 }); // an end-hole, radius 4 px
/// let filter = BorderFilter { min_points: 16, min_area: 64.0 };
/// let pose = Pose { x: 50.0, y: 50.0, angle: 0.0, scale: 1.0 };
/// let inside = |_x: f32, _y: f32| true;
/// let all = |_h: &Hole| true;
/// let pin = |x: f32, y: f32| if (x - 70.0).hypot(y - 50.0) < 4.0 { 0.0 } else { 60.0 };
/// assert_eq!(untraced_shown(&template, &pose, &Holes::new(), &filter, pin, inside, all), 1);
/// // Half a turn on, the hole's place is solid.
/// let turned = Pose { angle: core::f32::consts::PI, ..pose };
/// assert_eq!(untraced_shown(&template, &turned, &Holes::new(), &filter, pin, inside, all), 0);
/// // A hole of 2.5 px there, not 4 px: another part's (its centre dips as deep).
/// let other = |x: f32, y: f32| if (x - 70.0).hypot(y - 50.0) < 2.5 { 0.0 } else { 60.0 };
/// assert_eq!(untraced_shown(&template, &pose, &Holes::new(), &filter, other, inside, all), 0);
/// ```
pub fn untraced_shown(
    template: &Holes,
    pose: &Pose,
    part: &Holes,
    filter: &BorderFilter,
    d: impl Fn(f32, f32) -> f32,
    inside: impl Fn(f32, f32) -> bool,
    counts: impl Fn(&Hole) -> bool,
) -> usize {
    let scale = pose.scale;
    template
        .as_slice()
        .iter()
        .filter(|h| counts(h) && !traceable(h, scale, filter))
        .filter(|h| {
            let at = pose.apply(h.centre);
            let reach = reach(h, scale);
            let near = part.as_slice().iter().any(|q| {
                let (dx, dy) = (q.centre[0] - at[0], q.centre[1] - at[1]);
                dx * dx + dy * dy <= reach * reach
            });
            let r = radius(h.area * scale * scale);
            // As wide as a hole that would be found for it: the lower end of HOLE_AREA_RATIO's
            // band, where the half-contrast edge of the smallest such hole lies.
            let rim = r / crate::math::sqrt(HOLE_AREA_RATIO);
            !near
                && dip_and_face(at, r, &d, &inside).is_some_and(|dip| {
                    let around = DIRS
                        .iter()
                        .map(|u| dip.sign * d(at[0] + rim * u[0], at[1] + rim * u[1]))
                        .sum::<f32>();
                    dip.centre < SOLID_KEEPS * dip.face && around < 0.5 * dip.face * DIRS.len() as f32
                })
        })
        .count()
}

/// How many times the frame's edge blur σ a hole's radius must be for the blur to leave it
/// open in the mask ([`solid_where_a_hole_is`]): a disc of platform of radius `r` blurred by a
/// Gaussian of σ keeps `exp(−r²/2σ²)` of the face's contrast at its centre, 1.1 % at 3σ, below
/// any threshold the mask uses short of 1/90 of the contrast.
pub const OPEN_RADII: f32 = 3.0;

/// What a frame can show of a template's hole in a part ([`solid_where_a_hole_is`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sight {
    /// The widest wall a thick part's side may show inside a hole, px (the caller's bound): it
    /// may close a hole whose radius is half of it or less, and narrow one whose radius is up
    /// to it.
    pub hidden: f32,
    /// The border filter of the frame's tracing ([`crate::Params::filter`]): a hole whose
    /// border it drops never reaches the recognizer.
    pub filter: BorderFilter,
}

/// Whether a hole of radius `r` px leaves a border that `filter` keeps with its edge
/// [`HOLE_EDGE`] inside: a disc of radius `ρ = r − HOLE_EDGE`, of area `πρ²`, whose
/// 8-connected border has about `4√2·ρ` points.
fn traced(r: f32, filter: &BorderFilter) -> bool {
    let rho = r - HOLE_EDGE;
    rho > 0.0
        && core::f32::consts::PI * rho * rho >= filter.min_area
        && 4.0 * core::f32::consts::SQRT_2 * rho >= filter.min_points as f32
}

/// Most outline points [`edge_blur`] samples.
pub const BLUR_PROFILES: usize = 16;

/// Half the length of each profile of [`edge_blur`], px: both plateaus of a step blurred by up
/// to σ = 2 px lie within it (3σ each side).
const BLUR_REACH: f32 = 6.0;

/// The step between the samples of a profile of [`edge_blur`], px.
const BLUR_STEP: f32 = 0.5;

/// The blur of the frame's edges, σ px, from `|D|` (`d`, a sub-pixel sampler) across an
/// outline: `points` of it (each a frame position and a unit normal, either way; at most
/// [`BLUR_PROFILES`] of the `count` used, spread evenly). Along each normal, from the highest
/// value on the face's side to the lowest on the other, how far the difference takes to fall
/// from ¾ to ¼ of the way, which for a step blurred by a Gaussian of σ is `2 · 0.674 · σ`; the
/// median over the profiles (a corner, a touching neighbour or a shadow spoil a few). `None`
/// when no profile shows a fall. A blur above 2 px σ is measured low: its profiles end before
/// its plateaus ([`BLUR_PROFILES`] profiles of ±6 px).
///
/// ```
/// use vorl_core::pose::holes::edge_blur;
/// // A vertical edge at x = 20 blurred linearly over 4 px (x 18 → 22): the ¾-to-¼ fall
/// // takes 2 px, σ ≈ 1.48 px.
/// let d = |x: f32, _y: f32| (80.0 * (22.0 - x) / 4.0).clamp(0.0, 80.0);
/// let points = (0..8).map(|i| ([20.0, 10.0 + i as f32], [1.0, 0.0]));
/// let s = edge_blur(points, 8, d).unwrap();
/// assert!((s - 2.0 / 1.349).abs() < 0.05, "{s}");
/// ```
pub fn edge_blur(
    points: impl Iterator<Item = ([f32; 2], [f32; 2])>,
    count: usize,
    d: impl Fn(f32, f32) -> f32,
) -> Option<f32> {
    const N: usize = (2.0 * BLUR_REACH / BLUR_STEP) as usize + 1;
    let every = count.div_ceil(BLUR_PROFILES).max(1);
    let mut widths = [0.0f32; BLUR_PROFILES];
    let mut len = 0;
    for (p, n) in points.step_by(every).take(BLUR_PROFILES) {
        let mut f = [0.0f32; N];
        for (k, v) in f.iter_mut().enumerate() {
            let t = k as f32 * BLUR_STEP - BLUR_REACH;
            *v = d(p[0] + t * n[0], p[1] + t * n[1]);
        }
        // From the face's side out.
        if f.first() < f.last() {
            f.reverse();
        }
        if let (Some(w), Some(slot)) = (fall_width(&f), widths.get_mut(len)) {
            *slot = w * BLUR_STEP;
            len += 1;
        }
    }
    let widths = widths.get_mut(..len)?;
    let w = crate::math::select_nth(widths, len.checked_sub(1)? / 2)?;
    Some(w / (2.0 * 0.674_49))
}

/// How many profiles [`shade`] reads.
pub const SHADE_PROFILES: usize = 32;

/// Where [`shade`]'s profiles start outside the outline, px: the face's own edge, blurred by
/// σ ≤ 1 px, has fallen below 0.2 % of its contrast there, so what is left is beside the part.
pub const SHADE_START: f32 = 3.0;

/// How dark the part's own shadow beside it is, in the face's sense: along outward normals of
/// the part's outline (`points`, each a frame position and its unit outward normal; at most
/// [`SHADE_PROFILES`] of the `count` used, spread evenly), the largest of the difference `d`
/// (signed so that the face is positive) from [`SHADE_START`] to `reach` px outside, then
/// the profile at seven eighths of the way up: a front light's shadow lies along one side of
/// the part, and a neighbour within reach over an eighth of the outline does not count. Never
/// below 0 (a bright part's shadow, darker than the platform, is of the other sense).
///
/// ```
/// use vorl_core::pose::holes::shade;
/// // A disc of radius 20 at (50, 50) and, on its right, a shadow 30 deep out to 6 px.
/// let d = |x: f32, y: f32| {
///     let r = (x - 50.0).hypot(y - 50.0);
///     if r < 20.0 { 80.0 } else if r < 26.0 && x > 50.0 { 30.0 } else { 0.0 }
/// };
/// let outline = (0..64).map(|k| {
///     let a = k as f32 * core::f32::consts::TAU / 64.0;
///     ([50.0 + 20.0 * a.cos(), 50.0 + 20.0 * a.sin()], [a.cos(), a.sin()])
/// });
/// assert_eq!(shade(outline, 64, 12.0, d), 30.0);
/// ```
pub fn shade(
    points: impl Iterator<Item = ([f32; 2], [f32; 2])>,
    count: usize,
    reach: f32,
    d: impl Fn(f32, f32) -> f32,
) -> f32 {
    let every = count.div_ceil(SHADE_PROFILES).max(1);
    let mut tops = [0.0f32; SHADE_PROFILES];
    let mut len = 0;
    for (p, n) in points.step_by(every).take(SHADE_PROFILES) {
        let mut top = 0.0f32;
        let mut t = SHADE_START;
        while t <= reach {
            top = top.max(d(p[0] + t * n[0], p[1] + t * n[1]));
            t += 1.0;
        }
        if let Some(slot) = tops.get_mut(len) {
            *slot = top;
            len += 1;
        }
    }
    let Some(tops) = tops.get_mut(..len) else {
        return 0.0;
    };
    crate::math::select_nth(tops, (7 * len / 8).min(len.saturating_sub(1))).unwrap_or(0.0)
}

/// Along a profile `f` from inside out: from the highest value of its inner half to the lowest
/// of its outer half, the distance (in samples, interpolated) between where it falls below ¾
/// and below ¼ of the way. `None` without a fall.
fn fall_width(f: &[f32]) -> Option<f32> {
    let half = f.len() / 2;
    let (peak, top) =
        f.get(..=half)?.iter().enumerate().fold(
            (0, f32::NEG_INFINITY),
            |(i, m), (k, &v)| if v > m { (k, v) } else { (i, m) },
        );
    let low = f.get(half..)?.iter().fold(f32::INFINITY, |m, &v| m.min(v));
    if !(top > low) {
        return None;
    }
    let cross = |level: f32| {
        let mut prev = top;
        for (k, &v) in f.iter().enumerate().skip(peak + 1) {
            if v < level {
                return Some(k.saturating_sub(1) as f32 + (prev - level) / (prev - v));
            }
            prev = v;
        }
        None
    };
    let (hi, lo) = (low + 0.75 * (top - low), low + 0.25 * (top - low));
    Some(cross(lo)? - cross(hi)?)
}

/// The pose that puts `template`'s two largest holes (centres as offsets from its area
/// centroid) onto two of `part`'s holes: of every ordered pair of part holes, the one whose
/// areas fit the template holes' (scaled by the pair's spacing) best, each within
/// [`HOLE_AREA_RATIO`]. `None` for a template with fewer than two holes, or no pair that fits.
/// Angles as [`Pose`]: counter-clockwise on screen.
pub fn pose_from_holes(template: &Holes, part: &Holes) -> Option<Pose> {
    let (h0, h1) = match template.as_slice() {
        [a, b, ..] => (*a, *b),
        _ => return None,
    };
    let u = [h1.centre[0] - h0.centre[0], h1.centre[1] - h0.centre[1]];
    let len_u = crate::math::sqrt(u[0] * u[0] + u[1] * u[1]);
    if !(len_u > 0.0) {
        return None;
    }
    let misfit = |a: f32, b: f32| {
        let r = a / b;
        if r >= 1.0 {
            r
        } else {
            1.0 / r
        }
    };
    let mut best: Option<(f32, Pose)> = None;
    for (i, p0) in part.as_slice().iter().enumerate() {
        for (j, p1) in part.as_slice().iter().enumerate() {
            if i == j {
                continue;
            }
            let v = [p1.centre[0] - p0.centre[0], p1.centre[1] - p0.centre[1]];
            let scale = crate::math::sqrt(v[0] * v[0] + v[1] * v[1]) / len_u;
            let (f0, f1) = (
                misfit(p0.area, h0.area * scale * scale),
                misfit(p1.area, h1.area * scale * scale),
            );
            let cost = f0 * f1;
            if !(f0 <= HOLE_AREA_RATIO && f1 <= HOLE_AREA_RATIO) || best.is_some_and(|(b, _)| !(cost < b)) {
                continue;
            }
            // Screen angles (y down, counter-clockwise positive) of both spacings.
            let angle = crate::math::atan2(-v[1], v[0]) - crate::math::atan2(-u[1], u[0]);
            let turned = Pose {
                x: 0.0,
                y: 0.0,
                angle,
                scale,
            }
            .apply(h0.centre);
            let pose = Pose {
                x: p0.centre[0] - turned[0],
                y: p0.centre[1] - turned[1],
                angle,
                scale,
            };
            best = Some((cost, pose));
        }
    }
    best.map(|(_, p)| p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `|D|` of a straight edge through (`x0`, ·) with the part on its left, contrast 80,
    /// blurred by a Gaussian of `sigma` px: `40·(1 − erf((x − x0)/(σ√2)))`.
    fn blurred_edge(x0: f32, sigma: f32) -> impl Fn(f32, f32) -> f32 {
        move |x, _y| 40.0 * (1.0 - libm::erff((x - x0) / (sigma * core::f32::consts::SQRT_2)))
    }

    #[test]
    fn edge_blur_recovers_a_gaussian_blur() {
        for sigma in [0.7f32, 1.0, 2.0] {
            // Normals either way.
            for n in [[1.0, 0.0], [-1.0, 0.0]] {
                let points = (0..40).map(|i| ([30.0, i as f32], n));
                let s = edge_blur(points, 40, blurred_edge(30.0, sigma)).expect("a fall");
                assert!((s - sigma).abs() < 0.05 * sigma, "σ {sigma}: measured {s}");
            }
        }
    }

    #[test]
    fn edge_blur_takes_the_median_over_spoilt_profiles() {
        // A third of the profiles on a neighbour's flat face (no fall: left out) and two on a
        // softer stretch: the median is the edge's.
        let d = |x: f32, y: f32| {
            if y < 12.0 {
                60.0
            } else if y < 14.0 {
                blurred_edge(30.0, 3.0)(x, y)
            } else {
                blurred_edge(30.0, 1.0)(x, y)
            }
        };
        let points = (0..36).map(|i| ([30.0, i as f32], [1.0, 0.0]));
        let s = edge_blur(points, 36, d).expect("a fall");
        assert!((s - 1.0).abs() < 0.05, "{s}");
    }

    #[test]
    fn edge_blur_without_a_fall_is_none() {
        let points = (0..8).map(|i| ([30.0, i as f32], [1.0, 0.0]));
        assert_eq!(edge_blur(points, 8, |_, _| 50.0), None);
        assert_eq!(edge_blur(core::iter::empty(), 0, |_, _| 50.0), None);
    }

    #[test]
    fn a_hole_is_traced_when_its_border_passes_the_filter() {
        let f = BorderFilter {
            min_points: 16,
            min_area: 64.0,
        };
        // ρ = r − 1.5 must give πρ² ≥ 64 (ρ ≥ 4.51) and 4√2·ρ ≥ 16 (ρ ≥ 2.83).
        assert!(!traced(5.9, &f));
        assert!(traced(6.1, &f));
        let few = BorderFilter {
            min_points: 40,
            min_area: 0.0,
        };
        // 4√2·ρ ≥ 40: ρ ≥ 7.07.
        assert!(!traced(8.5, &few));
        assert!(traced(8.6, &few));
        assert!(!traced(
            1.0,
            &BorderFilter {
                min_points: 0,
                min_area: 0.0
            }
        ));
    }

    /// A template with one bore of radius 9.8 px (area 300) at its centre, posed at (50, 50).
    fn bore_at_50() -> (Holes, Pose) {
        let mut template = Holes::new();
        template.insert(Hole {
            centre: [0.0, 0.0],
            area: 300.0,
        });
        let pose = Pose {
            x: 50.0,
            y: 50.0,
            angle: 0.0,
            scale: 1.0,
        };
        (template, pose)
    }

    #[test]
    fn a_smaller_hole_is_the_bore_only_where_the_bore_opens_its_rim() {
        // A template bore of radius 9.8 px (area 300) at the part's centre (50, 50), the face's
        // contrast 80; the tracing keeps any hole, the edges are sharp.
        let (template, pose) = bore_at_50();
        let sight = Sight {
            hidden: 0.0,
            filter: BorderFilter {
                min_points: 0,
                min_area: 0.0,
            },
        };
        let inside = |_x: f32, _y: f32| true;
        let solid = |part: &Holes, d: &dyn Fn(f32, f32) -> f32| {
            solid_where_a_hole_is(&template, &pose, part, &sight, || Some(0.5), d, inside, |_, _| 0.0)
        };
        let hole = |centre: [f32; 2], area: f32| {
            let mut h = Holes::new();
            h.insert(Hole { centre, area });
            h
        };
        // Another part's bore, half as wide, where the template's is: the face all round it.
        let small = |x: f32, y: f32| if (x - 50.0).hypot(y - 50.0) < 4.9 { 0.0 } else { 80.0 };
        assert!(solid(&hole([50.0, 50.0], 75.4), &small));
        // The template's bore seen past a wall on its right that leaves only its left 3.6 px
        // open: the mask's hole is a segment of 41 px² (a radius of 3.6 px as a disc's),
        // 7.6 px off the bore's centre, but the bore's rim is open on its left.
        let walled = |x: f32, y: f32| {
            if (x - 50.0).hypot(y - 50.0) < 9.8 && x < 44.0 {
                0.0
            } else {
                80.0
            }
        };
        assert!(!solid(&hole([42.4, 50.0], 41.1), &walled));
        // A hole of a size the bore could be found at is its trace, whatever the face shows.
        assert!(!solid(&hole([50.0, 50.0], 160.0), &small));
    }

    /// A wall of a thick part may close a hole only where it is twice the hole's radius wide,
    /// and narrow a wider one: the face all over a hole's place vetoes it however wide a wall
    /// the alignment admits, unless that wall could close the hole; a dip there does not.
    #[test]
    fn only_a_wall_twice_a_holes_radius_wide_may_close_it() {
        // A template bore of radius 9.8 px at the part's centre (50, 50), the face's contrast 80.
        let (template, pose) = bore_at_50();
        let solid = |hidden: f32, d: &dyn Fn(f32, f32) -> f32| {
            let sight = Sight {
                hidden,
                filter: BorderFilter {
                    min_points: 0,
                    min_area: 0.0,
                },
            };
            let inside = |_x: f32, _y: f32| true;
            solid_where_a_hole_is(
                &template,
                &pose,
                &Holes::new(),
                &sight,
                || Some(0.5),
                d,
                inside,
                |_, _| 0.0,
            )
        };
        let face = |_x: f32, _y: f32| 80.0;
        // Walls up to 12 px admitted: one 12 px wide cannot close a bore of 9.8 px radius.
        assert!(solid(12.0, &face));
        // Up to 20 px: it could.
        assert!(!solid(20.0, &face));
        // A lens 6.8 px wide left open on the bore's right (it reaches a sample half the
        // radius out): a 12 px wall may have narrowed the bore to it.
        let lens = |x: f32, y: f32| {
            if (x - 50.0).hypot(y - 50.0) < 9.8 && x > 53.0 {
                0.0
            } else {
                80.0
            }
        };
        assert!(!solid(12.0, &lens));
        // Without a wall, a bore that wide would show in the mask: the lens is another thing.
        assert!(solid(0.0, &lens));
    }
}
