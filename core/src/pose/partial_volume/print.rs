//! What print and texture on a part's face take from its partial-volume weights
//! ([`print_deficit`]), so that the recognizer can give it back: pixel by pixel over each print
//! border's window (at most [`MAX_PRINT_WINDOW`] px a side, three bitmaps of 512 bytes on the
//! stack), the pixel's weight as the centroid gives it against the part's contrast.

use super::HOLE_RATIO;
use crate::pose::refine::Difference;

/// How far (px, in rows and columns) around a print border the partial-volume weights lose
/// to the print: the band's 2 px.
pub const PRINT_BAND: usize = 2;

/// How near (px, in rows and columns) to the outer border or a template hole a pixel may lie
/// and still not count as print's: those pixels' weights are the edge's coverage.
pub const PRINT_KEEP_OFF: usize = 2;

/// The widest print window (px a side, its border's box plus the band) that [`print_deficit`]
/// weighs pixel by pixel: the window's three bitmaps are 512 bytes each.
pub const MAX_PRINT_WINDOW: usize = 64;

/// What print and texture take from a part's partial-volume weights: `[Σ(1 − w), Σ(1 − w)·x,
/// Σ(1 − w)·y]` over the pixels inside a `print` hole border (a hole of the part's mask that its
/// template does not have) or within [`PRINT_BAND`] px of one, farther than [`PRINT_KEEP_OFF`]
/// px from every `keep_off` border (the part's outer border and its template's holes, whose
/// edges' weights are coverage). `w` is the weight [`partial_volume_centroid`](super::partial_volume_centroid) gives the pixel,
/// against the part's `contrast` (not the local one): 0 deep in a hole of the `mask` (0/1), `D/C`
/// clipped to `[0, 1]` in the band, and in the inside 1 unless `D/C` is below the hole test's
/// ratio. Added to the part's moments they make the print material: dark letters on a bright
/// wrench moved its centroid by 3.2 px, most of the print still in the mask but weighed down.
///
/// A pixel counts once (for the first print border that takes it). A print border whose
/// window (its box plus the band) is wider than [`MAX_PRINT_WINDOW`] adds its hole's pixels at
/// its centre instead; borders beyond the image are skipped. Time: per window, each keep-off
/// and print border point once and each pixel of the window once (three bitmaps of 512 bytes),
/// plus an inside test against the border (and the earlier ones) for a pixel outside its band.
///
/// ```
/// use vorl_core::borders::contour::Point;
/// use vorl_core::pose::partial_volume::print_deficit;
/// use vorl_core::pose::refine::Difference;
/// use vorl_core::{pixels::enhance::Alpha, Frame};
/// // A bright 20×20 part (level 200 on a platform of 100) with a 2×2 patch of platform in it.
/// let (w, h) = (40, 40);
/// let mut img = vec![100u8; w * h];
/// let mut mask = vec![0u8; w * h];
/// for y in 10..30 {
///     for x in 10..30 {
///         let print = (19..21).contains(&x) && (19..21).contains(&y);
///         img[y * w + x] = if print { 100 } else { 200 };
///         mask[y * w + x] = u8::from(!print);
///     }
/// }
/// let frame = Frame::new_checked(&img[..], w, h).unwrap();
/// let bg = vec![100u8; w * h];
/// let diff = Difference::new(&frame, &bg, Alpha::ONE);
/// let p = |x, y| Point { x, y };
/// // The hole border: the part's pixels around the patch.
/// let hole = [p(19, 18), p(18, 19), p(18, 20), p(19, 21), p(20, 21), p(21, 20), p(21, 19), p(20, 18)];
/// let outer = [p(10, 10), p(10, 29), p(29, 29), p(29, 10)];
/// let [m, mx, my] = print_deficit(&diff, &mask, 100.0, [&hole[..]].into_iter(), [&outer[..]].into_iter());
/// assert_eq!(m, 4.0); // the four pixels of the patch
/// assert_eq!([mx / m, my / m], [19.5, 19.5]);
/// ```
pub fn print_deficit<'p, B, P, K>(
    diff: &Difference<'_, B>,
    mask: &[u8],
    contrast: f32,
    print: P,
    keep_off: K,
) -> [f32; 3]
where
    B: AsRef<[u8]>,
    P: Iterator<Item = &'p [crate::borders::contour::Point]> + Clone,
    K: Iterator<Item = &'p [crate::borders::contour::Point]> + Clone,
{
    const WORDS: usize = MAX_PRINT_WINDOW * MAX_PRINT_WINDOW / 64;
    let (w, h) = (diff.width(), diff.height());
    let mut sums = [0.0f32; 3];
    if !(contrast.abs() >= 1.0) || mask.len() < w.saturating_mul(h) {
        return sums;
    }
    let at_mask = |x: usize, y: usize| mask.get(y * w + x).is_some_and(|&v| v & 1 != 0);
    for (k, border) in print.clone().enumerate() {
        let Some((x0, y0, x1, y1)) = border_box(border) else {
            continue;
        };
        // The window: the border's box plus the band, within the image.
        let (wx0, wy0) = (x0.saturating_sub(PRINT_BAND), y0.saturating_sub(PRINT_BAND));
        let (wx1, wy1) = (
            (x1 + PRINT_BAND).min(w.saturating_sub(1)),
            (y1 + PRINT_BAND).min(h.saturating_sub(1)),
        );
        if x1 >= w || y1 >= h {
            continue;
        }
        if wx1 + 1 - wx0 > MAX_PRINT_WINDOW || wy1 + 1 - wy0 > MAX_PRINT_WINDOW {
            // Too large to weigh pixel by pixel: its hole's pixels at its centre.
            if let Some(hole) = crate::pose::holes::Hole::from_border(border) {
                let a = hole.area;
                sums = [sums[0] + a, sums[1] + a * hole.centre[0], sums[2] + a * hole.centre[1]];
            }
            continue;
        }
        let ww = wx1 + 1 - wx0;
        // Pixels of the window near a keep-off border, in this border's band, and taken by an
        // earlier print border.
        let mut off = [0u64; WORDS];
        let mut band = [0u64; WORDS];
        let mut taken = [0u64; WORDS];
        let mark = |bits: &mut [u64; WORDS], p: &crate::borders::contour::Point, reach: usize| {
            let (px, py) = (p.x as usize, p.y as usize);
            if px + reach < wx0 || py + reach < wy0 || px > wx1 + reach || py > wy1 + reach {
                return;
            }
            for y in py.saturating_sub(reach).max(wy0)..=(py + reach).min(wy1) {
                for x in px.saturating_sub(reach).max(wx0)..=(px + reach).min(wx1) {
                    let i = (y - wy0) * ww + (x - wx0);
                    if let Some(word) = bits.get_mut(i / 64) {
                        *word |= 1 << (i % 64);
                    }
                }
            }
        };
        for b in keep_off.clone() {
            for p in b {
                mark(&mut off, p, PRINT_KEEP_OFF);
            }
        }
        for p in border {
            mark(&mut band, p, PRINT_BAND);
        }
        for b in print.clone().take(k) {
            for p in b {
                mark(&mut taken, p, PRINT_BAND);
            }
        }
        let earlier = print.clone().take(k);
        for y in wy0..=wy1 {
            for x in wx0..=wx1 {
                let i = (y - wy0) * ww + (x - wx0);
                let bit = |bits: &[u64; WORDS]| bits.get(i / 64).is_some_and(|&v| v >> (i % 64) & 1 != 0);
                if bit(&off) || bit(&taken) {
                    continue;
                }
                if !(bit(&band) || inside(border, x, y)) {
                    continue;
                }
                // Inside an earlier print border (its band was marked above).
                if earlier.clone().any(|b| inside(b, x, y)) {
                    continue;
                }
                // The pixel's weight as the partial-volume centroid gives it (5×5: the band).
                let (mut any_in, mut any_out) = (false, false);
                for v in y.saturating_sub(2)..=(y + 2).min(h - 1) {
                    for u in x.saturating_sub(2)..=(x + 2).min(w - 1) {
                        if at_mask(u, v) {
                            any_in = true;
                        } else {
                            any_out = true;
                        }
                    }
                }
                let ratio = diff.at(x as isize, y as isize) / contrast;
                let weight = if !any_in {
                    0.0
                } else if !any_out && ratio >= HOLE_RATIO {
                    1.0
                } else {
                    ratio.clamp(0.0, 1.0)
                };
                let d = 1.0 - weight;
                sums = [sums[0] + d, sums[1] + d * x as f32, sums[2] + d * y as f32];
            }
        }
    }
    sums
}

/// The box `(x0, y0, x1, y1)` (inclusive) of a border's points; `None` for no point.
fn border_box(border: &[crate::borders::contour::Point]) -> Option<(usize, usize, usize, usize)> {
    let first = border.first()?;
    let (mut x0, mut y0, mut x1, mut y1) = (first.x, first.y, first.x, first.y);
    for p in border {
        (x0, y0, x1, y1) = (x0.min(p.x), y0.min(p.y), x1.max(p.x), y1.max(p.y));
    }
    Some((x0 as usize, y0 as usize, x1 as usize, y1 as usize))
}

/// Whether `(x, y)` lies inside the closed polygon through a border's points (even-odd, a ray
/// from `(x + ¼, y + ¼)` along +x, which passes through no point of the integer grid).
fn inside(border: &[crate::borders::contour::Point], x: usize, y: usize) -> bool {
    let (tx, ty) = (x as f32 + 0.25, y as f32 + 0.25);
    let mut crossings = false;
    let mut prev = match border.last() {
        Some(p) => *p,
        None => return false,
    };
    for &p in border {
        let (ax, ay, bx, by) = (f32::from(prev.x), f32::from(prev.y), f32::from(p.x), f32::from(p.y));
        if (ay > ty) != (by > ty) {
            let cx = ax + (ty - ay) * (bx - ax) / (by - ay);
            if cx > tx {
                crossings = !crossings;
            }
        }
        prev = p;
    }
    crossings
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::pixels::enhance::Alpha;
    use crate::pixels::frame::Frame;
    use crate::pose::partial_volume::tests::coverage_centroid;
    use crate::pose::partial_volume::{partial_volume_moments, Rect};
    use std::vec;
    use std::vec::Vec;

    /// A bright disc with a blurred dark patch of print on its face (the patch at the
    /// platform's level, so the mask has a hole there that the template does not): the
    /// partial-volume moments plus [`print_deficit`] over the hole's border are the whole
    /// disc's, patch included, within 0.03 px (0.001 px here); the hole's pixel count at its
    /// centre instead (what the recognizer added before) leaves the blur's toll on the patch's
    /// rim and is off by more than three times that (0.08 px; the moments alone 0.34 px). A
    /// template hole passed as keep-off is left alone.
    #[test]
    fn print_deficit_gives_the_print_back_to_the_part() {
        use crate::borders::contour::{trace_borders, BorderFilter, BorderKind, ContourStore};
        let (w, h) = (80usize, 80usize);
        let (cx, cy, r) = (40.3f32, 39.6f32, 30.0f32);
        let (px, py, pr) = (52.0f32, 40.0f32, 5.0f32);
        let blur = 1.6;
        let mut frame = vec![0u8; w * h];
        let mut disc_cover = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let (xf, yf) = (x as f32, y as f32);
                let disc = (0.5 - (((xf - cx).powi(2) + (yf - cy).powi(2)).sqrt() - r) / blur).clamp(0.0, 1.0);
                let patch = (0.5 - (((xf - px).powi(2) + (yf - py).powi(2)).sqrt() - pr) / blur).clamp(0.0, 1.0);
                disc_cover[y * w + x] = disc;
                // Platform 60, the part 180, the print back at 60.
                frame[y * w + x] = (60.0 + 120.0 * disc * (1.0 - patch)).round() as u8;
            }
        }
        let background = vec![60u8; w * h];
        let f = Frame::new_checked(&frame[..], w, h).unwrap();
        let diff = Difference::new(&f, &background, Alpha::ONE);
        let mut mask: Vec<u8> = frame.iter().map(|&v| u8::from(v > 75)).collect();
        let want = coverage_centroid(&disc_cover, w);
        // The borders: the disc's outer one and the patch's hole.
        let mut labels = mask.clone();
        let mut store = ContourStore::<4096, 16>::new();
        trace_borders(
            &mut labels,
            w,
            h,
            BorderFilter {
                min_points: 1,
                min_area: 0.0,
            },
            &mut store,
        )
        .unwrap();
        let outer = (0..store.contours().len())
            .find(|&i| store.contours()[i].kind == BorderKind::Outer)
            .unwrap();
        let hole = store.holes_of(outer).next().unwrap();
        let seed = store.points(outer)[0];
        let bbox = Rect {
            x0: 5,
            y0: 5,
            x1: 76,
            y1: 75,
        };
        let m = partial_volume_moments(&diff, &mut mask, (seed.x as usize, seed.y as usize), bbox).unwrap();
        let combine = |[dm, dx, dy]: [f32; 3]| {
            let mass = m.mass + dm;
            [
                (m.mass * m.centroid[0] + dx) / mass,
                (m.mass * m.centroid[1] + dy) / mass,
            ]
        };
        let err = |c: [f32; 2]| (c[0] - want[0]).hypot(c[1] - want[1]);
        let print = core::iter::once(store.points(hole));
        let got = combine(print_deficit(
            &diff,
            &mask,
            m.contrast,
            print,
            core::iter::once(store.points(outer)),
        ));
        let area = crate::pose::holes::Hole::from_border(store.points(hole)).unwrap();
        let counted = combine([area.area, area.area * area.centre[0], area.area * area.centre[1]]);
        assert!(err(got) < 0.03, "{got:?} against {want:?}: {}", err(got));
        assert!(
            err(counted) > 3.0 * err(got).max(0.01),
            "pixel count {counted:?}: {}",
            err(counted)
        );
        // The same hole as a template's (keep-off): nothing of it counts.
        let kept = print_deficit(
            &diff,
            &mask,
            m.contrast,
            core::iter::empty(),
            [store.points(outer), store.points(hole)].into_iter(),
        );
        assert_eq!(kept, [0.0; 3]);
    }
}
