//! What `vorl teach` measures from the taught part and its surroundings, so that a set taught
//! from one photo a class runs with no hand tuning (the role of HALCON's automatic model
//! parameters): the part's polarity against the platform, and whether a shadow lies beside it.
//!
//! **Polarity.** A part front-lit on a mat is brighter than the platform and throws a shadow,
//! darker than the platform, beside itself. `|I − B| > τ` takes both as one blob, so the
//! taught silhouette carries the shadow, whose side changes across the frame. The rule: within
//! the taught blob, the pixels of the sign that holds most of the blob's contrast form the
//! part; their outer outline with every hole filled is its extent; pixels of the other sign
//! *outside* that extent lie beside the part, not on it. Where they cover more than a one-pixel
//! band along the extent's outline (more than the mask's own edge noise can make), they are a
//! shadow (or a halo), and the part's polarity is that majority sign: the other sign is not
//! part. Pixels of the other sign *inside* the extent (a nut's dark bore, a bolt's dark facet,
//! dark print on a bright part) are not evidence of a shadow. With no such evidence the polarity
//! stays "either": a part without a shadow loses nothing by it.
//!
//! **Where the silhouette's edge lies.** The mask holds every pixel beyond τ, so its outline lies
//! where the blurred edge first rises above τ: about a pixel outside the part on a strong
//! contrast, less on a weak one, and holes shrink by as much. Detection aligns templates on the
//! part's sub-pixel border, the half-contrast iso-line of the difference, so a template cut at τ
//! is too large by the blur's width (the backlit rods of `datasets/real`: 9 % of `rod_a`'s area,
//! 18 % of `rod_b`'s). [`half_contrast_silhouette`] cuts the taught blob where the difference
//! reaches the midpoint between the part's level and the platform's beside it, as detection's
//! edge profiles do, in the band along its outline only, so dark facets and print inside the
//! part stay part of it. The levels are the local ones, within the profiles' reach: a front-lit
//! screw's head is far brighter than its shaded shank, and one level for the whole part (half
//! its median contrast) is not where detection's profiles cross along the shank.

use std::collections::VecDeque;

use vorl_core::pixels::mask::Polarity;

/// What [`measure_polarity`] found in a taught blob.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolarityEvidence {
    /// Share of the blob's contrast `Σ|I − B|` above the platform, 0..1.
    pub brighter_share: f64,
    /// Pixels of the minority sign outside the majority sign's filled extent.
    pub beside: usize,
    /// Outline length of the majority sign's filled extent, px (its boundary pixels).
    pub outline: usize,
    /// The polarity that follows: one-sided only where a shadow (or halo) was found.
    pub polarity: Polarity,
}

impl PolarityEvidence {
    /// One line for the integrator: what was measured and what follows.
    pub fn describe(&self) -> String {
        let side = if self.brighter_share >= 0.5 {
            "brighter"
        } else {
            "darker"
        };
        let share = self.brighter_share.max(1.0 - self.brighter_share) * 100.0;
        match self.polarity {
            Polarity::Either => format!(
                "polarity: either (the part is {side} than the platform, {share:.0} % of its contrast; \
                 {} px of the other sign beside it, within the edge band of its {} px outline: no shadow)",
                self.beside, self.outline
            ),
            _ => format!(
                "polarity: {side} (the part is {side} than the platform, {share:.0} % of its contrast; \
                 {} px of the other sign beside it, more than the edge band of its {} px outline: a shadow, not part)",
                self.beside, self.outline
            ),
        }
    }
}

/// The polarity evidence of the blob `pixels` (indices into a `w`-wide plane) of `frame`
/// against the platform `platform`, at foreground threshold `tau`.
///
/// Returns `None` when the blob holds no pixel beyond `tau` (no contrast to measure).
pub fn measure_polarity(
    frame: &[u8],
    platform: &[u8],
    w: usize,
    h: usize,
    pixels: &[usize],
    tau: u8,
) -> Option<PolarityEvidence> {
    let (up, down) = contrast_sums(frame, platform, pixels)?;
    if up + down <= 0.0 || w == 0 || h == 0 {
        return None;
    }
    let brighter_share = up / (up + down);
    let brighter = brighter_share >= 0.5;
    // The majority sign's pixels, and the minority's, within the blob's bounding box (plus a
    // one-pixel margin of "outside" for the fill).
    let (x0, y0, x1, y1) = pixels.iter().fold((usize::MAX, usize::MAX, 0, 0), |(a, b, c, d), &i| {
        (a.min(i % w), b.min(i / w), c.max(i % w), d.max(i / w))
    });
    let (bw, bh) = (x1 - x0 + 3, y1 - y0 + 3);
    let mut major = vec![false; bw * bh];
    let mut minor = Vec::new();
    let t = f64::from(tau);
    for &i in pixels {
        let d = f64::from(frame[i]) - f64::from(platform[i]);
        let j = (i / w - y0 + 1) * bw + (i % w - x0 + 1);
        let signed = if brighter { d } else { -d };
        if signed > t {
            major[j] = true;
        } else if signed < -t {
            minor.push(j);
        }
    }
    // Everything the outside reaches without crossing the majority sign; the rest is its
    // filled extent.
    let mut outside = vec![false; bw * bh];
    let mut queue = VecDeque::from([0usize]);
    outside[0] = true;
    while let Some(j) = queue.pop_front() {
        let (x, y) = (j % bw, j / bw);
        let mut visit = |nx: usize, ny: usize| {
            let k = ny * bw + nx;
            if !outside[k] && !major[k] {
                outside[k] = true;
                queue.push_back(k);
            }
        };
        if x > 0 {
            visit(x - 1, y);
        }
        if x + 1 < bw {
            visit(x + 1, y);
        }
        if y > 0 {
            visit(x, y - 1);
        }
        if y + 1 < bh {
            visit(x, y + 1);
        }
    }
    let beside = minor.iter().filter(|&&j| outside[j]).count();
    // The extent's boundary pixels: inside, with a 4-neighbour outside.
    let outline = (0..bw * bh)
        .filter(|&j| !outside[j])
        .filter(|&j| {
            let (x, y) = (j % bw, j / bw);
            (x > 0 && outside[j - 1])
                || (x + 1 < bw && outside[j + 1])
                || (y > 0 && outside[j - bw])
                || (y + 1 < bh && outside[j + bw])
        })
        .count();
    let polarity = if beside > outline {
        if brighter {
            Polarity::Brighter
        } else {
            Polarity::Darker
        }
    } else {
        Polarity::Either
    };
    Some(PolarityEvidence {
        brighter_share,
        beside,
        outline,
        polarity,
    })
}

/// The blob's contrast above the platform and below it: `Σ max(I − B, 0)` and
/// `Σ max(B − I, 0)` over `pixels` (`None` for an index outside either plane).
fn contrast_sums(frame: &[u8], platform: &[u8], pixels: &[usize]) -> Option<(f64, f64)> {
    let (mut up, mut down) = (0f64, 0f64);
    for &i in pixels {
        let d = f64::from(*frame.get(i)?) - f64::from(*platform.get(i)?);
        if d > 0.0 {
            up += d;
        } else {
            down -= d;
        }
    }
    Some((up, down))
}

/// How far inside and outside a pixel on the taught blob's outline [`half_contrast_silhouette`]
/// looks for the part's and the platform's levels, px: the half-length of the profiles along
/// which detection finds the part's sub-pixel border (`RefineParams::DEFAULT.search`).
pub const LOCAL_REACH: usize = 3;

/// The taught silhouette of the blob `pixels` (indices into a `w×h` plane), cut where detection
/// puts the part's border: a blob pixel within 2 px of the blob's outer outline or a hole's
/// stays part only where its difference from the platform, of the part's sign (`polarity`'s,
/// or for `Either` the sign of most of the blob's difference), reaches the midpoint between
/// the part's level and the platform's nearby: the medians of the difference over the blob's
/// pixels further inside and over the pixels outside the blob within [`LOCAL_REACH`] px. That
/// is the level at which detection's edge profiles cross (the midpoint of their ends, 3 px
/// inside and outside), so a part whose contrast varies (a screw's bright head and its shaded
/// shank, a shadow beside it) is cut where detection will see it. A pixel with no inside
/// pixels that near (a thin part) uses half the median difference over the whole inside.
/// Returns a `w×h` 0/1 plane; a blob too thin to have an inside is kept as it is.
pub fn half_contrast_silhouette(
    frame: &[u8],
    platform: &[u8],
    w: usize,
    h: usize,
    pixels: &[usize],
    polarity: Polarity,
) -> Vec<u8> {
    let mut plane = vec![0u8; w * h];
    for &i in pixels {
        if i < plane.len() {
            plane[i] = 1;
        }
    }
    let signed = |i: usize| match (frame.get(i), platform.get(i)) {
        (Some(&f), Some(&b)) => i32::from(f) - i32::from(b),
        _ => 0,
    };
    let sign = match polarity {
        Polarity::Brighter => 1,
        Polarity::Darker => -1,
        // The sign that holds most of the contrast, as measure_polarity takes it.
        Polarity::Either => match contrast_sums(frame, platform, pixels) {
            Some((up, down)) if up < down => -1,
            _ => 1,
        },
    };
    let value = |i: usize| sign * signed(i);
    // Distance (in 8-neighbour steps, up to 3) of each blob pixel from the nearest non-blob
    // pixel: 1 on the outline.
    let mut depth = vec![0u8; w * h];
    for &i in pixels {
        if i < depth.len() {
            depth[i] = u8::MAX;
        }
    }
    for level in 1..=3u8 {
        for &i in pixels {
            if i >= depth.len() || depth[i] != u8::MAX {
                continue;
            }
            let (x, y) = (i % w, i / w);
            let edge = (-1i64..=1).any(|dy| {
                (-1i64..=1).any(|dx| {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        return level == 1;
                    }
                    let d = depth[ny as usize * w + nx as usize];
                    d < level
                })
            });
            if edge {
                depth[i] = level;
            }
        }
    }
    let mut inside: Vec<i32> = pixels
        .iter()
        .filter(|&&i| i < depth.len() && depth[i] == u8::MAX)
        .map(|&i| value(i))
        .collect();
    if inside.is_empty() {
        return plane;
    }
    let fallback = median(&mut inside) / 2;
    let (mut near_in, mut near_out) = (Vec::new(), Vec::new());
    // (The levels read `depth` and the images only: each pixel is cut where it is decided.)
    for &i in pixels {
        if i >= depth.len() || depth[i] > 2 {
            continue;
        }
        let (x, y) = (i % w, i / w);
        near_in.clear();
        near_out.clear();
        for ny in y.saturating_sub(LOCAL_REACH)..(y + LOCAL_REACH + 1).min(h) {
            for nx in x.saturating_sub(LOCAL_REACH)..(x + LOCAL_REACH + 1).min(w) {
                let j = ny * w + nx;
                match depth[j] {
                    0 => near_out.push(value(j)),
                    u8::MAX => near_in.push(value(j)),
                    _ => {}
                }
            }
        }
        let level = if near_in.is_empty() {
            fallback
        } else {
            // (No platform pixel that near: the platform's own level, 0.)
            (median(&mut near_in) + median(&mut near_out)) / 2
        };
        if value(i) < level {
            plane[i] = 0;
        }
    }
    plane
}

/// The median of `values` (the upper one of an even count; reorders them), 0 for none.
fn median(values: &mut [i32]) -> i32 {
    let mid = values.len() / 2;
    if values.is_empty() {
        0
    } else {
        *values.select_nth_unstable(mid).1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w×h` platform at 100 with a bright 20×10 bar, optionally a dark shadow band below
    /// it (`shadow` rows) and a dark 4×4 bore inside it; the blob is every pixel beyond τ.
    fn scene(shadow: usize, bore: bool) -> (Vec<u8>, Vec<u8>, Vec<usize>, usize, usize) {
        let (w, h) = (40, 30);
        let platform = vec![100u8; w * h];
        let mut frame = platform.clone();
        for y in 10..20 {
            for x in 10..30 {
                frame[y * w + x] = 190;
            }
        }
        for y in 20..20 + shadow {
            for x in 12..32 {
                frame[y * w + x] = 60;
            }
        }
        if bore {
            for y in 13..17 {
                for x in 18..22 {
                    frame[y * w + x] = 40;
                }
            }
        }
        let pixels: Vec<usize> = (0..w * h).filter(|&i| frame[i].abs_diff(platform[i]) > 15).collect();
        (frame, platform, pixels, w, h)
    }

    #[test]
    fn a_shadow_beside_a_bright_part_makes_it_brighter() {
        let (f, p, px, w, h) = scene(4, true);
        let e = measure_polarity(&f, &p, w, h, &px, 15).unwrap();
        assert_eq!(e.polarity, Polarity::Brighter, "{e:?}");
        assert!(e.beside >= 80 && e.brighter_share > 0.5, "{e:?}");
        assert!(e.describe().starts_with("polarity: brighter"));
    }

    #[test]
    fn a_dark_bore_inside_is_no_shadow_and_a_clean_part_stays_either() {
        let (f, p, px, w, h) = scene(0, true);
        let e = measure_polarity(&f, &p, w, h, &px, 15).unwrap();
        assert_eq!(e.polarity, Polarity::Either, "{e:?}");
        assert_eq!(e.beside, 0);
        // A one-pixel dark seam along the outline is edge noise, not a shadow.
        let (f, p, px, w, h) = scene(1, false);
        let e = measure_polarity(&f, &p, w, h, &px, 15).unwrap();
        assert_eq!(e.polarity, Polarity::Either, "{e:?}");
    }

    #[test]
    fn the_silhouette_is_cut_at_half_contrast_along_the_outline_only() {
        // A dark 20×20 square (level 20: a contrast of 200) on a platform at 220, its edge
        // blurred: a ring at 100 (a difference of 120, above half the contrast) around it and one
        // at 190 (a difference of 30: above τ = 15, below half) around that; a 2×2 spot at 200
        // (a difference of 20) in the middle.
        let (w, h) = (40, 40);
        let platform = vec![220u8; w * h];
        let mut frame = platform.clone();
        for y in 8..32 {
            for x in 8..32 {
                let r = (x - 8).min(31 - x).min(y - 8).min(31 - y);
                frame[y * w + x] = match r {
                    0 => 190,
                    1 => 100,
                    _ => 20,
                };
            }
        }
        for y in 19..21 {
            for x in 19..21 {
                frame[y * w + x] = 200;
            }
        }
        let px: Vec<usize> = (0..w * h).filter(|&i| frame[i].abs_diff(platform[i]) > 15).collect();
        assert_eq!(px.len(), 24 * 24);
        let sil = half_contrast_silhouette(&frame, &platform, w, h, &px, Polarity::Either);
        let on: usize = sil.iter().map(|&v| v as usize).sum();
        // The outer ring goes; the inner one and the faint spot inside stay.
        assert_eq!(on, 22 * 22);
        assert_eq!(sil[8 * w + 8], 0);
        assert_eq!(sil[9 * w + 9], 1);
        assert_eq!(sil[19 * w + 19], 1);
    }

    #[test]
    fn the_cut_follows_the_local_contrast_along_a_part() {
        // A bright bar on a platform at 50, rows 10..26: its left half at a difference of 200
        // (its outermost rows at 130), its right half shaded to 60 (outermost rows at 40); a
        // blurred ring outside it at 30 beside the left half and 20 beside the right (above
        // τ = 15). Where detection's profiles cross: half of 200 on the left, half of 60 on the
        // right.
        let (w, h) = (80, 36);
        let platform = vec![50u8; w * h];
        let mut frame = platform.clone();
        for y in 9..27 {
            for x in 4..76 {
                let left = x < 40;
                let ring = y == 9 || y == 26 || x == 4 || x == 75;
                let outer = y == 10 || y == 25 || x == 5 || x == 74;
                let d = match (ring, outer, left) {
                    (true, _, true) => 30,
                    (true, _, false) => 20,
                    (false, true, true) => 130,
                    (false, true, false) => 40,
                    (false, false, true) => 200,
                    (false, false, false) => 60,
                };
                frame[y * w + x] = 50 + d;
            }
        }
        let px: Vec<usize> = (0..w * h).filter(|&i| frame[i].abs_diff(platform[i]) > 15).collect();
        let sil = half_contrast_silhouette(&frame, &platform, w, h, &px, Polarity::Brighter);
        let column = |x: usize| (0..h).filter(|&y| sil[y * w + x] == 1).collect::<Vec<_>>();
        // Both halves keep the bar's 16 rows and lose the ring: the shaded half's outermost
        // rows (40, above its half of 60) stay, which half of the whole part's median
        // contrast would have cut.
        assert_eq!(column(20), (10..26).collect::<Vec<_>>());
        assert_eq!(column(60), (10..26).collect::<Vec<_>>());
    }

    #[test]
    fn a_dark_part_with_a_bright_halo_is_darker_and_no_contrast_is_none() {
        let (w, h) = (30, 30);
        let platform = vec![150u8; w * h];
        let mut frame = platform.clone();
        for y in 5..25 {
            for x in 5..25 {
                let halo = !(8..22).contains(&x) || !(8..22).contains(&y);
                frame[y * w + x] = if halo { 200 } else { 20 };
            }
        }
        let px: Vec<usize> = (0..w * h).filter(|&i| frame[i].abs_diff(platform[i]) > 15).collect();
        let e = measure_polarity(&frame, &platform, w, h, &px, 15).unwrap();
        assert_eq!(e.polarity, Polarity::Darker, "{e:?}");
        assert!(measure_polarity(&platform, &platform, w, h, &px, 15).is_none());
    }
}
