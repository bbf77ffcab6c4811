//! Every tunable parameter of the pipeline, with its default and range.

use crate::borders::contour::BorderFilter;
use crate::borders::resample::check_counts;
use crate::error::{Error, Result};
use crate::pixels::enhance::Alpha;
use crate::pixels::mask::{Cleanup, Polarity, Threshold};
use crate::shape::descriptor::DescriptorParams;

/// Most DP candidates a part is verified against ([`Params::candidates`]).
pub const MAX_CANDIDATES: usize = 8;

/// Which rotation estimator fills [`crate::Detection::angle_deg`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AngleEstimator {
    /// Signed least-squares rotation over the DP correspondences refined below the sampling
    /// step ([`crate::pose::angle_signed_refined`]), full circle (default).
    Signed,
    /// The paper's mean of unsigned arccos angles (eqs. 6.1–6.4), `[0, 180]`.
    Paper,
}

/// What follows the DP match (DESIGN.md, "Beyond the paper").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refine {
    /// The paper's path: best DP template, `f' < ε`, pose from the correspondences.
    Off,
    /// The paper's decision, with the pose aligned on the frame ([`crate::pose::refine::align`]).
    Pose,
    /// A few DP candidates each aligned and verified; the lowest verification score wins,
    /// unknown above [`Params::verify_threshold`] (default).
    Verify,
}

/// How a part's position is measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Position {
    /// The paper's: area centroid of the border polygon through pixel centres.
    Polygon,
    /// Partial-volume area centroid of the part's pixels ([`crate::pose::partial_volume::partial_volume_centroid`]).
    PartialVolume,
    /// The template's silhouette centroid carried into the frame by the aligned pose.
    Pose,
}

/// Pipeline parameters. [`Params::DEFAULT`] is a good start for parts of 40–200 px.
///
/// ```
/// let mut p = vorl_core::Params::DEFAULT;
/// p.n = 48;
/// p.m = 72;
/// p.validate().unwrap();
/// p.m = 100; // m < 2n fails
/// assert!(p.validate().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// Weight of intensity against gradient in `I'` (eq. 3.1), `[0, 1]`.
    pub alpha: f32,
    /// Foreground threshold on `|I' − B|`.
    pub threshold: Threshold,
    /// Which sign of `I' − B` is foreground: parts darker, brighter, or either (the default).
    pub polarity: Polarity,
    /// 3×3 clean-up of the mask.
    pub cleanup: Cleanup,
    /// Fewest border points of a kept contour.
    pub min_points: usize,
    /// Smallest polygon area of a kept contour, px².
    pub min_area: f32,
    /// Points a part contour is resampled to (`n`).
    pub n: usize,
    /// Points a template contour is resampled to (`m`, `n ≤ m < 2n`, eq. 4.5).
    pub m: usize,
    /// Neighbourhood of the angle term for parts (eq. 4.2); templates use `round(k·m/n)`.
    pub k: usize,
    /// Weight of the angle term `ω` (eq. 4.3), `[0, 1]`.
    pub omega: f32,
    /// Decision threshold `ε` on `f'` (eq. 5.2): known part iff `f' < ε`.
    pub epsilon: f32,
    /// Rotation estimator for the reported angle when the pose is not refined.
    pub angle: AngleEstimator,
    /// What follows the DP match.
    pub refine: Refine,
    /// Candidates aligned and verified per part (1..=8), with `refine = Verify`.
    pub candidates: usize,
    /// With `refine = Verify`, the templates are searched in ascending order of their
    /// sorted-value bound ([`crate::shape::matching::sorted_lower_bound`]), and a template is a
    /// candidate only if its DP cost is below this multiple of the lowest cost of the templates
    /// before it (`≥ 1`; `+∞`: the first `candidates` templates of that order). The default 1
    /// takes a candidate only when it beats every earlier one's cost: the first is the template
    /// of lowest bound (the right one for about 96 % of the generated sets' parts), the next
    /// ones steps towards the DP's best, and the search of every other template stops as soon
    /// as it cannot beat that cost.
    pub candidate_ratio: f32,
    /// Verification threshold, px: a part whose best score is at or above the larger of this
    /// and [`Self::verify_relative`] times the part's size is unknown.
    pub verify_threshold: f32,
    /// Verification threshold relative to the part's size (the matched template's
    /// [`crate::Template::size`] times the aligned scale), so that the score means the same for
    /// a small part and a large one, and for a camera of any resolution (blur, noise and the
    /// variation between parts of one type all grow with the part's image).
    pub verify_relative: f32,
    /// Largest uniform offset of the part's outline from its template's, along the normals,
    /// that the alignment fits, relative to the part's size (as [`Self::verify_relative`]):
    /// the walls of a thick part seen by a close lens, or an edge moved by blur and exposure,
    /// widen or narrow the whole outline. 0 fits none.
    pub offset_relative: f32,
    /// Smallest accepted scale of a part over its template (camera height, lens, part-to-part
    /// variation); an alignment below it is not verified. The default, 1/1.4, and
    /// [`Self::scale_max`]'s, 1.4, take in what real cameras showed without a setting: a camera
    /// moved between groups of photos (parts at 0.9–1.3× their taught size in the backlit rods
    /// of `datasets/real`, 0.89–1.37× in the front-lit nuts and screws). Parts of one shape in
    /// several sizes are told apart by their verified size only within this range.
    pub scale_min: f32,
    /// Largest accepted scale of a part over its template (default 1.4, see
    /// [`Self::scale_min`]).
    pub scale_max: f32,
    /// How the position is measured.
    pub position: Position,
    /// Whether an outer border that lies inside a hole of another part (print or a label on
    /// it, a pattern, a small part resting in a ring) is a part of its own. Off (the
    /// default), such a border is reported as a skip ([`crate::recognizer::SkipReason::InsideHole`]),
    /// not as a part.
    pub nested_parts: bool,
    /// Whether a part may lie upside down: for every chiral template
    /// ([`crate::Template::is_chiral`]) its mirror image is matched too, and a part that fits it
    /// is reported [`crate::Detection::flipped`] (on by default). Off for a line whose feeder
    /// never flips parts: chiral templates then cost no more than the others.
    pub flipped_parts: bool,
    /// Whether a blob whose border is not one template's is searched for the parts along it
    /// ([`crate::recognizer::split`]: touching and overlapping parts, and parts the frame's edge cuts that
    /// show at least half their border), reported [`crate::Detection::touching`] with their
    /// visible share. A blob inside the frame whose border has no junction where two outlines
    /// could meet is left whole unsearched, and a template is searched only on a blob with holes
    /// enough for its own. On by default: a user does not know to switch it on, and on the
    /// bench set, where parts lie apart, it adds about 3 % to a frame's instructions (unknown
    /// parts with sharp concave corners, such as stars, are searched;
    /// `docs/performance.md`, "The partial search on blobs of one part"). Off for a feeder
    /// that singles parts out.
    pub touching_parts: bool,
}

impl Params {
    /// The defaults.
    pub const DEFAULT: Params = Params {
        alpha: 1.0,
        threshold: Threshold::Fixed(15),
        polarity: Polarity::Either,
        cleanup: Cleanup::Open,
        min_points: 16,
        min_area: 64.0,
        n: 64,
        m: 96,
        k: 4,
        omega: 0.5,
        epsilon: 0.08,
        angle: AngleEstimator::Signed,
        refine: Refine::Verify,
        candidates: 3,
        candidate_ratio: 1.0,
        verify_threshold: 0.6,
        verify_relative: 0.04,
        offset_relative: 0.05,
        scale_min: 0.714,
        scale_max: 1.4,
        position: Position::PartialVolume,
        nested_parts: false,
        flipped_parts: true,
        touching_parts: true,
    };

    /// Checks every range.
    ///
    /// # Errors
    /// [`Error::Parameter`] naming the first parameter out of range, or [`Error::PointCounts`].
    pub fn validate(&self) -> Result<()> {
        if Alpha::new(self.alpha).is_none() {
            return Err(Error::Parameter {
                name: "alpha",
                value: self.alpha,
            });
        }
        if !(0.0..=1.0).contains(&self.omega) {
            return Err(Error::Parameter {
                name: "omega",
                value: self.omega,
            });
        }
        if !(self.epsilon >= 0.0) || !self.epsilon.is_finite() {
            return Err(Error::Parameter {
                name: "epsilon",
                value: self.epsilon,
            });
        }
        if !(self.min_area >= 0.0) || !self.min_area.is_finite() {
            return Err(Error::Parameter {
                name: "min_area",
                value: self.min_area,
            });
        }
        check_counts(self.n, self.m)?;
        if self.candidates == 0 || self.candidates > MAX_CANDIDATES {
            return Err(Error::Parameter {
                name: "candidates",
                value: self.candidates as f32,
            });
        }
        if !(self.candidate_ratio >= 1.0) {
            return Err(Error::Parameter {
                name: "candidate_ratio",
                value: self.candidate_ratio,
            });
        }
        if !(self.verify_threshold > 0.0) || !self.verify_threshold.is_finite() {
            return Err(Error::Parameter {
                name: "verify_threshold",
                value: self.verify_threshold,
            });
        }
        if !(self.verify_relative >= 0.0) || !self.verify_relative.is_finite() {
            return Err(Error::Parameter {
                name: "verify_relative",
                value: self.verify_relative,
            });
        }
        if !(self.offset_relative >= 0.0) || !(self.offset_relative < 1.0) {
            return Err(Error::Parameter {
                name: "offset_relative",
                value: self.offset_relative,
            });
        }
        if !(self.scale_min > 0.0) || !self.scale_min.is_finite() || self.scale_min > 1.0 {
            return Err(Error::Parameter {
                name: "scale_min",
                value: self.scale_min,
            });
        }
        if !(self.scale_max >= 1.0) || !self.scale_max.is_finite() {
            return Err(Error::Parameter {
                name: "scale_max",
                value: self.scale_max,
            });
        }
        if self.n < 8 {
            return Err(Error::Parameter {
                name: "n",
                value: self.n as f32,
            });
        }
        if self.k == 0 || self.k.checked_mul(2).is_none_or(|k2| k2 >= self.n) {
            return Err(Error::Parameter {
                name: "k",
                value: self.k as f32,
            });
        }
        Ok(())
    }

    /// `α` as checked type (1.0 when out of range; [`Self::validate`] reports that).
    pub fn alpha(&self) -> Alpha {
        Alpha::new(self.alpha).unwrap_or(Alpha::ONE)
    }

    /// The verification threshold for a part of `size` px ([`crate::Template::size`] times the
    /// scale): the larger of [`Self::verify_threshold`] and [`Self::verify_relative`]` × size`.
    pub fn verify_limit(&self, size: f32) -> f32 {
        let rel = self.verify_relative * size;
        if rel.is_finite() && rel > self.verify_threshold {
            rel
        } else {
            self.verify_threshold
        }
    }

    /// The border size filter.
    pub fn filter(&self) -> BorderFilter {
        BorderFilter {
            min_points: self.min_points,
            min_area: self.min_area,
        }
    }

    /// Descriptor parameters for a contour of `points` points.
    pub fn descriptor(&self, points: usize) -> DescriptorParams {
        DescriptorParams {
            k: crate::shape::descriptor::scaled_k(self.k, self.n, points),
            omega: self.omega,
        }
    }
}

impl Default for Params {
    fn default() -> Self {
        Self::DEFAULT
    }
}
