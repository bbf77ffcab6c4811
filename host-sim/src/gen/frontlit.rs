//! The `frontlit` variant: metal parts on a grey textured mat under diffuse light from one side,
//! camera overhead (what a webcam over a work table sees, as in the real photos `nuts-screws`).
//!
//! - The mat: a mean level of [`MAT_LEVEL`] with smooth uneven lighting of up to
//!   [`MAT_LIGHTING`] levels, and a fine speckle-and-fibre texture ([`paper_texture`], standard
//!   deviation [`MAT_TEXTURE_STD`]) that is part of the platform (in `background.png` too).
//! - The light comes from one direction per set, [`FrontLight::from_deg`] (degrees
//!   counter-clockwise on screen from +x: 90 is the top, 180 the left), drawn in
//!   [`LIGHT_FROM_DEG`] (about the upper left).
//! - Every part is metal, brighter than the lit mat under it ([`Metal`]): a base level
//!   [`METAL_CONTRAST`] above it, shaded by up to ±[`METAL_SHADING`] levels (brighter towards
//!   the light), so [`METAL_CONTRAST`] ± [`METAL_SHADING`] spans 40–120 levels; one darker
//!   facet ([`Facet`]: [`FACET_SHARE`] of the part's area, the edge away from the light at
//!   [`FACET_LEVEL`] from the mat, or a band across the part at [`BAND_LEVEL`] of its contrast); 1–2 specular highlights
//!   ([`HIGHLIGHT_LEVEL`] more, clipping at 255 where they reach it).
//! - Every part throws a soft shadow ([`Shadow`]): its silhouette moved [`SHADOW_OFFSET_PX`]
//!   away from the light, blurred by σ [`SHADOW_SIGMA_PX`], darkening the mat by up to
//!   [`SHADOW_DEPTH`] levels (where shadows meet, the darker one). Shadows lie on the mat under
//!   the parts: a part hides its own shadow (and any other) where it covers it, and the mat's
//!   texture.
//!
//! Templates are the crisp silhouettes, and truth is the part's own silhouette (its centroid and
//! turn), never the shadow or the facet.
//!
//! `frontlit-mixed` makes the parts of about [`MIXED_DARK_SHARE`] of the classes dark
//! ([`DARK_CONTRAST`] below the mat, a band facet, highlights as the others): a set of both
//! kinds, whose polarity is "either", and whose dark parts' shadows join them while bright
//! parts' lie beside them.

use std::f64::consts::TAU;

use super::effects::paper_texture;
use super::raster::{coverage, Pose};
use super::render::{blur, silhouette, Appearance, Lighting, Texture};
use super::rng::Rng;
use super::scene::Body;
use super::shapes::{dot, sub, PartSpec, P};

/// Mean level of the mat (drawn per set).
pub(crate) const MAT_LEVEL: (f64, f64) = (105.0, 125.0);
/// Peak deviation of the mat's smooth uneven lighting from its mean, levels (drawn per set).
pub(crate) const MAT_LIGHTING: (f64, f64) = (6.0, 12.0);
/// Standard deviation of the mat's texture, levels (drawn per set).
pub(crate) const MAT_TEXTURE_STD: (f64, f64) = (3.0, 5.0);
/// Where the light comes from, degrees counter-clockwise on screen from +x (135: upper left).
pub(crate) const LIGHT_FROM_DEG: (f64, f64) = (110.0, 160.0);
/// A part's base level above the lit mat, levels.
pub(crate) const METAL_CONTRAST: (f64, f64) = (55.0, 105.0);
/// The shading across a part: levels gained towards the light (lost away from it) at the part's
/// bounding radius.
pub(crate) const METAL_SHADING: (f64, f64) = (5.0, 15.0);
/// Share of a part's area its dark facet covers.
pub(crate) const FACET_SHARE: (f64, f64) = (0.05, 0.15);
/// Level of a dark facet, levels from the lit mat (about the mat's level, or a bit below).
pub(crate) const FACET_LEVEL: (f64, f64) = (-15.0, 5.0);
/// Level of a band facet across a part, as a fraction of the part's contrast over the mat.
pub(crate) const BAND_LEVEL: (f64, f64) = (0.4, 0.7);
/// Share of the facets that are the part's edge away from the light (the others are bands
/// across the part).
pub(crate) const EDGE_FACET_SHARE: f64 = 0.75;
/// Peak of a specular highlight over the part's level, levels.
pub(crate) const HIGHLIGHT_LEVEL: (f64, f64) = (30.0, 80.0);
/// Chance that a class's parts are dark in `frontlit-mixed`.
pub(crate) const MIXED_DARK_SHARE: f64 = 0.5;
/// A dark part's base level below the lit mat, levels (it keeps a few levels above black on the
/// darkest mat).
pub(crate) const DARK_CONTRAST: (f64, f64) = (45.0, 95.0);
/// How far a shadow lies from its part, away from the light, px.
pub(crate) const SHADOW_OFFSET_PX: (f64, f64) = (4.0, 10.0);
/// Sub-rows per pixel row when rasterising a shadow (it is blurred by 2 px and more).
const SHADOW_SUBROWS: usize = 4;
/// Blur of a shadow's edge (Gaussian σ), px.
pub(crate) const SHADOW_SIGMA_PX: (f64, f64) = (2.0, 4.0);
/// How much a shadow darkens the mat at its full depth, levels.
pub(crate) const SHADOW_DEPTH: (f64, f64) = (20.0, 50.0);

/// The set's light and mat.
#[derive(Clone, Debug)]
pub(crate) struct FrontLight {
    /// Where the light comes from, degrees counter-clockwise on screen from +x.
    pub(crate) from_deg: f64,
    /// Mean level of the mat.
    pub(crate) mat_level: f64,
    /// Peak deviation of the mat's smooth lighting from its mean, levels.
    pub(crate) mat_lighting: f64,
    /// Standard deviation of the mat's texture, levels.
    pub(crate) texture_std: f64,
    /// The mat's texture, levels, zero mean, row-major.
    pub(crate) texture: Vec<f64>,
    /// The lit mat without its texture, row-major.
    pub(crate) field: Vec<f64>,
    /// The classes whose parts are dark (blackened steel, dark plastic: [`DARK_CONTRAST`]):
    /// none for `frontlit`, each class with chance [`MIXED_DARK_SHARE`] for `frontlit-mixed`.
    pub(crate) dark: Vec<&'static str>,
}

impl FrontLight {
    /// A random light and mat for a `w`×`h` frame.
    pub(crate) fn random(rng: &mut Rng, w: usize, h: usize) -> Self {
        let from_deg = rng.range(LIGHT_FROM_DEG.0, LIGHT_FROM_DEG.1);
        let mat_level = rng.range(MAT_LEVEL.0, MAT_LEVEL.1);
        let mat_lighting = rng.range(MAT_LIGHTING.0, MAT_LIGHTING.1);
        let field = Lighting::random(rng, w, h, mat_level, mat_lighting).field(w, h, 0.0);
        let texture_std = rng.range(MAT_TEXTURE_STD.0, MAT_TEXTURE_STD.1);
        let texture = paper_texture(rng, w, h, texture_std);
        FrontLight {
            from_deg,
            mat_level,
            mat_lighting,
            texture_std,
            texture,
            field,
            dark: Vec::new(),
        }
    }

    /// Unit vector from a part towards the light, image frame (x right, y down).
    pub(crate) fn toward(&self) -> P {
        let a = self.from_deg.to_radians();
        [a.cos(), -a.sin()]
    }

    /// The empty mat: the lit field plus the texture, row-major.
    pub(crate) fn mat(&self) -> Vec<f64> {
        self.field.iter().zip(&self.texture).map(|(f, t)| f + t).collect()
    }
}

/// A part's soft shadow on the mat.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Shadow {
    /// Where the shadow lies from the part, image px (away from the light).
    pub(crate) offset: P,
    /// Gaussian σ of its edge, px.
    pub(crate) sigma: f64,
    /// Levels it takes from the mat at its full depth.
    pub(crate) depth: f64,
}

/// A darker facet of a metal part: the points `q` of the part (part frame, mm) with
/// `lo ≤ q·dir < hi`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Facet {
    /// Unit vector, part frame.
    pub(crate) dir: P,
    /// Start of the facet along `dir`, mm.
    pub(crate) lo: f64,
    /// End of the facet along `dir`, mm (beyond the part for an edge facet).
    pub(crate) hi: f64,
    /// Its level, levels from the lit mat.
    pub(crate) level: f64,
    /// The part's edge away from the light (else a band across the part).
    pub(crate) edge: bool,
    /// Share of the part's area it covers (measured on a grid of the part's points).
    pub(crate) share: f64,
}

/// A specular highlight: a Gaussian streak on the part's face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Highlight {
    /// Centre, part frame, mm.
    pub(crate) centre: P,
    /// Unit vector along the streak, part frame.
    pub(crate) axis: P,
    /// σ along the streak, mm.
    pub(crate) long: f64,
    /// σ across the streak, mm.
    pub(crate) short: f64,
    /// Peak, levels over the part's level.
    pub(crate) level: f64,
}

/// How a front-lit metal part's face looks (its base level is the part's contrast).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Metal {
    /// Unit vector towards the light, part frame.
    pub(crate) toward: P,
    /// Levels gained towards the light at the part's bounding radius (lost away from it).
    pub(crate) shading: f64,
    /// The dark facet.
    pub(crate) facet: Facet,
    /// Specular highlights.
    pub(crate) highlights: Vec<Highlight>,
}

impl Metal {
    /// The same face on the part mirrored left-right (`x → −x` in the part frame).
    pub(crate) fn mirrored(&self) -> Metal {
        let m = |p: P| [-p[0], p[1]];
        Metal {
            toward: m(self.toward),
            shading: self.shading,
            facet: Facet {
                dir: m(self.facet.dir),
                ..self.facet
            },
            highlights: self
                .highlights
                .iter()
                .map(|h| Highlight {
                    centre: m(h.centre),
                    axis: m(h.axis),
                    ..*h
                })
                .collect(),
        }
    }

    /// Whether part-frame point `q` lies on the facet.
    pub(crate) fn in_facet(&self, q: P) -> bool {
        let d = dot(q, self.facet.dir);
        d >= self.facet.lo && d < self.facet.hi
    }

    /// Level at part-frame point `q` (mm) of a part of base level `contrast` and bounding
    /// `radius` (mm), levels from the lit mat.
    pub(crate) fn level(&self, q: P, contrast: f64, radius: f64) -> f64 {
        if self.in_facet(q) {
            return self.facet.level;
        }
        let mut v = contrast + self.shading * dot(q, self.toward) / radius;
        for h in &self.highlights {
            let d = sub(q, h.centre);
            let (u, s) = (dot(d, h.axis), d[0] * h.axis[1] - d[1] * h.axis[0]);
            v += h.level * (-(u * u) / (2.0 * h.long * h.long) - (s * s) / (2.0 * h.short * h.short)).exp();
        }
        v
    }
}

/// Points of the part (part frame, mm) on a grid of about 120 steps across its bounding circle.
fn interior(spec: &PartSpec) -> Vec<P> {
    let b = spec.bbox_mm();
    let step = (spec.radius_mm() / 60.0).max(0.25);
    let mut out = Vec::new();
    let mut y = b[1] + step / 2.0;
    while y < b[3] {
        let mut x = b[0] + step / 2.0;
        while x < b[2] {
            if spec.coverage(x, y) {
                out.push([x, y]);
            }
            x += step;
        }
        y += step;
    }
    out
}

/// `v` turned by `a` radians.
fn turn(v: P, a: f64) -> P {
    let (s, c) = a.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1]]
}

/// The `q`-quantile of sorted values.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let i = ((sorted.len() as f64 - 1.0) * q.clamp(0.0, 1.0)).round() as usize;
    sorted.get(i).copied().unwrap_or(0.0)
}

/// The look and body of a front-lit part of `spec` at `pose`: its metal face and its shadow.
pub(crate) fn dress(rng: &mut Rng, spec: &PartSpec, pose: &Pose, light: &FrontLight) -> (Appearance, Body) {
    let t = light.toward();
    // The image direction towards the light in the part's frame.
    let toward = pose.invert([pose.cx + t[0] * pose.k, pose.cy + t[1] * pose.k]);
    let contrast = rng.range(METAL_CONTRAST.0, METAL_CONTRAST.1);
    let dark = light.dark.contains(&spec.name);
    let contrast = if dark {
        -rng.range(DARK_CONTRAST.0, DARK_CONTRAST.1)
    } else {
        contrast
    };
    let shading = rng.range(METAL_SHADING.0, METAL_SHADING.1);
    let points = interior(spec);
    // A dark part's facet is a band (a face turned away from the light is no brighter).
    let edge = rng.chance(EDGE_FACET_SHARE) && !dark;
    let share = rng.range(FACET_SHARE.0, FACET_SHARE.1);
    let dir = if edge {
        turn([-toward[0], -toward[1]], rng.range(-0.5, 0.5))
    } else {
        let a = rng.range(0.0, TAU);
        [a.cos(), a.sin()]
    };
    let mut along: Vec<f64> = points.iter().map(|&q| dot(q, dir)).collect();
    along.sort_by(f64::total_cmp);
    let beyond = spec.radius_mm() + 1.0;
    let (lo, hi) = if edge {
        (quantile(&along, 1.0 - share), beyond)
    } else {
        let u = rng.range(0.25, 0.75 - share);
        (quantile(&along, u), quantile(&along, u + share))
    };
    // An edge facet turned away from the light falls to about the mat's level (the real hex
    // bolt's head); a band across a flat face is a duller stripe of the metal (BAND_LEVEL of its
    // contrast), never at the mat's level: diffuse light lights a flat face alike across.
    let level = if edge {
        rng.range(FACET_LEVEL.0, FACET_LEVEL.1)
    } else {
        contrast * rng.range(BAND_LEVEL.0, BAND_LEVEL.1)
    };
    let on = |q: &P| (lo..hi).contains(&dot(*q, dir));
    let measured = points.iter().filter(|q| on(q)).count() as f64 / points.len().max(1) as f64;
    let facet = Facet {
        dir,
        lo,
        hi,
        level,
        edge,
        share: measured,
    };
    // Highlights on the lit side, off the facet.
    let lit: Vec<P> = points
        .iter()
        .copied()
        .filter(|q| !on(q) && dot(*q, toward) >= 0.0)
        .collect();
    let radius = spec.radius_mm();
    let mut highlights = Vec::new();
    for _ in 0..1 + rng.below(2) {
        let a = rng.range(0.0, TAU);
        let h = Highlight {
            centre: lit.get(rng.below(lit.len().max(1))).copied().unwrap_or([0.0, 0.0]),
            axis: [a.cos(), a.sin()],
            long: radius * rng.range(0.08, 0.2),
            short: rng.range(1.0, 3.0),
            level: rng.range(HIGHLIGHT_LEVEL.0, HIGHLIGHT_LEVEL.1),
        };
        if !lit.is_empty() {
            highlights.push(h);
        }
    }
    let d = rng.range(SHADOW_OFFSET_PX.0, SHADOW_OFFSET_PX.1);
    let shadow = Shadow {
        offset: [-t[0] * d, -t[1] * d],
        sigma: rng.range(SHADOW_SIGMA_PX.0, SHADOW_SIGMA_PX.1),
        depth: rng.range(SHADOW_DEPTH.0, SHADOW_DEPTH.1),
    };
    (
        Appearance {
            contrast,
            texture: Texture::Metal(Metal {
                toward,
                shading,
                facet,
                highlights,
            }),
        },
        Body::Frontlit(shadow),
    )
}

/// Darkens the mat in `img` (`w`×`h`) under the shadows of `parts` (shape, pose, shadow): each
/// shadow its silhouette moved by its offset and blurred, at its depth; where shadows meet, the
/// darker one.
pub(crate) fn cast_shadows(img: &mut [f64], w: usize, h: usize, parts: &[(&PartSpec, &Pose, Shadow)]) {
    let mut dark = vec![0.0_f64; w * h];
    for (spec, pose, s) in parts {
        let moved = Pose {
            cx: pose.cx + s.offset[0],
            cy: pose.cy + s.offset[1],
            ..**pose
        };
        let cov = coverage(&moved.rings(spec.rings()), None, SHADOW_SUBROWS);
        let pad = (3.0 * s.sigma).ceil() as i64 + 1;
        let (bw, bh) = (cov.w + 2 * pad as usize, cov.h + 2 * pad as usize);
        let mut buf = vec![0.0; bw * bh];
        cov.for_each(|x, y, c| {
            buf[(y - cov.y0 + pad) as usize * bw + (x - cov.x0 + pad) as usize] = c;
        });
        blur(&mut buf, bw, bh, s.sigma);
        for (j, row) in buf.chunks_exact(bw).enumerate() {
            let y = cov.y0 - pad + j as i64;
            if y < 0 || y >= h as i64 {
                continue;
            }
            for (i, &v) in row.iter().enumerate() {
                let x = cov.x0 - pad + i as i64;
                if x >= 0 && x < w as i64 {
                    let k = y as usize * w + x as usize;
                    dark[k] = dark[k].max(s.depth * v);
                }
            }
        }
    }
    img.iter_mut().zip(&dark).for_each(|(v, d)| *v -= d);
}

/// Draws a front-lit part over what `img` holds (`w`×`h`): each pixel becomes, by the part's
/// coverage, the lit mat `lit` (without texture or shadow) plus the metal's level there (its
/// [`Metal`] face sampled 4×4 in the pixel; a plain level for another texture).
pub(crate) fn draw_metal(
    img: &mut [f64],
    lit: &[f64],
    w: usize,
    h: usize,
    spec: &PartSpec,
    pose: &Pose,
    look: &Appearance,
) {
    let radius = spec.radius_mm();
    silhouette(spec, pose, w, h).for_each(|x, y, c| {
        let i = y as usize * w + x as usize;
        let level = match &look.texture {
            Texture::Metal(m) => {
                let mut s = 0.0;
                for a in 0..4 {
                    for b in 0..4 {
                        let p = [
                            x as f64 + (f64::from(a) - 1.5) / 4.0,
                            y as f64 + (f64::from(b) - 1.5) / 4.0,
                        ];
                        s += m.level(pose.invert(p), look.contrast, radius);
                    }
                }
                s / 16.0
            }
            _ => look.contrast,
        };
        img[i] += c * (lit[i] + level - img[i]);
    });
}
