//! Shadows beside bright parts, blob by blob ([`Polarity::Either`]).
//!
//! `|I' − B| > τ` takes a front-lit part brighter than the platform and the shadow it throws
//! beside itself, darker than the platform, as one blob. A set whose parts all lie on one side
//! of the platform is told so by `vorl teach` ([`Polarity::Brighter`], [`Polarity::Darker`]:
//! the shadow never enters the mask); a set of both kinds keeps `Either`, and [`separate`]
//! applies, to each blob of both signs, the rule `vorl teach` uses on the taught part:
//!
//! - the part's sign is the one that holds most of the blob's contrast `Σ|D|` (`D = I' − B`);
//! - its *extent* is what that sign's pixels enclose: the blob's pixels that the outside does
//!   not reach (4-connected) without crossing one of them;
//! - pixels of the other sign beyond τ outside the extent lie *beside* the part. Where they are
//!   more than the extent's outline has pixels (more than one band of pixels along it: more than
//!   the mask's own edge noise makes), and the part is the brighter (a shadow is darker than
//!   the platform beside a brighter part), the blob is cut: the pixels outside the extent that
//!   touch the part's (8-connected: a seam one pixel wide, with the shadow's faint rim that the
//!   clean-up joined) leave the mask, and so do the darker pixels beyond τ inside the extent
//!   (the shadowed platform seen through a bore), as [`Polarity::Brighter`] takes them, and as
//!   the template was taught.
//!
//! What lay beside the part is then a blob of its own ([`Beside::holds`] tells which). The
//! recognizer names it where a template explains it (a dark part against a bright one) and
//! otherwise skips it as a shadow ([`crate::recognizer::SkipReason::Shadow`]). The frame does
//! not tell an untaught dark part against a bright one from a shadow: it is skipped too.
//!
//! A blob with nothing darker beside its part keeps every pixel: a dark bore, a dark facet or
//! dark print inside a bright part is inside its extent and no evidence of a shadow; nor is a
//! notch of print on its rim, a few pixels along its outline. A dark part's blob (a bright one
//! against it, a highlight on its rim, a halo) is left as it is: light does not throw a
//! brighter shadow.
//!
//! Time: a glance at every fourth point of the blob's outline for every blob; for a blob of both signs
//! on its outline, a few raster passes over its bounding box. Memory: three flag bits of the
//! label plane in the box (cleared again), no buffer.

#[cfg(doc)]
use crate::pixels::mask::Polarity;

/// Flag bits of the label plane while [`separate`] runs (bit 0 is the mask): the blob's
/// 8-connected component,
const COMPONENT: u8 = 1 << 7;
/// its pixels brighter than the platform beyond τ (the part's),
const MAJOR: u8 = 1 << 6;
/// and what the outside reaches without crossing one of those.
const OUTSIDE: u8 = 1 << 5;

/// The outline points the glance reads: every fourth, which costs a quarter of reading them all
/// on the blobs it passes by (most of them). It misses a shadow only where it meets the
/// outline over fewer than four pixels, far less than the extent's outline it must outnumber.
const GLANCE_STEP: usize = 4;

/// A box of the plane: columns `x0..x1`, rows `y0..y1`.
#[derive(Debug, Clone, Copy)]
struct Area {
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
}

/// Cuts the shadow (what lies darker beside a bright part) off the blob whose outer border is `outline` off it (pixels of the mask in
/// `plane`, `w`×`h`, 0/1 with bits 1–7 clear), as the module doc says; `d(x, y)` is the signed
/// difference `D = I' − B` at a pixel and `tau` the mask's threshold. Returns what was cut,
/// or `None` for a blob of one sign, a dark part's, or a bright part's with nothing darker
/// beside it (the plane then is as it was). Bits 1–7 of the box are clear again on return. A plane shorter
/// than `w·h`, or an outline off the plane, changes nothing.
///
/// ```
/// use vorl_core::pixels::shadow::separate;
/// // A bright disc (D = +60) with a dark crescent beside it (D = −30), one blob of the mask.
/// let (w, h) = (40usize, 30usize);
/// let disc = |x: usize, y: usize| (x as f32 - 15.0).powi(2) + (y as f32 - 15.0).powi(2) <= 64.0;
/// let shade = |x: usize, y: usize| !disc(x, y) && (x as f32 - 19.0).powi(2) + (y as f32 - 15.0).powi(2) <= 64.0;
/// let d = |x: usize, y: usize| if disc(x, y) { 60.0 } else if shade(x, y) { -30.0 } else { 0.0 };
/// let mut plane = vec![0u8; w * h];
/// for y in 0..h { for x in 0..w { plane[y * w + x] = u8::from(disc(x, y) || shade(x, y)); } }
/// // Its outer border: here just the blob's pixels with a background 4-neighbour.
/// let outline: Vec<(usize, usize)> = (0..w * h)
///     .map(|i| (i % w, i / w))
///     .filter(|&(x, y)| plane[y * w + x] == 1
///         && [(x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)].iter().any(|&(a, b)| plane[b * w + a] == 0))
///     .collect();
/// let cut = separate(&mut plane, w, h, outline.iter().copied(), 20, d).unwrap();
/// assert!(cut.taken > 0);
/// // The disc stays; the crescent is a blob of its own, a pixel away from it.
/// let touching = |x: usize, y: usize| (x.saturating_sub(1)..=x + 1).any(|a| (y.saturating_sub(1)..=y + 1).any(|b| disc(a, b)));
/// for i in 0..w * h {
///     let (x, y) = (i % w, i / w);
///     assert_eq!(plane[i] == 1, disc(x, y) || (shade(x, y) && !touching(x, y)));
/// }
/// ```
pub fn separate(
    plane: &mut [u8],
    w: usize,
    h: usize,
    outline: impl Iterator<Item = (usize, usize)> + Clone,
    tau: u8,
    d: impl Fn(usize, usize) -> f32,
) -> Option<Beside> {
    let t = f32::from(tau);
    let plane = w.checked_mul(h).filter(|&n| n > 0).and_then(|n| plane.get_mut(..n))?;
    // The glance: both signs beyond τ on the outline (every GLANCE_STEP-th point: a shadow the
    // rule would cut lies along more of the outline than that), else nothing lies beside the
    // part. Most blobs stop here.
    let (mut up, mut down) = (false, false);
    for (x, y) in outline.clone().step_by(GLANCE_STEP) {
        if x >= w || y >= h {
            return None;
        }
        let v = d(x, y);
        up |= v > t;
        down |= v < -t;
        if up && down {
            break;
        }
    }
    if !(up && down) {
        return None;
    }
    let mut b = Area {
        x0: usize::MAX,
        y0: usize::MAX,
        x1: 0,
        y1: 0,
    };
    let mut seed = None;
    for (x, y) in outline {
        if x >= w || y >= h {
            return None;
        }
        (b.x0, b.y0, b.x1, b.y1) = (b.x0.min(x), b.y0.min(y), b.x1.max(x + 1), b.y1.max(y + 1));
        seed = seed.or(Some((x, y)));
    }
    let (sx, sy) = seed?;
    if plane.get(sy * w + sx).is_none_or(|&v| v & 1 == 0) {
        return None;
    }
    // One pixel round the blob, for the outside to pass.
    let r = Area {
        x0: b.x0.saturating_sub(1),
        y0: b.y0.saturating_sub(1),
        x1: (b.x1 + 1).min(w),
        y1: (b.y1 + 1).min(h),
    };
    if let Some(p) = plane.get_mut(sy * w + sx) {
        *p |= COMPONENT;
    }
    grow(plane, w, r, COMPONENT, true, |v| v & 1 != 0);
    // The part's sign: the one that holds most of the blob's contrast; only a bright part's
    // blob goes on.
    let (mut above, mut below) = (0.0f32, 0.0f32);
    for_box(plane, w, r, |x, y, v| {
        if *v & COMPONENT != 0 {
            let e = d(x, y);
            if e > 0.0 {
                above += e;
            } else {
                below -= e;
            }
        }
    });
    if above < below {
        // A dark part: nothing beside it is its shadow.
        for_box(plane, w, r, |_, _, v| *v &= 1);
        return None;
    }
    for_box(plane, w, r, |x, y, v| {
        if *v & COMPONENT != 0 && d(x, y) > t {
            *v |= MAJOR;
        }
    });
    // The outside: from the box's rim, through everything but the part's sign.
    for_box(plane, w, r, |x, y, v| {
        let rim = x == r.x0 || y == r.y0 || x + 1 == r.x1 || y + 1 == r.y1;
        if rim && *v & MAJOR == 0 {
            *v |= OUTSIDE;
        }
    });
    grow(plane, w, r, OUTSIDE, false, |v| v & MAJOR == 0);
    // Beside: the other sign beyond τ outside the extent; against the extent's outline.
    let (mut beside, mut edge) = (0usize, 0usize);
    for y in r.y0..r.y1 {
        for x in r.x0..r.x1 {
            let v = plane.get(y * w + x).copied().unwrap_or(0);
            if v & OUTSIDE != 0 {
                beside += usize::from(v & COMPONENT != 0 && d(x, y) < -t);
            } else if [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)]
                .iter()
                .any(|&(a, c)| {
                    !(r.x0..r.x1).contains(&a) || !(r.y0..r.y1).contains(&c) || flag_at(plane, w, a, c, OUTSIDE)
                })
            {
                edge += 1;
            }
        }
    }
    let mut taken = 0usize;
    let shadow = beside > edge;
    if shadow {
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let v = plane.get(y * w + x).copied().unwrap_or(0);
                if v & COMPONENT == 0 || v & MAJOR != 0 {
                    continue;
                }
                let off = if v & OUTSIDE == 0 {
                    d(x, y) < -t
                } else {
                    reaches(plane, w, r, x, y, MAJOR, true)
                };
                if let Some(p) = plane.get_mut(y * w + x).filter(|_| off) {
                    *p &= !1;
                    taken += 1;
                }
            }
        }
    }
    for_box(plane, w, r, |_, _, v| *v &= 1);
    let side = |v: usize| u16::try_from(v).unwrap_or(u16::MAX);
    shadow.then_some(Beside {
        taken: u32::try_from(taken).unwrap_or(u32::MAX),
        x0: side(r.x0),
        y0: side(r.y0),
        x1: side(r.x1),
        y1: side(r.y1),
    })
}

/// What [`separate`] found beside a bright part and cut off it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Beside {
    /// Pixels that left the mask: the seam, and the other sign inside the part's extent.
    pub taken: u32,
    /// The blob's box before (one pixel round it, within the plane): first column,
    pub x0: u16,
    /// first row,
    pub y0: u16,
    /// column past the last,
    pub x1: u16,
    /// and row past the last.
    pub y1: u16,
}

impl Beside {
    /// Whether a blob of the mask after [`separate`], whose outline holds `brighter` pixels
    /// brighter than the platform beyond τ and `darker` darker ones and starts at `(x, y)`,
    /// is of what lay beside this part: inside its box, mostly darker.
    pub fn holds(&self, x: usize, y: usize, brighter: usize, darker: usize) -> bool {
        let other = darker > brighter;
        let (x0, y0, x1, y1) = (self.x0.into(), self.y0.into(), self.x1.into(), self.y1.into());
        other && (x0..x1).contains(&x) && (y0..y1).contains(&y)
    }
}

/// Calls `f(x, y, pixel)` for every pixel of box `r`, row by row.
fn for_box(plane: &mut [u8], w: usize, r: Area, mut f: impl FnMut(usize, usize, &mut u8)) {
    for y in r.y0..r.y1 {
        if let Some(row) = plane.get_mut(y * w + r.x0..y * w + r.x1) {
            for (x, v) in (r.x0..).zip(row.iter_mut()) {
                f(x, y, v);
            }
        }
    }
}

/// Whether pixel `(x, y)` (inside the plane) has `flag`.
#[inline]
fn flag_at(plane: &[u8], w: usize, x: usize, y: usize, flag: u8) -> bool {
    x < w && plane.get(y * w + x).is_some_and(|&v| v & flag != 0)
}

/// Sets `flag` on every pixel of box `r` that `open` admits and that reaches a pixel already
/// flagged through pixels `open` admits (4-connected, 8 with `diagonal`): raster passes,
/// forward then backward, until one changes nothing (at most one pair per row and column of
/// the box: what a path that turns at every one of them needs).
fn grow(plane: &mut [u8], w: usize, r: Area, flag: u8, diagonal: bool, open: impl Fn(u8) -> bool) {
    let limit = (r.x1 - r.x0) + (r.y1 - r.y0) + 2;
    for _ in 0..limit {
        let mut changed = false;
        for forward in [true, false] {
            for yi in 0..(r.y1 - r.y0) {
                let y = if forward { r.y0 + yi } else { r.y1 - 1 - yi };
                for xi in 0..(r.x1 - r.x0) {
                    let x = if forward { r.x0 + xi } else { r.x1 - 1 - xi };
                    let Some(&v) = plane.get(y * w + x) else { continue };
                    if v & flag != 0 || !open(v) {
                        continue;
                    }
                    if reaches(plane, w, r, x, y, flag, diagonal) {
                        if let Some(p) = plane.get_mut(y * w + x) {
                            *p |= flag;
                        }
                        changed = true;
                    }
                }
            }
        }
        if !changed {
            break;
        }
    }
}

/// Whether a neighbour of `(x, y)` inside box `r` (4-connected, 8 with `diagonal`) has `flag`.
#[inline]
fn reaches(plane: &[u8], w: usize, r: Area, x: usize, y: usize, flag: u8, diagonal: bool) -> bool {
    for dy in [-1isize, 0, 1] {
        for dx in [-1isize, 0, 1] {
            if (dx == 0 && dy == 0) || (!diagonal && dx != 0 && dy != 0) {
                continue;
            }
            let (nx, ny) = (x.wrapping_add_signed(dx), y.wrapping_add_signed(dy));
            if (r.x0..r.x1).contains(&nx) && (r.y0..r.y1).contains(&ny) && flag_at(plane, w, nx, ny, flag) {
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
    use crate::test_rng::XorShift as Rng;
    use std::vec::Vec;

    const W: usize = 64;
    const H: usize = 48;
    const TAU: u8 = 20;

    /// A scene of `D` values: the mask is `|D| > τ` and the outline its pixels with a
    /// background 4-neighbour (or on the plane's edge).
    struct Scene {
        d: Vec<f32>,
    }

    impl Scene {
        fn new(f: impl Fn(f32, f32) -> f32) -> Self {
            Scene {
                d: (0..W * H).map(|i| f((i % W) as f32, (i / W) as f32)).collect(),
            }
        }

        fn d(&self) -> impl Fn(usize, usize) -> f32 + '_ {
            move |x, y| self.d.get(y * W + x).copied().unwrap_or(0.0)
        }

        fn mask(&self) -> Vec<u8> {
            self.d.iter().map(|&v| u8::from(v.abs() > f32::from(TAU))).collect()
        }

        /// The outer outline of the component of `mask` that holds `(x, y)`: its pixels with a
        /// 4-neighbour outside the mask (holes included: the glance only reads signs).
        fn outline(mask: &[u8]) -> Vec<(usize, usize)> {
            (0..W * H)
                .map(|i| (i % W, i / W))
                .filter(|&(x, y)| {
                    mask[y * W + x] == 1
                        && (x == 0
                            || y == 0
                            || x + 1 == W
                            || y + 1 == H
                            || mask[y * W + x - 1] == 0
                            || mask[y * W + x + 1] == 0
                            || mask[(y - 1) * W + x] == 0
                            || mask[(y + 1) * W + x] == 0)
                })
                .collect()
        }

        /// The mask after [`separate`], and the pixels it took.
        fn separated(&self) -> (Vec<u8>, Option<Beside>) {
            let mut plane = self.mask();
            let outline = Self::outline(&plane);
            let cut = separate(&mut plane, W, H, outline.iter().copied(), TAU, self.d());
            (plane, cut)
        }
    }

    /// Whether a pixel of `part` is among the 8 round `(x, y)`.
    fn next_to(part: impl Fn(f32, f32) -> bool, x: f32, y: f32) -> bool {
        (-1..=1).any(|dy| (-1..=1).any(|dx| part(x + dx as f32, y + dy as f32)))
    }

    fn disc(x: f32, y: f32, cx: f32, cy: f32, r: f32) -> bool {
        (x - cx).powi(2) + (y - cy).powi(2) <= r * r
    }

    #[test]
    fn a_washers_shadow_is_cut_off_it_and_its_bore_opens() {
        // A bright washer (+70) whose shadow (−35) lies beside it and shows through its bore.
        let washer = |x, y| disc(x, y, 28.0, 24.0, 14.0) && !disc(x, y, 28.0, 24.0, 6.0);
        let shadow = |x, y| disc(x, y, 33.0, 27.0, 14.0);
        let s = Scene::new(|x, y| {
            if washer(x, y) {
                70.0
            } else if shadow(x, y) {
                -35.0
            } else {
                0.0
            }
        });
        let (plane, cut) = s.separated();
        assert!(cut.is_some_and(|c| c.taken > 0), "{cut:?}");
        // The washer stays, its bore open; the shadow beside it is a blob of its own.
        for (i, &v) in plane.iter().enumerate() {
            let (x, y) = ((i % W) as f32, (i / W) as f32);
            let beside = shadow(x, y) && !disc(x, y, 28.0, 24.0, 14.0) && !next_to(washer, x, y);
            assert_eq!(v, u8::from(washer(x, y) || beside), "({x}, {y})");
        }
    }

    #[test]
    fn a_dark_parts_halo_or_a_bright_part_against_it_stays() {
        // A bright halo to one side of a dark disc, then a bright disc against a larger dark
        // one: light throws no brighter shadow, and the blob is left as it is.
        let part = |x, y| disc(x, y, 30.0, 22.0, 12.0);
        let halo = Scene::new(|x, y| {
            if part(x, y) {
                -80.0
            } else if disc(x, y, 26.0, 22.0, 14.0) {
                30.0
            } else {
                0.0
            }
        });
        let against = Scene::new(|x, y| {
            if disc(x, y, 24.0, 22.0, 14.0) {
                -70.0
            } else if disc(x, y, 44.0, 22.0, 7.0) {
                70.0
            } else {
                0.0
            }
        });
        for s in [halo, against] {
            let before = s.mask();
            let (plane, cut) = s.separated();
            assert_eq!(cut, None);
            assert_eq!(plane, before);
        }
    }

    #[test]
    fn what_lies_inside_a_part_or_along_a_few_pixels_of_its_rim_stays() {
        // A bright plate with a dark facet inside and a dark notch of print at its rim, and a
        // dark part with a highlight on its rim: nothing beside either, nothing taken.
        let plate = |x: f32, y: f32| (8.0..=40.0).contains(&x) && (8.0..=36.0).contains(&y);
        let bright = Scene::new(|x, y| {
            if plate(x, y) && (disc(x, y, 24.0, 22.0, 5.0) || disc(x, y, 40.0, 20.0, 1.5)) {
                -40.0
            } else if plate(x, y) {
                60.0
            } else {
                0.0
            }
        });
        let dark = Scene::new(|x, y| {
            if disc(x, y, 30.0, 24.0, 15.0) && disc(x, y, 16.0, 24.0, 2.0) {
                50.0
            } else if disc(x, y, 30.0, 24.0, 15.0) {
                -70.0
            } else {
                0.0
            }
        });
        for s in [bright, dark] {
            let before = s.mask();
            let (plane, cut) = s.separated();
            assert_eq!(cut, None);
            assert_eq!(plane, before);
        }
    }

    #[test]
    fn any_plane_keeps_its_bits_and_only_loses_pixels_of_the_blob() {
        let mut rng = Rng(7);
        for _ in 0..300 {
            let d: Vec<f32> = (0..W * H)
                .map(|_| match rng.below(4) {
                    0 => rng.range(-120.0, -21.0),
                    1 => rng.range(21.0, 120.0),
                    _ => rng.range(-25.0, 25.0),
                })
                .collect();
            let s = Scene { d };
            let before = s.mask();
            let mut plane = before.clone();
            // Any outline, on the plane or off it, with or without a seed in the mask.
            let outline: Vec<(usize, usize)> = (0..rng.below(60))
                .map(|_| (rng.below(W + 3), rng.below(H + 2)))
                .collect();
            let cut = separate(&mut plane, W, H, outline.iter().copied(), TAU, s.d());
            let lost = (0..W * H).filter(|&i| before[i] == 1 && plane[i] == 0).count();
            assert_eq!(lost, cut.map_or(0, |c| c.taken as usize));
            assert!(plane.iter().zip(&before).all(|(&a, &b)| a <= 1 && a <= b));
        }
        // A plane too short, or empty, is left alone.
        let mut short = std::vec![1u8; 10];
        assert_eq!(separate(&mut short, W, H, [(1, 1)].into_iter(), TAU, |_, _| 50.0), None);
        assert_eq!(separate(&mut [], 0, 0, core::iter::empty(), TAU, |_, _| 50.0), None);
    }
}
