//! The whole pipeline on one frame: mask → borders → descriptors → match → pose → detections.
//!
//! A [`Recognizer`] owns every buffer except the two frame-sized planes (the background model and
//! the label plane), which the caller places where it likes (on a camera: `static`s in RAM,
//! with the frame itself in flash or a DMA buffer). Its capacities are const generics, so its
//! size is known at compile time and `vorl budget` can add it up:
//!
//! | parameter | meaning | bytes (32-bit) |
//! |---|---|---|
//! | `T` | templates in the library | `T·(32·M + 156)` |
//! | `M` | points of a template (≥ `m`, and ≥ `n`) | part buffers `22·M`, and one template (the mirror image a part upside down is matched against) |
//! | `P` | border points stored per frame | `4·P` |
//! | `C` | borders kept per frame | `32·C + 16` |
//! | `D` | DP table cells, ≥ `n·(m − n + 1)` | `4·D` |
//!
//! (`crate::budget` has the exact formulas for any target.) Each kept outer border is a part:
//! resampled to `n` points and described; every template is bounded by
//! [`crate::shape::matching::sorted_lower_bound`], and the templates are searched by the cyclic DP in
//! ascending order of that bound.
//!
//! - With the default `refine = Verify`, each search is bounded by `candidate_ratio` (1 by
//!   default) times the lowest DP cost of the templates before it, and the templates that come in
//!   are the candidates (at most `candidates`): each is aligned on the frame from its DP pose
//!   and verified, the lowest verification score wins and is the class when below
//!   `verify_threshold`. The bound order puts the right template first for nearly all of the
//!   generated sets' parts (all but some of the small and cut parts), so a known part usually
//!   costs one search and one alignment; the further candidates are the steps towards the DP's
//!   best, and guard the parts whose bound order the descriptor gets wrong. Before this order
//!   the DP's three best templates were verified (an exact search of every template the bound
//!   could not rule out): the same classes on every generated set, at more searches and
//!   alignments per part (`docs/performance.md`).
//! - On the paper's path (`refine = Off`, and `Pose`) the searches are bounded by the best cost
//!   so far until the bound rules the rest out (exact: the DP's best template, as searching
//!   all); it is the class when `f' < ε`.
//! - Upside down ([`Params::flipped_parts`], on by default): every chiral template
//!   ([`Template::is_chiral`]) has a second place in the scan for its mirror image, with the same
//!   bounds (its descriptor values are the same, in reverse order), built on demand into one
//!   scratch template. After its template was searched it comes in only below [`MIRROR_GAIN`]
//!   of that cost; a mirror image that wins is held against its template, and the upside-down
//!   reading needs clear evidence ([`FLIP_EVIDENCE`], on the mean distance over every point);
//!   an accepted fit that is not confident, or whose outline is off over a stretch
//!   ([`STRETCH_OFF`]), has its other side aligned too. A part touching the frame's edge is
//!   never matched upside down (its cost: `docs/performance.md`); every
//!   accuracy set and the real photographs keep their classes and poses (`docs/accuracy.md`).
//!
//! The rotation comes from the aligned pose (or the best template's correspondence), the
//! position from the partial-volume centroid (or the border's area centroid) — or, for a part
//! whose alignment fitted a wall (a thick part under a close lens, [`WALL_FACTOR`]), from its
//! pose, the top face's. A border that cannot be described is reported as a [`Skip`] with the
//! reason.
//!
//! The module's files, by job: this one holds the [`Recognizer`], its set-up and one frame's
//! run (each border's way through the pipeline, and the paper's path); `report.rs` what a run
//! returns ([`Report`], [`Detection`], [`Skip`]); `candidates.rs` the candidate scan of
//! `refine = Verify` (the bound order, the DP searches, the mirror images); `verdict.rs` one
//! candidate aligned, verified and judged (the verification score, the acceptance rule and
//! the constants of the decision); [`split`] the partial search of blobs that hold several
//! parts.

use crate::borders::contour::{clear_labels, trace_borders_in, BorderKind, ContourStore};
use crate::borders::resample::resample;
use crate::error::{Error, Result};
use crate::library::template::Template;
use crate::library::Library;
use crate::math;
use crate::params::{AngleEstimator, Params, Position, Refine};
use crate::pixels::background::Background;
use crate::pixels::frame::Frame;
use crate::pixels::mask::{foreground_mask_spans, Polarity, RowSpans};
use crate::pixels::shadow::{self, Beside};
use crate::pose::holes::{Hole, HoleAgreement, Holes};
use crate::pose::partial_volume::{partial_volume_moments, print_deficit, Rect};
use crate::pose::refine::{outward_normal, Difference, RefineParams};
use crate::pose::{angle_paper, angle_signed_refined, area_centroid};
use crate::recognizer::split::BLOB_POINTS;
use crate::recognizer::verdict::{accepted, Fit};
use crate::shape::arcs::ARC_ROWS;
use crate::shape::descriptor::describe;
use crate::shape::matching::table_cells;

mod candidates;
mod report;
pub mod split;
mod verdict;

pub use crate::params::MAX_CANDIDATES;
pub use crate::pose::refine::VERIFY_KEPT;
pub use candidates::{FALLBACK_RATIO, MIRROR_GAIN, NEAR_TIE_RATIO, SCALE_SLACK, STRETCH_OFF, UNVERIFIED_FAMILY};
pub use report::{Detection, Report, Skip, SkipReason, Stage, MAX_DETECTIONS, MAX_SKIPS};
pub use verdict::{
    CONFIDENT, FLIP_EVIDENCE, HALF_TURN_AMBIGUOUS, HALF_TURN_SYMMETRIC, NEAR_MISS, WALL_FACTOR, WALL_SIGNIFICANT,
};

/// The share of the thinnest taught part's thickness, at its smallest scale, below which a
/// blob holds no part ([`Report::thin`]): half, the width a part keeps when the frame's edge
/// cuts it lengthwise to the least share a cut part is searched with.
pub const THIN_SHARE: f32 = 0.5;

/// A blob below [`THIN_SHARE`] of the taught parts is print only where it is also a stroke or
/// a speck: its mean thickness under this many times the narrowest stroke the mask's clean-up
/// keeps ([`crate::pixels::mask::Cleanup::narrowest_kept`], 3 px after the default opening).
/// Print and scratches are strokes of about one width, so the opening leaves them 3–5 px
/// thick; a speck (a disc `d` px across has mean thickness `d/2`) counts under 12 px across.
/// An untaught object smaller than every taught part (a star, a crescent beside a large part)
/// is thicker, and is still looked at and reported, unknown.
pub const STROKE_WIDTHS: f32 = 2.0;

/// Most blobs of one frame whose shadow (or a darker part against them) the shadow pass
/// cuts off ([`crate::pixels::shadow::separate`]); the frame's further blobs keep theirs. Front
/// light throws a shadow beside every part, and a conveyor's frame holds a few dozen parts at
/// most: [`MAX_DETECTIONS`] of them are reported.
pub const SHADOW_BLOBS: usize = 32;

/// How much blurrier than its part's edge the edge of what lay beside it must be to be its
/// shadow ([`crate::pixels::shadow`]): √2, a penumbra at least as wide as the lens's own blur
/// (blurs add in quadrature: `σ² = σ_lens² + σ_penumbra²`). Parts' edges in one frame agree to
/// about ±10 %; a dark part against a bright one, as sharp as it, measures 0.9–1.2 times its
/// edge, a shadow 1.5–3.8 times (`docs/accuracy.md`).
pub const PENUMBRA: f32 = core::f32::consts::SQRT_2;

/// Border points per chord when a blob's perimeter is measured for its thickness: a chord over
/// 4 pixel steps follows a straight edge at any slope within a few per cent, where the steps
/// themselves would add up to 8 % more for a staircase.
pub const THIN_CHORD: usize = 4;

/// The recognizer: parameters, template library and working buffers of fixed capacity.
///
/// ```
/// use vorl_core::{pixels::background::Background, Frame, Params, Recognizer};
/// // A 60×40 platform (grey 100) with a dark 16×10 bar, taught as template 0.
/// let (w, h) = (60, 40);
/// let bg_px = vec![100u8; w * h];
/// let mut tpl = vec![0u8; w * h];
/// let mut scene = bg_px.clone();
/// for y in 15..25 { for x in 22..38 { tpl[y * w + x] = 255; scene[y * w + x] = 20; } }
/// let mut labels = vec![0u8; w * h];
/// let mut rec = Recognizer::<2, 96, 2048, 16, 4096>::new();
/// rec.set_params(Params::DEFAULT).unwrap();
/// rec.teach(&Frame::new_checked(&tpl[..], w, h).unwrap(), &mut labels).unwrap();
/// let mut bg = Background::new(vec![0u8; w * h], w, h).unwrap();
/// bg.set_from_frame(&Frame::new_checked(&bg_px[..], w, h).unwrap(), Params::DEFAULT.alpha()).unwrap();
/// let report = rec.process(&Frame::new_checked(&scene[..], w, h).unwrap(), &bg, &mut labels).unwrap();
/// let d = report.detections[0];
/// assert_eq!(d.template, Some(0));
/// assert!((d.x - 29.5).abs() < 0.01 && (d.y - 19.5).abs() < 0.01);
/// assert!(d.angle_deg < 1.0 || d.angle_deg > 359.0 || (d.angle_deg - 180.0).abs() < 1.0);
/// ```
#[derive(Debug, Clone)]
pub struct Recognizer<const T: usize, const M: usize, const P: usize, const C: usize, const D: usize> {
    pub(crate) params: Params,
    pub(crate) templates: heapless::Vec<Template<M>, T>,
    pub(crate) store: ContourStore<P, C>,
    pub(crate) points: [[f32; 2]; M],
    descriptor: [f32; M],
    assignment: [u16; M],
    table: [f32; D],
    part_edges: [[f32; 2]; M],
    /// The blur of the part's edge (σ px, [`crate::pose::holes::edge_blur`] over
    /// `part_edges`): `None` until a verification asks for it, then kept until the next part.
    part_blur: core::cell::Cell<Option<Option<f32>>>,
    /// The mirror image of template `mirror_of` ([`Template::mirrored`]), made when a part is
    /// matched against it.
    mirror: Template<M>,
    mirror_of: Option<u16>,
    /// The partial search's blob border at a template's step ([`crate::recognizer::split`]).
    pub(crate) arc_points: [[f32; 2]; BLOB_POINTS],
    /// Its turning angles (and, after the search, marks of the explained points).
    pub(crate) arc_turning: [f32; BLOB_POINTS],
    /// A template's turning angles.
    pub(crate) arc_template: [f32; M],
    /// The partial DP's rows ([`crate::shape::arcs::ARC_ROWS`] of `M` cells and one for the pads).
    pub(crate) arc_rows: [[f32; M]; ARC_ROWS + 1],
    /// Whether a blob inside the frame whose border has no junction is left whole
    /// ([`crate::recognizer::split`], "Blobs of one part"; on unless
    /// [`Self::set_junction_gate`] turned it off).
    pub(crate) junction_gate: bool,
}

impl<const T: usize, const M: usize, const P: usize, const C: usize, const D: usize> Default
    for Recognizer<T, M, P, C, D>
{
    fn default() -> Self {
        Self::new()
    }
}

impl<const T: usize, const M: usize, const P: usize, const C: usize, const D: usize> Recognizer<T, M, P, C, D> {
    /// A recognizer with [`Params::DEFAULT`] and no templates (`const`, for `static` use).
    pub const fn new() -> Self {
        Recognizer {
            params: Params::DEFAULT,
            templates: heapless::Vec::new(),
            store: ContourStore::new(),
            points: [[0.0; 2]; M],
            descriptor: [0.0; M],
            assignment: [0; M],
            table: [0.0; D],
            part_edges: [[0.0; 2]; M],
            part_blur: core::cell::Cell::new(None),
            mirror: Template::empty(),
            mirror_of: None,
            arc_points: [[0.0; 2]; BLOB_POINTS],
            arc_turning: [0.0; BLOB_POINTS],
            arc_template: [0.0; M],
            arc_rows: [[0.0; M]; ARC_ROWS + 1],
            junction_gate: true,
        }
    }

    /// Sets the parameters after checking them and the capacities; clears the templates when
    /// `m`, `k` or `ω` change (they shape the templates).
    ///
    /// # Errors
    /// [`Params::validate`]'s errors; [`Error::Capacity`] when `m > M` or the DP table needs
    /// more than `D` cells.
    pub fn set_params(&mut self, params: Params) -> Result<()> {
        params.validate()?;
        if params.m > M {
            return Err(Error::Capacity {
                what: "template points M",
                capacity: M,
                requested: params.m,
            });
        }
        let cells = table_cells(params.n, params.m);
        if cells > D {
            return Err(Error::Capacity {
                what: "DP table cells D",
                capacity: D,
                requested: cells,
            });
        }
        let p = &self.params;
        if p.m != params.m || p.k != params.k || p.n != params.n || p.omega != params.omega {
            self.templates.clear();
        }
        self.mirror_of = None;
        self.params = params;
        Ok(())
    }

    /// The parameters in use.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Adds a template; returns its index.
    ///
    /// # Errors
    /// [`Error::Capacity`] when `T` templates are held already.
    pub fn add_template(&mut self, template: Template<M>) -> Result<usize> {
        let index = self.templates.len();
        self.templates.push(template).map_err(|_| Error::Capacity {
            what: "templates T",
            capacity: T,
            requested: T + 1,
        })?;
        Ok(index)
    }

    /// Replaces the templates by `library`'s: its `n`, `m`, `k`, `ω` are set from the library
    /// (the other parameters are kept), then every template is added in order, so template
    /// index `i` is the library's record `i`. Returns the number of templates.
    ///
    /// # Errors
    /// [`Self::set_params`]'s errors (e.g. `m > M` or a DP table larger than `D`),
    /// [`Error::Capacity`] when the library holds more than `T` templates; a record that does
    /// not read as a template ([`Library::template`]).
    pub fn load_library(&mut self, library: &Library<'_>) -> Result<usize> {
        let count = library.len();
        if count > T {
            return Err(Error::Capacity {
                what: "templates T",
                capacity: T,
                requested: count,
            });
        }
        self.set_params(library.params(self.params))?;
        self.clear_templates();
        for i in 0..count {
            self.add_template(library.template::<M>(i)?)?;
        }
        Ok(count)
    }

    /// Teaches the part in a silhouette image (part > 127) as a new template; `labels` is
    /// scratch of the silhouette's size.
    ///
    /// # Errors
    /// As [`Template::from_silhouette`] and [`Self::add_template`].
    pub fn teach<B: AsRef<[u8]>>(&mut self, silhouette: &Frame<B>, labels: &mut [u8]) -> Result<usize> {
        let t = Template::from_silhouette(silhouette, &self.params, labels, &mut self.store)?;
        self.add_template(t)
    }

    /// Sets template `index`'s class tolerance ([`Template::set_tolerance`]).
    ///
    /// # Errors
    /// [`Error::Capacity`] for an index past the last template; [`Template::set_tolerance`]'s.
    pub fn set_tolerance(&mut self, index: usize, tolerance: crate::library::template::Tolerance) -> Result<()> {
        let count = self.templates.len();
        self.mirror_of = None;
        self.templates
            .get_mut(index)
            .ok_or(Error::Capacity {
                what: "templates",
                capacity: count,
                requested: index.saturating_add(1),
            })?
            .set_tolerance(tolerance)
    }

    /// The templates.
    pub fn templates(&self) -> &[Template<M>] {
        &self.templates
    }

    /// Removes every template.
    pub fn clear_templates(&mut self) {
        self.templates.clear();
        self.mirror_of = None;
    }

    /// The borders of the last processed frame (index with [`Detection::contour`]).
    pub fn contours(&self) -> &ContourStore<P, C> {
        &self.store
    }

    /// Runs one frame through the whole pipeline. `labels` (`width·height` bytes) is scratch;
    /// afterwards it holds the 0/1 foreground mask (the border labels are cleared again, inside
    /// the mask's [`RowSpans`], outside which the mask is 0).
    ///
    /// # Errors
    /// [`Error::NoBackground`], [`Error::FrameSize`] (frame and background differ),
    /// [`Error::BufferTooSmall`] for `labels`. Problems with single borders are skips, not errors.
    pub fn process<B: AsRef<[u8]>, S: AsRef<[u8]> + AsMut<[u8]>>(
        &mut self,
        frame: &Frame<B>,
        background: &Background<S>,
        labels: &mut [u8],
    ) -> Result<Report> {
        self.process_observed(frame, background, labels, |_| {})
    }

    /// [`Self::process`], calling `observe` as each [`Stage`] ends (to time the stages on a
    /// camera). With a closure that does nothing it compiles to the same code as `process`.
    ///
    /// # Errors
    /// As [`Self::process`].
    pub fn process_observed<B: AsRef<[u8]>, S: AsRef<[u8]> + AsMut<[u8]>, F: FnMut(Stage)>(
        &mut self,
        frame: &Frame<B>,
        background: &Background<S>,
        labels: &mut [u8],
        mut observe: F,
    ) -> Result<Report> {
        let params = self.params;
        let (w, h) = (frame.width(), frame.height());
        // Where each row of the mask holds foreground: border following scans only there, and
        // only there can it leave labels.
        let mut spans = RowSpans::new();
        let mask = foreground_mask_spans(
            frame,
            background,
            params.alpha(),
            params.threshold,
            params.polarity,
            params.cleanup,
            labels,
            &mut spans,
        )?;
        observe(Stage::Mask);
        let mut trace = trace_borders_in(labels, w, h, &spans, params.filter(), &mut self.store)?;
        // From here on the label plane is the plain 0/1 mask (the shadow pass and the
        // partial-volume centroid use its other bits as scratch and clear them again).
        clear_labels(labels, w, h, &spans);
        // Taking both signs, a bright part's blob with darker pixels beside its extent holds
        // its shadow (or a darker part against it): cut off the part, and the borders are
        // followed again (pixels/shadow.rs).
        let mut mask = mask;
        // Each cut, with the blur of its part's edge.
        let mut beside: heapless::Vec<(Beside, Option<f32>), SHADOW_BLOBS> = heapless::Vec::new();
        let diff = Difference::new(frame, background.plane(), params.alpha());
        if params.polarity == Polarity::Either {
            for index in 0..self.store.contours().len() {
                if beside.is_full() {
                    break;
                }
                if self
                    .store
                    .contours()
                    .get(index)
                    .is_some_and(|c| c.kind == BorderKind::Outer)
                {
                    let outline = self.store.points(index).iter().map(|p| (p.x as usize, p.y as usize));
                    let d = |x: usize, y: usize| diff.at(x as isize, y as isize);
                    if let Some(cut) = shadow::separate(labels, w, h, outline, mask.threshold, d) {
                        mask.foreground = mask.foreground.saturating_sub(cut.taken as usize);
                        // (The border is the blob's before the cut: the part's edge on it is.)
                        let blur = self.outline_blur(index, &diff, mask.threshold, true);
                        // (Not full: checked above.)
                        let _ = beside.push((cut, blur));
                    }
                }
            }
            if !beside.is_empty() {
                trace = trace_borders_in(labels, w, h, &spans, params.filter(), &mut self.store)?;
                clear_labels(labels, w, h, &spans);
            }
        }
        observe(Stage::Borders);
        let mut report = Report {
            mask,
            trace,
            shadows: beside.len(),
            ..Report::default()
        };
        // Only a blob thinner than a stroke needs the templates' bound, worked out once.
        let stroke = STROKE_WIDTHS * params.cleanup.narrowest_kept();
        let mut thinnest_part: Option<f32> = None;
        for index in 0..self.store.contours().len() {
            let Some(contour) = self.store.contours().get(index).copied() else {
                continue;
            };
            if contour.kind != BorderKind::Outer {
                continue;
            }
            // Inside a hole of another part (its parent is a hole border).
            let in_hole = contour
                .parent
                .and_then(|p| self.store.contours().get(p as usize))
                .is_some_and(|p| p.kind == BorderKind::Hole);
            if in_hole && !self.params.nested_parts {
                report.skip(index, SkipReason::InsideHole);
                continue;
            }
            // Print, scratches, threads: thinner than any taught part could be, even half of
            // one at its smallest scale. Counted, not looked at, and no part's place taken.
            let thickness = self.blob_thickness(index);
            if thickness < stroke && thickness < *thinnest_part.get_or_insert_with(|| self.thinnest_part()) {
                report.thin += 1;
                continue;
            }
            // A full report takes no more parts: those are not worked out, only counted.
            if report.detections.is_full() {
                report.skip(index, SkipReason::TooManyParts);
                continue;
            }
            match self.part(index, frame, background.plane()) {
                // What lay beside a part, that no template explains: its shadow.
                Ok((detection, _))
                    if detection.template.is_none()
                        && self.lay_beside(index, &beside, &diff, report.mask.threshold) =>
                {
                    report.skip(index, SkipReason::Shadow);
                }
                Ok((mut detection, centroid_wanted)) => {
                    // A whole-border match that failed: the parts along the blob's border.
                    // Or one that explains too little of its blob: a part accepted on a blob
                    // that holds more (another part touching it) than its template covers.
                    let split = params.touching_parts
                        && params.refine == Refine::Verify
                        && self.blob_not_explained(&detection)
                        && self.split_into(index, frame, background.plane(), &detection, &mut report);
                    if !split {
                        // The partial-volume centroid only for a blob whose whole-border
                        // result stands: the partial search places its parts by their poses.
                        if let Some(part_holes) = centroid_wanted {
                            self.partial_volume_position(
                                index,
                                frame,
                                background.plane(),
                                labels,
                                &part_holes,
                                &mut detection,
                            );
                        }
                        if report.detections.push(detection).is_err() {
                            report.skip(index, SkipReason::TooManyParts);
                        }
                    }
                }
                Err(reason) => report.skip(index, reason),
            }
        }
        observe(Stage::Parts);
        Ok(report)
    }

    /// Whether outer border `index` is what lay beside a part before the shadow pass cut it off
    /// ([`Beside::holds`]: in its box, its outline mostly darker than the platform beyond
    /// `tau`), and a shadow: its edge against the platform blurrier than its part's by
    /// [`PENUMBRA`] or more ([`Self::outline_blur`]). A dark part against a bright one has an
    /// edge as sharp as the part's, and is looked at as any blob is. Where either blur cannot
    /// be measured, what lay beside is taken for a shadow.
    fn lay_beside<B: AsRef<[u8]>>(
        &self,
        index: usize,
        beside: &[(Beside, Option<f32>)],
        diff: &Difference<'_, B>,
        tau: u8,
    ) -> bool {
        let border = self.store.points(index);
        let Some(first) = border.first() else {
            return false;
        };
        let t = f32::from(tau);
        let (mut brighter, mut darker) = (0usize, 0usize);
        for p in border {
            let d = diff.at(p.x as isize, p.y as isize);
            brighter += usize::from(d > t);
            darker += usize::from(d < -t);
        }
        let Some((_, part)) = beside
            .iter()
            .find(|(b, _)| b.holds(first.x as usize, first.y as usize, brighter, darker))
        else {
            return false;
        };
        match (self.outline_blur(index, diff, tau, false), part) {
            (Some(own), Some(part)) => own >= PENUMBRA * part,
            _ => true,
        }
    }

    /// The blur of the frame's edge (σ px, [`crate::pose::holes::edge_blur`]) along outer
    /// border `index` where it bounds a face brighter than the platform beyond `tau`
    /// (`brighter`) or darker: at its points of that sign with none of the other within 2 px
    /// (not where a part and what lay beside it met), across the normal of the chord over
    /// four border steps. `None` where no such point shows a fall.
    fn outline_blur<B: AsRef<[u8]>>(
        &self,
        index: usize,
        diff: &Difference<'_, B>,
        tau: u8,
        brighter: bool,
    ) -> Option<f32> {
        let points = self.store.points(index);
        let n = points.len();
        let (t, sign) = (f32::from(tau), if brighter { 1.0 } else { -1.0 });
        let edge = |i: &usize| {
            points.get(*i).is_some_and(|p| {
                let (x, y) = (p.x as isize, p.y as isize);
                sign * diff.at(x, y) > t && (-2..=2).all(|dy| (-2..=2).all(|dx| -sign * diff.at(x + dx, y + dy) <= t))
            })
        };
        let count = (0..n).filter(edge).count();
        let profiles = (0..n).filter(edge).filter_map(|i| {
            let (a, b, p) = (points.get((i + n - 2) % n)?, points.get((i + 2) % n)?, points.get(i)?);
            let (tx, ty) = (f32::from(b.x) - f32::from(a.x), f32::from(b.y) - f32::from(a.y));
            let len = math::sqrt(tx * tx + ty * ty);
            (len > 0.0).then(|| ([f32::from(p.x), f32::from(p.y)], [-ty / len, tx / len]))
        });
        crate::pose::holes::edge_blur(profiles, count, |x, y| diff.bilinear(x, y).abs())
    }

    /// The least mean thickness (`2·area / perimeter`, [`Template::thickness`]) a blob must
    /// have to hold a taught part: half the thinnest template's thickness at the smallest
    /// scale its class may be seen at (the parameters' range, or the class's own). 0 without
    /// templates.
    ///
    /// A blob is a stroke of print (a scratch, a thread), counted in [`Report::thin`] and not
    /// looked at, when it is below both this bound and [`STROKE_WIDTHS`] times the narrowest
    /// stroke the mask keeps:
    ///
    /// - half, because a part cut lengthwise by the frame's edge to the least share the search
    ///   accepts (half of it) keeps half its width; a whole part, or one cut across, keeps all
    ///   of it, and a part touching another lies in a thicker blob. So no taught part is lost
    ///   to the rule;
    /// - a blob thicker than a stroke is an object, and an object no template can be is still
    ///   looked at and reported, unknown.
    ///
    /// `docs/accuracy.md`, "Parts over half of the frame, on printed paper", has the figures.
    fn thinnest_part(&self) -> f32 {
        let p = &self.params;
        let least = self
            .templates
            .iter()
            .map(|t| t.thickness() * t.tolerance().scale_range(p.scale_min, p.scale_max).0)
            .fold(f32::INFINITY, f32::min);
        if least.is_finite() {
            THIN_SHARE * least
        } else {
            0.0
        }
    }

    /// The mean thickness of outer border `index` (`2·area / perimeter`), its perimeter
    /// measured along chords of [`THIN_CHORD`] border points, so that the pixel border's
    /// staircase does not lengthen it; infinite for a border without points.
    fn blob_thickness(&self, index: usize) -> f32 {
        let Some(contour) = self.store.contours().get(index) else {
            return f32::INFINITY;
        };
        let border = self.store.points(index);
        if border.is_empty() {
            return f32::INFINITY;
        }
        let along = border.iter().step_by(THIN_CHORD);
        let perimeter = math::perimeter(along.map(|p| [f32::from(p.x), f32::from(p.y)]));
        if perimeter > 0.0 {
            2.0 * contour.area() / perimeter
        } else {
            0.0
        }
    }

    /// One outer border (store index `index`) through resampling, description, matching,
    /// alignment, verification and the position from the pose where it is the pose's; with
    /// the part's holes where its position is the partial-volume centroid's
    /// ([`Self::partial_volume_position`], left to the caller: after the partial search, only
    /// for a blob whose whole-border result stands; until then it is the border's area
    /// centroid).
    fn part<B: AsRef<[u8]>>(
        &mut self,
        index: usize,
        frame: &Frame<B>,
        background: &[u8],
    ) -> core::result::Result<(Detection, Option<Holes>), SkipReason> {
        let params = self.params;
        let n = params.n;
        let contour = self
            .store
            .contours()
            .get(index)
            .copied()
            .ok_or(SkipReason::Degenerate)?;
        let border = self.store.points(index);
        let holes = self.store.holes_of(index).map(|i| self.store.points(i));
        let [x, y] = area_centroid(border, holes).ok_or(SkipReason::NoArea)?;
        let part_holes = Holes::from_borders(self.store.holes_of(index).map(|i| self.store.points(i)), 0.0);
        let points = self.points.get_mut(..n).unwrap_or(&mut []);
        let descriptor = self.descriptor.get_mut(..n).unwrap_or(&mut []);
        let centroid = resample(border, points)
            .and_then(|_| describe(points, params.descriptor(n), descriptor))
            .map_err(|_| SkipReason::Degenerate)?;
        let mut detection = Detection {
            template: None,
            best_template: None,
            score: f32::INFINITY,
            x,
            y,
            polygon_centroid: [x, y],
            angle_deg: 0.0,
            angle_paper_deg: 0.0,
            angle_dp_deg: 0.0,
            verify: f32::INFINITY,
            verify_limit: params.verify_threshold,
            scale: 1.0,
            pose: None,
            holes: HoleAgreement::default(),
            contour: index as u16,
            area: contour.area(),
            touches_edge: contour.touches_edge,
            flipped: false,
            searches: 0,
            touching: false,
            visible_fraction: 1.0,
            position_from_pose: false,
        };
        let diff = Difference::new(frame, background, params.alpha());
        let best_fit = if params.refine == Refine::Verify {
            // A candidate whose alignment finds it this far off would not be verified (half
            // the distance alone reaches the threshold); a part cut by the frame's edge
            // converges slowly, so its alignments never give up.
            let refine_params = RefineParams {
                give_up: if contour.touches_edge {
                    f32::INFINITY
                } else {
                    2.0 * params.verify_threshold
                },
                ..RefineParams::DEFAULT
            };
            self.verify_candidates(
                n,
                centroid,
                [x, y],
                contour.area(),
                contour.area2 < 0,
                &part_holes,
                &diff,
                &refine_params,
                &mut detection,
            )
        } else {
            self.dp_best(
                n,
                centroid,
                [x, y],
                contour.area(),
                contour.area2 < 0,
                &part_holes,
                &diff,
                &mut detection,
            )
        };
        let mut walled = false;
        if let Some((slot, fit)) = best_fit {
            let ti = slot / 2;
            let pose = fit.pose;
            detection.angle_deg = math::wrap_degrees(math::degrees(pose.angle));
            detection.scale = pose.scale;
            detection.pose = Some(pose);
            if params.refine == Refine::Verify {
                detection.template = accepted(fit).then_some(ti as u16);
            }
            // A part that shows its walls: its pose is its top face's, which the silhouette's
            // centroid (walls and bottom included) is not.
            walled = fit.wall > WALL_SIGNIFICANT && detection.template.is_some();
            if params.position == Position::Pose || (walled && params.position == Position::PartialVolume) {
                if let Some(t) = self.templates.get(ti) {
                    // The mirror image's offset is the template's mirrored.
                    let [ox, oy] = t.position_offset();
                    let offset = if slot % 2 == 1 { [-ox, oy] } else { [ox, oy] };
                    let [px, py] = pose.apply(offset);
                    detection.x = px;
                    detection.y = py;
                }
            }
        }
        let centroid_wanted = params.position == Position::PartialVolume && !walled;
        Ok((detection, centroid_wanted.then_some(part_holes)))
    }

    /// The partial-volume centroid ([`partial_volume_moments`]) as the position of detection
    /// `detection` of outer border `index` (a known part's holes that its template does not
    /// have count as the part, [`print_deficit`]; `part_holes` from its hole borders);
    /// unchanged where the centroid has no contrast to weigh by. The label plane `mask` holds
    /// the 0/1 mask; its other bits are scratch, cleared again. Kept out of line, so its
    /// buffers take stack only while it runs (not under the partial search's).
    #[inline(never)]
    fn partial_volume_position<B: AsRef<[u8]>>(
        &mut self,
        index: usize,
        frame: &Frame<B>,
        background: &[u8],
        mask: &mut [u8],
        part_holes: &Holes,
        detection: &mut Detection,
    ) {
        let border = self.store.points(index);
        let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0usize, 0usize);
        for p in border {
            (x0, y0, x1, y1) = (
                x0.min(p.x as usize),
                y0.min(p.y as usize),
                x1.max(p.x as usize + 1),
                y1.max(p.y as usize + 1),
            );
        }
        let bbox = Rect { x0, y0, x1, y1 };
        let seed_pixel = border.first().map(|p| (p.x as usize, p.y as usize));
        let diff = Difference::new(frame, background, self.params.alpha());
        if let Some(seed) = seed_pixel {
            if let Some(m) = partial_volume_moments(&diff, mask, seed, bbox) {
                // A known part's holes that its template does not have are print: they and
                // the weights they take from the part around them count as the part.
                let [px, py] = if detection.template.is_some() && detection.holes.all_found() {
                    // Which of the part's hole borders its template's holes explain, once.
                    let matched = detection.holes.matched;
                    let mut explained = [false; C];
                    for i in self.store.holes_of(index) {
                        let hole = Hole::from_border(self.store.points(i));
                        if let (Some(e), Some(h)) = (explained.get_mut(i), hole) {
                            *e = part_holes
                                .as_slice()
                                .iter()
                                .enumerate()
                                .any(|(j, q)| matched & (1 << j) != 0 && *q == h);
                        }
                    }
                    let is_explained = |i: &usize| explained.get(*i).copied().unwrap_or(false);
                    let holes = self.store.holes_of(index);
                    let print = holes.clone().filter(|i| !is_explained(i)).map(|i| self.store.points(i));
                    let outer = self.store.points(index);
                    let keep_off =
                        core::iter::once(outer).chain(holes.filter(is_explained).map(|i| self.store.points(i)));
                    let [dm, dx, dy] = print_deficit(&diff, mask, m.contrast, print, keep_off);
                    let mass = m.mass + dm;
                    if dm > 0.0 && mass > 0.0 {
                        [
                            (m.mass * m.centroid[0] + dx) / mass,
                            (m.mass * m.centroid[1] + dy) / mass,
                        ]
                    } else {
                        m.centroid
                    }
                } else {
                    m.centroid
                };
                detection.x = px;
                detection.y = py;
            }
        }
    }

    /// The paper's path (`refine = Off`) and `refine = Pose`: the DP's best template, `f' < ε`,
    /// the angle from its correspondence; with `Pose`, that template's pose aligned on the
    /// frame (returned with the template's index) and its verification score.
    #[allow(clippy::too_many_arguments)]
    fn dp_best<B: AsRef<[u8]>>(
        &mut self,
        n: usize,
        centroid: [f32; 2],
        position: [f32; 2],
        area: f32,
        counter_clockwise: bool,
        part_holes: &Holes,
        diff: &Difference<'_, B>,
        detection: &mut Detection,
    ) -> Option<(usize, Fit)> {
        let params = self.params;
        let (found, searches) = self.dp_best_match(n, !detection.touches_edge);
        detection.searches = u8::try_from(searches).unwrap_or(u8::MAX);
        let (slot, m) = found?;
        let (signed, paper) = self.angles(n, centroid, slot)?;
        candidates::note_dp(detection, slot, m, (signed, paper));
        detection.angle_deg = match params.angle {
            AngleEstimator::Signed => signed,
            AngleEstimator::Paper => paper,
        };
        if m.normalized < params.epsilon {
            detection.template = Some((slot / 2) as u16);
        }
        if params.refine == Refine::Off {
            return None;
        }
        self.part_edge(n, counter_clockwise, diff);
        let family = m.normalized < params.epsilon;
        let fit = self.align_and_verify(
            n,
            position,
            signed,
            area,
            slot,
            family,
            None,
            part_holes,
            diff,
            &RefineParams::DEFAULT,
        )?;
        detection.verify = fit.verify;
        detection.verify_limit = fit.limit;
        detection.holes = fit.holes;
        Some((slot, fit))
    }

    /// The template of slot `slot` of the candidate scan: template `slot / 2`, or for an odd
    /// slot its mirror image (`None` unless `self.mirror` holds it: [`Self::prepare_mirror`]).
    fn slot_template(&self, slot: usize) -> Option<&Template<M>> {
        if slot % 2 == 1 {
            (self.mirror_of == Some((slot / 2) as u16)).then_some(&self.mirror)
        } else {
            self.templates.get(slot / 2)
        }
    }

    /// The signed and the paper's angles (degrees) over the correspondence with slot `slot`'s
    /// template ([`Self::slot_template`]) in `self.assignment`.
    fn angles(&self, n: usize, centroid: [f32; 2], slot: usize) -> Option<(f32, f32)> {
        let t = self.slot_template(slot)?;
        let part_pts = self.points.get(..n)?;
        let assignment = self.assignment.get(..n)?;
        let signed = angle_signed_refined(part_pts, centroid, t.points(), t.centroid(), assignment).unwrap_or(0.0);
        let paper = angle_paper(part_pts, centroid, t.points(), t.centroid(), assignment).unwrap_or(0.0);
        Some((signed, paper))
    }

    /// The part's sub-pixel edge at each resampled point (NaN where none is found).
    fn part_edge<B: AsRef<[u8]>>(&mut self, n: usize, counter_clockwise: bool, diff: &Difference<'_, B>) {
        let finder = diff.edge_finder(&RefineParams::DEFAULT);
        self.part_blur.set(None);
        let points = self.points.get(..n).unwrap_or(&[]);
        for k in 0..n {
            let e = points
                .get(k)
                .zip(outward_normal(points, k, counter_clockwise))
                .and_then(|(p, nrm)| finder.offset(*p, nrm).map(|u| [p[0] + u * nrm[0], p[1] + u * nrm[1]]));
            if let Some(slot) = self.part_edges.get_mut(k) {
                *slot = e.unwrap_or([f32::NAN; 2]);
            }
        }
    }
}

impl<const T: usize, const M: usize, const P: usize, const C: usize, const D: usize> Recognizer<T, M, P, C, D> {
    /// Candidates kept per part (capacity of the list).
    pub const MAX_CANDIDATES: usize = MAX_CANDIDATES;
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;

    /// After `process` the label plane holds the 0/1 mask, the same as [`foreground_mask`]'s,
    /// however the borders were labelled (rings with holes, parts on the edge, over 126
    /// borders) and whatever the plane held before; with polarity `Either`, less the shadows
    /// cut off bright parts (the pixels it took, and only those, counted out of the report's
    /// foreground).
    #[test]
    fn process_leaves_the_foreground_mask_in_the_label_plane() {
        use crate::pixels::mask::foreground_mask;
        let mut rng = crate::test_rng::XorShiftStar(0x1abe1);
        for case in 0..40 {
            let (w, h) = ([97usize, 160, 64, 33][case % 4], [61usize, 40, 70, 90][case % 4]);
            let n = w * h;
            let bg_px: std::vec::Vec<u8> = (0..n).map(|_| 60 + rng.below(6) as u8).collect();
            let mut frame_px = bg_px.clone();
            for _ in 0..rng.below(150) {
                let (x0, y0) = (rng.below(w as u64) as usize, rng.below(h as u64) as usize);
                let (rw, rh) = (1 + rng.below(20) as usize, 1 + rng.below(20) as usize);
                let ring = rng.below(2) == 0;
                let v = if rng.below(2) == 0 { 200 } else { 5 };
                for y in y0..(y0 + rh).min(h) {
                    for x in x0..(x0 + rw).min(w) {
                        let inside = x > x0 + 2 && x + 3 < x0 + rw && y > y0 + 2 && y + 3 < y0 + rh;
                        if !(ring && inside) {
                            frame_px[y * w + x] = v;
                        }
                    }
                }
            }
            let frame = Frame::new_checked(&frame_px[..], w, h).unwrap();
            let mut bg = Background::new(std::vec![0u8; n], w, h).unwrap();
            bg.set_from_frame(&Frame::new_checked(&bg_px[..], w, h).unwrap(), Params::DEFAULT.alpha())
                .unwrap();
            let mut rec: std::boxed::Box<Recognizer<4, 96, 4096, 64, 2112>> = std::boxed::Box::default();
            let polarity = [Polarity::Either, Polarity::Darker][case % 2];
            let p = Params {
                polarity,
                ..Params::DEFAULT
            };
            rec.set_params(p).unwrap();
            let mut labels = std::vec![rng.below(256) as u8; n + 3];
            let report = rec.process(&frame, &bg, &mut labels).unwrap();
            let mut mask = std::vec![0u8; n];
            let stats = foreground_mask(&frame, &bg, p.alpha(), p.threshold, p.polarity, p.cleanup, &mut mask).unwrap();
            let kept = labels[..n].iter().filter(|&&v| v == 1).count();
            assert_eq!(report.mask.threshold, stats.threshold);
            assert_eq!(report.mask.foreground, kept, "case {case}");
            assert!(
                labels[..n].iter().zip(&mask).all(|(&l, &m)| l <= 1 && l <= m),
                "case {case}"
            );
            if report.shadows == 0 {
                assert!(labels[..n] == mask[..], "case {case}: {w}×{h}");
            } else {
                assert_eq!(polarity, Polarity::Either);
            }
        }
    }

    /// Print on the platform (strokes 3 px wide, as wide as the mask's opening lets through)
    /// is thinner than half the taught part at its smallest scale: counted in
    /// [`Report::thin`], never a part, and it takes no part's place. The taught part is found,
    /// whole and cut in half by the frame's edge (the least share a cut part is searched with).
    #[test]
    fn print_thinner_than_any_taught_part_is_not_a_part() {
        let (w, h) = (200usize, 120usize);
        let bg_px = std::vec![200u8; w * h];
        // A disc of radius 22 (thickness 22), taught from its own silhouette.
        let disc = |x: usize, y: usize, cx: f32, cy: f32| {
            let (dx, dy) = (x as f32 - cx, y as f32 - cy);
            dx * dx + dy * dy < 22.0 * 22.0
        };
        let mut tpl = std::vec![0u8; w * h];
        let mut px = bg_px.clone();
        for y in 0..h {
            for x in 0..w {
                if disc(x, y, 60.0, 60.0) {
                    tpl[y * w + x] = 255;
                }
                // The same disc at x = 60, and one cut in half by the right edge.
                let part = disc(x, y, 60.0, 60.0) || disc(x, y, 199.5, 60.0);
                // Twelve rows of print between them: a line 3 px high with strokes 3 px wide
                // and 3 px apart hanging from it, each row a blob of its own.
                let print = (90..170).contains(&x) && (y % 10 < 3 || (y % 10 < 6 && x % 6 < 3));
                if part {
                    px[y * w + x] = 30;
                } else if print {
                    px[y * w + x] = 60;
                }
            }
        }
        let mut bg = Background::new(std::vec![0u8; w * h], w, h).unwrap();
        bg.set_from_frame(&Frame::new_checked(&bg_px[..], w, h).unwrap(), Params::DEFAULT.alpha())
            .unwrap();
        let mut rec: std::boxed::Box<Recognizer<4, 96, 8192, 128, 2112>> = std::boxed::Box::default();
        rec.set_params(Params::DEFAULT).unwrap();
        let mut labels = std::vec![0u8; w * h];
        rec.teach(&Frame::new_checked(&tpl[..], w, h).unwrap(), &mut labels)
            .unwrap();
        let least = 0.5 * rec.templates()[0].thickness() * Params::DEFAULT.scale_min;
        assert!((least - 0.5 * 22.0 / 1.4).abs() < 1.5, "{least}");
        let report = rec
            .process(&Frame::new_checked(&px[..], w, h).unwrap(), &bg, &mut labels)
            .unwrap();
        let found = |x: f32, y: f32| {
            report
                .detections
                .iter()
                .any(|d| d.template == Some(0) && (d.x - x).abs() < 3.0 && (d.y - y).abs() < 3.0)
        };
        assert!(found(60.0, 60.0), "{:?}", report.detections);
        assert!(
            report
                .detections
                .iter()
                .any(|d| d.template == Some(0) && d.y > 55.0 && d.x > 170.0),
            "the cut disc: {:?}",
            report.detections
        );
        assert_eq!(report.detections.len(), 2, "{:?}", report.detections);
        assert_eq!(report.thin, 12, "{:?}", report.trace);
        // Without a template every blob is looked at (nothing is known to be too thin).
        let mut bare: std::boxed::Box<Recognizer<4, 96, 8192, 128, 2112>> = std::boxed::Box::default();
        bare.set_params(Params::DEFAULT).unwrap();
        let all = bare
            .process(&Frame::new_checked(&px[..], w, h).unwrap(), &bg, &mut labels)
            .unwrap();
        assert_eq!(all.thin, 0);
        assert!(all.detections.len() > 2, "{:?}", all.detections.len());
    }

    /// A dark ring on a bright platform with a dark square (print, or a small part) inside its
    /// hole: the square's outer border lies inside the ring's hole border. By default it is a
    /// reported skip, not a part; with `nested_parts` it is a part of its own. A square beside
    /// the ring is a part either way.
    #[test]
    fn parts_inside_a_hole_are_skipped_unless_asked_for() {
        let (w, h) = (120usize, 80usize);
        let bg_px = std::vec![200u8; w * h];
        let mut px = bg_px.clone();
        for y in 0..h {
            for x in 0..w {
                let (dx, dy) = (x as f32 - 40.0, y as f32 - 40.0);
                let r = libm::sqrtf(dx * dx + dy * dy);
                let in_ring = (16.0..30.0).contains(&r);
                let in_square = (36..46).contains(&x) && (36..46).contains(&y);
                let beside = (90..102).contains(&x) && (30..42).contains(&y);
                if in_ring || in_square || beside {
                    px[y * w + x] = 20;
                }
            }
        }
        let frame = Frame::new_checked(&px[..], w, h).unwrap();
        let mut bg = Background::new(std::vec![0u8; w * h], w, h).unwrap();
        bg.set_from_frame(&Frame::new_checked(&bg_px[..], w, h).unwrap(), Params::DEFAULT.alpha())
            .unwrap();
        for nested in [false, true] {
            let mut rec: std::boxed::Box<Recognizer<4, 96, 4096, 64, 2112>> = std::boxed::Box::default();
            rec.set_params(Params {
                nested_parts: nested,
                ..Params::DEFAULT
            })
            .unwrap();
            let mut labels = std::vec![0u8; w * h];
            let report = rec.process(&frame, &bg, &mut labels).unwrap();
            let at = |x: f32, y: f32| {
                report
                    .detections
                    .iter()
                    .any(|d| (d.x - x).abs() < 1.0 && (d.y - y).abs() < 1.0)
            };
            // The ring (centred on its hole) and the square beside it.
            assert!(at(40.0, 40.0) || at(40.5, 40.5), "{nested}: {:?}", report.detections);
            assert!(at(95.5, 35.5), "{nested}: {:?}", report.detections);
            let inside = report
                .skips
                .iter()
                .filter(|s| s.reason == SkipReason::InsideHole)
                .count();
            if nested {
                assert_eq!(report.detections.len(), 3, "{:?}", report.detections);
                assert_eq!(inside, 0);
            } else {
                assert_eq!(report.detections.len(), 2, "{:?}", report.detections);
                assert_eq!(inside, 1, "{:?}", report.skips);
            }
        }
    }

    /// An L of unequal arms (chiral), `inside` in offsets from its area centroid.
    pub(super) fn l_inside(t: [f32; 2]) -> bool {
        // A bar 44 × 10 and a foot 10 × 16 below its left end; area centroid
        // ((440·22 + 160·5)/600, (440·5 + 160·18)/600).
        let (u, v) = (t[0] + 10480.0 / 600.0, t[1] + 5080.0 / 600.0);
        ((0.0..44.0).contains(&u) && (0.0..10.0).contains(&v))
            || ((0.0..10.0).contains(&u) && (10.0..26.0).contains(&v))
    }

    /// A T (mirror-symmetric), `inside` in offsets from its area centroid.
    pub(super) fn t_inside(t: [f32; 2]) -> bool {
        // Bar 44 × 10, stem 10 × 30 below its middle; area centroid (22, (440·5 + 300·25)/740).
        let (u, v) = (t[0] + 22.0, t[1] + 9700.0 / 740.0);
        ((0.0..44.0).contains(&u) && (0.0..10.0).contains(&v))
            || ((17.0..27.0).contains(&u) && (10.0..40.0).contains(&v))
    }

    /// A part of [`scene`]: an L (else a T), its centroid `(x, y)`, its angle (°) and whether it
    /// lies upside down.
    type Placed = (bool, f32, f32, f32, bool);

    /// A scene of dark parts (level 20) on a platform of 200: each shape mirrored left-right
    /// first when flipped, then turned counter-clockwise on screen and placed with its centroid
    /// at `(x, y)`; 4 × 4 samples per pixel.
    fn scene(w: usize, h: usize, parts: &[Placed]) -> std::vec::Vec<u8> {
        let shapes: std::vec::Vec<Drawn> = parts
            .iter()
            .map(|&(is_l, x, y, deg, flipped)| (if is_l { l_inside } else { t_inside }, x, y, deg, flipped))
            .collect();
        scene_of(w, h, &shapes)
    }

    /// A part of [`scene_of`]: its shape (`inside`, in offsets from its origin), where its origin
    /// lies, its angle (°) and whether it lies upside down.
    pub(super) type Drawn = (fn([f32; 2]) -> bool, f32, f32, f32, bool);

    /// [`scene`] of any shapes.
    pub(super) fn scene_of(w: usize, h: usize, parts: &[Drawn]) -> std::vec::Vec<u8> {
        let mut px = std::vec![200u8; w * h];
        for (y, row) in px.chunks_exact_mut(w).enumerate() {
            for (x, p) in row.iter_mut().enumerate() {
                let mut cover = 0.0f32;
                for &(inside, cx, cy, deg, flipped) in parts {
                    let (s, c) = libm::sincosf(deg.to_radians());
                    for k in 0..16 {
                        let dx = x as f32 - 0.375 + 0.25 * (k % 4) as f32 - cx;
                        let dy = y as f32 - 0.375 + 0.25 * (k / 4) as f32 - cy;
                        // The inverse of t → (t0·c + t1·s, −t0·s + t1·c), then the mirror.
                        let t = [c * dx - s * dy, s * dx + c * dy];
                        let t = if flipped { [-t[0], t[1]] } else { t };
                        cover += inside(t) as u8 as f32 / 16.0;
                    }
                }
                *p = (200.0 - 180.0 * cover.min(1.0)).round() as u8;
            }
        }
        px
    }

    /// A template taught from the shape `inside` (offsets from its area centroid) drawn at the
    /// middle of an 80 × 80 silhouette.
    pub(super) fn taught(inside: fn([f32; 2]) -> bool) -> Template<96> {
        let (tw, th) = (80usize, 80usize);
        let px: std::vec::Vec<u8> = (0..tw * th)
            .map(|i| u8::from(inside([(i % tw) as f32 - 30.0, (i / tw) as f32 - 30.0])) * 255)
            .collect();
        let mut labels = std::vec![0u8; tw * th];
        let mut store = std::boxed::Box::new(ContourStore::<4096, 16>::new());
        Template::<96>::from_silhouette(
            &Frame::new_checked(&px[..], tw, th).unwrap(),
            &Params::DEFAULT,
            &mut labels,
            &mut store,
        )
        .unwrap()
    }

    /// The empty platform of [`scene`] (200 everywhere), as the background model.
    fn platform(w: usize, h: usize) -> Background<std::vec::Vec<u8>> {
        let px = std::vec![200u8; w * h];
        let mut bg = Background::new(std::vec![0u8; w * h], w, h).unwrap();
        bg.set_from_frame(&Frame::new_checked(&px[..], w, h).unwrap(), Params::DEFAULT.alpha())
            .unwrap();
        bg
    }

    /// The report of a `w`×`h` frame `px` on [`platform`] with the partial search on
    /// (`touching_parts`) and `templates` taught, in that order.
    fn touching_report<const N: usize>(px: &[u8], w: usize, h: usize, templates: [Template<96>; N]) -> Report {
        let bg = platform(w, h);
        let mut rec: std::boxed::Box<Recognizer<4, 96, 4096, 64, 2112>> = std::boxed::Box::default();
        rec.set_params(Params {
            touching_parts: true,
            ..Params::DEFAULT
        })
        .unwrap();
        for t in templates {
            rec.add_template(t).unwrap();
        }
        let mut labels = std::vec![0u8; w * h];
        rec.process(&Frame::new_checked(px, w, h).unwrap(), &bg, &mut labels)
            .unwrap()
    }

    /// A disc of the L's area, `inside` in offsets from its centre.
    fn disc_inside(t: [f32; 2]) -> bool {
        t[0] * t[0] + t[1] * t[1] < 600.0 / core::f32::consts::PI
    }

    /// A cam: a disc of radius 14 and one of radius 8, their centres 18 apart, joined by a
    /// tapered neck. Nearly 2-fold (its half-turned outline lies 0.14 of its size off), so its
    /// template is aligned half a turn on too unless the DP rules that side out.
    fn cam_inside(t: [f32; 2]) -> bool {
        let (u, v) = (t[0] + 9.0, t[1]);
        let neck = (0.0..18.0).contains(&u) && v.abs() < 8.0 + 6.0 * (18.0 - u) / 18.0;
        u * u + v * v < 196.0 || (u - 18.0).powi(2) + v * v < 64.0 || neck
    }

    /// A whole cam whose fit is confident is aligned once: the DP's matches half a turn on cost
    /// more than `HALF_TURN_DP_RATIO` times its own (about 7 times here). The same cam cut by
    /// the frame's edge is still aligned both ways round (a cut part's DP match is no evidence).
    #[test]
    fn a_confident_part_the_dp_tells_from_its_half_turn_is_aligned_once() {
        use crate::recognizer::verdict::{HALF_TURN_AMBIGUOUS, HALF_TURN_SYMMETRIC};
        let template = taught(cam_inside);
        let h = template.half_turn();
        assert!(
            (HALF_TURN_SYMMETRIC..HALF_TURN_AMBIGUOUS).contains(&h),
            "the cam must be nearly 2-fold: {h}"
        );
        let (w, ht) = (120usize, 80usize);
        let bg = platform(w, ht);
        // Whole at (60, 40), then with its large end beyond the frame's left edge.
        for (x, cut) in [(60.0f32, false), (12.0, true)] {
            let px = scene_of(w, ht, &[(cam_inside, x, 40.0, 25.0, false)]);
            let mut rec: std::boxed::Box<Recognizer<4, 96, 4096, 64, 2112>> = std::boxed::Box::default();
            rec.add_template(template.clone()).unwrap();
            let mut labels = std::vec![0u8; w * ht];
            crate::recognizer::verdict::ALIGNMENTS.with(|a| a.set(0));
            let report = rec
                .process(&Frame::new_checked(&px[..], w, ht).unwrap(), &bg, &mut labels)
                .unwrap();
            assert_eq!(report.detections.len(), 1, "{:?}", report.detections);
            let d = report.detections[0];
            assert_eq!(d.touches_edge, cut, "{d:?}");
            let aligned = crate::recognizer::verdict::ALIGNMENTS.with(|a| a.get());
            if cut {
                assert!(aligned >= 2, "a cut cam is aligned both ways round: {aligned}");
            } else {
                assert_eq!(d.template, Some(0), "{d:?}");
                let err = (d.angle_deg - 25.0 + 540.0).rem_euclid(360.0) - 180.0;
                assert!(err.abs() < 0.5, "{d:?}");
                assert_eq!(aligned, 1, "{d:?}");
            }
        }
    }

    /// A bright cam front-lit on a darker platform throws a darker shadow beside itself: with
    /// polarity `Either` the mask takes both as one blob, whose outline is no cam's. The shadow
    /// pass takes the shadow out, and the cam is named and placed as with the one-sided
    /// polarity its set would be taught (`Brighter`), where the shadow never enters the mask.
    #[test]
    fn a_shadow_beside_a_bright_part_is_not_part_of_it() {
        use crate::pixels::mask::Polarity;
        let (w, h) = (120usize, 90usize);
        // Platform 100; the cam at 170 over a shadow at 55, moved 6 px right and 5 down.
        let cam = scene_of(w, h, &[(cam_inside, 58.0, 42.0, 30.0, false)]);
        let shade = scene_of(w, h, &[(cam_inside, 64.0, 47.0, 30.0, false)]);
        let px: std::vec::Vec<u8> = cam
            .iter()
            .zip(&shade)
            .map(|(&c, &s)| {
                let (c, s) = ((200.0 - f32::from(c)) / 180.0, (200.0 - f32::from(s)) / 180.0);
                let floor = 100.0 - 45.0 * s;
                (floor + (170.0 - floor) * c).round() as u8
            })
            .collect();
        let mut bg = Background::new(std::vec![0u8; w * h], w, h).unwrap();
        bg.set_from_frame(
            &Frame::new_checked(&std::vec![100u8; w * h][..], w, h).unwrap(),
            Params::DEFAULT.alpha(),
        )
        .unwrap();
        let run = |polarity| {
            let mut rec: std::boxed::Box<Recognizer<4, 96, 4096, 64, 2112>> = std::boxed::Box::default();
            rec.set_params(Params {
                polarity,
                ..Params::DEFAULT
            })
            .unwrap();
            rec.add_template(taught(cam_inside)).unwrap();
            let mut labels = std::vec![0u8; w * h];
            rec.process(&Frame::new_checked(&px[..], w, h).unwrap(), &bg, &mut labels)
                .unwrap()
        };
        let (either, brighter) = (run(Polarity::Either), run(Polarity::Brighter));
        assert_eq!(either.shadows, 1);
        assert_eq!(brighter.shadows, 0);
        assert_eq!(either.detections.len(), 1, "{:?}", either.detections);
        let (d, b) = (either.detections[0], brighter.detections[0]);
        assert_eq!(d.template, Some(0), "{d:?}");
        assert!(d.verify < 0.5 * d.verify_limit, "{d:?}");
        let err = (d.angle_deg - 30.0 + 540.0).rem_euclid(360.0) - 180.0;
        assert!(err.abs() < 1.0, "{d:?}");
        assert!((d.x - b.x).abs() < 0.05 && (d.y - b.y).abs() < 0.05, "{d:?} {b:?}");
    }

    /// What is cut off a bright cam is its shadow only where its edge is blurrier than the
    /// cam's ([`PENUMBRA`]): a soft shadow (σ ≈ 2.4 px, moved 10 px right and 7 down) is skipped, a sharp dark disc against
    /// the cam (an untaught part) is reported, unknown.
    #[test]
    fn only_a_blurred_neighbour_of_a_bright_part_is_its_shadow() {
        let (w, h) = (140usize, 100usize);
        let cover = |px: &[u8]| {
            px.iter()
                .map(|&v| (200.0 - f32::from(v)) / 180.0)
                .collect::<std::vec::Vec<f32>>()
        };
        let cam = cover(&scene_of(w, h, &[(cam_inside, 60.0, 46.0, 30.0, false)]));
        // The shadow, blurred by three box passes of radius 2 each way (σ ≈ 2.4 px).
        let mut shade = cover(&scene_of(w, h, &[(cam_inside, 70.0, 53.0, 30.0, false)]));
        for _ in 0..3 {
            for horizontal in [true, false] {
                let before = shade.clone();
                for y in 0..h {
                    for x in 0..w {
                        let at = |k: isize| {
                            let (a, b) = if horizontal {
                                (x as isize + k, y as isize)
                            } else {
                                (x as isize, y as isize + k)
                            };
                            let (a, b) = (a.clamp(0, w as isize - 1) as usize, b.clamp(0, h as isize - 1) as usize);
                            before[b * w + a]
                        };
                        shade[y * w + x] = (-2..=2).map(at).sum::<f32>() / 5.0;
                    }
                }
            }
        }
        let disc = cover(&scene_of(w, h, &[(disc_inside, 60.0, 73.0, 0.0, false)]));
        let bg = {
            let mut bg = Background::new(std::vec![0u8; w * h], w, h).unwrap();
            let level = std::vec![100u8; w * h];
            bg.set_from_frame(&Frame::new_checked(&level[..], w, h).unwrap(), Params::DEFAULT.alpha())
                .unwrap();
            bg
        };
        let run = |beside: &[f32], depth: f32| {
            let px: std::vec::Vec<u8> = cam
                .iter()
                .zip(beside)
                .map(|(&c, &s)| {
                    let floor = 100.0 - depth * s;
                    (floor + (170.0 - floor) * c).round() as u8
                })
                .collect();
            let mut rec: std::boxed::Box<Recognizer<4, 96, 4096, 64, 2112>> = std::boxed::Box::default();
            rec.add_template(taught(cam_inside)).unwrap();
            let mut labels = std::vec![0u8; w * h];
            rec.process(&Frame::new_checked(&px[..], w, h).unwrap(), &bg, &mut labels)
                .unwrap()
        };
        let soft = run(&shade, 60.0);
        assert_eq!(
            soft.shadows, 1,
            "{:?} {:?} {:?}",
            soft.mask, soft.detections, soft.skips
        );
        assert!(
            soft.skips.iter().any(|s| s.reason == SkipReason::Shadow),
            "{:?}",
            soft.skips
        );
        assert_eq!(soft.detections.len(), 1, "{:?}", soft.detections);
        assert_eq!(soft.detections[0].template, Some(0));
        let sharp = run(&disc, 80.0);
        assert_eq!(sharp.shadows, 1);
        assert!(
            sharp.skips.iter().all(|s| s.reason != SkipReason::Shadow),
            "{:?}",
            sharp.skips
        );
        assert_eq!(sharp.detections.len(), 2, "{:?}", sharp.detections);
        assert!(sharp.detections.iter().any(|d| d.template == Some(0)));
        assert!(sharp.detections.iter().any(|d| d.template.is_none()));
    }

    /// A whole part far from every template in shape (a disc against an L of its area: its
    /// DP cost is `f′ ≥ 2ε`) is unknown after one DP search and no alignment, its nearest
    /// template and cost reported; the L itself beside it is aligned and named. When the L is
    /// a class taught from several examples (a tolerance of its own), or the scan takes
    /// templates whatever their costs (`candidate_ratio = inf`), the disc is aligned (and
    /// still not an L).
    #[test]
    fn a_part_of_no_templates_family_is_not_aligned() {
        let (w, h) = (160usize, 80usize);
        let px = scene_of(
            w,
            h,
            &[
                (l_inside, 40.0, 40.0, 30.0, false),
                (disc_inside, 115.0, 40.0, 0.0, false),
            ],
        );
        let bg = platform(w, h);
        let eps = Params::DEFAULT.epsilon;
        let tolerant = crate::library::template::Tolerance {
            verify: 2.0,
            scale: [0.8, 1.25],
        };
        for (tolerance, ratio) in [(None, 1.0), (Some(tolerant), 1.0), (None, f32::INFINITY)] {
            let mut rec: std::boxed::Box<Recognizer<4, 96, 4096, 64, 2112>> = std::boxed::Box::default();
            rec.set_params(Params {
                candidate_ratio: ratio,
                ..Params::DEFAULT
            })
            .unwrap();
            rec.add_template(taught(l_inside)).unwrap();
            if let Some(t) = tolerance {
                rec.set_tolerance(0, t).unwrap();
            }
            let mut labels = std::vec![0u8; w * h];
            let report = rec
                .process(&Frame::new_checked(&px[..], w, h).unwrap(), &bg, &mut labels)
                .unwrap();
            assert_eq!(report.detections.len(), 2, "{:?}", report.detections);
            let exempt = tolerance.is_some() || ratio == f32::INFINITY;
            for d in &report.detections {
                if d.x < 80.0 {
                    assert_eq!(d.template, Some(0), "{d:?}");
                    assert!(d.pose.is_some() && d.score < eps, "{d:?}");
                } else {
                    assert!(
                        d.score >= UNVERIFIED_FAMILY * eps,
                        "the disc must lie outside the L's family: {d:?}"
                    );
                    // One search of each side of the chiral L (its mirror image, bounded by the
                    // family's cap, may be what a part upside down is), where the family rule
                    // ends the scan; else the scan's own.
                    let searches = if exempt { 1 } else { 2 };
                    assert_eq!(
                        (d.template, d.best_template, d.searches),
                        (None, Some(0), searches),
                        "{d:?}"
                    );
                    assert_eq!(d.pose.is_some(), exempt, "{exempt}: {d:?}");
                }
            }
        }
    }

    /// Two parts that touch and overlap (the L's bar under the T's by about a tenth of the L)
    /// form one blob; the whole-border match fails on it, and the partial search finds both,
    /// each with its template, `touching`, a visible share below 1 and the pose of its
    /// template (position within 0.5 px, angle within 0.5°); a lone part beside them is
    /// matched whole, as before.
    #[test]
    fn touching_parts_are_found_along_their_blob() {
        let (w, h) = (220usize, 110usize);
        let parts: [Placed; 3] = [
            (true, 60.0, 55.0, 0.0, false),
            (false, 95.0, 55.0, 0.0, false),
            (true, 175.0, 55.0, 75.0, false),
        ];
        let px = scene(w, h, &parts);
        let report = touching_report(&px, w, h, [taught(l_inside), taught(t_inside)]);
        assert_eq!(report.detections.len(), 3, "{:?}", report.detections);
        for (k, &(is_l, x, y, deg, _)) in parts.iter().enumerate() {
            let d = report
                .detections
                .iter()
                .find(|d| (d.x - x).abs() < 0.5 && (d.y - y).abs() < 0.5)
                .unwrap_or_else(|| panic!("no part at ({x}, {y}): {:?}", report.detections));
            assert_eq!(d.template, Some(if is_l { 0 } else { 1 }), "{d:?}");
            let err = (d.angle_deg - deg + 540.0).rem_euclid(360.0) - 180.0;
            assert!(err.abs() < 0.5, "{d:?}");
            let touching = k < 2;
            assert_eq!(d.touching, touching, "{d:?}");
            assert_eq!(d.position_from_pose, touching, "{d:?}");
            assert!(
                touching == (d.visible_fraction < 1.0) && d.visible_fraction >= 0.75,
                "{d:?}"
            );
        }
    }

    /// A blob the frame's edge cuts holds an L, cut, and a T against it that lies wholly
    /// inside: both are found; only the L is reported cut (`touches_edge`), and the T is held
    /// to the share of a part inside the frame, not the half a cut part needs.
    #[test]
    fn only_the_cut_part_of_a_blob_is_reported_cut() {
        let (w, h) = (200usize, 110usize);
        let parts: [Placed; 2] = [(true, 14.0, 55.0, 0.0, false), (false, 60.0, 55.0, 0.0, false)];
        let px = scene(w, h, &parts);
        let report = touching_report(&px, w, h, [taught(l_inside), taught(t_inside)]);
        assert_eq!(report.detections.len(), 2, "{:?}", report.detections);
        for (is_l, x, y, _, _) in parts {
            let d = report
                .detections
                .iter()
                .find(|d| (d.x - x).abs() < 0.5 && (d.y - y).abs() < 0.5)
                .unwrap_or_else(|| panic!("no part at ({x}, {y}): {:?}", report.detections));
            assert_eq!(d.template, Some(if is_l { 0 } else { 1 }), "{d:?}");
            assert!(d.touching && d.position_from_pose, "{d:?}");
            assert_eq!(d.touches_edge, is_l, "{d:?}");
        }
    }

    /// A connecting rod: a ring (outer radius 10, its hole 5) at `(−20, 0)`, a shaft of
    /// half-width `half` to a ball of radius `ball` at `(30, 0)`.
    fn rod(t: [f32; 2], half: f32, ball: f32) -> bool {
        let ring = (t[0] + 20.0).powi(2) + t[1] * t[1];
        let end = (t[0] - 30.0).powi(2) + t[1] * t[1];
        (ring <= 100.0 && ring > 25.0) || end <= ball * ball || ((-12.0..30.0).contains(&t[0]) && t[1].abs() <= half)
    }

    /// The rod as taught.
    fn rod_taught(t: [f32; 2]) -> bool {
        rod(t, 3.5, 7.0)
    }

    /// Another rod of the type: its shaft 2 px thicker and its ball 1.5 px larger than the
    /// taught one's, as real rods of one type differ.
    fn rod_other(t: [f32; 2]) -> bool {
        rod(t, 4.5, 8.5)
    }

    /// Two real rods lying against each other, each off its template's outline (a thicker
    /// shaft, a larger ball), are both found by the partial search: their off-centre ring
    /// holes, found where the poses put them, pin the poses and allow the outline's departure
    /// (`split::MIN_VISIBLE_PINNED`, `NEAR_MISS` times the partial limit; without them
    /// neither rod is taken).
    #[test]
    fn touching_parts_pinned_by_their_holes_may_depart_from_the_outline() {
        let (w, h) = (170usize, 130usize);
        let (c, s) = (libm::cosf(-50f32.to_radians()), libm::sinf(-50f32.to_radians()));
        // Rod A along x; rod B's ring against A's shaft from below (1 px over it), its ball
        // down and to the right.
        let ring_b = [80.0, 60.0 + 4.5 + 10.0 - 1.0];
        let b = [ring_b[0] + 20.0 * c, ring_b[1] - 20.0 * s];
        let parts: [Drawn; 2] = [
            (rod_other, 70.0, 60.0, 0.0, false),
            (rod_other, b[0], b[1], -50.0, false),
        ];
        let px = scene_of(w, h, &parts);
        let report = touching_report(&px, w, h, [taught(rod_taught), taught(l_inside)]);
        let named: std::vec::Vec<_> = report.detections.iter().filter(|d| d.template.is_some()).collect();
        assert_eq!(named.len(), 2, "{:?}", report.detections);
        for (_, x, y, deg, _) in parts {
            let d = named
                .iter()
                .find(|d| (d.x - x).abs() < 3.0 && (d.y - y).abs() < 3.0)
                .unwrap_or_else(|| panic!("no rod near ({x}, {y}): {:?}", report.detections));
            assert_eq!(d.template, Some(0), "{d:?}");
            assert!(d.touching && d.holes.all_found(), "{d:?}");
            let err = (d.angle_deg - deg + 540.0).rem_euclid(360.0) - 180.0;
            assert!(err.abs() < 1.0, "{d:?}");
        }
    }

    /// The partial search's defined results on hard blobs, never a panic or an endless search:
    /// - a heap (60 Ls and Ts in a chain, one blob whose border is longer than
    ///   [`crate::recognizer::split::BLOB_POINTS`] points at the templates' step) is not searched: it stays
    ///   one unknown part and [`Report::unsplit`] counts it;
    /// - two Ls lying almost wholly over one another (neither shows half its border) are one
    ///   part, named or not, never two;
    /// - an L against a square that is no template is found once (at its pose), with the
    ///   square as the unexplained rest, an unknown part near the square's centre.
    #[test]
    fn hard_blobs_have_defined_results() {
        let (w, h) = (360usize, 300usize);
        let (l, t) = (taught(l_inside), taught(t_inside));
        let bg = platform(w, h);
        let run = |px: &[u8]| {
            let mut rec: std::boxed::Box<Recognizer<4, 96, 16384, 64, 2112>> = std::boxed::Box::default();
            rec.set_params(Params {
                touching_parts: true,
                ..Params::DEFAULT
            })
            .unwrap();
            rec.add_template(l.clone()).unwrap();
            rec.add_template(t.clone()).unwrap();
            let mut labels = std::vec![0u8; w * h];
            rec.process(&Frame::new_checked(px, w, h).unwrap(), &bg, &mut labels)
                .unwrap()
        };
        // A heap: a chain of 60 parts, each overlapping the next, in a frame of its own.
        let (hw, hh) = (1060usize, 100usize);
        let chain: std::vec::Vec<Placed> = (0..60)
            .map(|k| (k % 2 == 0, 40.0 + 16.0 * k as f32, 50.0, k as f32 * 37.0, false))
            .collect();
        let hpx = scene(hw, hh, &chain);
        let hbg = platform(hw, hh);
        let mut rec: std::boxed::Box<Recognizer<4, 96, 16384, 64, 2112>> = std::boxed::Box::default();
        rec.set_params(Params {
            touching_parts: true,
            ..Params::DEFAULT
        })
        .unwrap();
        rec.add_template(l.clone()).unwrap();
        rec.add_template(t.clone()).unwrap();
        let mut labels = std::vec![0u8; hw * hh];
        let report = rec
            .process(&Frame::new_checked(&hpx[..], hw, hh).unwrap(), &hbg, &mut labels)
            .unwrap();
        assert_eq!(report.unsplit, 1, "{:?}", report.detections);
        assert_eq!(report.detections.len(), 1, "{:?}", report.detections);
        assert!(report.detections[0].template.is_none() && !report.detections[0].touching);
        // Two Ls, the second 3 px and 4° off the first.
        let report = run(&scene(
            w,
            h,
            &[(true, 150.0, 150.0, 20.0, false), (true, 153.0, 150.0, 24.0, false)],
        ));
        assert_eq!(report.detections.len(), 1, "{:?}", report.detections);
        // An L against a 20 × 20 square below its bar's right end (no template).
        let mut px = scene(w, h, &[(true, 150.0, 150.0, 0.0, false)]);
        for y in 151..171 {
            for x in 158..178 {
                px[y * w + x] = 20;
            }
        }
        let report = run(&px);
        let named: std::vec::Vec<_> = report.detections.iter().filter(|d| d.template.is_some()).collect();
        assert_eq!(named.len(), 1, "{:?}", report.detections);
        assert!(
            (named[0].x - 150.0).abs() < 0.5 && (named[0].y - 150.0).abs() < 0.5,
            "{:?}",
            named[0]
        );
        assert!(named[0].touching, "{:?}", named[0]);
        let rest: std::vec::Vec<_> = report.detections.iter().filter(|d| d.template.is_none()).collect();
        assert_eq!(rest.len(), 1, "{:?}", report.detections);
        assert!(
            (rest[0].x - 167.5).abs() < 4.0 && (rest[0].y - 161.0).abs() < 4.0,
            "{:?}",
            rest[0]
        );
    }

    /// A J hook (chiral, its mirror image far from any turn of it), `inside` in offsets from
    /// its area centroid: a shank 8 × 40, a foot 24 × 8 under it, and a tip 8 × 12 up from the
    /// foot's right end.
    fn hook_inside(t: [f32; 2]) -> bool {
        let (u, v) = (t[0] + 5504.0 / 608.0, t[1] + 18112.0 / 608.0);
        ((0.0..8.0).contains(&u) && (0.0..48.0).contains(&v))
            || ((0.0..24.0).contains(&u) && (40.0..48.0).contains(&v))
            || ((16.0..24.0).contains(&u) && (28.0..40.0).contains(&v))
    }

    /// A pin: a bar with round ends, 64 × 14 px, and a hole of radius 3.5 px near one end, too
    /// small for the frame's tracing (38 px² under `min_area`), its area centroid at the origin.
    pub(super) fn pin_inside(t: [f32; 2]) -> bool {
        // The hole moves the area centroid off the bar's centre, away from it.
        let hole_area = core::f32::consts::PI * 3.5 * 3.5;
        let bar_area = 50.0 * 14.0 + core::f32::consts::PI * 49.0;
        let (x, y) = (t[0] - 24.0 * hole_area / (bar_area - hole_area), t[1]);
        let bar = (x.abs() <= 25.0 && y.abs() <= 7.0) || (x.abs() - 25.0).hypot(y) <= 7.0;
        bar && (x - 24.0).hypot(y) > 3.5
    }

    /// A hook upside down, whose template's own turns all lie far (`f′ ≥ 2ε`) from it, is
    /// still matched by the mirror image: the scan's family rule ends a part's scan only after
    /// the mirror image of a chiral first candidate was searched too (it shares the template's
    /// bounds and comes after it).
    #[test]
    fn a_hook_upside_down_is_found_though_its_template_is_far() {
        let (w, h) = (120usize, 100usize);
        let hook = taught(hook_inside);
        assert!(hook.is_chiral(), "{}", hook.mirror_gap());
        let px = scene_of(w, h, &[(hook_inside, 60.0, 50.0, 35.0, true)]);
        let bg = platform(w, h);
        let mut rec: std::boxed::Box<Recognizer<4, 96, 4096, 64, 2112>> = std::boxed::Box::default();
        rec.set_params(Params::DEFAULT).unwrap();
        rec.add_template(hook).unwrap();
        let mut labels = std::vec![0u8; w * h];
        let report = rec
            .process(&Frame::new_checked(&px[..], w, h).unwrap(), &bg, &mut labels)
            .unwrap();
        assert_eq!(report.detections.len(), 1, "{:?}", report.detections);
        let d = report.detections[0];
        assert_eq!((d.template, d.flipped), (Some(0), true), "{d:?}");
        let err = (d.angle_deg - 35.0 + 540.0) % 360.0 - 180.0;
        assert!(err.abs() < 0.5, "{d:?}");
    }

    /// A plate 52 × 22 with a hole 15 px across at one end and one 10 px across at the other,
    /// `inside` in offsets from its area centroid (about 1.4 px off the plate's middle, toward
    /// the smaller hole).
    fn plate_inside(t: [f32; 2]) -> bool {
        // Areas: plate 1144, holes 176.7 and 78.5; the centroid's shift along x.
        let shift = 13.0 * (176.7 - 78.5) / (1144.0 - 176.7 - 78.5);
        let (u, v) = (t[0] - shift, t[1]);
        u.abs() < 26.0
            && v.abs() < 11.0
            && (u + 13.0) * (u + 13.0) + v * v >= 7.5 * 7.5
            && (u - 13.0) * (u - 13.0) + v * v >= 5.0 * 5.0
    }

    /// A part whose outline is the same half a turn on and whose two holes differ in size comes
    /// out the right way round at every angle: both ways its holes are found (a hole may be
    /// twice off in area), and their sizes decide.
    #[test]
    fn a_symmetric_outline_is_turned_by_the_sizes_of_its_holes() {
        let t = taught(plate_inside);
        assert_eq!(t.holes().len(), 2, "{:?}", t.holes());
        assert!(!t.holes_repeat_half_turn());
        let (w, h) = (320usize, 100usize);
        let bg = platform(w, h);
        for base in [0.0f32, 35.0, 70.0, 105.0, 140.0] {
            let placed: std::vec::Vec<Drawn> = [base, base + 180.0, base + 90.0, base + 270.0]
                .iter()
                .enumerate()
                .map(|(k, &deg)| {
                    (
                        plate_inside as fn([f32; 2]) -> bool,
                        45.0 + 75.0 * k as f32,
                        50.0,
                        deg,
                        false,
                    )
                })
                .collect();
            let px = scene_of(w, h, &placed);
            let mut rec: std::boxed::Box<Recognizer<4, 96, 4096, 64, 2112>> = std::boxed::Box::default();
            rec.add_template(t.clone()).unwrap();
            let mut labels = std::vec![0u8; w * h];
            let report = rec
                .process(&Frame::new_checked(&px[..], w, h).unwrap(), &bg, &mut labels)
                .unwrap();
            for &(_, x, y, deg, _) in &placed {
                let d = report
                    .detections
                    .iter()
                    .find(|d| (d.x - x).abs() < 3.0 && (d.y - y).abs() < 3.0)
                    .unwrap_or_else(|| panic!("no part at ({x}, {y}): {:?}", report.detections));
                assert_eq!(d.template, Some(0), "{d:?}");
                let err = (d.angle_deg - deg + 540.0).rem_euclid(360.0) - 180.0;
                assert!(err.abs() < 1.0, "{deg}°: {d:?}");
            }
        }
    }

    /// A chiral part lying upside down is its template's mirror image: found, reported
    /// `flipped` with the angle of the contract (the template mirrored, then turned), and
    /// positioned like any other part; the same part the right way up is not flipped; with
    /// `flipped_parts` off it is not matched; a mirror-symmetric part is never flipped.
    #[test]
    fn parts_upside_down_are_matched_by_the_mirror_image() {
        let (w, h) = (200usize, 100usize);
        let (l, t) = (taught(l_inside), taught(t_inside));
        assert!(l.is_chiral() && !t.is_chiral(), "{} {}", l.mirror_gap(), t.mirror_gap());
        let parts: [Placed; 4] = [
            (true, 40.0, 50.0, 30.0, false),
            (true, 95.0, 48.0, 250.0, true),
            (false, 150.0, 50.0, 115.0, false),
            (false, 150.0, 50.0, 115.0, true),
        ];
        let bg = platform(w, h);
        for flips in [true, false] {
            // The T's two scenes (it looks the same flipped) one after the other.
            for scene_parts in [&parts[..3], &[parts[0], parts[1], parts[3]][..]] {
                let px = scene(w, h, scene_parts);
                let mut rec: std::boxed::Box<Recognizer<4, 96, 4096, 64, 2112>> = std::boxed::Box::default();
                rec.set_params(Params {
                    flipped_parts: flips,
                    ..Params::DEFAULT
                })
                .unwrap();
                rec.add_template(l.clone()).unwrap();
                rec.add_template(t.clone()).unwrap();
                let mut labels = std::vec![0u8; w * h];
                let report = rec
                    .process(&Frame::new_checked(&px[..], w, h).unwrap(), &bg, &mut labels)
                    .unwrap();
                assert_eq!(report.detections.len(), 3, "{:?}", report.detections);
                for &(is_l, x, y, deg, flipped) in scene_parts {
                    let d = report
                        .detections
                        .iter()
                        .find(|d| (d.x - x).abs() < 2.0 && (d.y - y).abs() < 2.0)
                        .unwrap_or_else(|| panic!("no part at ({x}, {y}): {:?}", report.detections));
                    if is_l && flipped && !flips {
                        // Off: the L upside down is another part.
                        assert!(!d.flipped && d.template.is_none(), "{d:?}");
                        continue;
                    }
                    assert_eq!(d.template, Some(if is_l { 0 } else { 1 }), "{d:?}");
                    // A T is never flipped: upside down it is the T turned about its axis.
                    assert_eq!(d.flipped, is_l && flipped, "{d:?}");
                    // (The T's mirror axis is its template's y axis: mirrored, it is itself.)
                    let want = deg;
                    let err = (d.angle_deg - want + 540.0) % 360.0 - 180.0;
                    assert!(err.abs() < 0.3, "angle {} want {want}: {d:?}", d.angle_deg);
                    assert!(
                        (d.x - x).abs() < 0.1 && (d.y - y).abs() < 0.1,
                        "({}, {}) want ({x}, {y})",
                        d.x,
                        d.y
                    );
                }
            }
        }
    }
}
