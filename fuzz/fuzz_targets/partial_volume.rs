//! The partial-volume centroid on any box: `partial_volume::partial_volume_centroid` over any
//! frame, background (of any length), α, mask, seed and box (boxes narrower than the bit-row
//! path, as wide as it takes, wider; boxes past the image; seeds outside it).
//!
//! Input: width, height, α choice, mask choice, the box and seed, then the frame and background
//! planes (and, with the mask-bits choice, the mask one bit per pixel).
//!
//! Checked: the mask is the same 0/1 plane afterwards (the function's contract: scratch while it
//! runs, its 0/1 values again on return); a centroid is finite and lies in the image; the print
//! deficit (`print_deficit`) over any borders is finite and not negative.

#![no_main]

use libfuzzer_sys::fuzz_target;
use vorl_core::pixels::enhance::Alpha;
use vorl_core::borders::contour::Point;
use vorl_core::pose::partial_volume::{partial_volume_centroid, print_deficit, Rect};
use vorl_core::pose::refine::Difference;
use vorl_core::Frame;
use vorl_fuzz::Input;

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    let w = 1 + usize::from(input.u8()) % 200;
    let h = 1 + usize::from(input.u8()) % 96;
    let alpha = match input.u8() {
        0..=191 => Alpha::ONE,
        a => Alpha::new(f32::from(a - 192) / 64.0).unwrap_or(Alpha::ONE),
    };
    let mask_choice = input.u8();
    let tau = input.u8();
    let boxed = input.u8();
    let (bx0, by0, bx1, by1) = (input.count(), input.count(), input.count(), input.count());
    let (sx, sy) = (input.count(), input.count());
    let frame_px = input.plane(w * h);
    let bg_len = match mask_choice >> 4 {
        0 => w * h / 2,
        1 => 0,
        _ => w * h,
    };
    let bg = input.plane(bg_len);
    let bits = input.plane((w * h).div_ceil(8));
    let frame = Frame::new_checked(&frame_px[..], w, h).expect("w·h bytes");
    let diff = Difference::new(&frame, &bg, alpha);
    // The mask: the thresholded difference (as the recognizer's), or any bits.
    let mut mask: Vec<u8> = if mask_choice & 1 == 0 {
        (0..w * h)
            .map(|i| u8::from(frame_px[i].abs_diff(bg.get(i).copied().unwrap_or(0)) > tau))
            .collect()
    } else {
        (0..w * h).map(|i| (bits[i / 8] >> (i % 8)) & 1).collect()
    };
    // The box and seed: the mask's own (as the recognizer passes a border's), or any.
    let (bbox, seed) = if boxed < 128 {
        let Some(first) = mask.iter().position(|&v| v == 1) else {
            return;
        };
        let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
        for (i, &v) in mask.iter().enumerate() {
            if v == 1 {
                let (x, y) = (i % w, i / w);
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
            }
        }
        (Rect { x0, y0, x1, y1 }, (first % w, first / w))
    } else {
        (
            Rect {
                x0: bx0,
                y0: by0,
                x1: bx1,
                y1: by1,
            },
            (sx, sy),
        )
    };
    let before = mask.clone();
    let c = partial_volume_centroid(&diff, &mut mask, seed, bbox);
    assert_eq!(mask, before, "the mask holds its 0/1 values again");
    if let Some([x, y]) = c {
        assert!(x.is_finite() && y.is_finite(), "centroid {c:?}");
        assert!(
            x >= -0.5 && y >= -0.5 && x <= w as f32 - 0.5 && y <= h as f32 - 0.5,
            "centroid {c:?} in {w}×{h}"
        );
    }
    // Print deficits over any borders, on the 0/1 mask: finite, not negative.
    let n = usize::from(input.u8()) % 48;
    let pts: Vec<Point> = (0..n)
        .map(|_| Point {
            x: u16::from(input.u8()),
            y: u16::from(input.u8()),
        })
        .collect();
    let (a, b) = pts.split_at(pts.len() / 2);
    let contrast = f32::from(input.u8()) - 128.0;
    let [m, mx, my] = print_deficit(&diff, &before, contrast, [a, b].into_iter(), [b].into_iter());
    assert!(m.is_finite() && mx.is_finite() && my.is_finite() && m >= 0.0, "{m} {mx} {my}");
    // A short mask is refused without touching it.
    let mut short = before[..before.len() / 2].to_vec();
    let copy = short.clone();
    assert!(partial_volume_centroid(&diff, &mut short, seed, bbox).is_none());
    assert_eq!(short, copy);
});
