//! What one frame's run returns: the [`Report`] of the parts found ([`Detection`]) and of the
//! borders that were not ([`Skip`], with its [`SkipReason`]), with the mask and border stages'
//! figures; and the [`Stage`]s that [`Recognizer::process_observed`] reports as they end (to
//! time them on a camera).
//!
//! Plain data of fixed capacity, without allocation: at most [`MAX_DETECTIONS`] detections and
//! [`MAX_SKIPS`] skips a frame (further skips are counted, not kept), so a report's size is
//! known at compile time and it is returned by value.

use crate::borders::contour::TraceStats;
use crate::pixels::mask::MaskStats;
use crate::pose::holes::HoleAgreement;
use crate::pose::refine::Pose;
// What the doc links name.
#[cfg(doc)]
use crate::{
    library::template::Template,
    params::Params,
    recognizer::{Recognizer, UNVERIFIED_FAMILY},
};

/// Most detections reported for one frame.
pub const MAX_DETECTIONS: usize = 32;
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
    /// settled by its first candidate, more for a near miss or an unknown part within some
    /// template's family ([`UNVERIFIED_FAMILY`]). For a part found by the partial search
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
    /// What lay darker beside a bright part in one blob with it, cut off it by
    /// [`crate::pixels::shadow::separate`] (polarity `Either`), that no template explains and
    /// whose edge is blurred as a shadow's is ([`crate::recognizer::PENUMBRA`]): its shadow.
    Shadow,
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
    /// Outer borders that are strokes thinner than any taught part could be (half the
    /// thinnest template's thickness at its smallest scale, [`crate::recognizer::THIN_SHARE`],
    /// and [`crate::recognizer::STROKE_WIDTHS`] times the narrowest stroke the mask keeps):
    /// print on the platform, scratches, threads. Counted, not looked at; they take no part's
    /// place.
    pub thin: usize,
    /// Blobs that held a shadow (or a darker part) beside their bright part, cut off
    /// it before the parts were looked at (with [`crate::pixels::mask::Polarity::Either`],
    /// [`crate::pixels::shadow::separate`]; at most [`crate::recognizer::SHADOW_BLOBS`]).
    pub shadows: usize,
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
