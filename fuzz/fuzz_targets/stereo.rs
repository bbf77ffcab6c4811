//! Stereo on any numbers: `StereoRig::new`, `depth`, `disparity`, `point`; `pair_parts` with any
//! parts (NaN and ∞ positions, any classes, more right parts than it takes, an output buffer
//! too short) and any `PairParams`; `refine_disparity` on two small images with any outline,
//! seed and `DisparityParams`.
//!
//! Input: the rig's four numbers and three queries, the pairing rules, the part counts and parts,
//! the disparity fit's parameters, seed and outline, then the two 40×32 images (a bright disc
//! shifted by the input's disparity where the bytes run out).
//!
//! Checked: a rig's results are finite; every pair is one of each side's parts at most once, at a
//! disparity in `(0, max_disparity_px]` that is `x_left − x_right`; the count returned is the
//! number of pairs written; a fit's disparity is finite.

#![no_main]

use libfuzzer_sys::fuzz_target;
use vorl_core::pixels::enhance::Alpha;
use vorl_core::pose::refine::Difference;
use vorl_core::location::stereo::{
    pair_parts, refine_disparity, DisparityParams, PairOutcome, PairParams, StereoPart, StereoRig, Unpaired,
};
use vorl_core::Frame;
use vorl_fuzz::Input;

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    // The rig.
    let (f, b, cx, cy) = (
        input.num_or(800.0),
        input.num_or(60.0),
        input.num_or(320.0),
        input.num_or(240.0),
    );
    let (q1, q2, q3) = (input.num(), input.num(), input.num());
    if let Ok(rig) = StereoRig::new(f, b, cx, cy) {
        if let Ok(z) = rig.depth(q1) {
            assert!(z.is_finite() && z > 0.0, "depth {z} of disparity {q1}");
        }
        if let Ok(d) = rig.disparity(q1) {
            assert!(d.is_finite() && d > 0.0, "disparity {d} of depth {q1}");
        }
        if let Ok(p) = rig.point(q2, q3, q1) {
            assert!(p.iter().all(|v| v.is_finite()), "point {p:?}");
        }
        let _ = (rig.f_px(), rig.baseline_mm(), rig.principal_point());
    }

    // Pairing.
    let params = PairParams {
        row_tolerance_px: input.num_or(2.0),
        max_disparity_px: input.num_or(256.0),
    };
    let nl = input.below(24);
    let nr = if input.flag() { input.below(24) } else { input.below(80) };
    let part = |input: &mut Input<'_>| {
        let class = match input.u8() % 4 {
            0 => None,
            c => Some(u16::from(c)),
        };
        let (x, y) = (f32::from(input.u8()), f32::from(input.u8() % 8));
        StereoPart {
            class,
            x: input.num_or(x),
            y: input.num_or(y),
            angle_deg: input.num(),
        }
    };
    let left: Vec<StereoPart> = (0..nl).map(|_| part(&mut input)).collect();
    let right: Vec<StereoPart> = (0..nr).map(|_| part(&mut input)).collect();
    let out_len = if input.u8() < 200 { nl } else { nl.saturating_sub(1) };
    let mut out = vec![PairOutcome::Unpaired(Unpaired::Taken); out_len];
    if let Ok(pairs) = pair_parts(&left, &right, &params, &mut out) {
        let mut used = vec![false; right.len()];
        let mut count = 0;
        for (l, o) in left.iter().zip(&out) {
            if let Some((r, d)) = o.paired() {
                assert!(r < right.len() && !used[r], "right part {r} paired once");
                used[r] = true;
                count += 1;
                assert!(d > 0.0 && d <= params.max_disparity_px, "disparity {d}");
                assert_eq!(d, l.x - right[r].x, "disparity is x_left − x_right");
                assert_eq!(l.class, right[r].class, "same class");
            }
        }
        assert_eq!(pairs, count, "pairs counted");
    }

    // The disparity fit.
    let dp = DisparityParams {
        search_px: input.num_or(3.0),
        step_px: input.num_or(0.25),
        min_contrast: input.num_or(8.0),
        window_px: input.num_or(1.0),
        iterations: input.count_or(8),
        normal_span: input.count_or(3),
        min_normal_x: input.num_or(0.25),
        max_residual_px: input.num_or(1.5),
        min_points: input.count_or(12),
        max_shift_px: input.num_or(3.0),
        tolerance_px: input.num_or(1e-4),
    };
    let _ = dp.validate();
    let shift = f32::from(input.u8() % 16) / 2.0;
    let seed = input.num_or(shift + 0.4);
    let points = input.below(64);
    let outline: Vec<[f32; 2]> = (0..points)
        .map(|k| {
            let a = k as f32 * core::f32::consts::TAU / points.max(1) as f32;
            if input.u8() < 200 {
                [20.0 + 7.5 * a.cos(), 16.0 + 7.5 * a.sin()]
            } else {
                [input.num(), input.num()]
            }
        })
        .collect();
    let (w, h) = (40usize, 32usize);
    let disc = |cx: f32| -> Vec<u8> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let r = ((x - cx).powi(2) + (y - 16.0).powi(2)).sqrt();
                (50.0 + 100.0 * (8.0 - r).clamp(0.0, 1.0)) as u8
            })
            .collect()
    };
    let mut left_px = disc(20.0);
    let right_px = disc(20.0 - shift);
    let bytes = input.bytes(w * h);
    left_px[..bytes.len()].copy_from_slice(bytes);
    let bg = vec![50u8; w * h];
    let (lf, rf) = (
        Frame::new_checked(&left_px[..], w, h).expect("w·h"),
        Frame::new_checked(&right_px[..], w, h).expect("w·h"),
    );
    let alpha = if input.flag() {
        Alpha::ONE
    } else {
        Alpha::new(0.5).expect("in range")
    };
    let (dl, dr) = (
        Difference::new(&lf, &bg, alpha),
        Difference::new(&rf, &bg[..w * h / 2], alpha),
    );
    if let Ok(fit) = refine_disparity(&dl, &dr, &outline, seed, &dp) {
        assert!(fit.disparity.is_finite(), "fit {fit:?}");
    }
    // Images of two sizes are an error.
    let small = Frame::new_checked(&right_px[..w * 2], w, 2).expect("two rows");
    let ds = Difference::new(&small, &bg, alpha);
    assert!(refine_disparity(&dl, &ds, &outline, seed, &DisparityParams::DEFAULT).is_err());
});
