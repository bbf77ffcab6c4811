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
//!   `verify_threshold`. The bound order puts the right template first for about 96 % of the
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

use crate::borders::contour::{clear_labels, trace_borders_in, BorderKind, ContourStore, TraceStats};
use crate::borders::resample::resample;
use crate::error::{Error, Result};
use crate::library::template::Template;
use crate::library::Library;
use crate::math;
use crate::params::{AngleEstimator, Params, Position, Refine};
use crate::pixels::background::Background;
use crate::pixels::frame::Frame;
use crate::pixels::mask::{foreground_mask_spans, MaskStats, RowSpans};
use crate::pose::holes::{agreement, pose_from_holes, Hole, HoleAgreement, Holes, MIN_HOLE_FRACTION};
use crate::pose::partial_volume::{partial_volume_moments, print_deficit, Rect};
use crate::pose::refine::{
    align_recording, edge_distances_walled, outward_normal, wall_facing, Alignment, Difference, Outline, Pose,
    RefineParams,
};
use crate::pose::{angle_paper, angle_signed_refined, area_centroid};
use crate::recognizer::split::BLOB_POINTS;
use crate::shape::arcs::ARC_ROWS;
use crate::shape::descriptor::describe;
use crate::shape::matching::{best_match, sorted_lower_bound, sorted_window_bound, table_cells, Match};

pub mod split;

/// Most detections reported for one frame.
pub const MAX_DETECTIONS: usize = 32;
pub use crate::params::MAX_CANDIDATES;
/// Most skips reported for one frame (more are counted in [`Report::skips_lost`]).
pub const MAX_SKIPS: usize = 16;

/// One part found in a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detection {
    /// Index of the matched template, `None` for an unknown part (`f' ≥ ε` or no templates).
    pub template: Option<u16>,
    /// The best template even when the part is unknown.
    pub best_template: Option<u16>,
    /// `f'` against the best template (eq. 5.1); infinite without templates, and for a part
    /// the partial search names (no whole-border match of its own; the unexplained rest of a
    /// blob keeps the blob's).
    pub score: f32,
    /// Position x (px), by [`Params::position`].
    pub x: f32,
    /// Position y (px), by [`Params::position`].
    pub y: f32,
    /// The paper's position: the area centroid of the border polygon (holes subtracted). For a
    /// part found by the partial search ([`Self::position_from_pose`]): its blob's.
    pub polygon_centroid: [f32; 2],
    /// Rotation from the template's reference pose, degrees counter-clockwise on screen,
    /// `[0, 360)`, by [`Params::angle`].
    pub angle_deg: f32,
    /// The paper's unsigned estimate (eq. 6.4), degrees in `[0, 180]` (for a part found by the
    /// partial search: its blob's whole-border match's).
    pub angle_paper_deg: f32,
    /// The signed estimate over the DP correspondences (before alignment), degrees (for a part
    /// found by the partial search: its blob's whole-border match's).
    pub angle_dp_deg: f32,
    /// Verification score of the chosen template, px (infinite when not verified).
    pub verify: f32,
    /// The limit the score was held to, px ([`Params::verify_limit`] for the aligned part's
    /// size): the part is known when `verify < verify_limit`.
    pub verify_limit: f32,
    /// Scale of the part against its template (1 when not aligned).
    pub scale: f32,
    /// The aligned pose of [`Self::best_template`] (`None` when not aligned): where its
    /// outline lies in the frame ([`Pose::apply`] on [`Template::edge`]).
    pub pose: Option<Pose>,
    /// How many of [`Self::best_template`]'s holes the part shows where the aligned pose puts
    /// them ([`crate::pose::holes`]; zero expected when not aligned or the template has none).
    pub holes: HoleAgreement,
    /// Index of the part's border in the recognizer's contour store (for a part found by the
    /// partial search: its blob's border, which it shares with the blob's other parts).
    pub contour: u16,
    /// Polygon area of the border, px² (for a part found by the partial search: its blob's,
    /// whose border it shares; its own is its template's area times [`Self::scale`]²).
    pub area: f32,
    /// The border touches the frame's edge (the part may be cut). For a part found by the
    /// partial search: its blob touches the edge and its aligned outline leaves the frame.
    pub touches_edge: bool,
    /// The part lies upside down: [`Self::best_template`]'s mirror image
    /// ([`Template::mirrored`]) fits it, and [`Self::angle_deg`] and [`Self::pose`] are that
    /// mirror image's (DESIGN.md: the template mirrored left-right about its centroid, then
    /// turned). Never set for a template that is not chiral ([`Template::is_chiral`]) or with
    /// [`Params::flipped_parts`] off.
    pub flipped: bool,
    /// DP searches run for this part: one per template searched along the candidate scan
    /// (whether or not it came in), saturating at 255. The work the part took: 1 for a part
    /// settled by its first candidate, more for a near miss or an unknown part near some
    /// template ([`UNVERIFIED_FAMILY`]). For a part found by the partial search
    /// ([`crate::recognizer::split`]): the templates whose arcs were searched.
    pub searches: u8,
    /// Found in a blob that held other parts too (touching or overlapping another part, or
    /// beside a rest no template explains): by the partial search ([`crate::recognizer::split`]).
    pub touching: bool,
    /// The share of the template's edge points that the image confirms (1 for a part matched
    /// whole; 0 for the unexplained rest of a blob). See [`crate::recognizer::split`].
    pub visible_fraction: f32,
    /// The position is the aligned template's ([`Pose::apply`] on its position offset), not
    /// the silhouette's centroid: a part found by the partial search, whose silhouette is not
    /// whole.
    pub position_from_pose: bool,
}

/// Why a border was not turned into a detection.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SkipReason {
    /// The border has no extent to resample or describe.
    Degenerate,
    /// The border's polygon has zero net area (no centroid).
    NoArea,
    /// [`MAX_DETECTIONS`] were already reported (the border is not looked at further).
    TooManyParts,
    /// An outer border inside a hole of another part: print, a label, a pattern, or a small
    /// part resting in a ring, not a part of its own unless [`Params::nested_parts`].
    InsideHole,
}

/// A stage of [`Recognizer::process_observed`] that has just ended.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Edge enhancement, difference to the background, threshold and clean-up.
    Mask,
    /// Border following (and the size filter).
    Borders,
    /// Every part: resampling, descriptor, matching against the templates, pose.
    Parts,
}

/// A border that did not become a detection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Skip {
    /// Index of the border in the contour store.
    pub contour: u16,
    /// The reason.
    pub reason: SkipReason,
}

/// Everything the recognizer found in one frame.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// The parts, in border order (top to bottom by first row).
    pub detections: heapless::Vec<Detection, MAX_DETECTIONS>,
    /// Borders that were kept but not reported as parts.
    pub skips: heapless::Vec<Skip, MAX_SKIPS>,
    /// Skips that did not fit in [`Self::skips`].
    pub skips_lost: usize,
    /// The mask stage's figures.
    pub mask: MaskStats,
    /// The border stage's figures (dropped, subsampled and skipped borders are counted here).
    pub trace: TraceStats,
    /// Blobs whose whole-border match failed and that were too long for the partial search
    /// ([`crate::recognizer::split::BLOB_POINTS`]): reported whole, as unknown parts.
    pub unsplit: usize,
}

impl Report {
    pub(crate) fn skip(&mut self, contour: usize, reason: SkipReason) {
        if self
            .skips
            .push(Skip {
                contour: contour as u16,
                reason,
            })
            .is_err()
        {
            self.skips_lost += 1;
        }
    }
}

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
            mirror: Template::empty(),
            mirror_of: None,
            arc_points: [[0.0; 2]; BLOB_POINTS],
            arc_turning: [0.0; BLOB_POINTS],
            arc_template: [0.0; M],
            arc_rows: [[0.0; M]; ARC_ROWS + 1],
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
            params.cleanup,
            labels,
            &mut spans,
        )?;
        observe(Stage::Mask);
        let trace = trace_borders_in(labels, w, h, &spans, params.filter(), &mut self.store)?;
        observe(Stage::Borders);
        let mut report = Report {
            mask,
            trace,
            ..Report::default()
        };
        // From here on the label plane is the plain 0/1 mask (the partial-volume centroid uses
        // its other bits as scratch and clears them again).
        clear_labels(labels, w, h, &spans);
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
            // A full report takes no more parts: those are not worked out, only counted.
            if report.detections.is_full() {
                report.skip(index, SkipReason::TooManyParts);
                continue;
            }
            match self.part(index, frame, background.plane(), labels) {
                Ok(detection) => {
                    // A whole-border match that failed: the parts along the blob's border.
                    // Or one that explains too little of its blob: a part accepted on a blob
                    // that holds more (another part touching it) than its template covers.
                    let split = params.touching_parts
                        && params.refine == Refine::Verify
                        && self.blob_not_explained(&detection)
                        && self.split_into(index, frame, background.plane(), &detection, &mut report);
                    if !split && report.detections.push(detection).is_err() {
                        report.skip(index, SkipReason::TooManyParts);
                    }
                }
                Err(reason) => report.skip(index, reason),
            }
        }
        observe(Stage::Parts);
        Ok(report)
    }

    /// One outer border (store index `index`) through resampling, description, matching,
    /// alignment, verification and position.
    fn part<B: AsRef<[u8]>>(
        &mut self,
        index: usize,
        frame: &Frame<B>,
        background: &[u8],
        mask: &mut [u8],
    ) -> core::result::Result<Detection, SkipReason> {
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
        let part_holes = Holes::from_borders(self.store.holes_of(index).map(|i| self.store.points(i)), 0.0);
        let seed_pixel = border.first().map(|p| (p.x as usize, p.y as usize));
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
        if params.position == Position::PartialVolume && !walled {
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
        Ok(detection)
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
        detection.best_template = Some((slot / 2) as u16);
        detection.flipped = slot % 2 == 1;
        detection.score = m.normalized;
        detection.angle_paper_deg = paper;
        detection.angle_dp_deg = signed;
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
            part_holes,
            diff,
            &RefineParams::DEFAULT,
        )?;
        detection.verify = fit.verify;
        detection.verify_limit = fit.limit;
        detection.holes = fit.holes;
        Some((slot, fit))
    }

    /// Slot `slot`'s template ([`Self::slot_template`]) aligned on the frame from the DP's pose (the part's `position`, the
    /// `signed` angle in degrees, the scale of the areas), and its verification score against
    /// the part's edge (`self.part_edges`) with the score's limit for the aligned part's size,
    /// and which of its holes `part_holes` shows there.
    /// A template whose outline is nearly but not exactly 2-fold ([`Template::half_turn`]
    /// between [`HALF_TURN_SYMMETRIC`] and [`HALF_TURN_AMBIGUOUS`]: a connecting rod) is
    /// aligned half a turn on too, and the better of the two kept ([`Fit::better_than`]: the
    /// holes decide where they can, a rod's two eyes of different size).
    #[allow(clippy::too_many_arguments)]
    fn align_and_verify<B: AsRef<[u8]>>(
        &self,
        n: usize,
        position: [f32; 2],
        signed: f32,
        area: f32,
        slot: usize,
        family: bool,
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
        // length, which thin rings and slots need.
        let limit = limit_at(seed.scale);
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
        if t.half_turn() < HALF_TURN_AMBIGUOUS && (!symmetric || !best.holes.all_found()) {
            let second = once(seed_pose(position, signed + 180.0, area, t), !settled(&best));
            if second.better_than(&best) {
                best = second;
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

    /// `refine = Verify`: the candidates of [`Self::next_candidate`], each aligned on the
    /// frame from its DP pose and verified. Fills the detection's DP fields and `verify` from
    /// the best fit ([`Fit::better_than`]); returns its template index and fit (`None` without
    /// a candidate).
    #[allow(clippy::too_many_arguments)]
    fn verify_candidates<B: AsRef<[u8]>>(
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
        if whole {
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
            let Some((slot, m)) = self.next_candidate(&mut scan, n, limit, ratio) else {
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
            // one far off the part in size and shape (UNVERIFIED_FAMILY).
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
            // (An infinite ratio takes every template in turn, even after a cost of 0.)
            let bound = if ratio == f32::INFINITY {
                f32::INFINITY
            } else {
                scan.lowest * ratio
            };
            let slot = self.next_template(scan, n, bound)?;
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
    fn prepare_mirror(&mut self, ti: usize) {
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

    /// The template of slot `slot` of a [`CandidateScan`]: template `slot / 2`, or for an odd
    /// slot its mirror image (`None` unless `self.mirror` holds it: [`Self::prepare_mirror`]).
    fn slot_template(&self, slot: usize) -> Option<&Template<M>> {
        if slot % 2 == 1 {
            (self.mirror_of == Some((slot / 2) as u16)).then_some(&self.mirror)
        } else {
            self.templates.get(slot / 2)
        }
    }

    /// The next template of the scan in ascending order of its [`sorted_lower_bound`] (ties:
    /// library order), taken out of the scan; `None` when its bound reaches `bound` (then no
    /// later one can come in either, as long as the caller's `bound` never rises).
    ///
    /// The exact bounds are computed lazily: a template's [`sorted_window_bound`] is at most its
    /// sorted bound, so one whose window bound exceeds the least exact bound computed so far
    /// cannot come next, and one whose window bound reaches `bound` never comes in; the order
    /// is the same as computing every bound first. On the bench set about three of the 13
    /// templates per part need the exact bound.
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
        let Some(fit) = self.align_and_verify(n, position, signed, area, slot, family, part_holes, diff, refine_params)
        else {
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
            detection.best_template = Some((slot / 2) as u16);
            detection.flipped = slot % 2 == 1;
            detection.score = m.normalized;
            detection.angle_paper_deg = paper;
            detection.angle_dp_deg = signed;
        }
    }

    /// How far beyond the scale range's end an outline grown by walls may be and still be
    /// aligned with the wall model: `1 + 2 · offset_relative · (1 + WALL_FACTOR)` (the offset
    /// and the wall, each on both sides).
    fn grown_max(&self) -> f32 {
        1.0 + 2.0 * self.params.offset_relative * (1.0 + WALL_FACTOR)
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

    /// The paper's path: the template of lowest DP cost and its match, its correspondence in
    /// `self.assignment` (`None` without a template that can be matched). The scan of
    /// [`Self::next_candidate`] with ratio 1 and no limit: each template in ascending order of
    /// its sorted-value bound is searched bounded by the lowest cost so far, until the bound
    /// rules the rest out; the last that came in is the same template as searching all of them
    /// (the first in the bound order among equal costs). Also returns the DP searches run.
    fn dp_best_match(&mut self, n: usize, mirrors: bool) -> (Option<(usize, Match)>, usize) {
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
/// [`Listing::Out`] unless the template is chiral and [`Params::flipped_parts`] is on): the
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

/// One candidate's alignment: the aligned pose, its verification score and the score's limit
/// (px), which of the template's holes the part shows there, and whether the DP puts the part
/// in the template's family (the paper's decision, `f' < ε`, eq. 5.2).
#[derive(Debug, Clone, Copy)]
struct Fit {
    pose: Pose,
    verify: f32,
    /// The verification's distances over every point, none left out, px.
    full: f32,
    limit: f32,
    holes: HoleAgreement,
    family: bool,
    /// The wall the alignment fitted, px (0 without one).
    wall: f32,
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
    /// Whether this fit, of candidate slot `slot`, beats `other`, of slot `other_slot`
    /// ([`CandidateScan`]'s slots): [`Self::better_than`] — except between a template and its
    /// own mirror image: then the upside-down reading needs clear evidence, a mean distance
    /// over every point ([`Fit::full`]: a nearly mirror-symmetric part differs from its mirror
    /// image only over a stretch, which the verification's trimmed score leaves out) below
    /// [`FLIP_EVIDENCE`] times the other's, whatever the holes and the DP's family say (they
    /// follow the same outline). A part whose mirror axis the template nearly has (a real
    /// part photographed for its template, with its walls and variation) fits both alike, and
    /// is not flipped.
    fn beats(&self, slot: usize, other: &Fit, other_slot: usize) -> bool {
        if slot ^ 1 == other_slot {
            let (flipped, plain) = if slot % 2 == 1 { (self, other) } else { (other, self) };
            // (An infinite plain mean loses to any finite one; NaN never wins.)
            let flip_wins = flipped.full.is_finite() && flipped.full < FLIP_EVIDENCE * plain.full;
            return flip_wins == (slot % 2 == 1);
        }
        self.better_than(other)
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
/// have the template's descriptor profile and its holes in place. Holes never veto an outline
/// that verifies (the holes of small parts close in the mask, and a close lens's walls shrink
/// and move them); they rank the candidates ([`Fit::better_than`]).
fn accepted(fit: Fit) -> bool {
    let r = fit.ratio();
    // A fit that took a wall to get there has used its freedom: the outline alone decides.
    r < 1.0 || (fit.wall == 0.0 && fit.family && fit.holes.off_centre > 0 && fit.holes.all_found() && r < NEAR_MISS)
}

/// An accepted fit of a chiral template (or its mirror image) whose mean distance over every
/// point is this multiple of its trimmed verification score or more has a stretch of outline
/// that does not fit: the other side is aligned too. A part the right way up gives 1.3–2.
pub const STRETCH_OFF: f32 = 3.0;

/// A mirror image whose template was searched for this part is a candidate only when its DP
/// cost is below this share of the template's: a part upside down fits the mirror image
/// clearly better, one that is neither (an unknown part) about alike. A nearly
/// mirror-symmetric part upside down, whose two costs are too close to tell, is caught by its
/// fit instead ([`STRETCH_OFF`]).
pub const MIRROR_GAIN: f32 = 0.8;

/// How much closer than the template itself its mirror image must fit a part for the part to
/// be reported upside down: the ratio of their mean distances over every point. A part that
/// lies upside down fits the mirror image at the noise's level and the template by the
/// stretch where the two differ; a mirror-symmetric part whose template is not quite (a real
/// rod) fits both alike.
pub const FLIP_EVIDENCE: f32 = 0.5;

/// Relative margin by which a template's sorted lower bound must exceed the `k`-th best DP cost
/// before the template is skipped (the two are rounded differently in `f32`).
const LOWER_BOUND_MARGIN: f32 = 1e-5;

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
        // The template's outline moved by the fitted offset (in its own frame: over the scale).
        let mut moved = [[0.0f32; 2]; M];
        let sc = math::sin_cos(pose.angle);
        let edge = if a.offset == 0.0 && a.wall == 0.0 {
            edge
        } else {
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

/// Largest wall the second alignment may fit, as a multiple of its offset's limit
/// ([`Params::offset_relative`]): a close lens over a thick part shows its walls up to about a
/// fifth of the part's size on the side towards the principal point.
pub const WALL_FACTOR: f32 = 4.0;

/// A fitted wall above this (px) makes the part's position its pose's (its top face's).
pub const WALL_SIGNIFICANT: f32 = 0.5;

pub use crate::pose::refine::VERIFY_KEPT;

/// [`Template::half_turn`] below which the outline counts as nearly 2-fold: the DP's
/// correspondence may then be half a turn off, and both are aligned.
pub const HALF_TURN_AMBIGUOUS: f32 = 0.2;

/// [`Template::half_turn`] below which the outline is 2-fold symmetric: half a turn on is the
/// same pose, and it is not aligned twice.
pub const HALF_TURN_SYMMETRIC: f32 = 0.01;

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

/// A first candidate far off the part in size and in shape ends the candidate scan, the part
/// unknown: one that could not be verified (its alignment put the part's scale outside the
/// accepted range) and whose DP cost `f′` is at least this multiple of `ε` (the paper's
/// decision would call the part unknown twice over). On every set measured such parts were
/// distractors, which the scan would otherwise search against two or three more templates and
/// align on each, none verifying. Measured over every generated set and the real photos
/// (`docs/accuracy.md`): no classification or rejection changes, and about a tenth of the bench
/// set's instructions saved (`docs/performance.md`).
pub const UNVERIFIED_FAMILY: f32 = 2.0;

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

impl<const T: usize, const M: usize, const P: usize, const C: usize, const D: usize> Recognizer<T, M, P, C, D> {
    /// Candidates kept per part (capacity of the list).
    pub const MAX_CANDIDATES: usize = MAX_CANDIDATES;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::matching::{best_cost, match_at_start};
    extern crate std;

    /// After `process` the label plane holds the 0/1 mask, the same as [`foreground_mask`]'s,
    /// however the borders were labelled (rings with holes, parts on the edge, over 126
    /// borders) and whatever the plane held before.
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
            let mut labels = std::vec![rng.below(256) as u8; n + 3];
            let report = rec.process(&frame, &bg, &mut labels).unwrap();
            let p = Params::DEFAULT;
            let mut mask = std::vec![0u8; n];
            let stats = foreground_mask(&frame, &bg, p.alpha(), p.threshold, p.cleanup, &mut mask).unwrap();
            assert_eq!(report.mask, stats);
            assert!(labels[..n] == mask[..], "case {case}: {w}×{h}");
        }
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
    fn l_inside(t: [f32; 2]) -> bool {
        // A bar 44 × 10 and a foot 10 × 16 below its left end; area centroid
        // ((440·22 + 160·5)/600, (440·5 + 160·18)/600).
        let (u, v) = (t[0] + 10480.0 / 600.0, t[1] + 5080.0 / 600.0);
        ((0.0..44.0).contains(&u) && (0.0..10.0).contains(&v))
            || ((0.0..10.0).contains(&u) && (10.0..26.0).contains(&v))
    }

    /// A T (mirror-symmetric), `inside` in offsets from its area centroid.
    fn t_inside(t: [f32; 2]) -> bool {
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
    type Drawn = (fn([f32; 2]) -> bool, f32, f32, f32, bool);

    /// [`scene`] of any shapes.
    fn scene_of(w: usize, h: usize, parts: &[Drawn]) -> std::vec::Vec<u8> {
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
    fn taught(inside: fn([f32; 2]) -> bool) -> Template<96> {
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
        let (mut more_than_one, mut cut_short, mut never_bounded) = (0, 0, 0);
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
            for (k, ratio) in [(3usize, 1.0f32), (8, 1.0), (3, 1.5), (2, f32::INFINITY)] {
                // By definition: along the bound order, a template whose cost is below `ratio`
                // times the lowest cost before it, until `k` are found.
                let mut want = std::vec::Vec::new();
                let mut lowest = f32::INFINITY;
                for &(_, ti, c) in &all {
                    if want.len() == k {
                        break;
                    }
                    if c < lowest * ratio {
                        want.push(ti);
                    }
                    lowest = lowest.min(c);
                }
                let mut scan = r.candidate_scan(N, true);
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
        // Both ways of ending must occur for the test to mean anything, and the window bounds
        // must have spared some exact bounds.
        assert!(more_than_one > 5 && cut_short > 5, "{more_than_one} {cut_short}");
        assert!(never_bounded > 100, "{never_bounded}");
    }
}
