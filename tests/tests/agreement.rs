//! The core against the independent std reference (`vorl_host_sim::reference`) on random blob
//! images: background, mask, borders point for point, resampling, descriptors, DP costs (1e-3
//! relative), decisions, both angle estimators (0.1°) and centroids.

use image::GrayImage;
use proptest::prelude::*;
use vorl_core::pixels::mask::Threshold;
use vorl_core::Params;
use vorl_host_sim::compare::{compare_frame, Comparison, Tolerances};
use vorl_tests::rasterise;

const W: usize = 200;
const H: usize = 160;

fn star(radii: &[f64], cx: f64, cy: f64, turn: f64) -> Vec<(f64, f64)> {
    let k = radii.len();
    radii
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let t = turn + i as f64 / k as f64 * std::f64::consts::TAU;
            (cx + r * t.cos(), cy - r * t.sin())
        })
        .collect()
}

fn gray(px: Vec<u8>, w: usize, h: usize) -> GrayImage {
    GrayImage::from_raw(w as u32, h as u32, px).unwrap()
}

/// A platform with a little hashed noise (deterministic per seed).
fn platform(seed: u32) -> Vec<u8> {
    (0..W * H)
        .map(|i| {
            let v = (i as u32 ^ seed).wrapping_mul(2_654_435_761) >> 30;
            118 + v as u8
        })
        .collect()
}

fn blob() -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(10.0f64..30.0, 6..14)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, .. ProptestConfig::default() })]

    #[test]
    fn core_and_reference_agree(
        blobs in prop::collection::vec((blob(), 0.0f64..6.3, any::<bool>()), 1..4),
        otsu in any::<bool>(),
        alpha_low in any::<bool>(),
        seed in any::<u32>(),
    ) {
        let mut params = Params::DEFAULT;
        params.threshold = if otsu { Threshold::Otsu } else { Threshold::Fixed(30) };
        params.alpha = if alpha_low { 0.75 } else { 1.0 };
        // Parts on a 2×2 grid of cells so they never touch.
        let mut scene = platform(seed);
        let mut templates = Vec::new();
        for (i, (radii, turn, dark)) in blobs.iter().enumerate() {
            let (cx, cy) = (50.0 + 100.0 * (i % 2) as f64, 40.0 + 80.0 * (i / 2) as f64);
            let poly = star(radii, cx, cy, *turn);
            let v = if *dark { 40 } else { 220 };
            let part = rasterise(&poly, W, H, 1, 0);
            for (s, p) in scene.iter_mut().zip(&part) {
                if *p == 1 { *s = v; }
            }
            let tpl = rasterise(&star(radii, 60.0, 60.0, 0.0), 120, 120, 255, 0);
            templates.push(gray(tpl, 120, 120));
        }
        let backgrounds = vec![gray(platform(seed), W, H), gray(platform(seed.wrapping_add(7)), W, H)];
        let mut out = Comparison::default();
        let tol = Tolerances { pixels: if alpha_low { 2 } else { 0 }, ..Tolerances::default() };
        compare_frame("scene", &gray(scene, W, H), &backgrounds, &templates, &params, &tol, &mut out).unwrap();
        prop_assert!(out.disagreements.is_empty(), "{:#?}", out.disagreements);
        prop_assert!(out.borders >= blobs.len());
        prop_assert_eq!(out.matches, blobs.len() * blobs.len());
    }
}
