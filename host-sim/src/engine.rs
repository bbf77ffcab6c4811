//! The host's driver of the core: a boxed [`vorl_core::Recognizer`] with generous capacities,
//! the frame-sized planes, template names and silhouette checks.

use std::path::Path;

use image::GrayImage;
use vorl_core::background::Background;
use vorl_core::contour::{trace_borders, BorderFilter, BorderKind, ContourStore, Point};
use vorl_core::exposure::{fit_exposure, Exposure};
use vorl_core::platform::{PlatformGrid, PlatformStats};
use vorl_core::recognizer::{Report, Skip, SkipReason};
use vorl_core::{Frame, Params, Recognizer, Template};

use crate::io::{file_stem, list_files, load_gray, InputError};

/// Templates the host recognizer holds.
pub const HOST_TEMPLATES: usize = 64;
/// Template point capacity (`m ≤ 512`).
pub const HOST_M: usize = 512;
/// Border points stored per frame.
pub const HOST_POINTS: usize = 1 << 16;
/// Borders kept per frame.
pub const HOST_CONTOURS: usize = 512;
/// DP table cells.
pub const HOST_CELLS: usize = 1 << 16;
/// Cells of the platform estimate (frames without an empty shot).
pub const HOST_PLATFORM_CELLS: usize = 4096;

/// The core recognizer with the host's capacities.
pub type HostRecognizer = Recognizer<HOST_TEMPLATES, HOST_M, HOST_POINTS, HOST_CONTOURS, HOST_CELLS>;

/// A template silhouette with its class name.
#[derive(Debug, Clone)]
pub struct NamedSilhouette {
    /// Class name (the file stem).
    pub name: String,
    /// The file it came from.
    pub path: std::path::PathBuf,
    /// A note when the file had to be converted to 8-bit gray.
    pub note: Option<String>,
    /// The silhouette (part > 127).
    pub image: GrayImage,
}

/// One detection with names and the border, ready for JSON or an overlay.
#[derive(Debug, Clone)]
pub struct HostDetection {
    /// The core's detection.
    pub core: vorl_core::Detection,
    /// Class name, `None` for unknown.
    pub class: Option<String>,
    /// Best template's name even when unknown.
    pub best_class: Option<String>,
    /// The part's border points.
    pub border: Vec<(u16, u16)>,
    /// The best template's outline at its aligned pose, frame coordinates (empty when not
    /// aligned).
    pub outline: Vec<[f32; 2]>,
}

/// What one frame gave.
#[derive(Debug, Clone)]
pub struct FrameResult {
    /// The detections.
    pub detections: Vec<HostDetection>,
    /// Skipped borders.
    pub skips: Vec<Skip>,
    /// The core's report figures (mask, trace).
    pub report: Report,
    /// Time spent in the core, seconds.
    pub seconds: f64,
    /// The platform estimate, when the frame had no empty shot.
    pub platform: Option<PlatformStats>,
    /// The frame's exposure against the empty shot, when it was fitted (`exposure = "fit"`);
    /// undone before the core saw the frame unless it is the identity.
    pub exposure: Option<Exposure>,
    /// Width of the frame, px.
    pub width: usize,
    /// Height of the frame, px.
    pub height: usize,
}

/// Loads every silhouette (`*.png`, `*.gif`, `*.bmp`) in a folder; names are file stems.
///
/// # Errors
/// The folder is missing or holds no image, or one image cannot be read.
pub fn load_silhouettes(dir: &Path) -> Result<Vec<NamedSilhouette>, InputError> {
    let files = list_files(dir, &["png", "gif", "bmp"])?;
    if files.is_empty() {
        return Err(InputError::new(dir, "template folder holds no PNG, GIF or BMP image"));
    }
    files
        .iter()
        .map(|p| {
            load_gray(p).map(|l| NamedSilhouette {
                name: file_stem(p),
                path: p.clone(),
                note: l.note.map(|n| format!("{}: {n}", p.display())),
                image: l.image,
            })
        })
        .collect()
}

/// Checks that a silhouette holds exactly one part.
///
/// # Errors
/// No part, or several separate blobs (each at least 1% of the largest and 16 px²).
pub fn check_silhouette(img: &GrayImage) -> Result<(), String> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let mut labels: Vec<u8> = img.as_raw().iter().map(|&p| (p > 127) as u8).collect();
    let mut store = Box::new(ContourStore::<HOST_POINTS, HOST_CONTOURS>::new());
    let filter = BorderFilter {
        min_points: 1,
        min_area: 0.0,
    };
    trace_borders(&mut labels, w, h, filter, &mut store).map_err(|e| e.to_string())?;
    let areas: Vec<f32> = store
        .contours()
        .iter()
        .filter(|c| c.kind == BorderKind::Outer)
        .map(|c| c.area())
        .collect();
    let largest = areas.iter().copied().fold(0.0f32, f32::max);
    if largest <= 0.0 {
        return Err("silhouette holds no part (no pixel above 127, or only specks)".into());
    }
    let blobs = areas.iter().filter(|&&a| a >= (0.01 * largest).max(16.0)).count();
    if blobs > 1 {
        return Err(format!(
            "silhouette holds {blobs} separate blobs; a template must be one part"
        ));
    }
    Ok(())
}

/// The core, its planes and the class names.
pub struct Engine {
    rec: Box<HostRecognizer>,
    names: Vec<String>,
    background: Option<Background<Vec<u8>>>,
    labels: Vec<u8>,
    /// Estimate the platform from each frame (no empty shot).
    auto: bool,
    grid: Box<PlatformGrid<HOST_PLATFORM_CELLS>>,
    /// Fit each frame's exposure against the empty shot and undo it.
    exposure_fit: bool,
    /// The frame with its exposure undone (scratch).
    undone: Vec<u8>,
}

impl Engine {
    /// An engine with these parameters and no templates.
    ///
    /// # Errors
    /// Invalid parameters or capacities.
    pub fn new(params: Params) -> Result<Self, String> {
        let mut rec: Box<HostRecognizer> = Box::default();
        rec.set_params(params).map_err(|e| format!("invalid parameters: {e}"))?;
        Ok(Engine {
            rec,
            names: Vec::new(),
            background: None,
            labels: Vec::new(),
            auto: false,
            grid: Box::default(),
            exposure_fit: true,
            undone: Vec::new(),
        })
    }

    /// Whether each frame's gain and offset are fitted against the empty shot and undone before
    /// the frame is processed ([`vorl_core::exposure`]; on by default). Without an empty shot
    /// the platform estimate follows the exposure itself.
    pub fn set_exposure_fit(&mut self, on: bool) {
        self.exposure_fit = on;
    }

    /// The parameters.
    pub fn params(&self) -> &Params {
        self.rec.params()
    }

    /// Class names by template index.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The core templates.
    pub fn templates(&self) -> &[Template<HOST_M>] {
        self.rec.templates()
    }

    /// Teaches one silhouette under `name`.
    ///
    /// # Errors
    /// The silhouette holds no part or several blobs, or the library is full.
    pub fn add_silhouette(&mut self, name: &str, img: &GrayImage) -> Result<(), String> {
        check_silhouette(img)?;
        let (w, h) = (img.width() as usize, img.height() as usize);
        let frame = Frame::new_checked(img.as_raw().as_slice(), w, h).map_err(|e| e.to_string())?;
        let mut labels = vec![0u8; w * h];
        self.rec.teach(&frame, &mut labels).map_err(|e| e.to_string())?;
        self.names.push(name.to_string());
        Ok(())
    }

    /// The background is this image's `I'` (one frame).
    ///
    /// # Errors
    /// An empty image.
    pub fn set_background(&mut self, img: &GrayImage) -> Result<(), String> {
        self.learn_background(std::slice::from_ref(img))
    }

    /// Learns the mean background from several frames of one size.
    ///
    /// # Errors
    /// No frame, frames of different sizes, or more than the core can average.
    pub fn learn_background(&mut self, frames: &[GrayImage]) -> Result<(), String> {
        let first = frames.first().ok_or("no background frame")?;
        let (w, h) = (first.width() as usize, first.height() as usize);
        let mut bg = Background::new(vec![0u8; w * h], w, h).map_err(|e| e.to_string())?;
        let mut high = vec![0u8; w * h];
        let alpha = self.rec.params().alpha();
        for f in frames {
            let frame = Frame::new_checked(f.as_raw().as_slice(), f.width() as usize, f.height() as usize)
                .map_err(|e| e.to_string())?;
            bg.learn(&frame, alpha, &mut high).map_err(|e| e.to_string())?;
        }
        bg.finish_learning(&high).map_err(|e| e.to_string())?;
        self.labels = vec![0u8; w * h];
        self.background = Some(bg);
        Ok(())
    }

    /// No empty shot: the platform is estimated from each frame itself
    /// ([`vorl_core::platform`]), in the core, before the frame is processed.
    pub fn set_auto_background(&mut self) {
        self.auto = true;
        self.background = None;
    }

    /// Whether the platform is estimated from each frame.
    pub fn auto_background(&self) -> bool {
        self.auto
    }

    /// The label plane of the last frame (0 = background; row-major, background's size).
    pub fn labels(&self) -> &[u8] {
        &self.labels
    }

    /// The background model, when set.
    pub fn background(&self) -> Option<&Background<Vec<u8>>> {
        self.background.as_ref()
    }

    /// Runs the core on one frame.
    ///
    /// # Errors
    /// No background, or the frame's size differs from the background's.
    pub fn detect(&mut self, img: &GrayImage) -> Result<FrameResult, String> {
        let frame = Frame::new_checked(img.as_raw().as_slice(), img.width() as usize, img.height() as usize)
            .map_err(|e| e.to_string())?;
        let t0 = std::time::Instant::now();
        let mut platform = None;
        if self.auto {
            let (w, h) = (frame.width(), frame.height());
            let fits = self
                .background
                .as_ref()
                .is_some_and(|b| (b.width(), b.height()) == (w, h));
            if !fits {
                self.background = Some(Background::new(vec![0u8; w * h], w, h).map_err(|e| e.to_string())?);
                self.labels = vec![0u8; w * h];
            }
            let alpha = self.rec.params().alpha();
            if let Some(bg) = self.background.as_mut() {
                platform = Some(
                    bg.estimate_from_frame(&frame, alpha, &mut self.grid)
                        .map_err(|e| e.to_string())?,
                );
            }
        }
        let bg = self.background.as_ref().ok_or("no background set")?;
        let mut exposure = None;
        if !self.auto && self.exposure_fit && (bg.width(), bg.height()) == (frame.width(), frame.height()) {
            let e = fit_exposure(&frame, self.rec.params().alpha(), bg.plane()).map_err(|e| e.to_string())?;
            if !e.is_identity() {
                self.undone.clear();
                self.undone.extend_from_slice(img.as_raw());
                e.undo(&mut self.undone);
            }
            exposure = Some(e);
        }
        let undone;
        let frame = if exposure.is_some_and(|e| !e.is_identity()) {
            undone =
                Frame::new_checked(self.undone.as_slice(), frame.width(), frame.height()).map_err(|e| e.to_string())?;
            &undone
        } else {
            &frame
        };
        let report = self
            .rec
            .process(frame, bg, &mut self.labels)
            .map_err(|e| e.to_string())?;
        let seconds = t0.elapsed().as_secs_f64();
        let store = self.rec.contours();
        let name = |i: Option<u16>| i.and_then(|i| self.names.get(i as usize).cloned());
        let detections = report
            .detections
            .iter()
            .map(|d| HostDetection {
                core: *d,
                class: name(d.template),
                best_class: name(d.best_template),
                border: store
                    .points(d.contour as usize)
                    .iter()
                    .map(|p: &Point| (p.x, p.y))
                    .collect(),
                outline: match (
                    d.pose,
                    d.best_template.and_then(|i| self.rec.templates().get(i as usize)),
                ) {
                    (Some(pose), Some(t)) => t.edge().iter().map(|e| pose.apply(*e)).collect(),
                    _ => Vec::new(),
                },
            })
            .collect();
        Ok(FrameResult {
            detections,
            skips: report.skips.to_vec(),
            report,
            seconds,
            platform,
            exposure,
            width: frame.width(),
            height: frame.height(),
        })
    }
}

/// A readable reason for a skip.
pub fn skip_text(reason: SkipReason) -> &'static str {
    match reason {
        SkipReason::Degenerate => "border has no extent to resample",
        SkipReason::NoArea => "border encloses no area",
        SkipReason::TooManyParts => "more parts than the report holds",
        SkipReason::InsideHole => {
            "inside a hole of another part (print or a nested part; nested_parts = true keeps it)"
        }
        _ => "skipped",
    }
}

/// Foreground share of a frame from which [`frame_notes`] says the background may not fit.
pub const FOREGROUND_NOTE_SHARE: f64 = 0.5;

/// What the core could not keep or report in one frame, and a frame whose foreground covers
/// [`FOREGROUND_NOTE_SHARE`] or more of it, as one-line notes (without the frame's name):
///
/// - each border skipped as degenerate or without area;
/// - the parts beyond [`vorl_core::recognizer::MAX_DETECTIONS`], in one line;
/// - skips beyond [`vorl_core::recognizer::MAX_SKIPS`] that the report could not list;
/// - borders not kept because the contour store ([`HOST_CONTOURS`] borders, [`HOST_POINTS`]
///   points) was full, and borders kept subsampled;
/// - a foreground of half the frame or more (the background no longer fits the scene, or a
///   part covers the view).
pub fn frame_notes(result: &FrameResult) -> Vec<String> {
    use vorl_core::recognizer::{MAX_DETECTIONS, MAX_SKIPS};
    let mut notes = Vec::new();
    let r = &result.report;
    let mut too_many = 0usize;
    for s in &result.skips {
        match s.reason {
            SkipReason::TooManyParts => too_many += 1,
            reason => notes.push(format!("border {} skipped: {}", s.contour, skip_text(reason))),
        }
    }
    if too_many > 0 {
        notes.push(format!(
            "{too_many} outer border(s) not reported as parts (nor looked at): a frame reports at most \
             {MAX_DETECTIONS} parts"
        ));
    }
    if r.skips_lost > 0 {
        notes.push(format!(
            "{} further border(s) skipped and not listed (the report lists at most {MAX_SKIPS} skips)",
            r.skips_lost
        ));
    }
    if r.trace.skipped_capacity > 0 {
        notes.push(format!(
            "{} of {} border(s) not kept and not looked at: the contour store is full ({HOST_CONTOURS} borders, \
             {HOST_POINTS} points; {} kept)",
            r.trace.skipped_capacity, r.trace.found, r.trace.kept
        ));
    }
    if r.trace.subsampled > 0 {
        notes.push(format!(
            "{} border(s) kept subsampled: longer than the free point storage",
            r.trace.subsampled
        ));
    }
    let pixels = result.width * result.height;
    if pixels > 0 {
        let share = r.mask.foreground as f64 / pixels as f64;
        if share >= FOREGROUND_NOTE_SHARE {
            notes.push(format!(
                "{:.0} % of the frame differs from the background: the background may no longer fit \
                 (lighting changed, camera moved) or something covers the view",
                100.0 * share
            ));
        }
    }
    notes
}
