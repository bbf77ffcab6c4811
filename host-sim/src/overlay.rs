//! Overlay pictures: each part's contour, its class name (or "unknown"), f' and the
//! verification score, a cross at its position and an arrow along its angle (none for an
//! unknown part that was never aligned, being of no template's family: its label says the
//! nearest template and its f' instead). A part lying
//! upside down says `flipped` after its class; one the partial search found says `touching` or
//! `cut` and its visible share.
//!
//! Colours: green for a known part, red for an unknown one, yellow for a part touching the
//! frame's edge. The arrow points along the template's +x axis turned by the detected angle
//! (counter-clockwise on screen), so a part at 0° has its arrow pointing right.

use font8x8::UnicodeFonts;
use image::{GrayImage, Rgb, RgbImage};
use imageproc::drawing::{draw_cross_mut, draw_filled_rect_mut, draw_line_segment_mut};
use imageproc::rect::Rect;

use crate::engine::{FrameResult, HostDetection};

const KNOWN: Rgb<u8> = Rgb([40, 220, 60]);
const UNKNOWN: Rgb<u8> = Rgb([250, 60, 40]);
const EDGE: Rgb<u8> = Rgb([250, 210, 40]);
/// The cross and the caption.
pub const WHITE: Rgb<u8> = Rgb([255, 255, 255]);
/// The best template's outline at its aligned pose.
pub const ALIGNED: Rgb<u8> = Rgb([40, 200, 250]);
const SHADOW: Rgb<u8> = Rgb([0, 0, 0]);

/// The frame in colour with the detections drawn on it.
pub fn draw(frame: &GrayImage, result: &FrameResult) -> RgbImage {
    let mut img = RgbImage::from_fn(frame.width(), frame.height(), |x, y| {
        let v = frame.get_pixel(x, y).0[0];
        Rgb([v, v, v])
    });
    for d in &result.detections {
        draw_detection(&mut img, d);
    }
    draw_label(&mut img, 4, 4, &caption(result), WHITE);
    img
}

/// The caption [`draw`] writes at the frame's top left: the parts, the time in the core and
/// where the platform came from.
pub fn caption(result: &FrameResult) -> String {
    let platform = match (&result.platform, result.platform_frames_ago) {
        (Some(p), 0) => format!(
            ", platform estimated from the frame ({} of {} cells)",
            p.kept,
            p.cells_x * p.cells_y
        ),
        (Some(_), 1) => ", platform estimated from the frame before".to_string(),
        (Some(_), k) => format!(", platform estimated {k} frames before"),
        (None, _) => String::new(),
    };
    format!(
        "{} part(s), {:.1} ms{platform}",
        result.detections.len(),
        result.seconds * 1e3
    )
}

fn colour(d: &HostDetection) -> Rgb<u8> {
    if d.core.touches_edge {
        EDGE
    } else if d.class.is_some() {
        KNOWN
    } else {
        UNKNOWN
    }
}

/// A line from a point to another, frame coordinates.
pub type Segment = ((f32, f32), (f32, f32));

/// What the overlay draws for one detection, in frame coordinates (pixel centres at whole
/// numbers), in the order it is drawn: the border, the aligned outline, the cross, the arrow,
/// the label. [`draw_detection`] rasterises it; `vorl serve`'s page draws the same shapes in
/// the browser.
#[derive(Debug, Clone)]
pub struct Shapes<'a> {
    /// The colour of the border, the arrow and the label.
    pub colour: Rgb<u8>,
    /// The part's border, a closed polygon.
    pub border: &'a [(u16, u16)],
    /// The best template's outline at its aligned pose, a closed polygon in [`ALIGNED`]
    /// (empty when not drawn: a far miss, or no alignment).
    pub outline: &'a [[f32; 2]],
    /// The cross's centre (5 px across, white).
    pub cross: (i32, i32),
    /// The arrow's segments, from → to: the shaft, then the head's two strokes; none for an
    /// unknown part that was never aligned.
    pub arrow: Option<[Segment; 3]>,
    /// The label's text and where its box would start before [`label_box`] keeps it inside
    /// the frame.
    pub label: (i32, i32, String),
}

/// The shapes [`draw_detection`] draws for `d`.
pub fn shapes(d: &HostDetection) -> Shapes<'_> {
    let c = colour(d);
    // The best template's outline where the alignment put it (cyan), over the border: for a
    // known part, and for a near miss (score under twice its limit), not for a far one.
    let near = d.class.is_some() || d.core.verify < 2.0 * d.core.verify_limit;
    let outline = if near { &d.outline[..] } else { &[] };
    let (x, y) = (d.core.x, d.core.y);
    let cross = (x.round() as i32, y.round() as i32);
    // An unknown part that was never aligned (of no template's family) has no angle: no arrow.
    let angled = d.class.is_some() || d.core.pose.is_some();
    let arrow = angled.then(|| {
        let len = (d.core.area.max(1.0).sqrt() * 0.6).clamp(12.0, 120.0);
        let (s, co) = d.core.angle_deg.to_radians().sin_cos();
        let tip = (x + len * co, y - len * s);
        // Arrow head: two short strokes back from the tip at ±25°.
        let head = [-1.0f32, 1.0].map(|side| {
            let a = d.core.angle_deg.to_radians() + std::f32::consts::PI - side * 25f32.to_radians();
            (tip, (tip.0 + 7.0 * a.cos(), tip.1 - 7.0 * a.sin()))
        });
        [((x, y), tip), head[0], head[1]]
    });
    let class = d.class.as_deref().unwrap_or("unknown");
    let name = if d.core.flipped {
        format!("{class} flipped")
    } else {
        class.to_string()
    };
    // A part the partial search found shares its blob with others: its label goes beside its
    // own centre, and says how much of its edge the image confirms.
    let label = if d.core.position_from_pose || d.core.touching {
        let how = if d.core.touching { "touching" } else { "cut" };
        let text = if d.core.verify.is_finite() {
            format!(
                "{name} {how} vis={:.2} v={:.2}/{:.2}px {:.1}deg",
                d.core.visible_fraction, d.core.verify, d.core.verify_limit, d.core.angle_deg
            )
        } else {
            format!("{name} {how} (the rest of its blob)")
        };
        (x.round() as i32 + 6, y.round() as i32 + 6, text)
    } else {
        let text = if d.core.verify.is_finite() {
            format!(
                "{name} f'={:.3} v={:.2}/{:.2}px {:.1}deg",
                d.core.score, d.core.verify, d.core.verify_limit, d.core.angle_deg
            )
        } else if d.core.score.is_finite() && angled {
            format!("{name} f'={:.3} {:.1}deg", d.core.score, d.core.angle_deg)
        } else if d.core.score.is_finite() {
            let nearest = d.best_class.as_deref().unwrap_or("?");
            format!("{name} f'={:.3} from {nearest}", d.core.score)
        } else {
            name
        };
        let (bx, by) = bbox_top_left(&d.border);
        (bx as i32, by as i32 - 11, text)
    };
    Shapes {
        colour: c,
        border: &d.border,
        outline,
        cross,
        arrow,
        label,
    }
}

/// Draws one detection: contour, cross, arrow and label.
pub fn draw_detection(img: &mut RgbImage, d: &HostDetection) {
    let s = shapes(d);
    let n = s.border.len();
    for i in 0..n {
        let (a, b) = (s.border[i], s.border[(i + 1) % n]);
        draw_line_segment_mut(img, (a.0 as f32, a.1 as f32), (b.0 as f32, b.1 as f32), s.colour);
    }
    let m = s.outline.len();
    for i in 0..m {
        let (a, b) = (s.outline[i], s.outline[(i + 1) % m]);
        draw_line_segment_mut(img, (a[0], a[1]), (b[0], b[1]), ALIGNED);
    }
    draw_cross_mut(img, WHITE, s.cross.0, s.cross.1);
    for (from, to) in s.arrow.iter().flatten() {
        draw_line_segment_mut(img, *from, *to, s.colour);
    }
    let (x, y, text) = &s.label;
    draw_label(img, *x, *y, text, s.colour);
}

/// Writes a part number at (x, y) (for `vorl teach --list`).
pub fn draw_number(img: &mut RgbImage, x: f32, y: f32, number: usize) {
    let text = format!("#{number}");
    draw_label(img, x.round() as i32 + 6, y.round() as i32 - 4, &text, WHITE);
}

fn bbox_top_left(border: &[(u16, u16)]) -> (u16, u16) {
    let x = border.iter().map(|p| p.0).min().unwrap_or(0);
    let y = border.iter().map(|p| p.1).min().unwrap_or(0);
    (x, y)
}

/// Where [`draw_label`] puts the dark box of `text` asked at (x, y) in a `w`×`h` image, and
/// its width: `(x, y, width)`, the box 10 px high, moved inside the image where it fits.
pub fn label_box(w: i32, h: i32, x: i32, y: i32, text: &str) -> (i32, i32, i32) {
    let tw = 8 * text.chars().count() as i32 + 2;
    (x.clamp(0, (w - tw).max(0)), y.clamp(0, (h - 10).max(0)), tw)
}

/// Draws `text` in the 8×8 bitmap font on a dark box, clipped to the image.
pub fn draw_label(img: &mut RgbImage, x: i32, y: i32, text: &str, colour: Rgb<u8>) {
    let (w, h) = (img.width() as i32, img.height() as i32);
    let (x, y, tw) = label_box(w, h, x, y, text);
    draw_filled_rect_mut(img, Rect::at(x, y).of_size(tw as u32, 10), SHADOW);
    for (i, ch) in text.chars().enumerate() {
        let Some(glyph) = font8x8::BASIC_FONTS.get(ch) else {
            continue;
        };
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) != 0 {
                    let (px, py) = (x + 1 + 8 * i as i32 + col, y + 1 + row as i32);
                    if px >= 0 && py >= 0 && px < w && py < h {
                        img.put_pixel(px as u32, py as u32, colour);
                    }
                }
            }
        }
    }
}
