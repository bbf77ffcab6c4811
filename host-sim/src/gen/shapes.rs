//! The part catalogue: each part a set of polygon rings in its own millimetre frame.
//!
//! Frame of a part: x right, y down (as seen on screen at the reference pose, angle 0), origin at
//! the area centroid of the silhouette (shape minus holes). Rings are filled by the even–odd rule;
//! outer borders are stored with a positive shoelace area, holes with a negative one. Curves are
//! polygons whose chord error is below [`ARC_TOL_MM`], and the polygon *is* the shape: area and
//! centroid are exact (shoelace formulas), and the renderer, the templates and the truth all use
//! the same vertices.

use std::f64::consts::{PI, TAU};

use super::rng::Rng;
use super::{ROD_EYE, ROD_HEAD, ROD_STRETCH};

/// A point in mm (part frame) or px (image), `[x, y]`, y down.
pub(crate) type P = [f64; 2];

/// Largest distance between a sampled arc and the true circle, mm.
pub(crate) const ARC_TOL_MM: f64 = 0.005;

pub(crate) fn add(a: P, b: P) -> P {
    [a[0] + b[0], a[1] + b[1]]
}
pub(crate) fn sub(a: P, b: P) -> P {
    [a[0] - b[0], a[1] - b[1]]
}
pub(crate) fn mul(a: P, s: f64) -> P {
    [a[0] * s, a[1] * s]
}
pub(crate) fn dot(a: P, b: P) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}
pub(crate) fn norm(a: P) -> f64 {
    dot(a, a).sqrt()
}
fn unit(a: P) -> P {
    mul(a, 1.0 / norm(a))
}
fn polar(c: P, r: f64, a: f64) -> P {
    [c[0] + r * a.cos(), c[1] + r * a.sin()]
}

/// Signed shoelace area and centroid of one ring.
pub(crate) fn ring_moments(ring: &[P]) -> (f64, P) {
    let (mut a2, mut mx, mut my) = (0.0, 0.0, 0.0);
    for (i, p) in ring.iter().enumerate() {
        let q = ring[(i + 1) % ring.len()];
        let cr = p[0] * q[1] - q[0] * p[1];
        a2 += cr;
        mx += (p[0] + q[0]) * cr;
        my += (p[1] + q[1]) * cr;
    }
    let area = a2 / 2.0;
    if area == 0.0 {
        return (0.0, [0.0, 0.0]);
    }
    (area, [mx / (3.0 * a2), my / (3.0 * a2)])
}

/// Even–odd inside test of a point against rings (half-open in y, like the rasteriser).
pub(crate) fn inside(rings: &[Vec<P>], x: f64, y: f64) -> bool {
    let mut odd = false;
    for ring in rings {
        for (i, a) in ring.iter().enumerate() {
            let b = ring[(i + 1) % ring.len()];
            if (a[1] > y) != (b[1] > y) {
                let xi = a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
                if x < xi {
                    odd = !odd;
                }
            }
        }
    }
    odd
}

/// A closed path built from points, straight segments between them and sampled arcs.
struct Path(Vec<P>);

impl Path {
    fn new() -> Self {
        Path(Vec::new())
    }

    /// Appends a point (a straight segment from the previous one); drops exact repeats.
    fn to(&mut self, p: P) {
        if self.0.last().is_none_or(|l| norm(sub(*l, p)) > 1e-9) {
            self.0.push(p);
        }
    }

    /// Appends the arc around `c` of radius `r` from angle `a0` to `a1` (radians, either way;
    /// angles measured from +x towards +y), both ends included.
    fn arc(&mut self, c: P, r: f64, a0: f64, a1: f64) {
        let step = 2.0 * (1.0 - ARC_TOL_MM / r).clamp(-1.0, 1.0).acos();
        let n = ((a1 - a0).abs() / step).ceil().max(2.0) as usize;
        for i in 0..=n {
            self.to(polar(c, r, a0 + (a1 - a0) * i as f64 / n as f64));
        }
    }

    fn finish(mut self) -> Vec<P> {
        while self.0.len() > 1 && norm(sub(self.0[0], *self.0.last().unwrap_or(&[0.0; 2]))) <= 1e-9 {
            self.0.pop();
        }
        self.0
    }
}

fn circle(c: P, r: f64) -> Vec<P> {
    let mut p = Path::new();
    p.arc(c, r, 0.0, TAU);
    p.finish()
}

/// A polygon with each corner rounded by a fillet of the given radius (0 = sharp). Works for
/// convex and concave corners; the fillets of one edge must fit on it.
fn rounded_polygon(corners: &[(P, f64)]) -> Vec<P> {
    let n = corners.len();
    let mut path = Path::new();
    for i in 0..n {
        let (b, r) = corners[i];
        if r <= 0.0 {
            path.to(b);
            continue;
        }
        let a = corners[(i + n - 1) % n].0;
        let c = corners[(i + 1) % n].0;
        let (u1, u2) = (unit(sub(a, b)), unit(sub(c, b)));
        let half = dot(u1, u2).clamp(-1.0, 1.0).acos() / 2.0;
        let t = r / half.tan();
        let (p1, p2) = (add(b, mul(u1, t)), add(b, mul(u2, t)));
        let centre = add(b, mul(unit(add(u1, u2)), r / half.sin()));
        let a0 = (p1[1] - centre[1]).atan2(p1[0] - centre[0]);
        let a1 = (p2[1] - centre[1]).atan2(p2[0] - centre[0]);
        let mut d = a1 - a0;
        while d > PI {
            d -= TAU;
        }
        while d < -PI {
            d += TAU;
        }
        path.arc(centre, r, a0, a0 + d);
    }
    path.finish()
}

/// Convex hull (monotone chain) of points.
pub(crate) fn convex_hull(mut pts: Vec<P>) -> Vec<P> {
    pts.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    pts.dedup();
    let cross = |o: P, a: P, b: P| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    let mut hull: Vec<P> = Vec::with_capacity(pts.len() + 1);
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &P>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// A silhouette: rings (even–odd), centred on its area centroid.
#[derive(Clone, Debug)]
pub(crate) struct Shape {
    /// Outer borders (positive shoelace area) and holes (negative), mm, centroid at the origin.
    pub(crate) rings: Vec<Vec<P>>,
    /// Area, mm².
    pub(crate) area: f64,
    /// Largest distance of a vertex from the centroid, mm.
    pub(crate) radius: f64,
    /// `[min_x, min_y, max_x, max_y]`, mm.
    pub(crate) bbox: [f64; 4],
}

impl Shape {
    /// Orients the rings (a ring is a hole when it lies inside an odd number of the others),
    /// moves the area centroid to the origin and measures the shape.
    fn new(mut rings: Vec<Vec<P>>) -> Self {
        let depth_odd: Vec<bool> = (0..rings.len())
            .map(|i| {
                let p = rings[i][0];
                let others: Vec<Vec<P>> = rings
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| *j != i)
                    .map(|(_, r)| r.clone())
                    .collect();
                inside(&others, p[0], p[1])
            })
            .collect();
        for (ring, hole) in rings.iter_mut().zip(&depth_odd) {
            let (a, _) = ring_moments(ring);
            if (a < 0.0) != *hole {
                ring.reverse();
            }
        }
        let (mut area, mut mx, mut my) = (0.0, 0.0, 0.0);
        for ring in &rings {
            let (a, c) = ring_moments(ring);
            area += a;
            mx += a * c[0];
            my += a * c[1];
        }
        let c = [mx / area, my / area];
        for ring in &mut rings {
            for p in ring.iter_mut() {
                *p = sub(*p, c);
            }
        }
        let mut bbox = [f64::MAX, f64::MAX, f64::MIN, f64::MIN];
        let mut radius: f64 = 0.0;
        for p in rings.iter().flatten() {
            bbox = [
                bbox[0].min(p[0]),
                bbox[1].min(p[1]),
                bbox[2].max(p[0]),
                bbox[3].max(p[1]),
            ];
            radius = radius.max(norm(*p));
        }
        Shape {
            rings,
            area,
            radius,
            bbox,
        }
    }
}

/// One part of the catalogue: a template class or a distractor.
#[derive(Clone, Debug)]
pub struct PartSpec {
    /// Class name (the template file stem); distractors are written with class `null`.
    pub name: &'static str,
    /// A known part with a template (`false`: a distractor, not a template).
    pub is_template: bool,
    /// n for n-fold rotational symmetry; 0 = rotation undefined (a ring), 1 = none.
    pub symmetry: u32,
    pub(crate) shape: Shape,
    /// How the part varies part to part (the `rods` catalogue), or fixed.
    pub(crate) model: Model,
}

impl PartSpec {
    /// Inside test in the part's own frame: `x_mm`, `y_mm` from the area centroid, x right,
    /// y down, at the reference pose. Holes are outside.
    pub fn coverage(&self, x_mm: f64, y_mm: f64) -> bool {
        inside(&self.shape.rings, x_mm, y_mm)
    }

    /// The polygon rings (outer borders counter-clockwise in the shoelace sense, holes the other
    /// way), mm, centroid at the origin.
    pub fn rings(&self) -> &[Vec<[f64; 2]>] {
        &self.shape.rings
    }

    /// Area of the silhouette (holes removed), mm².
    pub fn area_mm2(&self) -> f64 {
        self.shape.area
    }

    /// Radius of the bounding circle about the centroid, mm.
    pub fn radius_mm(&self) -> f64 {
        self.shape.radius
    }

    /// Bounding box `[min_x, min_y, max_x, max_y]` at the reference pose, mm from the centroid.
    pub fn bbox_mm(&self) -> [f64; 4] {
        self.shape.bbox
    }
}

/// [`PartSpec::mirror_gap`] from which a part is chiral: 1 % of its size. Exact mirror axes give
/// well under 0.1 %, the catalogue's chiral parts 3 % and more.
pub(crate) const CHIRAL_GAP: f64 = 0.01;

impl PartSpec {
    /// The part lying upside down: mirrored left-right about its centroid (`x → −x` in its own
    /// frame), with the same name, class and symmetry (DESIGN.md, "Contracts").
    pub(crate) fn mirrored(&self) -> PartSpec {
        let rings = self
            .shape
            .rings
            .iter()
            .map(|r| r.iter().map(|p| [-p[0], p[1]]).collect())
            .collect();
        PartSpec {
            shape: Shape::new(rings),
            model: Model::Fixed,
            ..self.clone()
        }
    }

    /// Whether the mirror image of the part matches no turn of it ([`Self::mirror_gap`] at
    /// least [`CHIRAL_GAP`]): lying upside down, it is another shape.
    pub(crate) fn is_chiral(&self) -> bool {
        self.mirror_gap() >= CHIRAL_GAP
    }

    /// Mean distance of points spread evenly along every ring (holes included), mirrored and
    /// turned to where they fit best, to the nearest edge of the part's rings, over the size
    /// `√(area/π)`: 0 for a part with a mirror axis. The turn: every 2° on a quarter of the
    /// points, then the three lowest minima by golden-section search on all of them.
    pub(crate) fn mirror_gap(&self) -> f64 {
        let rings = &self.shape.rings;
        let samples = boundary_samples(rings, 160);
        let size = (self.shape.area / PI).sqrt();
        if samples.is_empty() || size.is_nan() || size <= 0.0 {
            return 0.0;
        }
        let gap = |theta: f64, step: usize| {
            let (s, c) = theta.sin_cos();
            let pts: Vec<P> = samples.iter().step_by(step).copied().collect();
            let total: f64 = pts
                .iter()
                .map(|p| {
                    let m = [-p[0], p[1]];
                    ring_distance(rings, [m[0] * c - m[1] * s, m[0] * s + m[1] * c])
                })
                .sum();
            total / pts.len() as f64
        };
        let coarse: Vec<f64> = (0..180).map(|k| gap((2.0 * k as f64).to_radians(), 4)).collect();
        let mut minima: Vec<(f64, usize)> = (0..180)
            .filter(|&k| coarse[k] <= coarse[(k + 179) % 180] && coarse[k] <= coarse[(k + 1) % 180])
            .map(|k| (coarse[k], k))
            .collect();
        minima.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut best = f64::INFINITY;
        for &(_, k) in minima.iter().take(3) {
            let (mut a, mut b) = ((2.0 * k as f64 - 2.0).to_radians(), (2.0 * k as f64 + 2.0).to_radians());
            let phi = (5f64.sqrt() - 1.0) / 2.0;
            for _ in 0..24 {
                let (x1, x2) = (b - phi * (b - a), a + phi * (b - a));
                if gap(x1, 1) <= gap(x2, 1) {
                    b = x2;
                } else {
                    a = x1;
                }
            }
            best = best.min(gap(0.5 * (a + b), 1));
        }
        best / size
    }
}

/// About `count` points spread evenly by length along all the rings.
fn boundary_samples(rings: &[Vec<P>], count: usize) -> Vec<P> {
    let segments = || {
        rings
            .iter()
            .flat_map(|r| (0..r.len()).map(move |i| (r[i], r[(i + 1) % r.len()])))
    };
    let total: f64 = segments().map(|(a, b)| norm(sub(b, a))).sum();
    if total.is_nan() || total <= 0.0 {
        return Vec::new();
    }
    let spacing = total / count as f64;
    let mut out = Vec::new();
    let mut carry = 0.0;
    for (a, b) in segments() {
        let len = norm(sub(b, a));
        let mut t = carry;
        while t < len {
            let u = t / len;
            out.push([a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])]);
            t += spacing;
        }
        carry = t - len;
    }
    out
}

/// Distance from `p` to the nearest edge of any ring.
fn ring_distance(rings: &[Vec<P>], p: P) -> f64 {
    let mut best = f64::INFINITY;
    for r in rings {
        for i in 0..r.len() {
            let (a, b) = (r[i], r[(i + 1) % r.len()]);
            let ab = sub(b, a);
            let len2 = ab[0] * ab[0] + ab[1] * ab[1];
            let t = if len2 > 0.0 {
                (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            best = best.min(norm(sub(p, [a[0] + t * ab[0], a[1] + t * ab[1]])));
        }
    }
    best
}

fn part(name: &'static str, is_template: bool, symmetry: u32, rings: Vec<Vec<P>>) -> PartSpec {
    PartSpec {
        name,
        is_template,
        symmetry,
        shape: Shape::new(rings),
        model: Model::Fixed,
    }
}

/// Spur gear outline: trapezoidal teeth between root and tip circle, centred round bore.
fn gear(z: u32) -> Vec<Vec<P>> {
    let (r_tip, r_root, r_bore) = (58.0, 46.0, 16.0);
    let pitch = TAU / f64::from(z);
    let (tip, root) = (0.20 * pitch, 0.32 * pitch);
    let mut p = Path::new();
    for k in 0..z {
        let phi = f64::from(k) * pitch;
        p.arc([0.0, 0.0], r_root, phi - pitch / 2.0, phi - root);
        p.arc([0.0, 0.0], r_tip, phi - tip, phi + tip);
        p.arc([0.0, 0.0], r_root, phi + root, phi + pitch / 2.0);
    }
    vec![p.finish(), circle([0.0, 0.0], r_bore)]
}

fn l_bracket() -> Vec<Vec<P>> {
    let outline = rounded_polygon(&[
        ([0.0, 0.0], 6.0),
        ([110.0, 0.0], 6.0),
        ([110.0, 34.0], 6.0),
        ([34.0, 34.0], 8.0),
        ([34.0, 100.0], 6.0),
        ([0.0, 100.0], 6.0),
    ]);
    vec![outline, circle([90.0, 17.0], 6.0), circle([17.0, 80.0], 6.0)]
}

/// A J hook (chiral: its mirror image lies far from every turn of it): a shank 18 × 96, a foot
/// 54 × 18 under it and a tip 18 × 34 up from the foot's far end, rounded corners.
fn hook() -> Vec<Vec<P>> {
    vec![rounded_polygon(&[
        ([0.0, 0.0], 4.0),
        ([18.0, 0.0], 4.0),
        ([18.0, 78.0], 4.0),
        ([36.0, 78.0], 4.0),
        ([36.0, 44.0], 4.0),
        ([54.0, 44.0], 4.0),
        ([54.0, 96.0], 4.0),
        ([0.0, 96.0], 4.0),
    ])]
}

/// A long L bracket (chiral, its mirror image nearer its turns than the hook's): an arm of
/// 130 × 22 and a foot 22 × 52 at one end, one hole in the arm's far end.
fn l_long() -> Vec<Vec<P>> {
    let outline = rounded_polygon(&[
        ([0.0, 0.0], 5.0),
        ([130.0, 0.0], 5.0),
        ([130.0, 22.0], 5.0),
        ([22.0, 22.0], 5.0),
        ([22.0, 52.0], 5.0),
        ([0.0, 52.0], 5.0),
    ]);
    vec![outline, circle([115.0, 11.0], 5.0)]
}

fn t_bracket() -> Vec<Vec<P>> {
    let outline = rounded_polygon(&[
        ([-65.0, 0.0], 5.0),
        ([65.0, 0.0], 5.0),
        ([65.0, 32.0], 5.0),
        ([17.0, 32.0], 8.0),
        ([17.0, 112.0], 5.0),
        ([-17.0, 112.0], 5.0),
        ([-17.0, 32.0], 8.0),
        ([-65.0, 32.0], 5.0),
    ]);
    vec![
        outline,
        circle([-48.0, 16.0], 5.5),
        circle([48.0, 16.0], 5.5),
        circle([0.0, 92.0], 5.5),
    ]
}

fn hex_nut() -> Vec<Vec<P>> {
    let r = 40.0 / (PI / 6.0).cos(); // 80 mm across flats
    let corners: Vec<(P, f64)> = (0..6)
        .map(|k| (polar([0.0, 0.0], r, f64::from(k) * PI / 3.0), 3.0))
        .collect();
    vec![rounded_polygon(&corners), circle([0.0, 0.0], 22.0)]
}

fn washer() -> Vec<Vec<P>> {
    vec![circle([0.0, 0.0], 44.0), circle([0.0, 0.0], 20.0)]
}

/// Oval two-bolt flange: hull of the hub disc and two bolt lugs, bore and two bolt holes.
fn flange_oval() -> Vec<Vec<P>> {
    let mut pts = circle([0.0, 0.0], 34.0);
    pts.extend(circle([54.0, 0.0], 15.0));
    pts.extend(circle([-54.0, 0.0], 15.0));
    vec![
        convex_hull(pts),
        circle([0.0, 0.0], 18.0),
        circle([54.0, 0.0], 6.5),
        circle([-54.0, 0.0], 6.5),
    ]
}

/// Square four-bolt flange with rounded corners and a centre bore.
fn flange_square() -> Vec<Vec<P>> {
    let s = 50.0;
    let outline = rounded_polygon(&[([-s, -s], 14.0), ([s, -s], 14.0), ([s, s], 14.0), ([-s, s], 14.0)]);
    let mut rings = vec![outline, circle([0.0, 0.0], 24.0)];
    for (x, y) in [(-32.0, -32.0), (32.0, -32.0), (32.0, 32.0), (-32.0, 32.0)] {
        rings.push(circle([x, y], 6.5));
    }
    rings
}

/// Parallel shaft key with rounded ends and a notch on one long side, off centre.
fn shaft_key() -> Vec<Vec<P>> {
    vec![rounded_polygon(&[
        ([-65.0, -18.0], 16.0),
        ([14.0, -18.0], 1.5),
        ([14.0, -9.0], 2.0),
        ([32.0, -9.0], 2.0),
        ([32.0, -18.0], 1.5),
        ([65.0, -18.0], 16.0),
        ([65.0, 18.0], 16.0),
        ([-65.0, 18.0], 16.0),
    ])]
}

/// Open-end wrench: round head with a jaw slot at 15° to the handle, handle with a round end.
fn wrench() -> Vec<Vec<P>> {
    let (r_head, h, w, s0, len) = (28.0_f64, 9.0_f64, 12.0, -3.0, 95.0);
    let ja = 15.0_f64.to_radians();
    let d = [ja.cos(), ja.sin()];
    let n = [-ja.sin(), ja.cos()];
    let o = [0.0, 0.0];
    let xj = -(r_head * r_head - h * h).sqrt();
    let a_junction = h.atan2(xj);
    let half = (w / r_head).asin();
    let q = mul(d, s0);
    let mut p = Path::new();
    p.to([-len, h]);
    p.to([xj, h]);
    p.arc(o, r_head, a_junction, ja + half);
    p.to(add(q, mul(n, w)));
    p.arc(q, w, ja + PI / 2.0, ja + 1.5 * PI);
    p.arc(o, r_head, ja - half, -a_junction);
    p.to([-len, -h]);
    p.arc([-len, 0.0], h, -PI / 2.0, -1.5 * PI);
    vec![p.finish()]
}

/// Eccentric cam: hull of the base circle and the lobe circle, bore on the base circle's axis.
fn cam() -> Vec<Vec<P>> {
    let mut pts = circle([0.0, 0.0], 36.0);
    pts.extend(circle([38.0, 0.0], 16.0));
    vec![convex_hull(pts), circle([0.0, 0.0], 11.0)]
}

/// Rectangular plate with a centred long slot.
fn slotted_plate() -> Vec<Vec<P>> {
    let outline = rounded_polygon(&[
        ([-60.0, -28.0], 6.0),
        ([60.0, -28.0], 6.0),
        ([60.0, 28.0], 6.0),
        ([-60.0, 28.0], 6.0),
    ]);
    let mut slot = Path::new();
    slot.arc([32.0, 0.0], 8.0, -PI / 2.0, PI / 2.0);
    slot.arc([-32.0, 0.0], 8.0, PI / 2.0, 1.5 * PI);
    vec![outline, slot.finish()]
}

/// U bracket (clevis): base and two arms with a hole near each arm's end.
fn u_bracket() -> Vec<Vec<P>> {
    let outline = rounded_polygon(&[
        ([0.0, 0.0], 6.0),
        ([100.0, 0.0], 6.0),
        ([100.0, 90.0], 4.0),
        ([74.0, 90.0], 4.0),
        ([74.0, 28.0], 6.0),
        ([26.0, 28.0], 6.0),
        ([26.0, 90.0], 4.0),
        ([0.0, 90.0], 4.0),
    ]);
    vec![outline, circle([13.0, 72.0], 6.0), circle([87.0, 72.0], 6.0)]
}

/// Distractor: five-pointed star.
fn star() -> Vec<Vec<P>> {
    let pts = (0..10)
        .map(|k| {
            let r = if k % 2 == 0 { 60.0 } else { 25.0 };
            polar([0.0, 0.0], r, f64::from(k) * PI / 5.0 - PI / 2.0)
        })
        .collect();
    vec![pts]
}

/// Distractor: crescent, a disc minus an offset disc.
fn crescent() -> Vec<Vec<P>> {
    let (big, c, small) = (48.0_f64, 22.0, 40.0);
    let x = (big * big - small * small + c * c) / (2.0 * c);
    let y = (big * big - x * x).sqrt();
    let a_out = y.atan2(x);
    let a_in = y.atan2(x - c);
    let mut p = Path::new();
    p.arc([0.0, 0.0], big, a_out, TAU - a_out);
    p.arc([c, 0.0], small, -a_in, -TAU + a_in);
    vec![p.finish()]
}

/// Distractor: an irregular smooth blob (fixed low-order Fourier outline).
fn blob() -> Vec<Vec<P>> {
    let n = 900;
    let pts = (0..n)
        .map(|i| {
            let t = TAU * f64::from(i) / f64::from(n);
            let r = 48.0
                * (1.0 + 0.13 * (2.0 * t + 0.4).cos() + 0.09 * (3.0 * t + 1.9).cos() + 0.06 * (5.0 * t + 0.7).cos()
                    - 0.04 * (7.0 * t + 2.3).cos());
            polar([0.0, 0.0], r, t)
        })
        .collect();
    vec![pts]
}

/// A square hole of side `s` about `c`, turned by `a` radians.
fn square(c: P, s: f64, a: f64) -> Vec<P> {
    (0..4)
        .map(|k| {
            polar(
                c,
                s / 2.0 * std::f64::consts::SQRT_2,
                a + PI / 4.0 + f64::from(k) * PI / 2.0,
            )
        })
        .collect()
}

/// Spur gear with sharp rectangular teeth: parallel flanks 11 mm apart, flat tips at 58 mm,
/// root arcs at 44 mm, round bore.
fn gear_sharp(z: u32) -> Vec<Vec<P>> {
    let (r_tip, r_root, r_bore, half) = (58.0_f64, 44.0_f64, 16.0, 5.5_f64);
    let pitch = TAU / f64::from(z);
    let (a_root, a_tip) = ((half / r_root).asin(), (half / r_tip).asin());
    let mut p = Path::new();
    for k in 0..z {
        let phi = f64::from(k) * pitch;
        p.arc([0.0, 0.0], r_root, phi - pitch / 2.0, phi - a_root);
        p.to(polar([0.0, 0.0], r_tip, phi - a_tip));
        p.to(polar([0.0, 0.0], r_tip, phi + a_tip));
        p.arc([0.0, 0.0], r_root, phi + a_root, phi + pitch / 2.0);
    }
    vec![p.finish(), circle([0.0, 0.0], r_bore)]
}

/// Snail (drop) cam: the radius grows linearly from 30 to 56 mm over one turn, then drops back
/// at a sharp radial step; bore on the spiral's axis.
fn cam_snail() -> Vec<Vec<P>> {
    let (r0, r1, n) = (30.0, 56.0, 720);
    let pts = (0..=n)
        .map(|i| {
            let t = f64::from(i) / f64::from(n);
            polar([0.0, 0.0], r0 + (r1 - r0) * t, TAU * t)
        })
        .collect();
    vec![pts, circle([0.0, 0.0], 10.0)]
}

/// L bracket with square corners, a round and a square hole.
fn l_square() -> Vec<Vec<P>> {
    let outline = vec![
        [0.0, 0.0],
        [110.0, 0.0],
        [110.0, 34.0],
        [34.0, 34.0],
        [34.0, 100.0],
        [0.0, 100.0],
    ];
    vec![outline, circle([90.0, 17.0], 6.0), square([17.0, 80.0], 12.0, 0.0)]
}

/// Hexagon with sharp corners, 80 mm across flats, round bore.
fn hex_sharp() -> Vec<Vec<P>> {
    let r = 40.0 / (PI / 6.0).cos();
    let corners: Vec<P> = (0..6).map(|k| polar([0.0, 0.0], r, f64::from(k) * PI / 3.0)).collect();
    vec![corners, circle([0.0, 0.0], 22.0)]
}

/// Rectangular plate, 120 × 60 mm, with a V notch in one long side, a rectangular notch in one
/// end and a square hole turned by 45°.
fn plate_notched() -> Vec<Vec<P>> {
    let outline = vec![
        [-60.0, -30.0],
        [-10.0, -30.0],
        [0.0, -16.0],
        [10.0, -30.0],
        [60.0, -30.0],
        [60.0, -8.0],
        [44.0, -8.0],
        [44.0, 8.0],
        [60.0, 8.0],
        [60.0, 30.0],
        [-60.0, 30.0],
    ];
    vec![outline, square([-35.0, 0.0], 14.0, PI / 4.0)]
}

/// Plus-shaped plate: arms 36 mm wide, 120 mm across, square corners, square centre hole.
fn cross() -> Vec<Vec<P>> {
    let (a, b) = (18.0, 60.0);
    let outline = vec![
        [-a, -b],
        [a, -b],
        [a, -a],
        [b, -a],
        [b, a],
        [a, a],
        [a, b],
        [-a, b],
        [-a, a],
        [-b, a],
        [-b, -a],
        [-a, -a],
    ];
    vec![outline, square([0.0, 0.0], 14.0, 0.0)]
}

/// Distractor: equilateral triangle plate (110 mm sides, sharp corners) with a round hole.
fn triangle() -> Vec<Vec<P>> {
    let r = 110.0 / 3.0_f64.sqrt();
    let corners: Vec<P> = (0..3)
        .map(|k| polar([0.0, 0.0], r, f64::from(k) * TAU / 3.0 - PI / 2.0))
        .collect();
    vec![corners, circle([0.0, 0.0], 12.0)]
}

/// How a part of a catalogue varies from one part to the next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Model {
    /// Every part is drawn as its template (all catalogues but `rods`'s; its washer too).
    Fixed,
    /// A connecting rod of these nominal proportions.
    Rod(Rod),
    /// A screw of these nominal proportions.
    Screw(Screw),
}

/// A connecting rod, mm: the big head (radius `r_big`) centred on the origin, the small head
/// (`r_small < r_big`) at `length` along +x, joined by a straight tapered shaft whose edges run
/// from half-width `w_big` at the big head's centre to `w_small` at the small head's; round eyes
/// (holes) centred in the heads, `eye_small` 0 for a solid small end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Rod {
    pub(crate) r_big: f64,
    pub(crate) r_small: f64,
    pub(crate) length: f64,
    pub(crate) w_big: f64,
    pub(crate) w_small: f64,
    pub(crate) eye_big: f64,
    pub(crate) eye_small: f64,
}

/// `rod_a`: one eye, in the big end.
pub(crate) const ROD_A: Rod = Rod {
    r_big: 24.0,
    r_small: 15.0,
    length: 88.0,
    w_big: 9.0,
    w_small: 6.5,
    eye_big: 11.0,
    eye_small: 0.0,
};

/// `rod_b`: the outline of `rod_a`, a larger eye in the big end and a smaller one in the small end,
/// both with thin rims like the real rods' (8 and 5.5 mm, an eye about 0.65 of its head's
/// radius): too thin for the partial-volume centroid's ring, so its edge pixels there take the
/// fallback contrast, scaled by the backlight's fall-off.
pub(crate) const ROD_B: Rod = Rod {
    eye_big: 16.0,
    eye_small: 9.5,
    ..ROD_A
};

/// Where the line `y = w + s·t` meets the circle of radius `r` about `t = 0, y = 0`: the root `t`
/// of `(1 + s²)t² + 2ws·t + w² − r² = 0` on the side `sign` (±1).
fn meet(w: f64, s: f64, r: f64, sign: f64) -> f64 {
    let a = 1.0 + s * s;
    let disc = (w * s) * (w * s) - a * (w * w - r * r);
    (-w * s + sign * disc.max(0.0).sqrt()) / a
}

impl Rod {
    /// The silhouette: one outline (the two heads and the shaft's two edges) and the eyes.
    pub(crate) fn rings(&self) -> Vec<Vec<P>> {
        let s = (self.w_small - self.w_big) / self.length;
        // The lower shaft edge y = w_big + s·x leaves the big head at x_a and enters the small
        // head at length + u (u < 0); the upper edge is its mirror image.
        let x_a = meet(self.w_big, s, self.r_big, 1.0);
        let u = meet(self.w_small, s, self.r_small, -1.0);
        let alpha = (self.w_big + s * x_a).atan2(x_a);
        let beta = (self.w_small + s * u).atan2(u);
        let mut p = Path::new();
        p.arc([0.0, 0.0], self.r_big, alpha, TAU - alpha);
        p.arc([self.length, 0.0], self.r_small, -beta, beta);
        let mut rings = vec![p.finish(), circle([0.0, 0.0], self.eye_big)];
        if self.eye_small > 0.0 {
            rings.push(circle([self.length, 0.0], self.eye_small));
        }
        rings
    }

    /// A rod of this type as made: the shaft's length times `stretch`, each head's radius and
    /// each eye's radius times its own factor.
    pub(crate) fn scaled(&self, stretch: f64, heads: [f64; 2], eyes: [f64; 2]) -> Rod {
        Rod {
            length: self.length * stretch,
            r_big: self.r_big * heads[0],
            r_small: self.r_small * heads[1],
            eye_big: self.eye_big * eyes[0],
            eye_small: self.eye_small * eyes[1],
            ..*self
        }
    }
}

/// A screw seen from the side, mm: a head `head_len` long and `2·head_half` wide ending at x = 0,
/// then a threaded shank `shank_len` long (threads between half-widths `minor` and `major`, one
/// per `pitch`) with a chamfered tip; no hole.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Screw {
    pub(crate) head_len: f64,
    pub(crate) head_half: f64,
    pub(crate) shank_len: f64,
    pub(crate) major: f64,
    pub(crate) minor: f64,
    pub(crate) pitch: f64,
}

/// The screw of the `rods` catalogue.
pub(crate) const SCREW: Screw = Screw {
    head_len: 9.0,
    head_half: 10.0,
    shank_len: 56.0,
    major: 5.0,
    minor: 4.1,
    pitch: 2.5,
};

impl Screw {
    /// The silhouette: one outline.
    pub(crate) fn rings(&self) -> Vec<Vec<P>> {
        let (t0, t1) = (3.0, self.shank_len - 4.0);
        let turns = ((t1 - t0) / self.pitch).floor() as usize;
        // The upper side, head to tip (y < 0 is up); the lower side is its mirror image.
        let mut upper: Vec<(P, f64)> = vec![
            ([-self.head_len, -self.head_half], 1.5),
            ([0.0, -self.head_half], 0.8),
            ([0.0, -self.major], 0.0),
        ];
        for k in 0..turns {
            let x = t0 + k as f64 * self.pitch;
            upper.push(([x, -self.major], 0.0));
            upper.push(([x + self.pitch / 2.0, -self.minor], 0.0));
        }
        upper.push(([t0 + turns as f64 * self.pitch, -self.major], 0.0));
        upper.push(([self.shank_len, -0.5 * self.minor], 0.0));
        let lower: Vec<(P, f64)> = upper.iter().rev().map(|&(p, r)| ([p[0], -p[1]], r)).collect();
        upper.extend(lower);
        vec![rounded_polygon(&upper)]
    }
}

/// A flat washer: a disc with a central hole.
fn flat_washer() -> Vec<Vec<P>> {
    vec![circle([0.0, 0.0], 20.0), circle([0.0, 0.0], 9.5)]
}

/// A part drawn with proportions of its own (the `rods` catalogue): its shape and how it differs
/// from the nominal one.
#[derive(Clone, Debug)]
pub(crate) struct Varied {
    /// The part as drawn (centroid at its origin, same name, class and symmetry as the template).
    pub(crate) spec: PartSpec,
    /// Length of the shaft (rod) or shank (screw) over the nominal one.
    pub(crate) stretch: f64,
    /// The other factors over the nominal proportions, by truth field name.
    pub(crate) factors: Vec<(&'static str, f64)>,
}

impl PartSpec {
    /// This part as one made with the part-to-part spread of its model ([`super::ROD_STRETCH`],
    /// [`super::ROD_HEAD`], [`super::ROD_EYE`]); `None` for a part that does not vary.
    pub(crate) fn varied(&self, rng: &mut Rng) -> Option<Varied> {
        let (rings, stretch, factors) = match self.model {
            Model::Fixed => return None,
            Model::Rod(rod) => {
                let stretch = rng.range(ROD_STRETCH.0, ROD_STRETCH.1);
                let heads = [rng.range(ROD_HEAD.0, ROD_HEAD.1), rng.range(ROD_HEAD.0, ROD_HEAD.1)];
                let eyes = [rng.range(ROD_EYE.0, ROD_EYE.1), rng.range(ROD_EYE.0, ROD_EYE.1)];
                let mut factors = vec![
                    ("head_big_scale", heads[0]),
                    ("head_small_scale", heads[1]),
                    ("eye_big_scale", eyes[0]),
                ];
                if rod.eye_small > 0.0 {
                    factors.push(("eye_small_scale", eyes[1]));
                }
                (rod.scaled(stretch, heads, eyes).rings(), stretch, factors)
            }
            Model::Screw(screw) => {
                let stretch = rng.range(ROD_STRETCH.0, ROD_STRETCH.1);
                let made = Screw {
                    shank_len: screw.shank_len * stretch,
                    ..screw
                };
                (made.rings(), stretch, Vec::new())
            }
        };
        Some(Varied {
            spec: PartSpec {
                shape: Shape::new(rings),
                ..self.clone()
            },
            stretch,
            factors,
        })
    }
}

/// The parts of the `rods` variant: two connecting rods whose outlines are the same and whose
/// eyes differ (`rod_a` one, `rod_b` two), then a washer and a screw as distractors. Rods and
/// screws vary part to part (`PartSpec::varied`); the templates are the nominal rods.
///
/// The rods are 127 mm long at the nominal proportions, drawn at 1 px/mm.
pub fn rods_catalogue() -> Vec<PartSpec> {
    let with = |model: Model, spec: PartSpec| PartSpec { model, ..spec };
    vec![
        with(Model::Rod(ROD_A), part("rod_a", true, 1, ROD_A.rings())),
        with(Model::Rod(ROD_B), part("rod_b", true, 1, ROD_B.rings())),
        part("flat_washer", false, 0, flat_washer()),
        with(Model::Screw(SCREW), part("screw", false, 1, SCREW.rings())),
    ]
}

/// The parts of the `sharp` variant: sharp-cornered templates (no fillets anywhere), then
/// sharp-cornered distractors.
///
/// Sizes are 92–120 mm across, drawn at 1 px/mm.
pub fn sharp_catalogue() -> Vec<PartSpec> {
    vec![
        part("gear_sharp_z12", true, 12, gear_sharp(12)),
        part("gear_sharp_z10", true, 10, gear_sharp(10)),
        part("cam_snail", true, 1, cam_snail()),
        part("l_square", true, 1, l_square()),
        part("hex_sharp", true, 6, hex_sharp()),
        part("plate_notched", true, 1, plate_notched()),
        part("cross", true, 4, cross()),
        part("star", false, 5, star()),
        part("triangle", false, 3, triangle()),
        part("crescent", false, 1, crescent()),
    ]
}

/// The `flipped` variant's parts: the standard [`catalogue`], two more chiral templates whose
/// mirror images lie far from every turn of them, a J hook and a long L bracket (a part upside
/// down whose template's own turns are all at `f′ ≥ 2ε` from it), and a pin whose two ends
/// only a hole too small for the tracing tells apart (which way round, rather than which side
/// up).
pub fn flipped_catalogue() -> Vec<PartSpec> {
    let mut cat = catalogue();
    let at = cat.iter().position(|p| !p.is_template).unwrap_or(cat.len());
    cat.insert(at, part("pin_end_hole", true, 1, pin_end_hole()));
    cat.insert(at, part("l_long", true, 1, l_long()));
    cat.insert(at, part("hook", true, 1, hook()));
    cat
}

/// A pin: a bar of 100 × 18 with round ends and a hole of radius 3.5 near one end (38 mm², under
/// the tracing's 64 px² at 1 px/mm: the mask shows it as a dip of `|D|`, not as a hole). Its
/// outline is the same half a turn on; only the hole tells its ends apart.
fn pin_end_hole() -> Vec<Vec<P>> {
    let outline = rounded_polygon(&[
        ([0.0, 0.0], 9.0),
        ([100.0, 0.0], 9.0),
        ([100.0, 18.0], 9.0),
        ([0.0, 18.0], 9.0),
    ]);
    vec![outline, circle([88.0, 9.0], 3.5)]
}

/// The parts: templates first (in a fixed order), then the distractors.
///
/// Sizes are 88–138 mm across, drawn at 1 px/mm by default (0.4 px/mm in the `small` variant).
pub fn catalogue() -> Vec<PartSpec> {
    vec![
        part("gear_z10", true, 10, gear(10)),
        part("gear_z12", true, 12, gear(12)),
        part("l_bracket", true, 1, l_bracket()),
        part("t_bracket", true, 1, t_bracket()),
        part("hex_nut", true, 6, hex_nut()),
        part("washer", true, 0, washer()),
        part("flange_oval", true, 2, flange_oval()),
        part("flange_square", true, 4, flange_square()),
        part("shaft_key", true, 1, shaft_key()),
        part("wrench", true, 1, wrench()),
        part("cam", true, 1, cam()),
        part("slotted_plate", true, 2, slotted_plate()),
        part("u_bracket", true, 1, u_bracket()),
        part("star", false, 5, star()),
        part("crescent", false, 1, crescent()),
        part("blob", false, 1, blob()),
    ]
}

/// The standard [`catalogue`] with untaught look-alikes among its distractors: templates with
/// a bore or holes drawn solid (their outer outline only, so a template fits their outline and
/// not their holes): a cam, a hex nut, a 12-tooth gear, a disc the washer's size, an oval
/// flange, and an L and a U bracket (holes of 6 mm radius, under the widest wall the
/// alignment admits, which once let any such hole pass unseen: another generator's random
/// blobs passed for a cam that way), each without a hole;
/// and a hex nut and a washer whose bore is half as wide as the template's (a hole where the
/// template's is, of a size it could not be found at).
pub fn lookalike_catalogue() -> Vec<PartSpec> {
    let solid = |rings: Vec<Vec<P>>| {
        let outer = rings
            .into_iter()
            .max_by(|a, b| ring_moments(a).0.abs().total_cmp(&ring_moments(b).0.abs()))
            .unwrap_or_default();
        vec![outer]
    };
    let mut cat = catalogue();
    cat.extend([
        part("cam_solid", false, 1, solid(cam())),
        part("hex_solid", false, 6, solid(hex_nut())),
        part("gear_z12_solid", false, 12, solid(gear(12))),
        part("disc", false, 0, solid(washer())),
        part("flange_oval_solid", false, 2, solid(flange_oval())),
        part("hex_small_bore", false, 6, small_bore(hex_nut())),
        part("washer_small_bore", false, 0, small_bore(washer())),
        part("l_bracket_solid", false, 1, solid(l_bracket())),
        part("u_bracket_solid", false, 1, solid(u_bracket())),
    ]);
    cat
}

/// A part whose rings are an outline and a round bore centred on the origin, with the bore's
/// radius halved (its area a quarter).
fn small_bore(mut rings: Vec<Vec<P>>) -> Vec<Vec<P>> {
    if let Some(bore) = rings.get_mut(1) {
        for p in bore.iter_mut() {
            *p = [p[0] * 0.5, p[1] * 0.5];
        }
    }
    rings
}

/// A guitar pick: the convex hull of a 12 mm tip circle and two 24 mm shoulder circles (a
/// rounded triangle 100 mm across, mirror-symmetric about its axis, no rotational symmetry).
fn pick() -> Vec<Vec<P>> {
    let mut pts = circle([0.0, 44.0], 12.0);
    pts.extend(circle([-30.0, -20.0], 24.0));
    pts.extend(circle([30.0, -20.0], 24.0));
    vec![convex_hull(pts)]
}

/// The `large` variant's frame, px, that [`large_catalogue`]'s sizes are measured against at
/// 1 px/mm (another frame size scales the set's px per mm by the smaller ratio of sides).
pub const LARGE_REFERENCE_PX: (f64, f64) = (640.0, 480.0);

/// The large parts of the `large` variant and the share of the [`LARGE_REFERENCE_PX`] frame each
/// covers: a pick (a third, as the user's photos) and a 12-tooth gear (the templates), then a
/// hex nut, a washer (the paper shows through its bore), a square flange, a cam and a blob (not
/// taught: `vorl soak` holds every variant's templates in one recognizer of 64, two to spare).
pub const LARGE_SHARES: [(&str, f64); 7] = [
    ("pick", 0.33),
    ("gear_z12", 0.40),
    ("hex_nut", 0.30),
    ("washer", 0.26),
    ("flange_square", 0.45),
    ("cam", 0.28),
    ("blob", 0.36),
];

/// The `large` variant's parts: the parts of [`LARGE_SHARES`] (a guitar pick and standard parts,
/// each scaled so that it covers its share of the reference frame at 1 px/mm), the pick and the
/// gear as templates, the others as distractors, then the standard star and crescent (small
/// distractors).
pub fn large_catalogue() -> Vec<PartSpec> {
    let reference = LARGE_REFERENCE_PX.0 * LARGE_REFERENCE_PX.1;
    let standard = catalogue();
    let find = |name: &str| -> Option<PartSpec> {
        if name == "pick" {
            return Some(part("pick", true, 1, pick()));
        }
        standard.iter().find(|p| p.name == name).cloned()
    };
    let scaled = |spec: PartSpec, share: f64| {
        let s = (share * reference / spec.area_mm2()).sqrt();
        let rings = spec
            .rings()
            .iter()
            .map(|r| r.iter().map(|&p| mul(p, s)).collect())
            .collect();
        PartSpec {
            shape: Shape::new(rings),
            is_template: matches!(spec.name, "pick" | "gear_z12"),
            ..spec
        }
    };
    let mut cat: Vec<PartSpec> = LARGE_SHARES
        .iter()
        .filter_map(|&(name, share)| find(name).map(|p| scaled(p, share)))
        .collect();
    cat.extend(["star", "crescent"].iter().filter_map(|n| find(n)));
    cat
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rotates a point by `a` radians about the origin (any sense: only used for symmetry tests).
    fn rot(p: P, a: f64) -> P {
        let (s, c) = a.sin_cos();
        [c * p[0] - s * p[1], s * p[0] + c * p[1]]
    }

    #[test]
    fn gen_catalogue_is_well_formed() {
        let cat = catalogue();
        assert!(cat.iter().filter(|p| p.is_template).count() >= 10);
        assert!(cat.iter().filter(|p| !p.is_template).count() >= 2);
        well_formed(&cat);
        let sharp = sharp_catalogue();
        assert!(sharp.iter().filter(|p| p.is_template).count() >= 6);
        assert!(sharp.iter().filter(|p| !p.is_template).count() >= 2);
        well_formed(&sharp);
    }

    #[test]
    fn gen_sharp_parts_have_sharp_corners() {
        // Every template of the sharp catalogue has corners of the outline (turns of more than
        // 30° between consecutive edges); the gear 4 per tooth.
        for p in sharp_catalogue().iter().filter(|p| p.is_template) {
            let outer = p.rings().iter().find(|r| ring_moments(r).0 > 0.0).expect("outer ring");
            let n = outer.len();
            let corners = (0..n)
                .filter(|&i| {
                    let (a, b, c) = (outer[(i + n - 1) % n], outer[i], outer[(i + 1) % n]);
                    let (u, v) = (sub(b, a), sub(c, b));
                    (dot(u, v) / (norm(u) * norm(v))).clamp(-1.0, 1.0).acos() > 30f64.to_radians()
                })
                .count();
            let want = match p.name {
                "gear_sharp_z12" => 48,
                "gear_sharp_z10" => 40,
                "cam_snail" => 2,
                "hex_sharp" => 6,
                "l_square" => 6,
                "plate_notched" => 11,
                "cross" => 12,
                other => panic!("unexpected part {other}"),
            };
            assert_eq!(corners, want, "{}", p.name);
        }
    }

    /// Size, centroid at the origin, unique names and one outer ring for every part of `cat`.
    fn well_formed(cat: &[PartSpec]) {
        let mut names: Vec<&str> = cat.iter().map(|p| p.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), cat.len(), "class names are unique");
        for p in cat {
            let across = (p.bbox_mm()[2] - p.bbox_mm()[0]).max(p.bbox_mm()[3] - p.bbox_mm()[1]);
            assert!((75.0..=150.0).contains(&across), "{}: {across} mm across", p.name);
            // Centroid at the origin, to rounding.
            let (mut a, mut mx, mut my) = (0.0, 0.0, 0.0);
            for r in p.rings() {
                let (ra, rc) = ring_moments(r);
                a += ra;
                mx += ra * rc[0];
                my += ra * rc[1];
            }
            assert!(a > 0.0 && (a - p.area_mm2()).abs() < 1e-9 * a, "{}", p.name);
            assert!(
                (mx / a).abs() < 1e-9 && (my / a).abs() < 1e-9,
                "{}: centroid off",
                p.name
            );
            // Exactly one outer ring (one connected silhouette).
            assert_eq!(
                p.rings().iter().filter(|r| ring_moments(r).0 > 0.0).count(),
                1,
                "{}",
                p.name
            );
        }
    }

    #[test]
    fn gen_symmetries_hold_on_sampled_points() {
        for p in catalogue().into_iter().chain(sharp_catalogue()).chain(rods_catalogue()) {
            let n = p.symmetry;
            let (r, b) = (p.radius_mm(), p.bbox_mm());
            // Points of a grid (offset so they avoid the vertices), away from the border by 0.05 mm.
            let near_border = |q: P| {
                p.rings().iter().any(|ring| {
                    ring.iter().enumerate().any(|(i, a)| {
                        let c = ring[(i + 1) % ring.len()];
                        let ab = sub(c, *a);
                        let t = (dot(sub(q, *a), ab) / dot(ab, ab)).clamp(0.0, 1.0);
                        norm(sub(q, add(*a, mul(ab, t)))) < 0.05
                    })
                })
            };
            let mut mismatches_at_other_angles = 0;
            let mut tested = 0;
            let steps = 41;
            for i in 0..steps {
                for j in 0..steps {
                    let q = [
                        b[0] + (b[2] - b[0]) * (f64::from(i) + 0.37) / f64::from(steps),
                        b[1] + (b[3] - b[1]) * (f64::from(j) + 0.61) / f64::from(steps),
                    ];
                    if norm(q) > r || near_border(q) {
                        continue;
                    }
                    let here = p.coverage(q[0], q[1]);
                    if n >= 2 {
                        let s = rot(q, TAU / f64::from(n));
                        if !near_border(s) {
                            assert_eq!(here, p.coverage(s[0], s[1]), "{}: not {n}-fold symmetric", p.name);
                        }
                    }
                    // No finer symmetry than claimed: some point changes under a rotation by 360/(2n)
                    // (or 90° for symmetry 1).
                    let other = if n == 0 {
                        0.7
                    } else if n == 1 {
                        PI / 2.0
                    } else {
                        PI / f64::from(n)
                    };
                    let s = rot(q, other);
                    if !near_border(s) {
                        tested += 1;
                        if here != p.coverage(s[0], s[1]) {
                            mismatches_at_other_angles += 1;
                        }
                    }
                }
            }
            if n == 0 {
                assert_eq!(
                    mismatches_at_other_angles, 0,
                    "{}: a ring is rotation invariant",
                    p.name
                );
            } else {
                assert!(
                    mismatches_at_other_angles > 0,
                    "{} of {tested}: looks more symmetric than {n}",
                    p.name
                );
            }
        }
    }

    #[test]
    fn gen_holes_are_outside() {
        let cat = catalogue();
        let washer = cat.iter().find(|p| p.name == "washer").expect("washer");
        assert!(!washer.coverage(0.0, 0.0));
        assert!(washer.coverage(30.0, 0.0));
        assert!(!washer.coverage(50.0, 0.0));
        let area = PI * (44.0_f64.powi(2) - 20.0_f64.powi(2));
        assert!((washer.area_mm2() - area).abs() / area < 1e-3);
    }

    #[test]
    fn gen_rods_stay_whole_at_the_ends_of_their_spread() {
        // Every corner of the spread (shaft, each head, each eye): one outline, the eyes inside
        // their heads with at least 3 mm of wall (2.7 px at the least drawn size, a rim the mask
        // keeps whole), the big head larger than the small one.
        let ends = |r: (f64, f64)| [r.0, r.1];
        for rod in [ROD_A, ROD_B] {
            for stretch in ends(ROD_STRETCH) {
                for hb in ends(ROD_HEAD) {
                    for hs in ends(ROD_HEAD) {
                        for eb in ends(ROD_EYE) {
                            for es in ends(ROD_EYE) {
                                let made = rod.scaled(stretch, [hb, hs], [eb, es]);
                                assert!(made.r_small < made.r_big);
                                let shape = Shape::new(made.rings());
                                let outer: Vec<&Vec<P>> =
                                    shape.rings.iter().filter(|r| ring_moments(r).0 > 0.0).collect();
                                assert_eq!(outer.len(), 1);
                                let eyes: Vec<(f64, P)> = shape
                                    .rings
                                    .iter()
                                    .filter(|r| ring_moments(r).0 < 0.0)
                                    .map(|r| {
                                        let (a, c) = ring_moments(r);
                                        ((-a / PI).sqrt(), c)
                                    })
                                    .collect();
                                assert_eq!(eyes.len(), 1 + usize::from(rod.eye_small > 0.0));
                                for (r, c) in eyes {
                                    let wall = outer[0].iter().map(|&q| norm(sub(q, c))).fold(f64::MAX, f64::min) - r;
                                    assert!(wall > 3.0, "{made:?}: wall {wall}");
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}
