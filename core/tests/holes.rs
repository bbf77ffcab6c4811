//! Hole signatures against hand-drawn frames: two templates of one outline that differ only in
//! their holes are told apart by them, the half turn of a 2-fold outline is decided by its one
//! eye, and the pose the holes give is the one they were drawn at.

use vorl_core::borders::contour::{trace_borders, BorderFilter, ContourStore};
use vorl_core::pixels::background::Background;
use vorl_core::pose::holes::{agreement, pose_from_holes, Hole, Holes};
use vorl_core::pose::refine::Pose;
use vorl_core::{Frame, Params, Recognizer};

const W: usize = 220;
const H: usize = 140;

/// A 64×20 bar centred at (`cx`, `cy`) with 9×9 eyes centred `eyes` px along its length from
/// its centre, turned by a multiple of 90° (`quarter`: 0 = along x; 2 = half a turn), written
/// with `value` into `img`.
fn bar(img: &mut [u8], cx: i32, cy: i32, eyes: &[i32], quarter: u32, value: u8) {
    for v in -10i32..10 {
        for u in -32..32 {
            let in_eye = eyes.iter().any(|&e| (u - e).abs() <= 4 && v.abs() <= 4);
            if in_eye {
                continue;
            }
            // Turn (u, v) by quarter·90° counter-clockwise on screen (y down).
            let (x, y) = match quarter % 4 {
                0 => (u, v),
                1 => (v, -u),
                2 => (-u, -v),
                _ => (-v, u),
            };
            let (px, py) = (cx + x, cy + y);
            img[py as usize * W + px as usize] = value;
        }
    }
}

fn silhouette(eyes: &[i32]) -> Vec<u8> {
    let mut img = vec![0u8; W * H];
    bar(&mut img, 110, 70, eyes, 0, 255);
    img
}

type Rec = Recognizer<4, 96, 4096, 32, 4096>;

fn recognizer() -> Rec {
    let mut rec = Rec::new();
    rec.set_params(Params::DEFAULT).unwrap();
    let mut labels = vec![0u8; W * H];
    // Template 0: one eye 20 px left of the centre; template 1: eyes at both ends.
    for eyes in [&[-20][..], &[-20, 20][..]] {
        let s = silhouette(eyes);
        rec.teach(&Frame::new_checked(&s[..], W, H).unwrap(), &mut labels)
            .unwrap();
    }
    rec
}

#[test]
fn a_template_keeps_its_holes() {
    let rec = recognizer();
    let (one, two) = (&rec.templates()[0], &rec.templates()[1]);
    assert_eq!(one.holes().len(), 1);
    assert_eq!(two.holes().len(), 2);
    // 9×9 eyes of 81 pixels. The outer border runs through the bar's edge pixels: a 63×19
    // rectangle centred half a pixel up-left of (110, 70); each eye's hole border through the
    // bar's pixels 4-adjacent to the eye: a 10×10 square less its four corner triangles (98 px²)
    // centred on the eye. The area centroid is the outer polygon less the hole polygons.
    let centroid = |eyes: &[f32]| {
        let (outer, hole) = (63.0 * 19.0, 98.0);
        let a = outer - hole * eyes.len() as f32;
        let x = (109.5 * outer - eyes.iter().map(|e| (110.0 + e) * hole).sum::<f32>()) / a;
        let y = (69.5 * outer - 70.0 * hole * eyes.len() as f32) / a;
        [x, y]
    };
    for (t, eyes) in [(one, &[-20.0f32][..]), (two, &[-20.0, 20.0][..])] {
        let c = centroid(eyes);
        let mut expected: Vec<f32> = eyes.iter().map(|e| 110.0 + e - c[0]).collect();
        expected.sort_by(f32::total_cmp);
        let mut got: Vec<f32> = t.holes().as_slice().iter().map(|h| h.centre[0]).collect();
        got.sort_by(f32::total_cmp);
        for (g, e) in got.iter().zip(&expected) {
            assert!((g - e).abs() < 1e-3, "{got:?} against {expected:?}");
        }
        for h in t.holes().as_slice() {
            assert_eq!(h.area, 81.0);
            assert!((h.centre[1] - (70.0 - c[1])).abs() < 1e-3, "{h:?}");
        }
    }
}

#[test]
fn parts_of_one_outline_are_told_apart_by_their_holes() {
    let mut rec = recognizer();
    let platform = vec![200u8; W * H];
    let mut scene = platform.clone();
    // The one-eyed bar turned half a turn (its eye now right of its centre), the two-eyed bar
    // a quarter turn.
    bar(&mut scene, 60, 40, &[-20], 2, 40);
    bar(&mut scene, 160, 75, &[-20, 20], 1, 40);
    let mut bg = Background::new(vec![0u8; W * H], W, H).unwrap();
    bg.set_from_frame(
        &Frame::new_checked(&platform[..], W, H).unwrap(),
        Params::DEFAULT.alpha(),
    )
    .unwrap();
    let mut labels = vec![0u8; W * H];
    let report = rec
        .process(&Frame::new_checked(&scene[..], W, H).unwrap(), &bg, &mut labels)
        .unwrap();
    assert_eq!(report.detections.len(), 2);
    let near = |x: f32, y: f32| {
        report
            .detections
            .iter()
            .find(|d| (d.x - x).abs() < 15.0 && (d.y - y).abs() < 15.0)
            .copied()
            .unwrap()
    };
    let one = near(60.0, 40.0);
    assert_eq!(one.template, Some(0), "{one:?}");
    assert_eq!((one.holes.expected, one.holes.found), (1, 1));
    // The outline is 2-fold; the eye says which way round: half a turn.
    assert!((one.angle_deg - 180.0).abs() < 1.0, "{one:?}");
    let two = near(160.0, 75.0);
    assert_eq!(two.template, Some(1), "{two:?}");
    assert_eq!((two.holes.expected, two.holes.found), (2, 2));
    let quarter = two.angle_deg.rem_euclid(180.0);
    assert!((quarter - 90.0).abs() < 1.0, "{two:?}");
}

#[test]
fn hole_borders_measure_their_pixels() {
    // A 5×3 hole in a 9×7 block: its hole border, as traced, encloses exactly 15 pixels centred
    // at (4, 3).
    let (w, h) = (9, 7);
    let mut labels = vec![1u8; w * h];
    for y in 2..5 {
        for x in 2..7 {
            labels[y * w + x] = 0;
        }
    }
    let mut store = ContourStore::<256, 8>::new();
    let filter = BorderFilter {
        min_points: 1,
        min_area: 0.0,
    };
    trace_borders(&mut labels, w, h, filter, &mut store).unwrap();
    let outer = store.largest_outer().unwrap();
    let holes: Vec<_> = store.holes_of(outer).collect();
    assert_eq!(holes.len(), 1);
    let hole = Hole::from_border(store.points(holes[0])).unwrap();
    assert_eq!(hole.area, 15.0);
    assert!((hole.centre[0] - 4.0).abs() < 1e-5 && (hole.centre[1] - 3.0).abs() < 1e-5);
}

#[test]
fn the_holes_give_the_pose_they_were_drawn_at() {
    // Two template holes of different size; the part's are the same, turned, scaled and moved.
    let mut template = Holes::new();
    template.insert(Hole {
        centre: [-30.0, 5.0],
        area: 400.0,
    });
    template.insert(Hole {
        centre: [25.0, -4.0],
        area: 40.0,
    });
    for (angle_deg, scale) in [(0.0f32, 1.0f32), (37.0, 1.2), (200.0, 0.8), (-95.0, 1.05)] {
        let truth = Pose {
            x: 101.5,
            y: 63.25,
            angle: angle_deg.to_radians(),
            scale,
        };
        let mut part = Holes::new();
        // Listed small first, and with a speck that fits neither.
        part.insert(Hole {
            centre: [5.0, 5.0],
            area: 4.0,
        });
        for h in template.as_slice().iter().rev() {
            part.insert(Hole {
                centre: truth.apply(h.centre),
                area: h.area * scale * scale,
            });
        }
        let pose = pose_from_holes(&template, &part).unwrap();
        assert!(
            (pose.x - truth.x).abs() < 1e-3 && (pose.y - truth.y).abs() < 1e-3,
            "{pose:?}"
        );
        assert!((pose.scale - scale).abs() < 1e-5, "{pose:?}");
        let d = (pose.angle - truth.angle).rem_euclid(core::f32::consts::TAU);
        assert!(
            !(1e-4..=core::f32::consts::TAU - 1e-4).contains(&d),
            "{pose:?} against {truth:?}"
        );
        let a = agreement(&template, &pose, &part);
        assert_eq!((a.expected, a.found, a.missing()), (2, 2, 0));
        // Half a turn off, the small eye lands where the large one is: not found (their radii,
        // 11.3 and 3.6 px at scale 1, lie outside each other's band).
        let wrong = Pose {
            angle: pose.angle + core::f32::consts::PI,
            ..pose
        };
        assert!(!agreement(&template, &wrong, &part).all_found());
    }
    // One hole is not enough for a pose.
    let mut one = Holes::new();
    one.insert(Hole {
        centre: [0.0, 0.0],
        area: 10.0,
    });
    assert_eq!(pose_from_holes(&one, &one), None);
}

#[test]
fn a_hole_the_template_does_not_have_does_not_move_the_position() {
    // Template: the plain bar. Part: the same bar with a light 9×9 patch (print) 20 px right of
    // its centre: a hole in the mask that the template does not have.
    let mut rec = Rec::new();
    rec.set_params(Params::DEFAULT).unwrap();
    let mut labels = vec![0u8; W * H];
    let s = silhouette(&[]);
    rec.teach(&Frame::new_checked(&s[..], W, H).unwrap(), &mut labels)
        .unwrap();
    assert!(rec.templates()[0].holes().is_empty());
    let platform = vec![200u8; W * H];
    let mut scene = platform.clone();
    bar(&mut scene, 100, 60, &[20], 0, 40);
    let mut bg = Background::new(vec![0u8; W * H], W, H).unwrap();
    bg.set_from_frame(
        &Frame::new_checked(&platform[..], W, H).unwrap(),
        Params::DEFAULT.alpha(),
    )
    .unwrap();
    let report = rec
        .process(&Frame::new_checked(&scene[..], W, H).unwrap(), &bg, &mut labels)
        .unwrap();
    assert_eq!(report.detections.len(), 1);
    let d = report.detections[0];
    assert_eq!(d.template, Some(0), "{d:?}");
    assert_eq!((d.holes.expected, d.holes.found, d.holes.matched), (0, 0, 0));
    // The whole bar's pixel centroid: columns 68..=131, rows 50..=69.
    assert!((d.x - 99.5).abs() < 0.02 && (d.y - 59.5).abs() < 0.02, "{d:?}");
    // Without the fill it would lie 81·20.5/(1280 − 81) = 1.38 px left of it (the polygon
    // centroid, holes subtracted, says so).
    assert!(d.polygon_centroid[0] < 99.5 - 1.0, "{d:?}");
}
