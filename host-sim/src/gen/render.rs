//! Rendering: platform lighting, parts with partial-volume edges and their texture, optical blur,
//! sensor noise and 8-bit quantisation; binary templates.
//!
//! An image is built in `f64` gray levels: the lighting field, plus for each part its coverage
//! times its contrast (so an edge pixel is the area-weighted mix of part and platform), then a
//! separable Gaussian blur, then i.i.d. Gaussian noise, rounding and clamping to 0..=255.

use image::GrayImage;

use super::effects::Lens;
use super::frontlit::Metal;
use super::raster::{coverage, fill_centres, Coverage, Pose};
use super::rng::Rng;
use super::shapes::{dot, norm, sub, PartSpec, P};

/// Sub-rows per pixel row when rasterising parts (coverage is exact along x).
pub(crate) const SUBROWS: usize = 16;
/// Optical blur, px.
pub(crate) const BLUR_SIGMA: f64 = 0.7;
/// Margin around a template silhouette, px.
pub(crate) const TEMPLATE_MARGIN: usize = 12;

/// Smooth uneven lighting of the empty platform: a base level plus a low-frequency field
/// (gradient, vignette, one slow wave) scaled to a given peak deviation.
#[derive(Clone, Debug)]
pub(crate) struct Lighting {
    base: f64,
    gain: f64,
    mean: f64,
    c: [f64; 8],
    /// Image centre and half width (normalisation of coordinates).
    centre: P,
    half_w: f64,
}

impl Lighting {
    /// Random lighting for a `w`×`h` image: mean level `base`, peak deviation `amplitude`.
    pub(crate) fn random(rng: &mut Rng, w: usize, h: usize, base: f64, amplitude: f64) -> Self {
        let c = [
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.5, -0.5),
            rng.range(-0.5, 0.5),
            rng.range(0.2, 0.6),
            rng.range(-2.5, 2.5),
            rng.range(-2.5, 2.5),
            rng.range(0.0, std::f64::consts::TAU),
        ];
        let mut l = Lighting {
            base,
            gain: 1.0,
            mean: 0.0,
            c,
            centre: [(w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0],
            half_w: w as f64 / 2.0,
        };
        let (gx, gy) = (41, 31);
        let samples: Vec<f64> = (0..gy)
            .flat_map(|j| (0..gx).map(move |i| (i, j)))
            .map(|(i, j)| {
                l.raw(
                    (w as f64 - 1.0) * f64::from(i) / f64::from(gx - 1),
                    (h as f64 - 1.0) * f64::from(j) / f64::from(gy - 1),
                )
            })
            .collect();
        let mean = samples.iter().sum::<f64>() / samples.len() as f64;
        let dev = samples.iter().map(|v| (v - mean).abs()).fold(0.0, f64::max);
        l.mean = mean;
        l.gain = if dev > 0.0 { amplitude / dev } else { 0.0 };
        l
    }

    fn raw(&self, x: f64, y: f64) -> f64 {
        let u = (x - self.centre[0]) / self.half_w;
        let v = (y - self.centre[1]) / self.half_w;
        let c = &self.c;
        c[0] * u + c[1] * v + c[2] * (u * u + v * v) + c[3] * u * v + c[4] * (c[5] * u + c[6] * v + c[7]).cos()
    }

    /// Gray level of the empty platform at image point (x, y).
    pub(crate) fn at(&self, x: f64, y: f64) -> f64 {
        self.base + self.gain * (self.raw(x, y) - self.mean)
    }

    /// The field over a `w`×`h` image whose pixel x sees the platform at x + `shift_x`.
    pub(crate) fn field(&self, w: usize, h: usize, shift_x: f64) -> Vec<f64> {
        (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .map(|(i, j)| self.at(i as f64 + shift_x, j as f64))
            .collect()
    }
}

/// A smooth per-frame lighting change: bilinear over the image, peak |offset| ≤ `max`.
pub(crate) fn add_drift(img: &mut [f64], w: usize, h: usize, rng: &mut Rng, max: f64) {
    let a = [
        rng.range(-1.0, 1.0),
        rng.range(-1.0, 1.0),
        rng.range(-1.0, 1.0),
        rng.range(-1.0, 1.0),
    ];
    let peak = [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
        .iter()
        .map(|(u, v)| (a[0] + a[1] * u + a[2] * v + a[3] * u * v).abs())
        .fold(0.0, f64::max);
    let target = max * rng.range(0.3, 1.0);
    let g = if peak > 0.0 { target / peak } else { 0.0 };
    let sx = 2.0 / (w.max(2) as f64 - 1.0);
    let sy = 2.0 / (h.max(2) as f64 - 1.0);
    for (j, row) in img.chunks_exact_mut(w).enumerate() {
        let v = j as f64 * sy - 1.0;
        for (i, px) in row.iter_mut().enumerate() {
            let u = i as f64 * sx - 1.0;
            *px += g * (a[0] + a[1] * u + a[2] * v + a[3] * u * v);
        }
    }
}

/// Separable Gaussian blur, edges replicated.
pub(crate) fn blur(img: &mut [f64], w: usize, h: usize, sigma: f64) {
    let r = (3.0 * sigma).ceil() as i64;
    let mut k: Vec<f64> = (-r..=r)
        .map(|i| (-((i * i) as f64) / (2.0 * sigma * sigma)).exp())
        .collect();
    let s: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= s);
    let mut tmp = vec![0.0; w * h];
    let clampi = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
    for j in 0..h {
        let row = &img[j * w..(j + 1) * w];
        for i in 0..w {
            tmp[j * w + i] = k
                .iter()
                .enumerate()
                .map(|(t, kv)| kv * row[clampi(i as i64 + t as i64 - r, w)])
                .sum();
        }
    }
    for j in 0..h {
        for i in 0..w {
            img[j * w + i] = k
                .iter()
                .enumerate()
                .map(|(t, kv)| kv * tmp[clampi(j as i64 + t as i64 - r, h) * w + i])
                .sum();
        }
    }
}

/// Adds i.i.d. Gaussian sensor noise of `sigma` levels, rounds and clamps to 8 bits.
pub(crate) fn capture(img: &[f64], w: usize, h: usize, sigma: f64, rng: &mut Rng) -> GrayImage {
    let px: Vec<u8> = img
        .iter()
        .map(|&v| (v + sigma * rng.normal()).round().clamp(0.0, 255.0) as u8)
        .collect();
    GrayImage::from_raw(w as u32, h as u32, px).unwrap_or_default()
}

/// How a part looks besides its silhouette.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Texture {
    /// One level.
    Plain,
    /// A linear shading across the part: `amplitude` levels at the bounding radius along `dir`
    /// (part frame).
    Gradient { dir: P, amplitude: f64 },
    /// A printed label: rectangles (part frame, mm, `[x0, y0, x1, y1]`) of another level.
    Label { bars: Vec<[f64; 4]>, level: f64 },
    /// Print on the face (`printed` variant): disjoint marks, each rings (part frame, mm,
    /// even–odd) of its own level (levels above the platform, like the contrast).
    Print { marks: Vec<Mark> },
    /// A front-lit metal face (`frontlit` variant): shading towards the light, a dark facet and
    /// specular highlights ([`Metal`]; drawn by `frontlit::draw_metal`).
    Metal(Metal),
}

/// One mark of a part's print.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Mark {
    /// Part frame, mm, even–odd.
    pub(crate) rings: Vec<Vec<P>>,
    /// Levels above the platform.
    pub(crate) level: f64,
    /// Ink (text, logo) or a patch near the platform's level.
    pub(crate) ink: bool,
}

impl Texture {
    /// The same texture on the part mirrored left-right (`x → −x` in the part frame), so that
    /// it keeps its place on the part lying upside down (its margins from the border too).
    pub(crate) fn mirrored(&self) -> Texture {
        match self {
            Texture::Plain => Texture::Plain,
            Texture::Gradient { dir, amplitude } => Texture::Gradient {
                dir: [-dir[0], dir[1]],
                amplitude: *amplitude,
            },
            Texture::Label { bars, level } => Texture::Label {
                bars: bars.iter().map(|b| [-b[2], b[1], -b[0], b[3]]).collect(),
                level: *level,
            },
            Texture::Print { marks } => Texture::Print {
                marks: marks
                    .iter()
                    .map(|m| Mark {
                        rings: m
                            .rings
                            .iter()
                            .map(|r| r.iter().map(|p| [-p[0], p[1]]).collect())
                            .collect(),
                        ..m.clone()
                    })
                    .collect(),
            },
            Texture::Metal(m) => Texture::Metal(m.mirrored()),
        }
    }

    /// Short name for the truth file.
    pub(crate) fn name(&self) -> &'static str {
        match self {
            Texture::Plain => "plain",
            Texture::Gradient { .. } => "gradient",
            Texture::Label { bars, .. } if bars.len() > 1 => "stripes",
            Texture::Label { .. } => "label",
            Texture::Print { .. } => "print",
            Texture::Metal(_) => "metal",
        }
    }
}

/// Contrast (levels above the platform, negative = darker) and texture of a part.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Appearance {
    pub(crate) contrast: f64,
    pub(crate) texture: Texture,
}

/// Draws a part into a `w`×`h` image (coverage × contrast added to what is there).
pub(crate) fn draw_part(img: &mut [f64], w: usize, h: usize, spec: &PartSpec, pose: &Pose, look: &Appearance) {
    draw_part_through(img, w, h, spec, pose, look, None);
}

/// [`draw_part`] seen through a distorting `lens` (none: the ideal camera): every ring of the part
/// and its marks is warped, and an image point takes the level of the part point it shows.
pub(crate) fn draw_part_through(
    img: &mut [f64],
    w: usize,
    h: usize,
    spec: &PartSpec,
    pose: &Pose,
    look: &Appearance,
    lens: Option<&Lens>,
) {
    let project = |rings: &[Vec<P>]| {
        let r = pose.rings(rings);
        match lens {
            Some(l) => l.warp(&r),
            None => r,
        }
    };
    let cov = coverage(&project(spec.rings()), Some((w, h)), SUBROWS);
    let radius = spec.radius_mm();
    let level = |p: P| match &look.texture {
        Texture::Gradient { dir, amplitude } => {
            let p = lens.map_or(p, |l| l.undistort(p));
            look.contrast + amplitude * dot(pose.invert(p), *dir) / radius
        }
        _ => look.contrast,
    };
    cov.for_each(|x, y, c| {
        img[y as usize * w + x as usize] += c * level([x as f64, y as f64]);
    });
    let mut mark = |rings: &[Vec<P>], level: f64| {
        let cov = coverage(&project(rings), Some((w, h)), SUBROWS);
        cov.for_each(|x, y, c| {
            img[y as usize * w + x as usize] += c * (level - look.contrast);
        });
    };
    match &look.texture {
        Texture::Label { bars, level: lab } => {
            for r in bars {
                let ring = vec![vec![[r[0], r[1]], [r[2], r[1]], [r[2], r[3]], [r[0], r[3]]]];
                mark(&ring, *lab);
            }
        }
        Texture::Print { marks } => {
            for m in marks {
                mark(&m.rings, m.level);
            }
        }
        _ => {}
    }
}

/// The coverage of a part's silhouette in a `w`×`h` image.
pub(crate) fn silhouette(spec: &PartSpec, pose: &Pose, w: usize, h: usize) -> Coverage {
    coverage(&pose.rings(spec.rings()), Some((w, h)), SUBROWS)
}

/// A template: the silhouette at the reference pose and `px_per_mm`, pixel-centre rule, 255 on
/// 0, with at least [`TEMPLATE_MARGIN`] px around it. Also returns where the area centroid (the
/// centre of rotation) lies in the image, px.
///
/// The sub-pixel position of the centroid is chosen (on a 1/16 px grid) so that the centroid and
/// area of the binary silhouette come as close as the pixel grid allows to the true ones.
pub(crate) fn template(spec: &PartSpec, px_per_mm: f64) -> (GrayImage, P) {
    let b = spec.bbox_mm();
    let m = TEMPLATE_MARGIN as f64;
    let cx0 = m + (-b[0] * px_per_mm).ceil();
    let cy0 = m + (-b[1] * px_per_mm).ceil();
    let w = (cx0 + (b[2] * px_per_mm).ceil() + m + 2.0) as usize;
    let h = (cy0 + (b[3] * px_per_mm).ceil() + m + 2.0) as usize;
    let raster = |c: P| fill_centres(&Pose::new(c[0], c[1], 0.0, px_per_mm).rings(spec.rings()), w, h);
    let area = spec.area_mm2() * px_per_mm * px_per_mm;
    let perimeter: f64 = spec
        .rings()
        .iter()
        .flat_map(|r| {
            r.iter()
                .enumerate()
                .map(move |(i, &a)| norm(sub(r[(i + 1) % r.len()], a)))
        })
        .sum::<f64>()
        * px_per_mm;
    // Centroid error plus the area error as a mean border shift, px.
    let error = |c: P| {
        let (mut n, mut sx, mut sy) = (0.0, 0.0, 0.0);
        for (i, &v) in raster(c).iter().enumerate() {
            if v {
                n += 1.0;
                sx += (i % w) as f64;
                sy += (i / w) as f64;
            }
        }
        (sx / n - c[0]).hypot(sy / n - c[1]) + (n - area).abs() / perimeter
    };
    let steps = 16;
    let c = (0..steps * steps)
        .map(|s| {
            [
                cx0 + f64::from(s % steps) / f64::from(steps),
                cy0 + f64::from(s / steps) / f64::from(steps),
            ]
        })
        .map(|c| (error(c), c))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or([cx0, cy0], |(_, c)| c);
    let px = raster(c).iter().map(|&v| if v { 255 } else { 0 }).collect();
    (GrayImage::from_raw(w as u32, h as u32, px).unwrap_or_default(), c)
}

#[cfg(test)]
mod tests {
    use super::super::shapes::catalogue;
    use super::*;

    #[test]
    fn gen_templates_have_margin_and_centroid() {
        for spec in catalogue() {
            for ppm in [1.0, 0.4] {
                let (img, c) = template(&spec, ppm);
                let (w, h) = img.dimensions();
                let (mut n, mut sx, mut sy) = (0.0, 0.0, 0.0);
                for (x, y, p) in img.enumerate_pixels() {
                    assert!(p.0[0] == 0 || p.0[0] == 255);
                    if p.0[0] == 255 {
                        assert!(x >= 10 && y >= 10 && x + 10 < w && y + 10 < h, "{}: margin", spec.name);
                        n += 1.0;
                        sx += f64::from(x);
                        sy += f64::from(y);
                    }
                }
                let want = spec.area_mm2() * ppm * ppm;
                assert!(
                    (n - want).abs() / want < if ppm < 1.0 { 0.05 } else { 0.02 },
                    "{}: {n} px vs {want}",
                    spec.name
                );
                let err = (sx / n - c[0]).hypot(sy / n - c[1]);
                assert!(err < 0.03, "{} at {ppm}: template centroid off by {err}", spec.name);
            }
        }
    }

    #[test]
    fn gen_lighting_is_smooth_and_bounded() {
        let mut rng = Rng::stream(5, 1, 0);
        let l = Lighting::random(&mut rng, 640, 480, 130.0, 15.0);
        let f = l.field(640, 480, 0.0);
        let (lo, hi) = f.iter().fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        assert!(lo > 130.0 - 16.0 && hi < 130.0 + 16.0, "{lo}..{hi}");
        assert!(hi - lo > 10.0, "uneven: {lo}..{hi}");
        let step = f
            .chunks_exact(640)
            .flat_map(|row| row.windows(2).map(|p| (p[1] - p[0]).abs()))
            .fold(0.0, f64::max);
        assert!(step < 0.5, "smooth: largest neighbour step {step}");
    }

    #[test]
    fn gen_blur_keeps_mean_and_centroid() {
        let (w, h) = (40, 30);
        let mut img = vec![0.0; w * h];
        img[12 * w + 17] = 100.0;
        img[13 * w + 17] = 50.0;
        blur(&mut img, w, h, BLUR_SIGMA);
        let s: f64 = img.iter().sum();
        let cy: f64 = img.iter().enumerate().map(|(i, v)| v * (i / w) as f64).sum::<f64>() / s;
        assert!((s - 150.0).abs() < 1e-9);
        assert!((cy - (12.0 * 100.0 + 13.0 * 50.0) / 150.0).abs() < 1e-9);
    }
}
