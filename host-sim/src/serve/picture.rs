//! What the page shows of a frame, made cheap: the frame itself as an 8-bit gray BMP (a header,
//! a palette and the rows copied: no conversion to colour, no compression) and the overlay of
//! `vorl detect --overlay` as its shapes in JSON ([`crate::overlay::shapes`]: outlines,
//! crosses, arrows, labels, the caption), which the page draws in the browser as an SVG layer
//! over the picture. The server draws no pixels for the page.

use image::{GrayImage, Rgb};
use serde_json::Value;

use crate::engine::FrameResult;
use crate::overlay;

/// `frame` as an uncompressed 8-bit BMP with a gray palette (rows bottom up, each padded to
/// 4 bytes, as BMP has them).
pub fn gray_bmp(frame: &GrayImage) -> Vec<u8> {
    let (w, h) = (frame.width() as usize, frame.height() as usize);
    let stride = (w + 3) & !3;
    let offset = 14 + 40 + 256 * 4;
    let size = offset + stride * h;
    let mut out = Vec::with_capacity(size);
    let u32le = |out: &mut Vec<u8>, v: usize| out.extend_from_slice(&(v as u32).to_le_bytes());
    // BITMAPFILEHEADER.
    out.extend_from_slice(b"BM");
    u32le(&mut out, size);
    u32le(&mut out, 0);
    u32le(&mut out, offset);
    // BITMAPINFOHEADER: width, height (positive: bottom up), 1 plane, 8 bits, no compression,
    // the pixels' size, 2835 px/m (72 dpi) both ways, 256 colours, all of them important.
    u32le(&mut out, 40);
    u32le(&mut out, w);
    u32le(&mut out, h);
    out.extend_from_slice(&1u16.to_le_bytes());
    out.extend_from_slice(&8u16.to_le_bytes());
    u32le(&mut out, 0);
    u32le(&mut out, stride * h);
    u32le(&mut out, 2835);
    u32le(&mut out, 2835);
    u32le(&mut out, 256);
    u32le(&mut out, 0);
    for v in 0..=255u8 {
        out.extend_from_slice(&[v, v, v, 0]);
    }
    let raw = frame.as_raw();
    for row in raw.chunks_exact(w.max(1)).rev().take(h) {
        out.extend_from_slice(row);
        out.resize(out.len() + stride - w, 0);
    }
    out
}

fn hex(c: Rgb<u8>) -> String {
    format!("\"#{:02x}{:02x}{:02x}\"", c.0[0], c.0[1], c.0[2])
}

/// `text` as a JSON string.
fn string(out: &mut Vec<u8>, text: &str) {
    out.extend_from_slice(Value::from(text).to_string().as_bytes());
}

/// A label's box as the overlay puts it (inside the frame) and its text.
fn label(out: &mut Vec<u8>, w: i32, h: i32, x: i32, y: i32, text: &str) {
    let (x, y, bw) = overlay::label_box(w, h, x, y, text);
    out.extend_from_slice(b"{\"x\":");
    int(out, i64::from(x));
    out.extend_from_slice(b",\"y\":");
    int(out, i64::from(y));
    out.extend_from_slice(b",\"w\":");
    int(out, i64::from(bw));
    out.extend_from_slice(b",\"text\":");
    string(out, text);
    out.push(b'}');
}

/// An integer in decimal, without the formatting machinery (the points are many).
fn int(out: &mut Vec<u8>, v: i64) {
    if v < 0 {
        out.push(b'-');
    }
    let mut v = v.unsigned_abs();
    let mut digits = [0u8; 20];
    let mut i = digits.len();
    loop {
        i -= 1;
        digits[i] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    out.extend_from_slice(&digits[i..]);
}

/// A border (a closed chain of pixels, each next to the one before) as SVG path data: `M x
/// y`, then a relative step `l dx dy` per pixel (written from a table: the border has
/// thousands of pixels), an absolute `L x y` for a step to a pixel not next to the one
/// before, and `Z`.
fn chain(out: &mut Vec<u8>, border: &[(u16, u16)]) {
    const STEPS: [[&[u8]; 3]; 3] = [
        [b"l-1 -1", b"l-1 0", b"l-1 1"],
        [b"l0 -1", b"l0 0", b"l0 1"],
        [b"l1 -1", b"l1 0", b"l1 1"],
    ];
    let Some(&(x0, y0)) = border.first() else {
        return;
    };
    out.extend_from_slice(b"M");
    int(out, i64::from(x0));
    out.push(b' ');
    int(out, i64::from(y0));
    let mut at = (i32::from(x0), i32::from(y0));
    for &(x, y) in &border[1..] {
        let (x, y) = (i32::from(x), i32::from(y));
        let (dx, dy) = (x - at.0, y - at.1);
        if dx.abs() <= 1 && dy.abs() <= 1 {
            out.extend_from_slice(STEPS[(dx + 1) as usize][(dy + 1) as usize]);
        } else {
            out.push(b'L');
            int(out, i64::from(x));
            out.push(b' ');
            int(out, i64::from(y));
        }
        at = (x, y);
    }
    out.push(b'Z');
}

/// Points as SVG's `points` attribute: `x,y x,y …`, tenths of a pixel at most.
fn points(out: &mut Vec<u8>, pts: impl Iterator<Item = (f32, f32)>) {
    for (i, (x, y)) in pts.enumerate() {
        if i > 0 {
            out.push(b' ');
        }
        tenths(out, x);
        out.push(b',');
        tenths(out, y);
    }
}

fn tenths(out: &mut Vec<u8>, v: f32) {
    let t = (v * 10.0).round() as i64;
    if t < 0 && t / 10 == 0 {
        out.push(b'-');
    }
    int(out, t / 10);
    if t % 10 != 0 {
        out.push(b'.');
        out.push(b'0' + (t % 10).unsigned_abs() as u8);
    }
}

/// The overlay's shapes for the frame `version` named `name`, of size `width`×`height`, as
/// JSON: `{"version", "frame", "width", "height", "aligned": colour, "cross": colour,
/// "caption": label, "parts": [{"colour", "border": points, "outline": points, "cross": [x,
/// y], "arrow": [[x0, y0, x1, y1], …], "label"}]}`, a label being `{"x", "y", "w", "text"}`
/// (its box, 10 px high), the border SVG's path data of a closed path (`M x y l dx dy … Z`)
/// and the outline SVG's points (`x,y x,y …`) of a closed polygon. Coordinates are
/// the frame's, a pixel's centre at whole numbers. Written by hand: its thousands of points
/// are most of a page's cost per frame.
pub fn shapes_json(version: u64, name: &str, frame: &GrayImage, result: &FrameResult) -> Vec<u8> {
    let (w, h) = (frame.width() as i32, frame.height() as i32);
    let n: usize = result.detections.iter().map(|d| d.border.len() + d.outline.len()).sum();
    let mut out = Vec::with_capacity(512 + 256 * result.detections.len() + 12 * n);
    out.extend_from_slice(b"{\"version\":");
    int(&mut out, i64::try_from(version).unwrap_or(i64::MAX));
    out.extend_from_slice(b",\"frame\":");
    string(&mut out, name);
    out.extend_from_slice(b",\"width\":");
    int(&mut out, i64::from(w));
    out.extend_from_slice(b",\"height\":");
    int(&mut out, i64::from(h));
    out.extend_from_slice(b",\"aligned\":");
    out.extend_from_slice(hex(overlay::ALIGNED).as_bytes());
    out.extend_from_slice(b",\"cross\":");
    out.extend_from_slice(hex(overlay::WHITE).as_bytes());
    out.extend_from_slice(b",\"caption\":");
    label(&mut out, w, h, 4, 4, &overlay::caption(result));
    out.extend_from_slice(b",\"parts\":[");
    for (i, d) in result.detections.iter().enumerate() {
        let s = overlay::shapes(d);
        if i > 0 {
            out.push(b',');
        }
        out.extend_from_slice(b"{\"colour\":");
        out.extend_from_slice(hex(s.colour).as_bytes());
        out.extend_from_slice(b",\"border\":\"");
        chain(&mut out, s.border);
        out.extend_from_slice(b"\",\"outline\":\"");
        points(&mut out, s.outline.iter().map(|p| (p[0], p[1])));
        out.extend_from_slice(b"\",\"cross\":[");
        int(&mut out, i64::from(s.cross.0));
        out.push(b',');
        int(&mut out, i64::from(s.cross.1));
        out.extend_from_slice(b"],\"arrow\":[");
        for (j, (a, b)) in s.arrow.iter().flatten().enumerate() {
            if j > 0 {
                out.push(b',');
            }
            out.push(b'[');
            for (k, v) in [a.0, a.1, b.0, b.1].into_iter().enumerate() {
                if k > 0 {
                    out.push(b',');
                }
                tenths(&mut out, v);
            }
            out.push(b']');
        }
        out.extend_from_slice(b"],\"label\":");
        let (lx, ly, text) = &s.label;
        label(&mut out, w, h, *lx, *ly, text);
        out.push(b'}');
    }
    out.extend_from_slice(b"]}");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bmp_decodes_to_the_frame() {
        for (w, h) in [(5u32, 3u32), (8, 2), (1, 1)] {
            let frame = GrayImage::from_fn(w, h, |x, y| image::Luma([(x * 37 + y * 101) as u8]));
            let bmp = gray_bmp(&frame);
            let back = image::load_from_memory_with_format(&bmp, image::ImageFormat::Bmp)
                .expect("a BMP")
                .to_luma8();
            assert_eq!(back, frame, "{w}x{h}");
        }
    }

    #[test]
    fn a_border_is_a_path_of_steps() {
        let mut s = Vec::new();
        chain(
            &mut s,
            &[
                (10, 5),
                (11, 5),
                (12, 6),
                (12, 7),
                (11, 8),
                (3, 8),
                (2, 7),
                (2, 6),
                (3, 5),
            ],
        );
        assert_eq!(
            String::from_utf8_lossy(&s),
            "M10 5l1 0l1 1l0 1l-1 1L3 8l-1 -1l0 -1l1 -1Z"
        );
        let mut s = Vec::new();
        chain(&mut s, &[]);
        assert!(s.is_empty());
    }

    #[test]
    fn tenths_round_and_drop_a_zero_decimal() {
        let mut s = Vec::new();
        points(
            &mut s,
            [
                (1.0f32, 2.25),
                (-0.04, -3.46),
                (10.96, 0.0),
                (-0.3, -12.0),
                (1234.5, -1e9),
            ]
            .into_iter(),
        );
        assert_eq!(
            String::from_utf8_lossy(&s),
            "1,2.3 0,-3.5 11,0 -0.3,-12 1234.5,-1000000000"
        );
    }
}
