//! The partial-volume centroid pixel by pixel, as the module doc defines it: the reference the
//! tests hold the bit rows to, and the path of the boxes they do not measure (wider than 256 px
//! or narrower than 4). The seed's component is marked in bit 7 of the mask plane by a scanline
//! fill ([`mark_component`]); [`moments`] grows and shrinks it by separable 3×3 passes over flag
//! bits 2–6 (band = grown twice minus shrunk twice, ring = shrunk three times minus five times),
//! takes the contrast as the median `D` of the ring, and adds the weights in raster order, the
//! local contrast of each band pixel from its 9×9 window. Time: a few dozen passes over the box's
//! bytes and 81 reads per band pixel; memory: the fill's stack of 256 spans (2 KB) and a
//! histogram of 511 counts. Bits 1–7 of the box are cleared on return.

use super::{Moments, Rect, HOLE_RATIO, LOW};
use crate::pose::refine::Difference;
use core::ops::Range;

/// Bit of the mask plane marking the seed's component (bit 0 is the mask).
pub(super) const COMPONENT: u8 = 1 << 7;

/// Flag bits of the plane while [`moments`] runs: the component grown twice,
const GROWN: u8 = 1 << 2;
/// shrunk twice (the inside),
const SHRUNK: u8 = 1 << 3;
/// a pass's output before it is moved, and the component shrunk three times,
const SCRATCH: u8 = 1 << 4;
/// and shrunk five times.
const RING: u8 = 1 << 5;
/// Horizontal scratch bit of the separable 3×3 passes.
const HORIZONTAL: u8 = 1 << 6;

/// [`super::partial_volume_centroid`] in box `r` of the plane (`w` wide) after
/// [`mark_component`]; clears bits 1–7 in the box.
#[cfg(test)]
pub(super) fn centroid<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    mask: &mut [u8],
    w: usize,
    r: Rect,
) -> Option<[f32; 2]> {
    moments(diff, mask, w, r).map(|m| m.centroid)
}

/// The partial-volume moments ([`Moments`]) in box `r` of the plane (`w` wide) after
/// [`mark_component`]; clears bits 1–7 in the box.
pub(super) fn moments<B: AsRef<[u8]>>(diff: &Difference<'_, B>, mask: &mut [u8], w: usize, r: Rect) -> Option<Moments> {
    // Band = grown by 2 minus shrunk by 2; ring = shrunk by 3 minus shrunk by 5.
    morph_bits(mask, w, r, COMPONENT, GROWN, false);
    morph_bits(mask, w, r, GROWN, SCRATCH, false);
    move_bit(mask, w, r, SCRATCH, GROWN);
    morph_bits(mask, w, r, COMPONENT, SHRUNK, true);
    morph_bits(mask, w, r, SHRUNK, SCRATCH, true);
    move_bit(mask, w, r, SCRATCH, SHRUNK);
    morph_bits(mask, w, r, SHRUNK, RING, true);
    morph_bits(mask, w, r, RING, SCRATCH, true);
    morph_bits(mask, w, r, SCRATCH, RING, true);
    // RING now = shrunk by 5; ring = shrunk by 3 (SCRATCH after one more) minus shrunk by 5.
    morph_bits(mask, w, r, SHRUNK, SCRATCH, true);
    // Contrast: median of D over the ring (signed, from a histogram).
    let mut hist = [0u16; 511];
    let mut ring_count = 0usize;
    let mut level = 0u64;
    for y in r.y0..r.y1 {
        for x in r.x0..r.x1 {
            let v = mask.get(y * w + x).copied().unwrap_or(0);
            if v & SCRATCH != 0 && v & RING == 0 {
                level += u64::from(diff.background_at(x as isize, y as isize));
                let d = diff.at(x as isize, y as isize);
                let bin = (d as i32 + 255).clamp(0, 510) as usize;
                if let Some(hb) = hist.get_mut(bin) {
                    *hb = hb.saturating_add(1);
                }
                ring_count += 1;
            }
        }
    }
    let contrast = if ring_count > 0 {
        let mut acc = 0usize;
        let mut med = 0.0f32;
        for (bin, &c) in hist.iter().enumerate() {
            acc += c as usize;
            if 2 * acc >= ring_count {
                med = bin as f32 - 255.0;
                break;
            }
        }
        med
    } else {
        0.0
    };
    let (mut sw, mut sx, mut sy) = (0.0f32, 0.0f32, 0.0f32);
    let weights = Weights::new(contrast, level as f32 / ring_count.max(1) as f32);
    if contrast.abs() >= 1.0 {
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let v = mask.get(y * w + x).copied().unwrap_or(0);
                let weight = if v & SHRUNK != 0 {
                    let ratio = diff.at(x as isize, y as isize) / contrast;
                    if ratio >= HOLE_RATIO {
                        1.0
                    } else {
                        ratio.clamp(0.0, 1.0)
                    }
                } else if v & GROWN != 0 {
                    let local = local_ring_mean(diff, mask, w, r, x, y)
                        .filter(|c| c.abs() >= 1.0 && c.signum() == contrast.signum());
                    let fallback = || weights.fallback(f32::from(diff.background_at(x as isize, y as isize)));
                    (diff.at(x as isize, y as isize) / local.unwrap_or_else(fallback)).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                if weight > 0.0 {
                    sw += weight;
                    sx += weight * (x - r.x0) as f32;
                    sy += weight * (y - r.y0) as f32;
                }
            }
        }
    }
    for y in r.y0..r.y1 {
        if let Some(row) = mask.get_mut(y * w + r.x0..y * w + r.x1) {
            keep_mask_bit(row);
        }
    }
    Moments::of(r, [sw, sx, sy], contrast)
}

/// Mean `D` of the ring pixels (bit `SCRATCH` set, `RING` clear) within 4 px of `(x, y)`.
fn local_ring_mean<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    mask: &[u8],
    w: usize,
    r: Rect,
    x: usize,
    y: usize,
) -> Option<f32> {
    const RADIUS: usize = 4;
    let (mut sum, mut count) = (0.0f32, 0usize);
    for yy in y.saturating_sub(RADIUS).max(r.y0)..(y + RADIUS + 1).min(r.y1) {
        for xx in x.saturating_sub(RADIUS).max(r.x0)..(x + RADIUS + 1).min(r.x1) {
            let v = mask.get(yy * w + xx).copied().unwrap_or(0);
            if v & SCRATCH != 0 && v & RING == 0 {
                sum += diff.at(xx as isize, yy as isize);
                count += 1;
            }
        }
    }
    (count > 0).then(|| sum / count as f32)
}

/// `dst` bit = 3×3 erosion (or dilation) of the `src` bit inside `r` (outside `r` counts as
/// 0), as a horizontal then a vertical 3-tap pass.
fn morph_bits(mask: &mut [u8], w: usize, r: Rect, src: u8, dst: u8, erode: bool) {
    let width = r.x1.saturating_sub(r.x0);
    if width == 0 {
        return;
    }
    for y in r.y0..r.y1 {
        let Some(row) = mask.get_mut(y * w + r.x0..y * w + r.x1) else {
            continue;
        };
        let mut prev = false; // outside r
        for x in 0..width {
            let cur = row.get(x).is_some_and(|v| v & src != 0);
            let next = x + 1 < width && row.get(x + 1).is_some_and(|v| v & src != 0);
            let on = if erode {
                prev && cur && next
            } else {
                prev || cur || next
            };
            if let Some(v) = row.get_mut(x) {
                *v = if on { *v | HORIZONTAL } else { *v & !HORIZONTAL };
            }
            prev = cur;
        }
    }
    for y in r.y0..r.y1 {
        for x in r.x0..r.x1 {
            let at = |yy: usize| mask.get(yy * w + x).is_some_and(|v| v & HORIZONTAL != 0);
            let up = y > r.y0 && at(y - 1);
            let cur = at(y);
            let down = y + 1 < r.y1 && at(y + 1);
            let on = if erode { up && cur && down } else { up || cur || down };
            if let Some(v) = mask.get_mut(y * w + x) {
                *v = if on { *v | dst } else { *v & !dst };
            }
        }
    }
    // HORIZONTAL is left set on some pixels; the caller clears bits 1.. at the end.
}

fn move_bit(mask: &mut [u8], w: usize, r: Rect, from: u8, to: u8) {
    for y in r.y0..r.y1 {
        for x in r.x0..r.x1 {
            if let Some(v) = mask.get_mut(y * w + x) {
                *v = if *v & from != 0 {
                    (*v | to) & !from
                } else {
                    *v & !(to | from)
                };
            }
        }
    }
}

/// What the weights depend on besides `D` and the ring's column sums.
#[derive(Clone, Copy)]
pub(super) struct Weights {
    pub(super) contrast: f32,
    /// The contrast's sign, ±1.
    pub(super) sign: f32,
    /// One over the ring's mean background level, by which [`Self::fallback`] scales the
    /// contrast; 0: no scaling.
    pub(super) per_level: f32,
}

impl Weights {
    /// The weights of a part whose ring has the median `D` `contrast` and the mean background
    /// level `level`. The level scales the fallback contrast only where it is at least half the
    /// contrast's size (always so for a part darker than its platform): on a dark platform the
    /// sensor's offset, not the light, sets the level.
    pub(super) fn new(contrast: f32, level: f32) -> Self {
        Weights {
            contrast,
            sign: contrast.signum(),
            per_level: if level >= 0.5 * contrast.abs() && level >= 1.0 {
                1.0 / level
            } else {
                0.0
            },
        }
    }

    /// The contrast of a band pixel with no ring pixel within 4 px, whose background level is
    /// `b`: the ring's median scaled by `b` over the ring's level (the light that falls on the
    /// platform falls on the part too, so a vignetted or unevenly lit platform changes the
    /// contrast in proportion; the ratio kept within `[1/2, 2]`), or the median itself without
    /// a level.
    #[inline(always)]
    pub(super) fn fallback(&self, b: f32) -> f32 {
        if self.per_level > 0.0 {
            self.contrast * (b * self.per_level).clamp(0.5, 2.0)
        } else {
            self.contrast
        }
    }
}

/// Clears bits 1–7 of every byte of `row`.
fn keep_mask_bit(row: &mut [u8]) {
    let mut chunks = row.chunks_exact_mut(8);
    for chunk in &mut chunks {
        if let Ok(bytes) = <&mut [u8; 8]>::try_from(chunk) {
            *bytes = (u64::from_le_bytes(*bytes) & LOW).to_le_bytes();
        }
    }
    for v in chunks.into_remainder() {
        *v &= 1;
    }
}

/// Marks the 8-connected foreground component of `seed` (inside `r`) with [`COMPONENT`]: a
/// scanline fill with a fixed stack; when the stack overflows, repeated raster passes finish the
/// job (bounded by the box's size). Returns the box's rows that hold the component (all of them
/// after an overflow).
pub(super) fn mark_component(mask: &mut [u8], w: usize, r: Rect, seed: (usize, usize)) -> Range<usize> {
    mark_component_with::<256>(mask, w, r, seed)
}

/// [`mark_component`] with a stack of `STACK` spans. Not inlined: its stack need not stay
/// allocated while the centroid is measured.
#[inline(never)]
fn mark_component_with<const STACK: usize>(mask: &mut [u8], w: usize, r: Rect, seed: (usize, usize)) -> Range<usize> {
    let width = r.x1 - r.x0;
    // (column, row) in the box.
    let mut stack = [(0u32, 0u32); STACK];
    let mut top = 0usize;
    let mut overflow = false;
    // The rows marked (the seed's row at least).
    let (mut top_row, mut bottom_row) = (seed.1, seed.1);
    match (
        stack.get_mut(0),
        u32::try_from(seed.0 - r.x0),
        u32::try_from(seed.1 - r.y0),
    ) {
        (Some(slot), Ok(x), Ok(y)) => {
            *slot = (x, y);
            top = 1;
        }
        _ => overflow = true,
    }
    while top > 0 {
        top -= 1;
        let Some(&(x, y)) = stack.get(top) else { break };
        let (x, y) = (x as usize, r.y0 + y as usize);
        let Some(row) = mask.get_mut(y * w + r.x0..y * w + r.x1) else {
            continue;
        };
        if !row.get(x).is_some_and(|&v| is_free(v)) {
            continue;
        }
        let xl = x - row.get(..x).map_or(0, free_suffix);
        let xr = x + row.get(x + 1..).map_or(0, free_prefix);
        set_flag(row.get_mut(xl..=xr).unwrap_or(&mut []), COMPONENT);
        (top_row, bottom_row) = (top_row.min(y), bottom_row.max(y));
        for ny in [y.wrapping_sub(1), y + 1] {
            if ny < r.y0 || ny >= r.y1 {
                continue;
            }
            let lo = xl.saturating_sub(1);
            let hi = (xr + 1).min(width - 1);
            let Some(next) = mask.get(ny * w + r.x0 + lo..=ny * w + r.x0 + hi) else {
                continue;
            };
            let by = (ny - r.y0) as u32;
            for_each_run_start(next, |k| match stack.get_mut(top) {
                // The box's width fits a u32 here: the seed's column did.
                Some(slot) => {
                    *slot = ((lo + k) as u32, by);
                    top += 1;
                }
                None => overflow = true,
            });
        }
    }
    if !overflow {
        return top_row - r.y0..bottom_row + 1 - r.y0;
    }
    let free_at = |mask: &[u8], x: usize, y: usize| mask.get(y * w + x).is_some_and(|&v| is_free(v));
    let mut changed = true;
    let mut passes = 0usize;
    while changed && passes < (r.x1 - r.x0) + (r.y1 - r.y0) + 2 {
        changed = false;
        for forward in [true, false] {
            for yi in 0..(r.y1 - r.y0) {
                let y = if forward { r.y0 + yi } else { r.y1 - 1 - yi };
                for xi in 0..(r.x1 - r.x0) {
                    let x = if forward { r.x0 + xi } else { r.x1 - 1 - xi };
                    if free_at(mask, x, y) && any_neighbour(mask, w, r, x, y, COMPONENT) {
                        if let Some(p) = mask.get_mut(y * w + x) {
                            *p |= COMPONENT;
                        }
                        changed = true;
                    }
                }
            }
        }
        passes += 1;
    }
    0..r.y1 - r.y0
}

/// Sets `flag` in every byte of `span`, 8 a step.
fn set_flag(span: &mut [u8], flag: u8) {
    let mut chunks = span.chunks_exact_mut(8);
    for chunk in &mut chunks {
        if let Ok(bytes) = <&mut [u8; 8]>::try_from(chunk) {
            *bytes = (u64::from_le_bytes(*bytes) | (LOW * flag as u64)).to_le_bytes();
        }
    }
    for v in chunks.into_remainder() {
        *v |= flag;
    }
}

/// A pixel of the mask not yet marked as the component's.
#[inline]
fn is_free(v: u8) -> bool {
    v & 1 != 0 && v & COMPONENT == 0
}

/// Byte `i` is 1 when pixel `i` of the 8 is free.
#[inline]
fn free_bytes(chunk: &[u8]) -> u64 {
    let v = u64::from_le_bytes(<[u8; 8]>::try_from(chunk).unwrap_or([0; 8]));
    v & !(v >> 7) & LOW
}

/// The number of free pixels at the start of `row`.
fn free_prefix(row: &[u8]) -> usize {
    let mut n = 0;
    let mut chunks = row.chunks_exact(8);
    for chunk in &mut chunks {
        let free = free_bytes(chunk);
        if free != LOW {
            return n + ((!free & LOW).trailing_zeros() / 8) as usize;
        }
        n += 8;
    }
    n + chunks.remainder().iter().take_while(|&&v| is_free(v)).count()
}

/// The number of free pixels at the end of `row`.
fn free_suffix(row: &[u8]) -> usize {
    let mut n = 0;
    let mut chunks = row.rchunks_exact(8);
    for chunk in &mut chunks {
        let free = free_bytes(chunk);
        if free != LOW {
            return n + ((!free & LOW).leading_zeros() / 8) as usize;
        }
        n += 8;
    }
    n + chunks.remainder().iter().rev().take_while(|&&v| is_free(v)).count()
}

/// Calls `f` with the index of the first pixel of every run of free pixels (mask bit set,
/// [`COMPONENT`] clear) in `row`, in increasing order; 8 pixels a step.
fn for_each_run_start(row: &[u8], mut f: impl FnMut(usize)) {
    // 1 when the pixel before the current one is free.
    let mut prev = 0u32;
    let mut chunks = row.chunks_exact(8);
    let mut k = 0usize;
    for chunk in &mut chunks {
        let free = free_bytes(chunk);
        if free == 0 {
            prev = 0;
        } else if free != LOW || prev == 0 {
            // Byte i's flag to bit i.
            let bits = (free.wrapping_mul(0x0102_0408_1020_4080) >> 56) as u32;
            let mut starts = bits & !((bits << 1) | prev);
            while starts != 0 {
                f(k + starts.trailing_zeros() as usize);
                starts &= starts - 1;
            }
            prev = bits >> 7;
        }
        k += 8;
    }
    for &v in chunks.remainder() {
        let free = is_free(v) as u32;
        if free > prev {
            f(k);
        }
        prev = free;
        k += 1;
    }
}

pub(super) fn any_neighbour(mask: &[u8], w: usize, r: Rect, x: usize, y: usize, bit: u8) -> bool {
    for dy in -1isize..=1 {
        for dx in -1isize..=1 {
            let (nx, ny) = (x as isize + dx, y as isize + dy);
            if nx < r.x0 as isize || ny < r.y0 as isize || nx >= r.x1 as isize || ny >= r.y1 as isize {
                continue;
            }
            if mask.get(ny as usize * w + nx as usize).is_some_and(|v| v & bit != 0) {
                return true;
            }
        }
    }
    false
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::pose::partial_volume::tests::components;
    use std::vec::Vec;

    use crate::test_rng::XorShift as Rng;

    #[test]
    fn component_fill_finishes_after_its_stack_overflows() {
        // A 2-span stack on ragged random masks: the raster passes must still find the whole
        // 8-connected component, inside the box only.
        let mut rng = Rng(12345);
        for _ in 0..40 {
            let (w, h) = (5 + rng.below(60), 5 + rng.below(60));
            let density = rng.range(0.4, 0.8);
            let mask: Vec<u8> = (0..w * h).map(|_| rng.chance(density) as u8).collect();
            let r = Rect {
                x0: rng.below(w / 3),
                y0: rng.below(h / 3),
                x1: w - rng.below(w / 3),
                y1: h - rng.below(h / 3),
            };
            let seed = (r.x0 + rng.below(r.x1 - r.x0), r.y0 + rng.below(r.y1 - r.y0));
            if mask[seed.1 * w + seed.0] == 0 {
                continue;
            }
            // The component within the box.
            let (bw, bh) = (r.x1 - r.x0, r.y1 - r.y0);
            let boxed: Vec<u8> = (0..bw * bh)
                .map(|i| mask[(r.y0 + i / bw) * w + r.x0 + i % bw])
                .collect();
            let comps = components(&boxed, bw, bh);
            let want = comps
                .iter()
                .find(|c| c.contains(&(seed.0 - r.x0, seed.1 - r.y0)))
                .unwrap();
            let top = want.iter().map(|p| p.1).min().unwrap();
            let bottom = want.iter().map(|p| p.1).max().unwrap() + 1;
            for small in [false, true] {
                let mut plane = mask.clone();
                let rows = if small {
                    mark_component_with::<2>(&mut plane, w, r, seed)
                } else {
                    mark_component(&mut plane, w, r, seed)
                };
                // The rows it reports hold the whole component.
                assert!(rows.start <= top && bottom <= rows.end && rows.end <= bh, "{rows:?}");
                if !small {
                    assert_eq!(rows, top..bottom);
                }
                let marked = plane.iter().filter(|&&v| v & COMPONENT != 0).count();
                assert_eq!(marked, want.len());
                for &(x, y) in want {
                    assert!(plane[(r.y0 + y) * w + r.x0 + x] & COMPONENT != 0);
                }
            }
        }
    }
}
