//! A frame's exposure against a fixed background: the gain and offset that map the empty
//! shot's levels onto the frame's, fitted on the platform's own pixels.
//!
//! A camera's exposure (shutter, gain, a backlight that dims with age) changes between the
//! empty shot and a frame, and then the whole platform differs from the model by more than the
//! foreground threshold: everything is foreground. [`fit_exposure`] finds `gain` and `offset`
//! with `frame ≈ gain · background + offset` on the pixels that are platform, and
//! [`Exposure::undo`] maps a frame back to the background's exposure before it is processed, so
//! a brighter or dimmer exposure of one scene gives the same masks and poses.
//!
//! The fit, on at most [`MAX_SAMPLES`] pixels on a regular grid (of `I'`, the model's own
//! quantity):
//! 1. the offset alone first: the median of `frame − background` (a 511-bin histogram), gain 1;
//! 2. then [`ROUNDS`] rounds of least squares for gain and offset over the samples within a
//!    threshold of the last fit: `max(`[`MIN_INLIER`]`, 4 × 1.4826 × MAD)` of the residuals of
//!    the last round's inliers, the first round `4 ×` [`MIN_INLIER`] (the offset alone does
//!    not follow a gain). One pass over the samples per round.
//!    Parts differ from the platform by more than the foreground threshold and fall out; the
//!    platform is most of the frame.
//!
//! A background of one level cannot tell a gain from an offset: the fit is then an offset (gain
//! 1). The result is the identity ([`Exposure::is_identity`]) when it changes no level of the
//! platform's by more than [`DEAD_BAND`] (a fixed camera's frames keep their bytes), and
//! [`Exposure::IDENTITY`] when too few samples agree.
//!
//! Time: one pass over the samples per round (4 in all). Memory: two histograms on the stack
//! (3 KB).

use crate::error::{Error, Result};
use crate::pixels::enhance::{enhance_span, Alpha};
use crate::pixels::frame::Frame;

/// The fit samples every `s`-th pixel of every `s`-th row, `s` the smallest of at least
/// `MIN_STEP` that takes at most [`MAX_SAMPLES`] samples.
pub const MIN_STEP: usize = 2;
/// Most samples the fit takes (QVGA: every 6th pixel of every 6th row; VGA: every 12th).
pub const MAX_SAMPLES: usize = 1200;
/// Rounds of least squares after the offset.
pub const ROUNDS: usize = 3;
/// The smallest inlier threshold, grey levels.
pub const MIN_INLIER: f32 = 6.0;
/// A fit that moves no level of 0..=255 by more than this many grey levels is the identity
/// (slow drift within the noise leaves the frame's bytes alone).
pub const DEAD_BAND: f32 = 2.0;
/// Fewest samples the fit needs (else the identity).
pub const MIN_SAMPLES: u32 = 64;

/// `frame ≈ gain · background + offset` on the platform's pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exposure {
    /// Multiplies the background's level.
    pub gain: f32,
    /// Added after the gain, grey levels.
    pub offset: f32,
    /// Samples the last round kept (the platform's share of the samples).
    pub inliers: u32,
    /// Samples taken.
    pub samples: u32,
    /// The lowest and highest background level among the inliers (the platform's levels).
    pub levels: [f32; 2],
    /// The platform's residuals after the fit: `1.4826 × MAD` of the last round's inliers,
    /// grey levels (about the noise's σ when the model fits the frame; larger when it does
    /// not, as a platform of another frame under other light).
    pub spread: f32,
}

impl Exposure {
    /// No change: gain 1, offset 0.
    pub const IDENTITY: Exposure = Exposure {
        gain: 1.0,
        offset: 0.0,
        inliers: 0,
        samples: 0,
        levels: [0.0; 2],
        spread: 0.0,
    };

    /// Whether undoing it changes no level of the platform's ([`Self::levels`]) by more than
    /// [`DEAD_BAND`] (then [`Self::undo`] leaves the frame alone).
    pub fn is_identity(&self) -> bool {
        let moved = |v: f32| (self.gain * v + self.offset - v).abs();
        let [lo, hi] = self.levels;
        moved(lo) <= DEAD_BAND && moved(hi) <= DEAD_BAND
    }

    /// The table that maps a frame's level `v` to the background's exposure,
    /// `round((v − offset) / gain)` clamped to 0..=255 (the identity for
    /// [`Self::is_identity`] or a gain that is not positive).
    pub fn undo_table(&self) -> [u8; 256] {
        let mut lut = [0u8; 256];
        let usable = !self.is_identity() && self.gain > 0.0 && self.gain.is_finite() && self.offset.is_finite();
        for (v, slot) in lut.iter_mut().enumerate() {
            *slot = if usable {
                let x = (v as f32 - self.offset) / self.gain;
                crate::math::round(x).clamp(0.0, 255.0) as u8
            } else {
                v as u8
            };
        }
        lut
    }

    /// Maps `pixels` (a frame's bytes) back to the background's exposure in place
    /// ([`Self::undo_table`]).
    ///
    /// ```
    /// use vorl_core::pixels::exposure::Exposure;
    /// let e = Exposure { gain: 0.5, offset: 10.0, inliers: 100, samples: 100, levels: [0.0, 255.0], spread: 1.0 };
    /// let mut px = [10u8, 60, 110, 200];
    /// e.undo(&mut px);
    /// assert_eq!(px, [0, 100, 200, 255]);
    /// ```
    pub fn undo(&self, pixels: &mut [u8]) {
        if self.is_identity() {
            return;
        }
        let lut = self.undo_table();
        for p in pixels {
            *p = lut.get(*p as usize).copied().unwrap_or(*p);
        }
    }
}

/// Fits the exposure of `frame` (its `I'` for `alpha`) against `background` (the model's plane,
/// row-major, the frame's size). See the module doc.
///
/// ```
/// use vorl_core::{pixels::enhance::Alpha, pixels::exposure::fit_exposure, Frame};
/// // A platform falling off from 200 to 120, a dark part, and the same scene at 0.7·v + 6.
/// let (w, h) = (64usize, 48usize);
/// let mut bg = vec![0u8; w * h];
/// for y in 0..h { for x in 0..w { bg[y * w + x] = (200 - 80 * x / (w - 1)) as u8; } }
/// let mut scene = bg.clone();
/// for y in 16..32 { for x in 20..44 { scene[y * w + x] = 30; } }
/// let dim: Vec<u8> = scene.iter().map(|&v| (0.7 * v as f32 + 6.0).round() as u8).collect();
/// let frame = Frame::new_checked(&dim[..], w, h).unwrap();
/// let e = fit_exposure(&frame, Alpha::ONE, &bg).unwrap();
/// assert!((e.gain - 0.7).abs() < 0.01 && (e.offset - 6.0).abs() < 1.0, "{e:?}");
/// let mut undone = dim.clone();
/// e.undo(&mut undone);
/// // Back at the background's exposure (within a level of the original scene).
/// assert!(undone.iter().zip(&scene).all(|(a, b)| (*a as i32 - *b as i32).abs() <= 1));
/// ```
///
/// # Errors
/// [`Error::BufferTooSmall`] when `background` is shorter than the frame.
pub fn fit_exposure<B: AsRef<[u8]>>(frame: &Frame<B>, alpha: Alpha, background: &[u8]) -> Result<Exposure> {
    fit_rounds(frame, alpha, background, ROUNDS)
}

/// [`fit_exposure`] with `rounds` rounds of least squares after the offset (`1..=`[`ROUNDS`];
/// other values are clamped into it): the
/// quick check of [`crate::pixels::background::Background::estimate_or_keep`] takes one, which tells an
/// unchanged exposure from a changed one and gives the residuals' spread at half the cost.
///
/// # Errors
/// As [`fit_exposure`].
pub fn fit_exposure_rounds<B: AsRef<[u8]>>(
    frame: &Frame<B>,
    alpha: Alpha,
    background: &[u8],
    rounds: usize,
) -> Result<Exposure> {
    fit_rounds(frame, alpha, background, rounds.clamp(1, ROUNDS))
}

/// Whether the platform still matches `background` (the platform's estimate): [`fit_exposure`]
/// with one round of least squares, its gain kept only where the platform's levels spread enough
/// to measure it, else an offset: whether the platform's levels moved. The gain is measurable
/// where it moves the platform's levels, one standard deviation from their mean, by at least the
/// robust spread of the residuals around it (one more pass over the samples, only where the
/// gain fit is not already the identity); over a platform of a few grey levels it is not: the
/// background's own noise flattens it, and light that varies across the platform tilts it. The no-shot path's check of whether an estimate still serves a frame
/// ([`crate::pixels::background::Background::estimate_or_keep`]), and the host's quick check of
/// whether a frame's exposure changed against the empty shot (a changed one then gets
/// [`fit_exposure`], whose gain is undone).
///
/// ```
/// use vorl_core::{pixels::enhance::Alpha, pixels::exposure::{fit_exposure_rounds, fit_platform_shift}, Frame};
/// // A platform of 8 levels (120–127) seen twice with fresh noise (±2 levels), the second
/// // time 3 levels brighter.
/// let (w, h) = (96usize, 72usize);
/// let noise = |i: usize, k: usize| (((i * (2 * k + 1) * 2_654_435_761) >> 16) % 5) as u8;
/// let level = |i: usize| (120 + (i % w) * 8 / w) as u8;
/// let bg: Vec<u8> = (0..w * h).map(|i| level(i) + noise(i, 1) - 2).collect();
/// let frame: Vec<u8> = (0..w * h).map(|i| level(i) + noise(i, 2) + 1).collect();
/// let frame = Frame::new_checked(&frame[..], w, h).unwrap();
/// // Least squares flatten the gain: the background's noise is a third of its levels' spread.
/// let full = fit_exposure_rounds(&frame, Alpha::ONE, &bg, 1).unwrap();
/// assert!(full.gain < 0.85, "{full:?}");
/// // The shift is an offset.
/// let shift = fit_platform_shift(&frame, Alpha::ONE, &bg).unwrap();
/// assert_eq!(shift.gain, 1.0);
/// assert!((shift.offset - 3.0).abs() < 0.3, "{shift:?}");
/// ```
///
/// # Errors
/// As [`fit_exposure`].
pub fn fit_platform_shift<B: AsRef<[u8]>>(frame: &Frame<B>, alpha: Alpha, background: &[u8]) -> Result<Exposure> {
    fit_with(frame, alpha, background, 1, GainRule::WhereMeasurable)
}

/// When a fit's least squares give a gain rather than an offset alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum GainRule {
    /// Wherever the levels spread over more than a grey level (an exposure undone: a real
    /// change of it on a narrow platform still moves the parts' levels).
    Spread,
    /// Where the gain is measurable ([`shift_unless_measurable`]).
    WhereMeasurable,
}

fn fit_rounds<B: AsRef<[u8]>>(frame: &Frame<B>, alpha: Alpha, background: &[u8], rounds: usize) -> Result<Exposure> {
    fit_with(frame, alpha, background, rounds, GainRule::Spread)
}

fn fit_with<B: AsRef<[u8]>>(
    frame: &Frame<B>,
    alpha: Alpha,
    background: &[u8],
    rounds: usize,
    rule: GainRule,
) -> Result<Exposure> {
    let (w, h) = (frame.width(), frame.height());
    let needed = w.saturating_mul(h);
    if background.len() < needed {
        return Err(Error::BufferTooSmall {
            needed,
            got: background.len(),
        });
    }
    // 1. The offset alone: the median difference.
    let mut hist = [0u32; 511];
    let mut samples = 0u32;
    for_samples(frame, alpha, background, |f, b| {
        if let Some(slot) = hist.get_mut((f as i32 - b as i32 + 255) as usize) {
            *slot += 1;
        }
        samples += 1;
    });
    if samples < MIN_SAMPLES {
        return Ok(Exposure::IDENTITY);
    }
    let median = median_bin(&hist, samples).map_or(0.0, |i| i as f32 - 255.0);
    let (mut gain, mut offset) = (1.0f32, median);
    let mut inliers = 0u32;
    let mut levels = [0.0f32; 2];
    let mut spread = 0.0f32;
    let mut threshold = 4.0 * MIN_INLIER;
    for _ in 0..rounds {
        // Least squares of f = gain·b + offset over the samples within the threshold of the
        // last fit, and their residuals' histogram for the next round's threshold. The sums
        // are exact integers (levels ≤ 255, at most MAX_SAMPLES of them: below 2^32 each).
        let line = Line::new(gain, offset);
        let mut abs_hist = [0u32; 256];
        let (mut n, mut sb, mut sf, mut sbb, mut sbf) = (0u32, 0u64, 0u64, 0u64, 0u64);
        let mut range = [u8::MAX, 0u8];
        for_samples(frame, alpha, background, |f, b| {
            let r = line.residual(f, b);
            if r <= threshold {
                range = [range[0].min(b), range[1].max(b)];
                if let Some(slot) = abs_hist.get_mut(r as usize) {
                    *slot += 1;
                }
                let (f, b) = (f as u64, b as u64);
                n += 1;
                sb += b;
                sf += f;
                sbb += b * b;
                sbf += b * f;
            }
        });
        if n < MIN_SAMPLES {
            return Ok(Exposure::IDENTITY);
        }
        inliers = n;
        levels = [range[0] as f32, range[1] as f32];
        let mad = mad_of(&abs_hist, n);
        spread = 1.4826 * mad;
        threshold = (4.0 * 1.4826 * mad).max(MIN_INLIER);
        // Centred moments, exact in integers: n²·var = n·Σb² − (Σb)², n²·cov = n·Σbf − Σb·Σf.
        let nn = n as u64;
        let var_n2 = nn_var(n, sb, sbb);
        let cov_n2 = (nn * sbf) as i64 - (sb as i64) * (sf as i64);
        let nf = n as f32;
        let (mb, mf) = (sb as f32 / nf, sf as f32 / nf);
        // Levels spread over less than ~2 grey levels cannot separate gain from offset.
        let (g, o) = if var_n2 as f32 > nf * nf {
            let g = cov_n2 as f32 / var_n2 as f32;
            (g, mf - g * mb)
        } else {
            (1.0, mf - mb)
        };
        if !(g.is_finite() && o.is_finite() && g > 0.0) {
            return Ok(Exposure::IDENTITY);
        }
        (gain, offset) = (g, o);
    }
    let mut e = Exposure {
        gain,
        offset,
        inliers,
        samples,
        levels,
        spread,
    };
    // (A fit within the dead band is the identity either way.)
    if rule == GainRule::WhereMeasurable && gain != 1.0 && !e.is_identity() {
        if let Some(shift) = shift_unless_measurable(frame, alpha, background, e, threshold) {
            e = shift;
        }
    }
    Ok(if e.is_identity() {
        Exposure {
            gain: 1.0,
            offset: 0.0,
            ..e
        }
    } else {
        e
    })
}

/// [`GainRule::WhereMeasurable`]: `None` where `fit`'s gain `g` is measurable, else the offset
/// that replaces it. One more pass over the samples: `g` is measurable where it moves the
/// platform's levels, one standard deviation from their mean, by at least the robust spread
/// (`1.4826 × MAD`) of the residuals around it: `(g − 1)²·var_b ≥ σ²`, over the samples within
/// `threshold` of the line. Else the offset is the mean `frame − background` of the samples
/// within `threshold` of the line's offset at their mid level, with their levels and spread.
///
/// Over a platform of a few grey levels a gain is not measurable: the background's own noise
/// flattens it (by `var / (var + σ²)`), and light that varies across the platform by a level or
/// two from frame to frame tilts it. The generated sets' platforms (levels 116–138) fit gains
/// of 0.5–0.85 at their own exposure, which extrapolate to a dark part 15 levels and more away,
/// and which moved the extreme platform levels past [`DEAD_BAND`] so that an estimate that still
/// fitted was made anew. A change of exposure on a wide platform (the real backlights' levels
/// spread over 60–90) moves its levels apart by far more than the residuals.
fn shift_unless_measurable<B: AsRef<[u8]>>(
    frame: &Frame<B>,
    alpha: Alpha,
    background: &[u8],
    fit: Exposure,
    threshold: f32,
) -> Option<Exposure> {
    // One pass: the residuals of the samples within `threshold` of the fitted line (their
    // median, and their background levels' variance), and those within it of the offset line
    // that meets the fitted one at the inliers' mid level (their mean difference, levels and
    // median residual).
    let mut line_hist = [0u32; 256];
    let (mut n, mut sb, mut sbb) = (0u32, 0u64, 0u64);
    let mut shift_hist = [0u32; 256];
    let (mut m, mut sd) = (0u32, 0i64);
    let mut range = [u8::MAX, 0u8];
    let line = Line::new(fit.gain, fit.offset);
    // The offset line's offset: the fit's value at the inliers' mean level.
    let mid = 0.5 * (fit.levels[0] + fit.levels[1]);
    let offset = fit.gain * mid + fit.offset - mid;
    for_samples(frame, alpha, background, |f, b| {
        let r = line.residual(f, b);
        if r <= threshold {
            if let Some(slot) = line_hist.get_mut(r as usize) {
                *slot += 1;
            }
            n += 1;
            sb += b as u64;
            sbb += b as u64 * b as u64;
        }
        let d = f as f32 - b as f32 - offset;
        if d.abs() <= threshold {
            if let Some(slot) = shift_hist.get_mut(d.abs() as usize) {
                *slot += 1;
            }
            m += 1;
            sd += f as i64 - b as i64;
            range = [range[0].min(b), range[1].max(b)];
        }
    });
    if n < MIN_SAMPLES || m < MIN_SAMPLES {
        return None;
    }
    let sigma = 1.4826 * mad_of(&line_hist, n);
    let nf = n as f32;
    let var_b = nn_var(n, sb, sbb) as f32 / (nf * nf);
    if (fit.gain - 1.0) * (fit.gain - 1.0) * var_b >= sigma * sigma {
        return None;
    }
    let mad = mad_of(&shift_hist, m);
    Some(Exposure {
        gain: 1.0,
        offset: sd as f32 / m as f32,
        inliers: m,
        levels: [range[0] as f32, range[1] as f32],
        spread: 1.4826 * mad,
        ..fit
    })
}

/// `n²` times the variance of `n` values of sum `s` and sum of squares `ss` (exact in integers).
fn nn_var(n: u32, s: u64, ss: u64) -> i64 {
    (n as u64 * ss) as i64 - (s as i64) * (s as i64)
}

/// The line `gain · b + offset` tabulated over the background's levels.
struct Line([f32; 256]);

impl Line {
    fn new(gain: f32, offset: f32) -> Self {
        let mut predicted = [0.0f32; 256];
        for (b, p) in predicted.iter_mut().enumerate() {
            *p = gain * b as f32 + offset;
        }
        Line(predicted)
    }

    /// `|f − (gain · b + offset)|`.
    fn residual(&self, f: u8, b: u8) -> f32 {
        (f as f32 - self.0.get(b as usize).copied().unwrap_or(0.0)).abs()
    }
}

/// The median absolute residual of `n` residuals binned by whole grey levels in `hist` (a
/// bin's centre; 0 for none).
fn mad_of(hist: &[u32], n: u32) -> f32 {
    median_bin(hist, n).map_or(0.0, |i| i as f32 + 0.5)
}

/// The sampling step for a `w`×`h` frame ([`MIN_STEP`], [`MAX_SAMPLES`]).
fn sample_step(w: usize, h: usize) -> usize {
    // At most 256: a frame of 65 536² px would then still be sampled at about 2 500 points.
    (MIN_STEP..256)
        .find(|&s| w.div_ceil(s.max(1)).saturating_mul(h.div_ceil(s.max(1))) <= MAX_SAMPLES)
        .unwrap_or(256)
}

/// Calls `f(frame level, background level)` for every sample.
fn for_samples<B: AsRef<[u8]>>(frame: &Frame<B>, alpha: Alpha, background: &[u8], mut f: impl FnMut(u8, u8)) {
    const CHUNK: usize = 64;
    let w = frame.width();
    let step = sample_step(w, frame.height()).max(1);
    for y in (0..frame.height()).step_by(step) {
        let row = background.get(y * w..(y + 1) * w).unwrap_or(&[]);
        if alpha.get() >= 1.0 {
            // I' = I: the frame's own row (by index: a step over a zipped pair of rows would
            // walk every pixel in between).
            let frame_row = frame.row(y);
            for x in (0..w).step_by(step) {
                if let (Some(&v), Some(&b)) = (frame_row.get(x), row.get(x)) {
                    f(v, b);
                }
            }
            continue;
        }
        let mut x = 0;
        while x < w {
            // A chunk starts on a sample (its length is a multiple of the step).
            let len = (w - x).min(CHUNK / step * step).max(1);
            let mut buf = [0u8; CHUNK];
            let part = buf.get_mut(..len).unwrap_or(&mut []);
            enhance_span(frame, y, x, alpha, part);
            for (k, &v) in part.iter().enumerate().step_by(step) {
                if let Some(&b) = row.get(x + k) {
                    f(v, b);
                }
            }
            x += len;
        }
    }
}

/// The bin holding the median of `count` values in `hist`.
fn median_bin(hist: &[u32], count: u32) -> Option<usize> {
    if count == 0 {
        return None;
    }
    let half = count.div_ceil(2);
    let mut seen = 0u32;
    for (i, &c) in hist.iter().enumerate() {
        seen += c;
        if seen >= half {
            return Some(i);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::vec::Vec;

    /// A vignetted platform (210 at the centre, 140 in the corners) with dark and bright parts
    /// over 30 % of it.
    fn scene(w: usize, h: usize) -> (Vec<u8>, Vec<u8>) {
        let (cx, cy) = (w as f32 / 2.0, h as f32 / 2.0);
        let r2 = cx * cx + cy * cy;
        let bg: Vec<u8> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32 - cx, (i / w) as f32 - cy);
                (210.0 - 70.0 * (x * x + y * y) / r2).round() as u8
            })
            .collect();
        let mut s = bg.clone();
        for (i, v) in s.iter_mut().enumerate() {
            let (x, y) = (i % w, i / w);
            if (10..50).contains(&x) && (10..40).contains(&y) {
                *v = 25;
            }
            if (70..100).contains(&x) && (30..70).contains(&y) {
                *v = 250;
            }
        }
        (bg, s)
    }

    fn expose(s: &[u8], gain: f32, offset: f32) -> Vec<u8> {
        s.iter()
            .map(|&v| (gain * v as f32 + offset).round().clamp(0.0, 255.0) as u8)
            .collect()
    }

    #[test]
    fn recovers_gain_and_offset_with_parts_of_both_polarities() {
        let (w, h) = (120, 90);
        let (bg, s) = scene(w, h);
        for (gain, offset) in [(0.6, 10.0), (1.15, -8.0), (0.8, 0.0), (1.0, 12.0)] {
            let f = expose(&s, gain, offset);
            let frame = Frame::new_checked(&f[..], w, h).unwrap();
            let e = fit_exposure(&frame, Alpha::ONE, &bg).unwrap();
            assert!((e.gain - gain).abs() < 0.01, "{gain} {offset}: {e:?}");
            assert!((e.offset - offset).abs() < 1.2, "{gain} {offset}: {e:?}");
            // The parts are not platform.
            assert!(e.inliers < e.samples * 8 / 10, "{e:?}");
            // Undone, the platform is the background's within a level.
            let mut u = f.clone();
            e.undo(&mut u);
            let off = u
                .iter()
                .zip(&s)
                .filter(|(a, b)| (**a as i32 - **b as i32).abs() > 1 && **b > 30 && **b < 245)
                .count();
            assert_eq!(off, 0, "{gain} {offset}");
        }
    }

    #[test]
    fn same_exposure_is_the_identity() {
        let (w, h) = (120, 90);
        let (bg, s) = scene(w, h);
        let frame = Frame::new_checked(&s[..], w, h).unwrap();
        let e = fit_exposure(&frame, Alpha::ONE, &bg).unwrap();
        assert!(e.is_identity(), "{e:?}");
        let mut u = s.clone();
        e.undo(&mut u);
        assert_eq!(u, s);
    }

    #[test]
    fn a_flat_platform_gets_an_offset() {
        let (w, h) = (64, 48);
        let bg = std::vec![150u8; w * h];
        let f = std::vec![170u8; w * h];
        let frame = Frame::new_checked(&f[..], w, h).unwrap();
        let e = fit_exposure(&frame, Alpha::ONE, &bg).unwrap();
        assert_eq!(e.gain, 1.0);
        assert!((e.offset - 20.0).abs() < 1e-3, "{e:?}");
    }

    #[test]
    fn the_platform_shift_keeps_a_gain_only_where_it_is_measurable() {
        // A wide platform (140–210) at another exposure: the gain is measurable and kept (one
        // round of least squares: on its way to the exposure's, parts' pixels still pull it).
        let (w, h) = (120, 90);
        let (bg, s) = scene(w, h);
        for (gain, offset) in [(0.6, 10.0), (1.15, -8.0)] {
            let f = expose(&s, gain, offset);
            let frame = Frame::new_checked(&f[..], w, h).unwrap();
            let e = fit_platform_shift(&frame, Alpha::ONE, &bg).unwrap();
            assert!(
                (e.gain - 1.0).signum() == (gain - 1.0).signum() && (e.gain - 1.0).abs() > 0.1,
                "{gain} {offset}: {e:?}"
            );
            assert!(!e.is_identity());
        }
        // A platform of a few levels (124..=129) seen twice with fresh noise (σ ≈ 1.6), the
        // second time under light tilted by up to ±1.5 levels across it: least squares find a
        // gain well below 1 (the noise of the background flattens it, the tilt tilts it) that
        // moves the platform past the dead band; the shift is an offset within it.
        let noise = |i: usize, k: u64| {
            let mut v = (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(k);
            v ^= v >> 29;
            v = v.wrapping_mul(0xBF58_476D_1CE4_E5B9);
            ((v >> 40) % 4 + (v >> 20) % 4) as f32 - 3.0
        };
        let level = |i: usize| 124.0 + ((i % w) * 6 / w) as f32;
        let bg: Vec<u8> = (0..w * h).map(|i| (level(i) + noise(i, 1)).round() as u8).collect();
        let f: Vec<u8> = (0..w * h)
            .map(|i| {
                let tilt = 1.5 - 3.0 * (i % w) as f32 / w as f32;
                (level(i) + tilt + noise(i, 2)).round() as u8
            })
            .collect();
        let frame = Frame::new_checked(&f[..], w, h).unwrap();
        let full = fit_exposure(&frame, Alpha::ONE, &bg).unwrap();
        assert!(full.gain < 0.7 && !full.is_identity(), "{full:?}");
        let shift = fit_platform_shift(&frame, Alpha::ONE, &bg).unwrap();
        assert_eq!(shift.gain, 1.0, "{shift:?}");
        assert!(shift.offset.abs() < 0.5 && shift.is_identity(), "{shift:?}");
    }

    #[test]
    fn bad_input() {
        let f = [0u8; 16];
        let frame = Frame::new_checked(&f[..], 4, 4).unwrap();
        assert!(fit_exposure(&frame, Alpha::ONE, &[0u8; 15]).is_err());
        // Too few samples: the identity.
        assert_eq!(
            fit_exposure(&frame, Alpha::ONE, &[0u8; 16]).unwrap(),
            Exposure::IDENTITY
        );
        // A nonsense exposure undoes nothing.
        for gain in [f32::NAN, -1.0] {
            let mut px = [1u8, 2, 3];
            Exposure {
                spread: 0.0,
                gain,
                offset: 3.0,
                inliers: 0,
                samples: 0,
                levels: [0.0, 255.0],
            }
            .undo(&mut px);
            assert_eq!(px, [1, 2, 3], "gain {gain}");
        }
    }
}
