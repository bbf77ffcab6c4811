//! What the real-camera variants put between the ideal scene and the sensor: a barrel-distorted
//! lens (`lens`), a close non-telecentric camera that sees a thick part's walls (`thick`), a
//! textured platform (`paper`) and a vignetted backlight (`backlit`).
//!
//! All of it is geometry or a fixed field, so the truth stays exact: the lens maps points by a
//! closed formula (its inverse by Newton's method to 1e-12 px), the walls are the exact polygonal
//! sweep of the part between its bottom and top face, and the textures are drawn once per set.

use std::f64::consts::TAU;

use super::raster::{coverage, Pose};
use super::render::blur;
use super::rng::Rng;
use super::shapes::{add, mul, norm, sub, P};

/// Longest edge of a ring before it is warped by the lens, px (the image of a straight edge
/// bends by less than 1e-5 px over it).
pub(crate) const WARP_STEP_PX: f64 = 0.5;

/// Radial (barrel) distortion about the principal point `centre`: an undistorted image point
/// `p` is seen at `c + (p − c)·(1 + k1·|p − c|² / r_norm²)`, with `k1 < 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Lens {
    pub(crate) centre: P,
    pub(crate) k1: f64,
    /// Radius the distortion is normalised by, px (half the frame's diagonal).
    pub(crate) r_norm: f64,
}

impl Lens {
    /// A random lens for a `w`×`h` frame: the principal point within ±1.5 % of the width of the
    /// frame's centre, and `k1` such that the frame corner farthest from it moves 3–6 px inward.
    pub(crate) fn random(rng: &mut Rng, w: usize, h: usize) -> Self {
        let (wf, hf) = (w as f64, h as f64);
        let centre = [
            (wf - 1.0) / 2.0 + rng.range(-0.015, 0.015) * wf,
            (hf - 1.0) / 2.0 + rng.range(-0.015, 0.015) * wf,
        ];
        let shift = rng.range(3.0, 6.0);
        let r_norm = wf.hypot(hf) / 2.0;
        let r = far_corner(centre, w, h);
        Lens {
            centre,
            k1: -shift * r_norm * r_norm / (r * r * r),
            r_norm,
        }
    }

    /// Undistorted → distorted image point.
    pub(crate) fn distort(&self, p: P) -> P {
        let d = sub(p, self.centre);
        let rho2 = (d[0] * d[0] + d[1] * d[1]) / (self.r_norm * self.r_norm);
        add(self.centre, mul(d, 1.0 + self.k1 * rho2))
    }

    /// Distorted → undistorted image point (Newton's method on the radius, to 1e-12 px).
    pub(crate) fn undistort(&self, p: P) -> P {
        let d = sub(p, self.centre);
        let rd = norm(d);
        if rd == 0.0 {
            return p;
        }
        let a = self.k1 / (self.r_norm * self.r_norm);
        let mut r = rd;
        for _ in 0..20 {
            let step = (r * (1.0 + a * r * r) - rd) / (1.0 + 3.0 * a * r * r);
            r -= step;
            if step.abs() < 1e-12 {
                break;
            }
        }
        add(self.centre, mul(d, r / rd))
    }

    /// How far the frame corner farthest from the principal point moves, px.
    pub(crate) fn corner_shift(&self, w: usize, h: usize) -> f64 {
        let r = far_corner(self.centre, w, h);
        -self.k1 * r * r * r / (self.r_norm * self.r_norm)
    }

    /// Rings (undistorted image px) as the lens shows them: every edge cut into pieces of at
    /// most [`WARP_STEP_PX`], every vertex distorted.
    pub(crate) fn warp(&self, rings: &[Vec<P>]) -> Vec<Vec<P>> {
        subdivide(rings, WARP_STEP_PX)
            .iter()
            .map(|r| r.iter().map(|&p| self.distort(p)).collect())
            .collect()
    }

    /// The least-squares similarity that maps the border of `rings` (undistorted image px) onto
    /// its distorted image, points paired by arc length and weighted by it: its rotation (degrees,
    /// counter-clockwise on screen) and scale.
    pub(crate) fn border_fit(&self, rings: &[Vec<P>]) -> (f64, f64) {
        let mut pairs = Vec::new();
        for ring in subdivide(rings, WARP_STEP_PX) {
            let n = ring.len();
            for i in 0..n {
                let (prev, p, next) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
                let weight = (norm(sub(p, prev)) + norm(sub(next, p))) / 2.0;
                pairs.push((p, self.distort(p), weight));
            }
        }
        fit_similarity(&pairs)
    }
}

/// Distance from `c` to the farthest pixel centre at a corner of a `w`×`h` frame.
fn far_corner(c: P, w: usize, h: usize) -> f64 {
    let (x1, y1) = (w as f64 - 1.0, h as f64 - 1.0);
    [[0.0, 0.0], [x1, 0.0], [0.0, y1], [x1, y1]]
        .iter()
        .map(|&q| norm(sub(q, c)))
        .fold(0.0, f64::max)
}

/// Rings with every edge cut into equal pieces of at most `step`.
pub(crate) fn subdivide(rings: &[Vec<P>], step: f64) -> Vec<Vec<P>> {
    rings
        .iter()
        .map(|r| {
            let mut out = Vec::with_capacity(r.len());
            for (i, &a) in r.iter().enumerate() {
                let b = r[(i + 1) % r.len()];
                let pieces = (norm(sub(b, a)) / step).ceil().max(1.0) as usize;
                out.extend((0..pieces).map(|j| add(a, mul(sub(b, a), j as f64 / pieces as f64))));
            }
            out
        })
        .collect()
}

/// Weighted least-squares similarity `v ≈ t + s·R(θ)·u` over pairs `(u, v, weight)`: θ in degrees
/// counter-clockwise on screen (y down, as [`Pose`]) and s.
pub(crate) fn fit_similarity(pairs: &[(P, P, f64)]) -> (f64, f64) {
    let total: f64 = pairs.iter().map(|p| p.2).sum();
    let mean = |f: fn(&(P, P, f64)) -> P| {
        let s = pairs.iter().fold([0.0, 0.0], |acc, p| add(acc, mul(f(p), p.2)));
        mul(s, 1.0 / total)
    };
    let (mu, mv) = (mean(|p| p.0), mean(|p| p.1));
    let (mut dot, mut cross, mut uu) = (0.0, 0.0, 0.0);
    for (u, v, w) in pairs {
        let (u, v) = (sub(*u, mu), sub(*v, mv));
        dot += w * (u[0] * v[0] + u[1] * v[1]);
        cross += w * (u[0] * v[1] - u[1] * v[0]);
        uu += w * (u[0] * u[0] + u[1] * u[1]);
    }
    // A turn by δ counter-clockwise on screen gives u × v = −sin δ·|u|² (y down).
    ((-cross).atan2(dot).to_degrees(), dot.hypot(cross) / uu)
}

/// A close pinhole camera looking straight down at the platform from `height_mm`, principal
/// point `centre`; the platform is imaged at the templates' scale, so a plane `z` mm above it is
/// imaged at `height / (height − z)` times that scale, about the principal point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CloseCamera {
    pub(crate) centre: P,
    pub(crate) height_mm: f64,
}

impl CloseCamera {
    /// Image scale of a plane `z_mm` above the platform, relative to the platform.
    pub(crate) fn scale(&self, z_mm: f64) -> f64 {
        self.height_mm / (self.height_mm - z_mm)
    }

    /// The image point of a platform point's image `p` lifted onto a plane of image scale `s`.
    pub(crate) fn lift_point(&self, p: P, s: f64) -> P {
        add(self.centre, mul(sub(p, self.centre), s))
    }

    /// The pose of a face of image scale `s` above a bottom face at `pose`: the bottom face
    /// magnified by `s` about the principal point.
    pub(crate) fn lift(&self, pose: &Pose, s: f64) -> Pose {
        let c = self.lift_point([pose.cx, pose.cy], s);
        Pose {
            cx: c[0],
            cy: c[1],
            k: pose.k * s,
            ..*pose
        }
    }

    /// The image of a prism whose bottom face is `bottom` (image px) and whose top face is its
    /// image at scale `s`: every face in between is the bottom magnified by a factor in [1, s]
    /// about the principal point, and their union is exactly the bottom face, the top face and,
    /// for every edge, the trapezoid it sweeps. Each is returned as its own ring set (to be filled
    /// as a union).
    pub(crate) fn sweep(&self, bottom: &[Vec<P>], s: f64) -> Vec<Vec<Vec<P>>> {
        let top: Vec<Vec<P>> = bottom
            .iter()
            .map(|r| r.iter().map(|&p| self.lift_point(p, s)).collect())
            .collect();
        let mut shapes = vec![bottom.to_vec()];
        for (rb, rt) in bottom.iter().zip(&top) {
            for i in 0..rb.len() {
                let j = (i + 1) % rb.len();
                shapes.push(vec![vec![rb[i], rb[j], rt[j], rt[i]]]);
            }
        }
        shapes.push(top);
        shapes
    }
}

/// A backlight seen through a lens with natural (cos⁴) vignetting: `level` at the optical centre,
/// `level / (1 + r²/f²)²` at `r` px from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Backlight {
    pub(crate) centre: P,
    pub(crate) level: f64,
    pub(crate) f_px: f64,
}

impl Backlight {
    /// A random backlight for a `w`×`h` frame: 246–252 at the optical centre (within ±2 % of the
    /// width of the frame's centre), 145–155 at the farthest frame corner.
    pub(crate) fn random(rng: &mut Rng, w: usize, h: usize) -> Self {
        let (wf, hf) = (w as f64, h as f64);
        let centre = [
            (wf - 1.0) / 2.0 + rng.range(-0.02, 0.02) * wf,
            (hf - 1.0) / 2.0 + rng.range(-0.02, 0.02) * wf,
        ];
        let level = rng.range(246.0, 252.0);
        let corner = rng.range(145.0, 155.0);
        let r = far_corner(centre, w, h);
        Backlight {
            centre,
            level,
            f_px: r / ((level / corner).sqrt() - 1.0).sqrt(),
        }
    }

    /// Brightness at image point `p`.
    pub(crate) fn at(&self, p: P) -> f64 {
        let d = sub(p, self.centre);
        let q = 1.0 + (d[0] * d[0] + d[1] * d[1]) / (self.f_px * self.f_px);
        self.level / (q * q)
    }

    /// Brightness at the farthest frame corner.
    pub(crate) fn corner_level(&self, w: usize, h: usize) -> f64 {
        let r = far_corner(self.centre, w, h);
        self.at(add(self.centre, [r, 0.0]))
    }

    /// The field over a `w`×`h` frame, row-major.
    pub(crate) fn field(&self, w: usize, h: usize) -> Vec<f64> {
        (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .map(|(i, j)| self.at([i as f64, j as f64]))
            .collect()
    }
}

/// Standard deviation of the paper texture, levels (range drawn per set).
pub(crate) const PAPER_STD: (f64, f64) = (3.0, 5.0);

/// A fine paper or belt texture over a `w`×`h` frame, zero mean, standard deviation `std`
/// levels: speckle (white noise blurred to a correlation length of about 2 px) plus fibres (thin
/// strokes 0.6–1.4 px wide, 6–30 px long, bent once, lighter or darker), lightly blurred.
pub(crate) fn paper_texture(rng: &mut Rng, w: usize, h: usize, std: f64) -> Vec<f64> {
    let mut t: Vec<f64> = (0..w * h).map(|_| rng.normal()).collect();
    blur(&mut t, w, h, 0.9);
    let speckle = spread(&t).1;
    t.iter_mut().for_each(|v| *v /= speckle);
    for _ in 0..w * h / 250 {
        let mut p = [rng.range(-15.0, w as f64 + 15.0), rng.range(-15.0, h as f64 + 15.0)];
        let mut a = rng.range(0.0, TAU);
        let half = rng.range(3.0, 15.0);
        let width = rng.range(0.6, 1.4);
        let level = rng.sign() * rng.range(2.0, 5.0);
        let bend = rng.range(-0.6, 0.6);
        for _ in 0..2 {
            let d = [a.cos(), a.sin()];
            let n = mul([-d[1], d[0]], width / 2.0);
            let q = add(p, mul(d, half));
            let quad = vec![vec![add(p, n), add(q, n), sub(q, n), sub(p, n)]];
            coverage(&quad, Some((w, h)), 4).for_each(|x, y, c| t[y as usize * w + x as usize] += c * level);
            p = q;
            a += bend;
        }
    }
    blur(&mut t, w, h, 0.5);
    let (mean, sd) = spread(&t);
    t.iter_mut().for_each(|v| *v = (*v - mean) * std / sd);
    t
}

/// Mean and standard deviation.
pub(crate) fn spread(v: &[f64]) -> (f64, f64) {
    let n = v.len().max(1) as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
    (mean, var.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gen_lens_undistort_inverts_distort_and_moves_the_corners() {
        for seed in 0..20 {
            let lens = Lens::random(&mut Rng::stream(seed, 1, 0), 640, 480);
            let shift = lens.corner_shift(640, 480);
            assert!((3.0..6.0).contains(&shift), "{shift}");
            assert!(lens.k1 < 0.0);
            for p in [[0.0, 0.0], [639.0, 479.0], [320.3, 240.1], [17.0, 400.0]] {
                let back = lens.undistort(lens.distort(p));
                assert!(norm(sub(back, p)) < 1e-9, "{p:?} → {back:?}");
                // Barrel: every point moves towards the centre.
                assert!(norm(sub(lens.distort(p), lens.centre)) <= norm(sub(p, lens.centre)));
            }
        }
    }

    #[test]
    fn gen_similarity_fit_recovers_a_turn_and_scale() {
        let pose = Pose::new(10.0, 20.0, 33.0, 1.1);
        let pts: Vec<(P, P, f64)> = (0..12)
            .map(|i| {
                let q = [f64::from(i).cos() * 30.0, f64::from(i * i % 7) * 4.0];
                (q, pose.apply(q), 1.0 + f64::from(i % 3))
            })
            .collect();
        let (rot, s) = fit_similarity(&pts);
        assert!((rot - 33.0).abs() < 1e-9 && (s - 1.1).abs() < 1e-12, "{rot} {s}");
    }

    #[test]
    fn gen_sweep_is_the_hull_of_both_faces() {
        // The faces of a convex part between scale 1 and s about the principal point fill the
        // convex hull of the bottom and the top face (any mix of two points of two faces lies on
        // a face in between).
        let cam = CloseCamera {
            centre: [100.0, 100.0],
            height_mm: 500.0,
        };
        let sq: Vec<P> = (0..4)
            .map(|k| {
                let a = 0.35 + f64::from(k) * std::f64::consts::FRAC_PI_2;
                add([160.0, 150.0], mul([a.cos(), a.sin()], 14.0))
            })
            .collect();
        let s = cam.scale(20.0);
        let shapes = cam.sweep(std::slice::from_ref(&sq), s);
        assert_eq!(shapes.len(), 2 + 4);
        let union = super::super::raster::coverage_union(&shapes, None, 16);
        let (area, _) = union.moments();
        let mut corners = sq.clone();
        corners.extend(sq.iter().map(|&p| cam.lift_point(p, s)));
        let want = super::super::shapes::ring_moments(&super::super::shapes::convex_hull(corners))
            .0
            .abs();
        assert!(want > 392.0 * s * s);
        assert!((area - want).abs() < 0.02, "{area} vs {want}");
    }

    #[test]
    fn gen_backlight_vignette_levels() {
        for seed in 0..10 {
            let b = Backlight::random(&mut Rng::stream(seed, 2, 0), 640, 480);
            assert!((145.0..155.0).contains(&b.corner_level(640, 480)));
            assert!((b.at(b.centre) - b.level).abs() < 1e-12);
        }
    }

    #[test]
    fn gen_paper_texture_is_fine_and_correlated() {
        let (w, h) = (200, 150);
        let t = paper_texture(&mut Rng::stream(3, 4, 0), w, h, 4.0);
        let (mean, sd) = spread(&t);
        assert!(mean.abs() < 1e-9 && (sd - 4.0).abs() < 1e-9);
        let corr = |dx: usize| {
            let (mut s, mut n) = (0.0, 0.0);
            for y in 0..h {
                for x in 0..w - dx {
                    s += t[y * w + x] * t[y * w + x + dx];
                    n += 1.0;
                }
            }
            s / n / (sd * sd)
        };
        // Correlated over 1–3 px, not beyond.
        assert!(corr(1) > 0.5, "lag 1: {}", corr(1));
        assert!(corr(6) < 0.25, "lag 6: {}", corr(6));
    }
}
