//! Border following on hand-drawn masks. Every expected point list below was worked out by hand
//! from the Suzuki–Abe rules (start pixel, clockwise search for the second point,
//! counter-clockwise tracing), not taken from the code's output.

use vorl_tests::{core_borders, TracedBorder};

fn outer(points: &[(u16, u16)]) -> TracedBorder {
    TracedBorder {
        points: points.to_vec(),
        hole: false,
        parent: None,
    }
}

#[test]
fn square() {
    let b = core_borders(&[".....", ".###.", ".###.", ".###.", "....."]);
    assert_eq!(
        b,
        vec![outer(&[(1, 1), (1, 2), (1, 3), (2, 3), (3, 3), (3, 2), (3, 1), (2, 1)])]
    );
}

#[test]
fn l_shape_with_one_pixel_stem_revisits_pixels() {
    let b = core_borders(&["......", ".#....", ".#....", ".###..", "......"]);
    assert_eq!(
        b,
        vec![outer(&[(1, 1), (1, 2), (1, 3), (2, 3), (3, 3), (2, 3), (1, 2)])]
    );
}

#[test]
fn ring_has_outer_and_hole_with_parent() {
    let b = core_borders(&[".....", ".###.", ".#.#.", ".###.", "....."]);
    assert_eq!(b.len(), 2);
    assert_eq!(
        b[0],
        outer(&[(1, 1), (1, 2), (1, 3), (2, 3), (3, 3), (3, 2), (3, 1), (2, 1)])
    );
    assert_eq!(
        b[1],
        TracedBorder {
            points: vec![(1, 2), (2, 1), (3, 2), (2, 3)],
            hole: true,
            parent: Some(0)
        }
    );
}

#[test]
fn single_pixel() {
    let b = core_borders(&["....", "..#.", "...."]);
    assert_eq!(b, vec![outer(&[(2, 1)])]);
}

#[test]
fn part_touching_left_and_top_border() {
    let b = core_borders(&["##..", "##..", "...."]);
    assert_eq!(b, vec![outer(&[(0, 0), (0, 1), (1, 1), (1, 0)])]);
}

#[test]
fn part_touching_right_border_gives_no_false_hole() {
    let b = core_borders(&["..##", "..##", "...."]);
    assert_eq!(b, vec![outer(&[(2, 0), (2, 1), (3, 1), (3, 0)])]);
}

#[test]
fn two_parts_in_raster_order() {
    let b = core_borders(&[".......", ".##..#.", ".##..#.", "......."]);
    assert_eq!(
        b,
        vec![outer(&[(1, 1), (1, 2), (2, 2), (2, 1)]), outer(&[(5, 1), (5, 2)])]
    );
}

#[test]
fn touches_edge_flag() {
    use vorl_core::borders::contour::{trace_borders, BorderFilter, ContourStore};
    let (mut p, w, h) = vorl_tests::ascii_mask(&["......", ".##..#", ".##..#", "......"]);
    let mut store = ContourStore::<64, 8>::new();
    trace_borders(
        &mut p,
        w,
        h,
        BorderFilter {
            min_points: 1,
            min_area: 0.0,
        },
        &mut store,
    )
    .unwrap();
    let flags: Vec<bool> = store.contours().iter().map(|c| c.touches_edge).collect();
    assert_eq!(flags, [false, true]);
}

#[test]
fn size_filter_drops_small_borders() {
    use vorl_core::borders::contour::{trace_borders, BorderFilter, ContourStore};
    let (mut p, w, h) = vorl_tests::ascii_mask(&[".......", ".###.#.", ".###...", ".###...", "......."]);
    let mut store = ContourStore::<64, 8>::new();
    let stats = trace_borders(
        &mut p,
        w,
        h,
        BorderFilter {
            min_points: 2,
            min_area: 1.0,
        },
        &mut store,
    )
    .unwrap();
    assert_eq!(stats.found, 2);
    assert_eq!(stats.kept, 1);
    assert_eq!(stats.dropped_small, 1);
}

#[test]
fn long_border_is_subsampled_not_cut() {
    use vorl_core::borders::contour::{trace_borders, BorderFilter, ContourStore};
    // A 30×30 block has a border of 116 points; a store of 40 points keeps every 3rd.
    let rows: Vec<String> = (0..32)
        .map(|y| {
            (0..32)
                .map(|x| {
                    if (1..31).contains(&x) && (1..31).contains(&y) {
                        '#'
                    } else {
                        '.'
                    }
                })
                .collect()
        })
        .collect();
    let refs: Vec<&str> = rows.iter().map(|s| s.as_str()).collect();
    let (mut p, w, h) = vorl_tests::ascii_mask(&refs);
    let mut store = ContourStore::<40, 8>::new();
    let stats = trace_borders(
        &mut p,
        w,
        h,
        BorderFilter {
            min_points: 1,
            min_area: 0.0,
        },
        &mut store,
    )
    .unwrap();
    assert_eq!(stats.subsampled, 1);
    let c = store.contours()[0];
    assert_eq!(c.traced_len, 116);
    assert_eq!(c.stride, 3);
    assert_eq!(c.len, 39);
    let pts = store.points(0);
    // The subsampled points still go all the way round: first, then every third.
    assert_eq!((pts[0].x, pts[0].y), (1, 1));
    assert_eq!((pts[1].x, pts[1].y), (1, 4));
    let max_x = pts.iter().map(|p| p.x).max().unwrap();
    let max_y = pts.iter().map(|p| p.y).max().unwrap();
    assert_eq!((max_x, max_y), (30, 30));
    // The area is of the full trace: the polygon through the 30×30 pixel centres is 29×29.
    assert_eq!(c.area(), 29.0 * 29.0);
}
