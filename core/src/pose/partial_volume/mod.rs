//! Partial-volume centroid: a part's area centroid with its edge pixels counted by coverage, so
//! that the position does not move with where the mask's threshold cuts the blurred edge.
//! [`partial_volume_centroid`]: in the box (the border's bounding box plus 6 px; outside it
//! counts as background) `P` is the seed's 8-connected component of the mask; the inside (`P`
//! eroded twice by 3×3) counts 1, the band (`P` dilated twice minus the inside: the 2 px around
//! the mask's edge) counts `D / C` clipped to `[0, 1]`, where `D = I' − B` is the difference
//! image and `C` the local contrast: the mean `D` of the ring pixels (`P` eroded three times
//! minus eroded five times, 3–4 px inside the edge) within 4 px of the band pixel, or where none
//! is near, the ring's median scaled by the background's level at the pixel over the ring's mean
//! level (within `[1/2, 2]`). An inside pixel whose `D / C` is below 1/5 (a hole the mask's
//! closing filled) counts `D / C` clipped too. Time: `O(box area / word)` word operations plus a
//! few dozen instructions per band and ring pixel (boxes of 4 to 256 px; the others pixel by
//! pixel, a 9×9 window per band pixel). Memory: stack only, at most about 4.4 KB on the
//! Cortex-M4; the mask plane's box rows are scratch during the call and hold their 0/1 values
//! again afterwards. Guards: `None` for a seed outside the image, the box or the mask, a plane
//! shorter than the image (left untouched), or a part without ring pixels (no contrast to weigh
//! by: the caller keeps the polygon centroid); no input panics.
//!
//! Why coverage: the mask's edge lies where `D` crosses the threshold, which moves with the
//! part's contrast and the edge's blur; the band's weights are the fraction of each pixel the
//! part covers, so with blur symmetric about the edge the centroid is the true silhouette's to a
//! few hundredths of a pixel. The contrast is local so that shading across the part does not
//! tilt the weights; where no ring pixel is near (a thin rim, a rod's eye) the median is scaled
//! by the platform's level because the light that falls on the platform falls on the part too,
//! so a vignetted backlight or an unevenly lit belt changes the contrast in proportion (unscaled
//! on a platform darker than half the contrast, where the sensor's offset sets the level).
//!
//! The files: `definition.rs` is the definition pixel by pixel (flag bits of the plane, a 9×9
//! window per band pixel): it measures the boxes the bit rows do not, and the tests hold the fast
//! path to it. `bit_rows/` measures the others with rows of bits and the same result: the same
//! bits where `D` is an integer (`α = 1`), within 1e-4 px otherwise (its local sums are added in
//! another order). `print.rs` weighs what print on a part's face takes from it
//! ([`print_deficit`]). Measured costs: `docs/performance.md`.

use crate::pose::refine::Difference;

mod definition;

mod bit_rows;
mod print;

pub use print::{print_deficit, MAX_PRINT_WINDOW, PRINT_BAND, PRINT_KEEP_OFF};

/// Below this fraction of the part's contrast an interior pixel is taken for platform (a filled
/// hole).
const HOLE_RATIO: f32 = 0.2;

/// The margin added around the border's bounding box, px.
const MARGIN: usize = 6;

/// The low bit of each of 8 bytes.
const LOW: u64 = 0x0101_0101_0101_0101;

/// A rectangle of pixels `[x0, x1) × [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rect {
    /// Left.
    pub x0: usize,
    /// Top.
    pub y0: usize,
    /// Right (exclusive).
    pub x1: usize,
    /// Bottom (exclusive).
    pub y1: usize,
}

/// The partial-volume area centroid of the part whose border passes through `seed` (a foreground
/// pixel), within `bbox` (the border's bounding box; a 6 px margin is added, clipped to the
/// image). `mask` is the 0/1 plane: inside the box it is scratch while the call runs (bits 1–7
/// must be 0 on entry), and it holds its 0/1 values again on return. `None` when the part has no
/// weight, or when `seed` is outside the image, the box or the mask, or `mask` is shorter than the
/// image (then `mask` is not touched).
pub fn partial_volume_centroid<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    mask: &mut [u8],
    seed: (usize, usize),
    bbox: Rect,
) -> Option<[f32; 2]> {
    partial_volume_moments(diff, mask, seed, bbox).map(|m| m.centroid)
}

/// The partial-volume centroid and the weight it is the centroid of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moments {
    /// The sum of the pixels' weights: the part's area in px², by coverage.
    pub mass: f32,
    /// The weighted centroid, px.
    pub centroid: [f32; 2],
    /// The part's contrast `C`: the median `D` of its ring.
    pub contrast: f32,
}

impl Moments {
    fn of(r: Rect, [sw, sx, sy]: [f32; 3], contrast: f32) -> Option<Moments> {
        (sw > 0.0).then(|| Moments {
            mass: sw,
            centroid: [r.x0 as f32 + sx / sw, r.y0 as f32 + sy / sw],
            contrast,
        })
    }
}

/// [`partial_volume_centroid`] with its mass ([`Moments`]), for a caller that adds to the
/// part what the mask left out (the recognizer fills the holes its template does not have).
pub fn partial_volume_moments<B: AsRef<[u8]>>(
    diff: &Difference<'_, B>,
    mask: &mut [u8],
    seed: (usize, usize),
    bbox: Rect,
) -> Option<Moments> {
    let (w, h) = (diff.width(), diff.height());
    if mask.len() < w * h || seed.0 >= w || seed.1 >= h {
        return None;
    }
    let r = Rect {
        x0: bbox.x0.saturating_sub(MARGIN),
        y0: bbox.y0.saturating_sub(MARGIN),
        x1: bbox.x1.saturating_add(MARGIN).min(w),
        y1: bbox.y1.saturating_add(MARGIN).min(h),
    };
    if !(r.x0..r.x1).contains(&seed.0) || !(r.y0..r.y1).contains(&seed.1) {
        return None;
    }
    if mask.get(seed.1 * w + seed.0).is_none_or(|v| v & 1 == 0) {
        return None;
    }
    if !bit_rows::measures(r.x1 - r.x0) {
        definition::mark_component(mask, w, r, seed);
        return definition::moments(diff, mask, w, r);
    }
    bit_rows::moments(diff, mask, w, r, (seed.0 - r.x0, seed.1 - r.y0))
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::pixels::enhance::Alpha;
    use crate::pixels::frame::Frame;
    use std::boxed::Box;
    use std::vec;
    use std::vec::Vec;

    use crate::test_rng::XorShift as Rng;

    /// Signed distance to a shape (negative inside), px.
    type Shape = Box<dyn Fn(f32, f32) -> f32>;

    fn disc(cx: f32, cy: f32, radius: f32) -> Shape {
        Box::new(move |x, y| ((x - cx).powi(2) + (y - cy).powi(2)).sqrt() - radius)
    }

    /// A random shape: discs, turned rectangles, discs with holes, 1-px rings, tiny specks,
    /// anywhere including across the image's border.
    fn random_shape(rng: &mut Rng, w: usize, h: usize) -> Shape {
        let (wf, hf) = (w as f32, h as f32);
        let cx = rng.range(-0.15 * wf, 1.15 * wf);
        let cy = rng.range(-0.15 * hf, 1.15 * hf);
        let size = wf.min(hf);
        match rng.below(7) {
            0 => disc(cx, cy, rng.range(0.3, 0.5 * size)),
            1 | 2 => {
                let (hw, hh) = (rng.range(0.5, 0.45 * wf), rng.range(0.5, 0.45 * hf));
                let a = if rng.chance(0.5) { 0.0 } else { rng.range(0.0, 3.2) };
                let (s, c) = a.sin_cos();
                Box::new(move |x, y| {
                    let (px, py) = (x - cx, y - cy);
                    let (qx, qy) = ((c * px + s * py).abs() - hw, (c * py - s * px).abs() - hh);
                    let outside = (qx.max(0.0).powi(2) + qy.max(0.0).powi(2)).sqrt();
                    outside + qx.max(qy).min(0.0)
                })
            }
            3 => {
                // A disc with a hole (off-centre), possibly touching its rim.
                let radius = rng.range(3.0, 0.5 * size + 3.0);
                let hole = rng.range(0.5, 0.6 * radius);
                let (hx, hy) = (cx + rng.range(-0.5, 0.5) * radius, cy + rng.range(-0.5, 0.5) * radius);
                Box::new(move |x, y| {
                    let outer = ((x - cx).powi(2) + (y - cy).powi(2)).sqrt() - radius;
                    let inner = hole - ((x - hx).powi(2) + (y - hy).powi(2)).sqrt();
                    outer.max(inner)
                })
            }
            4 => {
                // A ring about 1 px wide.
                let radius = rng.range(1.0, 0.5 * size + 1.0);
                let half = rng.range(0.3, 0.8);
                Box::new(move |x, y| (((x - cx).powi(2) + (y - cy).powi(2)).sqrt() - radius).abs() - half)
            }
            5 => {
                // A speck.
                let (x0, y0) = (rng.below(w) as f32, rng.below(h) as f32);
                let (hw, hh) = (rng.range(0.2, 1.5), rng.range(0.2, 1.5));
                Box::new(move |x, y| ((x - x0).abs() - hw).max((y - y0).abs() - hh))
            }
            _ => {
                // Two discs a few px apart (either may fall in the other's box).
                let r1 = rng.range(1.0, 0.3 * size + 1.0);
                let r2 = rng.range(1.0, 0.3 * size + 1.0);
                let gap = rng.range(0.5, 4.0);
                let a = rng.range(0.0, 6.3);
                let (dx, dy) = ((r1 + r2 + gap) * a.cos(), (r1 + r2 + gap) * a.sin());
                let (d1, d2) = (disc(cx, cy, r1), disc(cx + dx, cy + dy, r2));
                Box::new(move |x, y| d1(x, y).min(d2(x, y)))
            }
        }
    }

    /// A frame, its background and the 0/1 mask `|D| > τ`.
    struct Scene {
        w: usize,
        h: usize,
        frame: Vec<u8>,
        background: Vec<u8>,
        mask: Vec<u8>,
    }

    fn scene(rng: &mut Rng, w: usize, h: usize, alpha: Alpha) -> Scene {
        let base = 20.0 + rng.range(0.0, 80.0);
        let tilt = rng.range(-0.3, 0.3);
        let background: Vec<u8> = (0..w * h)
            .map(|i| (base + tilt * (i % w) as f32 + rng.below(4) as f32).clamp(0.0, 255.0) as u8)
            .collect();
        let sign = if rng.chance(0.7) { 1.0 } else { -1.0 };
        let amplitude = rng.range(25.0, 150.0);
        let shading = rng.range(-0.4, 0.4);
        let mut cover = vec![0.0f32; w * h];
        for _ in 0..1 + rng.below(6) {
            let shape = random_shape(rng, w, h);
            let blur = rng.range(0.3, 3.0);
            // Part of some parts is a printed label of lower contrast.
            let label = rng
                .chance(0.3)
                .then(|| (rng.below(w), rng.below(h), 1 + rng.below(8), rng.range(0.3, 0.7)));
            for y in 0..h {
                for x in 0..w {
                    let mut c = (0.5 - shape(x as f32, y as f32) / blur).clamp(0.0, 1.0);
                    if let Some((lx, ly, ls, lf)) = label {
                        if x.abs_diff(lx) < ls && y.abs_diff(ly) < ls {
                            c *= lf;
                        }
                    }
                    let slot = &mut cover[y * w + x];
                    *slot = slot.max(c);
                }
            }
        }
        let frame: Vec<u8> = (0..w * h)
            .map(|i| {
                let gain = 1.0 + shading * ((i % w) as f32 / w as f32 - 0.5);
                let noise = rng.below(5) as f32 - 2.0;
                (background[i] as f32 + sign * amplitude * gain * cover[i] + noise).clamp(0.0, 255.0) as u8
            })
            .collect();
        let mut mask = vec![0u8; w * h];
        {
            let f = Frame::new_checked(&frame[..], w, h).unwrap();
            let diff = Difference::new(&f, &background, alpha);
            let tau = amplitude * rng.range(0.25, 0.6);
            for y in 0..h {
                for x in 0..w {
                    mask[y * w + x] = (diff.at(x as isize, y as isize).abs() > tau) as u8;
                }
            }
        }
        if rng.chance(0.3) {
            // Specks and pinholes.
            for _ in 0..rng.below(w * h / 20 + 1) {
                let i = rng.below(w * h);
                mask[i] ^= 1;
            }
        }
        if rng.chance(0.05) {
            // Dense noise: one big ragged component.
            let density = rng.range(0.45, 0.75);
            for m in mask.iter_mut() {
                *m = rng.chance(density) as u8;
            }
        }
        Scene {
            w,
            h,
            frame,
            background,
            mask,
        }
    }

    /// The 8-connected components of a 0/1 plane: their pixels, first the top-left one.
    pub(super) fn components(mask: &[u8], w: usize, h: usize) -> Vec<Vec<(usize, usize)>> {
        let mut seen = vec![false; w * h];
        let mut out = Vec::new();
        for y in 0..h {
            for x in 0..w {
                if mask[y * w + x] == 0 || seen[y * w + x] {
                    continue;
                }
                let mut pixels = vec![(x, y)];
                seen[y * w + x] = true;
                let mut k = 0;
                while k < pixels.len() {
                    let (px, py) = pixels[k];
                    k += 1;
                    for ny in py.saturating_sub(1)..(py + 2).min(h) {
                        for nx in px.saturating_sub(1)..(px + 2).min(w) {
                            if mask[ny * w + nx] != 0 && !seen[ny * w + nx] {
                                seen[ny * w + nx] = true;
                                pixels.push((nx, ny));
                            }
                        }
                    }
                }
                out.push(pixels);
            }
        }
        out
    }

    fn bounding_box(pixels: &[(usize, usize)]) -> Rect {
        let mut r = Rect {
            x0: usize::MAX,
            y0: usize::MAX,
            x1: 0,
            y1: 0,
        };
        for &(x, y) in pixels {
            r.x0 = r.x0.min(x);
            r.y0 = r.y0.min(y);
            r.x1 = r.x1.max(x + 1);
            r.y1 = r.y1.max(y + 1);
        }
        r
    }

    #[derive(Default, Debug)]
    struct Tally {
        calls: usize,
        some: usize,
        bit_identical: usize,
        worst: f32,
    }

    /// Old and new on copies of the plane: same `Option`, centroids within `tolerance` (0: the
    /// same bits), the same plane afterwards.
    fn compare(scene: &Scene, alpha: Alpha, seed: (usize, usize), bbox: Rect, tolerance: f32, tally: &mut Tally) {
        let (w, h) = (scene.w, scene.h);
        let frame = Frame::new_checked(&scene.frame[..], w, h).unwrap();
        let diff = Difference::new(&frame, &scene.background, alpha);
        let mut old_plane = scene.mask.clone();
        let mut new_plane = scene.mask.clone();
        let new = partial_volume_centroid(&diff, &mut new_plane, seed, bbox);
        let inside = seed.0 + MARGIN >= bbox.x0
            && seed.0 < bbox.x1.saturating_add(MARGIN)
            && seed.1 + MARGIN >= bbox.y0
            && seed.1 < bbox.y1.saturating_add(MARGIN);
        if !inside {
            assert_eq!(new, None, "seed {seed:?} outside the box {bbox:?}");
            assert!(new_plane == scene.mask, "plane touched, seed outside the box");
            return;
        }
        let old = reference::reference_partial_volume_centroid(&diff, &mut old_plane, seed, bbox);
        tally.calls += 1;
        let context = || std::format!("{w}x{h} seed {seed:?} box {bbox:?}: old {old:?} new {new:?}");
        assert!(new_plane == old_plane, "planes differ afterwards, {}", context());
        assert!(new_plane.iter().all(|&v| v <= 1), "plane not 0/1, {}", context());
        match (old, new) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                tally.some += 1;
                if a.map(f32::to_bits) == b.map(f32::to_bits) {
                    tally.bit_identical += 1;
                }
                let err = (a[0] - b[0]).abs().max((a[1] - b[1]).abs());
                tally.worst = tally.worst.max(err);
                assert!(err <= tolerance, "centroids differ by {err}, {}", context());
            }
            _ => panic!("Option-ness differs, {}", context()),
        }
    }

    /// Random scenes; every component's top-left pixel (what the recognizer passes) and a few
    /// random pixels as seeds, with the component's box or a perturbed one.
    fn random_scenes(seed: u64, scenes: usize, alpha: f32, tolerance: f32) -> Tally {
        let alpha = Alpha::new(alpha).unwrap();
        let mut rng = Rng(seed);
        let mut tally = Tally::default();
        for _ in 0..scenes {
            let (w, h) = if rng.chance(0.04) {
                (230 + rng.below(60), 6 + rng.below(30))
            } else {
                (1 + rng.below(72), 1 + rng.below(72))
            };
            let scene = scene(&mut rng, w, h, alpha);
            for pixels in components(&scene.mask, w, h).iter().take(12) {
                let exact = bounding_box(pixels);
                let mut seeds = vec![pixels[0]];
                for _ in 0..2 {
                    seeds.push(pixels[rng.below(pixels.len())]);
                }
                for seed in seeds {
                    let bbox = if rng.chance(0.25) {
                        let mut jitter = |v: usize| (v as isize + rng.below(17) as isize - 8).max(0) as usize;
                        let (x0, y0, x1, y1) = (jitter(exact.x0), jitter(exact.y0), jitter(exact.x1), jitter(exact.y1));
                        Rect {
                            x0,
                            y0,
                            x1: x1.max(x0),
                            y1: y1.max(y0),
                        }
                    } else {
                        exact
                    };
                    compare(&scene, alpha, seed, bbox, tolerance, &mut tally);
                }
            }
        }
        tally
    }

    fn cases(default: usize) -> usize {
        std::env::var("VORL_PV_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(default)
    }

    /// The centroid of a coverage plane `w` wide (in f64, so its sums do not round).
    pub(super) fn coverage_centroid(cover: &[f32], w: usize) -> [f32; 2] {
        let (mut sw, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
        for (i, &c) in cover.iter().enumerate() {
            sw += f64::from(c);
            sx += f64::from(c) * (i % w) as f64;
            sy += f64::from(c) * (i / w) as f64;
        }
        [(sx / sw) as f32, (sy / sw) as f32]
    }

    /// A bar with a thin-rimmed eye (a connecting rod's end: no ring pixel 3–5 px inside its
    /// edge within 4 px of the eye) on a platform whose light falls off by half across it, the
    /// part lit by the same light (its level a fixed fraction of the platform's): the
    /// partial-volume centroid is the coverage's centroid, with both polarities and the eye at
    /// the bright end or the dim one. A fallback contrast taken from the whole ring's median,
    /// unscaled by the platform's level, put it 0.27–0.48 px off here (the real rod of `TESI21`
    /// 1.8 px); scaled, it is within 0.06 px. (With α < 1 the difference is not the coverage
    /// on a rim this thin: the edges' gradient lifts all of it.)
    #[test]
    fn a_thin_rim_on_a_vignetted_platform_keeps_its_centroid() {
        let (w, h) = (110usize, 60usize);
        for (end, dark) in [("dim", true), ("bright", true), ("dim", false)] {
            let dim = end == "dim";
            let (cx, cy, outer, inner) = (if dim { 78.3 } else { 31.7 }, 30.4, 11.0, 8.0);
            let bar_x = if dim { 50.0 } else { 60.0 };
            let shape = move |x: f32, y: f32| {
                let ring = ((x - cx).powi(2) + (y - cy).powi(2)).sqrt();
                let eye = (ring - outer).max(inner - ring);
                let bar = ((x - bar_x).abs() - 30.0).max((y - 30.2).abs() - 8.0);
                eye.min(bar)
            };
            // Light from 240 at the left to 120 at the right (platform), the part at 15 % of it
            // (dark) or 170 % of a dim platform (bright).
            let light = |x: usize| 240.0 - 120.0 * x as f32 / (w - 1) as f32;
            let (platform, part) = if dark { (1.0, 0.15) } else { (0.5, 0.85) };
            let blur = 1.6;
            let mut cover = vec![0.0f32; w * h];
            let mut frame = vec![0u8; w * h];
            let mut empty = vec![0u8; w * h];
            for y in 0..h {
                for x in 0..w {
                    let c = (0.5 - shape(x as f32, y as f32) / blur).clamp(0.0, 1.0);
                    let b = platform * light(x);
                    cover[y * w + x] = c;
                    empty[y * w + x] = b.round() as u8;
                    frame[y * w + x] = (b + (part * light(x) - b) * c).round() as u8;
                }
            }
            let background = empty;
            let want = coverage_centroid(&cover, w);
            let mut mask: Vec<u8> = cover.iter().map(|&c| u8::from(c > 0.5)).collect();
            let pixels = components(&mask, w, h).into_iter().max_by_key(Vec::len).unwrap();
            let f = Frame::new_checked(&frame[..], w, h).unwrap();
            let diff = Difference::new(&f, &background, Alpha::ONE);
            let got = partial_volume_centroid(&diff, &mut mask, pixels[0], bounding_box(&pixels)).unwrap();
            let err = (got[0] - want[0]).hypot(got[1] - want[1]);
            assert!(
                err < 0.1,
                "eye at the {end} end, dark {dark}: {got:?} against {want:?} ({err} px)"
            );
        }
    }

    #[test]
    fn matches_the_reference_on_random_scenes() {
        // α = 1: D is an integer, so every sum is exact and the result has the same bits.
        let tally = random_scenes(0x9E37_79B9_7F4A_7C15, cases(400), 1.0, 0.0);
        std::println!("{tally:?}");
        assert!(tally.calls > 2000 && tally.some > 400, "{tally:?}");
        assert_eq!(tally.bit_identical, tally.some);
    }

    #[test]
    fn matches_the_reference_with_alpha_one_half() {
        // α < 1: D is fractional and the local sums are added in another order.
        let tally = random_scenes(0x2545_F491_4F6C_DD1D, cases(400), 0.5, 1e-4);
        std::println!("{tally:?}");
        assert!(tally.calls > 2000 && tally.some > 300, "{tally:?}");
    }

    #[test]
    fn box_width_at_the_bit_row_limit() {
        // Bar parts whose box (bbox + 2·6) is 250..=262 px wide: both paths and the switch.
        let (w, h) = (280, 24);
        let alpha = Alpha::ONE;
        let mut tally = Tally::default();
        for (k, bar) in (238..=250).enumerate() {
            let mut rng = Rng(77 + k as u64);
            let x0 = 8.0 + rng.below(10) as f32 + rng.unit();
            let shape = move |x: f32, y: f32| {
                ((x - x0 - bar as f32 / 2.0).abs() - bar as f32 / 2.0).max((y - 11.3).abs() - 5.0)
            };
            let background = vec![40u8; w * h];
            let frame: Vec<u8> = (0..w * h)
                .map(|i| {
                    let c = (0.5f32 - shape((i % w) as f32, (i / w) as f32) / 1.5).clamp(0.0, 1.0);
                    (40.0 + 120.0 * c) as u8 + rng.below(3) as u8
                })
                .collect();
            let mask: Vec<u8> = frame.iter().map(|&v| (v > 100) as u8).collect();
            let scene = Scene {
                w,
                h,
                frame,
                background,
                mask,
            };
            for pixels in components(&scene.mask, w, h) {
                compare(&scene, alpha, pixels[0], bounding_box(&pixels), 0.0, &mut tally);
            }
        }
        assert!(tally.some >= 13, "{tally:?}");
        assert_eq!(tally.bit_identical, tally.some);
    }

    #[test]
    fn bad_input_gives_none_without_panic() {
        let (w, h) = (30, 20);
        let frame_px = vec![90u8; w * h];
        let background = vec![10u8; w * h];
        let frame = Frame::new_checked(&frame_px[..], w, h).unwrap();
        let diff = Difference::new(&frame, &background, Alpha::ONE);
        let mut mask = vec![0u8; w * h];
        for y in 3..17 {
            for x in 4..24 {
                mask[y * w + x] = 1;
            }
        }
        let bbox = Rect {
            x0: 4,
            y0: 3,
            x1: 24,
            y1: 17,
        };
        let original = mask.clone();
        // A plane shorter than the image.
        let mut short = mask[..w * h - 1].to_vec();
        assert_eq!(partial_volume_centroid(&diff, &mut short, (5, 5), bbox), None);
        assert_eq!(partial_volume_centroid(&diff, &mut [], (5, 5), bbox), None);
        // Seeds outside the image or on the background; a seed outside its box.
        for seed in [(w, 5), (5, h), (usize::MAX, usize::MAX), (0, 0), (29, 19)] {
            assert_eq!(partial_volume_centroid(&diff, &mut mask, seed, bbox), None, "{seed:?}");
            assert_eq!(mask, original);
        }
        let boxes = [
            Rect {
                x0: 12,
                y0: 0,
                x1: 15,
                y1: 9,
            },
            Rect {
                x0: usize::MAX,
                y0: usize::MAX,
                x1: usize::MAX,
                y1: usize::MAX,
            },
            Rect {
                x0: 30,
                y0: 0,
                x1: 2,
                y1: 1,
            },
        ];
        for b in boxes {
            assert_eq!(partial_volume_centroid(&diff, &mut mask, (5, 5), b), None, "{b:?}");
            assert_eq!(mask, original);
        }
        // D is 80 everywhere: the part and its 2-px band count 1. A huge box is clipped.
        for b in [
            bbox,
            Rect {
                x0: 0,
                y0: 0,
                x1: usize::MAX,
                y1: usize::MAX,
            },
        ] {
            let c = partial_volume_centroid(&diff, &mut mask, (5, 5), b).unwrap();
            assert!((c[0] - 13.5).abs() < 1e-4 && (c[1] - 9.5).abs() < 1e-4, "{c:?}");
            assert_eq!(mask, original);
        }
    }

    mod reference {
        use super::super::definition::{self, any_neighbour, COMPONENT};
        use super::super::Rect;
        use crate::pose::refine::Difference;

        /// The implementation before the bit-row rewrite as the oracle: the partial-volume area
        /// centroid of the part whose border passes through `seed` (a foreground pixel), within
        /// `bbox` plus a 6 px margin. Its component fill is kept here verbatim (but for the flag
        /// bit); its morphology and weights live on unchanged as `per_pixel::centroid`, the path
        /// of boxes wider than the bit rows.
        pub fn reference_partial_volume_centroid<B: AsRef<[u8]>>(
            diff: &Difference<'_, B>,
            mask: &mut [u8],
            seed: (usize, usize),
            bbox: Rect,
        ) -> Option<[f32; 2]> {
            let (w, h) = (diff.width(), diff.height());
            if mask.len() < w * h || seed.0 >= w || seed.1 >= h {
                return None;
            }
            let r = Rect {
                x0: bbox.x0.saturating_sub(6),
                y0: bbox.y0.saturating_sub(6),
                x1: (bbox.x1 + 6).min(w),
                y1: (bbox.y1 + 6).min(h),
            };
            // The 8-connected component of the seed.
            if mask.get(seed.1 * w + seed.0).is_none_or(|v| v & 1 == 0) {
                return None;
            }
            mark_component(mask, w, r, seed);
            definition::centroid(diff, mask, w, r)
        }

        /// Marks the 8-connected foreground component of `seed` (inside `r`) with [`COMPONENT`]: a
        /// scanline fill with a fixed stack; when the stack overflows, repeated raster passes finish the
        /// job (bounded by the box's size).
        fn mark_component(mask: &mut [u8], w: usize, r: Rect, seed: (usize, usize)) {
            const STACK: usize = 256;
            let free =
                |mask: &[u8], x: usize, y: usize| mask.get(y * w + x).is_some_and(|v| v & 1 != 0 && v & COMPONENT == 0);
            let mut stack = [(0usize, 0usize); STACK];
            let mut top = 0usize;
            let mut overflow = false;
            if let Some(slot) = stack.get_mut(0) {
                *slot = seed;
                top = 1;
            }
            while top > 0 {
                top -= 1;
                let Some(&(x, y)) = stack.get(top) else { break };
                if !free(mask, x, y) {
                    continue;
                }
                let (mut xl, mut xr) = (x, x);
                while xl > r.x0 && free(mask, xl - 1, y) {
                    xl -= 1;
                }
                while xr + 1 < r.x1 && free(mask, xr + 1, y) {
                    xr += 1;
                }
                for xx in xl..=xr {
                    if let Some(v) = mask.get_mut(y * w + xx) {
                        *v |= COMPONENT;
                    }
                }
                for ny in [y.wrapping_sub(1), y + 1] {
                    if ny < r.y0 || ny >= r.y1 {
                        continue;
                    }
                    let mut xx = xl.saturating_sub(1).max(r.x0);
                    let last = (xr + 1).min(r.x1 - 1);
                    while xx <= last {
                        if free(mask, xx, ny) {
                            match stack.get_mut(top) {
                                Some(slot) => {
                                    *slot = (xx, ny);
                                    top += 1;
                                }
                                None => overflow = true,
                            }
                            while xx <= last && free(mask, xx, ny) {
                                xx += 1;
                            }
                        } else {
                            xx += 1;
                        }
                    }
                }
            }
            if !overflow {
                return;
            }
            let mut changed = true;
            let mut passes = 0usize;
            while changed && passes < (r.x1 - r.x0) + (r.y1 - r.y0) + 2 {
                changed = false;
                for forward in [true, false] {
                    for yi in 0..(r.y1 - r.y0) {
                        let y = if forward { r.y0 + yi } else { r.y1 - 1 - yi };
                        for xi in 0..(r.x1 - r.x0) {
                            let x = if forward { r.x0 + xi } else { r.x1 - 1 - xi };
                            if free(mask, x, y) && any_neighbour(mask, w, r, x, y, COMPONENT) {
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
        }
    }
}
