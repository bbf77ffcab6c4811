//! Placement: which parts a frame holds, where, at what angle, scale and look.
//!
//! Parts do not overlap: their bounding circles (about the centroid) stay [`GAP_PX`] apart. Parts
//! lie fully inside the frame, at least [`INSIDE_MARGIN_PX`] from its edge, except the parts of
//! the `border` variant that are placed across an edge on purpose (`partial`). Stereo parts lie
//! inside both images of the pair.

use std::f64::consts::TAU;
use std::sync::Arc;

use super::effects::CloseCamera;
use super::frontlit::Shadow;
use super::raster::{bounds, clipped_area, Pose};
use super::render::{Appearance, Texture};
use super::rng::Rng;
use super::shapes::{norm, sub, PartSpec, Varied, P};

/// Free space between the bounding circles of two parts, px.
pub(crate) const GAP_PX: f64 = 8.0;
/// Least distance of a whole part from the frame edge, px (the blur reaches ~2 px).
pub(crate) const INSIDE_MARGIN_PX: f64 = 4.0;
/// Least distance of a label from the silhouette's border, px (the brief asks for 3).
pub(crate) const LABEL_MARGIN_PX: f64 = 3.5;
/// Share of distractors among the parts.
pub(crate) const DISTRACTOR_SHARE: f64 = 0.2;
/// Share of parts placed across the frame edge in the `border` variant.
pub(crate) const PARTIAL_SHARE: f64 = 0.4;
/// Visible share of a partial part's area.
pub(crate) const PARTIAL_VISIBLE: (f64, f64) = (0.3, 0.85);
/// Part heights above the platform in stereo sets, mm.
pub(crate) const HEIGHT_MM: (f64, f64) = (5.0, 60.0);

/// A rectified stereo rig looking down at the platform.
#[derive(Clone, Copy, Debug)]
pub(crate) struct StereoRig {
    pub(crate) f_px: f64,
    pub(crate) baseline_mm: f64,
    pub(crate) platform_z_mm: f64,
}

/// What a frame is made of.
#[derive(Clone, Debug)]
pub(crate) struct SceneConfig {
    pub(crate) w: usize,
    pub(crate) h: usize,
    /// Nominal scale (templates), px per mm.
    pub(crate) px_per_mm: f64,
    /// Range of |contrast|, levels.
    pub(crate) contrast: (f64, f64),
    /// Least |level − platform| anywhere on a part (texture included).
    pub(crate) min_contrast: f64,
    pub(crate) border: bool,
    pub(crate) stereo: Option<StereoRig>,
    /// A close camera (`thick`): parts are placed so that their walls keep the gap and stay inside.
    pub(crate) close: Option<CloseFit>,
    /// Range of a flat part's scale over the template's (without a stereo rig).
    pub(crate) scale: (f64, f64),
    /// Whether each part is made with its own proportions ([`PartSpec::varied`], `rods`).
    pub(crate) vary: bool,
}

/// Room a part needs under a close camera: its top face is its bottom face magnified by up to
/// `s_max` about the camera's principal point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CloseFit {
    pub(crate) camera: CloseCamera,
    pub(crate) s_max: f64,
}

/// What a part is besides a flat silhouette of one look.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) enum Body {
    /// A flat part (every variant but `thick`, `backlit`, `rods` and `frontlit`).
    #[default]
    Flat,
    /// A prism of this height under a close camera; its walls at `wall` levels above the platform.
    Thick { thickness_mm: f64, wall: f64 },
    /// Opaque in front of a backlight: the silhouette at this gray level.
    Opaque { level: f64 },
    /// A front-lit metal part (`frontlit`): opaque over the mat, throwing this shadow on it.
    Frontlit(Shadow),
}

/// One part placed in a frame.
#[derive(Clone, Debug)]
pub(crate) struct Placed {
    /// Index into the catalogue.
    pub(crate) spec: usize,
    /// Pose in the (left) image.
    pub(crate) pose: Pose,
    pub(crate) angle_deg: f64,
    /// Scale relative to the template.
    pub(crate) scale: f64,
    pub(crate) partial: bool,
    /// Share of the area inside the frame.
    pub(crate) visible: f64,
    pub(crate) look: Appearance,
    /// Stereo: depth of the top face (mm) and disparity (px).
    pub(crate) depth: Option<(f64, f64)>,
    /// Set after planning by the variants that need it.
    pub(crate) body: Body,
    /// The part's own proportions (`rods`) or its mirror image (`flipped`), or `None`: drawn as
    /// its template.
    pub(crate) varied: Option<Arc<Varied>>,
    /// Lying upside down (`flipped`): drawn as its template's mirror image.
    pub(crate) flipped: bool,
    /// Against or partly over another part (`touching`).
    pub(crate) touching: bool,
}

impl Placed {
    /// The part as drawn: its own shape when it varies, else its catalogue entry in `cat`.
    pub(crate) fn drawn<'a>(&'a self, cat: &'a [PartSpec]) -> &'a PartSpec {
        self.varied.as_ref().map_or(&cat[self.spec], |v| &v.spec)
    }
}

/// Plans one frame: 2–5 parts (fewer when they do not fit).
pub(crate) fn plan(rng: &mut Rng, cat: &[PartSpec], cfg: &SceneConfig) -> Vec<Placed> {
    let templates: Vec<usize> = (0..cat.len()).filter(|&i| cat[i].is_template).collect();
    let distractors: Vec<usize> = (0..cat.len()).filter(|&i| !cat[i].is_template).collect();
    let want = 2 + rng.below(4);
    let mut placed: Vec<Placed> = Vec::new();
    for _ in 0..want {
        let spec = if !distractors.is_empty() && rng.chance(DISTRACTOR_SHARE) {
            distractors[rng.below(distractors.len())]
        } else {
            templates[rng.below(templates.len())]
        };
        for _attempt in 0..60 {
            if let Some(p) = try_place(rng, cat, spec, cfg, &placed) {
                placed.push(p);
                break;
            }
        }
    }
    placed
}

fn try_place(rng: &mut Rng, cat: &[PartSpec], spec_i: usize, cfg: &SceneConfig, placed: &[Placed]) -> Option<Placed> {
    let angle_deg = rng.range(0.0, 360.0);
    let (scale, depth) = match cfg.stereo {
        Some(s) => {
            let z = s.platform_z_mm - rng.range(HEIGHT_MM.0, HEIGHT_MM.1);
            (s.platform_z_mm / z, Some((z, s.f_px * s.baseline_mm / z)))
        }
        None => (rng.range(cfg.scale.0, cfg.scale.1), None),
    };
    let varied = if cfg.vary { cat[spec_i].varied(rng) } else { None };
    let spec = varied.as_ref().map_or(&cat[spec_i], |v| &v.spec);
    let k = cfg.px_per_mm * scale;
    let b = bounds(&Pose::new(0.0, 0.0, angle_deg, k).rings(spec.rings()));
    let radius = spec.radius_mm() * k;
    let (w, h) = (cfg.w as f64, cfg.h as f64);
    let m = INSIDE_MARGIN_PX;
    let shift = depth.map_or(0.0, |d| d.1);
    let within = |rng: &mut Rng, lo: f64, hi: f64| {
        if lo <= hi {
            Some(rng.range(lo, hi))
        } else {
            None
        }
    };
    let partial = cfg.border && rng.chance(PARTIAL_SHARE);
    let (cx, cy) = if partial {
        let side = rng.below(4);
        let t = rng.range(0.45, 0.85);
        let (ex, ey) = (b[2] - b[0], b[3] - b[1]);
        let free_x = within(rng, m - b[0], w - 1.0 - m - b[2]).unwrap_or((w - 1.0) / 2.0);
        let free_y = within(rng, m - b[1], h - 1.0 - m - b[3]).unwrap_or((h - 1.0) / 2.0);
        match side {
            0 => (-0.5 + t * ex - b[2], free_y),
            1 => (w - 0.5 - t * ex - b[0], free_y),
            2 => (free_x, -0.5 + t * ey - b[3]),
            _ => (free_x, h - 0.5 - t * ey - b[1]),
        }
    } else {
        (
            within(rng, m - b[0] + shift, w - 1.0 - m - b[2])?,
            within(rng, m - b[1], h - 1.0 - m - b[3])?,
        )
    };
    let gap = GAP_PX + if cfg.stereo.is_some() { 5.0 } else { 0.0 };
    let centre: P = [cx, cy];
    // The circle about the centroid that holds the part, under a close camera its walls too.
    let reach = |c: P, r: f64| {
        cfg.close
            .map_or(r, |f| f.s_max * r + norm(sub(c, f.camera.centre)) * (f.s_max - 1.0))
    };
    for q in placed {
        let rq = q.drawn(cat).radius_mm() * q.pose.k;
        let qc = [q.pose.cx, q.pose.cy];
        if norm(sub(centre, qc)) < reach(centre, radius) + reach(qc, rq) + gap {
            return None;
        }
    }
    let pose = Pose::new(cx, cy, angle_deg, k);
    if let Some(f) = cfg.close {
        // The top face (the highest there may be) inside the frame too; the walls lie between.
        let t = bounds(&f.camera.lift(&pose, f.s_max).rings(spec.rings()));
        if t[0] < m || t[1] < m || t[2] > w - 1.0 - m || t[3] > h - 1.0 - m {
            return None;
        }
    }
    let visible = if partial {
        if !(0.0..=w - 1.0).contains(&cx) || !(0.0..=h - 1.0).contains(&cy) {
            return None;
        }
        let v = clipped_area(&pose.rings(spec.rings()), [-0.5, -0.5, w - 0.5, h - 0.5]) / (spec.area_mm2() * k * k);
        if !(PARTIAL_VISIBLE.0..=PARTIAL_VISIBLE.1).contains(&v) {
            return None;
        }
        v
    } else {
        1.0
    };
    let look = appearance(rng, spec, k, cfg);
    Some(Placed {
        spec: spec_i,
        pose,
        angle_deg,
        scale,
        partial,
        visible,
        look,
        depth,
        body: Body::Flat,
        varied: varied.map(Arc::new),
        flipped: false,
        touching: false,
    })
}

/// Contrast and texture of a part drawn at `k` px per mm.
fn appearance(rng: &mut Rng, spec: &PartSpec, k: f64, cfg: &SceneConfig) -> Appearance {
    let sign = rng.sign();
    let mag = rng.range(cfg.contrast.0, cfg.contrast.1);
    let contrast = sign * mag;
    let roll = rng.uniform();
    let gradient = |rng: &mut Rng| {
        let a = rng.range(0.0, TAU);
        // Gentle: at most a quarter of the contrast, never closer than min_contrast to the platform.
        let amplitude = rng
            .range(6.0, 15.0)
            .min(0.25 * mag)
            .min(mag - cfg.min_contrast)
            .max(0.0);
        Texture::Gradient {
            dir: [a.cos(), a.sin()],
            amplitude,
        }
    };
    let texture = if roll < 0.35 {
        label(rng, spec, k, sign, mag, cfg.min_contrast).unwrap_or_else(|| gradient(rng))
    } else if roll < 0.65 {
        gradient(rng)
    } else {
        Texture::Plain
    };
    Appearance { contrast, texture }
}

/// A label rectangle (solid or 2–4 bars) that fits inside the silhouette with
/// [`LABEL_MARGIN_PX`] to spare, or `None` when 60 tries find no room. A try: a random interior
/// point, a rectangle about it as large as its clearance allows (at most 45 % of the part's
/// extent), shrunk until it fits. The largest of the first 6 that fit is kept.
fn label(rng: &mut Rng, spec: &PartSpec, k: f64, sign: f64, mag: f64, min_contrast: f64) -> Option<Texture> {
    let margin = LABEL_MARGIN_PX / k;
    let (min_long, min_short) = (8.0 / k, 5.0 / k);
    let b = spec.bbox_mm();
    let max_long = 0.45 * (b[2] - b[0]).max(b[3] - b[1]);
    let mut best: Option<([f64; 4], bool)> = None;
    let mut found = 0;
    for _ in 0..60 {
        let (cx, cy) = (rng.range(b[0], b[2]), rng.range(b[1], b[3]));
        let aspect = rng.range(1.4, 3.0);
        let along_x = rng.chance(0.5);
        if !spec.coverage(cx, cy) {
            continue;
        }
        let room = clearance(spec.rings(), [cx, cy]) - margin;
        if room <= 0.0 {
            continue;
        }
        let mut short = 2.0 * 2.0 * room / (1.0 + aspect * aspect).sqrt();
        let mut long = (aspect * short).min(max_long);
        short = short.min(long / 1.4);
        while long >= min_long && short >= min_short {
            let (hw, hh) = if along_x {
                (long / 2.0, short / 2.0)
            } else {
                (short / 2.0, long / 2.0)
            };
            let rect = [cx - hw, cy - hh, cx + hw, cy + hh];
            if rect_clear(spec.rings(), rect, margin) {
                let area = |r: &[f64; 4]| (r[2] - r[0]) * (r[3] - r[1]);
                if best.is_none_or(|(r, _)| area(&rect) > area(&r)) {
                    best = Some((rect, along_x));
                }
                found += 1;
                break;
            }
            long *= 0.9;
            short *= 0.9;
        }
        if found == 6 {
            break;
        }
    }
    best.map(|(rect, along_x)| label_texture(rng, rect, along_x, k, sign, mag, min_contrast))
}

/// A solid label or 2–4 bars in `rect`, of a level 15–35 away from the part's (never closer
/// than `min_contrast` to the platform).
fn label_texture(
    rng: &mut Rng,
    rect: [f64; 4],
    along_x: bool,
    k: f64,
    sign: f64,
    mag: f64,
    min_contrast: f64,
) -> Texture {
    let delta = rng.range(15.0, 35.0);
    let lab_mag = if mag - delta >= min_contrast && rng.chance(0.5) {
        mag - delta
    } else {
        (mag + delta).min(120.0)
    };
    let bars = 2 + rng.below(3);
    let stripes = (2 * bars - 1) as f64;
    let long = if along_x { rect[2] - rect[0] } else { rect[3] - rect[1] };
    let rects = if rng.chance(0.5) && long * k / stripes >= 2.0 {
        (0..bars)
            .map(|i| {
                let s0 = (2 * i) as f64 * long / stripes;
                let s1 = s0 + long / stripes;
                if along_x {
                    [rect[0] + s0, rect[1], rect[0] + s1, rect[3]]
                } else {
                    [rect[0], rect[1] + s0, rect[2], rect[1] + s1]
                }
            })
            .collect()
    } else {
        vec![rect]
    };
    Texture::Label {
        bars: rects,
        level: sign * lab_mag,
    }
}

/// Distance from `p` to the nearest border segment.
pub(crate) fn clearance(rings: &[Vec<P>], p: P) -> f64 {
    rings
        .iter()
        .flat_map(|r| {
            r.iter()
                .enumerate()
                .map(move |(i, &a)| point_seg_dist(p, a, r[(i + 1) % r.len()]))
        })
        .fold(f64::MAX, f64::min)
}

fn point_rect_dist(p: P, r: [f64; 4]) -> f64 {
    let dx = (r[0] - p[0]).max(p[0] - r[2]).max(0.0);
    let dy = (r[1] - p[1]).max(p[1] - r[3]).max(0.0);
    dx.hypot(dy)
}

fn point_seg_dist(p: P, a: P, b: P) -> f64 {
    let ab = sub(b, a);
    let l2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    norm(sub(p, [a[0] + t * ab[0], a[1] + t * ab[1]]))
}

fn segments_cross(a: P, b: P, c: P, d: P) -> bool {
    let orient = |p: P, q: P, r: P| (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]);
    let (d1, d2) = (orient(c, d, a), orient(c, d, b));
    let (d3, d4) = (orient(a, b, c), orient(a, b, d));
    (d1 * d2 <= 0.0) && (d3 * d4 <= 0.0)
}

/// True when no border segment of `rings` comes within `margin` of the rectangle.
pub(crate) fn rect_clear(rings: &[Vec<P>], r: [f64; 4], margin: f64) -> bool {
    let corners = [[r[0], r[1]], [r[2], r[1]], [r[2], r[3]], [r[0], r[3]]];
    for ring in rings {
        for (i, &a) in ring.iter().enumerate() {
            let b = ring[(i + 1) % ring.len()];
            if a[0].max(b[0]) < r[0] - margin
                || a[0].min(b[0]) > r[2] + margin
                || a[1].max(b[1]) < r[1] - margin
                || a[1].min(b[1]) > r[3] + margin
            {
                continue;
            }
            if point_rect_dist(a, r) < margin || point_rect_dist(b, r) < margin {
                return false;
            }
            if (0..4).any(|e| segments_cross(a, b, corners[e], corners[(e + 1) % 4])) {
                return false;
            }
            if corners.iter().any(|&c| point_seg_dist(c, a, b) < margin) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::super::shapes::catalogue;
    use super::*;

    fn cfg(border: bool) -> SceneConfig {
        SceneConfig {
            w: 640,
            h: 480,
            px_per_mm: 1.0,
            contrast: (40.0, 90.0),
            min_contrast: 30.0,
            border,
            stereo: None,
            close: None,
            scale: (0.97, 1.03),
            vary: false,
        }
    }

    #[test]
    fn gen_placements_respect_gap_frame_and_labels() {
        let cat = catalogue();
        let c = cfg(false);
        let mut labels = 0;
        for f in 0..60 {
            let mut rng = Rng::stream(3, 77, f);
            let parts = plan(&mut rng, &cat, &c);
            assert!(parts.len() >= 2 && parts.len() <= 5);
            for (i, p) in parts.iter().enumerate() {
                let spec = &cat[p.spec];
                let rings = p.pose.rings(spec.rings());
                let b = bounds(&rings);
                assert!(b[0] >= INSIDE_MARGIN_PX && b[2] <= 639.0 - INSIDE_MARGIN_PX);
                assert!(b[1] >= INSIDE_MARGIN_PX && b[3] <= 479.0 - INSIDE_MARGIN_PX);
                for q in &parts[i + 1..] {
                    let gap = norm(sub([p.pose.cx, p.pose.cy], [q.pose.cx, q.pose.cy]))
                        - spec.radius_mm() * p.pose.k
                        - cat[q.spec].radius_mm() * q.pose.k;
                    assert!(gap >= GAP_PX);
                }
                if let Texture::Label { bars, level } = &p.look.texture {
                    labels += 1;
                    assert_eq!(level.signum(), p.look.contrast.signum());
                    assert!(level.abs() >= 30.0);
                    for r in bars {
                        // Every point of the bar is inside, 3 px (3 mm here) from the border.
                        assert!(rect_clear(spec.rings(), *r, 3.0 / p.pose.k));
                        assert!(spec.coverage((r[0] + r[2]) / 2.0, (r[1] + r[3]) / 2.0));
                    }
                }
            }
        }
        assert!(labels > 5);
    }

    #[test]
    fn gen_border_parts_are_cut() {
        let cat = catalogue();
        let c = cfg(true);
        let mut partial = 0;
        for f in 0..40 {
            let mut rng = Rng::stream(4, 77, f);
            for p in plan(&mut rng, &cat, &c) {
                let b = bounds(&p.pose.rings(cat[p.spec].rings()));
                let cut = b[0] < -0.5 || b[1] < -0.5 || b[2] > 639.5 || b[3] > 479.5;
                assert_eq!(cut, p.partial);
                if p.partial {
                    partial += 1;
                    assert!(p.visible >= 0.3 && p.visible <= 0.85);
                }
            }
        }
        assert!(partial > 10);
    }

    #[test]
    fn gen_rect_clearance() {
        let sq = vec![vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]];
        assert!(rect_clear(&sq, [3.0, 3.0, 7.0, 7.0], 2.9));
        assert!(!rect_clear(&sq, [3.0, 3.0, 7.0, 7.0], 3.1));
        assert!(!rect_clear(&sq, [-1.0, 3.0, 7.0, 7.0], 0.5));
    }
}
