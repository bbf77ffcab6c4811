//! Border following on any mask: `contour::trace_borders` and `trace_borders_in` (with the
//! mask stage's own spans, and with spans of another size), `clear_labels`, and the store's
//! queries, with small and large stores and any size filter.
//!
//! Input: width, height, store choice, filter (`min_points`, `min_area`), then the mask, one bit
//! per pixel (or, with the raw flag, one byte per pixel: any label value).
//!
//! Checked: `trace_borders_in` with the spans of `foreground_mask_spans` gives exactly what
//! `trace_borders` gives (stats, borders, points, and the label plane afterwards); every stored
//! point lies in the image; every border's points lie in the store; after `clear_labels` the
//! plane is the 0/1 mask again.

#![no_main]

use libfuzzer_sys::fuzz_target;
use vorl_core::pixels::background::Background;
use vorl_core::borders::contour::{clear_labels, trace_borders, trace_borders_in, BorderFilter, ContourStore};
use vorl_core::pixels::enhance::Alpha;
use vorl_core::pixels::mask::{foreground_mask_spans, Cleanup, Polarity, RowSpans, Threshold};
use vorl_core::Frame;
use vorl_fuzz::Input;

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    let w = 1 + usize::from(input.u8()) % 200;
    let h = 1 + usize::from(input.u8()) % 64;
    let choice = input.u8();
    let filter = BorderFilter {
        min_points: if input.u8() < 128 { 1 } else { input.count() },
        min_area: if input.u8() < 128 { 0.0 } else { input.num() },
    };
    let raw = choice & 1 == 1;
    let mut mask = vec![0u8; w * h];
    if raw {
        let bytes = input.bytes(w * h);
        mask[..bytes.len()].copy_from_slice(bytes);
    } else {
        let bits = input.bytes((w * h).div_ceil(8));
        for (i, m) in mask.iter_mut().enumerate() {
            *m = bits.get(i / 8).map_or(0, |b| (b >> (i % 8)) & 1);
        }
    }
    if choice & 2 == 2 {
        run::<64, 4>(&mask, w, h, filter, raw, choice);
    } else {
        run::<4096, 64>(&mask, w, h, filter, raw, choice);
    }
});

fn run<const P: usize, const C: usize>(mask: &[u8], w: usize, h: usize, filter: BorderFilter, raw: bool, choice: u8) {
    let mut full = mask.to_vec();
    let mut a = ContourStore::<P, C>::new();
    let stats_full = trace_borders(&mut full, w, h, filter, &mut a);
    check_store(&a, w, h);
    if raw {
        // Any label values: only "no panic", and the spans' other forms.
        let mut plane = mask.to_vec();
        let mut b = ContourStore::<P, C>::new();
        let spans = if choice & 4 == 4 {
            RowSpans::full(w, h + 1)
        } else {
            RowSpans::new()
        };
        let _ = trace_borders_in(&mut plane, w, h, &spans, filter, &mut b);
        clear_labels(&mut plane, w, h, &spans);
        let _ = trace_borders_in(&mut plane[..mask.len() / 2], w, h, &spans, filter, &mut b);
        return;
    }
    // The same mask from the mask stage (frame 0/1 against a zero background, τ = 0, no
    // clean-up), with its spans.
    let frame = Frame::new_checked(mask, w, h).expect("w·h bytes");
    let mut bg_plane = vec![0u8; w * h];
    let mut bg = Background::new(&mut bg_plane[..], w, h).expect("size");
    let zeros = vec![0u8; w * h];
    bg.set_from_frame(&Frame::new_checked(&zeros[..], w, h).expect("w·h bytes"), Alpha::ONE)
        .expect("same size");
    let mut labels = vec![0u8; w * h];
    let mut spans = RowSpans::new();
    foreground_mask_spans(
        &frame,
        &bg,
        Alpha::ONE,
        Threshold::Fixed(0),
        Polarity::Either,
        Cleanup::Off,
        &mut labels,
        &mut spans,
    )
    .expect("mask");
    assert_eq!(labels, mask, "the mask stage reproduces a 0/1 mask");
    let mut b = ContourStore::<P, C>::new();
    let stats_in = trace_borders_in(&mut labels, w, h, &spans, filter, &mut b);
    assert_eq!(
        stats_full, stats_in,
        "trace_borders_in with the mask's spans is trace_borders"
    );
    assert_eq!(full, labels, "same label plane");
    assert_eq!(a.contours(), b.contours(), "same borders");
    for i in 0..a.contours().len() {
        assert_eq!(a.points(i), b.points(i), "same points of border {i}");
    }
    clear_labels(&mut labels, w, h, &spans);
    assert_eq!(labels, mask, "clear_labels gives the 0/1 mask back");
    let _ = a.largest_outer();
    for i in 0..a.contours().len() + 1 {
        for hole in a.holes_of(i) {
            assert!(hole < a.contours().len());
        }
    }
}

fn check_store<const P: usize, const C: usize>(store: &ContourStore<P, C>, w: usize, h: usize) {
    for (i, c) in store.contours().iter().enumerate() {
        let pts = store.points(i);
        assert_eq!(pts.len(), c.len as usize, "border {i} holds its points");
        assert!(c.start as usize + c.len as usize <= P, "border {i} inside the store");
        for p in pts {
            assert!(
                (p.x as usize) < w && (p.y as usize) < h,
                "point {p:?} of border {i} in the image"
            );
        }
    }
}
