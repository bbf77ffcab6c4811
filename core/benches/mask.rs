//! The foreground-mask stage alone (`|I' − B| > τ` and the 3×3 clean-up) on synthetic frames:
//! a platform with a gentle gradient and noise, and a few bright and dark blobs.
//!
//! `cargo bench -p vorl-core --bench mask`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use vorl_core::pixels::background::Background;
use vorl_core::pixels::enhance::Alpha;
use vorl_core::pixels::mask::{foreground_mask, Cleanup, Polarity, Threshold};
use vorl_core::Frame;

/// Hash noise in `0..=7`.
fn noise(i: usize, salt: u32) -> u8 {
    ((i as u32 ^ salt).wrapping_mul(2_654_435_761) >> 29) as u8
}

/// Background and frame of `w`×`h`: the frame is the platform with fresh noise and six
/// elliptic blobs (three bright, three dark), some touching the border.
fn scene(w: usize, h: usize) -> (Vec<u8>, Vec<u8>) {
    let platform = |i: usize, salt: u32| {
        let (x, y) = (i % w, i / w);
        (120 + x * 8 / w + y * 5 / h) as u8 + noise(i, salt)
    };
    let bg: Vec<u8> = (0..w * h).map(|i| platform(i, 0)).collect();
    let blobs = [
        (0.20, 0.25, 0.10, 0.14, 210u8),
        (0.55, 0.20, 0.16, 0.08, 40),
        (0.85, 0.30, 0.07, 0.12, 200),
        (0.30, 0.75, 0.12, 0.10, 45),
        (0.70, 0.70, 0.09, 0.16, 215),
        (0.02, 0.95, 0.08, 0.08, 35),
    ];
    let frame: Vec<u8> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32 / w as f32, (i / w) as f32 / h as f32);
            for &(cx, cy, rx, ry, v) in &blobs {
                let (dx, dy) = ((x - cx) / rx, (y - cy) / ry);
                if dx * dx + dy * dy <= 1.0 {
                    return v.wrapping_add(noise(i, 77));
                }
            }
            platform(i, 0x5bd1_e995)
        })
        .collect();
    (bg, frame)
}

fn mask(c: &mut Criterion) {
    let mut g = c.benchmark_group("mask");
    for (w, h) in [(640usize, 480usize), (320, 240)] {
        let (bg_px, frame_px) = scene(w, h);
        let mut bg = Background::new(vec![0u8; w * h], w, h).expect("background");
        bg.set_from_frame(&Frame::new_checked(&bg_px[..], w, h).expect("frame"), Alpha::ONE)
            .expect("bg");
        let frame = Frame::new_checked(&frame_px[..], w, h).expect("frame");
        let mut labels = vec![0u8; w * h];
        g.throughput(Throughput::Elements((w * h) as u64));
        for (name, threshold, cleanup) in [
            ("fixed15_open", Threshold::Fixed(15), Cleanup::Open),
            ("otsu_openclose", Threshold::Otsu, Cleanup::OpenClose),
        ] {
            let stats = foreground_mask(
                &frame,
                &bg,
                Alpha::ONE,
                threshold,
                Polarity::Either,
                cleanup,
                &mut labels,
            )
            .expect("mask");
            assert!(stats.foreground > w * h / 20, "bench scene must show its blobs");
            g.bench_function(format!("{w}x{h}_{name}"), |b| {
                b.iter(|| {
                    foreground_mask(
                        black_box(&frame),
                        &bg,
                        Alpha::ONE,
                        threshold,
                        Polarity::Either,
                        cleanup,
                        &mut labels,
                    )
                    .expect("mask")
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, mask);
criterion_main!(benches);
