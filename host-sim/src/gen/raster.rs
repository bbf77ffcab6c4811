//! Placing a part in the image and rasterising it.
//!
//! Image coordinates: x right, y down, pixel centres at integers, pixel (i, j) covers
//! [i − ½, i + ½) × [j − ½, j + ½).
//!
//! - [`Pose`]: the similarity that maps the part frame (mm, centroid at the origin) into the image.
//! - [`coverage`]: the area fraction of each pixel covered by the shape, exact along x (span
//!   lengths) and sampled on `subrows` evenly spaced lines per pixel along y. Time
//!   O(rows · subrows · (edges crossing the row) + covered pixels · subrows).
//! - [`fill_centres`]: the pixel-centre rule for the binary templates.
//! - [`clipped_area`]: exact area of the shape inside a rectangle (how much of a part is visible).

use super::shapes::{ring_moments, P};

/// Where a part lies in the image: centroid (px), rotation and scale (px per mm).
///
/// A point `(dx, dy)` mm from the centroid in the part frame maps to
/// `(cx, cy) + k · (dx·cosθ + dy·sinθ, −dx·sinθ + dy·cosθ)`: θ turns the part counter-clockwise
/// as seen on screen (y down).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Pose {
    pub(crate) cx: f64,
    pub(crate) cy: f64,
    pub(crate) cos: f64,
    pub(crate) sin: f64,
    /// px per mm.
    pub(crate) k: f64,
}

impl Pose {
    pub(crate) fn new(cx: f64, cy: f64, angle_deg: f64, k: f64) -> Self {
        let (sin, cos) = angle_deg.to_radians().sin_cos();
        Pose { cx, cy, cos, sin, k }
    }

    /// The same pose moved by `dx` px along x.
    pub(crate) fn shifted(&self, dx: f64) -> Self {
        Pose {
            cx: self.cx + dx,
            ..*self
        }
    }

    /// Part frame (mm) → image (px).
    pub(crate) fn apply(&self, q: P) -> P {
        [
            self.cx + self.k * (q[0] * self.cos + q[1] * self.sin),
            self.cy + self.k * (-q[0] * self.sin + q[1] * self.cos),
        ]
    }

    /// Image (px) → part frame (mm).
    pub(crate) fn invert(&self, p: P) -> P {
        let (dx, dy) = ((p[0] - self.cx) / self.k, (p[1] - self.cy) / self.k);
        [dx * self.cos - dy * self.sin, dx * self.sin + dy * self.cos]
    }

    /// All rings mapped into the image.
    pub(crate) fn rings(&self, rings: &[Vec<P>]) -> Vec<Vec<P>> {
        rings
            .iter()
            .map(|r| r.iter().map(|&q| self.apply(q)).collect())
            .collect()
    }
}

/// Bounding box `[min_x, min_y, max_x, max_y]` of rings.
pub(crate) fn bounds(rings: &[Vec<P>]) -> [f64; 4] {
    let mut b = [f64::MAX, f64::MAX, f64::MIN, f64::MIN];
    for p in rings.iter().flatten() {
        b = [b[0].min(p[0]), b[1].min(p[1]), b[2].max(p[0]), b[3].max(p[1])];
    }
    b
}

/// Area (holes removed) and area centroid of oriented rings (outer positive, holes negative).
pub(crate) fn moments(rings: &[Vec<P>]) -> (f64, P) {
    let (mut area, mut mx, mut my) = (0.0, 0.0, 0.0);
    for ring in rings {
        let (a, c) = ring_moments(ring);
        area += a;
        mx += a * c[0];
        my += a * c[1];
    }
    (area, [mx / area, my / area])
}

/// Per-pixel coverage over a window of the image.
#[derive(Clone, Debug, Default)]
pub(crate) struct Coverage {
    /// Image column of the window's first pixel.
    pub(crate) x0: i64,
    /// Image row of the window's first pixel.
    pub(crate) y0: i64,
    pub(crate) w: usize,
    pub(crate) h: usize,
    /// Row-major, 0..=1.
    pub(crate) data: Vec<f64>,
}

impl Coverage {
    /// Coverage at image pixel (x, y), 0 outside the window.
    pub(crate) fn at(&self, x: i64, y: i64) -> f64 {
        let (i, j) = (x - self.x0, y - self.y0);
        if i < 0 || j < 0 || i >= self.w as i64 || j >= self.h as i64 {
            return 0.0;
        }
        self.data[j as usize * self.w + i as usize]
    }

    /// Total coverage (px²) and its centroid, pixels weighted at their centres.
    #[cfg(test)]
    pub(crate) fn moments(&self) -> (f64, P) {
        let (mut s, mut sx, mut sy) = (0.0, 0.0, 0.0);
        for (j, row) in self.data.chunks_exact(self.w.max(1)).enumerate() {
            for (i, &c) in row.iter().enumerate() {
                s += c;
                sx += c * (self.x0 + i as i64) as f64;
                sy += c * (self.y0 + j as i64) as f64;
            }
        }
        (s, [sx / s, sy / s])
    }

    /// Calls `f(x, y, coverage)` for every pixel with coverage > 0.
    pub(crate) fn for_each(&self, mut f: impl FnMut(i64, i64, f64)) {
        for (j, row) in self.data.chunks_exact(self.w.max(1)).take(self.h).enumerate() {
            for (i, &c) in row.iter().enumerate() {
                if c > 0.0 {
                    f(self.x0 + i as i64, self.y0 + j as i64, c);
                }
            }
        }
    }
}

/// A non-horizontal edge, top end first.
struct Edge {
    y_top: f64,
    y_bot: f64,
    x_top: f64,
    dxdy: f64,
}

fn edges(rings: &[Vec<P>]) -> Vec<Edge> {
    let mut out = Vec::new();
    for ring in rings {
        for (i, &a) in ring.iter().enumerate() {
            let b = ring[(i + 1) % ring.len()];
            if a[1] == b[1] {
                continue;
            }
            let (t, u) = if a[1] < b[1] { (a, b) } else { (b, a) };
            out.push(Edge {
                y_top: t[1],
                y_bot: u[1],
                x_top: t[0],
                dxdy: (u[0] - t[0]) / (u[1] - t[1]),
            });
        }
    }
    out
}

/// Pixel index whose cell contains coordinate `v`.
fn cell(v: f64) -> i64 {
    (v + 0.5).floor() as i64
}

/// Adds `weight` × the overlap of [a, b) with each pixel cell of a row that starts at column
/// `x0` (its cells cover [x0 − ½ + i, x0 + ½ + i)).
fn add_span(row: &mut [f64], x0: i64, a: f64, b: f64, weight: f64) {
    let lo = x0 as f64 - 0.5;
    let hi = lo + row.len() as f64;
    let (a, b) = (a.max(lo), b.min(hi));
    if b <= a {
        return;
    }
    let last = row.len() - 1;
    let ia = ((a - lo).floor() as usize).min(last);
    let ib = ((b - lo).floor() as usize).min(last);
    if ia == ib {
        row[ia] += (b - a) * weight;
        return;
    }
    row[ia] += (lo + ia as f64 + 1.0 - a) * weight;
    for v in &mut row[ia + 1..ib] {
        *v += weight;
    }
    row[ib] += (b - (lo + ib as f64)) * weight;
}

/// Coverage of the even–odd filled `rings` (image px), clipped to a `clip` = (width, height)
/// image when given. Each pixel row is sampled on `subrows` lines; along each line the covered
/// length of every pixel is exact.
pub(crate) fn coverage(rings: &[Vec<P>], clip: Option<(usize, usize)>, subrows: usize) -> Coverage {
    let b = bounds(rings);
    let (mut x0, mut y0, mut x1, mut y1) = (cell(b[0]), cell(b[1]), cell(b[2]), cell(b[3]));
    if let Some((w, h)) = clip {
        x0 = x0.max(0);
        y0 = y0.max(0);
        x1 = x1.min(w as i64 - 1);
        y1 = y1.min(h as i64 - 1);
    }
    if x1 < x0 || y1 < y0 {
        return Coverage::default();
    }
    let (w, h) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    let es = edges(rings);
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); h];
    for (n, e) in es.iter().enumerate() {
        let (r0, r1) = (cell(e.y_top).max(y0), cell(e.y_bot).min(y1));
        for r in r0..=r1 {
            buckets[(r - y0) as usize].push(n as u32);
        }
    }
    let mut data = vec![0.0; w * h];
    let weight = 1.0 / subrows as f64;
    let mut xs: Vec<f64> = Vec::new();
    for (j, row) in data.chunks_exact_mut(w).enumerate() {
        let yr = (y0 + j as i64) as f64;
        for k in 0..subrows {
            let ys = yr - 0.5 + (k as f64 + 0.5) * weight;
            xs.clear();
            for &n in &buckets[j] {
                let e = &es[n as usize];
                if e.y_top <= ys && ys < e.y_bot {
                    xs.push(e.x_top + (ys - e.y_top) * e.dxdy);
                }
            }
            xs.sort_by(f64::total_cmp);
            for pair in xs.chunks_exact(2) {
                add_span(row, x0, pair[0], pair[1], weight);
            }
        }
    }
    Coverage { x0, y0, w, h, data }
}

/// Coverage of the union of several shapes, each a set of even–odd filled rings (image px),
/// clipped to a `clip` = (width, height) image when given. Sampled as [`coverage`]: `subrows`
/// lines per pixel row, along each line the covered length of every pixel exact (the spans of
/// every shape are merged before they are added).
pub(crate) fn coverage_union(shapes: &[Vec<Vec<P>>], clip: Option<(usize, usize)>, subrows: usize) -> Coverage {
    let all: Vec<Vec<P>> = shapes.iter().flatten().cloned().collect();
    if all.is_empty() {
        return Coverage::default();
    }
    let b = bounds(&all);
    let (mut x0, mut y0, mut x1, mut y1) = (cell(b[0]), cell(b[1]), cell(b[2]), cell(b[3]));
    if let Some((w, h)) = clip {
        x0 = x0.max(0);
        y0 = y0.max(0);
        x1 = x1.min(w as i64 - 1);
        y1 = y1.min(h as i64 - 1);
    }
    if x1 < x0 || y1 < y0 {
        return Coverage::default();
    }
    let (w, h) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    // Edges tagged with their shape.
    let es: Vec<(u32, Edge)> = shapes
        .iter()
        .enumerate()
        .flat_map(|(n, s)| edges(s).into_iter().map(move |e| (n as u32, e)))
        .collect();
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); h];
    for (n, (_, e)) in es.iter().enumerate() {
        let (r0, r1) = (cell(e.y_top).max(y0), cell(e.y_bot).min(y1));
        for r in r0..=r1 {
            buckets[(r - y0) as usize].push(n as u32);
        }
    }
    let mut data = vec![0.0; w * h];
    let weight = 1.0 / subrows as f64;
    let mut xs: Vec<(u32, f64)> = Vec::new();
    let mut spans: Vec<(f64, f64)> = Vec::new();
    for (j, row) in data.chunks_exact_mut(w).enumerate() {
        let yr = (y0 + j as i64) as f64;
        for k in 0..subrows {
            let ys = yr - 0.5 + (k as f64 + 0.5) * weight;
            xs.clear();
            for &n in &buckets[j] {
                let (shape, e) = &es[n as usize];
                if e.y_top <= ys && ys < e.y_bot {
                    xs.push((*shape, e.x_top + (ys - e.y_top) * e.dxdy));
                }
            }
            // Even–odd spans of each shape, then their union.
            xs.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
            spans.clear();
            for pair in xs.chunk_by(|a, b| a.0 == b.0).flat_map(|s| s.chunks_exact(2)) {
                spans.push((pair[0].1, pair[1].1));
            }
            spans.sort_by(|a, b| a.0.total_cmp(&b.0));
            let mut open: Option<(f64, f64)> = None;
            for &(a, b) in &spans {
                match open {
                    Some((oa, ob)) if a <= ob => open = Some((oa, ob.max(b))),
                    Some((oa, ob)) => {
                        add_span(row, x0, oa, ob, weight);
                        open = Some((a, b));
                    }
                    None => open = Some((a, b)),
                }
            }
            if let Some((a, b)) = open {
                add_span(row, x0, a, b, weight);
            }
        }
    }
    Coverage { x0, y0, w, h, data }
}

/// Binary raster by the pixel-centre rule: pixel (i, j) of a `w`×`h` image is set iff its centre
/// (i, j) is inside the even–odd filled `rings`. Row-major.
pub(crate) fn fill_centres(rings: &[Vec<P>], w: usize, h: usize) -> Vec<bool> {
    let es = edges(rings);
    // Edges by the first row whose centre they reach; an edge spans rows ceil(y_top)..ceil(y_bot).
    let mut starts: Vec<Vec<u32>> = vec![Vec::new(); h];
    for (n, e) in es.iter().enumerate() {
        let r = e.y_top.ceil().max(0.0) as usize;
        if r < h && (r as f64) < e.y_bot {
            starts[r].push(n as u32);
        }
    }
    let mut out = vec![false; w * h];
    let mut active: Vec<u32> = Vec::new();
    let mut xs: Vec<f64> = Vec::new();
    for (j, row) in out.chunks_exact_mut(w).enumerate() {
        let y = j as f64;
        active.extend_from_slice(&starts[j]);
        active.retain(|&n| y < es[n as usize].y_bot);
        xs.clear();
        xs.extend(active.iter().map(|&n| {
            let e = &es[n as usize];
            e.x_top + (y - e.y_top) * e.dxdy
        }));
        xs.sort_by(f64::total_cmp);
        for pair in xs.chunks_exact(2) {
            // Centres i with pair[0] <= i < pair[1].
            let a = pair[0].ceil().max(0.0) as usize;
            let b = (pair[1].ceil().max(0.0) as usize).min(w);
            for v in row.iter_mut().take(b).skip(a) {
                *v = true;
            }
        }
    }
    out
}

/// Clips a ring to the half-plane `keep(p)`; `cut(a, b)` is where edge a→b leaves or enters it.
fn clip_ring(ring: &[P], keep: impl Fn(P) -> bool, cut: impl Fn(P, P) -> P) -> Vec<P> {
    let mut out = Vec::with_capacity(ring.len() + 4);
    for (i, &a) in ring.iter().enumerate() {
        let b = ring[(i + 1) % ring.len()];
        match (keep(a), keep(b)) {
            (true, true) => out.push(b),
            (true, false) => out.push(cut(a, b)),
            (false, true) => {
                out.push(cut(a, b));
                out.push(b);
            }
            (false, false) => {}
        }
    }
    out
}

/// Area of oriented rings (outer positive, holes negative) inside `[x0, x1] × [y0, y1]`
/// (Sutherland–Hodgman per ring; exact for polygons).
pub(crate) fn clipped_area(rings: &[Vec<P>], rect: [f64; 4]) -> f64 {
    let at_x = |x: f64| move |a: P, b: P| [x, a[1] + (x - a[0]) * (b[1] - a[1]) / (b[0] - a[0])];
    let at_y = |y: f64| move |a: P, b: P| [a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1]), y];
    let [x0, y0, x1, y1] = rect;
    rings
        .iter()
        .map(|r| {
            let r = clip_ring(r, |p| p[0] >= x0, at_x(x0));
            let r = clip_ring(&r, |p| p[0] <= x1, at_x(x1));
            let r = clip_ring(&r, |p| p[1] >= y0, at_y(y0));
            let r = clip_ring(&r, |p| p[1] <= y1, at_y(y1));
            if r.len() < 3 {
                0.0
            } else {
                ring_moments(&r).0
            }
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::super::shapes::catalogue;
    use super::*;

    #[test]
    fn gen_angle_convention_is_counter_clockwise_on_screen() {
        // A point to the right of the centroid goes above it (smaller y) at +90°.
        let pose = Pose::new(100.0, 50.0, 90.0, 1.0);
        let p = pose.apply([10.0, 0.0]);
        assert!((p[0] - 100.0).abs() < 1e-12 && (p[1] - 40.0).abs() < 1e-12, "{p:?}");
        // A point below the centroid (y down) goes to the right.
        let p = pose.apply([0.0, 10.0]);
        assert!((p[0] - 110.0).abs() < 1e-12 && (p[1] - 50.0).abs() < 1e-12, "{p:?}");
        // The documented formula, at an arbitrary angle and scale.
        let (th, s, d) = (37.5_f64, 1.02, [3.0, -7.0]);
        let pose = Pose::new(0.0, 0.0, th, s);
        let (sn, cs) = th.to_radians().sin_cos();
        let want = [(d[0] * cs + d[1] * sn) * s, (-d[0] * sn + d[1] * cs) * s];
        let got = pose.apply(d);
        assert!((got[0] - want[0]).abs() < 1e-12 && (got[1] - want[1]).abs() < 1e-12);
        let back = pose.invert(got);
        assert!((back[0] - d[0]).abs() < 1e-12 && (back[1] - d[1]).abs() < 1e-12);
    }

    #[test]
    fn gen_rendered_part_follows_the_angle_convention() {
        // The wrench's jaw opens to the right at angle 0; at 90° CCW its head must be above the
        // centroid. Check against the part's inside test at many points.
        let cat = catalogue();
        let wrench = cat.iter().find(|p| p.name == "wrench").expect("wrench");
        let pose = Pose::new(200.3, 180.7, 90.0, 1.0);
        let cov = coverage(&pose.rings(wrench.rings()), None, 16);
        let mut checked = 0;
        for dy in -80..=80 {
            for dx in -80..=80 {
                let q = [f64::from(dx), f64::from(dy)];
                let p = pose.apply(q);
                let (ix, iy) = (p[0].round() as i64, p[1].round() as i64);
                let c = cov.at(ix, iy);
                // Only pixels well inside or well outside (coverage exactly 0 or 1 and the
                // part's state the same at the pixel's corners).
                let corner = |ox: f64, oy: f64| {
                    let q = pose.invert([ix as f64 + ox, iy as f64 + oy]);
                    wrench.coverage(q[0], q[1])
                };
                let states = [
                    corner(-0.6, -0.6),
                    corner(0.6, -0.6),
                    corner(-0.6, 0.6),
                    corner(0.6, 0.6),
                ];
                if states.iter().all(|&s| s == states[0]) {
                    checked += 1;
                    assert_eq!(c > 0.5, states[0], "at {q:?}");
                }
            }
        }
        assert!(checked > 20_000);
        // The head (far right of the template, where the jaw is) is above the centroid now.
        let b = wrench.bbox_mm();
        let head = pose.apply([b[2] - 20.0, 0.0]);
        assert!(head[1] < 180.7 - 30.0);
    }

    #[test]
    fn gen_coverage_centroid_matches_truth() {
        // For every part, at default and small scale, a few sub-pixel poses.
        let cat = catalogue();
        let mut worst: f64 = 0.0;
        for (n, spec) in cat.iter().enumerate() {
            for (m, &k) in [1.0, 0.4, 1.07].iter().enumerate() {
                let a = 13.7 + 71.3 * (n * 3 + m) as f64;
                let pose = Pose::new(150.0 + 0.137 * n as f64, 140.0 + 0.291 * m as f64, a % 360.0, k);
                let cov = coverage(&pose.rings(spec.rings()), None, 16);
                let (area, c) = cov.moments();
                let err = (c[0] - pose.cx).hypot(c[1] - pose.cy);
                worst = worst.max(err);
                assert!(err < 0.02, "{} at k={k}: centroid off by {err} px", spec.name);
                let want = spec.area_mm2() * k * k;
                assert!(
                    (area - want).abs() / want < 2e-3,
                    "{}: area {area} vs {want}",
                    spec.name
                );
            }
        }
        assert!(worst > 0.0);
    }

    #[test]
    fn gen_union_coverage_merges_shapes() {
        let sq = |x: f64, y: f64, s: f64| vec![vec![[x, y], [x + s, y], [x + s, y + s], [x, y + s]]];
        // One shape: the same as coverage().
        let ring = vec![
            vec![[3.2, 4.1], [20.7, 6.3], [11.1, 19.9]],
            vec![[9.0, 8.0], [12.0, 8.5], [10.0, 11.0]],
        ];
        let (a, b) = (
            coverage(&ring, None, 16),
            coverage_union(std::slice::from_ref(&ring), None, 16),
        );
        assert_eq!((a.x0, a.y0, a.w, a.h), (b.x0, b.y0, b.w, b.h));
        assert!(a.data.iter().zip(&b.data).all(|(p, q)| (p - q).abs() < 1e-12));
        // Two overlapping squares: 100 + 100 − 25.
        let u = coverage_union(&[sq(0.0, 0.0, 10.0), sq(5.0, 5.0, 10.0)], None, 16);
        assert!((u.moments().0 - 175.0).abs() < 1e-9);
        assert!((u.at(7, 7) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn gen_clipped_area_and_fill() {
        let sq = vec![vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]];
        assert!((clipped_area(&sq, [-5.0, -5.0, 100.0, 100.0]) - 100.0).abs() < 1e-12);
        assert!((clipped_area(&sq, [2.5, -5.0, 100.0, 4.0]) - 30.0).abs() < 1e-12);
        let m = fill_centres(&sq, 12, 12);
        // Centres 0..=9 inside on each axis (x in [0, 10), y in [0, 10)).
        assert_eq!(m.iter().filter(|&&v| v).count(), 100);
        assert!(m[0] && m[9 * 12 + 9] && !m[10]);
        let cov = coverage(&sq, None, 8);
        let (a, c) = cov.moments();
        assert!((a - 100.0).abs() < 1e-9 && (c[0] - 5.0).abs() < 1e-9 && (c[1] - 5.0).abs() < 1e-9);
        assert!((cov.at(0, 0) - 0.25).abs() < 1e-12 && (cov.at(5, 5) - 1.0).abs() < 1e-12);
    }
}
