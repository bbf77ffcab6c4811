//! The whole pipeline on a 640×480 frame with several parts: mask, borders, descriptors, DP
//! against every template, pose.
//!
//! `cargo bench -p vorl-core --bench pipeline`

#[path = "../src/test_support.rs"]
mod common;

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use vorl_core::pixels::background::Background;
use vorl_core::{Frame, Params, Recognizer};

const W: usize = 640;
const H: usize = 480;

type Rec = Recognizer<32, 128, 16384, 128, 8192>;

fn inside(poly: &[[f32; 2]], x: f32, y: f32) -> bool {
    let mut c = false;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        if (a[1] > y) != (b[1] > y) && x < a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0]) {
            c = !c;
        }
    }
    c
}

fn draw(img: &mut [u8], poly: &[[f32; 2]], cx: f32, cy: f32, v: u8) {
    for y in 0..H {
        for x in 0..W {
            if inside(poly, x as f32 - cx, y as f32 - cy) {
                img[y * W + x] = v;
            }
        }
    }
}

/// A platform with a gentle gradient and hash noise.
fn platform() -> Vec<u8> {
    (0..W * H)
        .map(|i| {
            let (x, y) = (i % W, i / W);
            let h = (i as u32).wrapping_mul(2_654_435_761) >> 29;
            (120 + x / 64 + y / 96) as u8 + h as u8
        })
        .collect()
}

fn pipeline(c: &mut Criterion) {
    let params = Params::DEFAULT;
    // Templates: the wrench and three stretched variants (different classes).
    let mut rec: Box<Rec> = Box::default();
    rec.set_params(params).expect("params");
    let mut labels = vec![0u8; W * H];
    for stretch in [1.0f32, 1.4, 0.7, 1.8] {
        let poly: Vec<[f32; 2]> = common::outline(0.0).iter().map(|p| [p[0], p[1] * stretch]).collect();
        let mut sil = vec![0u8; W * H];
        draw(&mut sil, &poly, 320.0, 240.0, 255);
        rec.teach(&Frame::new_checked(&sil[..], W, H).expect("frame"), &mut labels)
            .expect("teach");
    }
    let bg_px = platform();
    let mut bg = Background::new(vec![0u8; W * H], W, H).expect("background");
    bg.set_from_frame(&Frame::new_checked(&bg_px[..], W, H).expect("frame"), params.alpha())
        .expect("bg");
    // Six parts at different poses.
    let mut scene = bg_px.clone();
    for (i, (cx, cy, a, s)) in [
        (120.0, 110.0, 20.0, 1.0),
        (330.0, 100.0, 95.0, 1.4),
        (520.0, 120.0, 200.0, 0.7),
        (130.0, 340.0, 300.0, 1.8),
        (340.0, 350.0, 45.0, 1.0),
        (530.0, 360.0, 160.0, 1.4),
    ]
    .into_iter()
    .enumerate()
    {
        let poly: Vec<[f32; 2]> = common::outline(0.0)
            .iter()
            .map(|p| [p[0], p[1] * s])
            .map(|p| {
                let (sn, cs) = (a as f32).to_radians().sin_cos();
                [p[0] * cs + p[1] * sn, -p[0] * sn + p[1] * cs]
            })
            .collect();
        draw(&mut scene, &poly, cx, cy, if i % 2 == 0 { 40 } else { 210 });
    }
    let frame = Frame::new_checked(&scene[..], W, H).expect("frame");
    let report = rec.process(&frame, &bg, &mut labels).expect("process");
    assert_eq!(report.detections.len(), 6, "bench scene must show its six parts");
    let mut g = c.benchmark_group("pipeline");
    g.sample_size(20);
    g.bench_function("640x480_6_parts_4_templates", |b| {
        b.iter(|| rec.process(black_box(&frame), &bg, &mut labels).expect("process"))
    });
    g.finish();
}

/// A star-like outline with `lobes` lobes of depth `depth`, about 50 px in radius: distinct
/// template shapes for the template-count sweep.
fn lobed(lobes: usize, depth: f32, twist: f32) -> Vec<[f32; 2]> {
    (0..96)
        .map(|i| {
            let t = i as f32 / 96.0 * std::f32::consts::TAU;
            let r = 45.0 * (1.0 + depth * (lobes as f32 * t).sin() + 0.12 * (t + twist).cos());
            [r * t.cos(), r * t.sin()]
        })
        .collect()
}

/// Frame time against the number of parts (1, 4, 8) and templates (4, 12, 32): the DP's
/// early rejection should make the cost grow gently with the library.
fn template_sweep(c: &mut Criterion) {
    type Big = Recognizer<32, 128, 16384, 128, 8192>;
    let shapes: Vec<Vec<[f32; 2]>> = (0..32)
        .map(|i| lobed(3 + i % 8, 0.08 + 0.03 * (i / 8) as f32, i as f32 * 0.7))
        .collect();
    let bg_px = platform();
    let mut bg = Background::new(vec![0u8; W * H], W, H).expect("background");
    bg.set_from_frame(
        &Frame::new_checked(&bg_px[..], W, H).expect("frame"),
        Params::DEFAULT.alpha(),
    )
    .expect("bg");
    let mut labels = vec![0u8; W * H];
    let mut g = c.benchmark_group("frame");
    g.sample_size(10);
    for templates in [4usize, 12, 32] {
        let mut rec: Box<Big> = Box::default();
        rec.set_params(Params::DEFAULT).expect("params");
        for shape in shapes.iter().take(templates) {
            let mut sil = vec![0u8; W * H];
            draw(&mut sil, shape, 320.0, 240.0, 255);
            rec.teach(&Frame::new_checked(&sil[..], W, H).expect("frame"), &mut labels)
                .expect("teach");
        }
        for parts in [1usize, 4, 8] {
            let mut scene = bg_px.clone();
            for k in 0..parts {
                let (cx, cy) = (80.0 + 160.0 * (k % 4) as f32, 120.0 + 240.0 * (k / 4) as f32);
                let a = (37.0 * k as f32 + 11.0).to_radians();
                let (sn, cs) = a.sin_cos();
                let poly: Vec<[f32; 2]> = shapes[k % templates]
                    .iter()
                    .map(|p| [p[0] * cs + p[1] * sn, -p[0] * sn + p[1] * cs])
                    .collect();
                draw(&mut scene, &poly, cx, cy, if k % 2 == 0 { 40 } else { 210 });
            }
            let frame = Frame::new_checked(&scene[..], W, H).expect("frame");
            let report = rec.process(&frame, &bg, &mut labels).expect("process");
            assert_eq!(report.detections.len(), parts, "sweep scene must show its parts");
            g.bench_function(format!("{parts}_parts_{templates}_templates"), |b| {
                b.iter(|| rec.process(black_box(&frame), &bg, &mut labels).expect("process"))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, pipeline, template_sweep);
criterion_main!(benches);
