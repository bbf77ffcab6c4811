//! The independent std reference implementation of the contour-matching pipeline.
//!
//! Written from the paper (`000_b373188109264851.txt`, sections 3–6) and
//! `docs/pipeline-spec.md` only, in plain `f64` / `Vec` code that mirrors the equations, so that
//! the no_std `f32` core can be held against it. Section numbers `§n` refer to the
//! specification, `eq. n.m` to the paper.
//!
//! Pipeline ([`detect`]):
//!
//! 1. [`enhance`] — edge-enhanced intensity `I'` (eq. 3.1, §1);
//! 2. [`learn_background`] — mean background model `B` (§2);
//! 3. [`foreground_mask`] — `D = |I' − B|` ([`difference`]), threshold fixed or [`otsu`], 3×3
//!    opening then closing (§3);
//! 4. [`borders`] — Suzuki–Abe border following via `imageproc::contours::find_contours` (§4),
//!    kept borders by `min_points` / `min_area` ([`polygon_area`]);
//! 5. [`resample`] — arc-length resampling to `n` (parts) or `m` (templates) points (§5);
//! 6. [`descriptor`] — mixed distance / angle descriptor (eqs. 4.1–4.3, §6);
//! 7. [`cyclic_dp`] — cyclic order-preserving DP (eqs. 4.4–4.9, §7), `f' = f_min / n`
//!    (eq. 5.1) against `ε` (eq. 5.2); [`brute_force_cyclic`] checks it in tests;
//! 8. [`angle_signed`], [`angle_paper`] (eqs. 6.1–6.4) and [`area_centroid`] — the pose (§8);
//! 9. [`template_from_silhouette`] — templates (§9).
//!
//! # Choices where the specification is silent
//!
//! * **Otsu** ([`otsu`]) is written here rather than taken from `imageproc::contrast::otsu_level`:
//!   imageproc compares the between-class variance in floating point (so two thresholds that tie
//!   exactly may be ordered by rounding) and accumulates `t·h(t)` in `u32` (overflows for
//!   frames above ~16.8 M pixels). This version compares `w0·w1·(μ0 − μ1)²` exactly in integer
//!   arithmetic, so "the first maximising `t`" is exact. A test checks it agrees with imageproc
//!   on ordinary histograms.
//! * **Morphology** is written here (3×3, neighbours outside the image ignored, §3); a test
//!   checks it against `imageproc::morphology` with `Norm::LInf`, `k = 1`.
//! * **Borders** treat every non-zero mask pixel as foreground. An image too large for `i32`
//!   coordinates, or with a zero dimension, has no borders.
//! * **Resampling** (§5) skips zero-length edges; the point at arc length exactly on a vertex is
//!   that vertex. An empty point list, `count = 0`, or a non-finite / zero perimeter is an error.
//! * **Descriptor** (§6): `k = 0` is an error (the spec requires `k ≥ 1`); `k` larger than the
//!   number of points wraps cyclically. `A = −0.0` counts as 0 and is guarded to `+0.05`.
//! * **DP** ([`cyclic_dp`]) accepts any `1 ≤ n ≤ m` (the `m < 2n` rule of §5 is a pipeline
//!   parameter rule, checked by [`detect`] and [`template_from_silhouette`]); non-finite
//!   descriptor values are an error. Ties in the minimum keep the first start `s` and, when
//!   backtracking, the smallest `δ`.
//! * **Angles** with no usable pairs (empty input, every pair degenerate, or an assignment that
//!   indexes outside the template) are `0.0`; pairs whose template index is out of range, and
//!   part points beyond the assignment's length, are ignored.
//! * **Position**: when the outer polygon minus its kept holes has no positive area (a
//!   one-pixel-wide ring's hole border runs through the same pixel centres as its outer
//!   border), [`detect`] falls back to the outer polygon's area centroid alone, and if that has
//!   no area either (a one-pixel-wide line), to the mean of the border's points.
//! * **Skipped parts**: a kept outer border whose perimeter is 0 or whose descriptor is
//!   degenerate (§5, §6) is skipped by [`detect`] (no detection is emitted for it).
//! * **Templates** ([`template_from_silhouette`]): the largest-area outer border is taken
//!   without the `min_points` / `min_area` filter; ties in area keep the first in border order.
//!   [`detect`] requires every template to have as many points as descriptor values, with
//!   `n ≤ m_t < 2n`.
//! * **No templates**: [`detect`] still reports every part, with `template = None`,
//!   `score = f64::INFINITY` and both angles `0.0`. Ties between templates keep the first.

mod contour;
mod descriptor;
mod imaging;
mod matching;
mod pipeline;
mod pose;

#[cfg(test)]
mod tests;

use std::fmt;

pub use contour::{area_centroid, borders, polygon_area, resample, RefBorder};
pub use descriptor::descriptor;
pub use imaging::{difference, enhance, foreground_mask, learn_background, otsu};
pub use matching::{brute_force_cyclic, cyclic_dp, RefMatch};
pub use pipeline::{detect, template_from_silhouette, RefDetection, RefTemplate};
pub use pose::{angle_paper, angle_signed};

/// Why a reference computation could not produce a result (degenerate or invalid input).
#[derive(Debug, Clone, PartialEq)]
pub enum RefError {
    /// [`learn_background`] was given no frames.
    NoFrames,
    /// [`learn_background`] was given more than 255 frames (the spec allows `1 ≤ K ≤ 255`).
    TooManyFrames(usize),
    /// Two images that must have the same size do not.
    SizeMismatch {
        /// Size `(width, height)` of the first image.
        expected: (u32, u32),
        /// Size `(width, height)` of the offending image.
        found: (u32, u32),
    },
    /// A parameter is out of its allowed range; the text says which.
    InvalidParams(String),
    /// A point list or descriptor is empty.
    Empty,
    /// The border's perimeter is 0 (or not finite), so it cannot be resampled (§5).
    ZeroPerimeter,
    /// The contour is degenerate: `mean(r) < 1e-9` (§6).
    Degenerate,
    /// An input value is NaN or infinite.
    NonFinite,
    /// The silhouette has no outer border (§9).
    NoOuterBorder,
    /// The brute-force enumeration would be too large to run.
    TooLarge,
}

impl fmt::Display for RefError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RefError::NoFrames => write!(f, "no background frames given"),
            RefError::TooManyFrames(k) => {
                write!(f, "{k} background frames given; at most 255 are allowed")
            }
            RefError::SizeMismatch { expected, found } => write!(
                f,
                "image size {}x{} differs from {}x{}",
                found.0, found.1, expected.0, expected.1
            ),
            RefError::InvalidParams(what) => write!(f, "invalid parameters: {what}"),
            RefError::Empty => write!(f, "empty point list or descriptor"),
            RefError::ZeroPerimeter => write!(f, "border has zero perimeter"),
            RefError::Degenerate => write!(f, "degenerate contour (mean radius < 1e-9)"),
            RefError::NonFinite => write!(f, "input contains NaN or infinite values"),
            RefError::NoOuterBorder => write!(f, "silhouette has no outer border"),
            RefError::TooLarge => write!(f, "brute-force enumeration too large"),
        }
    }
}

impl std::error::Error for RefError {}

/// The foreground threshold τ of §3.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RefThreshold {
    /// A fixed τ: foreground is `D > τ`.
    Fixed(u8),
    /// τ is Otsu's level of the histogram of `D` over the whole frame ([`otsu`]).
    Otsu,
}

/// Which sign of `I' − B` is foreground (a part darker or brighter than the platform, or
/// either): `D` is `|I' − B|`, `B − I'` or `I' − B`, negative values counting as 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RefPolarity {
    /// `D = |I' − B|` (§3 as written).
    #[default]
    Either,
    /// `D = B − I'`.
    Darker,
    /// `D = I' − B`.
    Brighter,
}

/// The 3×3 clean-up of §3: none, an opening, or an opening then a closing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RefCleanup {
    /// No clean-up.
    Off,
    /// Erode, then dilate.
    Open,
    /// Erode, dilate, dilate, erode.
    OpenClose,
}

/// Every parameter of the reference pipeline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefParams {
    /// Weight α of the intensity in eq. 3.1, in `[0, 1]`.
    pub alpha: f64,
    /// Foreground threshold (§3).
    pub threshold: RefThreshold,
    /// Which sign of `I' − B` is foreground.
    pub polarity: RefPolarity,
    /// Whether the 3×3 opening + closing clean-up runs (§3).
    pub cleanup: RefCleanup,
    /// A border is kept only with at least this many points (§4).
    pub min_points: usize,
    /// A border is kept only with at least this polygon area in px² (§4).
    pub min_area: f64,
    /// Number of resampled points of a part (§5).
    pub n: usize,
    /// Number of resampled points of a template (§5), `n ≤ m < 2n`.
    pub m: usize,
    /// Neighbourhood `k` of the angle term for parts (eq. 4.2, §6); templates use
    /// `k_t = max(1, round(k·m/n))`.
    pub k: usize,
    /// Weight ω of the angle term in eq. 4.3.
    pub omega: f64,
    /// Similarity threshold ε of eq. 5.2: a part is of a template's class when `f' < ε`.
    pub epsilon: f64,
}

impl Default for RefParams {
    /// The spec's defaults: α = 1, τ = 30, clean-up on, 16 points, 64 px², `n = 64`, `m = 96`,
    /// `k = 4`, ω = 0.5, ε = 0.08.
    fn default() -> Self {
        RefParams {
            alpha: 1.0,
            threshold: RefThreshold::Fixed(30),
            polarity: RefPolarity::Either,
            cleanup: RefCleanup::Open,
            min_points: 16,
            min_area: 64.0,
            n: 64,
            m: 96,
            k: 4,
            omega: 0.5,
            epsilon: 0.08,
        }
    }
}

impl RefParams {
    /// Checks the parameter rules the pipeline relies on: `n ≥ 1`, `n ≤ m < 2n` (§5), `k ≥ 1`,
    /// ω finite.
    fn check(&self) -> Result<(), RefError> {
        if self.n == 0 {
            return Err(RefError::InvalidParams("n must be at least 1".into()));
        }
        if self.m < self.n || self.m >= self.n.saturating_mul(2) {
            return Err(RefError::InvalidParams(format!(
                "need n <= m < 2n, got n = {}, m = {}",
                self.n, self.m
            )));
        }
        if self.k == 0 {
            return Err(RefError::InvalidParams("k must be at least 1".into()));
        }
        if !self.omega.is_finite() {
            return Err(RefError::InvalidParams("omega must be finite".into()));
        }
        Ok(())
    }

    /// The template neighbourhood `k_t = max(1, round(k·m/n))` (§6), rounding half up (all
    /// values are non-negative, so this is half away from zero).
    fn k_template(&self) -> usize {
        if self.n == 0 {
            return self.k.max(1);
        }
        let k = self.k as u128;
        let m = self.m as u128;
        let n = self.n as u128;
        let kt = (2 * k * m + n) / (2 * n);
        usize::try_from(kt).unwrap_or(usize::MAX).max(1)
    }
}
