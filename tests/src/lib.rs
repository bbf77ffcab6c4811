//! Shared helpers for the integration tests: ASCII-art masks, polygon shapes rasterised at any
//! pose, and scenes on a platform.

use vorl_core::borders::contour::{trace_borders, BorderFilter, BorderKind, ContourStore};

/// A 0/1 plane from ASCII art (`#` foreground, anything else background).
pub fn ascii_mask(rows: &[&str]) -> (Vec<u8>, usize, usize) {
    let w = rows.first().map_or(0, |r| r.len());
    let mut p = Vec::with_capacity(w * rows.len());
    for r in rows {
        assert_eq!(r.len(), w, "ragged ASCII art");
        p.extend(r.bytes().map(|c| (c == b'#') as u8));
    }
    (p, w, rows.len())
}

/// One traced border as plain data.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TracedBorder {
    /// Points in traced order.
    pub points: Vec<(u16, u16)>,
    /// Hole border?
    pub hole: bool,
    /// Parent index.
    pub parent: Option<u16>,
}

/// Every border of an ASCII-art mask, traced by the core with no size filter.
pub fn core_borders(rows: &[&str]) -> Vec<TracedBorder> {
    let (mut plane, w, h) = ascii_mask(rows);
    let mut store = Box::new(ContourStore::<4096, 64>::new());
    trace_borders(
        &mut plane,
        w,
        h,
        BorderFilter {
            min_points: 1,
            min_area: 0.0,
        },
        &mut store,
    )
    .unwrap();
    (0..store.contours().len())
        .map(|i| TracedBorder {
            points: store.points(i).iter().map(|p| (p.x, p.y)).collect(),
            hole: store.contours()[i].kind == BorderKind::Hole,
            parent: store.contours()[i].parent,
        })
        .collect()
}

/// A simple polygon shape in its own frame (units: px at scale 1), centred near the origin.
#[derive(Debug, Clone)]
pub struct Shape {
    /// Name for messages.
    pub name: &'static str,
    /// Vertices of the outline.
    pub outline: Vec<(f64, f64)>,
}

/// A few asymmetric test shapes (no rotational symmetry, so every angle is defined).
pub fn shapes() -> Vec<Shape> {
    vec![
        Shape {
            name: "l_bracket",
            outline: vec![
                (-30.0, -40.0),
                (-10.0, -40.0),
                (-10.0, 20.0),
                (40.0, 20.0),
                (40.0, 40.0),
                (-30.0, 40.0),
            ],
        },
        Shape {
            name: "arrow",
            outline: vec![
                (-45.0, -8.0),
                (15.0, -8.0),
                (15.0, -25.0),
                (48.0, 0.0),
                (15.0, 25.0),
                (15.0, 8.0),
                (-45.0, 8.0),
            ],
        },
        Shape {
            name: "key",
            outline: vec![
                (-40.0, -15.0),
                (30.0, -15.0),
                (45.0, 0.0),
                (30.0, 15.0),
                (5.0, 15.0),
                (5.0, 28.0),
                (-12.0, 28.0),
                (-12.0, 15.0),
                (-40.0, 15.0),
            ],
        },
    ]
}

impl Shape {
    /// The outline turned counter-clockwise on screen by `angle_deg`, scaled, and moved to
    /// `(cx, cy)` (image coordinates, y down).
    pub fn posed(&self, angle_deg: f64, scale: f64, cx: f64, cy: f64) -> Vec<(f64, f64)> {
        let (s, c) = angle_deg.to_radians().sin_cos();
        self.outline
            .iter()
            .map(|&(x, y)| (cx + scale * (x * c + y * s), cy + scale * (-x * s + y * c)))
            .collect()
    }
}

/// Whether `(x, y)` is inside the polygon (even–odd rule).
pub fn inside(poly: &[(f64, f64)], x: f64, y: f64) -> bool {
    let mut inside = false;
    let n = poly.len();
    for i in 0..n {
        let (x0, y0) = poly[i];
        let (x1, y1) = poly[(i + 1) % n];
        if (y0 > y) != (y1 > y) {
            let t = (y - y0) / (y1 - y0);
            if x < x0 + t * (x1 - x0) {
                inside = !inside;
            }
        }
    }
    inside
}

/// A `w`×`h` image with `fg` where a pixel centre is inside the polygon, `bg` elsewhere.
pub fn rasterise(poly: &[(f64, f64)], w: usize, h: usize, fg: u8, bg: u8) -> Vec<u8> {
    let mut img = vec![bg; w * h];
    for y in 0..h {
        for x in 0..w {
            if inside(poly, x as f64, y as f64) {
                img[y * w + x] = fg;
            }
        }
    }
    img
}

/// Smallest difference between two angles in degrees, in `[0, 180]`.
pub fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

/// The README's Rust example, compiled and run as a doctest so it stays true.
#[cfg(doctest)]
#[doc = include_str!("../../README.md")]
pub struct ReadmeDoctests;
