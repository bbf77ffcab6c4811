//! A frame of any size and bytes through `Recognizer::process` with any `Params`: background
//! learned, set, estimated from the frame (no empty shot) or updated, templates taught from
//! silhouettes, frames with a stride, labels planes too short, a background of another size.
//!
//! Input: width, height, mode, parameters (`vorl_fuzz::params`), the background plane, the frame
//! plane, a rectangle silhouette's box (a template), then anything left is a second frame.
//!
//! Checked besides "no panic": every detection has a finite position inside the frame's box
//! (widened by a pixel), an angle in `[0, 360)`, a finite area; afterwards the label plane holds
//! only 0 and 1 (the documented contract of `process`).

#![no_main]

use libfuzzer_sys::fuzz_target;
use vorl_core::pixels::background::Background;
use vorl_core::{Frame, Recognizer};
use vorl_fuzz::{params, Input};

type Rec = Recognizer<4, 96, 2048, 32, 4096>;

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    let w = 1 + usize::from(input.u8()) % 128;
    let h = 1 + usize::from(input.u8()) % 96;
    let mode = input.u8();
    let p = params(&mut input);
    let bg_px = input.plane(w * h);
    let frame_px = input.plane(w * h);
    // A rectangle silhouette, a template the frame may hold.
    let (rx, ry, rw, rh) = (
        usize::from(input.u8()) % w,
        usize::from(input.u8()) % h,
        usize::from(input.u8()),
        usize::from(input.u8()),
    );
    let second = input.bytes(w * h);

    let mut rec: Box<Rec> = Box::default();
    let _ = rec.set_params(p);
    let mut labels = vec![0u8; w * h];
    let mut silhouette = vec![0u8; w * h];
    for y in ry..(ry + rh).min(h) {
        for x in rx..(rx + rw).min(w) {
            silhouette[y * w + x] = 255;
        }
    }
    let sil = Frame::new_checked(&silhouette[..], w, h).expect("w·h bytes");
    let _ = rec.teach(&sil, &mut labels);
    if mode & 1 == 1 {
        // The frame's own bright pixels as a second template.
        let f = Frame::new_checked(&frame_px[..], w, h).expect("w·h bytes");
        let _ = rec.teach(&f, &mut labels);
    }

    // The background: set from one frame, or learned from two; sometimes of another size.
    let (bw, bh) = if mode & 2 == 2 { (w, (h % 7) + 1) } else { (w, h) };
    let mut plane = vec![0u8; bw * bh];
    let Ok(mut bg) = Background::new(&mut plane[..], bw, bh) else {
        return;
    };
    let bg_frame = Frame::new_checked(&bg_px[..], w, h).expect("w·h bytes");
    let alpha = rec.params().alpha();
    if mode & 4 == 4 {
        let mut high = vec![0u8; if mode & 8 == 8 { w * h / 2 } else { w * h }];
        let _ = bg.learn(&bg_frame, alpha, &mut high);
        let _ = bg.learn(&bg_frame, alpha, &mut high);
        let _ = bg.finish_learning(&high);
    } else {
        let _ = bg.set_from_frame(&bg_frame, alpha);
    }

    // The frame, packed or with a stride; the labels plane sometimes short.
    let stride = if mode & 16 == 16 { w + 3 } else { w };
    let mut strided = vec![0u8; stride * h];
    for y in 0..h {
        strided[y * stride..y * stride + w].copy_from_slice(&frame_px[y * w..(y + 1) * w]);
    }
    let frame = Frame::with_stride(&strided[..], w, h, stride).expect("stride·h bytes");
    // The frame's exposure against the background: gain positive and finite when fitted, and
    // undoing it keeps the length.
    if let Ok(e) = vorl_core::pixels::exposure::fit_exposure(&frame, alpha, bg.plane()) {
        assert!(e.gain > 0.0 && e.gain.is_finite() && e.offset.is_finite(), "{e:?}");
        assert!(e.inliers <= e.samples, "{e:?}");
        let mut copy = frame_px.to_vec();
        e.undo(&mut copy);
        assert_eq!(copy.len(), frame_px.len());
    }
    // No empty shot: the platform estimated from the frame itself (a grid of any small size).
    if mode & 64 == 64 {
        let mut grid = vorl_core::pixels::platform::PlatformGrid::<24>::new();
        if let Ok(stats) = bg.estimate_from_frame(&frame, alpha, &mut grid) {
            assert!(stats.cells_x * stats.cells_y <= 24 && stats.cell >= 1);
            assert!(bg.is_ready());
        }
        // Kept for the next frame while it fits: the same frame twice is kept the second
        // time unless too few samples agree (then estimated again), and the figures are those
        // of the estimate in use.
        let mut keeping = vorl_core::pixels::background::PlatformKeeping::new(1 + u32::from((mode >> 2) & 3));
        if let Ok(first) = bg.estimate_or_keep(&frame, alpha, &mut grid, &mut keeping) {
            assert!(matches!(first, vorl_core::pixels::background::PlatformUse::Estimated(_)));
            if let Ok(second) = bg.estimate_or_keep(&frame, alpha, &mut grid, &mut keeping) {
                let key = |s: vorl_core::pixels::platform::PlatformStats| (s.cell, s.cells_x, s.cells_y, s.kept);
                assert_eq!(key(second.stats()), key(first.stats()), "{first:?} {second:?}");
            }
        }
    }
    let labels_len = if mode & 32 == 32 {
        (w * h).saturating_sub(1)
    } else {
        w * h
    };
    let mut labels = vec![0u8; labels_len];
    if let Ok(report) = rec.process(&frame, &bg, &mut labels) {
        check(&report, w, h);
        assert!(labels.iter().all(|&v| v <= 1), "labels hold the 0/1 mask after process");
        let _ = bg.update(&frame, alpha, &labels, mode >> 6);
    }
    // A second frame through the same recognizer (state carried over).
    if second.len() == w * h {
        let f2 = Frame::new_checked(second, w, h).expect("w·h bytes");
        let mut stages = 0;
        if let Ok(report) = rec.process_observed(&f2, &bg, &mut labels, |_| stages += 1) {
            check(&report, w, h);
            assert_eq!(stages, 3, "three stages observed");
        }
    }
});

fn check(report: &vorl_core::Report, w: usize, h: usize) {
    for d in &report.detections {
        assert!(d.x.is_finite() && d.y.is_finite(), "position {d:?}");
        assert!(
            d.x >= -1.0 && d.y >= -1.0 && d.x <= w as f32 && d.y <= h as f32,
            "inside {d:?}"
        );
        assert!((0.0..360.0).contains(&d.angle_deg), "angle {d:?}");
        assert!(d.area.is_finite(), "area {d:?}");
    }
}
