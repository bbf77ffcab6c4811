//! Outlines and samplers that the benchmarks (`core/benches/`, through `#[path]`) and the unit
//! tests both draw, written once: a real part's outline rather than random numbers, because the
//! DP's pruning depends on the data.

#![allow(dead_code)]

extern crate std;
use std::vec;
use std::vec::Vec;
use vorl_core::shape::descriptor::{describe, scaled_k, DescriptorParams};

/// The outline of a wrench-like part (px), turned by `deg` counter-clockwise on screen.
pub fn outline(deg: f32) -> Vec<[f32; 2]> {
    let v: [[f32; 2]; 12] = [
        [-60.0, -8.0],
        [20.0, -8.0],
        [30.0, -22.0],
        [52.0, -22.0],
        [44.0, -8.0],
        [44.0, 8.0],
        [52.0, 22.0],
        [30.0, 22.0],
        [20.0, 8.0],
        [-60.0, 8.0],
        [-66.0, 0.0],
        [-64.0, -4.0],
    ];
    let (s, c) = deg.to_radians().sin_cos();
    v.iter().map(|p| [p[0] * c + p[1] * s, -p[0] * s + p[1] * c]).collect()
}

/// `count` points evenly spaced along a closed polygon, starting `offset` of a step in.
pub fn sample(poly: &[[f32; 2]], count: usize, offset: f32) -> Vec<[f32; 2]> {
    let n = poly.len();
    let seg = |i: usize| {
        let (a, b) = (poly[i % n], poly[(i + 1) % n]);
        ((b[0] - a[0]).hypot(b[1] - a[1]), a, b)
    };
    let perimeter: f32 = (0..n).map(|i| seg(i).0).sum();
    let step = perimeter / count as f32;
    (0..count)
        .map(|k| {
            let mut s = (k as f32 + offset) * step;
            let mut i = 0;
            loop {
                let (len, a, b) = seg(i);
                if s <= len || i >= 4 * n {
                    let t = if len > 0.0 { (s / len).min(1.0) } else { 0.0 };
                    return [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
                }
                s -= len;
                i += 1;
            }
        })
        .collect()
}

/// Part (`n` points of the outline turned `deg`, rotated by `shift` points) and template (`m`
/// points) descriptors, k = n/16, ω = 0.5. The benchmarks use `deg = 37`, `shift = 0`.
pub fn descriptors(n: usize, m: usize, deg: f32, shift: usize) -> (Vec<f32>, Vec<f32>) {
    let k = (n / 16).max(1);
    let mut part_pts = sample(&outline(deg), n, 0.3);
    part_pts.rotate_left(shift % n.max(1));
    let tpl_pts = sample(&outline(0.0), m, 0.0);
    let mut part = vec![0.0; n];
    let mut tpl = vec![0.0; m];
    describe(&part_pts, DescriptorParams { k, omega: 0.5 }, &mut part).expect("part descriptor");
    describe(
        &tpl_pts,
        DescriptorParams {
            k: scaled_k(k, n, m),
            omega: 0.5,
        },
        &mut tpl,
    )
    .expect("template descriptor");
    (part, tpl)
}
