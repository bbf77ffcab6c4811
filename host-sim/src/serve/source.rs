//! Frame sources of `vorl serve`: the set's frames replayed, scenes drawn live by the
//! generator, or (with the `camera` feature) a V4L2/UVC camera.

use std::path::{Path, PathBuf};

use image::GrayImage;

use crate::gen::{GenOptions, MemorySet, Variant};
use crate::io::{file_name, load_gray};

/// One frame from a source: its name and its pixels, or why it could not be had.
#[derive(Debug)]
pub struct Captured {
    /// The frame's name (file name in replay, `g000001.png` and on from the generator).
    pub name: String,
    /// The frame, 8-bit gray, or the one-line error naming the file.
    pub image: Result<GrayImage, String>,
    /// A note on the file (converted to 8-bit gray, …).
    pub note: Option<String>,
}

/// A stream of frames.
pub trait FrameSource: Send {
    /// The next frame.
    fn next_frame(&mut self) -> Captured;
    /// One line saying what the source is.
    fn describe(&self) -> String;
}

/// The set's frames in name order, from the first again after the last.
pub struct Replay {
    frames: Vec<PathBuf>,
    next: usize,
}

impl Replay {
    /// A replay of these frame files.
    ///
    /// # Errors
    /// No frames.
    pub fn new(frames: Vec<PathBuf>, set: &Path) -> Result<Self, String> {
        if frames.is_empty() {
            return Err(format!(
                "{}: no frames to replay in frames/ (--source gen draws scenes instead)",
                set.display()
            ));
        }
        Ok(Replay { frames, next: 0 })
    }
}

impl FrameSource for Replay {
    fn next_frame(&mut self) -> Captured {
        let path = &self.frames[self.next % self.frames.len()];
        self.next = (self.next + 1) % self.frames.len();
        let name = file_name(path);
        match load_gray(path) {
            Ok(l) => Captured {
                name,
                image: Ok(l.image),
                note: l.note.map(|n| format!("{}: {n}", path.display())),
            },
            Err(e) => Captured {
                name,
                image: Err(e.to_string()),
                note: None,
            },
        }
    }

    fn describe(&self) -> String {
        format!("replay of {} frame(s), looping", self.frames.len())
    }
}

/// Scenes drawn by the generator, one new scene per frame.
pub struct Generated {
    set: MemorySet,
    seed: u64,
    next: usize,
}

/// The generator's options for `vorl serve --source gen` (the default variant, 640×480).
pub fn gen_options(seed: u64) -> GenOptions {
    GenOptions {
        seed,
        frames: 1,
        variant: Variant::Default,
        ..GenOptions::default()
    }
}

impl Generated {
    /// The generator with this seed.
    ///
    /// # Errors
    /// The generator refuses the options.
    pub fn new(seed: u64) -> Result<Self, String> {
        let set = MemorySet::new(&gen_options(seed)).map_err(|e| e.to_string())?;
        Ok(Generated { set, seed, next: 0 })
    }
}

impl FrameSource for Generated {
    fn next_frame(&mut self) -> Captured {
        let (image, _truth) = self.set.frame(self.next);
        self.next += 1;
        Captured {
            name: format!("g{:06}.png", self.next),
            image: Ok(image),
            note: None,
        }
    }

    fn describe(&self) -> String {
        format!("scenes drawn live by the generator (seed {})", self.seed)
    }
}

/// A V4L2/UVC camera (the `camera` feature, through the `v4l` crate): frames in 8-bit gray
/// (`GREY`) or the luma of `YUYV`, as the device's current size; named by the driver's
/// sequence number.
#[cfg(feature = "camera")]
pub struct Camera {
    stream: v4l::io::mmap::Stream<'static>,
    device: String,
    width: u32,
    height: u32,
    stride: usize,
    yuyv: bool,
}

#[cfg(feature = "camera")]
impl Camera {
    /// Opens `device` (`/dev/video0`, …) and starts streaming, asking for 8-bit gray and
    /// taking YUYV's luma when the camera has no gray mode.
    ///
    /// # Errors
    /// The device cannot be opened, takes neither format, or will not stream.
    pub fn open(device: &str) -> Result<Self, String> {
        use v4l::video::Capture as _;
        let bad = |e: std::io::Error| format!("camera {device}: {e}");
        let dev = v4l::Device::with_path(device).map_err(bad)?;
        let mut format = dev.format().map_err(bad)?;
        let mut got = None;
        for code in [b"GREY", b"YUYV"] {
            format.fourcc = v4l::FourCC::new(code);
            let set = dev.set_format(&format).map_err(bad)?;
            if set.fourcc == format.fourcc {
                got = Some(set);
                break;
            }
        }
        let format = got.ok_or_else(|| format!("camera {device}: gives neither GREY nor YUYV frames"))?;
        let yuyv = format.fourcc == v4l::FourCC::new(b"YUYV");
        let stream = v4l::io::mmap::Stream::with_buffers(&dev, v4l::buffer::Type::VideoCapture, 4).map_err(bad)?;
        Ok(Camera {
            stream,
            device: device.to_string(),
            width: format.width,
            height: format.height,
            stride: format.stride as usize,
            yuyv,
        })
    }
}

/// An 8-bit gray frame from a camera buffer: rows of `stride` bytes, gray or YUYV (luma in
/// every other byte).
///
/// # Errors
/// The buffer is shorter than the frame.
pub fn gray_from_buffer(buf: &[u8], width: u32, height: u32, stride: usize, yuyv: bool) -> Result<GrayImage, String> {
    let bytes_per_pixel = if yuyv { 2 } else { 1 };
    let row = width as usize * bytes_per_pixel;
    let stride = stride.max(row);
    let need = stride * (height as usize).saturating_sub(1) + row;
    if height == 0 || width == 0 || buf.len() < need {
        return Err(format!(
            "a {}-byte buffer is short of a {width}×{height} frame ({need} bytes)",
            buf.len()
        ));
    }
    let mut pixels = Vec::with_capacity(width as usize * height as usize);
    for y in 0..height as usize {
        let line = &buf[y * stride..y * stride + row];
        pixels.extend(line.iter().step_by(bytes_per_pixel));
    }
    GrayImage::from_raw(width, height, pixels).ok_or_else(|| "frame of the wrong size".to_string())
}

#[cfg(feature = "camera")]
impl FrameSource for Camera {
    fn next_frame(&mut self) -> Captured {
        use v4l::io::traits::CaptureStream as _;
        match self.stream.next() {
            Ok((buf, meta)) => Captured {
                name: meta.sequence.to_string(),
                image: gray_from_buffer(buf, self.width, self.height, self.stride, self.yuyv)
                    .map_err(|e| format!("camera {}: {e}", self.device)),
                note: None,
            },
            Err(e) => Captured {
                name: "?".into(),
                image: Err(format!("camera {}: {e}", self.device)),
                note: None,
            },
        }
    }

    fn describe(&self) -> String {
        format!(
            "camera {} ({}×{}, {})",
            self.device,
            self.width,
            self.height,
            if self.yuyv { "YUYV luma" } else { "8-bit gray" }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_buffers_become_gray_frames() {
        // 3×2 gray with a stride of 4 (one byte of padding a row).
        let g = gray_from_buffer(&[1, 2, 3, 0, 4, 5, 6, 0], 3, 2, 4, false).expect("gray");
        assert_eq!(g.as_raw(), &vec![1, 2, 3, 4, 5, 6]);
        // 2×2 YUYV: Y0 U Y1 V; the lumas are taken.
        let y = gray_from_buffer(&[10, 99, 11, 98, 12, 97, 13, 96], 2, 2, 4, true).expect("yuyv");
        assert_eq!(y.as_raw(), &vec![10, 11, 12, 13]);
        // The last row needs no padding; a short buffer is refused, not read past.
        assert!(gray_from_buffer(&[1, 2, 3, 0, 4, 5, 6], 3, 2, 4, false).is_ok());
        assert!(gray_from_buffer(&[1, 2, 3, 0, 4, 5], 3, 2, 4, false).is_err());
        assert!(gray_from_buffer(&[], 0, 0, 0, false).is_err());
    }
}
