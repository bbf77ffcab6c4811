//! The `large` variant: one large part (a quarter to a half of the frame, dark or bright) and
//! up to two small ones on white printed paper (rows of dark text-like glyphs and ruled lines,
//! fixed for the set: in `background*.png` and every frame alike, hidden under the parts).
//!
//! The paper is what the user's photos showed (a dark printed guitar pick over a third of the
//! frame on printed paper, no empty shot): a platform whose cells scatter with the print, and a
//! part of uniform level that covers a third of the cells.

use super::effects::paper_texture;
use super::raster::{bounds, coverage_union, Pose};
use super::render::{Appearance, Lighting, Texture};
use super::rng::Rng;
use super::scene::{Body, Placed, SceneConfig, GAP_PX, INSIDE_MARGIN_PX};
use super::shapes::{norm, sub, PartSpec, P};

/// Mean level of the paper.
pub(crate) const PAPER_LEVEL: (f64, f64) = (200.0, 225.0);
/// Peak deviation of the paper's smooth lighting, levels.
pub(crate) const PAPER_LIGHTING: (f64, f64) = (6.0, 14.0);
/// Standard deviation of the paper's fine texture, levels.
pub(crate) const PAPER_TEXTURE_STD: (f64, f64) = (1.5, 3.0);
/// How much darker than the paper the text's ink is, levels.
pub(crate) const INK_DEPTH: (f64, f64) = (80.0, 150.0);
/// How much darker than the paper the ruled lines are, levels.
pub(crate) const RULE_DEPTH: (f64, f64) = (30.0, 70.0);
/// Height of the text's glyphs, px (at the reference frame).
pub(crate) const GLYPH_PX: (f64, f64) = (6.0, 10.0);
/// Share of the text lines that carry text (the others are paragraph breaks).
pub(crate) const TEXT_LINES: (f64, f64) = (0.5, 0.9);
/// Turn of the page against the frame, degrees.
pub(crate) const PAGE_TURN_DEG: (f64, f64) = (-8.0, 8.0);
/// Level of a dark large part.
pub(crate) const DARK_LEVEL: (f64, f64) = (20.0, 120.0);
/// Level of a bright large part.
pub(crate) const BRIGHT_LEVEL: (f64, f64) = (238.0, 250.0);
/// Share of the parts that are dark.
pub(crate) const DARK_SHARE: f64 = 0.55;
/// Least share of the reference frame a part of the catalogue covers to count as a large part.
pub(crate) const LARGE_FROM: f64 = 0.2;
/// Share of the frames whose large part is a template (the others: any large part).
pub(crate) const TAUGHT_SHARE: f64 = 0.6;
/// Most small parts beside the large one.
pub(crate) const SMALL_MAX: usize = 2;

/// The printed paper of a set.
#[derive(Clone, Debug)]
pub(crate) struct Paper {
    pub(crate) level: f64,
    pub(crate) lighting_amplitude: f64,
    pub(crate) texture_std: f64,
    pub(crate) page_turn_deg: f64,
    pub(crate) glyph_px: f64,
    pub(crate) line_pitch_px: f64,
    pub(crate) ink_depth: f64,
    pub(crate) rule_depth: f64,
    /// Share of the frame's pixels the print covers (text and rules, by coverage).
    pub(crate) ink_share: f64,
    lighting: Lighting,
    /// The empty paper: lighting, texture and print, row-major.
    field: Vec<f64>,
}

impl Paper {
    /// A random printed paper for a `w`×`h` frame whose parts are drawn at `px_per_mm`.
    pub(crate) fn random(rng: &mut Rng, w: usize, h: usize, px_per_mm: f64) -> Self {
        let level = rng.range(PAPER_LEVEL.0, PAPER_LEVEL.1);
        let lighting_amplitude = rng.range(PAPER_LIGHTING.0, PAPER_LIGHTING.1);
        let lighting = Lighting::random(rng, w, h, level, lighting_amplitude);
        let texture_std = rng.range(PAPER_TEXTURE_STD.0, PAPER_TEXTURE_STD.1);
        let texture = paper_texture(rng, w, h, texture_std);
        let page_turn_deg = rng.range(PAGE_TURN_DEG.0, PAGE_TURN_DEG.1);
        let glyph_px = rng.range(GLYPH_PX.0, GLYPH_PX.1) * px_per_mm.max(0.5);
        let line_pitch_px = glyph_px * rng.range(1.5, 2.0);
        let ink_depth = rng.range(INK_DEPTH.0, INK_DEPTH.1);
        let rule_depth = rng.range(RULE_DEPTH.0, RULE_DEPTH.1);
        let text_lines = rng.range(TEXT_LINES.0, TEXT_LINES.1);
        let (text, rules) = print(rng, w, h, page_turn_deg, glyph_px, line_pitch_px, text_lines);
        let mut field = lighting.field(w, h, 0.0);
        let mut ink = 0.0;
        for (i, v) in field.iter_mut().enumerate() {
            let (t, r) = (text[i].min(1.0), rules[i].min(1.0));
            *v += texture[i] - ink_depth * t - rule_depth * r * (1.0 - t);
            ink += t + r * (1.0 - t);
        }
        Paper {
            level,
            lighting_amplitude,
            texture_std,
            page_turn_deg,
            glyph_px,
            line_pitch_px,
            ink_depth,
            rule_depth,
            ink_share: ink / (w * h).max(1) as f64,
            lighting,
            field,
        }
    }

    /// The empty paper (lighting, texture and print), row-major.
    pub(crate) fn field(&self) -> &[f64] {
        &self.field
    }

    /// The paper's level without its print or texture at `p`.
    pub(crate) fn at(&self, p: P) -> f64 {
        self.lighting.at(p[0], p[1])
    }
}

/// The text's and the ruled lines' coverage (row-major, may exceed 1 where marks overlap) of a
/// page turned by `turn_deg` about the frame's centre: lines of glyphs `glyph` px high every
/// `pitch` px (a share `text_lines` of them written, the rest paragraph breaks), in one or two
/// columns, each line resting on a ruled line; a vertical margin rule.
fn print(
    rng: &mut Rng,
    w: usize,
    h: usize,
    turn_deg: f64,
    glyph: f64,
    pitch: f64,
    text_lines: f64,
) -> (Vec<f64>, Vec<f64>) {
    let (wf, hf) = (w as f64, h as f64);
    let centre = [(wf - 1.0) / 2.0, (hf - 1.0) / 2.0];
    let (s, c) = turn_deg.to_radians().sin_cos();
    // Page (u along the lines, v down) to image, about the frame's centre.
    let to_image = |q: P| [centre[0] + q[0] * c - q[1] * s, centre[1] + q[0] * s + q[1] * c];
    let rect = |u0: f64, v0: f64, u1: f64, v1: f64| {
        vec![vec![
            to_image([u0, v0]),
            to_image([u1, v0]),
            to_image([u1, v1]),
            to_image([u0, v1]),
        ]]
    };
    let half = 0.5 * wf.hypot(hf) + pitch;
    let in_frame = |u: f64, v: f64| {
        let p = to_image([u, v]);
        p[0] > -pitch && p[1] > -pitch && p[0] < wf + pitch && p[1] < hf + pitch
    };
    let columns = 1 + rng.below(2);
    let gutter = 3.0 * glyph;
    let margin = -half + rng.range(0.1, 0.4) * half;
    let col_w = (half - margin - gutter * (columns as f64 - 1.0)) / columns as f64;
    let (gw, adv, stroke) = (0.6 * glyph, 0.85 * glyph, (0.18 * glyph).max(1.0));
    let mut glyphs: Vec<Vec<Vec<P>>> = Vec::new();
    let mut rules: Vec<Vec<Vec<P>>> = Vec::new();
    let rule_w = rng.range(0.8, 1.4);
    let mut v = -half + rng.range(0.0, pitch);
    while v < half {
        let base = v + glyph;
        rules.push(rect(-half, base + 1.0, half, base + 1.0 + rule_w));
        for col in 0..columns {
            if !rng.chance(text_lines) {
                continue;
            }
            let u0 = margin + col as f64 * (col_w + gutter);
            // A ragged right end.
            let u_end = u0 + col_w * rng.range(0.6, 1.0);
            let mut u = u0;
            while u + gw < u_end {
                let word = 2 + rng.below(8);
                for _ in 0..word {
                    if u + gw >= u_end {
                        break;
                    }
                    if in_frame(u, v) || in_frame(u + gw, base) {
                        for [a0, b0, a1, b1] in glyph_bars(rng.below(7), gw, glyph, stroke) {
                            glyphs.push(rect(u + a0, v + b0, u + a1, v + b1));
                        }
                    }
                    u += adv;
                }
                u += adv;
            }
        }
        v += pitch;
    }
    // The margin rule.
    let um = margin - 2.0 * glyph;
    rules.push(rect(um, -half, um + rule_w, half));
    let field = |shapes: &[Vec<Vec<P>>]| {
        let mut out = vec![0.0; w * h];
        // One union per glyph row keeps each call small.
        for chunk in shapes.chunks(64) {
            coverage_union(chunk, Some((w, h)), 4).for_each(|x, y, cov| out[y as usize * w + x as usize] += cov);
        }
        out
    };
    (field(&glyphs), field(&rules))
}

/// The bars (`[u0, v0, u1, v1]` in the glyph's cell, `gw` wide, `gh` high, strokes `s` wide) of
/// glyph `shape`: an "l", an "o", an "n", a "t", an "e", an "i" or an "h".
fn glyph_bars(shape: usize, gw: f64, gh: f64, s: f64) -> Vec<[f64; 4]> {
    // x-height: the lower 60 % of the cell.
    let xh = gh - 0.6 * gh;
    match shape {
        0 => vec![[0.5 * gw - s / 2.0, 0.0, 0.5 * gw + s / 2.0, gh]],
        1 => vec![
            [0.0, xh, gw, xh + s],
            [0.0, gh - s, gw, gh],
            [0.0, xh + s, s, gh - s],
            [gw - s, xh + s, gw, gh - s],
        ],
        2 => vec![[0.0, xh, s, gh], [s, xh, gw, xh + s], [gw - s, xh + s, gw, gh]],
        3 => vec![
            [0.4 * gw - s / 2.0, 0.1 * gh, 0.4 * gw + s / 2.0, gh],
            [0.0, xh, gw, xh + s],
        ],
        4 => vec![
            [0.0, xh, gw, xh + s],
            [0.0, 0.5 * (xh + gh) - s / 2.0, gw, 0.5 * (xh + gh) + s / 2.0],
            [0.0, gh - s, gw, gh],
            [0.0, xh + s, s, gh - s],
        ],
        5 => vec![
            [0.5 * gw - s / 2.0, xh, 0.5 * gw + s / 2.0, gh],
            [0.5 * gw - s / 2.0, xh - 2.0 * s, 0.5 * gw + s / 2.0, xh - s],
        ],
        _ => vec![[0.0, 0.0, s, gh], [s, xh, gw, xh + s], [gw - s, xh + s, gw, gh]],
    }
}

/// Plans one frame of a `large` set: one large part of `cat` (a share of the frame of
/// [`LARGE_FROM`] or more; a template in [`TAUGHT_SHARE`] of the frames, else any) at a random
/// pose inside the frame, then up to [`SMALL_MAX`] small
/// ones where they fit; each part opaque, dark or bright, its contrast measured against the
/// paper's level at its centroid.
pub(crate) fn plan(rng: &mut Rng, cat: &[PartSpec], cfg: &SceneConfig, paper: &Paper) -> Vec<Placed> {
    let frame = (cfg.w * cfg.h) as f64;
    let k = cfg.px_per_mm;
    let is_large = |s: &PartSpec| s.area_mm2() * k * k >= LARGE_FROM * frame;
    let large: Vec<usize> = (0..cat.len()).filter(|&i| is_large(&cat[i])).collect();
    let small: Vec<usize> = (0..cat.len()).filter(|&i| !is_large(&cat[i])).collect();
    let mut placed: Vec<Placed> = Vec::new();
    if !large.is_empty() {
        // A template more often than not.
        let taught: Vec<usize> = large.iter().copied().filter(|&i| cat[i].is_template).collect();
        let from = if !taught.is_empty() && rng.chance(TAUGHT_SHARE) {
            &taught
        } else {
            &large
        };
        let spec = from[rng.below(from.len())];
        for _ in 0..200 {
            if let Some(p) = try_place(rng, cat, spec, cfg, &placed, paper) {
                placed.push(p);
                break;
            }
        }
    }
    if !small.is_empty() {
        for _ in 0..rng.below(SMALL_MAX + 1) {
            let spec = small[rng.below(small.len())];
            for _ in 0..60 {
                if let Some(p) = try_place(rng, cat, spec, cfg, &placed, paper) {
                    placed.push(p);
                    break;
                }
            }
        }
    }
    placed
}

/// Part `spec_i` at a random angle, scale and place inside the frame, its bounding circle
/// [`GAP_PX`] from the others', or `None` where it does not fit.
fn try_place(
    rng: &mut Rng,
    cat: &[PartSpec],
    spec_i: usize,
    cfg: &SceneConfig,
    placed: &[Placed],
    paper: &Paper,
) -> Option<Placed> {
    let spec = &cat[spec_i];
    let angle_deg = rng.range(0.0, 360.0);
    let scale = rng.range(cfg.scale.0, cfg.scale.1);
    let k = cfg.px_per_mm * scale;
    let b = bounds(&Pose::new(0.0, 0.0, angle_deg, k).rings(spec.rings()));
    let (w, h, m) = (cfg.w as f64, cfg.h as f64, INSIDE_MARGIN_PX);
    let (x0, x1, y0, y1) = (m - b[0], w - 1.0 - m - b[2], m - b[1], h - 1.0 - m - b[3]);
    if x0 > x1 || y0 > y1 {
        return None;
    }
    let centre = [rng.range(x0, x1), rng.range(y0, y1)];
    let radius = spec.radius_mm() * k;
    for q in placed {
        let rq = cat[q.spec].radius_mm() * q.pose.k;
        if norm(sub(centre, [q.pose.cx, q.pose.cy])) < radius + rq + GAP_PX {
            return None;
        }
    }
    let level = if rng.chance(DARK_SHARE) {
        rng.range(DARK_LEVEL.0, DARK_LEVEL.1)
    } else {
        rng.range(BRIGHT_LEVEL.0, BRIGHT_LEVEL.1)
    };
    Some(Placed {
        spec: spec_i,
        pose: Pose::new(centre[0], centre[1], angle_deg, k),
        angle_deg,
        scale,
        partial: false,
        visible: 1.0,
        look: Appearance {
            contrast: level - paper.at(centre),
            texture: Texture::Plain,
        },
        depth: None,
        body: Body::Opaque { level },
        varied: None,
        flipped: false,
        touching: false,
    })
}
