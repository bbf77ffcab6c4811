//! The calibration fits and maps on any numbers: `Homography::fit`, `from_matrix`, `map`,
//! `map_angle`, `mirrored`; `RigidTransform::fit`, `from_parts`, `map`.
//!
//! Input: a choice byte, then point pairs: either any floats, or robot points made from the
//! pixels by a known map (exact pairs, the fits' normal case) with any floats mixed in, duplicated
//! and collinear points; then a 3×3 matrix, a rotation and translation, and probe points.
//!
//! Checked (the module's contract: never a panic and never a NaN in a result): a fitted or
//! given homography has finite entries and a finite residual; a map, when `Some`, is finite; an
//! angle is in `[0, 360)`; a fitted rigid transform is finite with a rotation of determinant
//! near +1.

#![no_main]

use libfuzzer_sys::fuzz_target;
use vorl_core::location::calibrate::{Homography, RigidTransform};
use vorl_fuzz::Input;

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    let choice = input.u8();
    let count = input.below(40);
    // A projective map for the exact pairs (mild: the fits' normal case).
    let (a, b, tx, ty, p, q) = (
        1.0 + f32::from(input.u8()) / 256.0,
        f32::from(input.u8() as i8) / 512.0,
        f32::from(input.u8()),
        f32::from(input.u8()),
        f32::from(input.u8() as i8) * 1e-5,
        f32::from(input.u8() as i8) * 1e-5,
    );
    let pairs2: Vec<([f32; 2], [f32; 2])> = (0..count)
        .map(|_| {
            let sel = input.u8();
            let px = if sel < 128 {
                [f32::from(input.u16() % 640), f32::from(input.u16() % 480)]
            } else {
                [input.num(), input.num()]
            };
            let robot = if choice & 1 == 0 && sel < 200 {
                let w = 1.0 + p * px[0] + q * px[1];
                [(a * px[0] + b * px[1] + tx) / w, (-b * px[0] + a * px[1] + ty) / w]
            } else {
                [input.num(), input.num()]
            };
            (px, robot)
        })
        .collect();
    if let Ok((h, rms)) = Homography::fit(&pairs2) {
        assert!(rms.is_finite(), "residual {rms}");
        check_homography(&h, &mut input);
    }
    let m = [
        [input.num_or(1.0), input.num_or(0.0), input.num_or(0.0)],
        [input.num_or(0.0), input.num_or(1.0), input.num_or(0.0)],
        [input.num_or(0.0), input.num_or(0.0), input.num_or(1.0)],
    ];
    if let Ok(h) = Homography::from_matrix(m) {
        check_homography(&h, &mut input);
    }

    // Rigid transforms: exact pairs under a rotation about z, or any floats.
    let (s, c) = (f32::from(input.u8()) / 40.0).sin_cos();
    let t = [input.num_or(10.0), input.num_or(-5.0), input.num_or(700.0)];
    let count3 = input.below(24);
    let pairs3: Vec<([f32; 3], [f32; 3])> = (0..count3)
        .map(|_| {
            let sel = input.u8();
            let cam = if sel < 128 {
                [f32::from(input.u8()), f32::from(input.u8()), f32::from(input.u8())]
            } else {
                [input.num(), input.num(), input.num()]
            };
            let robot = if choice & 2 == 0 && sel < 200 {
                [
                    c * cam[0] - s * cam[1] + t[0],
                    s * cam[0] + c * cam[1] + t[1],
                    cam[2] + t[2],
                ]
            } else {
                [input.num(), input.num(), input.num()]
            };
            (cam, robot)
        })
        .collect();
    if let Ok((r, rms)) = RigidTransform::fit(&pairs3) {
        assert!(rms.is_finite(), "residual {rms}");
        let rot = r.rotation();
        assert!(
            rot.iter().flatten().chain(&r.translation()).all(|v| v.is_finite()),
            "{r:?}"
        );
        let det = rot[0][0] * (rot[1][1] * rot[2][2] - rot[1][2] * rot[2][1])
            - rot[0][1] * (rot[1][0] * rot[2][2] - rot[1][2] * rot[2][0])
            + rot[0][2] * (rot[1][0] * rot[2][1] - rot[1][1] * rot[2][0]);
        assert!((det - 1.0).abs() < 1e-3, "rotation of determinant {det}");
        let _ = r.map([input.num(), input.num(), input.num()]);
    }
    let rotation = [
        [input.num_or(1.0), input.num_or(0.0), input.num_or(0.0)],
        [input.num_or(0.0), input.num_or(1.0), input.num_or(0.0)],
        [input.num_or(0.0), input.num_or(0.0), input.num_or(1.0)],
    ];
    if let Ok(r) = RigidTransform::from_parts(rotation, [input.num(), input.num(), input.num()]) {
        let _ = r.map([input.num(), input.num(), input.num()]);
    }
});

fn check_homography(h: &Homography, input: &mut Input<'_>) {
    assert!(h.matrix().iter().flatten().all(|v| v.is_finite()), "{h:?}");
    for _ in 0..4 {
        let at = [input.num_or(320.0), input.num_or(240.0)];
        if let Some(p) = h.map(at) {
            assert!(p.iter().all(|v| v.is_finite()), "map {at:?} -> {p:?}");
        }
        if let Some(a) = h.map_angle(at, input.num()) {
            assert!((0.0..360.0).contains(&a), "angle {a}");
        }
        let _ = h.mirrored(at);
    }
}
