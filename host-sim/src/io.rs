//! Reading images and fixture sets, with one-line errors that name the file.

use std::fmt;
use std::path::{Path, PathBuf};

use image::{DynamicImage, GrayImage};

/// A problem with one input file: the path and what is wrong, printable as one line.
#[derive(Debug, Clone, PartialEq)]
pub struct InputError {
    /// The file.
    pub path: PathBuf,
    /// What is wrong with it.
    pub problem: String,
}

impl InputError {
    /// An error about `path`.
    pub fn new(path: impl Into<PathBuf>, problem: impl Into<String>) -> Self {
        InputError {
            path: path.into(),
            problem: problem.into(),
        }
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.problem)
    }
}

impl std::error::Error for InputError {}

/// An 8-bit gray image and, when it had to be converted, a note saying from what.
#[derive(Debug, Clone)]
pub struct LoadedImage {
    /// The pixels.
    pub image: GrayImage,
    /// `Some("converted from RGB8 to 8-bit gray")` and the like.
    pub note: Option<String>,
}

/// Largest width or height of an image the `vorl` program reads, px.
pub const MAX_SIDE: u32 = 16_384;

/// Most pixels of an image the `vorl` program reads: 2²⁶ = 67 108 864 (64 Mi pixels, e.g.
/// 8192 × 8192). Decoding one at the widest pixel format (16-bit RGBA, 8 bytes a pixel) takes at
/// most 512 MiB, which is also the decoder's allocation limit.
pub const MAX_PIXELS: u64 = 1 << 26;

/// The decoder's allocation limit, bytes: [`MAX_PIXELS`] at 8 bytes a pixel.
const MAX_DECODE_BYTES: u64 = MAX_PIXELS * 8;

/// The image size limits as a phrase, for messages.
fn limit_text() -> String {
    format!("vorl reads images of at most {MAX_SIDE} px a side and {MAX_PIXELS} pixels")
}

/// The size an image file declares in its header (PNG `IHDR`, GIF logical screen, BMP info
/// header), read from the bytes without decoding anything; `None` when the header is cut off or
/// the format is another.
pub fn declared_size(bytes: &[u8], format: image::ImageFormat) -> Option<(u32, u32)> {
    let be = |at: usize| Some(u32::from_be_bytes(bytes.get(at..at + 4)?.try_into().ok()?));
    let le16 = |at: usize| Some(u32::from(u16::from_le_bytes(bytes.get(at..at + 2)?.try_into().ok()?)));
    let le32 = |at: usize| Some(i32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?).unsigned_abs());
    match format {
        // Signature (8), IHDR length (4) and type (4), then width and height, big-endian.
        image::ImageFormat::Png if bytes.get(12..16) == Some(b"IHDR") => Some((be(16)?, be(20)?)),
        image::ImageFormat::Gif => Some((le16(6)?, le16(8)?)),
        // File header (14), info header size (4): 12 for the old core header (u16 sizes).
        image::ImageFormat::Bmp => match le32(14)? {
            12 => Some((le16(18)?, le16(20)?)),
            _ => Some((le32(18)?, le32(22)?)),
        },
        _ => None,
    }
}

/// PNG's colour type and bit depth from `IHDR`, when the bytes are a PNG with a whole header.
fn png_kind(bytes: &[u8]) -> Option<(u8, u8)> {
    if bytes.get(12..16) != Some(b"IHDR") {
        return None;
    }
    Some((*bytes.get(25)?, *bytes.get(24)?))
}

/// Whether a decoding error is the file ending early.
fn is_truncation(e: &image::ImageError) -> bool {
    if let image::ImageError::IoError(io) = e {
        return io.kind() == std::io::ErrorKind::UnexpectedEof;
    }
    let mut cause: Option<&(dyn std::error::Error + 'static)> = Some(e);
    while let Some(c) = cause {
        if c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::UnexpectedEof)
        {
            return true;
        }
        cause = c.source();
    }
    false
}

/// Loads an image file as 8-bit gray (PNG, GIF or BMP; the format is read from the content).
///
/// Accepted and converted to 8-bit gray, with a note: RGB and RGBA (luma of the channels),
/// 16-bit (the nearest 8-bit value, `v / 257` rounded), gray with alpha (the gray, alpha
/// ignored), palette PNGs (the palette's colours, as RGB). Interlaced (Adam7) PNGs and gray
/// below 8 bits are read as the same pixels, without a note. An image declaring more than
/// [`MAX_SIDE`] px a side or [`MAX_PIXELS`] pixels is refused from its header, before any pixel
/// buffer is allocated.
///
/// # Errors
/// Missing or unreadable file, a directory, an empty file, an unknown or unsupported format,
/// an image larger than the limits, a truncated or corrupt image — each as an [`InputError`]
/// naming the file.
pub fn load_gray(path: &Path) -> Result<LoadedImage, InputError> {
    if path.is_dir() {
        return Err(InputError::new(path, "is a directory, not an image file"));
    }
    let bytes = std::fs::read(path).map_err(|e| InputError::new(path, io_problem(&e)))?;
    if bytes.is_empty() {
        return Err(InputError::new(path, "empty file (0 bytes), not an image"));
    }
    let format = image::guess_format(&bytes).map_err(|_| {
        InputError::new(
            path,
            "not a PNG, GIF or BMP image (its first bytes are no known image signature)",
        )
    })?;
    let kind = format!("{format:?}").to_uppercase();
    if let Some((w, h)) = declared_size(&bytes, format) {
        if w > MAX_SIDE || h > MAX_SIDE || u64::from(w) * u64::from(h) > MAX_PIXELS {
            return Err(InputError::new(
                path,
                format!("{kind} image declares {w}×{h} pixels, too large: {}", limit_text()),
            ));
        }
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_SIDE);
    limits.max_image_height = Some(MAX_SIDE);
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    let mut reader = image::ImageReader::with_format(std::io::Cursor::new(&bytes[..]), format);
    reader.limits(limits);
    let img = reader.decode().map_err(|e| {
        let what = match &e {
            _ if is_truncation(&e) => {
                format!("truncated {kind} image: the file ends early ({e})")
            }
            image::ImageError::Limits(_) => format!("{kind} image too large ({e}): {}", limit_text()),
            image::ImageError::Decoding(_) | image::ImageError::IoError(_) => format!("corrupt {kind} image ({e})"),
            image::ImageError::Unsupported(_) => format!("unsupported {kind} image ({e})"),
            _ => format!("cannot decode {kind} image ({e})"),
        };
        InputError::new(path, what)
    })?;
    let palette = format == image::ImageFormat::Png && png_kind(&bytes).is_some_and(|(colour, _)| colour == 3);
    Ok(to_gray(img, palette))
}

fn to_gray(img: DynamicImage, palette: bool) -> LoadedImage {
    let kind = match &img {
        DynamicImage::ImageLuma8(_) => None,
        _ if palette => Some("a palette (indexed-colour) image"),
        DynamicImage::ImageLuma16(_) => Some("16-bit gray"),
        DynamicImage::ImageLumaA8(_) => Some("8-bit gray with alpha (alpha ignored)"),
        DynamicImage::ImageLumaA16(_) => Some("16-bit gray with alpha (alpha ignored)"),
        DynamicImage::ImageRgb8(_) => Some("8-bit RGB"),
        DynamicImage::ImageRgba8(_) => Some("8-bit RGBA (alpha ignored)"),
        DynamicImage::ImageRgb16(_) => Some("16-bit RGB"),
        DynamicImage::ImageRgba16(_) => Some("16-bit RGBA (alpha ignored)"),
        _ => Some("another pixel format"),
    };
    match (kind, img) {
        (None, DynamicImage::ImageLuma8(g)) => LoadedImage { image: g, note: None },
        (kind, img) => LoadedImage {
            image: img.to_luma8(),
            note: Some(format!(
                "converted from {} to 8-bit gray",
                kind.unwrap_or("another format")
            )),
        },
    }
}

/// A friendlier text for an I/O error.
pub fn io_problem(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".to_string(),
        std::io::ErrorKind::PermissionDenied => "permission denied".to_string(),
        std::io::ErrorKind::IsADirectory => "is a directory, not a file".to_string(),
        _ => format!("cannot read ({e})"),
    }
}

/// Files in `dir` whose extension is one of `exts` (lower case), sorted by name.
///
/// # Errors
/// The folder is missing or unreadable.
pub fn list_files(dir: &Path, exts: &[&str]) -> Result<Vec<PathBuf>, InputError> {
    let rd = std::fs::read_dir(dir).map_err(|e| InputError::new(dir, io_problem(&e)))?;
    let mut out: Vec<PathBuf> = rd
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.is_file())
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| exts.iter().any(|x| x.eq_ignore_ascii_case(e)))
        })
        .collect();
    out.sort();
    Ok(out)
}

/// The file name of `path` as a string (`"?"` when it has none).
pub fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "?".into())
}

/// The file stem of `path` as a string.
pub fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "?".into())
}

/// A progress bar over `len` items for long runs, drawn on stderr only when it is a terminal
/// (indicatif hides it otherwise), e.g. `progress(40, "eval", "frames")`.
pub fn progress(len: usize, label: &str, unit: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len as u64);
    let template = format!("{label} [{{bar:30}}] {{pos}}/{{len}} {unit}, {{eta}} left");
    bar.set_style(
        indicatif::ProgressStyle::with_template(&template)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar
}
