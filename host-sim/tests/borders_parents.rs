//! The core's border hierarchy against the independent reference (`imageproc`'s Suzuki–Abe
//! tracing, `vorl_host_sim::reference::contour`, whose labels never run out) on masks with
//! hundreds of borders: print on a platform makes that many, and the core's `u8` label plane
//! runs out after 126, from where it finds parents by containment. Every kept border must have
//! the reference's parent (when that parent is kept too), before and after the labels run out.

use image::GrayImage;
use proptest::prelude::*;
use vorl_core::borders::contour::{trace_borders, BorderFilter, BorderKind, ContourStore};
use vorl_host_sim::reference::{borders, polygon_area};

/// A `w × h` mask of `rings` rectangles (a frame of foreground round a hole, some with a dot
/// inside the hole) and `dots` small squares, placed by the seeds; overlaps merge.
fn scene(w: u32, h: u32, shapes: &[(u32, u32, u32, u32, u8)]) -> GrayImage {
    let mut m = GrayImage::new(w, h);
    for &(x, y, a, b, kind) in shapes {
        let (x1, y1) = ((x + a).min(w), (y + b).min(h));
        for yy in y..y1 {
            for xx in x..x1 {
                let edge = xx < x + 2 || yy < y + 2 || xx + 2 >= x1 || yy + 2 >= y1;
                let centre = xx >= x + a / 2 - 1 && xx <= x + a / 2 && yy >= y + b / 2 - 1 && yy <= y + b / 2;
                let on = match kind % 3 {
                    0 => true,                                 // a solid block
                    1 => edge,                                 // a ring: outer border and a hole
                    _ => edge || (centre && a >= 8 && b >= 8), // a ring with a dot in its hole
                };
                if on {
                    m.put_pixel(xx, yy, image::Luma([255]));
                }
            }
        }
    }
    m
}

/// The core's borders and parents (store indices) and the reference's, compared border by
/// border through the kept borders' positions in the reference's order. Returns whether the
/// labels ran out.
fn same_parents(mask: &GrayImage, filter: BorderFilter) -> bool {
    let (w, h) = (mask.width() as usize, mask.height() as usize);
    let mut labels: Vec<u8> = mask.as_raw().iter().map(|&v| u8::from(v != 0)).collect();
    let mut store = Box::new(ContourStore::<{ 1 << 16 }, 2048>::new());
    let stats = trace_borders(&mut labels, w, h, filter, &mut store).unwrap();
    let all = borders(mask);
    // The reference's borders that the filter keeps, in order: the core's store.
    let kept: Vec<usize> = (0..all.len())
        .filter(|&i| all[i].points.len() >= filter.min_points && polygon_area(&all[i].points) >= filter.min_area as f64)
        .collect();
    assert_eq!(kept.len(), store.contours().len(), "kept borders");
    for (ci, &ri) in kept.iter().enumerate() {
        let c = store.contours()[ci];
        assert_eq!(c.kind == BorderKind::Hole, all[ri].is_hole, "border {ci} kind");
        let want = all[ri].parent.and_then(|p| kept.iter().position(|&k| k == p));
        // A reference parent the filter dropped: the core cannot name it (it has no index).
        if all[ri].parent.is_some() && want.is_none() {
            continue;
        }
        assert_eq!(
            c.parent.map(usize::from),
            want,
            "border {ci} ({:?}, {} points, saturated {})",
            c.kind,
            c.len,
            stats.labels_saturated
        );
    }
    stats.labels_saturated
}

/// A dense grid of rings with dots in their holes: far more than 126 borders, every kind of
/// parent (outer in hole, hole in outer) after the labels run out.
#[test]
fn parents_hold_past_the_labels_on_a_grid_of_rings() {
    let mut shapes = Vec::new();
    for j in 0..14 {
        for i in 0..14 {
            shapes.push((4 + i * 22, 4 + j * 22, 16 + (i % 3), 15 + (j % 4), 2));
        }
    }
    // One large ring round a corner of the grid, traced early, holding later borders.
    shapes.push((0, 150, 160, 160, 1));
    let mask = scene(320, 320, &shapes);
    let all = borders(&mask);
    assert!(all.len() > 3 * 126, "{} borders", all.len());
    assert!(same_parents(
        &mask,
        BorderFilter {
            min_points: 1,
            min_area: 0.0
        }
    ));
    assert!(same_parents(
        &mask,
        BorderFilter {
            min_points: 16,
            min_area: 20.0
        }
    ));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, .. ProptestConfig::default() })]

    /// Random rings, blocks and dotted rings, overlapping at will, with and without a size
    /// filter.
    #[test]
    fn parents_equal_the_reference(
        shapes in prop::collection::vec((0u32..200, 0u32..150, 3u32..40, 3u32..40, 0u8..3), 20..220),
        filtered in any::<bool>(),
    ) {
        let mask = scene(200, 150, &shapes);
        let filter = if filtered {
            BorderFilter { min_points: 12, min_area: 16.0 }
        } else {
            BorderFilter { min_points: 1, min_area: 0.0 }
        };
        same_parents(&mask, filter);
    }
}
