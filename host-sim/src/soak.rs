//! The soak run (`vorl soak`): a long stream of generated frames of every `vorl gen` variant
//! through one core recognizer, with resident memory sampled, every frame's report held
//! against the report of a fresh recognizer on the same frame.
//!
//! The stream is made in chunks, in memory ([`crate::gen::MemorySet`], nothing written):
//! each chunk renders `distinct` new frames, cycling over the sources (every variant with its
//! own platform: the empty shot where the variant has one, estimated from the frame where it
//! has none; `default` and `exposure` also with the platform estimated), runs each through a
//! fresh recognizer (a clone of the one just taught) for its reference, then sends the chunk
//! `reuse` times, shuffled, through the one long-lived recognizer. Every frame of the stream is
//! compared with its reference: detections, skips and the mask's and tracer's figures, f32 for
//! f32 (`{:?}` of the report's parts, which prints every float exactly).
//!
//! Rendering is the slow part (about 30 ms a 640×480 frame, the recognizer about 1 ms), hence
//! the reuse.

use std::time::Instant;

use rayon::prelude::*;
use vorl_core::pixels::background::Background;
use vorl_core::pixels::platform::PlatformGrid;
use vorl_core::recognizer::Report;
use vorl_core::{Frame, Params};

use crate::engine::{HostRecognizer, HOST_PLATFORM_CELLS};
use crate::gen::{GenOptions, MemorySet, Variant};

/// What to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SoakOptions {
    /// Frames through the long-lived recognizer.
    pub frames: usize,
    /// New frames rendered per chunk.
    pub distinct: usize,
    /// Times each rendered frame goes through the long-lived recognizer.
    pub reuse: usize,
    /// Seed of the sets.
    pub seed: u64,
    /// Frame width, px.
    pub width: u32,
    /// Frame height, px.
    pub height: u32,
    /// Frames between two memory samples.
    pub sample_every: usize,
}

impl Default for SoakOptions {
    fn default() -> Self {
        SoakOptions {
            frames: 100_000,
            distinct: 112,
            reuse: 8,
            seed: 1,
            width: 640,
            height: 480,
            sample_every: 1000,
        }
    }
}

/// One memory sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemorySample {
    /// Frames done when it was taken.
    pub frames: usize,
    /// Resident set, KiB (`VmRSS`).
    pub rss_kib: u64,
    /// Peak resident set so far, KiB (`VmHWM`).
    pub hwm_kib: u64,
}

/// What the run found.
#[derive(Debug, Clone, PartialEq)]
pub struct SoakReport {
    /// Frames through the long-lived recognizer.
    pub frames: usize,
    /// Frames rendered (each also run through a fresh recognizer).
    pub rendered: usize,
    /// Sources (variant and platform) in the stream.
    pub sources: Vec<String>,
    /// Templates the recognizer holds.
    pub templates: usize,
    /// Detections over the stream.
    pub detections: usize,
    /// Of which classified as a template.
    pub known: usize,
    /// Frames whose report differs from the fresh recognizer's.
    pub mismatches: usize,
    /// Frames the core refused.
    pub errors: usize,
    /// The first mismatch or error, if any.
    pub first_problem: Option<String>,
    /// Seconds of the whole run (rendering included).
    pub seconds: f64,
    /// Seconds in the long-lived recognizer (platform estimates included).
    pub core_seconds: f64,
    /// Memory samples (the first after the first chunk).
    pub memory: Vec<MemorySample>,
}

impl SoakReport {
    /// The first sample's resident set, KiB.
    pub fn first_rss_kib(&self) -> u64 {
        self.memory.first().map_or(0, |m| m.rss_kib)
    }
    /// The largest resident set sampled, KiB.
    pub fn peak_rss_kib(&self) -> u64 {
        self.memory.iter().map(|m| m.rss_kib).max().unwrap_or(0)
    }
    /// The last sample's resident set, KiB.
    pub fn final_rss_kib(&self) -> u64 {
        self.memory.last().map_or(0, |m| m.rss_kib)
    }
    /// The process's peak resident set at the end, KiB.
    pub fn hwm_kib(&self) -> u64 {
        self.memory.last().map_or(0, |m| m.hwm_kib)
    }
}

/// `VmRSS` and `VmHWM` of this process, KiB (0 where /proc is not there).
pub fn memory_kib() -> (u64, u64) {
    let text = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let field = |name: &str| {
        text.lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(0)
    };
    (field("VmRSS:"), field("VmHWM:"))
}

/// One source of the stream.
struct Source {
    name: String,
    set: MemorySet,
    /// The learned empty shot; `None`: the platform is estimated from each frame.
    background: Option<Background<Vec<u8>>>,
}

/// The report's parts that must not change from one recognizer to another, exactly.
fn signature(report: &Report) -> String {
    format!(
        "{:?}|{:?}|{}|{}|{}|{}",
        report.detections.as_slice(),
        report.skips.as_slice(),
        report.mask.foreground,
        report.mask.threshold,
        report.trace.kept,
        report.skips_lost
    )
}

/// Runs one frame: the platform estimated into `plane` when the source has no empty shot.
fn process(
    rec: &mut HostRecognizer,
    src: &Source,
    img: &image::GrayImage,
    plane: &mut Background<Vec<u8>>,
    grid: &mut PlatformGrid<HOST_PLATFORM_CELLS>,
    labels: &mut [u8],
) -> Result<Report, String> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let frame = Frame::new_checked(img.as_raw().as_slice(), w, h).map_err(|e| e.to_string())?;
    match &src.background {
        Some(bg) => rec.process(&frame, bg, labels).map_err(|e| e.to_string()),
        None => {
            let alpha = rec.params().alpha();
            plane
                .estimate_from_frame(&frame, alpha, grid)
                .map_err(|e| e.to_string())?;
            rec.process(&frame, plane, labels).map_err(|e| e.to_string())
        }
    }
}

/// Stack of the thread the run takes place on: a recognizer with the host's capacities is
/// about 2 MiB, and cloning one may pass it through the stack (a test thread has 2 MiB).
const STACK: usize = 64 << 20;

/// The run; `progress` gets a line at every memory sample.
///
/// # Errors
/// Options out of range, or templates the recognizer does not take.
pub fn run(opts: &SoakOptions, progress: impl FnMut(&str) + Send) -> Result<SoakReport, String> {
    std::thread::scope(|scope| {
        std::thread::Builder::new()
            .name("soak".into())
            .stack_size(STACK)
            .spawn_scoped(scope, || run_here(opts, progress))
            .map_err(|e| format!("cannot start the soak thread: {e}"))?
            .join()
            .map_err(|_| "the soak thread panicked".to_string())?
    })
}

/// [`run`] on this thread.
fn run_here(opts: &SoakOptions, mut progress: impl FnMut(&str)) -> Result<SoakReport, String> {
    if opts.frames == 0 || opts.distinct == 0 || opts.reuse == 0 || opts.sample_every == 0 {
        return Err("frames, distinct, reuse and sample-every must be at least 1".into());
    }
    let started = Instant::now();
    let (w, h) = (opts.width as usize, opts.height as usize);
    // Every variant with its own platform, and two with the platform estimated as well.
    let mut plan: Vec<(Variant, bool)> = Variant::ALL.iter().map(|&v| (v, v.writes_background())).collect();
    plan.push((Variant::Default, false));
    plan.push((Variant::Exposure, false));

    let mut rec: Box<HostRecognizer> = Box::default();
    rec.set_params(Params::DEFAULT).map_err(|e| e.to_string())?;
    let mut labels = vec![0u8; w * h];
    // Templates: every variant's, all in the one recognizer; a silhouette byte for byte the
    // same as one taught already (the variants share most of their catalogues and scales) is
    // the same template, taught once.
    let mut silhouettes: Vec<(u32, u32, Vec<u8>)> = Vec::new();
    let mut sources = Vec::new();
    for (k, &(variant, shot)) in plan.iter().enumerate() {
        let gen = GenOptions {
            seed: opts.seed.wrapping_add(k as u64),
            frames: 0,
            variant,
            width: opts.width,
            height: opts.height,
            background: Some(shot),
        };
        let set = MemorySet::new(&gen).map_err(|e| e.to_string())?;
        for (name, img) in set.templates() {
            let key = (img.width(), img.height(), img.as_raw().clone());
            if silhouettes.contains(&key) {
                continue;
            }
            silhouettes.push(key);
            let (tw, th) = (img.width() as usize, img.height() as usize);
            let frame = Frame::new_checked(img.as_raw().as_slice(), tw, th).map_err(|e| e.to_string())?;
            let mut scratch = vec![0u8; tw * th];
            rec.teach(&frame, &mut scratch)
                .map_err(|e| format!("template {name} of {variant}: {e}"))?;
        }
        let background = if shot {
            let captures = set.backgrounds();
            let mut bg = Background::new(vec![0u8; w * h], w, h).map_err(|e| e.to_string())?;
            let alpha = rec.params().alpha();
            for c in &captures {
                let f = Frame::new_checked(c.as_raw().as_slice(), w, h).map_err(|e| e.to_string())?;
                bg.learn(&f, alpha, &mut labels).map_err(|e| e.to_string())?;
            }
            bg.finish_learning(&labels).map_err(|e| e.to_string())?;
            Some(bg)
        } else {
            None
        };
        let name = format!("{variant}{}", if shot { "" } else { " (platform estimated)" });
        sources.push(Source { name, set, background });
    }
    let pristine = rec.clone();
    let mut plane = Background::new(vec![0u8; w * h], w, h).map_err(|e| e.to_string())?;
    let mut grid: Box<PlatformGrid<HOST_PLATFORM_CELLS>> = Box::default();

    let mut report = SoakReport {
        frames: 0,
        rendered: 0,
        sources: sources.iter().map(|s| s.name.clone()).collect(),
        templates: rec.templates().len(),
        detections: 0,
        known: 0,
        mismatches: 0,
        errors: 0,
        first_problem: None,
        seconds: 0.0,
        core_seconds: 0.0,
        memory: Vec::new(),
    };
    let mut shuffle: u64 = opts.seed ^ 0x9E37_79B9_7F4A_7C15;
    let mut chunk = 0usize;
    while report.frames < opts.frames {
        // Render the chunk (in parallel) and take each frame's reference from a fresh recognizer.
        let jobs: Vec<(usize, usize)> = (0..opts.distinct)
            .map(|k| {
                let n = chunk * opts.distinct + k;
                (n % sources.len(), n / sources.len())
            })
            .collect();
        let images: Vec<image::GrayImage> = jobs.par_iter().map(|&(s, i)| sources[s].set.frame(i).0).collect();
        report.rendered += images.len();
        let mut references = Vec::with_capacity(images.len());
        for (&(s, _), img) in jobs.iter().zip(&images) {
            let mut fresh = pristine.clone();
            let mut fresh_plane = Background::new(vec![0u8; w * h], w, h).map_err(|e| e.to_string())?;
            let mut fresh_grid: Box<PlatformGrid<HOST_PLATFORM_CELLS>> = Box::default();
            let mut fresh_labels = vec![0u8; w * h];
            let r = process(
                &mut fresh,
                &sources[s],
                img,
                &mut fresh_plane,
                &mut fresh_grid,
                &mut fresh_labels,
            );
            references.push(r.map(|r| signature(&r)));
        }
        // The chunk, `reuse` times, shuffled (Fisher–Yates on xorshift64*).
        let mut order: Vec<usize> = (0..images.len() * opts.reuse).map(|k| k % images.len()).collect();
        for i in (1..order.len()).rev() {
            shuffle ^= shuffle >> 12;
            shuffle ^= shuffle << 25;
            shuffle ^= shuffle >> 27;
            let j = (shuffle.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 33) as usize % (i + 1);
            order.swap(i, j);
        }
        for &k in order.iter().take(opts.frames - report.frames) {
            let (s, i) = jobs[k];
            let t0 = Instant::now();
            let got = process(&mut rec, &sources[s], &images[k], &mut plane, &mut grid, &mut labels);
            report.core_seconds += t0.elapsed().as_secs_f64();
            report.frames += 1;
            match (&got, &references[k]) {
                (Ok(r), Ok(expected)) => {
                    report.detections += r.detections.len();
                    report.known += r.detections.iter().filter(|d| d.template.is_some()).count();
                    if signature(r) != *expected {
                        report.mismatches += 1;
                        report.first_problem.get_or_insert_with(|| {
                            format!(
                                "{} frame {i}: the report differs from a fresh recognizer's",
                                sources[s].name
                            )
                        });
                    }
                }
                (Err(e), _) | (_, Err(e)) => {
                    report.errors += 1;
                    report
                        .first_problem
                        .get_or_insert_with(|| format!("{} frame {i}: {e}", sources[s].name));
                }
            }
            if report.frames % opts.sample_every == 0 || report.frames == opts.frames {
                let (rss, hwm) = memory_kib();
                report.memory.push(MemorySample {
                    frames: report.frames,
                    rss_kib: rss,
                    hwm_kib: hwm,
                });
                progress(&format!(
                    "soak frames={} rendered={} mismatches={} errors={} rss_kib={rss} hwm_kib={hwm} seconds={:.1}",
                    report.frames,
                    report.rendered,
                    report.mismatches,
                    report.errors,
                    started.elapsed().as_secs_f64()
                ));
            }
        }
        chunk += 1;
    }
    report.seconds = started.elapsed().as_secs_f64();
    Ok(report)
}
