//! The per-border stages on any points: `resample::resample`, `descriptor::describe` (any `k`
//! and `ω`), `pose::area_centroid`, the three angle estimators on any correspondence,
//! `Template::from_border`, `from_parts` and `set_edge`, and the refine stage on a small image:
//! `refine::align` from any seed pose, `outward_normal`, `Outline::capped_distance`,
//! `Difference::bilinear`, `edge_offset`, `edge_finder`, `ProfileRay` and `sample_by_pixels`
//! with any `RefineParams`.
//!
//! Input: choices, a border of up to 300 points (resampled to up to 512) (coordinates below 256), a hole, counts, any
//! floats for the descriptor parameters, the poses, the refine parameters and probe points, then a
//! 48×40 frame over a flat background.
//!
//! Checked: a resampled border has finite points; a described one finite values; an angle is
//! finite; an alignment's pose and distance are not NaN.

#![no_main]

use libfuzzer_sys::fuzz_target;
use vorl_core::borders::contour::Point;
use vorl_core::shape::descriptor::{centroid, describe, scaled_k, DescriptorParams};
use vorl_core::pixels::enhance::Alpha;
use vorl_core::pose::{angle_paper, angle_signed, angle_signed_refined, area_centroid};
use vorl_core::pose::refine::{align, outward_normal, sample_by_pixels, Difference, Outline, Pose, ProfileRay, RefineParams};
use vorl_core::borders::resample::{check_counts, resample};
use vorl_core::{Frame, Params, Template};
use vorl_fuzz::{params, Input};

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    let len = input.below(300);
    let border: Vec<Point> = (0..len)
        .map(|_| Point {
            x: u16::from(input.u8()),
            y: u16::from(input.u8()),
        })
        .collect();
    let hole_len = input.below(40);
    let hole: Vec<Point> = (0..hole_len)
        .map(|_| Point {
            x: u16::from(input.u8()),
            y: u16::from(input.u8()),
        })
        .collect();
    let count = if input.flag() {
        1 + input.below(128)
    } else {
        input.count().min(512)
    };
    let dp = DescriptorParams {
        k: input.count(),
        omega: input.num_or(0.5),
    };
    let p = if input.flag() {
        Params::DEFAULT
    } else {
        params(&mut input)
    };

    let _ = area_centroid(&border, [&hole[..]].into_iter());
    let mut pts = vec![[0.0f32; 2]; count];
    if resample(&border, &mut pts).is_ok() {
        assert!(pts.iter().flatten().all(|v| v.is_finite()), "resampled points");
    }
    let mut desc = vec![0.0f32; count];
    if let Ok(c) = describe(&pts, dp, &mut desc) {
        assert!(c.iter().all(|v| v.is_finite()), "centroid {c:?}");
        assert!(desc.iter().all(|v| v.is_finite()), "descriptor {desc:?}");
    }
    let _ = describe(&pts, dp, &mut desc[..count / 2]);
    let _ = centroid(&pts);
    let _ = scaled_k(input.count(), input.count(), input.count());
    let _ = check_counts(input.count(), input.count());
    let _ = p.validate();
    let _ = p.descriptor(input.count());

    // Templates from the border, from parts, with any edge.
    if let Ok(t) = Template::<128>::from_border(&border, [&hole[..]].into_iter(), &p) {
        assert!(t.descriptor().iter().all(|v| v.is_finite()));
        assert!(
            t.sorted_descriptor().windows(2).all(|w| w[0] <= w[1]),
            "sorted descriptor"
        );
    }
    let m = pts.len().min(desc.len());
    if let Ok(mut t) = Template::<128>::from_parts(pts.iter().copied(), desc.iter().copied(), [0.0; 2], [0.0; 2], 1.0) {
        let edge: Vec<[f32; 2]> = (0..m).map(|_| [input.num(), input.num()]).collect();
        let _ = t.set_edge(&edge, &edge, [input.num(), input.num()]);
        let _ = t.set_edge(&edge[..m / 2], &edge, [0.0, 0.0]);
    }

    // Angles from a correspondence of any indices.
    let assignment: Vec<u16> = (0..pts.len()).map(|_| input.u16() % 300).collect();
    let (pc, tc) = ([input.num(), input.num()], [input.num(), input.num()]);
    for angle in [
        angle_paper(&pts, pc, &pts, tc, &assignment),
        angle_signed(&pts, pc, &pts, tc, &assignment),
        angle_signed_refined(&pts, pc, &pts, tc, &assignment),
    ]
    .into_iter()
    .flatten()
    {
        assert!(angle.is_finite(), "angle {angle}");
    }

    // The refine stage on a 48×40 frame: a bright square (or the input's bytes) on grey 100.
    let (w, h) = (48, 40);
    let mut frame_px = vec![100u8; w * h];
    let bytes = input.bytes(w * h);
    if bytes.len() == w * h {
        frame_px.copy_from_slice(bytes);
    } else {
        for y in 12..28 {
            for x in 14..34 {
                frame_px[y * w + x] = 220;
            }
        }
    }
    let bg = vec![100u8; if input.flag() { w * h } else { w * h / 3 }];
    let frame = Frame::new_checked(&frame_px[..], w, h).expect("w·h bytes");
    let alpha = Alpha::new(input.num_or(1.0)).unwrap_or(Alpha::ONE);
    let diff = Difference::new(&frame, &bg, alpha);
    let rp = RefineParams {
        iterations: input.count_or(12).min(64),
        search: input.num_or(3.0),
        step: input.num_or(0.25),
        min_contrast: input.num_or(8.0),
        cap: input.num_or(2.0),
        give_up: input.num_or(f32::INFINITY),
        offset_max: input.num_or(0.0),
        wall_max: input.num_or(0.0),
        wall_toward: [input.num_or(0.0), input.num_or(0.0)],
    };
    let seed = Pose {
        x: input.num_or(24.0),
        y: input.num_or(20.0),
        angle: input.num_or(0.0),
        scale: input.num_or(1.0),
    };
    // The template's edge: the resampled border around its centroid, with its normals.
    let c = centroid(&pts);
    let edge: Vec<[f32; 2]> = pts.iter().map(|p| [(p[0] - c[0]) * 0.1, (p[1] - c[1]) * 0.1]).collect();
    let ccw = input.flag();
    let normals: Vec<[f32; 2]> = (0..edge.len())
        .map(|k| outward_normal(&edge, k, ccw).unwrap_or([1.0, 0.0]))
        .collect();
    let _ = outward_normal(&edge, input.count(), ccw);
    let a = align(&diff, &edge, &normals, seed, &rp);
    if seed.x.is_finite() && seed.y.is_finite() && seed.angle.is_finite() && seed.scale.is_finite() {
        assert!(!a.distance.is_nan(), "alignment {a:?}");
        assert!(
            !(a.pose.x.is_nan() || a.pose.y.is_nan() || a.pose.scale.is_nan()),
            "alignment {a:?}"
        );
    }
    let _ = align(
        &diff,
        &edge,
        &normals[..normals.len() / 2],
        seed,
        &RefineParams::DEFAULT,
    );
    let outline = Outline::new(&edge);
    let q = [input.num(), input.num()];
    let _ = outline.capped_distance(q, input.num());
    let _ = diff.at(input.count() as isize, input.count() as isize);
    let _ = diff.bilinear(q[0], q[1]);
    let _ = diff.rows(input.count());
    let normal = [input.num(), input.num()];
    let _ = diff.edge_offset(q, normal, &rp);
    let finder = diff.edge_finder(&rp);
    let _ = finder.offset(q, normal);
    for (p, n) in edge.iter().zip(&normals).take(16) {
        let _ = finder.offset(seed.apply(*p), seed.rotate(*n));
    }
    let _ = seed.invert(q);
    if let Some(ray) = ProfileRay::new(q, normal, input.num(), input.u32() as i32) {
        let k = input.u32() as i32;
        let _ = ray.at(k);
        let _ = sample_by_pixels(&diff, &ray, k);
    }
});
