//! The host's driver of the core: a boxed [`vorl_core::Recognizer`] with generous capacities,
//! the frame-sized planes, template names and silhouette checks.

use std::path::Path;

use image::GrayImage;
use vorl_core::borders::contour::{trace_borders, BorderFilter, BorderKind, ContourStore, Point};
use vorl_core::pixels::background::{Background, PlatformKeeping, PlatformUse};
use vorl_core::pixels::exposure::{fit_exposure, fit_platform_shift, Exposure};
use vorl_core::pixels::platform::{PlatformGrid, PlatformStats};
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
    /// The platform estimate in use, when the frame had no empty shot.
    pub platform: Option<PlatformStats>,
    /// How many frames before this one that estimate was made (0: from this frame).
    pub platform_frames_ago: u32,
    /// The frame's exposure against the empty shot, when it was fitted (`exposure = "fit"`);
    /// undone before the core saw the frame unless it is the identity.
    pub exposure: Option<Exposure>,
    /// Width of the frame, px.
    pub width: usize,
    /// Height of the frame, px.
    pub height: usize,
}

/// Loads every silhouette (`*.png`, `*.gif`, `*.bmp`) in a folder: `<class>.png` is a class of
/// one example, and a subfolder `<class>/` holds several examples of one class (any file names;
/// the class then carries the tolerance its examples need, [`Engine::add_silhouettes`]).
///
/// # Errors
/// The folder is missing or holds no image, a class folder holds no image, or one image cannot
/// be read (named: a class folder mixing good and unreadable examples is refused, not
/// silently taught from the good ones).
pub fn load_silhouettes(dir: &Path) -> Result<Vec<NamedSilhouette>, InputError> {
    const EXTS: [&str; 3] = ["png", "gif", "bmp"];
    let mut entries: Vec<(String, std::path::PathBuf)> = list_files(dir, &EXTS)?
        .into_iter()
        .map(|p| (file_stem(&p), p))
        .collect();
    let mut classes: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| InputError::new(dir, e.to_string()))?
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.is_dir())
        .collect();
    classes.sort();
    for class in classes {
        let files = list_files(&class, &EXTS)?;
        if files.is_empty() {
            return Err(InputError::new(&class, "class folder holds no PNG, GIF or BMP image"));
        }
        let name = crate::io::file_name(&class);
        if entries.iter().any(|(n, _)| *n == name) {
            return Err(InputError::new(
                &class,
                format!("class {name:?} is both a file and a folder of examples; keep one"),
            ));
        }
        entries.extend(files.into_iter().map(|p| (name.clone(), p)));
    }
    if entries.is_empty() {
        return Err(InputError::new(dir, "template folder holds no PNG, GIF or BMP image"));
    }
    entries
        .into_iter()
        .map(|(name, p)| {
            load_gray(&p).map(|l| NamedSilhouette {
                name,
                note: l.note.map(|n| format!("{}: {n}", p.display())),
                path: p,
                image: l.image,
            })
        })
        .collect()
}

/// The largest factor on the verification limit a class's examples may ask for
/// ([`Engine::add_silhouettes`]); examples further apart are reported, and the factor capped.
pub const MAX_CLASS_TOLERANCE: f32 = 4.0;

/// How one example of a class verified against another: the score over its limit, and the
/// scale of the second against the first (`None`: it could not be aligned at all).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossFit {
    /// Verification score over its limit.
    pub ratio: f32,
    /// Scale of the second example over the first.
    pub scale: f32,
}

/// How much farther than the examples lie from each other a part of a class may lie from its
/// nearest example, where the examples agree more closely than the parameters' limit: a few
/// examples are a few samples of the class's spread, and its parts reach past them. (Chosen on
/// another generator's scenes, classes taught from three frames each and the other frames
/// evaluated: the examples' own spread as the limit lost whole parts in two of twelve sets,
/// twice it none; `docs/accuracy.md`, "Classes taught from several examples".)
pub const SPREAD_MARGIN: f32 = 2.0;

/// The tolerance a class of several examples needs (see [`vorl_core::Tolerance`]): each example
/// is taught alone and the others are recognised against it (`fits[i][j]`: example `j` against
/// template `i`); the spread is the largest, over the examples, of the lowest ratio to any
/// other (a part of the class lies nearer to one of its examples than the examples lie to each
/// other). Where the spread exceeds the parameters' limit (1) it is the factor, at most
/// [`MAX_CLASS_TOLERANCE`]; where it is within it, the factor is [`SPREAD_MARGIN`] times it,
/// at most 1 and at least [`vorl_core::Tolerance::MIN_VERIFY`] (a class of closely alike
/// examples is held closely, so a part that only resembles it is unknown); an example that
/// aligns on no other leaves the factor at 1 at least. The scale range spans every pair's
/// scale. Returns the tolerance and whether the cap was reached.
pub fn class_tolerance(fits: &[Vec<Option<CrossFit>>]) -> (vorl_core::Tolerance, bool) {
    let k = fits.len();
    let mut spread = 0.0f32;
    let (mut lo, mut hi) = (1.0f32, 1.0f32);
    let mut capped = false;
    for j in 0..k {
        let nearest = (0..k)
            .filter(|&i| i != j)
            .filter_map(|i| fits.get(i).and_then(|row| row.get(j)).copied().flatten())
            .map(|f| f.ratio)
            .fold(f32::INFINITY, f32::min);
        if k > 1 {
            if nearest.is_finite() {
                spread = spread.max(nearest);
            } else {
                capped = true;
            }
        }
    }
    let mut factor = if k < 2 {
        1.0
    } else if spread > 1.0 {
        spread
    } else {
        (SPREAD_MARGIN * spread).clamp(vorl_core::Tolerance::MIN_VERIFY, 1.0)
    };
    if capped {
        factor = factor.max(1.0);
    }
    for row in fits {
        for f in row.iter().flatten() {
            if f.scale.is_finite() && f.scale > 0.0 {
                lo = lo.min(f.scale);
                hi = hi.max(f.scale);
            }
        }
    }
    if factor > MAX_CLASS_TOLERANCE || capped {
        capped = true;
        factor = factor.min(MAX_CLASS_TOLERANCE);
    }
    (
        vorl_core::Tolerance {
            verify: factor,
            scale: [lo, hi],
        },
        capped,
    )
}

/// `silhouette` (part bright on black) recognised against `template` taught alone, with
/// `params` but any scale in 0.5–2 and the template aligned whatever its DP cost (an infinite
/// `candidate_ratio`: examples of one class may lie further apart in the descriptor than the
/// family of [`vorl_core::recognizer::UNVERIFIED_FAMILY`]): the detection of its largest part
/// (`None` without one). How one example of a class lies against another
/// ([`Engine::add_silhouettes`], `vorl teach --add`).
///
/// # Errors
/// `template` cannot be taught.
pub fn recognise_alone(
    params: Params,
    template: &GrayImage,
    silhouette: &GrayImage,
) -> Result<Option<vorl_core::Detection>, String> {
    let mut one = Engine::new(Params {
        scale_min: 0.5,
        scale_max: 2.0,
        candidate_ratio: f32::INFINITY,
        ..params
    })?;
    one.add_silhouette("template", template)?;
    one.set_background(&GrayImage::new(silhouette.width(), silhouette.height()))?;
    let result = one.detect(silhouette)?;
    Ok(result
        .detections
        .iter()
        .max_by(|x, y| x.core.area.total_cmp(&y.core.area))
        .map(|d| d.core))
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

/// A zeroed plane of `len` bytes whose pages are already mapped: `vec![0; len]` gets pages
/// from the system only when they are first written, so the first frame would pay about 75
/// page faults for a 640×480 plane inside its timed work; a camera program sets its planes up
/// before the first part arrives, and so does the engine.
fn touched_plane(len: usize) -> Vec<u8> {
    let mut plane = vec![0u8; len];
    // One write a page maps it (the value is the zero it holds; `black_box` keeps the write).
    for i in (0..len).step_by(4096) {
        if let Some(b) = plane.get_mut(i) {
            *b = std::hint::black_box(0);
        }
    }
    plane
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
    keeping: PlatformKeeping,
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
            keeping: PlatformKeeping::new(crate::config::DEFAULT_PLATFORM_EVERY),
            undone: Vec::new(),
        })
    }

    /// Whether each frame's gain and offset are fitted against the empty shot and undone before
    /// the frame is processed ([`vorl_core::pixels::exposure`]; on by default). Without an empty shot
    /// the platform estimate follows the exposure itself.
    pub fn set_exposure_fit(&mut self, on: bool) {
        self.exposure_fit = on;
    }

    /// Whether a blob inside the frame whose border has no junction is left whole by the
    /// partial search ([`vorl_core::Recognizer::set_junction_gate`]; on by default). Off, every
    /// blob the whole-border result does not settle is searched, to hold the gate against it.
    pub fn set_junction_gate(&mut self, on: bool) {
        self.rec.set_junction_gate(on);
    }

    /// Without an empty shot: most frames one platform estimate serves while they still fit it
    /// ([`Background::estimate_or_keep`]; 1: every frame is estimated anew).
    pub fn set_platform_every(&mut self, every: u32) {
        self.keeping = PlatformKeeping::new(every);
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

    /// Teaches every silhouette, in order, each under its name; a class of several examples
    /// (several silhouettes of one name) gets the [`class_tolerance`] of its examples, measured
    /// here by recognising each example against each other one. Returns one line per class of
    /// several examples, saying its tolerance (and when its examples lie further apart than
    /// [`MAX_CLASS_TOLERANCE`]).
    ///
    /// # Errors
    /// As [`Self::add_silhouette`], naming the file.
    pub fn add_silhouettes(&mut self, silhouettes: &[NamedSilhouette]) -> Result<Vec<String>, String> {
        let first = self.names.len();
        for t in silhouettes {
            self.add_silhouette(&t.name, &t.image)
                .map_err(|e| format!("{}: {e}", t.path.display()))?;
        }
        let mut notes = Vec::new();
        let mut done: Vec<&str> = Vec::new();
        for t in silhouettes {
            if done.contains(&t.name.as_str()) {
                continue;
            }
            done.push(&t.name);
            let examples: Vec<&NamedSilhouette> = silhouettes.iter().filter(|s| s.name == t.name).collect();
            if examples.len() < 2 {
                continue;
            }
            let fits = self.cross_fits(&examples)?;
            let (tolerance, capped) = class_tolerance(&fits);
            let indices: Vec<usize> = (first..self.names.len()).filter(|&i| self.names[i] == t.name).collect();
            for i in indices {
                self.rec
                    .set_tolerance(i, tolerance)
                    .map_err(|e| format!("class {}: {e}", t.name))?;
            }
            notes.push(format!(
                "class {}: {} examples; verification limit ×{:.2}, scale {:.2}–{:.2}{}",
                t.name,
                examples.len(),
                tolerance.verify,
                tolerance.scale[0],
                tolerance.scale[1],
                if capped {
                    format!(
                        " (capped: some examples lie further from every other than ×{MAX_CLASS_TOLERANCE} the limit; teach them as a class of their own)"
                    )
                } else {
                    String::new()
                }
            ));
        }
        Ok(notes)
    }

    /// Each example recognised against each other one taught alone (`[i][j]`: example `j`
    /// against example `i`, [`recognise_alone`]).
    fn cross_fits(&self, examples: &[&NamedSilhouette]) -> Result<Vec<Vec<Option<CrossFit>>>, String> {
        let mut fits = Vec::new();
        for (i, a) in examples.iter().enumerate() {
            let mut row = Vec::new();
            for (j, b) in examples.iter().enumerate() {
                if i == j {
                    row.push(None);
                    continue;
                }
                let d = recognise_alone(*self.rec.params(), &a.image, &b.image)
                    .map_err(|e| format!("{}: {e}", a.path.display()))?;
                row.push(d.filter(|d| d.verify.is_finite()).map(|d| CrossFit {
                    ratio: d.verify / d.verify_limit,
                    scale: d.scale,
                }));
            }
            fits.push(row);
        }
        Ok(fits)
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
        self.labels = touched_plane(w * h);
        // The scratch of a frame whose exposure is undone, mapped now as well.
        self.undone = touched_plane(w * h);
        self.background = Some(bg);
        Ok(())
    }

    /// No empty shot: the platform is estimated from the frames themselves
    /// ([`vorl_core::pixels::platform`]), in the core, before the frame is processed; an estimate
    /// serves the next frames while they fit it ([`Self::set_platform_every`]).
    pub fn set_auto_background(&mut self) {
        self.auto = true;
        self.background = None;
    }

    /// Whether the platform is estimated from the frames (no empty shot).
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
        self.detect_pixels(img.as_raw(), img.width() as usize, img.height() as usize)
    }

    /// Runs the core on one frame held in the caller's memory: `pixels` row-major, `width`
    /// pixels a row and no padding, 8-bit gray (a camera's buffer or a Python array, read in
    /// place, not copied).
    ///
    /// # Errors
    /// `pixels` does not hold `width × height` bytes, no background, or the frame's size differs
    /// from the background's.
    pub fn detect_pixels(&mut self, pixels: &[u8], width: usize, height: usize) -> Result<FrameResult, String> {
        let frame = Frame::new_checked(pixels, width, height).map_err(|e| e.to_string())?;
        if self.auto {
            // A frame of a new size: its planes are set up before the clock starts (set-up, not
            // the frame's work).
            let (w, h) = (frame.width(), frame.height());
            let fits = self
                .background
                .as_ref()
                .is_some_and(|b| (b.width(), b.height()) == (w, h));
            if !fits {
                self.background = Some(Background::new(touched_plane(w * h), w, h).map_err(|e| e.to_string())?);
                self.labels = touched_plane(w * h);
                self.keeping.reset();
            }
        }
        let t0 = std::time::Instant::now();
        let mut platform = None;
        let mut platform_frames_ago = 0;
        if self.auto {
            let alpha = self.rec.params().alpha();
            if let Some(bg) = self.background.as_mut() {
                let used = bg
                    .estimate_or_keep(&frame, alpha, &mut self.grid, &mut self.keeping)
                    .map_err(|e| e.to_string())?;
                platform = Some(used.stats());
                if let PlatformUse::Kept { frames_ago, .. } = used {
                    platform_frames_ago = frames_ago;
                }
            }
        }
        let bg = self.background.as_ref().ok_or("no background set")?;
        let mut exposure = None;
        if !self.auto && self.exposure_fit && (bg.width(), bg.height()) == (frame.width(), frame.height()) {
            // Whether the platform's levels moved first (one round of least squares, a gain only
            // where the platform's levels spread enough to measure one: half the cost, and a
            // narrow platform's spurious gain does not count as a change): an unchanged
            // exposure ends there; a changed one gets the full fit.
            let alpha = self.rec.params().alpha();
            let quick = fit_platform_shift(&frame, alpha, bg.plane()).map_err(|e| e.to_string())?;
            let e = if quick.is_identity() {
                quick
            } else {
                fit_exposure(&frame, alpha, bg.plane()).map_err(|e| e.to_string())?
            };
            if !e.is_identity() {
                self.undone.clear();
                self.undone.extend_from_slice(pixels);
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
                    // A part upside down: the mirror image's outline.
                    (Some(pose), Some(t)) if d.flipped => t.mirrored().edge().iter().map(|e| pose.apply(*e)).collect(),
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
            platform_frames_ago,
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
        SkipReason::Shadow => {
            "a shadow: darker beside a bright part, its edge blurred, cut off it, and no template explains it"
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
/// - blobs too thin to hold any taught part ([`vorl_core::recognizer::Report::thin`]), in one line;
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
    if r.thin > 0 {
        notes.push(format!(
            "{} speck(s) or stroke(s) thinner than any taught part could be (print, dust, scratches): \
             not parts, not looked at",
            r.thin
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

#[cfg(test)]
mod class_tests {
    use super::*;

    fn fit(ratio: f32, scale: f32) -> Option<CrossFit> {
        Some(CrossFit { ratio, scale })
    }

    #[test]
    fn class_tolerance_is_the_farthest_example_from_its_nearest() {
        // Three examples: 0 and 1 close (ratio 1.5 both ways), 2 nearest to 1 at 2.5.
        let fits = vec![
            vec![None, fit(1.5, 1.1), fit(3.0, 1.3)],
            vec![fit(1.5, 0.9), None, fit(2.5, 1.2)],
            vec![fit(3.2, 0.77), fit(2.6, 0.83), None],
        ];
        let (t, capped) = class_tolerance(&fits);
        assert!(!capped);
        assert_eq!(t.verify, 2.5);
        assert_eq!(t.scale, [0.77, 1.3]);
        // Examples within half the limit of each other need nothing more than the parameters;
        // closer ones hold the class to twice their spread, at least MIN_VERIFY.
        let close = vec![vec![None, fit(0.4, 1.0)], vec![fit(0.5, 1.0), None]];
        assert_eq!(class_tolerance(&close), (vorl_core::Tolerance::NONE, false));
        let closer = vec![vec![None, fit(0.3, 1.0)], vec![fit(0.35, 1.0), None]];
        assert_eq!(class_tolerance(&closer).0.verify, 0.7);
        let alike = vec![vec![None, fit(0.05, 1.0)], vec![fit(0.1, 1.0), None]];
        assert_eq!(class_tolerance(&alike).0.verify, vorl_core::Tolerance::MIN_VERIFY);
        // An example that aligns on no other: the class is not narrowed.
        let lost = vec![
            vec![None, fit(0.1, 1.0), None],
            vec![fit(0.1, 1.0), None, None],
            vec![None, None, None],
        ];
        let (t, capped) = class_tolerance(&lost);
        assert!(capped && t.verify == 1.0);
        // One that aligns on no other, or too far: capped, and said so.
        let apart = vec![vec![None, None], vec![None, None]];
        let (t, capped) = class_tolerance(&apart);
        assert!(capped && t.verify == 1.0);
        let far = vec![vec![None, fit(9.0, 1.0)], vec![fit(7.0, 1.0), None]];
        let (t, capped) = class_tolerance(&far);
        assert!(capped && t.verify == MAX_CLASS_TOLERANCE);
    }
}

#[cfg(test)]
mod class_recognition_tests {
    use super::*;

    /// A 64 px bar `thick` px wide, centred, on a black canvas (a template silhouette) or dark
    /// on a platform of 200 (a frame).
    fn bar(thick: u32, silhouette: bool) -> GrayImage {
        bar_of(64, thick, silhouette)
    }

    /// A bar `long` × `thick` px, centred, as [`bar`].
    fn bar_of(long: u32, thick: u32, silhouette: bool) -> GrayImage {
        let (bg, part) = if silhouette { (0u8, 255u8) } else { (200, 40) };
        let mut img = GrayImage::from_pixel(220, 120, image::Luma([bg]));
        for y in (60 - thick / 2)..(60 - thick / 2 + thick) {
            for x in (110 - long / 2)..(110 - long / 2 + long) {
                img.put_pixel(x, y, image::Luma([part]));
            }
        }
        img
    }

    fn named(thick: u32) -> NamedSilhouette {
        NamedSilhouette {
            name: "bar".into(),
            path: format!("bar{thick}.png").into(),
            note: None,
            image: bar(thick, true),
        }
    }

    #[test]
    fn a_part_between_a_classes_examples_is_that_class() {
        let frame = bar(THICK, false);
        let run = |examples: &[NamedSilhouette]| {
            let mut e = Engine::new(Params::DEFAULT).unwrap();
            let notes = e.add_silhouettes(examples).unwrap();
            e.set_background(&GrayImage::from_pixel(220, 120, image::Luma([200])))
                .unwrap();
            let d = e.detect(&frame).unwrap().detections[0].clone();
            (notes, d)
        };
        // Taught from the 16 px thick bar alone, the thicker one is too far off.
        let (notes, alone) = run(&[named(16)]);
        assert!(notes.is_empty());
        assert_eq!(alone.class, None, "{:?}", alone.core);
        // Taught from a 16 and a 32 px thick bar, it lies between them: a bar.
        let (notes, class) = run(&[named(16), named(32)]);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert_eq!(class.class.as_deref(), Some("bar"), "{:?} {notes:?}", class.core);
    }

    #[test]
    fn a_class_of_alike_examples_is_held_closely() {
        let run = |examples: &[NamedSilhouette], frame: &GrayImage| {
            let mut e = Engine::new(Params::DEFAULT).unwrap();
            let notes = e.add_silhouettes(examples).unwrap();
            e.set_background(&GrayImage::from_pixel(220, 120, image::Luma([200])))
                .unwrap();
            let d = e.detect(frame).unwrap().detections[0].clone();
            (notes, d)
        };
        let right = bar_of(64, 16, false);
        // A bar an eighth shorter: the similarity takes most of it up (scale ~0.93).
        let shorter = bar_of(56, 16, false);
        let alike = [
            named(16),
            NamedSilhouette {
                path: "bar16b.png".into(),
                ..named(16)
            },
        ];
        // One example: the parameters' limit, and the shorter bar passes for it.
        let (_, alone) = run(&[named(16)], &shorter);
        assert_eq!(alone.class.as_deref(), Some("bar"), "{:?}", alone.core);
        // Two examples that agree: the class is held to half the limit; the bar itself is
        // still the class, the shorter one is not.
        let (notes, held) = run(&alike, &shorter);
        assert!(notes.iter().any(|n| n.contains("×0.50")), "{notes:?}");
        assert_eq!(held.class, None, "{:?}", held.core);
        let (_, same) = run(&alike, &right);
        assert_eq!(same.class.as_deref(), Some("bar"), "{:?}", same.core);
    }

    const THICK: u32 = 24;
}

#[cfg(test)]
mod exposure_tests {
    use super::*;

    /// A platform of a few grey levels (116–131) seen with fresh noise each time (σ 2.7), a
    /// dark part on it when `part`, the whole mapped by `gain · v + offset`.
    fn capture(seed: u64, part: bool, gain: f32, offset: f32) -> GrayImage {
        let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        GrayImage::from_fn(160, 120, |x, y| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let noise = (0..6).map(|k| (state >> (10 * k)) % 4).sum::<u64>() as f32 - 9.0;
            let dark = part && (50..110).contains(&x) && (40..80).contains(&y);
            let v = if dark { 40.0 } else { 116.0 + (x / 10) as f32 } + noise;
            image::Luma([(gain * v + offset).round().clamp(0.0, 255.0) as u8])
        })
    }

    #[test]
    fn a_frame_at_the_shots_exposure_is_left_alone_and_a_changed_one_undone() {
        let mut e = Engine::new(Params::DEFAULT).unwrap();
        // The model: one capture of the empty platform.
        e.learn_background(&[capture(1, false, 1.0, 0.0)]).unwrap();
        // At the shot's exposure least squares over these few levels fit a gain well below 1
        // (the noise flattens it); the platform has not moved, and the frame is left alone.
        let same = capture(4, true, 1.0, 0.0);
        let plane = e.background.as_ref().unwrap().plane().to_vec();
        let frame = Frame::new_checked(same.as_raw().as_slice(), 160, 120).unwrap();
        let full = fit_exposure(&frame, Params::DEFAULT.alpha(), &plane).unwrap();
        assert!(full.gain < 0.9 && !full.is_identity(), "{full:?}");
        let r = e.detect(&same).unwrap();
        assert!(r.exposure.is_some_and(|x| x.is_identity()), "{:?}", r.exposure);
        assert_eq!(r.detections.len(), 1);
        // A dimmer exposure of the same scene (0.7·v + 6: the platform 28–33 levels down) is
        // undone, and the part is still one.
        let r = e.detect(&capture(5, true, 0.7, 6.0)).unwrap();
        assert!(r.exposure.is_some_and(|x| !x.is_identity()), "{:?}", r.exposure);
        assert_eq!(r.detections.len(), 1);
    }
}
