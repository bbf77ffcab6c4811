//! Property tests of the core: invariances of the matching and pose, and no panics on any input.

use proptest::prelude::*;
use vorl_core::pixels::background::Background;
use vorl_core::pose::angle_signed;
use vorl_core::shape::descriptor::{describe, DescriptorParams};
use vorl_core::shape::matching::{best_cost, match_with_assignment, table_cells};
use vorl_core::{Frame, Params, Recognizer};
use vorl_tests::{angle_diff, rasterise, shapes};

type Rec = Recognizer<4, 256, 8192, 32, 16384>;

const W: usize = 240;
const H: usize = 240;
const PLATFORM: u8 = 120;
const PART: u8 = 40;

/// A recognizer taught the shape `shape` at angle 0, scale 1, and a flat background.
fn taught(shape: usize) -> (Box<Rec>, Background<Vec<u8>>) {
    taught_with(shape, Params::DEFAULT)
}

/// The paper's path: decision by `f' < ε` (the verification stage penalises a scale far from 1
/// on purpose, so the scale properties of the paper's `f'` are tested without it).
fn paper_params() -> Params {
    Params {
        refine: vorl_core::Refine::Off,
        ..Params::DEFAULT
    }
}

fn taught_with(shape: usize, params: Params) -> (Box<Rec>, Background<Vec<u8>>) {
    let s = &shapes()[shape];
    let tpl = rasterise(&s.posed(0.0, 1.0, 120.0, 120.0), W, H, 255, 0);
    let mut rec: Box<Rec> = Box::default();
    rec.set_params(params).unwrap();
    let mut labels = vec![0u8; W * H];
    rec.teach(&Frame::new_checked(&tpl[..], W, H).unwrap(), &mut labels)
        .unwrap();
    let bg_px = vec![PLATFORM; W * H];
    let mut bg = Background::new(vec![0u8; W * H], W, H).unwrap();
    bg.set_from_frame(&Frame::new_checked(&bg_px[..], W, H).unwrap(), Params::DEFAULT.alpha())
        .unwrap();
    (rec, bg)
}

fn detect_one(rec: &mut Rec, bg: &Background<Vec<u8>>, scene: &[u8]) -> vorl_core::Detection {
    let mut labels = vec![0u8; W * H];
    let report = rec
        .process(&Frame::new_checked(scene, W, H).unwrap(), bg, &mut labels)
        .unwrap();
    assert_eq!(
        report.detections.len(),
        1,
        "expected one part, got {:?}",
        report.detections
    );
    report.detections[0]
}

/// A random star-shaped polygon around the origin: `k` vertices with radii in [20, 60].
fn star_polygon() -> impl Strategy<Value = Vec<[f32; 2]>> {
    prop::collection::vec(20.0f32..60.0, 12..40).prop_map(|radii| {
        let k = radii.len();
        radii
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let t = i as f32 / k as f32 * std::f32::consts::TAU;
                [r * t.cos(), r * t.sin()]
            })
            .collect()
    })
}

/// Resamples a polygon (as border points with float coordinates) to `count` points.
fn polygon_points(poly: &[[f32; 2]], count: usize) -> Vec<[f32; 2]> {
    let n = poly.len();
    let per = count / n + 1;
    let mut dense = Vec::new();
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        for s in 0..per {
            let t = s as f32 / per as f32;
            dense.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }
    (0..count).map(|i| dense[i * dense.len() / count]).collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]

    /// A contour matched with itself costs 0 and gives angle 0.
    #[test]
    fn self_match_is_free_and_unrotated(poly in star_polygon(), n in 16usize..96) {
        let pts = polygon_points(&poly, n);
        let mut desc = vec![0.0f32; n];
        let c = describe(&pts, DescriptorParams { k: 3, omega: 0.5 }, &mut desc).unwrap();
        let mut table = vec![0.0f32; table_cells(n, n)];
        let mut assignment = vec![0u16; n];
        let m = match_with_assignment(&desc, &desc, &mut table, &mut assignment).unwrap();
        prop_assert_eq!(m.cost, 0.0);
        let a = angle_signed(&pts, c, &pts, c, &assignment).unwrap();
        prop_assert!(angle_diff(a as f64, 0.0) < 1e-3, "angle {a}");
    }

    /// Shifting the template's start point (a cyclic rotation of its points) changes neither the
    /// optimal cost nor the angle.
    #[test]
    fn template_start_shift_changes_nothing(poly in star_polygon(), shift in 0usize..96, rot in 0.0f32..360.0) {
        let (n, m) = (48usize, 72usize);
        let tpl = polygon_points(&poly, m);
        let (s, c) = rot.to_radians().sin_cos();
        let turned: Vec<[f32; 2]> = poly.iter().map(|p| [p[0] * c + p[1] * s, -p[0] * s + p[1] * c]).collect();
        let part = polygon_points(&turned, n);
        let p = DescriptorParams { k: 3, omega: 0.5 };
        let tp = DescriptorParams { k: vorl_core::shape::descriptor::scaled_k(3, n, m), omega: 0.5 };
        let mut pd = vec![0.0f32; n];
        let pc = describe(&part, p, &mut pd).unwrap();
        let run = |tpl: &[[f32; 2]]| {
            let mut td = vec![0.0f32; m];
            let tc = describe(tpl, tp, &mut td).unwrap();
            let mut table = vec![0.0f32; table_cells(n, m)];
            let mut asg = vec![0u16; n];
            let r = match_with_assignment(&pd, &td, &mut table, &mut asg).unwrap();
            (r.cost, angle_signed(&part, pc, tpl, tc, &asg).unwrap())
        };
        let (c0, a0) = run(&tpl);
        let shifted: Vec<[f32; 2]> = (0..m).map(|i| tpl[(i + shift) % m]).collect();
        let (c1, a1) = run(&shifted);
        prop_assert!((c0 - c1).abs() <= 1e-4 * c0.max(1.0), "cost {c0} vs {c1}");
        prop_assert!(angle_diff(a0 as f64, a1 as f64) < 0.05, "angle {a0} vs {a1}");
    }

    /// The best cost with a bound equals the unbounded best whenever it beats the bound (the
    /// pruning is exact).
    #[test]
    fn pruning_is_exact(part in prop::collection::vec(0.0f32..2.0, 8..24), extra in 0usize..8, seed in any::<u64>(), bound in 0.0f32..20.0) {
        let n = part.len();
        let m = n + extra.min(n - 1);
        let mut x = seed | 1;
        let tpl: Vec<f32> = (0..m).map(|_| { x ^= x << 13; x ^= x >> 7; x ^= x << 17; (x % 2000) as f32 / 1000.0 }).collect();
        // With a search-sized buffer (the divide-and-conquer search and its interval bounds).
        let mut row = vec![0.0f32; vorl_core::shape::matching::search_cells(n, m).max(m - n + 1)];
        let free = best_cost(&part, &tpl, f32::INFINITY, &mut row).unwrap().unwrap();
        let bounded = best_cost(&part, &tpl, bound, &mut row).unwrap();
        if free.cost < bound {
            prop_assert_eq!(bounded.map(|b| b.cost), Some(free.cost));
        } else {
            prop_assert!(bounded.is_none());
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, .. ProptestConfig::default() })]

    /// A part turned by any angle and drawn again is found at that angle (within 1°) with f' far
    /// below ε.
    #[test]
    fn rotation_is_recovered(shape in 0usize..3, angle in 0.0f64..360.0, dx in -8.0f64..8.0, dy in -8.0f64..8.0) {
        let (mut rec, bg) = taught(shape);
        let poly = shapes()[shape].posed(angle, 1.0, 120.0 + dx, 120.0 + dy);
        let scene = rasterise(&poly, W, H, PART, PLATFORM);
        let d = detect_one(&mut rec, &bg, &scene);
        prop_assert_eq!(d.template, Some(0));
        prop_assert!(d.score < 0.5 * Params::DEFAULT.epsilon, "f' {} not far below ε", d.score);
        let err = angle_diff(d.angle_deg as f64, angle);
        prop_assert!(err < 1.0, "angle {} vs truth {angle}: error {err}", d.angle_deg);
    }

    /// Scaling the part by 0.5×–2× keeps f' below ε.
    #[test]
    fn scale_keeps_score_below_epsilon(shape in 0usize..3, scale in 0.5f64..1.45, angle in 0.0f64..360.0) {
        let (mut rec, bg) = taught_with(shape, paper_params());
        let poly = shapes()[shape].posed(angle, scale, 120.0, 120.0);
        let scene = rasterise(&poly, W, H, PART, PLATFORM);
        let d = detect_one(&mut rec, &bg, &scene);
        prop_assert!(d.score < Params::DEFAULT.epsilon, "scale {scale}: f' {}", d.score);
        prop_assert_eq!(d.template, Some(0));
    }
}

/// Scaling up to 2× needs a larger frame than the proptest above uses.
#[test]
fn double_scale_keeps_score_below_epsilon() {
    const BIG: usize = 320;
    for (i, s) in shapes().iter().enumerate() {
        let tpl = rasterise(&s.posed(0.0, 1.0, 160.0, 160.0), BIG, BIG, 255, 0);
        let mut rec: Box<Rec> = Box::default();
        rec.set_params(paper_params()).unwrap();
        let mut labels = vec![0u8; BIG * BIG];
        rec.teach(&Frame::new_checked(&tpl[..], BIG, BIG).unwrap(), &mut labels)
            .unwrap();
        let bg_px = vec![PLATFORM; BIG * BIG];
        let mut bg = Background::new(vec![0u8; BIG * BIG], BIG, BIG).unwrap();
        bg.set_from_frame(
            &Frame::new_checked(&bg_px[..], BIG, BIG).unwrap(),
            Params::DEFAULT.alpha(),
        )
        .unwrap();
        for angle in [0.0, 77.0, 211.0] {
            let scene = rasterise(&s.posed(angle, 2.0, 160.0, 160.0), BIG, BIG, PART, PLATFORM);
            let report = rec
                .process(&Frame::new_checked(&scene[..], BIG, BIG).unwrap(), &bg, &mut labels)
                .unwrap();
            let d = report.detections[0];
            assert!(
                d.score < Params::DEFAULT.epsilon,
                "shape {i} at 2×, {angle}°: f' {}",
                d.score
            );
            assert_eq!(d.template, Some(0));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, .. ProptestConfig::default() })]

    /// Random bytes of any size, with a background of any size: an error or a report, never a
    /// panic.
    #[test]
    fn no_input_panics(
        w in 0usize..40, h in 0usize..40, bw in 0usize..40, bh in 0usize..40,
        bytes in prop::collection::vec(any::<u8>(), 0..1600),
        bg_bytes in prop::collection::vec(any::<u8>(), 0..1600),
        otsu in any::<bool>(), alpha in 0.0f32..=1.0, stride_extra in 0usize..3,
    ) {
        let mut rec: Box<Rec> = Box::default();
        let mut p = Params::DEFAULT;
        p.alpha = alpha;
        p.min_points = 1;
        p.min_area = 0.0;
        if otsu { p.threshold = vorl_core::pixels::mask::Threshold::Otsu; }
        rec.set_params(p).unwrap();
        // Teach from random bytes too (may fail with an error, must not panic).
        let mut labels = vec![0u8; w * h + 7];
        if let Ok(f) = Frame::new_checked(&bytes[..], w, h) {
            let _ = rec.teach(&f, &mut labels);
        }
        let mut bg = match Background::new(vec![0u8; bw * bh], bw, bh) {
            Ok(b) => b,
            Err(_) => return Ok(()),
        };
        let mut high = vec![0u8; bw * bh];
        if let Ok(bf) = Frame::new_checked(&bg_bytes[..], bw, bh) {
            let _ = bg.learn(&bf, p.alpha(), &mut high);
            let _ = bg.finish_learning(&high);
        }
        if let Ok(f) = Frame::with_stride(&bytes[..], w, h, w + stride_extra) {
            let _ = rec.process(&f, &bg, &mut labels);
            let mut short = vec![0u8; (w * h) / 2];
            let _ = rec.process(&f, &bg, &mut short);
        }
    }

    /// Random 0/1 planes: border following never panics and every stored point is foreground.
    #[test]
    fn border_points_lie_on_foreground(w in 1usize..30, h in 1usize..30, bits in prop::collection::vec(any::<bool>(), 900)) {
        use vorl_core::borders::contour::{trace_borders, BorderFilter, ContourStore};
        let mut plane: Vec<u8> = bits.iter().take(w * h).map(|&b| b as u8).collect();
        plane.resize(w * h, 0);
        let orig = plane.clone();
        let mut store = Box::new(ContourStore::<256, 16>::new());
        trace_borders(&mut plane, w, h, BorderFilter { min_points: 1, min_area: 0.0 }, &mut store).unwrap();
        for i in 0..store.contours().len() {
            for p in store.points(i) {
                prop_assert_eq!(orig[p.y as usize * w + p.x as usize], 1);
            }
        }
    }
}
