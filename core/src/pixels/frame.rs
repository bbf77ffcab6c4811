//! Frames: 8-bit gray images over caller-provided storage.
//!
//! [`Frame`] is a checked view over any byte buffer (a slice, an array, a `static` in flash);
//! once [`Frame::new_checked`] has succeeded, no accessor can panic. [`FrameBuffer`] owns its
//! pixels in a const-generic array, for `static` use on a microcontroller.

use crate::error::{Error, Result};

/// A width×height 8-bit gray image stored row by row with `stride` bytes between rows.
///
/// ```
/// use vorl_core::Frame;
/// let pixels = [0u8, 1, 2, 3, 4, 5];
/// let frame = Frame::new_checked(&pixels[..], 3, 2).unwrap();
/// assert_eq!(frame.get(2, 1), 5);
/// assert!(Frame::new_checked(&pixels[..], 4, 2).is_err());
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Frame<B> {
    data: B,
    width: usize,
    height: usize,
    stride: usize,
}

impl<B: AsRef<[u8]>> Frame<B> {
    /// A view of `data` as a `width`×`height` image with rows packed (`stride == width`).
    ///
    /// # Errors
    /// [`Error::EmptyFrame`] for a zero dimension, [`Error::BufferTooSmall`] when `data` is
    /// shorter than `width·height`.
    pub fn new_checked(data: B, width: usize, height: usize) -> Result<Self> {
        Self::with_stride(data, width, height, width)
    }

    /// A view with `stride` bytes from one row to the next (`stride ≥ width`).
    ///
    /// # Errors
    /// [`Error::EmptyFrame`], [`Error::Stride`] when `stride < width`, and
    /// [`Error::BufferTooSmall`] when the last row does not fit in `data`.
    pub fn with_stride(data: B, width: usize, height: usize, stride: usize) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(Error::EmptyFrame { width, height });
        }
        if stride < width {
            return Err(Error::Stride { width, stride });
        }
        let needed = (height - 1)
            .checked_mul(stride)
            .and_then(|v| v.checked_add(width))
            .ok_or(Error::Capacity {
                what: "frame size",
                capacity: usize::MAX,
                requested: width,
            })?;
        let got = data.as_ref().len();
        if got < needed {
            return Err(Error::BufferTooSmall { needed, got });
        }
        Ok(Frame {
            data,
            width,
            height,
            stride,
        })
    }

    /// Width in pixels.
    #[inline]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[inline]
    pub fn height(&self) -> usize {
        self.height
    }

    /// Bytes from one row to the next.
    #[inline]
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// The whole buffer: pixel `(x, y)` at `y·stride + x` (at least `(height − 1)·stride +
    /// width` bytes; the bytes past `width` in a row are not part of the image).
    #[inline]
    pub fn pixels(&self) -> &[u8] {
        self.data.as_ref()
    }

    /// Pixel at `(x, y)`, or 0 outside the image.
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> u8 {
        if x >= self.width || y >= self.height {
            return 0;
        }
        self.data.as_ref().get(y * self.stride + x).copied().unwrap_or(0)
    }

    /// Pixel at `(x, y)` with coordinates clamped into the image (replicated border).
    #[inline]
    pub fn get_clamped(&self, x: isize, y: isize) -> u8 {
        // `max(0).min(..)`, not `clamp`: clamp panics on crossed bounds (a zero width).
        let xc = x.max(0).min(self.width as isize - 1) as usize;
        let yc = y.max(0).min(self.height as isize - 1) as usize;
        self.data.as_ref().get(yc * self.stride + xc).copied().unwrap_or(0)
    }

    /// Row `y` (exactly `width` bytes), or an empty slice outside the image.
    #[inline]
    pub fn row(&self, y: usize) -> &[u8] {
        if y >= self.height {
            return &[];
        }
        let start = y * self.stride;
        self.data.as_ref().get(start..start + self.width).unwrap_or(&[])
    }

    /// The bytes from row `y` on (row `y + k` starts at `k · stride`), or an empty slice outside
    /// the image.
    #[inline]
    pub(crate) fn bytes_from(&self, y: usize) -> &[u8] {
        if y >= self.height {
            return &[];
        }
        self.data.as_ref().get(y * self.stride..).unwrap_or(&[])
    }

    /// Checks that `other` has the same width and height.
    ///
    /// # Errors
    /// [`Error::FrameSize`] naming both sizes.
    pub fn check_same_size<C: AsRef<[u8]>>(&self, other: &Frame<C>) -> Result<()> {
        if self.width != other.width || self.height != other.height {
            return Err(Error::FrameSize {
                expected_width: self.width,
                expected_height: self.height,
                width: other.width,
                height: other.height,
            });
        }
        Ok(())
    }
}

/// An owned frame of at most `N` pixels, for `static` storage on a microcontroller.
///
/// ```
/// use vorl_core::FrameBuffer;
/// let mut fb = FrameBuffer::<{ 4 * 3 }>::new(4, 3).unwrap();
/// fb.pixels_mut()[5] = 200;
/// assert_eq!(fb.frame().get(1, 1), 200);
/// assert!(FrameBuffer::<4>::new(4, 3).is_err());
/// ```
#[derive(Debug, Clone)]
pub struct FrameBuffer<const N: usize> {
    pixels: [u8; N],
    width: usize,
    height: usize,
}

impl<const N: usize> FrameBuffer<N> {
    /// A black `width`×`height` frame.
    ///
    /// # Errors
    /// [`Error::EmptyFrame`] or [`Error::Capacity`] when `width·height > N`.
    /// `const`, so a `static` can be initialised with it.
    pub const fn new(width: usize, height: usize) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(Error::EmptyFrame { width, height });
        }
        let requested = width.saturating_mul(height);
        if requested > N {
            return Err(Error::Capacity {
                what: "frame buffer pixels",
                capacity: N,
                requested,
            });
        }
        Ok(FrameBuffer {
            pixels: [0; N],
            width,
            height,
        })
    }

    /// The pixels in use, row by row.
    pub fn pixels(&self) -> &[u8] {
        &self.pixels[..self.width * self.height]
    }

    /// The pixels in use, for filling from a sensor.
    pub fn pixels_mut(&mut self) -> &mut [u8] {
        &mut self.pixels[..self.width * self.height]
    }

    /// A [`Frame`] view of the buffer.
    pub fn frame(&self) -> Frame<&[u8]> {
        Frame {
            data: self.pixels(),
            width: self.width,
            height: self.height,
            stride: self.width,
        }
    }
}
