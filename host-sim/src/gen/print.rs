//! Print on a part's face (`printed` variant): dark ink (text-like rows of glyph blobs, a logo
//! ring) and, on dark parts, light patches near the platform's own level (glare, worn paint).
//!
//! Every mark lies inside the silhouette, [`LABEL_MARGIN_PX`] or more from its border (holes
//! included), and the marks of a part do not touch, so the part's outline and its area centroid
//! are those of the plain silhouette; a mask that keeps only pixels unlike the platform may still
//! cut a patch, or the thin rim around a glyph where the ink's edge passes the platform's level,
//! as a hole.

use std::f64::consts::TAU;

use super::render::{Mark, Texture};
use super::rng::Rng;
use super::scene::{rect_clear, LABEL_MARGIN_PX};
use super::shapes::{PartSpec, P};

/// Share of parts that carry print.
pub(crate) const PRINTED_SHARE: f64 = 0.7;
/// Least free space between two marks, px.
const SPACING_PX: f64 = 1.5;
/// Tries to find room for one mark.
const TRIES: usize = 40;

/// Print for a part of `contrast` levels drawn at `k` px per mm, or `None` when nothing fits.
/// Ink is darker than the platform on a light part (35–75 levels below it) and 25–45 levels
/// darker than a dark part; a dark part may also get 1–2 patches within 8 levels of the platform.
pub(crate) fn print(rng: &mut Rng, spec: &PartSpec, k: f64, contrast: f64) -> Option<Texture> {
    let margin = LABEL_MARGIN_PX / k;
    let ink = if contrast > 0.0 {
        -rng.range(35.0, 75.0)
    } else {
        (contrast - rng.range(25.0, 45.0)).max(-130.0)
    };
    let mut taken: Vec<[f64; 4]> = Vec::new();
    let mut marks = Vec::new();
    for _ in 0..1 + rng.below(2) {
        marks.extend(text_block(rng, spec, k, margin, &mut taken, ink));
    }
    if rng.chance(0.6) {
        marks.extend(logo_ring(rng, spec, k, margin, &mut taken, ink));
    }
    if contrast < 0.0 {
        for _ in 0..1 + rng.below(2) {
            marks.extend(patch(rng, spec, k, margin, &mut taken));
        }
    }
    (!marks.is_empty()).then_some(Texture::Print { marks })
}

/// A free place for a `size` (mm) rectangle: inside the part, `margin` from its border, clear
/// of the rectangles `taken`; the place is added to them.
fn place(
    rng: &mut Rng,
    spec: &PartSpec,
    size: P,
    margin: f64,
    spacing: f64,
    taken: &mut Vec<[f64; 4]>,
) -> Option<[f64; 4]> {
    let b = spec.bbox_mm();
    for _ in 0..TRIES {
        let c = [rng.range(b[0], b[2]), rng.range(b[1], b[3])];
        let r = [
            c[0] - size[0] / 2.0,
            c[1] - size[1] / 2.0,
            c[0] + size[0] / 2.0,
            c[1] + size[1] / 2.0,
        ];
        let apart = |t: &[f64; 4]| {
            r[0] > t[2] + spacing || t[0] > r[2] + spacing || r[1] > t[3] + spacing || t[1] > r[3] + spacing
        };
        if spec.coverage(c[0], c[1]) && rect_clear(spec.rings(), r, margin) && taken.iter().all(apart) {
            taken.push(r);
            return Some(r);
        }
    }
    None
}

/// 1–2 lines of 2–8 glyph blobs 5–9 px high along the part's x or y axis (shrunk until it fits).
fn text_block(rng: &mut Rng, spec: &PartSpec, k: f64, margin: f64, taken: &mut Vec<[f64; 4]>, ink: f64) -> Vec<Mark> {
    let mut gh = rng.range(5.0, 9.0) / k;
    let mut lines = 1 + rng.below(2);
    let mut per_line = 3 + rng.below(6);
    let along_x = rng.chance(0.5);
    let shapes: Vec<usize> = (0..16).map(|_| rng.below(7)).collect();
    loop {
        let (gw, adv, lead) = (0.65 * gh, 0.9 * gh, 1.5 * gh);
        let (len, depth) = (per_line as f64 * adv - (adv - gw), lines as f64 * lead - (lead - gh));
        let size = if along_x { [len, depth] } else { [depth, len] };
        if let Some(r) = place(rng, spec, size, margin, SPACING_PX / k, taken) {
            let stroke = (1.2 / k).max(0.22 * gh);
            let mut out = Vec::new();
            for line in 0..lines {
                for i in 0..per_line {
                    let shape = shapes[(line * per_line + i) % shapes.len()];
                    // Cell in text coordinates (u along the line, v across), mm from the block's corner.
                    let (u, v) = (i as f64 * adv, line as f64 * lead);
                    let Some(rings) = glyph(shape, u, v, gw, gh, stroke) else {
                        continue;
                    };
                    let to_part = |q: P| {
                        if along_x {
                            [r[0] + q[0], r[1] + q[1]]
                        } else {
                            [r[0] + q[1], r[1] + q[0]]
                        }
                    };
                    out.push(Mark {
                        rings: rings
                            .iter()
                            .map(|ring| ring.iter().map(|&q| to_part(q)).collect())
                            .collect(),
                        level: ink,
                        ink: true,
                    });
                }
            }
            return out;
        }
        if per_line > 2 {
            per_line -= 1;
        } else if lines > 1 {
            lines = 1;
        } else if gh * k > 5.0 {
            gh = (gh * 0.85).max(5.0 / k);
        } else {
            return Vec::new();
        }
    }
}

/// A glyph blob in the cell `[u, u + gw] × [v, v + gh]` (text coordinates, mm): a block, a bar,
/// an "o", an "n", an "L", a "T", or a space (`None`).
fn glyph(shape: usize, u: f64, v: f64, gw: f64, gh: f64, s: f64) -> Option<Vec<Vec<P>>> {
    let (u1, v1, uc) = (u + gw, v + gh, u + gw / 2.0);
    let rings = match shape {
        0 => vec![vec![[u, v], [u1, v], [u1, v1], [u, v1]]],
        1 => vec![vec![
            [uc - s / 2.0, v],
            [uc + s / 2.0, v],
            [uc + s / 2.0, v1],
            [uc - s / 2.0, v1],
        ]],
        2 => vec![
            vec![[u, v], [u1, v], [u1, v1], [u, v1]],
            vec![[u + s, v + s], [u1 - s, v + s], [u1 - s, v1 - s], [u + s, v1 - s]],
        ],
        3 => vec![vec![
            [u, v1],
            [u, v],
            [u1, v],
            [u1, v1],
            [u1 - s, v1],
            [u1 - s, v + s],
            [u + s, v + s],
            [u + s, v1],
        ]],
        4 => vec![vec![
            [u, v],
            [u + s, v],
            [u + s, v1 - s],
            [u1, v1 - s],
            [u1, v1],
            [u, v1],
        ]],
        5 => vec![vec![
            [u, v],
            [u1, v],
            [u1, v + s],
            [uc + s / 2.0, v + s],
            [uc + s / 2.0, v1],
            [uc - s / 2.0, v1],
            [uc - s / 2.0, v + s],
            [u, v + s],
        ]],
        _ => return None,
    };
    Some(rings)
}

/// Points of a circle (or of an arc from `a0` to `a1`), 0.2 mm chords or finer.
fn arc(c: P, r: f64, a0: f64, a1: f64) -> Vec<P> {
    let n = ((a1 - a0).abs() * r / 0.2).ceil().max(12.0) as usize;
    (0..=n)
        .map(|i| {
            let a = a0 + (a1 - a0) * i as f64 / n as f64;
            [c[0] + r * a.cos(), c[1] + r * a.sin()]
        })
        .collect()
}

/// A logo: a ring 5–12 px in radius with a 1.5–3 px stroke, closed or open like a "C".
fn logo_ring(rng: &mut Rng, spec: &PartSpec, k: f64, margin: f64, taken: &mut Vec<[f64; 4]>, ink: f64) -> Option<Mark> {
    let ro = rng.range(5.0, 12.0) / k;
    let ri = ro - rng.range(1.5, 3.0) / k;
    let open = rng.chance(0.5);
    let turn = rng.range(0.0, TAU);
    let r = place(rng, spec, [2.0 * ro, 2.0 * ro], margin, SPACING_PX / k, taken)?;
    let c = [(r[0] + r[2]) / 2.0, (r[1] + r[3]) / 2.0];
    let rings = if open {
        let gap = 0.5;
        let mut outline = arc(c, ro, turn + gap, turn + TAU - gap);
        outline.extend(arc(c, ri, turn + TAU - gap, turn + gap));
        vec![outline]
    } else {
        let mut outer = arc(c, ro, 0.0, TAU);
        let mut inner = arc(c, ri, 0.0, TAU);
        outer.pop();
        inner.pop();
        vec![outer, inner]
    };
    Some(Mark {
        rings,
        level: ink,
        ink: true,
    })
}

/// A light patch: an ellipse 3–8 px in half-length within 8 levels of the platform.
fn patch(rng: &mut Rng, spec: &PartSpec, k: f64, margin: f64, taken: &mut Vec<[f64; 4]>) -> Option<Mark> {
    let a = rng.range(3.0, 8.0) / k;
    let b = a * rng.range(0.5, 1.0);
    let turn = rng.range(0.0, TAU);
    let level = rng.range(-8.0, 8.0);
    let (s, co) = turn.sin_cos();
    let half = [(a * co).hypot(b * s), (a * s).hypot(b * co)];
    let r = place(rng, spec, [2.0 * half[0], 2.0 * half[1]], margin, SPACING_PX / k, taken)?;
    let c = [(r[0] + r[2]) / 2.0, (r[1] + r[3]) / 2.0];
    let n = ((a * TAU / 0.2).ceil() as usize).max(24);
    let ring = (0..n)
        .map(|i| {
            let t = TAU * i as f64 / n as f64;
            let (x, y) = (a * t.cos(), b * t.sin());
            [c[0] + x * co - y * s, c[1] + x * s + y * co]
        })
        .collect();
    Some(Mark {
        rings: vec![ring],
        level,
        ink: false,
    })
}

#[cfg(test)]
mod tests {
    use super::super::shapes::catalogue;
    use super::*;

    #[test]
    fn gen_print_stays_inside_and_apart() {
        let cat = catalogue();
        let (mut printed, mut patches, mut rings) = (0, 0, 0);
        for (n, spec) in cat.iter().enumerate() {
            for t in 0..8u64 {
                let mut rng = Rng::stream(5, 9, n as u64 * 100 + t);
                let contrast = if t % 2 == 0 { 60.0 } else { -60.0 };
                let Some(Texture::Print { marks }) = print(&mut rng, spec, 1.0, contrast) else {
                    continue;
                };
                printed += 1;
                for m in &marks {
                    patches += usize::from(!m.ink);
                    rings += usize::from(m.rings.len() == 2 && m.rings[0].len() > 20);
                    if m.ink {
                        assert!(m.level < 0.0 && (m.level - contrast).abs() >= 20.0);
                    } else {
                        assert!(contrast < 0.0 && m.level.abs() <= 8.0);
                    }
                    // Every vertex inside the part, the mark's box clear of the border.
                    let b = super::super::raster::bounds(&m.rings);
                    assert!(rect_clear(spec.rings(), b, 3.0), "{}", spec.name);
                    for q in m.rings.iter().flatten() {
                        assert!(spec.coverage(q[0], q[1]), "{}", spec.name);
                    }
                }
                // Marks apart.
                for (i, a) in marks.iter().enumerate() {
                    let ba = super::super::raster::bounds(&a.rings);
                    for b in &marks[i + 1..] {
                        let bb = super::super::raster::bounds(&b.rings);
                        let overlap = ba[0] < bb[2] && bb[0] < ba[2] && ba[1] < bb[3] && bb[1] < ba[3];
                        assert!(!overlap, "{}: marks overlap", spec.name);
                    }
                }
            }
        }
        assert!(printed > 60 && patches > 10 && rings > 3, "{printed} {patches} {rings}");
    }
}
