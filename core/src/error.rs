//! The one error type of the core.

use core::fmt;

/// Everything that can go wrong in `vorl-core`.
///
/// Variants carry the numbers involved so that a caller (or a log line on a camera) can say
/// exactly what did not fit. The enum is `#[non_exhaustive]`: new stages add variants.
///
/// ```
/// use vorl_core::Error;
/// let e = Error::FrameSize { expected_width: 320, expected_height: 240, width: 640, height: 480 };
/// assert_eq!(
///     format!("{e}"),
///     "frame is 640×480 but 320×240 was expected"
/// );
/// ```
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Error {
    /// A frame has zero width or height.
    EmptyFrame {
        /// Width given.
        width: usize,
        /// Height given.
        height: usize,
    },
    /// A buffer is shorter than the image (or table) it must hold.
    BufferTooSmall {
        /// Bytes (or elements) needed.
        needed: usize,
        /// Bytes (or elements) given.
        got: usize,
    },
    /// A stride is smaller than the width.
    Stride {
        /// The width of a row.
        width: usize,
        /// The stride given.
        stride: usize,
    },
    /// Two images that must have the same size do not.
    FrameSize {
        /// Width that was expected (e.g. the background's).
        expected_width: usize,
        /// Height that was expected.
        expected_height: usize,
        /// Width given.
        width: usize,
        /// Height given.
        height: usize,
    },
    /// A parameter is out of its range.
    Parameter {
        /// Name of the parameter, as in [`crate::Params`].
        name: &'static str,
        /// The value given.
        value: f32,
    },
    /// The point counts break `n ≤ m < 2n` (paper eq. 4.5) or a capacity.
    PointCounts {
        /// Points of a part contour.
        n: usize,
        /// Points of a template contour.
        m: usize,
    },
    /// A fixed capacity is too small for the request.
    Capacity {
        /// What ran out.
        what: &'static str,
        /// Its capacity.
        capacity: usize,
        /// How much was asked for.
        requested: usize,
    },
    /// A contour cannot be described: zero perimeter, or all points at the centroid.
    DegenerateContour {
        /// Number of points in the contour.
        points: usize,
    },
    /// The background model has not learned any frame yet.
    NoBackground,
    /// A background model already holds the largest number of frames it can average.
    TooManyBackgroundFrames {
        /// The largest number of frames.
        max: usize,
    },
    /// A silhouette image holds no part.
    NoPart,
    /// Fewer point pairs than a fit needs.
    TooFewPoints {
        /// Pairs needed.
        needed: usize,
        /// Pairs given.
        got: usize,
    },
    /// The points of a fit are degenerate (coincident or collinear), so the fit is not defined.
    DegeneratePoints,
    /// A linear system is singular (or too ill-conditioned to solve in `f32`).
    Singular,
    /// A disparity is zero or negative, so no depth follows.
    Disparity {
        /// The disparity in pixels.
        disparity: f32,
    },
    /// A template library does not start with the library magic.
    BadMagic,
    /// A template library has a format version this core cannot read.
    UnsupportedVersion {
        /// Version found in the data.
        found: u16,
        /// Version this core reads.
        supported: u16,
    },
    /// A template library is shorter than its header says.
    Truncated {
        /// Bytes needed.
        needed: usize,
        /// Bytes present.
        got: usize,
    },
    /// A template library's checksum does not match its contents.
    Checksum {
        /// Checksum stored in the data.
        stored: u32,
        /// Checksum computed over the data.
        computed: u32,
    },
    /// A template library's contents are inconsistent (a count or value out of range).
    Corrupt {
        /// What is out of range.
        what: &'static str,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::EmptyFrame { width, height } => {
                write!(f, "frame is {width}×{height}: width and height must be at least 1")
            }
            Error::BufferTooSmall { needed, got } => {
                write!(f, "buffer holds {got} elements but {needed} are needed")
            }
            Error::Stride { width, stride } => {
                write!(f, "stride {stride} is smaller than the width {width}")
            }
            Error::FrameSize {
                expected_width,
                expected_height,
                width,
                height,
            } => write!(
                f,
                "frame is {width}×{height} but {expected_width}×{expected_height} was expected"
            ),
            Error::Parameter { name, value } => write!(f, "parameter {name} = {value} is out of range"),
            Error::PointCounts { n, m } => write!(
                f,
                "point counts n = {n}, m = {m} break n ≤ m < 2n (paper eq. 4.5) or a capacity"
            ),
            Error::Capacity {
                what,
                capacity,
                requested,
            } => {
                write!(f, "{what}: {requested} requested but the capacity is {capacity}")
            }
            Error::DegenerateContour { points } => {
                write!(f, "degenerate contour of {points} points (no length or no extent)")
            }
            Error::NoBackground => write!(f, "the background model has learned no frame yet"),
            Error::TooManyBackgroundFrames { max } => {
                write!(f, "the background model averages at most {max} frames")
            }
            Error::NoPart => write!(f, "the image holds no part"),
            Error::TooFewPoints { needed, got } => {
                write!(f, "{got} point pairs given but at least {needed} are needed")
            }
            Error::DegeneratePoints => {
                write!(f, "the points are coincident or collinear: the fit is not defined")
            }
            Error::Singular => write!(f, "the linear system is singular"),
            Error::Disparity { disparity } => {
                write!(f, "disparity {disparity} px is not positive: no depth follows")
            }
            Error::BadMagic => write!(f, "not a vorl template library (bad magic)"),
            Error::UnsupportedVersion { found, supported } => write!(
                f,
                "template library version {found} is not supported (this core reads version {supported})"
            ),
            Error::Truncated { needed, got } => {
                write!(f, "template library truncated: {got} bytes present, {needed} needed")
            }
            Error::Checksum { stored, computed } => write!(
                f,
                "template library checksum mismatch: stored {stored:#010x}, computed {computed:#010x}"
            ),
            Error::Corrupt { what } => write!(f, "template library corrupt: {what}"),
        }
    }
}

impl core::error::Error for Error {}

/// Result type of the core.
pub type Result<T> = core::result::Result<T, Error>;
