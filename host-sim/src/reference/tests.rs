//! Unit tests of the reference pipeline: hand-checked borders, DP against brute force,
//! descriptor and angle properties, imageproc cross-checks and an end-to-end run.

use image::{GrayImage, Luma};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use super::imaging::{dilate, erode};
use super::*;

/// A mask of the given size with the listed pixels at 255.
fn mask_from(w: u32, h: u32, on: impl Fn(u32, u32) -> bool) -> GrayImage {
    GrayImage::from_fn(w, h, |x, y| Luma([if on(x, y) { 255 } else { 0 }]))
}

// ---------------------------------------------------------------- §4 borders, by hand

#[test]
fn border_of_3x3_square() {
    let mask = mask_from(5, 5, |x, y| (1..=3).contains(&x) && (1..=3).contains(&y));
    let b = borders(&mask);
    assert_eq!(b.len(), 1);
    // Start (1,1); second point by the clockwise search from W is E (2,1), which closes the
    // list; the counter-clockwise tracing goes down the left side first.
    let expected = vec![(1, 1), (1, 2), (1, 3), (2, 3), (3, 3), (3, 2), (3, 1), (2, 1)];
    assert_eq!(b[0].points, expected);
    assert!(!b[0].is_hole);
    assert_eq!(b[0].parent, None);
    assert_eq!(polygon_area(&b[0].points), 4.0);
}

#[test]
fn border_of_square_touching_the_image_edge() {
    // The padding makes an outer border start at x = 0.
    let mask = mask_from(3, 3, |_, _| true);
    let b = borders(&mask);
    assert_eq!(b.len(), 1);
    let expected = vec![(0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (2, 1), (2, 0), (1, 0)];
    assert_eq!(b[0].points, expected);
    assert!(!b[0].is_hole);
    assert_eq!(b[0].parent, None);
}

#[test]
fn one_pixel_image() {
    let on = mask_from(1, 1, |_, _| true);
    assert_eq!(
        borders(&on),
        vec![RefBorder {
            points: vec![(0, 0)],
            is_hole: false,
            parent: None
        }]
    );
    let off = mask_from(1, 1, |_, _| false);
    assert!(borders(&off).is_empty());
    assert!(borders(&GrayImage::new(0, 0)).is_empty());
}

#[test]
fn ring_with_a_one_pixel_hole() {
    // 5×5 block at (1..=5, 1..=5) with the pixel (3,3) cleared.
    let mask = mask_from(7, 7, |x, y| {
        (1..=5).contains(&x) && (1..=5).contains(&y) && (x, y) != (3, 3)
    });
    let b = borders(&mask);
    assert_eq!(b.len(), 2);

    let outer = vec![
        (1, 1),
        (1, 2),
        (1, 3),
        (1, 4),
        (1, 5),
        (2, 5),
        (3, 5),
        (4, 5),
        (5, 5),
        (5, 4),
        (5, 3),
        (5, 2),
        (5, 1),
        (4, 1),
        (3, 1),
        (2, 1),
    ];
    assert_eq!(b[0].points, outer);
    assert!(!b[0].is_hole);
    assert_eq!(b[0].parent, None);

    // The hole border starts at (2,3), whose right neighbour is the hole; the clockwise search
    // from E finds SE (3,4) first, which closes the list.
    assert_eq!(b[1].points, vec![(2, 3), (3, 2), (4, 3), (3, 4)]);
    assert!(b[1].is_hole);
    assert_eq!(b[1].parent, Some(0));
    assert_eq!(polygon_area(&b[1].points), 2.0);

    // Position: outer area 16 centred (3,3) minus the hole diamond (area 2) centred (3,3).
    let c = area_centroid(&b[0].points, &[&b[1].points]).unwrap();
    assert!((c.0 - 3.0).abs() < 1e-12 && (c.1 - 3.0).abs() < 1e-12);
}

#[test]
fn blob_inside_a_hole_has_the_hole_as_parent() {
    // 7×7 block with a 3×3 hole and a single pixel in the middle of the hole.
    let mask = mask_from(9, 9, |x, y| {
        let block = (1..=7).contains(&x) && (1..=7).contains(&y);
        let hole = (3..=5).contains(&x) && (3..=5).contains(&y);
        (block && !hole) || (x, y) == (4, 4)
    });
    let b = borders(&mask);
    assert_eq!(b.len(), 3);
    assert!(!b[0].is_hole && b[0].parent.is_none());
    assert!(b[1].is_hole && b[1].parent == Some(0));
    assert!(!b[2].is_hole && b[2].parent == Some(1));
    assert_eq!(b[2].points, vec![(4, 4)]);
    // The hole border runs round the 3×3 hole through the eight pixels around it.
    let mut hole_pixels = b[1].points.clone();
    hole_pixels.sort_unstable();
    hole_pixels.dedup();
    assert_eq!(hole_pixels.len(), 12);
    assert!(hole_pixels
        .iter()
        .all(|&(x, y)| (2..=6).contains(&x) && (2..=6).contains(&y)));
}

// ---------------------------------------------------------------- §7 DP against brute force

/// Checks that `a` is a cyclic order-preserving injective assignment into `0..m`.
fn assert_cyclic_order_preserving(a: &[usize], m: usize) {
    let offsets: Vec<usize> = a.iter().map(|&j| (j + m - a[0]) % m).collect();
    assert!(a.iter().all(|&j| j < m));
    assert!(offsets.windows(2).all(|w| w[0] < w[1]), "{a:?} (m = {m})");
}

#[test]
fn dp_equals_brute_force_on_random_inputs() {
    let mut rng = Pcg64::seed_from_u64(0x5eed_0001);
    let mut cases = 0;
    for trial in 0..3000 {
        let n = rng.random_range(1..=7usize);
        // n ≤ m < 2n and m ≤ 10 (the spec's range); every fourth trial any n ≤ m ≤ 10.
        let m_max = if trial % 4 == 3 { 10 } else { (2 * n - 1).min(10) };
        let m = rng.random_range(n..=m_max);
        // Quantised values in some trials, to produce ties.
        let quantised = trial % 3 == 0;
        let mut value = || {
            let v: f64 = rng.random_range(0.0..2.0);
            if quantised {
                (v * 4.0).floor() / 4.0
            } else {
                v
            }
        };
        let part: Vec<f64> = (0..n).map(|_| value()).collect();
        let template: Vec<f64> = (0..m).map(|_| value()).collect();

        let dp = cyclic_dp(&part, &template).unwrap();
        let bf = brute_force_cyclic(&part, &template).unwrap();
        assert!(
            (dp.cost - bf).abs() <= 1e-12 * (1.0 + bf),
            "n {n} m {m}: dp {} bf {bf}",
            dp.cost
        );
        assert!((dp.normalized - dp.cost / n as f64).abs() < 1e-15);
        assert_eq!(dp.assignment.len(), n);
        assert_cyclic_order_preserving(&dp.assignment, m);
        let total: f64 = (0..n).map(|i| (part[i] - template[dp.assignment[i]]).abs()).sum();
        assert!((total - dp.cost).abs() <= 1e-12 * (1.0 + total));
        cases += 1;
    }
    assert_eq!(cases, 3000);
}

#[test]
fn dp_finds_a_rotated_copy() {
    // The part is the template read from index 3, with two template points dropped.
    let template = [0.9, 1.4, 0.2, 1.1, 0.7, 1.8, 0.5, 1.0];
    let part = [1.1, 0.7, 0.5, 1.0, 0.9, 1.4];
    let dp = cyclic_dp(&part, &template).unwrap();
    assert_eq!(dp.cost, 0.0);
    assert_eq!(dp.assignment, vec![3, 4, 6, 7, 0, 1]);
}

#[test]
fn dp_and_brute_force_reject_bad_input() {
    assert!(cyclic_dp(&[], &[1.0]).is_err());
    assert!(cyclic_dp(&[1.0, 2.0], &[1.0]).is_err());
    assert!(cyclic_dp(&[f64::NAN], &[1.0]).is_err());
    assert!(brute_force_cyclic(&[1.0; 20], &[1.0; 40]).is_err());
    assert_eq!(brute_force_cyclic(&[1.0], &[3.0, 1.5]).unwrap(), 0.5);
}

// ---------------------------------------------------------------- §5, §6

fn circle(count: usize, radius: f64, centre: (f64, f64)) -> Vec<(f64, f64)> {
    (0..count)
        .map(|i| {
            let t = i as f64 / count as f64 * std::f64::consts::TAU;
            (centre.0 + radius * t.cos(), centre.1 + radius * t.sin())
        })
        .collect()
}

#[test]
fn resample_walks_the_closed_polygon() {
    // Square of side 4: perimeter 16; 8 points every 2 units from (0,0).
    let square = [(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)];
    let q = resample(&square, 8).unwrap();
    let expected = [
        (0.0, 0.0),
        (2.0, 0.0),
        (4.0, 0.0),
        (4.0, 2.0),
        (4.0, 4.0),
        (2.0, 4.0),
        (0.0, 4.0),
        (0.0, 2.0),
    ];
    for (a, b) in q.iter().zip(expected) {
        assert!((a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12, "{q:?}");
    }
    // Two points: the closing edge counts, perimeter 2·5 = 10, 4 points every 2.5.
    let q = resample(&[(0.0, 0.0), (3.0, 4.0)], 4).unwrap();
    assert!((q[1].0 - 1.5).abs() < 1e-12 && (q[1].1 - 2.0).abs() < 1e-12);
    assert!((q[2].0 - 3.0).abs() < 1e-12 && (q[2].1 - 4.0).abs() < 1e-12);
    assert!((q[3].0 - 1.5).abs() < 1e-12 && (q[3].1 - 2.0).abs() < 1e-12);
    // Degenerate.
    assert_eq!(resample(&[(1.0, 1.0)], 4), Err(RefError::ZeroPerimeter));
    assert_eq!(resample(&[], 4), Err(RefError::Empty));
    assert_eq!(resample(&square, 0), Err(RefError::Empty));
}

#[test]
fn descriptor_of_a_circle_is_constant() {
    let q = resample(&circle(300, 50.0, (80.0, 60.0)), 64).unwrap();
    let c = descriptor(&q, 4, 0.5).unwrap();
    assert_eq!(c.len(), 64);
    for v in &c {
        assert!((v - 1.0).abs() < 1e-4, "{c:?}");
    }
}

#[test]
fn descriptor_of_a_rasterised_disk_is_near_constant() {
    let mask = mask_from(120, 120, |x, y| {
        let (dx, dy) = (f64::from(x) - 60.0, f64::from(y) - 60.0);
        dx * dx + dy * dy <= 40.0 * 40.0
    });
    let b = borders(&mask);
    assert_eq!(b.len(), 1);
    let pts: Vec<(f64, f64)> = b[0].points.iter().map(|&(x, y)| (f64::from(x), f64::from(y))).collect();
    let q = resample(&pts, 64).unwrap();
    let c = descriptor(&q, 4, 0.5).unwrap();
    for v in &c {
        assert!((v - 1.0).abs() < 0.02, "{c:?}");
    }
}

#[test]
fn descriptor_guards() {
    assert_eq!(descriptor(&[(2.0, 2.0), (2.0, 2.0)], 1, 0.5), Err(RefError::Degenerate));
    assert!(descriptor(&[(0.0, 0.0), (1.0, 0.0)], 0, 0.5).is_err());
    assert_eq!(descriptor(&[], 1, 0.5), Err(RefError::Empty));
    // Regular octagon with k = 1: q_{i−1} and q_{i+1} are 90° apart about the centre, so
    // cos = 0 everywhere → A is guarded to ±0.05, a_i = 0, d_i = 1: c_i = 1 − ω.
    let octagon = circle(8, 3.0, (1.0, 2.0));
    let c = descriptor(&octagon, 1, 0.25).unwrap();
    for v in c {
        assert!((v - 0.75).abs() < 1e-12, "{v}");
    }
    // Square with k = 1: the neighbours of a corner are opposite each other, cos = −1 = A.
    let square = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
    let c = descriptor(&square, 1, 0.25).unwrap();
    for v in c {
        assert!((v - 1.0).abs() < 1e-12, "{v}");
    }
    // k wraps cyclically: k = 5 on 4 points is k = 1.
    assert_eq!(descriptor(&square, 5, 0.25), descriptor(&square, 1, 0.25));
}

// ---------------------------------------------------------------- §8 angles

/// Rotates `(x, y)` about `centre` by θ degrees counter-clockwise on screen, then shifts it
/// (spec, Conventions: `(dx·cosθ + dy·sinθ, −dx·sinθ + dy·cosθ)`).
fn rotate_screen_ccw(p: (f64, f64), centre: (f64, f64), deg: f64, shift: (f64, f64)) -> (f64, f64) {
    let (s, c) = deg.to_radians().sin_cos();
    let (dx, dy) = (p.0 - centre.0, p.1 - centre.1);
    (
        centre.0 + dx * c + dy * s + shift.0,
        centre.1 - dx * s + dy * c + shift.1,
    )
}

/// An asymmetric L-shaped polygon (relative to the origin).
const L_SHAPE: [(f64, f64); 6] = [
    (-30.0, -20.0),
    (30.0, -20.0),
    (30.0, 0.0),
    (0.0, 0.0),
    (0.0, 25.0),
    (-30.0, 25.0),
];

#[test]
fn signed_angle_recovers_known_rotations() {
    let template = resample(&L_SHAPE, 96).unwrap();
    let identity: Vec<usize> = (0..template.len()).collect();
    for deg in [0.0, 10.0, 30.0, 89.5, 90.0, 135.25, 180.0, 200.0, 270.0, 333.0, 359.0] {
        let part: Vec<(f64, f64)> = template
            .iter()
            .map(|&p| rotate_screen_ccw(p, (0.0, 0.0), deg, (150.0, 90.0)))
            .collect();
        let got = angle_signed(&part, &template, &identity);
        assert!((0.0..360.0).contains(&got));
        let err = (got - deg).rem_euclid(360.0);
        let err = err.min(360.0 - err);
        assert!(err < 1e-9, "rotated by {deg}, got {got}");
    }
    // 90° counter-clockwise on screen takes the +x axis to −y (up).
    let part = [(0.0, -1.0), (1.0, 0.0), (0.0, 1.0), (-1.0, 0.0)];
    let template = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)];
    let got = angle_signed(&part, &template, &[0, 1, 2, 3]);
    assert!((got - 90.0).abs() < 1e-9, "{got}");
}

#[test]
fn paper_angle_is_unsigned() {
    let template = resample(&L_SHAPE, 96).unwrap();
    let identity: Vec<usize> = (0..template.len()).collect();
    let rotated = |deg: f64| -> Vec<(f64, f64)> {
        template
            .iter()
            .map(|&p| rotate_screen_ccw(p, (0.0, 0.0), deg, (-7.0, 3.0)))
            .collect()
    };
    for deg in [5.0, 30.0, 90.0, 120.0, 179.0] {
        let a = angle_paper(&rotated(deg), &template, &identity);
        let b = angle_paper(&rotated(360.0 - deg), &template, &identity);
        assert!((a - b).abs() < 1e-9, "{deg}: {a} vs {b}");
        assert!((a - deg).abs() < 1e-6, "{deg}: {a}");
        // The signed estimator tells them apart.
        let s = angle_signed(&rotated(360.0 - deg), &template, &identity);
        assert!((s - (360.0 - deg)).abs() < 1e-9);
    }
    assert_eq!(angle_paper(&[], &[], &[]), 0.0);
    assert_eq!(angle_signed(&[(1.0, 1.0)], &[(0.0, 0.0)], &[5]), 0.0);
}

// ---------------------------------------------------------------- §1–§3 imaging

#[test]
fn enhance_by_hand() {
    let flat = GrayImage::from_pixel(4, 3, Luma([77]));
    assert_eq!(enhance(&flat, 1.0), flat);
    // Gradient 0 everywhere: I' = round(0.5·77) = round(38.5) = 39 (half away from zero).
    assert!(enhance(&flat, 0.5).pixels().all(|p| p.0[0] == 39));
    // Vertical step 0 | 255 between x = 1 and x = 2: next to the step gx = 4·255,
    // g / (4√2) = 255/√2 = 180.3 → 180; far from it (replicated borders) 0.
    let step = GrayImage::from_fn(4, 3, |x, _| Luma([if x >= 2 { 255 } else { 0 }]));
    let e = enhance(&step, 0.0);
    for y in 0..3 {
        let row: Vec<u8> = (0..4).map(|x| e.get_pixel(x, y).0[0]).collect();
        assert_eq!(row, vec![0, 180, 180, 0]);
    }
}

#[test]
fn background_mean_by_hand() {
    let a = GrayImage::from_pixel(2, 2, Luma([10]));
    let b = GrayImage::from_pixel(2, 2, Luma([11]));
    // (10 + 11 + 1) / 2 = 11
    let bg = learn_background(&[a.clone(), b.clone()], 1.0).unwrap();
    assert!(bg.pixels().all(|p| p.0[0] == 11));
    // (0 + 0 + 1 + 1) / 3 = 0
    let z = GrayImage::from_pixel(2, 2, Luma([0]));
    let o = GrayImage::from_pixel(2, 2, Luma([1]));
    let bg = learn_background(&[z.clone(), z, o], 1.0).unwrap();
    assert!(bg.pixels().all(|p| p.0[0] == 0));
    assert_eq!(learn_background(&[], 1.0), Err(RefError::NoFrames));
    assert!(learn_background(&vec![a.clone(); 256], 1.0).is_err());
    assert!(learn_background(&[a, GrayImage::new(3, 2)], 1.0).is_err());
}

#[test]
fn otsu_by_hand() {
    assert_eq!(otsu(&GrayImage::from_pixel(5, 5, Luma([9]))), 0);
    assert_eq!(otsu(&GrayImage::new(0, 0)), 0);
    // Two values: every t in 10..200 splits them the same way; the first is 10.
    let two = GrayImage::from_fn(10, 10, |x, _| Luma([if x < 5 { 10 } else { 200 }]));
    assert_eq!(otsu(&two), 10);
}

#[test]
fn otsu_agrees_with_imageproc_on_random_histograms() {
    let mut rng = Pcg64::seed_from_u64(0x0750);
    for _ in 0..200 {
        let (lo, hi) = (rng.random_range(0..120u8), rng.random_range(100..=255u8));
        let spread = rng.random_range(1..40u8);
        let img = GrayImage::from_fn(40, 30, |_, _| {
            let centre = if rng.random_bool(0.6) { lo } else { hi };
            let jitter = rng.random_range(0..spread);
            Luma([centre.saturating_add(jitter)])
        });
        assert_eq!(otsu(&img), imageproc::contrast::otsu_level(&img));
    }
}

#[test]
fn morphology_agrees_with_imageproc_linf() {
    use imageproc::distance_transform::Norm;
    let mut rng = Pcg64::seed_from_u64(0x3030);
    for trial in 0..100 {
        let w = rng.random_range(1..20u32);
        let h = rng.random_range(1..20u32);
        let density = if trial % 2 == 0 { 0.5 } else { 0.9 };
        let img = GrayImage::from_fn(w, h, |_, _| Luma([if rng.random_bool(density) { 255 } else { 0 }]));
        let fg: Vec<bool> = img.as_raw().iter().map(|&v| v != 0).collect();
        let (wu, hu) = (w as usize, h as usize);
        let as_bool = |g: &GrayImage| -> Vec<bool> { g.as_raw().iter().map(|&v| v != 0).collect() };
        assert_eq!(
            erode(&fg, wu, hu),
            as_bool(&imageproc::morphology::erode(&img, Norm::LInf, 1)),
            "erode {w}x{h}"
        );
        assert_eq!(
            dilate(&fg, wu, hu),
            as_bool(&imageproc::morphology::dilate(&img, Norm::LInf, 1)),
            "dilate {w}x{h}"
        );
    }
}

#[test]
fn mask_clean_up_removes_specks_and_keeps_edges() {
    let bg = GrayImage::from_pixel(12, 10, Luma([40]));
    // A block touching the left edge plus an isolated speck.
    let frame = GrayImage::from_fn(12, 10, |x, y| {
        let block = x <= 4 && (2..=7).contains(&y);
        Luma([if block || (x, y) == (9, 1) { 200 } else { 40 }])
    });
    let raw = foreground_mask(
        &frame,
        &bg,
        RefThreshold::Fixed(30),
        RefPolarity::Either,
        RefCleanup::Off,
    )
    .unwrap();
    assert_eq!(raw.get_pixel(9, 1).0[0], 255);
    let clean = foreground_mask(
        &frame,
        &bg,
        RefThreshold::Fixed(30),
        RefPolarity::Either,
        RefCleanup::OpenClose,
    )
    .unwrap();
    assert_eq!(clean.get_pixel(9, 1).0[0], 0);
    for y in 0..10 {
        for x in 0..12 {
            let block = x <= 4 && (2..=7).contains(&y);
            assert_eq!(clean.get_pixel(x, y).0[0] == 255, block, "({x},{y})");
        }
    }
    let otsu_mask = foreground_mask(&frame, &bg, RefThreshold::Otsu, RefPolarity::Either, RefCleanup::Off).unwrap();
    assert_eq!(otsu_mask, raw);
    assert!(foreground_mask(
        &frame,
        &GrayImage::new(3, 3),
        RefThreshold::Otsu,
        RefPolarity::Either,
        RefCleanup::OpenClose
    )
    .is_err());
}

// ---------------------------------------------------------------- §9 and the whole pipeline

/// Even-odd point-in-polygon test.
fn inside(poly: &[(f64, f64)], p: (f64, f64)) -> bool {
    let mut result = false;
    let mut j = poly.len() - 1;
    for i in 0..poly.len() {
        let (xi, yi) = poly[i];
        let (xj, yj) = poly[j];
        if (yi > p.1) != (yj > p.1) && p.0 < (xj - xi) * (p.1 - yi) / (yj - yi) + xi {
            result = !result;
        }
        j = i;
    }
    result
}

/// Draws `poly` rotated by `deg` (screen CCW) about the origin and placed at `centre`.
fn draw(w: u32, h: u32, poly: &[(f64, f64)], centre: (f64, f64), deg: f64, fg: u8, bg: u8) -> GrayImage {
    GrayImage::from_fn(w, h, |x, y| {
        // Inverse rotation (by −deg) of the offset from the centre.
        let back = rotate_screen_ccw(
            (f64::from(x) - centre.0, f64::from(y) - centre.1),
            (0.0, 0.0),
            -deg,
            (0.0, 0.0),
        );
        Luma([if inside(poly, back) { fg } else { bg }])
    })
}

#[test]
fn pipeline_finds_a_rotated_part() {
    let params = RefParams::default();
    let ring: Vec<(f64, f64)> = circle(64, 28.0, (0.0, 0.0));
    let templates = vec![
        template_from_silhouette(&draw(100, 100, &ring, (50.0, 50.0), 0.0, 255, 0), &params).unwrap(),
        template_from_silhouette(&draw(100, 100, &L_SHAPE, (50.0, 50.0), 0.0, 255, 0), &params).unwrap(),
    ];
    assert_eq!(templates[1].points.len(), params.m);
    assert_eq!(templates[1].descriptor.len(), params.m);

    let background = learn_background(&vec![GrayImage::from_pixel(200, 160, Luma([40])); 3], params.alpha).unwrap();
    // Area centroid of the L polygon: (1200·(0, −10) + 750·(−15, 12.5)) / 1950.
    let l_centroid = (-15.0 * 750.0 / 1950.0, (-10.0 * 1200.0 + 12.5 * 750.0) / 1950.0);
    for deg in [0.0, 30.0, 145.0, 250.0] {
        let centre = (95.0, 80.0);
        let frame = draw(200, 160, &L_SHAPE, centre, deg, 200, 40);
        let found = detect(&frame, &background, &templates, &params).unwrap();
        assert_eq!(found.len(), 1, "{deg}");
        let d = &found[0];
        assert_eq!(d.template, Some(1), "{deg}: score {}", d.score);
        assert!(d.score < params.epsilon);
        let err = (d.angle_deg - deg).rem_euclid(360.0);
        assert!(err.min(360.0 - err) < 3.0, "{deg}: got {}", d.angle_deg);
        let unsigned = if deg > 180.0 { 360.0 - deg } else { deg };
        assert!(
            (d.angle_paper_deg - unsigned).abs() < 8.0,
            "{deg}: paper {}",
            d.angle_paper_deg
        );
        let expected = rotate_screen_ccw(l_centroid, (0.0, 0.0), deg, centre);
        assert!(
            (d.x - expected.0).abs() < 1.0 && (d.y - expected.1).abs() < 1.0,
            "{deg}: ({}, {}) vs {expected:?}",
            d.x,
            d.y
        );
        assert_eq!(d.border_index, 0);
    }

    // No templates: every part is reported as unknown.
    let frame = draw(200, 160, &L_SHAPE, (95.0, 80.0), 10.0, 200, 40);
    let found = detect(&frame, &background, &[], &params).unwrap();
    assert_eq!(found.len(), 1);
    assert_eq!(found[0].template, None);
    assert_eq!(found[0].score, f64::INFINITY);
}

#[test]
fn pipeline_position_subtracts_holes() {
    let params = RefParams::default();
    // A 40×30 block at x 10..50, y 20..50 with a 10×10 hole at x 15..25, y 25..35.
    let frame = GrayImage::from_fn(80, 70, |x, y| {
        let block = (10..50).contains(&x) && (20..50).contains(&y);
        let hole = (15..25).contains(&x) && (25..35).contains(&y);
        Luma([if block && !hole { 200 } else { 40 }])
    });
    let bg = GrayImage::from_pixel(80, 70, Luma([40]));
    let found = detect(&frame, &bg, &[], &params).unwrap();
    assert_eq!(found.len(), 1);
    // Pixel-centre polygons: outer (10,20)-(49,49), area 39·29; the hole border runs through
    // the pixels 4-adjacent to the hole, the square (14,24)-(25,35) without its corner pixels,
    // area 11·11 − 4·½, centred (19.5, 29.5).
    let a_o = 39.0 * 29.0;
    let a_h = 11.0 * 11.0 - 2.0;
    let x = (a_o * 29.5 - a_h * 19.5) / (a_o - a_h);
    let y = (a_o * 34.5 - a_h * 29.5) / (a_o - a_h);
    assert!((found[0].x - x).abs() < 1e-9 && (found[0].y - y).abs() < 1e-9);
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let params = RefParams::default();
    let img = GrayImage::new(10, 10);
    assert!(template_from_silhouette(&img, &params).is_err()); // no border
    assert!(template_from_silhouette(&GrayImage::new(0, 0), &params).is_err());
    let one = mask_from(5, 5, |x, y| (x, y) == (2, 2));
    assert_eq!(template_from_silhouette(&one, &params), Err(RefError::ZeroPerimeter));
    let bad = RefParams { m: 128, ..params };
    assert!(template_from_silhouette(&img, &bad).is_err());
    assert!(detect(&img, &img, &[], &bad).is_err());
    let bad_k = RefParams { k: 0, ..params };
    assert!(detect(&img, &img, &[], &bad_k).is_err());
    assert!(detect(&img, &GrayImage::new(4, 4), &[], &params).is_err());
    let short = RefTemplate {
        points: vec![(0.0, 0.0); 10],
        descriptor: vec![1.0; 10],
    };
    assert!(detect(&img, &img, &[short], &params).is_err());
    assert!(detect(&GrayImage::new(0, 0), &GrayImage::new(0, 0), &[], &params)
        .unwrap()
        .is_empty());
    assert_eq!(area_centroid(&[], &[]), None);
    assert_eq!(area_centroid(&[(1, 1), (5, 1)], &[]), None);
    assert_eq!(polygon_area(&[]), 0.0);
}

#[test]
fn template_neighbourhood_scales_with_m() {
    let p = RefParams::default();
    assert_eq!(p.k_template(), 6); // round(4·96/64) = 6
    let p = RefParams {
        n: 64,
        m: 70,
        k: 1,
        ..p
    };
    assert_eq!(p.k_template(), 1); // round(1.09) = 1
    let p = RefParams { n: 4, m: 6, k: 1, ..p };
    assert_eq!(p.k_template(), 2); // round(1.5) = 2, half away from zero
}
