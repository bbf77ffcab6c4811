//! Mean background model of the edge-enhanced intensity `I'` (paper section 3.2).
//!
//! The model is one `u8` plane: the per-pixel mean of `I'` over K learned frames, rounded
//! (`B = (Σ I' + K/2) / K`, `docs/pipeline-spec.md` §2). Learning sums exactly in 16 bits: the
//! model's own plane holds the low byte and a caller-provided plane of the same size (on a camera,
//! the label plane that [`crate::Recognizer::process`] uses, free while learning) holds the high byte, so no
//! extra frame-sized buffer is needed. Up to [`MAX_LEARN_FRAMES`] frames can be averaged.
//!
//! Two ways to follow a changing scene:
//! - [`Background::update`]: slow update on background pixels, `B ← B ± 1` towards `I'` every
//!   `2^shift` calls (lighting drift);
//! - [`Background::set_from_frame`]: frame-difference mode for slowly moving parts, the
//!   "background" is simply the previous frame's `I'`.
//!
//! Memory: `width·height` bytes (plus the borrowed high-byte plane while learning).

use crate::pixels::enhance::{enhance_row, enhance_span, Alpha};

/// Pixels of `I'` computed at a time on the stack while learning or updating.
const CHUNK: usize = 64;
use crate::error::{Error, Result};
use crate::pixels::exposure::{fit_platform_shift, Exposure};
use crate::pixels::frame::Frame;

/// The largest number of frames [`Background::learn`] averages (the 16-bit sum of 255 frames of
/// 255 still fits).
pub const MAX_LEARN_FRAMES: usize = 255;

/// How far the spread of a frame's platform residuals may rise above that of the frame the
/// platform was estimated from, and the estimate still serve it ([`Background::estimate_or_keep`]),
/// grey levels: one step of the spread's resolution (the median of whole-level residuals).
pub const KEEP_SPREAD: f32 = 1.5;

/// Rounds of least squares in a quick exposure check (after the median offset): one tells an
/// unchanged exposure from a changed one. [`Background::estimate_or_keep`]'s check
/// ([`crate::pixels::exposure::fit_platform_shift`]) takes one; with an empty shot, the host
/// runs the full fit only where one round finds the exposure changed.
pub const KEEP_ROUNDS: usize = 1;

/// A sensible [`PlatformKeeping::every`] for a fixed camera: one estimate serves at most 30
/// frames (a second of video), so slow changes of the light are followed at least that often.
pub const DEFAULT_KEEP_FRAMES: u32 = 30;

/// A platform estimate's life across frames ([`Background::estimate_or_keep`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlatformKeeping {
    /// Most frames one estimate serves, its own included (1: every frame is estimated anew).
    pub every: u32,
    served: u32,
    spread: f32,
    stats: crate::pixels::platform::PlatformStats,
}

impl PlatformKeeping {
    /// No estimate yet; each will serve at most `every` frames (at least 1).
    pub const fn new(every: u32) -> Self {
        PlatformKeeping {
            every: if every == 0 { 1 } else { every },
            served: 0,
            spread: 0.0,
            stats: crate::pixels::platform::PlatformStats {
                cell: 0,
                cells_x: 0,
                cells_y: 0,
                with_level: 0,
                kept: 0,
                degree: 0,
                outlier: 0.0,
                range: [0.0; 2],
            },
        }
    }

    /// Forgets the estimate: the next frame is estimated anew.
    pub fn reset(&mut self) {
        *self = PlatformKeeping::new(self.every);
    }
}

/// What [`Background::estimate_or_keep`] did with a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PlatformUse {
    /// The platform was estimated from this frame.
    Estimated(crate::pixels::platform::PlatformStats),
    /// An earlier estimate served.
    Kept {
        /// That estimate's figures.
        stats: crate::pixels::platform::PlatformStats,
        /// How many frames before this one it was made.
        frames_ago: u32,
        /// This frame's exposure against it (the identity, or it would not have been kept).
        exposure: Exposure,
    },
}

impl PlatformUse {
    /// The figures of the estimate in use.
    pub fn stats(&self) -> crate::pixels::platform::PlatformStats {
        match self {
            PlatformUse::Estimated(s) | PlatformUse::Kept { stats: s, .. } => *s,
        }
    }
}

/// The learned background over a caller-provided plane of `width·height` bytes.
///
/// ```
/// use vorl_core::{pixels::background::Background, pixels::enhance::Alpha, Frame};
/// let a = Alpha::new(1.0).unwrap();
/// let mut plane = [0u8; 4];
/// let mut high = [0u8; 4];
/// let mut bg = Background::new(&mut plane[..], 2, 2).unwrap();
/// bg.learn(&Frame::new_checked(&[10u8, 20, 30, 40][..], 2, 2).unwrap(), a, &mut high).unwrap();
/// bg.learn(&Frame::new_checked(&[11u8, 20, 30, 41][..], 2, 2).unwrap(), a, &mut high).unwrap();
/// bg.finish_learning(&high).unwrap();
/// assert_eq!(bg.plane(), &[11, 20, 30, 41]); // 10.5 → 11, 40.5 → 41
/// ```
#[derive(Debug)]
pub struct Background<S> {
    plane: S,
    width: usize,
    height: usize,
    learned: usize,
    ready: bool,
    updates: u32,
}

impl<S: AsRef<[u8]> + AsMut<[u8]>> Background<S> {
    /// A model of `width`×`height` over `plane`.
    ///
    /// # Errors
    /// [`Error::EmptyFrame`] or [`Error::BufferTooSmall`].
    pub fn new(plane: S, width: usize, height: usize) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(Error::EmptyFrame { width, height });
        }
        let needed = width.saturating_mul(height);
        let got = plane.as_ref().len();
        if got < needed {
            return Err(Error::BufferTooSmall { needed, got });
        }
        Ok(Background {
            plane,
            width,
            height,
            learned: 0,
            ready: false,
            updates: 0,
        })
    }

    /// Width of the model.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height of the model.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Whether the model can be used (learning finished, or set from a frame).
    pub fn is_ready(&self) -> bool {
        self.ready
    }

    /// Frames averaged by the last learning.
    pub fn learned_frames(&self) -> usize {
        self.learned
    }

    /// The model's pixels, row by row (`width·height` bytes).
    pub fn plane(&self) -> &[u8] {
        let n = self.width * self.height;
        self.plane.as_ref().get(..n).unwrap_or(&[])
    }

    fn check<B: AsRef<[u8]>>(&self, frame: &Frame<B>) -> Result<()> {
        if frame.width() != self.width || frame.height() != self.height {
            return Err(Error::FrameSize {
                expected_width: self.width,
                expected_height: self.height,
                width: frame.width(),
                height: frame.height(),
            });
        }
        Ok(())
    }

    /// Adds one frame of `I'` to the running 16-bit sum; `high` (at least `width·height` bytes)
    /// holds the sum's high byte and must not be touched until [`Self::finish_learning`].
    /// The first call after a finished learning starts a new one.
    ///
    /// # Errors
    /// [`Error::FrameSize`], [`Error::BufferTooSmall`] for `high`, and
    /// [`Error::TooManyBackgroundFrames`] past [`MAX_LEARN_FRAMES`].
    pub fn learn<B: AsRef<[u8]>>(&mut self, frame: &Frame<B>, alpha: Alpha, high: &mut [u8]) -> Result<()> {
        self.check(frame)?;
        let n = self.width * self.height;
        if high.len() < n {
            return Err(Error::BufferTooSmall {
                needed: n,
                got: high.len(),
            });
        }
        if self.ready || self.learned == 0 {
            self.plane.as_mut().iter_mut().take(n).for_each(|p| *p = 0);
            high.iter_mut().take(n).for_each(|p| *p = 0);
            self.learned = 0;
            self.ready = false;
        }
        if self.learned >= MAX_LEARN_FRAMES {
            return Err(Error::TooManyBackgroundFrames { max: MAX_LEARN_FRAMES });
        }
        // (`max(1)`: a width of 0 has no pixels, n = 0 above; without it the chunking keeps a
        // panic path the firmware would link.)
        let w = self.width.max(1);
        let low = self.plane.as_mut();
        for (y, (lo_row, hi_row)) in low
            .chunks_exact_mut(w)
            .zip(high.chunks_exact_mut(w))
            .take(self.height)
            .enumerate()
        {
            let mut x0 = 0;
            for (lo_chunk, hi_chunk) in lo_row.chunks_mut(CHUNK).zip(hi_row.chunks_mut(CHUNK)) {
                let mut enh = [0u8; CHUNK];
                enhance_span(frame, y, x0, alpha, &mut enh);
                for ((lo, hi), &v) in lo_chunk.iter_mut().zip(hi_chunk.iter_mut()).zip(&enh) {
                    let sum = ((*hi as u16) << 8 | *lo as u16) + v as u16;
                    *lo = sum as u8;
                    *hi = (sum >> 8) as u8;
                }
                x0 += lo_chunk.len();
            }
        }
        self.learned += 1;
        Ok(())
    }

    /// Turns the sum into the rounded mean (`docs/pipeline-spec.md` §2).
    ///
    /// # Errors
    /// [`Error::NoBackground`] when no frame was learned, [`Error::BufferTooSmall`] for `high`.
    pub fn finish_learning(&mut self, high: &[u8]) -> Result<()> {
        if self.learned == 0 {
            return Err(Error::NoBackground);
        }
        let n = self.width * self.height;
        if high.len() < n {
            return Err(Error::BufferTooSmall {
                needed: n,
                got: high.len(),
            });
        }
        let k = self.learned as u32;
        for (lo, &hi) in self.plane.as_mut().iter_mut().zip(high).take(n) {
            let sum = (hi as u32) << 8 | *lo as u32;
            *lo = ((sum + k / 2) / k).min(255) as u8;
        }
        self.ready = true;
        Ok(())
    }

    /// Frame-difference mode: the model becomes this frame's `I'`.
    ///
    /// # Errors
    /// [`Error::FrameSize`].
    pub fn set_from_frame<B: AsRef<[u8]>>(&mut self, frame: &Frame<B>, alpha: Alpha) -> Result<()> {
        self.check(frame)?;
        let w = self.width;
        for (y, row) in self.plane.as_mut().chunks_exact_mut(w).take(self.height).enumerate() {
            enhance_row(frame, y, alpha, row);
        }
        self.learned = 1;
        self.ready = true;
        Ok(())
    }

    /// No empty shot: the model becomes the platform estimated from this frame itself
    /// ([`crate::pixels::platform::estimate_platform`]: vignetting, fall-off and exposure are the
    /// frame's own), with `grid` as storage. Call it for every frame before processing it.
    ///
    /// # Errors
    /// [`Error::FrameSize`]; [`crate::pixels::platform::estimate_platform`]'s errors.
    pub fn estimate_from_frame<B: AsRef<[u8]>, const G: usize>(
        &mut self,
        frame: &Frame<B>,
        alpha: Alpha,
        grid: &mut crate::pixels::platform::PlatformGrid<G>,
    ) -> Result<crate::pixels::platform::PlatformStats> {
        self.check(frame)?;
        let stats = crate::pixels::platform::estimate_platform(frame, alpha, self.plane.as_mut(), grid)?;
        self.learned = 0;
        self.ready = true;
        Ok(stats)
    }

    /// No empty shot, a fixed camera: the platform estimated from an earlier frame serves this
    /// one while it still fits it, else it is estimated anew from this frame
    /// ([`Self::estimate_from_frame`]). `keeping` carries the estimate's age and fit from
    /// frame to frame; one per model.
    ///
    /// The earlier estimate is kept when all of these hold:
    /// - it has served fewer than [`PlatformKeeping::every`] frames;
    /// - this frame's platform against it ([`crate::pixels::exposure::fit_platform_shift`]: one
    ///   round of least squares, a gain only where the platform's levels spread enough to
    ///   measure one) is the identity: no level of the platform moved by more than
    ///   [`crate::pixels::exposure::DEAD_BAND`] (a new exposure, a dimmed backlight: estimated
    ///   anew, so the frame gives what its own estimate would);
    /// - enough samples agree with it ([`crate::pixels::exposure::MIN_SAMPLES`]);
    /// - their spread ([`Exposure::spread`]) is at most [`KEEP_SPREAD`] grey levels above that
    ///   of the estimate's own frame (light that changed in places, a moved camera).
    ///
    /// A kept frame costs one exposure check (the median offset and one round of least squares
    /// on at most [`crate::pixels::exposure::MAX_SAMPLES`] samples) instead of the estimate and its
    /// plane; an estimated one costs the estimate and one check more (its own spread).
    ///
    /// ```
    /// use vorl_core::{pixels::background::{Background, PlatformKeeping, PlatformUse}, pixels::enhance::Alpha, pixels::platform::PlatformGrid, Frame};
    /// let (w, h) = (64usize, 48usize);
    /// // A backlight falling off to the right, a little noise, and a dark part that moves.
    /// let scene = |x0: usize| -> Vec<u8> {
    ///     let mut px = vec![0u8; w * h];
    ///     for y in 0..h { for x in 0..w {
    ///         let noise = ((x * 7 + y * 13 + x0) % 5) as i32 - 2;
    ///         let part = (x0..x0 + 12).contains(&x) && (16..30).contains(&y);
    ///         px[y * w + x] = if part { 30 } else { (220 - 40 * x / w) as i32 + noise } as u8;
    ///     } }
    ///     px
    /// };
    /// let mut plane = vec![0u8; w * h];
    /// let mut bg = Background::new(&mut plane[..], w, h).unwrap();
    /// let mut grid = PlatformGrid::<64>::new();
    /// let mut keeping = PlatformKeeping::new(30);
    /// let (a, b) = (scene(10), scene(40));
    /// let first = bg.estimate_or_keep(&Frame::new_checked(&a[..], w, h).unwrap(), Alpha::ONE, &mut grid, &mut keeping).unwrap();
    /// assert!(matches!(first, PlatformUse::Estimated(_)));
    /// let second = bg.estimate_or_keep(&Frame::new_checked(&b[..], w, h).unwrap(), Alpha::ONE, &mut grid, &mut keeping).unwrap();
    /// assert!(matches!(second, PlatformUse::Kept { frames_ago: 1, .. }), "{second:?}");
    /// // The same scene under a brighter exposure: estimated anew.
    /// let bright: Vec<u8> = b.iter().map(|&v| (v as f32 * 1.1).min(255.0) as u8).collect();
    /// let third = bg.estimate_or_keep(&Frame::new_checked(&bright[..], w, h).unwrap(), Alpha::ONE, &mut grid, &mut keeping).unwrap();
    /// assert!(matches!(third, PlatformUse::Estimated(_)));
    /// ```
    ///
    /// # Errors
    /// As [`Self::estimate_from_frame`].
    pub fn estimate_or_keep<B: AsRef<[u8]>, const G: usize>(
        &mut self,
        frame: &Frame<B>,
        alpha: Alpha,
        grid: &mut crate::pixels::platform::PlatformGrid<G>,
        keeping: &mut PlatformKeeping,
    ) -> Result<PlatformUse> {
        self.check(frame)?;
        if self.ready && keeping.served > 0 && keeping.served < keeping.every {
            let e = fit_platform_shift(frame, alpha, self.plane.as_ref())?;
            let fits = e.is_identity()
                && e.samples > 0
                && e.inliers >= crate::pixels::exposure::MIN_SAMPLES
                && e.spread <= keeping.spread + KEEP_SPREAD;
            if fits {
                let frames_ago = keeping.served;
                keeping.served += 1;
                return Ok(PlatformUse::Kept {
                    stats: keeping.stats,
                    frames_ago,
                    exposure: e,
                });
            }
        }
        let stats = self.estimate_from_frame(frame, alpha, grid)?;
        let own = fit_platform_shift(frame, alpha, self.plane.as_ref())?;
        *keeping = PlatformKeeping {
            every: keeping.every,
            served: 1,
            spread: own.spread,
            stats,
        };
        Ok(PlatformUse::Estimated(stats))
    }

    /// Slow update: every `2^shift` calls, each pixel whose `labels` entry is 0 (background in
    /// the last mask) moves one grey level towards this frame's `I'`.
    ///
    /// # Errors
    /// [`Error::NoBackground`], [`Error::FrameSize`], [`Error::BufferTooSmall`] for `labels`.
    pub fn update<B: AsRef<[u8]>>(&mut self, frame: &Frame<B>, alpha: Alpha, labels: &[u8], shift: u8) -> Result<()> {
        if !self.ready {
            return Err(Error::NoBackground);
        }
        self.check(frame)?;
        let n = self.width * self.height;
        if labels.len() < n {
            return Err(Error::BufferTooSmall {
                needed: n,
                got: labels.len(),
            });
        }
        self.updates = self.updates.wrapping_add(1);
        let period = 1u32 << shift.min(31);
        if self.updates % period != 0 {
            return Ok(());
        }
        let w = self.width;
        for (y, (brow, lrow)) in self
            .plane
            .as_mut()
            .chunks_exact_mut(w)
            .zip(labels.chunks_exact(w))
            .take(self.height)
            .enumerate()
        {
            let mut x0 = 0;
            for (bchunk, lchunk) in brow.chunks_mut(CHUNK).zip(lrow.chunks(CHUNK)) {
                let mut enh = [0u8; CHUNK];
                enhance_span(frame, y, x0, alpha, &mut enh);
                for ((b, &l), &v) in bchunk.iter_mut().zip(lchunk).zip(&enh) {
                    if l == 0 {
                        if v > *b {
                            *b += 1;
                        } else if v < *b {
                            *b -= 1;
                        }
                    }
                }
                x0 += bchunk.len();
            }
        }
        Ok(())
    }
}
