//! §1–§3: edge-enhanced intensity, background model, difference image, Otsu, foreground mask
//! and its 3×3 morphological clean-up.

use std::cmp::Ordering;

use image::{GrayImage, Luma};

use super::{RefCleanup, RefError, RefPolarity, RefThreshold};

/// Edge-enhanced intensity `I'` of eq. 3.1 as fixed by §1.
///
/// Sobel `gx = [-1 0 1; -2 0 2; -1 0 1]`, `gy` its transpose, with replicated borders;
/// `g = sqrt(gx² + gy²)` scaled by `1 / (4·√2)`; then
/// `I' = round(α·I + (1 − α)·g / (4·√2))` (half away from zero), clamped to `[0, 255]`.
/// α is not checked; a NaN result becomes 0.
pub fn enhance(img: &GrayImage, alpha: f64) -> GrayImage {
    let (w, h) = img.dimensions();
    let mut out = GrayImage::new(w, h);
    if w == 0 || h == 0 {
        return out;
    }
    // Replicated border: a neighbour outside the image takes the nearest pixel inside.
    let at = |x: i64, y: i64| -> f64 {
        let xc = x.clamp(0, i64::from(w) - 1) as u32;
        let yc = y.clamp(0, i64::from(h) - 1) as u32;
        f64::from(img.get_pixel(xc, yc).0[0])
    };
    let scale = 4.0 * std::f64::consts::SQRT_2;
    for y in 0..h {
        for x in 0..w {
            let (xi, yi) = (i64::from(x), i64::from(y));
            // gx = [-1 0 1; -2 0 2; -1 0 1]
            let gx = (at(xi + 1, yi - 1) - at(xi - 1, yi - 1))
                + 2.0 * (at(xi + 1, yi) - at(xi - 1, yi))
                + (at(xi + 1, yi + 1) - at(xi - 1, yi + 1));
            // gy = gxᵀ = [-1 -2 -1; 0 0 0; 1 2 1]
            let gy = (at(xi - 1, yi + 1) - at(xi - 1, yi - 1))
                + 2.0 * (at(xi, yi + 1) - at(xi, yi - 1))
                + (at(xi + 1, yi + 1) - at(xi + 1, yi - 1));
            let g = (gx * gx + gy * gy).sqrt();
            // eq. 3.1: I' = α·I + (1 − α)·|∇I|, the gradient scaled into the intensity range.
            let value = alpha * at(xi, yi) + (1.0 - alpha) * g / scale;
            out.put_pixel(x, y, Luma([to_u8(value.round())]));
        }
    }
    out
}

/// Clamps to `[0, 255]` (NaN → 0).
fn to_u8(v: f64) -> u8 {
    if v.is_nan() {
        0
    } else {
        v.clamp(0.0, 255.0) as u8
    }
}

/// Mean background model of §2 (section 3.2): `B = floor((Σ I' + K/2) / K)` over the `K`
/// frames' edge-enhanced intensities `I' = enhance(frame, alpha)`.
///
/// Errors: no frames, more than 255 frames, frames of different sizes.
pub fn learn_background(frames: &[GrayImage], alpha: f64) -> Result<GrayImage, RefError> {
    let first = frames.first().ok_or(RefError::NoFrames)?;
    if frames.len() > 255 {
        return Err(RefError::TooManyFrames(frames.len()));
    }
    let (w, h) = first.dimensions();
    for f in frames {
        if f.dimensions() != (w, h) {
            return Err(RefError::SizeMismatch {
                expected: (w, h),
                found: f.dimensions(),
            });
        }
    }
    let mut sum = vec![0u32; first.as_raw().len()];
    for f in frames {
        let e = enhance(f, alpha);
        for (s, &v) in sum.iter_mut().zip(e.as_raw()) {
            *s += u32::from(v);
        }
    }
    let k = frames.len() as u32;
    let mut out = GrayImage::new(w, h);
    for (o, &s) in out.iter_mut().zip(&sum) {
        // B = floor((Σ I' + K/2) / K), integer division
        *o = ((s + k / 2) / k) as u8;
    }
    Ok(out)
}

/// The difference image `D(x, y) = |I'(x, y) − B(x, y)|` of §3. Errors when the sizes differ.
pub fn difference(enhanced: &GrayImage, background: &GrayImage) -> Result<GrayImage, RefError> {
    same_size(enhanced, background)?;
    let mut out = GrayImage::new(enhanced.width(), enhanced.height());
    for ((o, &a), &b) in out.iter_mut().zip(enhanced.as_raw()).zip(background.as_raw()) {
        *o = a.abs_diff(b);
    }
    Ok(out)
}

fn same_size(a: &GrayImage, b: &GrayImage) -> Result<(), RefError> {
    if a.dimensions() == b.dimensions() {
        Ok(())
    } else {
        Err(RefError::SizeMismatch {
            expected: a.dimensions(),
            found: b.dimensions(),
        })
    }
}

/// Otsu's level of the histogram of `d` (§3): the `t` maximising `w0·w1·(μ0 − μ1)²` with class 0
/// being `D ≤ t`; the first such `t` in increasing order; 0 when no `t` gives a positive value.
///
/// With counts `w0`, `w1`, class sums `s0`, `s1` and `N = w0 + w1`, `S = s0 + s1`:
/// `w0·w1·(μ0 − μ1)² = (s0·N − S·w0)² / (w0·w1)`, which is compared exactly as a fraction of
/// integers, so ties are real ties.
pub fn otsu(d: &GrayImage) -> u8 {
    let mut hist = [0u128; 256];
    for &v in d.as_raw() {
        hist[usize::from(v)] += 1;
    }
    let total: u128 = hist.iter().sum();
    let total_sum: u128 = hist.iter().enumerate().map(|(t, &c)| t as u128 * c).sum();

    let mut best_t = 0u8;
    // The best value so far as the fraction num / den; 0 / 1 means "nothing positive yet".
    let mut best_num = Big::from_u128(0);
    let mut best_den = Big::from_u128(1);
    let mut w0 = 0u128;
    let mut s0 = 0u128;
    for t in 0..=255u8 {
        w0 += hist[usize::from(t)];
        s0 += u128::from(t) * hist[usize::from(t)];
        let w1 = total - w0;
        if w0 == 0 || w1 == 0 {
            continue; // one class empty: the value is 0, never positive
        }
        let x = (s0 * total).abs_diff(total_sum * w0);
        let num = Big::from_u128(x).mul(&Big::from_u128(x));
        let den = Big::from_u128(w0 * w1);
        // num / den > best_num / best_den  ⇔  num·best_den > best_num·den
        if num.mul(&best_den).compare(&best_num.mul(&den)) == Ordering::Greater {
            best_t = t;
            best_num = num;
            best_den = den;
        }
    }
    best_t
}

/// A small unsigned big integer (little-endian `u64` limbs) for Otsu's exact comparison.
#[derive(Debug, Clone)]
struct Big(Vec<u64>);

impl Big {
    fn from_u128(v: u128) -> Self {
        Big(vec![v as u64, (v >> 64) as u64])
    }

    fn mul(&self, other: &Big) -> Big {
        let mut out = vec![0u64; self.0.len() + other.0.len()];
        for (i, &a) in self.0.iter().enumerate() {
            let mut carry = 0u128;
            for (j, &b) in other.0.iter().enumerate() {
                let cur = u128::from(out[i + j]) + u128::from(a) * u128::from(b) + carry;
                out[i + j] = cur as u64;
                carry = cur >> 64;
            }
            let mut idx = i + other.0.len();
            while carry != 0 && idx < out.len() {
                let cur = u128::from(out[idx]) + carry;
                out[idx] = cur as u64;
                carry = cur >> 64;
                idx += 1;
            }
        }
        Big(out)
    }

    fn compare(&self, other: &Big) -> Ordering {
        let len = self.0.len().max(other.0.len());
        for i in (0..len).rev() {
            let a = self.0.get(i).copied().unwrap_or(0);
            let b = other.0.get(i).copied().unwrap_or(0);
            match a.cmp(&b) {
                Ordering::Equal => continue,
                unequal => return unequal,
            }
        }
        Ordering::Equal
    }
}

/// Foreground mask of §3: `D = |I' − B|` (or one side of it, by `polarity`), foreground (255)
/// where `D > τ`, else 0, with τ fixed or [`otsu`]`(D)`; then, when `cleanup`, a 3×3 opening
/// (erode, dilate) followed by a 3×3 closing (dilate, erode), neighbours outside the image
/// ignored.
///
/// Errors when the two images differ in size.
pub fn foreground_mask(
    enhanced: &GrayImage,
    background: &GrayImage,
    threshold: RefThreshold,
    polarity: RefPolarity,
    cleanup: RefCleanup,
) -> Result<GrayImage, RefError> {
    let mut d = difference(enhanced, background)?;
    if polarity != RefPolarity::Either {
        for ((o, &a), &b) in d.iter_mut().zip(enhanced.as_raw()).zip(background.as_raw()) {
            let signed = i32::from(a) - i32::from(b);
            let keep = if polarity == RefPolarity::Brighter {
                signed > 0
            } else {
                signed < 0
            };
            if !keep {
                *o = 0;
            }
        }
    }
    let tau = match threshold {
        RefThreshold::Fixed(t) => t,
        RefThreshold::Otsu => otsu(&d),
    };
    let (w, h) = d.dimensions();
    let mut fg: Vec<bool> = d.as_raw().iter().map(|&v| v > tau).collect();
    let (wu, hu) = (w as usize, h as usize);
    if cleanup != RefCleanup::Off {
        fg = erode(&fg, wu, hu); // opening
        fg = dilate(&fg, wu, hu);
    }
    if cleanup == RefCleanup::OpenClose {
        fg = dilate(&fg, wu, hu); // closing
        fg = erode(&fg, wu, hu);
    }
    let mut out = GrayImage::new(w, h);
    for (o, &f) in out.iter_mut().zip(&fg) {
        *o = if f { 255 } else { 0 };
    }
    Ok(out)
}

/// The in-image 3×3 neighbourhood of `(x, y)` (itself included).
fn neighbourhood(x: usize, y: usize, w: usize, h: usize) -> impl Iterator<Item = (usize, usize)> {
    let xs = x.saturating_sub(1)..=(x + 1).min(w - 1);
    let ys = y.saturating_sub(1)..=(y + 1).min(h - 1);
    ys.flat_map(move |yy| xs.clone().map(move |xx| (xx, yy)))
}

/// 3×3 erosion: a pixel stays foreground when it and all its in-image 8-neighbours are
/// foreground (§3).
pub(super) fn erode(fg: &[bool], w: usize, h: usize) -> Vec<bool> {
    let mut out = vec![false; fg.len()];
    for y in 0..h {
        for x in 0..w {
            out[y * w + x] = neighbourhood(x, y, w, h).all(|(xx, yy)| fg[yy * w + xx]);
        }
    }
    out
}

/// 3×3 dilation: a pixel becomes foreground when it or any in-image 8-neighbour is
/// foreground (§3).
pub(super) fn dilate(fg: &[bool], w: usize, h: usize) -> Vec<bool> {
    let mut out = vec![false; fg.len()];
    for y in 0..h {
        for x in 0..w {
            out[y * w + x] = neighbourhood(x, y, w, h).any(|(xx, yy)| fg[yy * w + xx]);
        }
    }
    out
}
